"""Registers, spills and stack of a kernel on a CUDA architecture, measured without a GPU.

Warp compiles the kernel's module to PTX with NVRTC (no driver needed), and ``ptxas -v`` assembles
it for ``--arch`` and reports what each thread uses. Occupancy follows from the registers (65536 a
SM on sm_90, blocks of 256 threads): a register cap that spills, or a kernel that holds values
through a loop it does not need there, shows here before any GPU time is spent.

    python bench/kernel_registers.py dem_contact --caps none,128,96,80,64
    python bench/kernel_registers.py imp_forces
    python bench/kernel_registers.py dem_split_search

One JSON line per (kernel, cap): registers, spill_stores and spill_loads [bytes], stack [bytes],
blocks_per_sm (256 threads). Needs ``ptxas`` on the PATH (the CUDA toolkit); the PTX version line
is set to what that ptxas reads. Nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import tempfile
from pathlib import Path

import warp as wp

REGISTERS_PER_SM = 65536
MAX_WARPS_PER_SM = 64
BLOCK = 256


def kernels(name: str, cap: int | None):
    """The kernel ``name`` (built with register cap ``cap``) of the f32 solver."""
    if name == "dem_contact":
        from mpmdem.kernels.dem import make_dem_kernels

        return make_dem_kernels("f32", False).make_contact_forces(cap)
    if name.startswith("dem_split_"):  # dem_split_candidates, dem_split_search, dem_split_assemble
        from mpmdem import Tuning
        from mpmdem.kernels.dem_split import make_split_search

        hits = Tuning().split_hits_per_pair
        return getattr(make_split_search("f32", hits, assemble_registers=cap), name.removeprefix("dem_split_"))
    if name == "imp_forces":
        from mpmdem.kernels.coupling import make_coupling_kernels

        if cap is not None:
            raise SystemExit("imp_forces has no register cap option")
        return make_coupling_kernels("f32").forces
    raise SystemExit(f"unknown kernel {name!r} (dem_contact, dem_split_candidates, dem_split_search, "
                   "dem_split_assemble, imp_forces)")


def ptxas_version() -> str:
    """The newest PTX ISA version the installed ptxas reads ("9.0" for CUDA 13.0)."""
    out = subprocess.run(["ptxas", "--version"], capture_output=True, text=True, check=True).stdout
    m = re.search(r"release (\d+)\.(\d+)", out)
    major, minor = int(m.group(1)), int(m.group(2))
    return f"{major - 4}.{minor}" if major >= 13 else f"8.{minor}"


def measure(kernel, arch: int) -> dict:
    """ptxas's report for the kernel's module on sm_``arch``."""
    with tempfile.TemporaryDirectory() as d:
        wp.compile_aot_module(kernel.module, device=None, arch=arch, module_dir=d, use_ptx=True)
        ptx = next(Path(d).rglob("*.ptx"))
        text = re.sub(r"^\.version \S+", f".version {ptxas_version()}", ptx.read_text().rstrip("\0"), flags=re.M)
        ptx.write_text(text)
        log = subprocess.run(["ptxas", f"-arch=sm_{arch}", "-v", str(ptx), "-o", "/dev/null"],
                             capture_output=True, text=True, check=True).stderr
    regs = int(re.findall(r"Used (\d+) registers", log)[-1])
    stack, stores, loads = map(int, re.findall(r"(\d+) bytes stack frame, (\d+) bytes spill stores, "
                                               r"(\d+) bytes spill loads", log)[-1])
    blocks = min(REGISTERS_PER_SM // (max(regs, 1) * BLOCK), MAX_WARPS_PER_SM * 32 // BLOCK)
    return {"registers": regs, "spill_stores": stores, "spill_loads": loads, "stack": stack,
            "blocks_per_sm": blocks}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("kernel", help="dem_contact or imp_forces")
    p.add_argument("--caps", default="none", help="comma-separated register caps (none: the compiler's choice)")
    p.add_argument("--arch", type=int, default=90)
    args = p.parse_args(argv)
    wp.config.quiet = True
    wp.init()
    for c in args.caps.split(","):
        cap = None if c == "none" else int(c)
        row = {"kernel": args.kernel, "cap": cap, "arch": args.arch, **measure(kernels(args.kernel, cap), args.arch)}
        print(json.dumps(row), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
