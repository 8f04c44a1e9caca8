"""argparse types of the command line's numeric flags (``mpmdem run CASE``, the config flags, the
study and plotting commands).

Each type refuses what its flag cannot mean — 0 where 0 is not a value, a negative number, NaN,
inf, a word — while the flags are parsed, so the parser prints one line and exits with code 2
before any scene is built or any kernel runs. The message names the flag (argparse adds it) and
what is allowed, as ``mpmdem.errors.InputError`` does: ``argument --cell-size: 0 is invalid: a
finite number > 0 [m]``. A number is a finite real, as for ``mpmdem.checks.finite``.

Narrower ranges that depend on the case (an angle below 80°, an orifice narrower than the silo)
stay with the case's ``build``, which raises ``InputError`` before anything runs.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable

__all__ = ["choice", "count_at_least", "given", "interval", "non_negative", "nonzero", "positive", "real"]


def given(value, default):
    """A flag's value, or ``default`` when the flag was not given (None). 0 is a value: a flag whose
    default is None never reads 0 as "not given" (``x or default`` would)."""
    return default if value is None else value


def _units(unit: str) -> str:
    return f" [{unit}]" if unit else ""


def real(allowed: str, ok: Callable[[float], bool] = lambda v: True) -> Callable[[str], float]:
    """An argparse type: the text as a finite float for which ``ok(value)`` holds, else an
    ArgumentTypeError "TEXT is invalid: ALLOWED" (argparse prints it in one line, exit code 2)."""

    def parse(text: str) -> float:
        try:
            v = float(text)
        except ValueError:
            v = math.nan
        if not (math.isfinite(v) and ok(v)):
            raise argparse.ArgumentTypeError(f"{text} is invalid: {allowed}")
        return v

    return parse


def positive(unit: str = "") -> Callable[[str], float]:
    """A finite number > 0 [unit] (a length, a time, a stiffness, a speed)."""
    return real(f"a finite number > 0{_units(unit)}", lambda v: v > 0.0)


def non_negative(unit: str = "") -> Callable[[str], float]:
    """A finite number >= 0 [unit] (a coefficient for which 0 means none)."""
    return real(f"a finite number >= 0{_units(unit)}", lambda v: v >= 0.0)


def nonzero(unit: str = "") -> Callable[[str], float]:
    """A finite number other than 0, of either sign (a spin, a signed speed)."""
    return real(f"a finite number other than 0{_units(unit)}", lambda v: v != 0.0)


def interval(low: float, high: float, *, open_low: bool = False, open_high: bool = False,
             unit: str = "") -> Callable[[str], float]:
    """A finite number in [low, high] [unit]; ``open_low``/``open_high`` leave an end out."""
    text = f"a number in {'(' if open_low else '['}{low:g}, {high:g}{')' if open_high else ']'}{_units(unit)}"
    return real(text, lambda v: (v > low if open_low else v >= low) and (v < high if open_high else v <= high))


def count_at_least(least: int) -> Callable[[str], int]:
    """An integer >= least (a count, a seed, an index)."""

    def parse(text: str) -> int:
        try:
            n = int(text)
        except ValueError:
            n = least - 1
        if n < least:
            raise argparse.ArgumentTypeError(f"{text} is invalid: an integer >= {least}")
        return n

    return parse


def choice(name: str, allowed: tuple[str, ...]) -> Callable[[str], str]:
    """One of ``allowed``, in any case ("apic" is "APIC"); else "unknown NAME 'x'; allowed: ..."."""
    lower = {a.lower(): a for a in allowed}

    def parse(text: str) -> str:
        if text.lower() not in lower:
            raise argparse.ArgumentTypeError(f"unknown {name} {text!r}; allowed: {', '.join(allowed)}")
        return lower[text.lower()]

    return parse
