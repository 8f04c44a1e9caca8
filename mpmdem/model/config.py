"""SolverConfig: the discretisation choices of one run, frozen and validated on construction.

Every field selects a kernel variant that is specialised at build time (see ``mpmdem.kernels``);
nothing here is read per particle at run time.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Literal, get_args

from ..errors import InputError
from ..kernels.constitutive import DENSITY_CONTROLS
from ..kernels.coupling import COUPLING_SCHEMES

__all__ = [
    "COUPLING_SCHEMES",
    "PRECISIONS",
    "SHAPE_FUNCTIONS",
    "STRESS_UPDATES",
    "TRANSFER_SCHEMES",
    "SolverConfig",
    "TransferScheme",
]

#: Shape functions: original MPM (tent), uniform GIMP, contiguous-particle GIMP,
#: quadratic and cubic B-splines ("MPM notes"; MPM-SDEM appendix), and CPDI1 (parallelogram
#: domains following F, "Motion integration" §2.2).
ShapeFunction = Literal["linear", "ugimp", "cpgimp", "bspline2", "bspline3", "cpdi1"]
SHAPE_FUNCTIONS = get_args(ShapeFunction)

#: Where the stress update sits in the step ("Motion integration" §3.4): first (USF), last with
#: the updated grid velocities (USL), last with velocities re-mapped from the updated points
#: (MUSL), or half before and half after the force update (USAVG).
StressUpdate = Literal["USF", "USL", "MUSL", "USAVG"]
STRESS_UPDATES = get_args(StressUpdate)

#: Floating-point precision of every point and grid field.
Precision = Literal["f32", "f64"]
PRECISIONS = get_args(Precision)

#: What happens below a material's critical density (``kernels/constitutive.py``).
DensityControl = Literal[DENSITY_CONTROLS]
#: How a point–body contact force reaches the grid (``kernels/coupling.py``).
CouplingScheme = Literal[COUPLING_SCHEMES]


@dataclass(frozen=True)
class TransferScheme:
    """One member of the PIC/FLIP/affine transfer family ("Motion integration" Table 1).

    Attributes:
        affine: extra term added to the particle velocity in P2G: "none" (eq. 17),
            "apic" (affine matrix C = B D^-1, eq. 23–27) or "taylor" (velocity gradient, eq. 19–22).
        flip_fraction: X in eq. 37; 0 is the PIC velocity update (eq. 31), 1 pure FLIP (eq. 33).
        position: "grid" moves points with the interpolated updated grid velocity (eq. 32);
            "particle" moves them with the new particle velocity (eq. 36/38, the N-variants);
            "xpic" is the second-order update of XPIC(m) (eq. 41).
        xpic: True for XPIC(m): the velocity update of eq. 40 with the order from the config.
    """

    affine: Literal["none", "apic", "taylor"] = "none"
    flip_fraction: float = 0.0
    position: Literal["grid", "particle", "xpic"] = "grid"
    xpic: bool = False


#: Named schemes of "Motion integration" Table 1 that the kernels provide.
#: The FLIP fraction of the X-variants is taken from SolverConfig.flip_fraction.
TRANSFER_SCHEMES: dict[str, TransferScheme] = {
    "PIC": TransferScheme("none", 0.0, "grid"),
    "APIC": TransferScheme("apic", 0.0, "grid"),
    "TPIC": TransferScheme("taylor", 0.0, "grid"),
    "FLIP": TransferScheme("none", 1.0, "grid"),
    "AFLIP": TransferScheme("apic", 1.0, "grid"),
    "TFLIP": TransferScheme("taylor", 1.0, "grid"),
    "NFLIP": TransferScheme("none", 1.0, "particle"),
    "ANFLIP": TransferScheme("apic", 1.0, "particle"),
    "FLIPX": TransferScheme("none", -1.0, "grid"),
    "AFLIPX": TransferScheme("apic", -1.0, "grid"),
    "NFLIPX": TransferScheme("none", -1.0, "particle"),
    "ANFLIPX": TransferScheme("apic", -1.0, "particle"),
    "XPIC": TransferScheme("none", 0.0, "xpic", xpic=True),
}
TransferName = Literal["PIC", "APIC", "TPIC", "FLIP", "AFLIP", "TFLIP", "NFLIP", "ANFLIP", "FLIPX", "AFLIPX", "NFLIPX",
                       "ANFLIPX", "XPIC"]
assert get_args(TransferName) == tuple(TRANSFER_SCHEMES)


def flag(default, help: str, *, positive: bool = False):
    """A field that is also a flag of ``mpmdem run`` (``mpmdem.study.runner.add_config_flags``): its
    ``help`` ({choices}: the values of a Literal field) and, for numbers, whether it must be > 0
    (else >= 0: no number of the config is negative; ``mpmdem.study.flag_types`` checks it as the flags
    are parsed)."""
    return dataclasses.field(default=default, metadata={"flag": {"help": help, "positive": positive}})


@dataclass(frozen=True)
class SolverConfig:
    """Discretisation and time-step choices of one run.

    The fields are grouped by stage (comments in the class body). Fields made with ``flag`` are
    also flags of ``mpmdem run`` (``--flip-fraction`` for ``flip_fraction``; Literal fields take one
    of their values).

    Attributes:
        shape: the shape function of the MPM stage (not a geometric ``Shape``), one of SHAPE_FUNCTIONS.
        transfer: transfer scheme name, one of TRANSFER_SCHEMES ("PIC", "FLIP", "APIC", ...).
        flip_fraction: X of the blended schemes (FLIPX, NFLIPX, ...); 0.99 means 1 % PIC.
        update: stress-update order, one of STRESS_UPDATES.
        precision: "f32" or "f64" for every particle and grid field.
        xpic_order: m of XPIC(m), an integer >= 1 (XPIC(1) is PIC; "Motion integration" eq. 39-41).
        cfl: time-step factor κ in dt = κ h / max_p(c_p + |v_p|), 0 < κ ≤ 1 (default 0.4).
        dt: a fixed time step [s]; None (default) computes dt on the device each step from the
            CFL bound. A fixed dt above the bound is an error.
        damping: Cundall's local damping coefficient D >= 0 ("Motion integration" eq. 61-62);
            0 (default) is no damping.
        allow_unstable: accept cfl up to 10 and a fixed dt above the bound (for stability studies
            such as bench/motion_integration.py; the blow-up detector still stops the run).
        blowup_energy_factor: stop when the total energy exceeds its initial scale by this
            factor (energy growth is the signature of an unstable explicit step).
        cuda_graph: record one step as a CUDA graph on GPUs and replay it.
        sort_interval: re-sorting of the points by grid cell, which keeps the P2G atomics
            coalesced as material flows (the points start in cell order). None (default):
            automatic — ``Simulation.advance_to`` measures how far the memory order has drifted
            after its batches of steps and re-sorts when it passed a threshold
            (``mpmdem.sim.auto_sort``); it runs on CUDA devices only, for scenes of at least
            ``Tuning.auto_sort_min_points`` points without rigid bodies, and is off (silently) elsewhere,
            so CPU runs, small scenes and coupled scenes never re-sort. 0: never re-sort. N > 0:
            re-sort every N steps, in ``advance`` too (not allowed in coupled scenes, whose
            point–body lists follow the memory order).
        deterministic: make GPU runs bit-identical from run to run (ordered float atomics in
            P2G and in the DEM contact sums; slower). CPU runs always are. Needed for bit-for-bit
            checkpoint restarts on GPUs.
        dem_kappa: κ2 of the DEM time step dt = 2π κ2 sqrt(m* / k_n) (sqrt(1 + ζ²) − ζ)
            (MPM-SDEM eq. 51, with m* the smallest rotational effective mass of the free bodies
            and the explicit-dashpot factor, see mpmdem.sim.dem.dem_time_step_bound); the paper's
            0.1 is the default. At most 1/π: above it even one body on one contact is unstable.
        dem_skin: Verlet skin of the DEM neighbour lists [m]; None picks a quarter of the median
            bounding radius of the bodies. Lists are rebuilt when a body has moved (or turned)
            more than half the skin since the last build.
        dem_max_neighbors: neighbour slots per body in the DEM Verlet lists; None picks from the
            size spread of the bodies. A list that overflows stops the run with a message.
        granular: Granular MPM ("Granular MPM" §3.3–3.4): points interact only when their domains
            of interaction (domains scaled to the critical volume) overlap and they share a grid
            node; each connected group of interacting points (component) gets a grid of its own,
            so disconnected grains never feel each other through the grid. Off (default): plain MPM.
        density_control: what happens to a point of a material with a critical density when its
            density falls below it: "revert" (default; σ = 0 and F back to the previous step,
            "Granular MPM" eq. 13–15), "volumetric" (σ = 0 and only the volume change removed,
            eq. 18) or "none" (σ = 0 only: the stress-free MPM the paper compares with).
        granular_layers: grid copies per node in granular mode: the most components that may put
            mass on one node in one step; None picks 4 per point per cell of the densest body,
            at least 8. More stops the run with a message naming this setting.
        coupling: how the contact force between a material point and a rigid body reaches the
            grid (scenes with both; MPM-SDEM §5.4): "imp" (default, the paper's: at the point,
            with its shape function, eq. 47), "grid" (the same force at the grid node nearest
            the contact point, MPM-SDEM Fig. 17b) or "liu" (no contact force: each rigid body is carried by
            a few material points that share the grid's velocity field, Liu et al.'s momentum
            exchange).
        imp_skin: Verlet skin of the point–body lists [m]; None picks h/2. Lists are rebuilt when
            a point or body moved more than half of it since the last build.
        imp_max_bodies: rigid bodies one point may list at once (overflow stops the run).
        imp_cell_capacity: points per grid cell in the binning of the point–body search; None
            picks 4 × the densest seeding, at least 16.
    """

    # -- MPM stage: discretisation
    shape: ShapeFunction = flag("bspline2", "shape function: {choices}")
    transfer: TransferName = flag("APIC", "transfer scheme: {choices}")
    flip_fraction: float = flag(0.99, "FLIP fraction X of blended schemes")
    xpic_order: int = flag(2, "m of XPIC(m) (with --transfer XPIC)", positive=True)
    update: StressUpdate = flag("USL", "stress update: {choices}")
    precision: Precision = flag("f32", "f32 or f64")
    # -- time step (all stages) and run control
    cfl: float = flag(0.4, "CFL factor in (0, 1]", positive=True)
    dt: float | None = flag(None, "fixed time step [s] (default: CFL)", positive=True)
    damping: float = flag(0.0, "Cundall local damping coefficient D >= 0")
    allow_unstable: bool = False
    blowup_energy_factor: float = 2.0
    cuda_graph: bool = True
    sort_interval: int | None = None
    deterministic: bool = False
    # -- DEM stage
    dem_kappa: float = flag(0.1, "κ2 of the DEM time step (MPM-SDEM eq. 51 with rotation and damping, "
                            "see mpmdem.sim.dem)", positive=True)
    dem_skin: float | None = None
    dem_max_neighbors: int | None = None
    # -- Granular MPM
    granular: bool = flag(False, "Granular MPM (domains of interaction, a grid per component); --no-granular: "
                          "plain MPM")
    density_control: DensityControl = flag("revert", "below the critical density: {choices} (revert: Granular MPM "
                                           "eq. 14; volumetric: eq. 18; none: stress-free MPM)")
    granular_layers: int | None = None
    # -- coupling of points and rigid bodies
    coupling: CouplingScheme = flag("imp", "points against rigid bodies: {choices} (imp: MPM-SDEM's identified "
                                    "material points)")
    imp_skin: float | None = None
    imp_max_bodies: int = 4
    imp_cell_capacity: int | None = None

    def __post_init__(self):
        shape = str(self.shape).lower()
        if shape not in SHAPE_FUNCTIONS:
            raise InputError("shape", self.shape, f"one of {', '.join(SHAPE_FUNCTIONS)}")
        object.__setattr__(self, "shape", shape)
        transfer = str(self.transfer).upper()
        if transfer not in TRANSFER_SCHEMES:
            raise InputError("transfer", self.transfer, f"one of {', '.join(TRANSFER_SCHEMES)}")
        object.__setattr__(self, "transfer", transfer)
        update = str(self.update).upper()
        if update not in STRESS_UPDATES:
            raise InputError("update", self.update, f"one of {', '.join(STRESS_UPDATES)}")
        object.__setattr__(self, "update", update)
        if self.precision not in PRECISIONS:
            raise InputError("precision", self.precision, f"one of {', '.join(PRECISIONS)}")
        if not (0.0 <= float(self.flip_fraction) <= 1.0):
            raise InputError("flip_fraction", self.flip_fraction, "a number in [0, 1]")
        if not (0.0 < float(self.cfl) <= (10.0 if self.allow_unstable else 1.0)):
            allowed = "a number in (0, 10] (allow_unstable)" if self.allow_unstable else "a number in (0, 1]"
            raise InputError("cfl", self.cfl, f"{allowed}; 0.5 or less is advised")
        if not (isinstance(self.xpic_order, int) and self.xpic_order >= 1):
            raise InputError("xpic_order", self.xpic_order, "an integer >= 1 (the m of XPIC(m))")
        if self.sort_interval is not None and not (isinstance(self.sort_interval, int) and self.sort_interval >= 0):
            raise InputError("sort_interval", self.sort_interval,
                             "an integer >= 0 (steps between re-sorts; 0: never), or None (default: automatic, "
                             "as the points' order drifts)")
        if not (float(self.damping) >= 0.0):
            raise InputError("damping", self.damping, "Cundall's coefficient D >= 0 (0 = off; 0.1 is typical)")
        if self.dt is not None and not (float(self.dt) > 0.0):
            raise InputError("dt", self.dt, "a positive time step in seconds, or None for the CFL policy")
        if not (float(self.blowup_energy_factor) > 0.0):
            raise InputError("blowup_energy_factor", self.blowup_energy_factor, "a positive number")
        kappa_max = 10.0 / math.pi if self.allow_unstable else 1.0 / math.pi
        if not (0.0 < float(self.dem_kappa) <= kappa_max):
            raise InputError("dem_kappa", self.dem_kappa,
                             f"a number in (0, {kappa_max:.4g}] (MPM-SDEM eq. 51; 0.1 is the paper's value)")
        if self.dem_skin is not None and not (math.isfinite(float(self.dem_skin)) and float(self.dem_skin) > 0.0):
            raise InputError("dem_skin", self.dem_skin, "a Verlet skin > 0 [m], or None for the default")
        if self.dem_max_neighbors is not None and not (
            isinstance(self.dem_max_neighbors, int) and 1 <= self.dem_max_neighbors <= 256
        ):
            raise InputError("dem_max_neighbors", self.dem_max_neighbors, "an integer in 1..256, or None (automatic)")

        if not isinstance(self.granular, bool):
            raise InputError("granular", self.granular, "True or False")
        if self.density_control not in DENSITY_CONTROLS:
            raise InputError("density_control", self.density_control, f"one of {', '.join(DENSITY_CONTROLS)}")
        v = self.granular_layers
        # (each point keeps the layer of each of its stencil nodes in 8 bits, 255 meaning none)
        if v is not None and not (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 254):
            raise InputError("granular_layers", v, "an integer in 1..254, or None (automatic)")
        if self.coupling not in COUPLING_SCHEMES:
            raise InputError("coupling", self.coupling, f"one of {', '.join(COUPLING_SCHEMES)}")
        if self.imp_skin is not None and not (math.isfinite(float(self.imp_skin)) and float(self.imp_skin) > 0.0):
            raise InputError("imp_skin", self.imp_skin, "a Verlet skin > 0 [m], or None for h/2")
        if not (isinstance(self.imp_max_bodies, int) and not isinstance(self.imp_max_bodies, bool)
                and 1 <= self.imp_max_bodies <= 64):
            raise InputError("imp_max_bodies", self.imp_max_bodies, "an integer in 1..64")
        v = self.imp_cell_capacity
        if v is not None and not (isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 1024):
            raise InputError("imp_cell_capacity", v, "an integer in 1..1024, or None (automatic)")
        if self.coupling == "liu" and self.update != "USL":
            raise InputError("update", self.update, "USL with coupling=\"liu\" (the exchange corrects the "
                             "updated nodal velocities of USL)")
        if self.granular and self.coupling != "imp":
            raise InputError("coupling", self.coupling, "\"imp\" in granular mode (the other schemes write to "
                             "nodes a point's component may not own)")
        if self.granular and self.scheme.xpic:
            raise InputError("transfer", self.transfer, "a non-XPIC transfer in granular mode (XPIC's smoothing "
                             "passes are not layered yet)")

    @property
    def scheme(self) -> TransferScheme:
        """The transfer scheme with the FLIP fraction of the blended variants filled in."""
        s = TRANSFER_SCHEMES[self.transfer]
        if s.flip_fraction < 0.0:
            s = dataclasses.replace(s, flip_fraction=float(self.flip_fraction))
        return s

    def replace(self, **changes) -> SolverConfig:
        """A copy with some fields changed (validated again)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        """JSON-serialisable description, stored with every output file."""
        d = dataclasses.asdict(self)
        d["scheme"] = dataclasses.asdict(self.scheme)
        return d
