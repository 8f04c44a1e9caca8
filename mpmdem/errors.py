"""Exceptions raised by mpmdem, so callers (CLI, case scripts) can tell user errors from bugs."""

from __future__ import annotations

__all__ = ["BlowUpError", "InputError"]


class InputError(ValueError):
    """A parameter given by the user is invalid.

    The message names the parameter, the value that was given and what is allowed. Raised on
    construction of scenes, materials and configs, always before any kernel runs.
    """

    def __init__(self, name: str, value: object, allowed: str):
        self.name = name
        self.value = value
        self.allowed = allowed
        super().__init__(f"{name}={value!r} is invalid: {allowed}")


class BlowUpError(RuntimeError):
    """The simulation became unstable (NaN/inf, energy growth, points leaving the domain).

    ``reason`` is a short keyword ("non-finite", "energy-growth", "left-domain"); the message
    names the likely cause. What was written before the blow-up stays in the output file.
    """

    def __init__(self, reason: str, message: str, time: float):
        self.reason = reason
        self.time = time
        super().__init__(message)
