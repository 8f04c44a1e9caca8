"""Warp structs that bundle the particle and grid arrays of one precision for kernel launches."""

import functools

import warp as wp

from .types import scalar_types

__all__ = ["make_state_structs"]


@functools.cache
def make_state_structs(precision: str):
    """(Particles, Grid, Domain) structs for one precision."""
    t = scalar_types(precision)

    @wp.struct
    class Particles:
        x: wp.array(dtype=t.vec2)  # position [m]
        v: wp.array(dtype=t.vec2)  # velocity [m/s]
        C: wp.array(dtype=t.mat22)  # affine velocity matrix / velocity gradient [1/s]
        F: wp.array(dtype=t.mat22)  # deformation gradient
        stress: wp.array(dtype=t.mat22)  # in-plane Cauchy stress [Pa]
        szz: wp.array(dtype=t.scalar)  # out-of-plane stress σ_zz [Pa] (plastic laws; plane strain)
        mass: wp.array(dtype=t.scalar)  # [kg/m] (per unit thickness)
        vol: wp.array(dtype=t.scalar)  # current volume [m²]
        vol0: wp.array(dtype=t.scalar)  # initial volume [m²]
        half0: wp.array(dtype=t.vec2)  # initial GIMP half-lengths [m]
        material: wp.array(dtype=wp.int32)  # index into the material table
        strain_energy: wp.array(dtype=t.scalar)  # stored elastic energy [J/m]
        tmp: wp.array(dtype=t.vec2)  # XPIC scratch (G v*_k, then the displacement) [m/s or m]
        pid: wp.array(dtype=wp.int32)  # index of the point in the scene's order (outputs use it)
        comp: wp.array(dtype=wp.int32)  # granular mode: component label (its root point) this step
        slots: wp.array2d(dtype=wp.int32)  # granular mode: grid layer of each stencil node this step, 8 bits each
        release: wp.array(dtype=wp.float64)  # time a point enters the scene [s] (staged scenes only)
        fcont: wp.array(dtype=t.vec2)  # contact force from rigid bodies this step [N/m] (coupled scenes)

    @wp.struct
    class Grid:
        mass: wp.array2d(dtype=t.scalar)  # nodal mass [kg/m]
        mom: wp.array2d(dtype=t.vec2)  # nodal momentum (with impulse when fused) [kg/s]
        force: wp.array2d(dtype=t.vec2)  # nodal internal force [N/m]
        v: wp.array2d(dtype=t.vec2)  # nodal velocity at the start of the step [m/s]
        vt: wp.array2d(dtype=t.vec2)  # nodal velocity after the force update, Ṽ [m/s]
        vm: wp.array2d(dtype=t.vec2)  # MUSL: velocity re-mapped from the updated points [m/s]
        vs: wp.array2d(dtype=t.vec2)  # XPIC: Σ_k (−1)^{k+1} C(m,k) v*_k [m/s]
        vk: wp.array2d(dtype=t.vec2)  # XPIC: v*_k = (P_m G)^{k−1} P_m V [m/s]
        pk: wp.array2d(dtype=t.vec2)  # XPIC: momentum accumulator of the next v*_k [kg m/s]
        owner: wp.array2d(dtype=wp.int32)  # granular mode: component using each layer of a node (−1: free)
        depth: wp.array2d(dtype=wp.int32)  # granular mode: copies in use at the busiest node of each run of nodes
        solid: wp.array2d(dtype=wp.int32)  # nodes of one layer in an obstacle: 0 none, 1 fixed, 2 slip
        solid_normal: wp.array2d(dtype=t.vec2)  # outward normal of the obstacle's surface at slip nodes

    @wp.struct
    class Domain:
        origin: t.vec2  # position of grid node (0, 0), a ghost node [m]
        h: t.scalar  # cell size [m]
        inv_h: t.scalar
        lo: t.vec2  # domain box [m]
        hi: t.vec2
        node_lo: wp.vec2i  # first and last node index on the domain boundary
        node_hi: wp.vec2i
        bc_kind: wp.vec4i  # left, right, bottom, top: 0 fixed, 1 slip, 2 friction, 3 free
        bc_mu: t.vec4  # Coulomb coefficient of friction walls
        bc_speed: t.vec4  # tangential speed of fixed walls [m/s]: along +y (left, right), +x (bottom, top)
        gravity: t.vec2  # [m/s²]
        gravity_ramp: wp.float64  # gravity grows linearly from 0 over this time [s] (0 = at once)
        mass_eps: t.scalar  # nodes lighter than this carry no velocity [kg/m]
        damping: t.scalar  # Cundall's local damping coefficient D
        layer_rows: int  # rows of one grid layer; layer s of node (i, j) is row s·layer_rows + i
        layers: int  # grid layers per node (1 unless granular mode)
        tile_rows: int  # node rows of one tile: the x walls repeat every tile (kernels/tiles.py; layer_rows: one tile)

    return Particles, Grid, Domain
