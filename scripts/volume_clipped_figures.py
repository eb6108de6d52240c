"""Volumes clipped to their box: the README's measurements.

Meshes four volumes whose isosurface leaves the box (``tests/clipped_volumes.py``)
with ``VolumeSurface(border="clipped")`` and prints what holds at the
boundary::

    python scripts/volume_clipped_figures.py
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

from clipped_volumes import TORUS_BOX, corner_sphere, cylinder, plane, torus, volume  # noqa: E402

CASES = {
    "plane, 24^3": (plane, {}),
    "cylinder, 24^3": (cylinder, {}),
    "sphere cut by a corner, 24^3": (corner_sphere, {}),
    "torus cut by a face, 32^3": (torus, {"lo": TORUS_BOX[0], "hi": TORUS_BOX[1], "n": 32}),
}
SIZE, DISTANCE = 0.1, 0.01


def measure(f, kwargs: dict) -> dict:
    """Mesh one volume (radius bound 0.1, distance bound 0.01) and measure its boundary."""
    s = volume(f, **kwargs)
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(s, radius_bound=SIZE, distance_bound=DISTANCE)
    seconds = time.perf_counter() - t0
    v, n = m.vertices, len(m.vertices)
    st = complex_status(m.faces, n)
    key = st.edge_key[st.edge_count == 1]
    edges = np.column_stack([key // n, key % n])
    bv = np.unique(edges)
    gap = np.minimum(v - s.box[0], s.box[1] - v).min(axis=1)
    on = np.abs(gap) <= 1e-12
    # A boundary edge's midpoint: its distance to the curve, |f| over the
    # gradient within the face the edge lies in.
    faces = np.concatenate([np.abs(v - s.box[0]), np.abs(s.box[1] - v)], axis=1) <= 1e-12
    axis = np.argmax(faces[edges[:, 0]] & faces[edges[:, 1]], axis=1) % 3
    mid = v[edges].mean(axis=1)
    g = s.grad(mid)
    g[np.arange(len(g)), axis] = 0.0
    chord = np.abs(s(mid)) / np.linalg.norm(g, axis=1)
    length = np.linalg.norm(v[edges[:, 0]] - v[edges[:, 1]], axis=1)
    exempt = on[m.faces].sum(axis=1) >= 2
    topo = m.topology()
    return {
        "vertices": n,
        "seconds": seconds,
        "chi": topo["euler"],
        "loops": topo["boundary_loops"],
        "edge crossings": m.report["boundary"]["edge_crossings"],
        "max face distance at boundary": float(np.abs(gap[bv]).max()),
        "max |f|/|grad f| at boundary": float(
            (np.abs(s(v[bv])) / np.linalg.norm(s.grad(v[bv]), axis=1)).max()
        ),
        "longest boundary edge": float(length.max()),
        "max chord-to-curve distance": float(chord.max()),
        "min angle, interior": float(m.angles[~exempt].min()),
        "min angle, edge on the boundary": float(m.angles[exempt].min()),
    }


def main() -> None:
    for name, (f, kwargs) in CASES.items():
        row = measure(f, kwargs)
        print(name, {k: (f"{x:.3g}" if isinstance(x, float) else x) for k, x in row.items()})


if __name__ == "__main__":
    main()
