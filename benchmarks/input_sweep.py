#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
# ruff: noqa: E501 (the cases are one line each)
"""A sweep of odd and bad input (issue 30): every case in its own process.

Each case builds a surface (a mesh with repeated, turned or missing faces, a
volume with odd shapes, types or spacings, an expression or a Python ``f``
that misbehaves) and meshes it with ``rdmesh.mesh_surface`` in a child
process with a timeout, and records what happened:

- ``ok``: a mesh (its vertices, components, Euler characteristics, whether it
  is a closed manifold and complete, its smallest angle);
- ``budget``: ``BudgetExceeded`` (a time limit or vertex budget the case set);
- ``error``: an rdmesh error, ``ValueError`` or ``TypeError``, with its text;
- ``OTHER`` (any other exception), ``CRASH`` (the child died) or ``HANG``
  (the timeout): each is a bug, and the exit status is 1 when there is one.

What counts as right for each ``ok`` or ``error`` is read from the table (an
empty mesh marked incomplete, or an error that names the wrong problem, are
bugs too)::

    python benchmarks/input_sweep.py                 # about 3 minutes
    python benchmarks/input_sweep.py --only vol      # the cases whose name has "vol"
    python benchmarks/input_sweep.py --out results/input-sweep.json
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import time
from pathlib import Path

#: Builders the cases' code may use (run in the child before the case).
PRELUDE = r"""
import numpy as np, rdmesh, trimesh
def sph(sub=3):
    m = trimesh.creation.icosphere(sub)
    return np.asarray(m.vertices), np.asarray(m.faces, np.int64)
def tet():
    return (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]),
            np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]))
def cube():
    m = trimesh.creation.box()
    return np.asarray(m.vertices), np.asarray(m.faces, np.int64)
def moebius(n=40):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.array([[(1 + s * np.cos(a / 2)) * np.cos(a), (1 + s * np.cos(a / 2)) * np.sin(a),
                   s * np.sin(a / 2)] for a in t for s in (-0.3, 0.3)])
    f = []
    for i in range(n):
        j = (i + 1) % n
        b0, b1 = (2 * j, 2 * j + 1) if j else (1, 0)
        f += [[2 * i, b0, 2 * i + 1], [2 * i + 1, b0, b1]]
    return v, np.array(f)
def box_volume(n=12):
    a = np.zeros((n, n, n)); a[3:8, 3:8, 3:8] = 1.0
    return a
