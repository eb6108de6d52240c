"""Surfaces that leave the domain: the README's picture and measurements.

Meshes a gyroid-like surface in a sphere of radius 2 with
``topology="manifold-with-boundary"``, writes docs/clipped-gyroid.png, and
prints what holds at the boundary for it and three surfaces of known
topology (a plane, a cylinder, a torus cut by the sphere)::

    python scripts/clipped_picture.py [OUT.png]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import rdmesh
from rdmesh.topology.complex import complex_status

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

from clipped_surfaces import GYROID, cylinder, plane, torus_off_centre  # noqa: E402

CASES = {
    "plane (R=1, r_b=0.1)": (plane, 1.0, 0.1),
    "cylinder (R=1, r_b=0.08)": (cylinder, 1.0, 0.08),
    "torus cut (R=1, r_b=0.05)": (torus_off_centre, 1.0, 0.05),
    "gyroid (R=2, r_b=0.2)": (GYROID, 2.0, 0.2),
    "gyroid (R=2, default r_b=0.1)": (GYROID, 2.0, None),
}


def measure(f, radius: float, bound: float | None) -> tuple[rdmesh.SurfaceMesh, dict]:
    """Mesh one case and measure its boundary."""
    if isinstance(f, str):
        s = rdmesh.ImplicitSurface.from_expression(f, ((0, 0, 0), radius))
    else:
        s = rdmesh.ImplicitSurface(f, ((0, 0, 0), radius))
    t = time.perf_counter()
    m = rdmesh.mesh_surface(s, topology="manifold-with-boundary", radius_bound=bound)
    seconds = time.perf_counter() - t
    n = len(m.vertices)
    st = complex_status(m.faces, n)
    key = st.edge_key[st.edge_count == 1]
    bv = np.unique(np.concatenate([key // n, key % n]))
    r = np.linalg.norm(m.vertices, axis=1)
    on = np.abs(r - radius) <= 1e-9 * radius
    edge = on[m.faces].sum(axis=1) >= 2
    topo = m.topology()
    return m, {
        "vertices": n,
        "complete": m.complete,
        "chi": topo["euler"],
        "loops": topo["boundary_loops"],
        "max |r-R|/R at boundary": float(np.abs(r[bv] - radius).max() / radius),
        "max |f| at boundary": float(np.abs(s(m.vertices[bv])).max()),
        "min angle, <= 1 vertex on the sphere": round(float(m.angles[~edge].min()), 2),
        "min angle, 2-3 vertices on the sphere": round(float(m.angles[edge].min()), 2),
        "seconds": round(seconds, 1),
    }


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = argv[0] if argv else str(ROOT / "docs" / "clipped-gyroid.png")
    picture = None
    for name, (f, radius, bound) in CASES.items():
        m, row = measure(f, radius, bound)
        print(name, row)
        if name.startswith("gyroid (R=2, default"):
            picture = m
    topo = picture.topology()
    picture.render(
        out,
        title=(
            f"gyroid clipped by a sphere: {len(picture.vertices)} vertices, "
            f"{sum(topo['boundary_loops'])} boundary loops, genus {topo['genus'][0]:g}"
        ),
    )
    print("wrote", out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
