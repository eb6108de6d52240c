# SPDX-License-Identifier: GPL-3.0-or-later
"""Sizes: from a target vertex count to a radius bound, per surface.

Restricted Delaunay refinement with radius bound r gives about
``V = C * area / r^2`` vertices.  ``calibrate`` measures C and the area with
a few small rdmesh runs; ``cached_calibration`` keeps the result in a JSON
file; ``radius_for`` turns it into the radius bound for a target size.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

__all__ = ["cached_calibration", "calibrate", "calibration_target", "radius_for"]


def calibrate(surface_name: str, angle: float, target: int, seed: int) -> dict[str, Any]:
    """Small rdmesh runs; returns ``radius``/``vertices``/``area``/``C``/``bbox``.

    A first run at a fifteenth of the bounding radius, then two that aim at
    ``target`` vertices from the one before (``r <- r sqrt(V / target)``).
    ``C = vertices * radius^2 / area`` of the last one maps any target vertex
    count N to the radius bound ``sqrt(C * area / N)``.
    """
    import numpy as np
    import rdmesh
    from metrics import compact, mesh_area, surface_bbox

    s = rdmesh.surfaces.get(surface_name)
    r = float(s.radius) / 15.0
    runs = []
    for _ in range(3):
        m = rdmesh.mesh_surface(
            rdmesh.surfaces.get(surface_name),
            angle_bound=angle,
            radius_bound=r,
            distance_bound=r,
            seed=seed,
        )
        v, f = compact(m.vertices, m.faces)
        runs.append((r, len(v), mesh_area(v, f)))
        r = r * math.sqrt(len(v) / target)
    r, nv, area = runs[-1]
    lo, hi = surface_bbox(s)
    return {
        "radius": r,
        "vertices": nv,
        "area": area,
        "C": nv * r * r / area,
        "bbox": [np.asarray(lo).tolist(), np.asarray(hi).tolist()],
        "runs": [{"radius": a, "vertices": b, "area": c} for a, b, c in runs],
    }


def calibration_target(sizes: Sequence[float]) -> int:
    """The vertex count calibration aims at: the smallest size, clamped to 2k-20k."""
    return int(min(max(min(sizes), 2000), 20000))


def cached_calibration(
    cache: Path,
    surface: str,
    angle: float,
    target: int,
    seed: int,
    *,
    recalibrate: bool = False,
    log: Callable[[str], None] = lambda msg: None,
) -> dict[str, Any]:
    """``calibrate``, through ``cache / "calibration.json"`` (``recalibrate``: ignore it).

    A fresh calibration also records how long it took (``seconds``).
    """
    key = f"{surface}|angle={angle:g}|target={target}|seed={seed}"
    path = cache / "calibration.json"
    known = json.loads(path.read_text()) if path.exists() else {}
    if key in known and not recalibrate:
        return known[key]
    log(f"calibrating {surface} (rdmesh at about {target} vertices) ...")
    t0 = time.perf_counter()
    cal = calibrate(surface, angle, target, seed)
    cal["seconds"] = time.perf_counter() - t0
    known[key] = cal
    path.write_text(json.dumps(known, indent=1))
    return cal


def radius_for(cal: dict[str, Any], size: int) -> float:
    """The radius bound that gives about ``size`` vertices on a calibrated surface."""
    return math.sqrt(cal["C"] * cal["area"] / size)
