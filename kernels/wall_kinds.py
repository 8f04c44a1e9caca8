"""The kinds of the domain's sides as the kernels number them (``mpmdem.model.boundaries.Boundary.kind_id``):
shared by the grid update (``grid``) and the wall images (``wall_images``)."""

__all__ = ["BC_FIXED", "BC_FREE", "BC_FRICTION", "BC_SLIP"]

BC_FIXED = 0
BC_SLIP = 1
BC_FRICTION = 2
BC_FREE = 3
