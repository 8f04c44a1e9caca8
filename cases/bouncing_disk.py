# Bouncing disk: an elastic disk dropped from rest under gravity onto a rigid frictionless floor.
# Seed: "Motion integration" (Duverger et al.), §4.1 (bouncing cube under gravity, eq. 46-48 for
# the energies) and appendix B.1 (bouncing elastic disk); here in 2D plane strain, in SI units.
# Exact elastic answer: the total energy E_k + E_el + E_g is conserved, so every rebound brings
# the mass centroid back to its drop height, less the energy left in the disk's vibrations
# (reported at each apex as the internal energy). §4.1 finds FLIP with USF nearly conservative and
# the PIC family (and USL, appendix A) dissipative, which is what this case measures.
"""Elastic disk dropped onto a frictionless floor; rebound heights and energy per transfer."""

import math
import sys

import numpy as np

from mpmdem import InputError, NeoHookean, Scene, disk
from mpmdem.io import RunFile
from mpmdem.study.case import CaseSetup
from mpmdem.study.flag_types import count_at_least, given, positive

NAME = "bouncing-disk"
DESCRIPTION = "elastic disk dropped under gravity onto a frictionless floor: rebound height and energy"
# FLIP with USF is the energy-conserving pair of "Motion integration" §4.1; f64 keeps the round-off
# of the gravitational energy (m g y summed over points) far below the discretisation effects.
DEFAULTS = {"shape": "bspline2", "transfer": "FLIP", "update": "USF", "precision": "f64"}

RADIUS = 0.1  # m
DROP_HEIGHT = 0.5  # m, centroid above the floor at t = 0
DENSITY = 1000.0  # kg/m³
YOUNGS = 1.0e6  # Pa
POISSON = 0.3
GRAVITY = 9.81  # m/s²
WIDTH = 0.6  # m
HEIGHT = 0.8  # m (grown when a larger drop height needs it)
HEADROOM = 0.2  # m between the top of the disk and the top of the domain at t = 0

# Why these numbers: the impact speed sqrt(2 g (H - R)) = 2.8 m/s is 8 % of the wave speed
# c = sqrt((λ+2μ)/ρ) = 37 m/s, so the impact strain is moderate (Neo-Hookean, no blow-up) while
# the contact lasts ~25 ms (measured, peak floor force ~44 M g) against a 0.57 s flight; the
# disk's own sag, strain ρ g R / E ≈ 1e-3 (~1e-4 m), is negligible. A bounce takes ~0.6 s, and
# dt ≈ 0.4 h / c ≈ 2.7e-4 s at h = 0.025 m: ~2600 steps per bounce.


def add_arguments(parser):
    parser.add_argument("--cells", type=count_at_least(4), default=None,
                        help="cells across the 0.6 m width (default 48; 24 with --quick)")
    parser.add_argument("--drop-height", type=positive("m"), default=None,
                        help=f"height of the disk centre above the floor at t = 0 [m] (default {DROP_HEIGHT})")


def build(args) -> CaseSetup:
    cells = given(args.cells, 24 if args.quick else 48)
    if cells < 4:
        raise InputError("cells", cells, "an integer >= 4 (cells across the 0.6 m width)")
    drop = given(args.drop_height, DROP_HEIGHT)
    h = WIDTH / cells
    if not (math.isfinite(drop) and drop >= RADIUS + 2 * h):
        raise InputError("drop_height", drop, f"a centre height >= R + 2 cells = {RADIUS + 2 * h:g} m")
    height = max(HEIGHT, drop + RADIUS + HEADROOM)
    scene = Scene(domain=((0.0, 0.0), (WIDTH, height)), cell_size=h, gravity=(0.0, -GRAVITY),
                  boundaries=dict.fromkeys(("left", "right", "bottom", "top"), "slip"))
    scene.add_mpm_body(disk(center=(0.5 * WIDTH, drop), radius=RADIUS), NeoHookean(YOUNGS, POISSON, DENSITY),
                   points_per_cell=2, name="disk")
    # free fall time sqrt(2 (H - R) / g) = 0.29 s; a full bounce ~0.6 s. Quick: the first rebound
    # apex (~0.58 s); default: two rebounds. Frames dense enough to catch each apex to ~1e-4 m.
    fall = math.sqrt(2.0 * (drop - RADIUS) / GRAVITY)
    if args.quick:
        return CaseSetup(scene, end_time=round(2.5 * fall, 3), frames=100)
    return CaseSetup(scene, end_time=round(4.3 * fall, 3), frames=200)


def centroid_heights(path) -> np.ndarray:
    """Height of the mass centroid at every frame of a run file [m]."""
    with RunFile(path) as run:
        ys = []
        for k in range(run.frame_count):
            m = np.asarray(run.field("mass", k), dtype=np.float64)
            y = np.asarray(run.field("x", k), dtype=np.float64)[:, 1]
            ys.append(float(np.sum(m * y) / np.sum(m)))
    return np.array(ys)


