"""Arguments checked before anything is sent: a ValueError that names the
argument, at once, instead of a wait that never ends (a NaN timeout), an
OverflowError from the standard library (an infinite one) or a message
jeepney cannot pack (an index past 0xFFFF looked like a lost connection)."""

from __future__ import annotations

import math
from typing import Any, Optional

#: D-Bus integer types: (lowest, highest)
_RANGES = {
    "y": (0, 0xFF),
    "q": (0, 0xFFFF),
    "u": (0, 0xFFFF_FFFF),
    "x": (-(1 << 63), (1 << 63) - 1),
    "t": (0, (1 << 64) - 1),
}


def _number(name: str, value: Any) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValueError(f"{name} must be a number, got {value!r}")
    return float(value)


def seconds(name: str, value: Any) -> float:
    """A duration: finite and >= 0 (NaN compares false with everything, so a
    wait for it never ends; inf overflows threading's timeouts)."""
    v = _number(name, value)
    if not math.isfinite(v) or v < 0:
        raise ValueError(f"{name} must be a finite number of seconds >= 0, got {value!r}")
    return v


def optional_seconds(name: str, value: Optional[Any]) -> Optional[float]:
    """A duration, or None (no bound)."""
    return None if value is None else seconds(name, value)


def finite(name: str, value: Any) -> float:
    """A value of a physical quantity: finite."""
    v = _number(name, value)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {value!r}")
    return v


def integer(name: str, value: Any, dbus_type: str) -> int:
    """An integer that fits the D-Bus type ``dbus_type`` (y, q, u, x, t)."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ValueError(f"{name} must be an integer, got {value!r}")
    lo, hi = _RANGES[dbus_type]
    if not lo <= value <= hi:
        raise ValueError(f"{name} must be within {lo:#x}..{hi:#x}, got {value:#x}"
                         if lo >= 0 else f"{name} must be within {lo}..{hi}, got {value}")
    return value
