"""The flags of a case whose sand may be DEM grains (``--sand dem``): one definition for the silo,
the column collapse and the block impact (``mpmdem.sim.gated_grains`` settles the grains)."""

from __future__ import annotations

from mpmdem.study.flag_types import count_at_least, positive

SANDS = ("mpm", "dem")
GRAIN_SHAPES = ("disk", "polygon")


def add_grain_arguments(parser, *, what: str, radius: float, radius_note: str) -> None:
    """Add --sand, --grain-radius [m], --grain-shape, --seed and --settle-max [s] to ``parser``;
    ``what`` names the sand ("the sand", "the column"), ``radius_note`` says where the default comes from."""
    parser.add_argument("--sand", default="mpm", choices=SANDS,
                        help=f"{what} as Granular MPM points (mpm, the default) or as free DEM grains (dem)")
    parser.add_argument("--grain-radius", type=positive("m"), default=radius,
                        help=f"--sand dem: mean grain radius [m] (default {radius}: {radius_note})")
    parser.add_argument("--grain-shape", default="disk", choices=GRAIN_SHAPES,
                        help="--sand dem: sphero-disks (default) or rounded random pentagons")
    parser.add_argument("--seed", type=count_at_least(0), default=1,
                        help="--sand dem: seed of the grains' sizes and places")
    parser.add_argument("--settle-max", type=positive("s"), default=None,
                        help="--sand dem: the longest the grains settle behind the gate [s] (default 8 free falls "
                             "through the lattice they start on; they stop earlier once at rest)")


def add_mu_i_set_argument(parser) -> None:
    """Add --mu-i-set: the friction law and ρs of a case's --material mu-i, one of the named sets of
    ``mpmdem.study.references.grain_calibration`` (``mu_i_law``)."""
    from mpmdem.study.references.grain_calibration import GLASS_BEAD_SOLID_FRACTION, MU_I_SETS, MU_I_SOURCE

    parser.add_argument("--mu-i-set", default="glass-beads", choices=tuple(MU_I_SETS),
                        help="mu_s, mu_2, I0 of --material mu-i: glass-beads (Jop et al. 2006, rho_s = rho / "
                             f"{GLASS_BEAD_SOLID_FRACTION}) or dem-disks (our r_p = 1 mm disks' incline flows, "
                             f"{MU_I_SOURCE}; rho_s = their grain density)")
