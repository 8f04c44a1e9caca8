"""Exclusive prefix sums of int32 counts on the device, in three levels of tile scans.

Used to turn per-cell point counts into the start of each cell's run in a cell-sorted list (a
compressed-sparse-row layout), inside a CUDA graph: plain kernel launches, no temporary memory.
Level 1 scans tiles of ``SCAN_TILE`` counts and writes each tile's total; level 2 scans those totals
the same way; level 3 scans the level-2 totals in one tile. The exclusive sum up to entry i is then
``prefix1[i] + prefix2[i >> SCAN_BITS] + prefix3[i >> 2 SCAN_BITS]`` (``prefix_sum``): up to
SCAN_TILE³ (about 10⁹) entries. On the CPU, where tile operations run one thread a block, one
thread sums the counts in order instead (``make_serial_scan``: all of it in level 1).
"""

import functools

import warp as wp

from .types import kernel

__all__ = ["PACK_BLOCK", "SCAN_BITS", "SCAN_THREADS", "SCAN_TILE", "block_append", "make_serial_scan",
           "make_tile_scan", "pack_launch", "prefix_sum", "scan_lengths"]

SCAN_BITS = 10
#: Entries per tile of each level.
SCAN_TILE = 1 << SCAN_BITS
#: Threads per block of a tile scan.
SCAN_THREADS = 256
#: Threads per block of the kernels that append to a packed list through ``block_append``.
PACK_BLOCK = 256


def scan_lengths(entries: int) -> tuple[int, int]:
    """(level-1 length, level-2 length) for ``entries`` counts, each a whole number of tiles; the
    level-3 arrays hold one tile. Raises ValueError past SCAN_TILE³ entries."""
    n1 = -(-max(entries, 1) // SCAN_TILE) * SCAN_TILE
    n2 = -(-(n1 // SCAN_TILE) // SCAN_TILE) * SCAN_TILE
    if n2 // SCAN_TILE > SCAN_TILE:
        raise ValueError(f"{entries} entries exceed the {SCAN_TILE ** 3} a three-level scan covers")
    return n1, n2


@functools.cache
def make_tile_scan():
    """Kernel ``tile_scan(values, prefix, totals, gate)``, launched over (tiles, SCAN_THREADS) with
    block_dim SCAN_THREADS: ``prefix`` gets the exclusive prefix sum of ``values`` within each tile
    of SCAN_TILE entries, ``totals[b]`` the sum of tile b, when ``gate[0]`` ≠ 0 (as ``serial_scan``)."""

    @kernel
    def tile_scan(values: wp.array(dtype=wp.int32), prefix: wp.array(dtype=wp.int32),
                  totals: wp.array(dtype=wp.int32), gate: wp.array(dtype=wp.int32)):
        if gate[0] == 0:  # (the same for every thread of the block: the tile operations are skipped whole)
            return
        b, lane = wp.tid()
        tile = wp.tile_load(values, shape=SCAN_TILE, offset=b * SCAN_TILE)
        wp.tile_store(prefix, wp.tile_scan_exclusive(tile), offset=b * SCAN_TILE)
        wp.tile_store(totals, wp.tile_sum(tile), offset=b)

    return tile_scan


@functools.cache
def make_serial_scan():
    """Kernel ``serial_scan(values, prefix, gate)``, one thread (the CPU's scan): ``prefix`` gets the
    exclusive prefix sum of all of ``values`` (levels 2 and 3 stay zero), when ``gate[0]`` ≠ 0 (a
    rebuild flag: outside a CUDA graph the kernels of a skipped rebuild are launched and return)."""

    @kernel
    def serial_scan(values: wp.array(dtype=wp.int32), prefix: wp.array(dtype=wp.int32),
                    gate: wp.array(dtype=wp.int32)):
        if gate[0] == 0:
            return
        total = int(0)
        for i in range(values.shape[0]):
            v = values[i]
            prefix[i] = total
            total = total + v

    return serial_scan


@wp.func
def prefix_sum(prefix1: wp.array(dtype=wp.int32), prefix2: wp.array(dtype=wp.int32),
               prefix3: wp.array(dtype=wp.int32), i: int):
    """Sum of the counts before entry i, from the three levels of ``tile_scan``."""
    return prefix1[i] + prefix2[i >> SCAN_BITS] + prefix3[i >> (2 * SCAN_BITS)]


@wp.func
def block_append(counter: wp.array(dtype=wp.int32), n: int):
    """Where this thread's n entries start in a list packed by ``counter[0]`` (its length so far),
    counter[0] advanced by the block's total: one atomic a block instead of one a thread (a million
    atomics on one address queue in one L2 slice). The block's threads get consecutive ranges, in
    thread order. Every thread of the block must call it (it holds block barriers): launch over a
    whole number of blocks (``pack_launch``), with n = 0 for the threads past the work. On the CPU a
    block is one thread: this is ``atomic_add(counter, 0, n)``."""
    counts = wp.tile(n)
    start = wp.tile_atomic_add(counter, wp.tile_sum(counts))
    return wp.tile_extract(start, 0) + wp.untile(wp.tile_scan_exclusive(counts))


def pack_launch(threads: int, device) -> tuple[int, int | None]:
    """(launch dim, block_dim) of a kernel calling ``block_append`` over ``threads`` threads: on CUDA
    a whole number of PACK_BLOCK blocks, on the CPU the threads themselves (a block is one thread)."""
    if device.is_cuda:
        return -(-threads // PACK_BLOCK) * PACK_BLOCK, PACK_BLOCK
    return threads, None
