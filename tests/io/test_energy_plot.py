"""energy.png reads: the energies and the works in two panels, every curve of a panel in a colour
of its own, a line style per group of terms, each legend outside its panel (issue 48: 17 curves in
10 colours under their legend)."""

from pathlib import Path

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as pyplot  # noqa: E402

from mpmdem.io.plotting import ENERGY_BLACK, _energy_history  # noqa: E402

#: the energy and work diagnostics of a coupled run (points, bodies, contacts between them)
COUPLED = ("energy_kinetic", "energy_strain", "energy_gravity", "energy_contact", "energy_contact_bodies",
           "energy_contact_points", "energy_total", "work_boundary", "work_damping", "work_plastic",
           "work_inflow", "work_contact_damping", "work_contact_friction", "work_driven", "work_imp_damping",
           "work_imp_friction", "work_numerical")


class _KeepFigures:
    """pyplot for ``_energy_history``, whose close keeps the figure for the test to read."""

    def __init__(self):
        self.figures = []

    def subplots(self, *args, **kwargs):
        return pyplot.subplots(*args, **kwargs)

    def close(self, fig):
        self.figures.append(fig)


def test_energy_plot_groups_colours_styles_and_legends(tmp_path):
    """Verify all 17 terms are drawn, energies above and works below; in each panel no two curves
    share a colour; the styles tell the groups (works of the points solid, of the bodies dashed,
    between them dash-dot); the totals are black; each legend lies right of its axes."""
    times = np.linspace(0.0, 1.0, 60)
    diags = {name: np.sin(times + i) for i, name in enumerate(COUPLED)} | {"momentum_x": times}
    plt = _KeepFigures()
    _energy_history(plt, tmp_path / "energy.png", times, diags, "run.h5")
    assert Path(tmp_path / "energy.png").stat().st_size > 1000
    fig = plt.figures[0]
    top, bottom = fig.axes[:2]
    drawn = {ax: {line.get_label(): line for line in ax.get_lines()} for ax in (top, bottom)}
    assert len(drawn[top]) == 7 and len(drawn[bottom]) == 10
    for ax in (top, bottom):
        colours = [matplotlib.colors.to_hex(line.get_color()) for line in ax.get_lines()]
        assert len(set(colours)) == len(colours), colours
    styles = {label: line.get_linestyle() for ax in (top, bottom) for label, line in drawn[ax].items()}
    assert styles["MPM points: plastic"] == "-" and styles["DEM bodies: contact friction"] == "--"
    assert styles["points on bodies: imp friction"] == "-." and styles["balance residual"] == ":"
    assert styles["contact bodies"] == "-." and styles["kinetic"] == "--"
    blacks = [line for ax in (top, bottom) for line in ax.get_lines() if line.get_color() == "black"]
    assert len(blacks) == len(ENERGY_BLACK)
    fig.canvas.draw()
    for ax in (top, bottom):
        legend = ax.get_legend().get_window_extent()
        assert legend.x0 >= ax.get_window_extent().x1
    pyplot.close(fig)
