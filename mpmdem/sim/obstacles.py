"""Obstacles rasterised onto the grid: which nodes of one layer lie in a fixed or slip obstacle,
and the outward normal there (read by the grid update, ``kernels/grid.py``)."""

from __future__ import annotations

import numpy as np
import shapely

from ..model.finished import Model

__all__ = ["solid_nodes"]


def solid_nodes(scene: Model, rows: int, cols: int, ghost_nodes: int) -> tuple[np.ndarray, np.ndarray]:
    """Obstacle nodes of one layer: kind (0 none, 1 fixed, 2 slip) and, for slip nodes, the
    outward normal of the nearest edge of the obstacle (rows, cols, 2). (1, 1) arrays if none.

    Node (i, j) sits at the domain's corner + (i − ghost_nodes, j − ghost_nodes) h.
    """
    if not scene.obstacles:
        return np.zeros((1, 1), np.int32), np.zeros((1, 1, 2))
    h = scene.cell_size
    (x0, y0), _ = scene.domain
    g = ghost_nodes
    ii, jj = np.meshgrid(np.arange(rows), np.arange(cols), indexing="ij")
    xy = np.column_stack([(x0 + (ii - g) * h).ravel(), (y0 + (jj - g) * h).ravel()])
    kind = np.zeros(rows * cols, np.int32)
    normal = np.zeros((rows * cols, 2))
    for obstacle in scene.obstacles:
        shape = obstacle.shape
        if shape.kind == "disk":
            (cx, cy), r = shape._circle()
            d = xy - np.array([cx, cy])
            inside = (d ** 2).sum(axis=1) <= r * r * (1.0 + 1e-12)
            n = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
        else:
            # nodes inside or on the outline; normal of the nearest edge of the (CCW) outline
            inside = shapely.intersects_xy(shape.polygon, xy[:, 0], xy[:, 1])
            ring = np.asarray(shapely.geometry.polygon.orient(shape.polygon, 1.0).exterior.coords)
            a, b = ring[:-1], ring[1:]
            e = b - a
            length = np.linalg.norm(e, axis=1)
            tpar = np.clip(((xy[:, None, :] - a[None]) * e[None]).sum(-1) / (length ** 2)[None], 0.0, 1.0)
            dist = np.linalg.norm(xy[:, None, :] - (a[None] + tpar[..., None] * e[None]), axis=-1)
            nearest = np.argmin(dist, axis=1)
            n = np.column_stack([e[nearest, 1], -e[nearest, 0]]) / length[nearest][:, None]
        kind[inside] = 1 if obstacle.kind == "fixed" else 2
        normal[inside] = n[inside]
    return kind.reshape(rows, cols), normal.reshape(rows, cols, 2)
