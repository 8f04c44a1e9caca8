"""Shape functions: partition of unity, zero gradient sum, linear reproduction, derivatives."""

import numpy as np
import pytest
import warp as wp

from mpmdem.kernels.shape_functions import SUPPORT_NODES, make_weights_1d
from mpmdem.kernels.types import kernel

SHAPES = ["linear", "ugimp", "cpgimp", "bspline2", "bspline3"]
K_MAX = 4


def _evaluate(shape, c, lp, device):
    """Run the 1D weights at coordinates c (grid units) with half-lengths lp."""
    weights = make_weights_1d(shape, "f64")
    K = SUPPORT_NODES[shape]
    T = wp.float64

    @kernel
    def eval_weights(c: wp.array(dtype=T), lp: wp.array(dtype=T), base: wp.array(dtype=int),
                     w: wp.array2d(dtype=T), dw: wp.array2d(dtype=T)):
        p = wp.tid()
        b, wk, dwk = weights(c[p], lp[p])
        base[p] = b
        for k in range(wp.static(K)):
            w[p, k] = wk[k]
            dw[p, k] = dwk[k]

    n = len(c)
    out_b = wp.zeros(n, dtype=int, device=device)
    out_w = wp.zeros((n, K), dtype=T, device=device)
    out_dw = wp.zeros((n, K), dtype=T, device=device)
    wp.launch(eval_weights, n, inputs=[wp.array(c, dtype=T, device=device), wp.array(lp, dtype=T, device=device),
                                       out_b, out_w, out_dw], device=device)
    return out_b.numpy(), out_w.numpy(), out_dw.numpy()


def _sample(shape, rng):
    # Ghost layers put the domain boundary at grid coordinate 3: sample the whole domain
    # [3, 13], points exactly on nodes, and points a hair away from the boundary node.
    c = np.concatenate([rng.uniform(3.0, 13.0, 400), np.arange(3.0, 13.5, 0.5), [3.0 + 1e-9, 13.0 - 1e-9]])
    hi = {"ugimp": 0.5, "cpgimp": 0.999}.get(shape, 0.25)
    lp = rng.uniform(0.05, hi, len(c))
    return c, lp


@pytest.mark.parametrize("shape", SHAPES)
def test_partition_of_unity_and_gradient_sum(shape, device):
    """Verify Σ N_i = 1, Σ ∇N_i = 0 and Σ N_i x_i = x at random points, boundary included."""
    c, lp = _sample(shape, np.random.default_rng(1))
    base, w, dw = _evaluate(shape, c, lp, device)
    nodes = base[:, None] + np.arange(w.shape[1])[None, :]
    # f64 kernels: sums of at most 4 terms of O(1) are exact to a few ulps
    np.testing.assert_allclose(w.sum(1), 1.0, atol=1e-12)
    np.testing.assert_allclose(dw.sum(1), 0.0, atol=1e-12)
    np.testing.assert_allclose((w * nodes).sum(1), c, atol=1e-11)  # linear completeness
    np.testing.assert_allclose((dw * nodes).sum(1), 1.0, atol=1e-11)  # ∇x = 1
    assert (w >= -1e-15).all()


@pytest.mark.parametrize("shape", SHAPES)
def test_gradient_matches_finite_difference(shape, device):
    """Verify dN/dx against a central difference of N away from kinks."""
    rng = np.random.default_rng(2)
    c, lp = _sample(shape, rng)
    c = c[:400]
    lp = lp[:400]
    eps = 1e-6
    b0, w0, dw0 = _evaluate(shape, c, lp, device)
    bp, wp_, _ = _evaluate(shape, c + eps, lp, device)
    bm, wm, _ = _evaluate(shape, c - eps, lp, device)
    same = (bp == b0) & (bm == b0)
    fd = (wp_ - wm) / (2 * eps)
    # the laws are piecewise polynomials: away from the few kink points (where the one-sided
    # slopes differ, |jump| <= 2 for the tent) the central difference error is O(eps^2)
    err = np.abs(fd - dw0)[same]
    assert np.median(err) < 1e-6
    assert (err < 1e-4).mean() > 0.97


def test_cubic_bspline_has_four_node_support(device):
    """Verify the cubic B-spline touches 4 nodes with the textbook weights at a node."""
    base, w, _ = _evaluate("bspline3", np.array([5.0]), np.array([0.0]), device)
    assert base[0] == 4
    np.testing.assert_allclose(w[0], [1 / 6, 2 / 3, 1 / 6, 0.0], atol=1e-14)


def test_ugimp_equals_quadratic_bspline_for_cell_sized_particles(device):
    """Verify uGIMP with lp = h/2 reproduces the quadratic B-spline (MPM-SDEM §2.1, Gao et al.)."""
    c = np.random.default_rng(3).uniform(3, 13, 200)
    bg, wg, _ = _evaluate("ugimp", c, np.full(200, 0.5), device)
    bb, wb, _ = _evaluate("bspline2", c, np.zeros(200), device)
    assert (bg == bb).all()
    np.testing.assert_allclose(wg, wb, atol=1e-12)
