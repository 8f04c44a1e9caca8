"""Device code of mpmdem (imported as ``mpmdem.kernels``).

Only ``@wp.func`` laws and ``@wp.kernel`` factories live here; nothing imports ``mpmdem``.
Factories are memoised on their variant tuple so each variant compiles once per process, and
each kernel gets its own Warp module (``module="unique"``) so building a new variant never
invalidates the compiled ones.
"""

from .types import scalar_types

__all__ = ["scalar_types"]
