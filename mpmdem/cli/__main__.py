"""``python -m mpmdem.cli``: the ``mpmdem`` command."""

import sys

from .commands import main

sys.exit(main())
