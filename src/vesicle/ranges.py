"""The one reader of parameter ranges: ``"START:STOP[:STEP]"``, ``"LOW:HIGH"`` with a number of
points, or a comma list (or a TOML list), each with one explicit meaning.

Three spacings are used by the commands and configs, and each caller names its own:

``"step"``
    ``START:STOP`` with a step (``--step``, or ``START:STOP:STEP``): ``START, START ± STEP, ...,
    STOP`` (STOP always included).  The range may run down (``8:7``: continuation from 8 to 7);
    the step is a size, positive.  ``vesicle branch``, the ``branch`` sweep task.
``"linear"`` and ``"log"``
    ``LOW:HIGH`` with ``points`` values, evenly spaced or log-spaced, ``LOW < HIGH``.
    ``vesicle neutral --chi 0.1:10 --points 13`` (log), ``ellipsoid_map``'s ``psi``/``lams``
    (linear).

Every error says which part of the text is wrong and what was expected, before any work.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

__all__ = ["SPACINGS", "parse_range"]

SPACINGS = ("step", "linear", "log")


def parse_range(
    text: str | float | Sequence[float],
    spacing: str,
    *,
    step: float | None = None,
    points: int | None = None,
    name: str = "values",
    positive: bool = False,
) -> list[float]:
    """The values of ``text`` (a range of the given ``spacing``, a comma list, a number or a
    list of numbers).

    Parameters
    ----------
    text
        ``"1:9"``, ``"1:9:0.5"``, ``"0.1:10"``, ``"1,2,4"``, ``3.0`` or ``[1, 2, 4]``.
    spacing
        ``"step"``, ``"linear"`` or ``"log"`` (module docstring).
    step
        The step of a ``"step"`` range given as ``START:STOP`` (default 1).
    points
        The number of values of a ``"linear"``/``"log"`` range (default 10); only with a range.
    name
        How errors name the option or key (``"--lam"``, ``"[task] chi"``).
    positive
        Whether every value must be > 0 (always so for ``"log"``).

    Raises
    ------
    ValueError
        With a message naming ``name``, the text and what is wrong.
    """
    if spacing not in SPACINGS:
        raise ValueError(f"spacing must be one of {SPACINGS}, got {spacing!r}")
    if isinstance(text, list | tuple):
        values = [_number(x, name, text) for x in text]
        if points is not None:
            raise ValueError(f"{name}: points go with a range LOW:HIGH, not a list")
        return _checked(values, name, text, positive)
    text = str(text).strip()
    if ":" not in text:
        if points is not None and spacing != "step":
            raise ValueError(f"{name}: points go with a range LOW:HIGH, got {text!r}")
        if step is not None and spacing == "step":
            raise ValueError(f"{name}: a step goes with a range START:STOP, not the list {text!r}")
        values = [_number(x, name, text) for x in text.split(",") if x.strip()]
        if not values:
            raise ValueError(f"{name}: no values in {text!r}")
        return _checked(values, name, text, positive)
    parts = [_number(x, name, text) for x in text.split(":")]
    if spacing == "step":
        return _checked(_stepped(parts, step, name, text), name, text, positive)
    if len(parts) != 2:
        raise ValueError(f"{name}: a range is LOW:HIGH (with points), got {text!r}")
    lo, hi = parts
    if not lo < hi:
        raise ValueError(f"{name}: a range LOW:HIGH needs LOW < HIGH, got {text!r}")
    k = 10 if points is None else points
    if isinstance(k, bool) or not isinstance(k, int | np.integer) or k < 2:
        raise ValueError(f"{name}: points must be an integer of at least 2, got {k!r}")
    if spacing == "log":
        if not lo > 0:
            raise ValueError(f"{name}: a log-spaced range needs 0 < LOW, got {text!r}")
        return _checked([float(x) for x in np.geomspace(lo, hi, int(k))], name, text, True)
    return _checked([float(x) for x in np.linspace(lo, hi, int(k))], name, text, positive)


def _number(x, name: str, text) -> float:
    if isinstance(x, bool):
        raise ValueError(f"{name}: {x!r} is not a number (in {text!r})")
    try:
        value = float(x)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: {str(x).strip()!r} is not a number (in {text!r})") from None
    if not math.isfinite(value):
        raise ValueError(f"{name}: values must be finite, got {text!r}")
    return value


def _stepped(parts: list[float], step: float | None, name: str, text: str) -> list[float]:
    if len(parts) == 3:
        if step is not None:
            raise ValueError(f"{name}: {text!r} gives its own step: leave --step out")
        start, stop, step = parts
    elif len(parts) == 2:
        start, stop = parts
        step = 1.0 if step is None else step
    else:
        raise ValueError(f"{name}: a range is START:STOP or START:STOP:STEP, got {text!r}")
    if not (isinstance(step, int | float) and math.isfinite(step) and step > 0):
        raise ValueError(f"{name}: the step must be a positive number (its size; the range runs "
                         f"from START to STOP either way), got {step!r}")  # fmt: skip
    if start == stop:
        raise ValueError(f"{name}: START and STOP are equal in {text!r}: give one value instead")
    sign = 1.0 if stop > start else -1.0
    n = int(np.floor(abs(stop - start) / step + 1e-9))
    values = [start + sign * k * step for k in range(n + 1)]
    if abs(values[-1] - stop) > 1e-9 * max(1.0, abs(stop)):
        values.append(stop)
    return values


def _checked(values: list[float], name: str, text, positive: bool) -> list[float]:
    if positive and any(not x > 0 for x in values):
        raise ValueError(f"{name}: values must be positive, got {text!r}")
    return values
