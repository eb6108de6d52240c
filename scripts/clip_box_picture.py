"""A gyroid clipped to a cube: the README's picture and measurements.

Meshes ``sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)`` clipped to the cube
``[-4, 4]^3`` (``ImplicitSurface.from_expression(..., clip_box=...)``), writes
docs/clip-box-gyroid.png, and prints what held: the same call as
``rdmesh mesh GYROID --clip-box -4 -4 -4 4 4 4 --radius 0.2``. It also
measures the tests' case (``tests/test_clip_box_expression.py``: an
off-centre cube of side 6.6, radius bound 0.3, distance bound 0.02)::

    python scripts/clip_box_picture.py [OUT.png]
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np
import rdmesh
from rdmesh.topology.complex import complex_status
from volume_picture import render_framed

ROOT = Path(__file__).resolve().parent.parent

GYROID = "sin(x)*cos(y) + sin(y)*cos(z) + sin(z)*cos(x)"
#: (box, radius bound, distance bound): the picture's (the default radius
#: bound would be R / 20 = 0.38 for its sphere) and the tests'.
CASES = {
    "cube [-4, 4]^3, radius bound 0.2": (np.array([[-4.0] * 3, [4.0] * 3]), 0.2, None),
    "tests' cube, radius bound 0.3, distance bound 0.02": (
        np.array([[0.3, -0.2, 0.1]]) + np.array([[-3.3] * 3, [3.3] * 3]),
        0.3,
        0.02,
    ),
}


def measure(
    box: np.ndarray, size: float, distance: float | None
) -> tuple[rdmesh.SurfaceMesh, dict]:
    """Mesh the gyroid clipped to ``box`` and measure it at the boundary."""
    # The box's circumscribed sphere enlarged by 10%, as the command line's.
    sphere = (box.mean(axis=0), 1.1 * 0.5 * float(np.linalg.norm(box[1] - box[0])))
    s = rdmesh.ImplicitSurface.from_expression(GYROID, sphere, name="gyroid", clip_box=box)
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(s, radius_bound=size, distance_bound=distance)
    seconds = time.perf_counter() - t0
    v, n = m.vertices, len(m.vertices)
    st = complex_status(m.faces, n)
    key = st.edge_key[st.edge_count == 1]
    bv = np.unique(np.concatenate([key // n, key % n]))
    gap = np.minimum(v - box[0], box[1] - v).min(axis=1)
    on = np.abs(gap) <= 1e-12 * float(np.max(box[1] - box[0]))
    exempt = on[m.faces].sum(axis=1) >= 2
    topo = m.topology()
    return m, {
        "vertices": n,
        "seconds": round(seconds, 1),
        "complete": m.complete,
        "components": topo["components"],
        "chi": topo["euler"],
        "loops": topo["boundary_loops"],
        "edge crossings": m.report["boundary"]["edge_crossings"],
        "boundary basis": m.report["boundary"]["basis"],
        "loops match the traced curve": m.report["boundary"]["loops_match"],
        "max face distance at boundary": float(np.abs(gap[bv]).max()),
        "max |f|/|grad f| at vertices": float(
            (np.abs(s(v)) / np.linalg.norm(s.grad(v), axis=1)).max()
        ),
        "min angle, interior": round(float(m.angles[~exempt].min()), 2),
        "min angle, edge on the boundary": round(float(m.angles[exempt].min()), 2),
    }


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    out = argv[0] if argv else str(ROOT / "docs" / "clip-box-gyroid.png")
    rows = {}
    for name, case in CASES.items():
        rows[name] = measure(*case)
        print(name, rows[name][1])
    m, row = rows[next(iter(CASES))]
    genus = m.topology()["genus"]
    loops = sum(row["loops"])
    title = (
        f"gyroid clipped to [-4, 4]^3: {row['vertices']} vertices, genus "
        f"{', '.join(f'{g:g}' for g in genus)}, {loops} boundary loop{'s' * (loops != 1)}"
    )
    render_framed(m, out, title)
    print("wrote", out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
