"""Checks of user input: each raises ValueError naming the parameter and the value."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np


def choice(name: str, value: Any, options: Iterable[str]) -> str:
    """``value`` if it is one of ``options``."""
    options = tuple(options)
    if not isinstance(value, str) or value not in options:
        raise ValueError(f"unknown {name} {value!r}; use one of {', '.join(options)}")
    return value


def integer(name: str, value: Any, lo: int | None = None, hi: int | None = None) -> int:
    """``value`` as an int, if it is a whole number (not a bool) in ``[lo, hi]``."""
    ok = isinstance(value, (int, np.integer, float, np.floating)) and not isinstance(value, bool)
    if ok:
        ok = math.isfinite(value) and int(value) == value
    if ok:
        ok = (lo is None or value >= lo) and (hi is None or value <= hi)
    if not ok:
        if lo is not None and hi is not None:
            what = f"an integer in [{lo}, {hi}]"
        elif lo == 1:
            what = "a positive integer"
        elif lo is not None:
            what = f"an integer of at least {lo}"
        elif hi is not None:
            what = f"an integer of at most {hi}"
        else:
            what = "an integer"
        raise ValueError(f"{name} must be {what}, got {value!r}")
    return int(value)


def positive(name: str, value: Any, unit: str = "") -> float:
    """``value`` as a float, if it is finite and positive."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = math.nan
    if isinstance(value, bool) or not math.isfinite(v) or v <= 0:
        raise ValueError(f"{name} must be a positive number{unit}, got {value!r}")
    return v


def sphere(bounding_sphere: Any) -> tuple[np.ndarray, float]:
    """``(centre (3,), radius)`` of a bounding sphere given as a pair."""
    try:
        centre, radius = bounding_sphere
    except (TypeError, ValueError):
        raise ValueError("bounding_sphere must be a pair (centre, radius)") from None
    try:
        c = np.asarray(centre, dtype=float)
    except (TypeError, ValueError):
        c = np.full(0, np.nan)
    if c.shape != (3,) or not np.all(np.isfinite(c)):
        raise ValueError(f"bounding sphere centre must be 3 finite numbers, got {centre!r}")
    try:
        r = float(radius)
    except (TypeError, ValueError):
        raise ValueError(f"bounding sphere radius must be a number, got {radius!r}") from None
    if not np.isfinite(r) or r <= 0:
        raise ValueError(f"bounding sphere radius must be positive and finite, got {radius!r}")
    problem = scale_problem(c, r)
    if problem:
        raise ValueError(problem)
    return c, r


#: Bounding radii rdmesh meshes at: lengths are squared and multiplied (the
#: Delaunay core's predicates, areas, distances), and outside this range
#: they underflow or overflow (measured: a cube meshes from 1e-13 to 1e50).
RADIUS_RANGE = (1e-10, 1e40)
#: A bounding sphere's centre at most this many radii from the origin: a
#: double's last digit there (2.2e-16 of the distance) stays 45 times below
#: the spacing floor (1e-6 R). A cube 1e12 radii out kept 4 digits of its size.
MAX_OFFSET = 1e8


def scale_problem(centre: np.ndarray, radius: float) -> str:
    """Why a surface in the bounding sphere ``(centre, radius)`` cannot be
    meshed as it stands (too small, too large or too far from the origin), or
    ``""``."""
    lo, hi = RADIUS_RANGE
    if not lo <= radius <= hi:
        return (
            f"the bounding radius {radius:.3g} is outside [{lo:g}, {hi:g}]: scale the "
            "coordinates into that range (lengths are squared and multiplied while "
            "meshing and would underflow or overflow)"
        )
    far = float(np.max(np.abs(centre)))
    if far > MAX_OFFSET * radius:
        return (
            f"the surface lies {far / radius:.3g} bounding radii from the origin (at most "
            f"{MAX_OFFSET:g}): coordinates that far carry too few digits for its size; "
            f"translate it towards the origin (subtract its centre "
            f"{np.round(centre, 3).tolist()})"
        )
    return ""


def box_in_sphere(box: Any, centre: np.ndarray, radius: float, name: str) -> np.ndarray:
    """``box`` as a new ``(2, 3)`` float64 array (lowest corner, highest corner),
    if it is finite, ``lo < hi`` on every axis and strictly inside the sphere.

    ``name`` is the surface's, for the messages.
    """
    try:
        raw = np.array(box)
    except (TypeError, ValueError):
        raise ValueError(
            f"clip_box of {name!r} must be a (2, 3) array (lowest and highest corners), "
            f"got {box!r}"
        ) from None
    if raw.shape != (2, 3):
        raise ValueError(
            f"clip_box of {name!r} must have shape (2, 3) (lowest and highest corners), "
            f"got shape {raw.shape}"
        )
    if raw.dtype.kind not in "iuf":
        raise ValueError(
            f"clip_box of {name!r} must hold real numbers, got {raw.dtype} values {box!r}"
        )
    b = raw.astype(np.float64)
    if not np.all(np.isfinite(b)):
        raise ValueError(f"clip_box of {name!r} must be finite, got {b.tolist()}")
    flat = b[0] >= b[1]
    if flat.any():
        axes = ", ".join("xyz"[k] for k in np.flatnonzero(flat))
        raise ValueError(
            f"clip_box of {name!r} must have lo < hi on every axis (rows: lowest corner, "
            f"highest corner), got {b.tolist()}: not on {axes}"
        )
    # The boundary curve is traced on the box faces: all of them in the ball.
    corners = np.stack(np.meshgrid(*b.T, indexing="ij"), axis=-1).reshape(-1, 3)
    far = float(np.linalg.norm(corners - centre, axis=1).max())
    if far >= radius:
        raise ValueError(
            f"the clip box {b.tolist()} of {name!r} must lie inside its bounding sphere "
            f"(centre {np.asarray(centre).tolist()}, radius {radius:g}): a corner is "
            f"{far:.6g} from the centre"
        )
    return b
