"""Tests of ``mpmdem animate`` (mpmdem.io.animation): GIFs of a made-up run and of a real coupled run,
frame selection, and the one-line errors of the command line."""

from __future__ import annotations

import pytest
from helpers import run_script
from PIL import Image
from test_io import N, write_body_run, write_run

from mpmdem.cli import main
from mpmdem.errors import InputError
from mpmdem.io import animation


def gif_frames(path) -> int:
    """Frames of a GIF, as Pillow reads them."""
    with Image.open(path) as im:
        assert im.format == "GIF"
        return im.n_frames


def test_animate_gif_of_every_frame_and_a_stride(tmp_path):
    """Verify a run of points and bodies gives a GIF of its 5 frames, and of 3 with ::2 or a list."""
    path = tmp_path / "run.h5"
    write_body_run(path, frames=5, particles=N, csv=False)
    out = animation.animate_run(path, tmp_path / "all.gif", field="pressure", fps=4)
    assert out == tmp_path / "all.gif" and gif_frames(out) == 5
    assert gif_frames(animation.animate_run(path, tmp_path / "odd.gif", frames="::2", field="omega")) == 3
    assert gif_frames(animation.animate_run(path, tmp_path / "some.gif", frames="0,-1,2")) == 3


def test_default_output_is_a_gif_without_ffmpeg(tmp_path, monkeypatch):
    """Verify the default output is RUN_FIELD.gif beside the run when no ffmpeg writer is available."""
    from matplotlib import animation as mpl_animation

    monkeypatch.setattr(mpl_animation.writers, "is_available", lambda name: name != "ffmpeg")
    path = tmp_path / "run.h5"
    write_run(path, frames=2, csv=False)
    assert main(["animate", str(path), "--field", "J", "--fps", "2"]) == 0
    assert gif_frames(tmp_path / "run_J.gif") == 2
    with pytest.raises(InputError, match="ffmpeg"):
        animation.animate_run(path, tmp_path / "run.mp4")


def test_parse_frames():
    """Verify slices, lists and negative indices, and errors for a zero step, out-of-range or empty picks."""
    assert animation.parse_frames(None, 4) == [0, 1, 2, 3]
    assert animation.parse_frames("1:", 4) == [1, 2, 3]
    assert animation.parse_frames("::3", 7) == [0, 3, 6]
    assert animation.parse_frames("-1,0", 4) == [3, 0]
    for bad in ("::0", "1:2:3:4", "a", "4", "-5", "3:1"):
        with pytest.raises(InputError, match="frames"):
            animation.parse_frames(bad, 4)


def test_animate_errors_are_one_line_exit_2(tmp_path, capsys):
    """Verify a missing file, a non-HDF5 file, an unknown field or a bad suffix exit with 2 and one line."""
    path = tmp_path / "run.h5"
    write_run(path, frames=1, csv=False)
    (tmp_path / "notes.h5").write_text("not HDF5")
    cases = [
        ([str(tmp_path / "missing.h5")], "existing"),
        ([str(tmp_path / "notes.h5")], "not HDF5"),
        ([str(path), "--field", "colour"], "field='colour'"),
        ([str(path), "--out", str(tmp_path / "a.avi")], ".mp4 or .gif"),
        ([str(path), "--fps", "0"], "fps"),
    ]
    for argv, words in cases:
        assert main(["animate", *argv]) == 2
        err = capsys.readouterr().err.strip()
        assert len(err.splitlines()) == 1 and err.startswith("mpmdem: error:") and words in err, err


def test_animate_a_coupled_case(tmp_path):
    """Verify a real run (disk_drop: an MPM disk onto a fixed spheropolygon) animates to one GIF frame per frame."""
    run_script("disk_drop", tmp_path, "--end-time", "0.003", "--frames", "4")
    out = tmp_path / "drop.gif"
    assert main(["animate", str(tmp_path / "disk_drop.h5"), "--out", str(out)]) == 0
    assert gif_frames(out) == 5