def rebounds(t, y, py, mass, g=GRAVITY):
    """Floor contacts and rebound apexes from the centroid height y and vertical momentum py.

    Contact: a frame interval over which the floor pushed on average with more than half the
    disk's weight, (Δp_y/Δt + M g) > M g / 2 (in free flight the momentum changes by exactly
    −M g Δt; the total momentum is unaffected by the disk's internal vibration). A rebound apex
    is the highest centroid position between the end of one contact and the start of the next,
    refined by the parabola through the three frames around it (the centroid of a body in free
    flight moves on a parabola); a flight still rising at the end of the run has no apex yet.

    Returns (contact start times, apex times, apex heights, highest height after the first
    impact's lowest point up to the second contact or the end).
    """
    dt = np.diff(t)
    force = np.diff(py) / dt + mass * g  # mean floor force over each frame interval [N/m]
    contact = force > 0.5 * mass * g
    runs = []  # (first interval, last interval) of each contact
    k = 0
    while k < len(contact):
        if contact[k]:
            j = k
            while j + 1 < len(contact) and contact[j + 1]:
                j += 1
            runs.append((k, j))
            k = j + 1
        else:
            k += 1
    apex_t, apex_y = [], []
    for i, (_, b) in enumerate(runs):
        lo = b + 1  # first frame after the contact
        hi = runs[i + 1][0] if i + 1 < len(runs) else len(y) - 1  # last frame before the next one
        if hi - lo < 2:
            continue
        k = lo + int(np.argmax(y[lo:hi + 1]))
        if not lo < k < hi:
            continue  # still rising at the end of the run (or no apex inside the flight)
        c2, c1, c0 = np.polyfit(t[k - 1:k + 2] - t[k], y[k - 1:k + 2], 2)
        tk = -c1 / (2.0 * c2) if c2 < 0.0 else 0.0
        apex_t.append(float(t[k] + tk))
        apex_y.append(float(c0 + c1 * tk + c2 * tk * tk) if c2 < 0.0 else float(y[k]))
    first_high = float("nan")
    if runs:
        a = runs[0][0]
        end = runs[1][0] if len(runs) > 1 else len(y) - 1
        low = a + int(np.argmin(y[a:end + 1]))
        first_high = float(y[low:end + 1].max())
        if apex_y and apex_t[0] < t[end]:
            first_high = max(first_high, apex_y[0])
    contact_t = [float(t[a]) for a, _ in runs]
    return contact_t, apex_t, apex_y, first_high


def summarize(sim, result, args) -> dict:
    if result.path is None:
        raise InputError("out", None, "an output folder: the centroid history is read from the run file")
    d = result.diagnostics
    t = result.times
    y = centroid_heights(result.path)
    drop = float(y[0])
    mass = float(d["mass"][0])
    contact_t, apex_t, apex_y, first_high = rebounds(t, y, d["momentum_y"], mass)
    fall = drop - RADIUS
    e0 = float(d["energy_total"][0])
    # Rebound ratio: height of the centroid above its rest-on-floor height R (the disk's sag
    # ρ g R / E ~ 1e-4 m is neglected) at the first rebound apex, over the same at the drop;
    # exactly 1 for an elastic disk. Without a rebound, the highest the centroid rose after
    # the first impact's lowest point (≈ 0 for a disk that stays on the floor).
    first = apex_y[0] if apex_y else first_high
    # Energy left inside the disk (kinetic energy about the centroid + stored energy): real
    # vibrations after the impact plus transfer noise; at an apex it is what the centroid's
    # height does not account for of the total energy.
    internal = (d["energy_kinetic"] - (d["momentum_x"] ** 2 + d["momentum_y"] ** 2) / (2.0 * mass)
                + d["energy_strain"]) / e0
    at_apex = [float(internal[np.argmin(np.abs(t - ta))]) for ta in apex_t]
    return {
        "cells": round(WIDTH / sim.scene.cell_size),
        "radius": RADIUS,
        "drop_height": drop,
        "impact_speed_exact": math.sqrt(2.0 * GRAVITY * fall),
        "first_contact_time_exact": math.sqrt(2.0 * fall / GRAVITY),
        "contact_times": contact_t,
        "rebound_apex_times": apex_t,
        "rebound_apex_heights": apex_y,
        "rebound_ratios": [(a - RADIUS) / fall for a in apex_y],
        "rebound_ratio_first": float((first - RADIUS) / fall),
        "internal_energy_at_apexes_over_initial": at_apex,
        "energy_total_final_over_initial": float(d["energy_total"][-1] / e0),
        "energy_min_over_initial": float(d["energy_total"].min() / e0),
        "energy_max_over_initial": float(d["energy_total"].max() / e0),
        "centroid_height_final": float(y[-1]),
    }


if __name__ == "__main__":
    from mpmdem.study.runner import run_case

    sys.exit(run_case(sys.modules[__name__], prog="python cases/bouncing_disk.py"))
