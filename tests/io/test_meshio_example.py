"""The meshio example of docs/guide/output.md runs as printed on a run's sidecar, and meshio.read,
which the page says not to use, indeed does not read it (no Warp: FrameWriter's made-up run)."""

import re

import pytest
from helpers import ROOT
from test_io import make_fields, write_run

meshio = pytest.importorskip("meshio")

PAGE = ROOT / "docs" / "guide" / "output.md"


def test_docs_meshio_example_reads_the_last_frame(tmp_path, monkeypatch):
    """Verify the page's Python block, run in a folder with RUN.xdmf, gives the points of the first
    frame and the last frame's time and fields."""
    (code,) = [c for c in re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), re.S)
               if "TimeSeriesReader" in c]
    write_run(tmp_path / "RUN.h5", frames=3)
    monkeypatch.chdir(tmp_path)
    scope = {}
    exec(code, scope)
    assert scope["points"].shape == (len(make_fields(0)["x"]), 3)
    assert scope["t"] == pytest.approx(0.2)
    assert {"x", "v", "stress"} <= set(scope["point_data"])


def test_meshio_read_does_not_read_a_sidecar(tmp_path):
    """Verify the page's warning: meshio.read refuses the time series, and ends the process (exit 1)."""
    write_run(tmp_path / "RUN.h5", frames=2)
    with pytest.raises(SystemExit) as stop:
        meshio.read(tmp_path / "RUN.xdmf")
    assert stop.value.code == 1