SPHERE = "x*x + y*y + z*z - 1"
KW = {}
"""

#: Mesh inputs: code that sets ``v, f``; meshed at R/10 with distance bound R/100.
MESHES = {
    "single triangle": "v, f = tet(); v, f = v[:3], f[:1]",
    "two triangles": "v = np.array([[0,0,0],[1,0,0],[0,1,0],[1,1,0.]]); f = np.array([[0,1,2],[1,3,2]])",
    "tetrahedron": "v, f = tet()",
    "tetrahedron, a face twice": "v, f = tet(); f = np.r_[f, f[:1]]",
    "tetrahedron, a face turned": "v, f = tet(); f = np.r_[f[:3], f[3:, ::-1]]",
    "tetrahedron, all faces turned": "v, f = tet(); f = f[:, ::-1].copy()",
    "two tetrahedra sharing an edge": "v, f = tet(); v = np.r_[v, [[1,1,1.],[2,2,0.]]]; f = np.r_[f, [[0,1,4],[1,5,4],[0,4,5],[0,5,1]]]",
    "two tetrahedra sharing a vertex": "v, f = tet(); v = np.r_[v, v[1:] + [1,0,0]]; f = np.r_[f, np.where(f == 0, 1, f + 3 * (f > 0))]",
    "two overlapping cubes": "a, b = cube(); v = np.r_[a, a + 0.5]; f = np.r_[b, b + 8]",
    "nested spheres, inner turned": "a, b = sph(); v = np.r_[a, 0.5 * a]; f = np.r_[b, b[:, ::-1] + len(a)]",
    "nested spheres, same way": "a, b = sph(); v = np.r_[a, 0.5 * a]; f = np.r_[b, b + len(a)]",
    "sphere turned inside out": "v, f = sph(); f = f[:, ::-1].copy()",
    "sheet listed both ways": "v = np.array([[0,0,0],[1,0,0],[0,1,0],[1,1,0.]]); f = np.array([[0,1,2],[1,3,2],[0,2,1],[1,2,3]])",
    "collinear triangle": "v = np.array([[0,0,0],[1,0,0],[2,0,0.]]); f = np.array([[0,1,2]])",
    "index out of range": "v, f = tet(); f = np.r_[f, [[0, 1, 9]]]",
    "negative index": "v, f = tet(); f = np.r_[f[:3], [[1, 2, -1]]]",
    "NaN vertex": "v, f = tet(); v[3, 0] = np.nan",
    "unused NaN vertex": "v, f = tet(); v = np.r_[v, [[np.nan] * 3]]",
    "infinite vertex": "v, f = tet(); v[3, 0] = np.inf",
    "float32 and int32": "v, f = sph(); v, f = v.astype(np.float32), f.astype(np.int32)",
    "Fortran-ordered": "v, f = sph(); v = np.asfortranarray(v)",
    "faces as whole floats": "v, f = sph(); f = f.astype(float)",
    "faces as fractions": "v, f = sph(); f = f + 0.5",
    "quads": "v, f = sph(); f = np.c_[f, f[:, :1]]",
    "no faces": "v, f = sph(); f = np.zeros((0, 3), np.int64)",
    "2-D vertices": "v, f = sph(); v = v[:, :2]",
    "boolean faces": "v, f = sph(); f = f.astype(bool)",
    "complex vertices": "v, f = sph(); v = v.astype(complex)",
    "object vertices": "v, f = sph(); v = v.astype(object)",
    "a face repeating a vertex": "v, f = sph(); f[0] = [f[0, 0], f[0, 0], f[0, 1]]",
    "a sliver 1e-30 high": "v, f = sph(); a, b, c = f[0]; v = np.r_[v, [(v[a] + v[b]) / 2 + 1e-30]]; f = np.r_[f[1:], [[a, len(v) - 1, c], [len(v) - 1, b, c]]]",
    "cube, a face missing": "v, f = cube(); f = f[1:]",
    "cube, two faces missing": "v, f = cube(); f = f[2:]",
    "T-junction": "v, f = cube(); a, b, c = f[0]; v = np.r_[v, [(v[a] + v[b]) / 2]]; f = np.r_[f[1:], [[a, 8, c], [8, b, c]]]",
    "Moebius strip": "v, f = moebius()",
    "triangle soup (unmerged)": "v, f = sph(); v = v[f].reshape(-1, 3); f = np.arange(3 * len(f)).reshape(-1, 3)",
    "sphere and a stray triangle far away": "v, f = sph(); n = len(v); v = np.r_[v, [[100,0,0],[101,0,0],[100,1,0.]]]; f = np.r_[f, [[n, n + 1, n + 2]]]",
    "sphere and an unused vertex far away": "v, f = sph(); v = np.r_[v, [[1e6, 0, 0]]]",
    "two spheres 1e4 apart": "a, b = sph(); v = np.r_[a, a + [1e4, 0, 0]]; f = np.r_[b, b + len(a)]",
    "two spheres touching at a point": "a, b = sph(); v = np.r_[a, a + [2, 0, 0]]; f = np.r_[b, b + len(a)]",
    "two coincident spheres": "a, b = sph(); v = np.r_[a, a]; f = np.r_[b, b + len(a)]",
    "sphere with a fin inside": "v, f = sph(); n = len(v); v = np.r_[v, [[0,0,0],[0.5,0,0],[0,0.5,0.]]]; f = np.r_[f, [[n, n + 1, n + 2]]]",
    "sphere squashed to 1e-9": "v, f = sph(); v = v * [1, 1, 1e-9]",
    "sphere squeezed to a 1e-6 needle": "v, f = sph(); v = v * [1, 1e-6, 1e-6]",
}

#: Other inputs: code that sets ``s`` (and ``KW``, mesh_surface's options
#: beside radius_bound = R/8).
OTHERS = {
    "vol constant": "s = rdmesh.VolumeSurface(np.zeros((8, 8, 8)))",
    "vol NaN sample": "a = np.random.default_rng(0).random((10, 10, 10)); a[3, 3, 3] = np.nan; s = rdmesh.VolumeSurface(a, isovalue=0.5)",
    "vol 1x1x1": "s = rdmesh.VolumeSurface(np.ones((1, 1, 1)), isovalue=0.5)",
    "vol one voxel on": "a = np.zeros((9, 9, 9)); a[4, 4, 4] = 1; s = rdmesh.VolumeSurface(a, isovalue=0.5)",
    "vol one voxel on, linear": "a = np.zeros((9, 9, 9)); a[4, 4, 4] = 1; s = rdmesh.VolumeSurface(a, isovalue=0.5, interpolation='linear')",
    "vol boolean": "s = rdmesh.VolumeSurface(box_volume() > 0)",
    "vol int8": "s = rdmesh.VolumeSurface((box_volume() * 100).astype(np.int8), isovalue=50)",
    "vol 2-D": "s = rdmesh.VolumeSurface(np.zeros((8, 8)))",
    "vol object": "s = rdmesh.VolumeSurface(np.zeros((8, 8, 8), object))",
    "vol complex": "s = rdmesh.VolumeSurface(box_volume().astype(complex), isovalue=0.5)",
    "vol isovalue NaN": "s = rdmesh.VolumeSurface(box_volume(), isovalue=float('nan'))",
    "vol isovalue at the maximum": "s = rdmesh.VolumeSurface(box_volume(), isovalue=1)",
    "vol spacing 0": "s = rdmesh.VolumeSurface(box_volume(), isovalue=0.5, spacing=(1, 0, 1))",
    "vol spacing (1, 1, 1000)": "s = rdmesh.VolumeSurface(box_volume(), isovalue=0.5, spacing=(1, 1, 1000))",
    "vol origin infinite": "s = rdmesh.VolumeSurface(box_volume(), isovalue=0.5, origin=(np.inf, 0, 0))",
    "vol unknown border": "s = rdmesh.VolumeSurface(box_volume(), isovalue=0.5, border='open')",
    "vol all on but a corner": "a = np.ones((12, 12, 12)); a[0, 0, 0] = 0; s = rdmesh.VolumeSurface(a, isovalue=0.5)",
    "vol checkerboard, cubic (every saddle on the isovalue)": "i = np.indices((12, 12, 12)).sum(0) % 2; s = rdmesh.VolumeSurface(i.astype(float), isovalue=0.5); KW = dict(time_limit=30)",
    "vol checkerboard, linear": "i = np.indices((12, 12, 12)).sum(0) % 2; s = rdmesh.VolumeSurface(i.astype(float), isovalue=0.5, interpolation='linear')",
    "vol noise": "a = np.random.default_rng(1).random((16, 16, 16)); s = rdmesh.VolumeSurface(a, isovalue=0.5)",
    "vol values near 1e-300": "s = rdmesh.VolumeSurface(box_volume() * 1e-300, isovalue=5e-301)",
    "vol values near 1e300": "s = rdmesh.VolumeSurface(box_volume() * 1e300, isovalue=5e299)",
    "vol strided view": "a = np.zeros((24, 24, 24)); a[6:16, 6:16, 6:16] = 1; s = rdmesh.VolumeSurface(a[::2, ::2, ::2], isovalue=0.5)",
    "expr empty": "s = rdmesh.ImplicitSurface.from_expression('', ((0, 0, 0), 1))",
    "expr import": 's = rdmesh.ImplicitSurface.from_expression(\'__import__("os").system("true")\', ((0, 0, 0), 1))',
    "expr 1/0": "s = rdmesh.ImplicitSurface.from_expression('1/0 + x', ((0, 0, 0), 1))",
    "expr sqrt of negatives": "s = rdmesh.ImplicitSurface.from_expression('sqrt(x) - 0.5', ((0, 0, 0), 1))",
    "expr x**1000": "s = rdmesh.ImplicitSurface.from_expression('x**1000 + y**2 + z**2 - 0.5', ((0, 0, 0), 1))",
    "expr 0": "s = rdmesh.ImplicitSurface.from_expression('0*x', ((0, 0, 0), 1))",
    "expr a plane": "s = rdmesh.ImplicitSurface.from_expression('x', ((0, 0, 0), 1))",
    "expr 10,001 characters": "s = rdmesh.ImplicitSurface.from_expression('+'.join(['x*x'] * 5000) + '-1', ((0, 0, 0), 3000))",
    "expr 500 parentheses deep": "s = rdmesh.ImplicitSurface.from_expression('(' * 500 + SPHERE + ')' * 500, ((0, 0, 0), 2))",
    "expr a point": "s = rdmesh.ImplicitSurface.from_expression('x*x + y*y + z*z', ((0, 0, 0), 1))",
    "expr a sphere 0.002 across a radius of 1": "s = rdmesh.ImplicitSurface.from_expression('(x-0.3)**2 + y*y + z*z - 1e-6', ((0, 0, 0), 1)); KW = dict(radius_bound=3e-4)",
    "expr two spheres touching at a point": "s = rdmesh.ImplicitSurface.from_expression('min((x-0.5)**2+y*y+z*z-0.25, (x+0.5)**2+y*y+z*z-0.25)', ((0, 0, 0), 1.5))",
    "opt radius_bound 0": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=0)",
    "opt radius_bound 1e-5, 20 s": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=1e-5, time_limit=20)",
    "opt radius_bound 1e9": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=1e9)",
    "opt angle_bound 31": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(angle_bound=31)",
    "opt distance_bound 1e-12, 20 s": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(distance_bound=1e-12, time_limit=20)",
    "opt max_vertices 5": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(max_vertices=5)",
    "opt time_limit 1e-9": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(time_limit=1e-9)",
    "opt seed 2**80": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(seed=2**80)",
    "opt workers 64": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(workers=64)",
    "opt sizing field returning NaN": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=lambda p: np.full(len(p), np.nan))",
    "opt sizing field raising": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=lambda p: 1 / 0)",
    "opt sizing field 1e-7 in a spot, 20 s": "s = rdmesh.ImplicitSurface.from_expression(SPHERE, ((0, 0, 0), 2)); KW = dict(radius_bound=lambda p: np.where(p[:, 0] > 0.99, 1e-7, 0.2), time_limit=20)",
    "f of the wrong shape": "s = rdmesh.ImplicitSurface(lambda p: np.ones(3), ((0, 0, 0), 1))",
    "f returning NaN in places": "s = rdmesh.ImplicitSurface(lambda p: np.where(p[:, 0] > 0.3, np.nan, np.linalg.norm(p, axis=1) - 0.5), ((0, 0, 0), 1))",
    "f returning integers": "s = rdmesh.ImplicitSurface(lambda p: (np.linalg.norm(p, axis=1) > 0.5).astype(int) * 2 - 1, ((0, 0, 0), 1))",
    "f returning complex": "s = rdmesh.ImplicitSurface(lambda p: (np.linalg.norm(p, axis=1) - 0.5).astype(complex), ((0, 0, 0), 1))",
    "f raising on large batches": "s = rdmesh.ImplicitSurface(lambda p: (np.linalg.norm(p, axis=1) - 0.5) if len(p) < 5000 else 1 / 0, ((0, 0, 0), 1))",
    "f writing into its argument": "s = rdmesh.ImplicitSurface(lambda p: (p.__setitem__((slice(None), 0), 0) or np.linalg.norm(p, axis=1) - 0.5), ((0, 0, 0), 1))",
    "f returning None": "s = rdmesh.ImplicitSurface(lambda p: None, ((0, 0, 0), 1))",
    "f not callable": "s = rdmesh.ImplicitSurface(3, ((0, 0, 0), 1))",
}

CHILD = r"""
try:
{code}
    if "v" in dir() and "s" not in dir():
        s = rdmesh.MeshSurface((v, f))
        kw = dict(radius_bound=s.radius / 10, distance_bound=s.radius / 100, time_limit=60)
    else:
        kw = dict(radius_bound=s.radius / 8)
    kw.update(KW)
    m = rdmesh.mesh_surface(s, **kw)
    t = m.topology()
    print("OUTCOME ok", len(m.vertices), "vertices,", t["components"], "components, Euler",
          t["euler"][:4], "closed" if t["closed_manifold"] else "NOT closed",
          "complete" if m.complete else "incomplete", f"{float(m.min_angle):.1f} deg")
