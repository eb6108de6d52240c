"""Angles of the triangles at the boundary of clipped surfaces (issue 15).

Meshes the clipped cases of ``tests/test_boundary_angles.py`` (a gyroid in a
cube at two size bounds, a plane, a cylinder longer than the box, a torus cut
in half by a box, a clipped volume) and prints, for each, the vertex count,
the time of ``mesh_surface``, the topology, and the smallest angle of the
triangles with an edge on the boundary (two or three vertices on the box),
of the others, and of the boundary triangles whose surface Delaunay ball is
above a quarter of the size bound (those the angle bound applies to)::

    python scripts/boundary_angles.py [--repeat N] [--json OUT]

With ``--repeat N`` each case is meshed N times (times: min and max). The
script uses only the public API, so it runs on older versions as well.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import rdmesh

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from clipped_volumes import TORUS_BOX, torus, volume  # noqa: E402

GYROID = "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"
CUBE = np.array([[-4.0] * 3, [4.0] * 3])
UNIT = np.array([[-1.0] * 3, [1.0] * 3])
HALF = np.array([[0.0, -1.0, -0.5], [1.0, 1.0, 0.5]])


def _expression(text: str, box: np.ndarray, radius: float | None = None):
    r = radius or 1.1 * 0.5 * float(np.linalg.norm(box[1] - box[0]))
    return rdmesh.ImplicitSurface.from_expression(text, (box.mean(axis=0), r), clip_box=box)


#: name -> (surface factory, box, radius bound, distance bound)
CASES = {
    "gyroid in [-4, 4]^3, 0.25, 0.02": (lambda: _expression(GYROID, CUBE, 7.7), CUBE, 0.25, 0.02),
    "gyroid in [-4, 4]^3, 0.3, 0.02": (lambda: _expression(GYROID, CUBE, 7.7), CUBE, 0.3, 0.02),
    "tilted plane in [-1, 1]^3, 0.1": (
        lambda: _expression("z - 0.13 - 0.1*x + 0.2*y", UNIT), UNIT, 0.1, None,
    ),
    "cylinder r=0.55 in [-1, 1]^3, 0.08": (
        lambda: _expression("sqrt(x**2 + y**2) - 0.55", UNIT), UNIT, 0.08, None,
    ),
    "torus cut in half (x >= 0), 0.05, 0.01": (
        lambda: _expression("sqrt((sqrt(x**2 + y**2) - 0.6)**2 + z**2) - 0.25", HALF), HALF, 0.05,
        0.01,
    ),
    "clipped volume: torus 32^3, 0.1, 0.01": (
        lambda: volume(torus, TORUS_BOX[0], TORUS_BOX[1], n=32), np.array(TORUS_BOX), 0.1, 0.01,
    ),
}  # fmt: skip


def boundary_triangles(vertices: np.ndarray, faces: np.ndarray, box: np.ndarray) -> np.ndarray:
    """Which faces have two or three vertices on a face of ``box``."""
    tol = 1e-12 * float(np.max(box[1] - box[0]))
    gap = np.minimum(vertices - box[0], box[1] - vertices).min(axis=1)
    return (np.abs(gap)[faces] <= tol).sum(axis=1) >= 2


def circumradii(corners: np.ndarray) -> np.ndarray:
    a, b, c = (np.linalg.norm(corners[:, i] - corners[:, j], axis=1) for i, j in
               ((1, 2), (2, 0), (0, 1)))  # fmt: skip
    s = 0.5 * (a + b + c)
    area = np.sqrt(np.maximum(s * (s - a) * (s - b) * (s - c), 1e-300))
    return a * b * c / (4.0 * area)


def measure(name: str) -> dict:
    make, box, size, distance = CASES[name]
    s = make()
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(s, radius_bound=size, distance_bound=distance)
    seconds = time.perf_counter() - t0
    at = boundary_triangles(m.vertices, m.faces, box)
    # Circumradius <= surface ball radius: above 0.25 x size, the ball is too.
    held = at & (circumradii(m.vertices[m.faces]) > 0.25 * size)
    topo = m.topology()
    gap = np.minimum(m.vertices - box[0], box[1] - m.vertices).min(axis=1)
    return {
        "vertices": len(m.vertices),
        "seconds": round(seconds, 2),
        "complete": m.complete,
        "euler": topo["euler"],
        "loops": topo["boundary_loops"],
        "min angle, interior": round(float(m.angles[~at].min()), 2),
        "min angle, edge on the boundary": round(float(m.angles[at].min()), 2),
        "min angle, boundary, circumradius > size/4": round(
            float(m.angles[held].min()) if held.any() else float("nan"), 2
        ),
        "boundary triangles": int(at.sum()),
        "min gap to the box (vertices)": float(gap.min()),
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeat", type=int, default=1)
    p.add_argument("--json")
    p.add_argument("--only", help="cases whose name contains this")
    a = p.parse_args(argv)
    rows = {}
    for name in CASES:
        if a.only and a.only not in name:
            continue
        runs = [measure(name) for _ in range(a.repeat)]
        row = dict(runs[0])
        times = [r["seconds"] for r in runs]
        row["seconds"] = [min(times), max(times)] if a.repeat > 1 else times[0]
        rows[name] = row
        print(name, json.dumps(row), flush=True)  # noqa: T201
    if a.json:
        Path(a.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
