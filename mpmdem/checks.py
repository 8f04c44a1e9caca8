"""Checks of user input: each failure is an ``InputError`` naming the parameter and what is allowed.

One rule for what a number is, for every module that takes numbers from the user (shapes,
spheropolygons, bodies and contact laws, materials): a real value that ``float()`` accepts and
that is finite. A bool is not a number here (``True`` would pass as 1.0), nor is a string.

``mpmdem.study.validation`` is something else: the ``mpmdem validate`` command (cases against their
references).
"""

from __future__ import annotations

import math

from .errors import InputError

__all__ = ["at_least", "check_time_step", "eq51_step", "finite", "positive", "within"]


def finite(name: str, value: object, allowed: str = "a finite number") -> float:
    """``value`` as a float; InputError(name, value, allowed) unless it is a finite real number."""
    if isinstance(value, (bool, str, bytes)):
        raise InputError(name, value, allowed)
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(name, value, allowed) from None
    if not math.isfinite(v):
        raise InputError(name, value, allowed)
    return v


def positive(name: str, value: object, allowed: str) -> float:
    """``value`` as a float; InputError(name, value, allowed) unless it is finite and > 0."""
    v = finite(name, value, allowed)
    if v <= 0.0:
        raise InputError(name, value, allowed)
    return v


def at_least(name: str, value: object, low: float, allowed: str) -> float:
    """``value`` as a float; InputError(name, value, allowed) unless it is finite and >= low."""
    v = finite(name, value, allowed)
    if v < low:
        raise InputError(name, value, allowed)
    return v


def within(name: str, value: object, low: float, high: float, allowed: str) -> float:
    """``value`` as a float; InputError(name, value, allowed) unless it is finite and in [low, high]."""
    v = finite(name, value, allowed)
    if not low <= v <= high:
        raise InputError(name, value, allowed)
    return v


def check_time_step(config, bound: float, what: str, *, use: str = "it") -> None:
    """InputError unless a fixed ``config.dt`` is at most the stable step ``bound`` [s] (or the
    config allows unstable steps). ``what`` names the bound and its value in the message, ``use``
    what an unset dt uses instead."""
    if config.dt is not None and config.dt > bound and not config.allow_unstable:
        raise InputError("dt", config.dt, f"at most the stable bound {what}; leave dt unset to use {use}")


def eq51_step(config, bound: float) -> str:
    """The step MPM-SDEM eq. 51 takes under a stable bound [s], for the messages about dt."""
    return f"MPM-SDEM eq. 51 with dem_kappa = {config.dem_kappa:g} gives {math.pi * config.dem_kappa * bound:.6g} s"
