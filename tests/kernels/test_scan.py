"""The three-level tile scan (kernels/scan.py) that turns cell counts into run starts."""

import numpy as np
import pytest
import warp as wp

from mpmdem.kernels import scan as kscan


@wp.kernel
def _gather_prefix(prefix1: wp.array(dtype=wp.int32), prefix2: wp.array(dtype=wp.int32),
                   prefix3: wp.array(dtype=wp.int32), at: wp.array(dtype=wp.int32), out: wp.array(dtype=wp.int32)):
    k = wp.tid()
    out[k] = kscan.prefix_sum(prefix1, prefix2, prefix3, at[k])


def _scan(counts: np.ndarray, device: str) -> tuple[wp.array, wp.array, wp.array]:
    n1, n2 = kscan.scan_lengths(len(counts))
    values = np.zeros(n1, np.int32)
    values[: len(counts)] = counts
    values = wp.array(values, dtype=wp.int32, device=device)
    prefixes = [wp.zeros(n, dtype=wp.int32, device=device) for n in (n1, n2, kscan.SCAN_TILE)]
    totals = [wp.zeros(n, dtype=wp.int32, device=device) for n in (n2, kscan.SCAN_TILE, 1)]
    inputs = [values, totals[0], totals[1]]
    gate = wp.ones(1, dtype=wp.int32, device=device)
    for level in range(3):
        tiles = inputs[level].shape[0] // kscan.SCAN_TILE
        wp.launch(kscan.make_tile_scan(), (tiles, kscan.SCAN_THREADS),
                  inputs=[inputs[level], prefixes[level], totals[level], gate], block_dim=kscan.SCAN_THREADS,
                  device=device)
    return prefixes


@pytest.mark.parametrize("entries", [1, 3000, kscan.SCAN_TILE**2 + 4321])
def test_prefix_sum_is_the_exclusive_cumulative_sum(entries, device):
    """Every level is needed past SCAN_TILE² entries: the sum must match numpy's exactly there too."""
    rng = np.random.default_rng(entries)
    counts = rng.integers(0, 5, entries).astype(np.int32)
    prefixes = _scan(counts, device)
    at = np.unique(np.concatenate([[0, entries - 1, entries], rng.integers(0, entries + 1, 2000)])).astype(np.int32)
    out = wp.zeros(len(at), dtype=wp.int32, device=device)
    wp.launch(_gather_prefix, len(at), inputs=[*prefixes, wp.array(at, dtype=wp.int32, device=device), out],
              device=device)
    expected = np.concatenate([[0], np.cumsum(counts)])[at]
    np.testing.assert_array_equal(out.numpy(), expected)


def test_scan_lengths_are_whole_tiles_and_refuse_too_many():
    n1, n2 = kscan.scan_lengths(kscan.SCAN_TILE + 1)
    assert (n1, n2) == (2 * kscan.SCAN_TILE, kscan.SCAN_TILE)
    with pytest.raises(ValueError, match="entries"):
        kscan.scan_lengths(kscan.SCAN_TILE**3 + 1)


def test_serial_scan_matches_and_respects_its_gate():
    """The CPU's one-thread scan: the same exclusive sums, written only when the gate is open."""
    counts = np.random.default_rng(7).integers(0, 5, 5000).astype(np.int32)
    values = wp.array(counts, dtype=wp.int32, device="cpu")
    prefix = wp.full(len(counts), -7, dtype=wp.int32, device="cpu")
    closed = wp.zeros(1, dtype=wp.int32, device="cpu")
    wp.launch(kscan.make_serial_scan(), 1, inputs=[values, prefix, closed], device="cpu")
    assert (prefix.numpy() == -7).all()
    wp.launch(kscan.make_serial_scan(), 1, inputs=[values, prefix, wp.ones(1, dtype=wp.int32, device="cpu")],
              device="cpu")
    np.testing.assert_array_equal(prefix.numpy(), np.cumsum(counts) - counts)
