"""MPM-SDEM Table 3 (the granular-flow runs of §5.3 and §6), in the paper's units, converted once.

The paper works in 2D and mixes cm, g, N and kPa. Densities in g/cm² and stiffnesses in N/cm are
read as a slice one metre thick (docs/concepts/units.md): 1.5 g/cm² → 1500 kg/m³, 6.0e6 N/cm → 6.0e8 N/m
per m. Gravity: Table 3 prints 10.0 cm/s², §6 says g = 10 m/s²; both runs here use 10 m/s², the
gravity of the experiments (cases/sand_blocks.py gives the argument from the paper's own times).
"""

from ...model.granular_materials import DruckerPrager

CM = 1.0e-2  # m
KN_TABLE = 6.0e6 / CM  # 6.0e6 N/cm → N/m per m
KT_TABLE = 3.0e5 / CM  # 3.0e5 N/cm → N/m per m
MU_TABLE = 0.2  # Coulomb μ of the DEM contacts
DT_TABLE = 2.0e-4  # s
VERLET = 0.2 * CM  # V_d
SPHERO_RADIUS = 0.5 * CM  # r_d
GRID_TABLE = 0.35 * CM  # dg
R_P_TABLE = 0.1 * CM  # r_p
K_BULK = 5.0e2 * 1.0e3  # 5.0e2 kPa → Pa
G_SHEAR = 3.2e2 * 1.0e3  # 3.2e2 kPa → Pa
NU_TABLE = 0.2358
DENSITY = 1.5e-3 / CM**3  # 1.5 g/cm² read as 1.5 g/cm³ = 1500 kg/m³ over 1 m of thickness
FRICTION_ANGLE = 35.0  # deg
DILATANCY_ANGLE = 25.0  # deg
TENSILE_STRENGTH = 0.0  # Pa
GRAVITY_TABLE = 10.0 * CM  # 10.0 cm/s² as printed → 0.1 m/s² (not used, see above)
GRAVITY = 10.0  # m/s², the experiments' gravity (§6: "g = 10 m/s")

YOUNGS = 9.0 * K_BULK * G_SHEAR / (3.0 * K_BULK + G_SHEAR)  # 3D relations (plane strain), 791 kPa
POISSON = (3.0 * K_BULK - 2.0 * G_SHEAR) / (2.0 * (3.0 * K_BULK + G_SHEAR))  # 0.2363 (Table 3: 0.2358)
#: points looser than this fraction of the initial density turn stress-free (Granular MPM eq. 13)
CRITICAL_DENSITY_RATIO = 0.99


def sand(friction_angle: float = FRICTION_ANGLE, dilatancy_angle: float = DILATANCY_ANGLE,
         critical_ratio: float | None = CRITICAL_DENSITY_RATIO) -> DruckerPrager:
    """Table 3's dry sand: Drucker–Prager matched to Mohr–Coulomb in plane strain (MPM-SDEM eq. 35),
    no cohesion, no tension; Granular MPM's critical density at ``critical_ratio`` × ρ (None: original
    MPM, a continuum at any density)."""
    return DruckerPrager(YOUNGS, POISSON, DENSITY, friction_angle, dilatancy_angle, TENSILE_STRENGTH,
                         critical_density=critical_ratio * DENSITY if critical_ratio else None)