except rdmesh.BudgetExceeded as e:
    print("OUTCOME budget", str(e)[:160])
except (rdmesh.RdmeshError, ValueError, TypeError) as e:
    print("OUTCOME error", type(e).__name__ + ":", str(e)[:200])
except Exception as e:
    print("OUTCOME OTHER", type(e).__name__ + ":", str(e)[:200])
"""


def run_case(code: str, timeout: float) -> tuple[str, str, float]:
    body = "\n".join("    " + line for line in code.split("; "))
    t = time.perf_counter()
    try:
        p = subprocess.run(
            [sys.executable, "-c", PRELUDE + CHILD.replace("{code}", body)],
            capture_output=True, text=True, timeout=timeout,
        )  # fmt: skip
        lines = [x for x in p.stdout.splitlines() if x.startswith("OUTCOME ")]
        if lines:
            kind, _, text = lines[-1][len("OUTCOME ") :].partition(" ")
        else:
            kind, text = "CRASH", f"exit status {p.returncode}: {p.stderr.strip()[-200:]}"
    except subprocess.TimeoutExpired:
        kind, text = "HANG", f"no result in {timeout:g} s"
    return kind, text, time.perf_counter() - t


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--only", help="run the cases whose name contains this text")
    ap.add_argument("--timeout", type=float, default=150.0)
    ap.add_argument("--out", type=Path, help="write the rows as JSON here")
    args = ap.parse_args(argv)
    cases = {**MESHES, **OTHERS}
    rows = []
    print("| case | s | outcome |\n|---|---|---|")
    for name, code in cases.items():
        if args.only and args.only not in name:
            continue
        kind, text, sec = run_case(code, args.timeout)
        rows.append({"case": name, "seconds": round(sec, 2), "outcome": kind, "detail": text})
        print(f"| {name} | {sec:.1f} | {kind}: {text.replace('|', '/')} |", flush=True)
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(json.dumps(rows, indent=1))
    bugs = [r for r in rows if r["outcome"] in ("OTHER", "CRASH", "HANG")]
    print(f"\n{len(rows)} cases, {len(bugs)} crashed, hung or raised something else")
    return 1 if bugs else 0


if __name__ == "__main__":
    sys.exit(main())
