"""`mpmdem run|info|plot` on a bodies-only run (the DEM cases' quick runs and their figures:
tests/cases/test_case_table.py)."""





def test_cli_info_and_plot_of_a_dem_run(tmp_path):
    """`mpmdem run|info|plot` work on a bodies-only run file."""
    import subprocess
    import sys

    from helpers import ENV

    exe = [sys.executable, "-m", "mpmdem.cli"]
    run = subprocess.run(exe + ["run", "domino", "--quick", "--quiet", "--device", "cpu", "--out", str(tmp_path)],
                         capture_output=True, text=True, env=ENV, timeout=600)
    assert run.returncode == 0, run.stderr
    h5 = tmp_path / "domino.h5"
    info = subprocess.run(exe + ["info", str(h5)], capture_output=True, text=True, env=ENV)
    assert info.returncode == 0 and "bodies" in info.stdout
    plot = subprocess.run(exe + ["plot", str(h5), "--out", str(tmp_path / "plots")], capture_output=True, text=True,
                          env=ENV)
    assert plot.returncode == 0, plot.stderr
    pngs = sorted(p.name for p in (tmp_path / "plots").glob("*.png"))
    assert "energy.png" in pngs and any(p.startswith("snapshot_") for p in pngs)
