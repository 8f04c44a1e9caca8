"""The block impact of MPM-SDEM §6: the paper's event times, and how a run's block tracks are read to
compare with them (first touch of the floor, at rest on a face; SI units, angles in degrees). The
`sand-blocks` case and the block-impact studies read their runs with these."""

import numpy as np

__all__ = ["ENSEMBLE_STARTS", "FLAT", "LAND", "REST_FRAMES", "T_PAPER", "T_PAPER_PRINTED", "face_down", "first_time",
           "pose", "readings"]

T_PAPER_PRINTED = {"reach": 2.5, "block2_touch": 4.0, "block1_touch": 4.5}  # s, as printed
T_PAPER = {"reach": 0.25, "block2_touch": 0.40, "block1_touch": 0.45}  # s, at g = 10 m/s² (cases/sand_blocks.py: why)
#: block 1 tumbles: its row is the median of this many perturbed starts (--ensemble-seed 1 … N)
ENSEMBLE_STARTS = 16
LAND = 0.001  # m: a block whose lowest point is this close to the floor touches it (1/18 of its height)
FLAT = 10.0  # deg: a block turned within this of a multiple of 90° lies on a face
REST_FRAMES = 5  # frames (0.05 s, the paper's reading resolution): at rest = on a face on the floor this long


def first_time(times: np.ndarray, flags: np.ndarray) -> float | None:
    """The first time [s] at which ``flags`` holds, or None."""
    k = np.flatnonzero(flags)
    return float(times[k[0]]) if len(k) else None


def face_down(angle_deg: np.ndarray) -> np.ndarray:
    """Whether a block turned by ``angle_deg`` from upright lies on a face (within FLAT of a multiple of 90°)."""
    return np.abs((np.asarray(angle_deg, dtype=float) + 45.0) % 90.0 - 45.0) <= FLAT


def pose(lowest_m: float, angle_deg: float) -> str:
    """A block's pose from its lowest point's height [m] and its turn from upright [deg]: the face it
    lies on ("upright", "on its side", "inverted", or "leaning" between faces) and where ("on the
    floor" within LAND of it, else "raised")."""
    wrapped = (angle_deg + 180.0) % 360.0 - 180.0
    quarter = round(wrapped / 90.0)
    face = "leaning" if abs(wrapped - 90.0 * quarter) > FLAT else \
        {0: "upright", 1: "on its side", -1: "on its side", 2: "inverted", -2: "inverted"}[quarter]
    return f"{face} {'on the floor' if lowest_m <= LAND else 'raised'}"


def readings(times, lowest_m, angle_deg, *, hold: int = REST_FRAMES) -> dict:
    """Both readings of a block's landing from its track (times [s], its lowest point's height [m],
    its turn from upright [deg], one per frame):

    * ``touch``: the first time its lowest point is within LAND of the floor (MPM-SDEM §6's
      "touches the ground");
    * ``rest``: the first time from which it lies on a face on the floor up to the end of the run,
      for at least ``hold`` frames (None if it does not, or not that long);
    * ``pose``: its final pose (``pose()``); ``rest_height_m``: its lowest point at the end.
    """
    times = np.asarray(times, dtype=float)
    lowest = np.asarray(lowest_m, dtype=float)
    on = (lowest <= LAND) & face_down(angle_deg)
    rest = None
    if len(on) and on[-1]:
        off = np.flatnonzero(~on)
        k = off[-1] + 1 if len(off) else 0
        rest = float(times[k]) if len(on) - k >= hold else None
    return {"touch": first_time(times, lowest <= LAND), "rest": rest,
            "pose": pose(float(lowest[-1]), float(np.asarray(angle_deg)[-1])), "rest_height_m": float(lowest[-1])}
