#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""What issue 14's speed levers could give at most, measured.

``seeds``: the most that seeding near the final density can save. One run
meshes the surface (f alone, as the suite's ``rdmesh_f_only``); then each run
is seeded with a share of that run's own output vertices on top of its usual
seeds (a share of 1 is a perfect seed: the refinement has nothing left to
find), so the rounds that re-evaluate the same facets go away. The seeds
cost nothing here, which no real seeding achieves::

    python benchmarks/levers.py seeds torus 0.01068486690230627 --shares 0 0.5 0.8 1

``resolution``: the seeding grid made finer (``mesh_surface``'s public
``seed_resolution``, 64 by default), a real seeding near the final density
whose cost is counted (``phase_seconds["seeding"]``)::

    python benchmarks/levers.py resolution torus 0.01068486690230627 --resolutions 64 150

``insertion``: how far CGAL's parallel insertion (TBB) and the bulk build are
from the core's sequential insertion, on one run's own batches. The run's
batches are written to a file and replayed by ``insertion_replay/`` (built
here with CMake; it needs libtbb-dev for the parallel row)::

    python benchmarks/levers.py insertion torus 0.01068486690230627 --threads 2

``band``: seeding near the final density from a fine grid in a narrow band
around the surface, as a real seeding would do it. The grid cells that
change sign are halved, level by level, down to ``--cell`` times the radius
bound (f is evaluated only at the new nodes of those cells); the crossings
on the finest cells' edges are thinned to points at least ``--spacing``
times the radius bound apart, from each other and from the usual seeds, and
added to them. With ``--estimates`` they are thinned on linear estimates of
the crossings and only the kept edges are searched for a root (add it to the
second command below for the cheaper band). The band's cost
is printed (``band_s``) and left out of ``wall_s``: ``wall_s + band_s`` is what
the seeded run took::

    python benchmarks/levers.py band torus 0.01068486690230627 --spacings 1 1.5 2 2.6
    python benchmarks/levers.py band torus 0.01068486690230627 --spacings 1.5 --cell 1.5

Each prints one JSON object per run.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
REPLAY_SOURCE = HERE / "insertion_replay"
REPLAY_BUILD = HERE / "build" / "insertion_replay"


def _surface(name: str):
    import rdmesh
    from rdmesh import surfaces

    made = surfaces.SURFACES[name].make()
    return rdmesh.ImplicitSurface(made.f, made.bounding_sphere)


def _mesh(name: str, radius: float, resolution: int = 64):
    import rdmesh

    t0 = time.perf_counter()
    mesh = rdmesh.mesh_surface(
        _surface(name), radius_bound=radius, distance_bound=radius, seed_resolution=resolution
    )
    return mesh, time.perf_counter() - t0


def _row(mesh, wall: float, **extra) -> dict:
    s = mesh.stats
    return {
        **extra,
        "vertices": len(mesh.vertices),
        "wall_s": round(wall, 3),
        "rounds": s["rounds"],
        "facets_evaluated": s["facets_evaluated"],
        "min_angle": round(float(mesh.min_angle), 3),
        "closed_manifold": bool(mesh.is_closed_manifold()),
        "phase_seconds": {k: round(v, 3) for k, v in s["phase_seconds"].items()},
    }


def seeds(name: str, radius: float, shares: list[float]) -> None:
    """Runs seeded with a share of a first run's output vertices."""
    from rdmesh.refine import methods
    from rdmesh.sampling.grid import GridScan

    first, wall = _mesh(name, radius)
    print(json.dumps(_row(first, wall, surface=name, run="first", share=None)), flush=True)
    scan = methods._scan
    rng = np.random.default_rng(1)
    try:
        for share in shares:
            extra = first.vertices[rng.random(len(first.vertices)) < share]

            def seeded(*args, extra=extra, **kwargs):
                found, discovery = scan(*args, **kwargs)
                points = np.concatenate([found.seeds, extra])
                return GridScan(points, found.crossings, found.spacing), discovery

            methods._scan = seeded
            mesh, wall = _mesh(name, radius)
            row = _row(mesh, wall, surface=name, run="seeded", share=share, extra_seeds=len(extra))
            print(json.dumps(row), flush=True)
    finally:
        methods._scan = scan


def resolution(name: str, radius: float, resolutions: list[int]) -> None:
    """Runs with finer seeding grids, the seeding's cost included."""
    for res in resolutions:
        mesh, wall = _mesh(name, radius, res)
        row = _row(mesh, wall, surface=name, seed_resolution=res, seeds=mesh.stats["inserted"])
        print(json.dumps(row), flush=True)


def _distinct(keys: np.ndarray) -> np.ndarray:
    """Sorted distinct keys, by a sort (numpy's hashing ``unique`` took 5 times
    as long on these)."""
    keys = np.sort(keys)
    return keys[np.r_[True, keys[1:] != keys[:-1]]] if len(keys) else keys


def band_edges(surface, rng: np.random.Generator, resolution: int, cell: float):
    """The sign-changing edges of a fine grid in the band of grid cells that
    change sign: ``(origin, direction, f at both ends, evaluations, spacing)``.

    Level 0 is a rotated, shifted grid of ``resolution`` cells across the
    ball, as the seeding scan's; each level halves the cells whose corners
    change sign, until the spacing is at most ``cell``. f is evaluated only at
    the new nodes of the halved cells, and only their nodes are kept.
    ``evaluations`` counts the grid nodes where f was evaluated.
    """
    from scipy.spatial.transform import Rotation

    c0, R = surface.centre, surface.radius
    h = 2.0 * R / resolution
    rot = Rotation.random(random_state=rng).as_matrix()
    base = -(R + h) + rng.uniform(0.0, h, size=3)
    dims = (resolution + 3,) * 3

    def at(ijk: np.ndarray, step: float) -> np.ndarray:
        return c0 + (base + ijk * step) @ rot.T

    grid = np.stack(np.meshgrid(*(np.arange(dims[0]),) * 3, indexing="ij"), -1).reshape(-1, 3)
    keys = np.arange(len(grid), dtype=np.int64)  # row-major order
    values = surface(at(grid, h))
    evaluations = len(keys)
    inside = values.reshape(dims) < 0
    n = dims[0]
    corner = [inside[i : n - 1 + i, j : n - 1 + j, k : n - 1 + k]
              for i in (0, 1) for j in (0, 1) for k in (0, 1)]  # fmt: skip
    cells = np.argwhere(np.any(corner, 0) & ~np.all(corner, 0))
    step = h
    sub = np.stack(np.meshgrid(*(np.arange(3),) * 3, indexing="ij"), -1).reshape(-1, 3)
    child = np.stack(np.meshgrid(*(np.arange(2),) * 3, indexing="ij"), -1).reshape(-1, 3)
    while step > cell and len(cells):
        step, old, dims = step / 2, dims, tuple(2 * d - 1 for d in dims)
        # Doubling the coordinates keeps the keys in row-major order.
        keys = np.ravel_multi_index(tuple(2 * np.stack(np.unravel_index(keys, old))), dims)
        nk = np.ravel_multi_index(tuple(((2 * cells)[:, None, :] + sub).reshape(-1, 3).T), dims)
        wanted = _distinct(nk)  # every later node is one of these
        pos = np.minimum(np.searchsorted(keys, wanted), len(keys) - 1)
        known = keys[pos] == wanted
        fresh = np.empty(len(wanted))
        fresh[known] = values[pos[known]]
        fresh[~known] = surface(at(np.stack(np.unravel_index(wanted[~known], dims), -1), step))
        evaluations += int((~known).sum())
        keys, values = wanted, fresh
        signs = (values[np.searchsorted(keys, nk)] < 0).reshape(-1, 3, 3, 3)
        kids = []
        for a, b, c in child:
            eight = signs[:, a : a + 2, b : b + 2, c : c + 2].reshape(len(signs), 8)
            mixed = eight.any(1) & ~eight.all(1)
            kids.append(2 * cells[mixed] + (a, b, c))
        cells = np.concatenate(kids)
    # Edges of the finest mixed cells, as (start node key, axis), once each.
    starts = []
    for ax in range(3):
        u, v = [x for x in range(3) if x != ax]
        for du in (0, 1):
            for dv in (0, 1):
                o = np.zeros(3, np.int64)
                o[u], o[v] = du, dv
                starts.append(3 * np.ravel_multi_index(tuple((cells + o).T), dims) + ax)
    edge = _distinct(np.concatenate(starts))
    start, axis = edge // 3, edge % 3
    a = np.stack(np.unravel_index(start, dims), -1)
    b = a.copy()
    b[np.arange(len(b)), axis] += 1
    end = np.ravel_multi_index(tuple(b.T), dims)
    fa, fb = values[np.searchsorted(keys, start)], values[np.searchsorted(keys, end)]
    change = (fa < 0) != (fb < 0)
    origin = at(a[change], step)
    direction = np.ascontiguousarray(rot[:, axis[change]].T)
    return origin, direction, fa[change], fb[change], evaluations, step


def _roots(surface, origin, direction, step):
    from rdmesh._tol import SHOT_ATOL
    from rdmesh.sampling.roots import SegmentSamples, line_crossings

    samples = SegmentSamples.uniform(np.full(len(origin), step), 1)
    return line_crossings(surface, origin, direction, samples, SHOT_ATOL * surface.radius).point


def band_crossings(surface, rng: np.random.Generator, resolution: int, cell: float):
    """The crossings on :func:`band_edges`: ``(points, evaluations of f in all, spacing)``."""
    before = surface.evaluations
    origin, direction, _, _, _, step = band_edges(surface, rng, resolution, cell)
    return _roots(surface, origin, direction, step), surface.evaluations - before, step


def band_seeds(surface, rng, resolution, cell, spacing, seeds, estimates=False):
    """Band crossings at least ``spacing`` apart and from ``seeds``:
    ``(points, crossings found or estimated, evaluations of f in all, band spacing)``.

    With ``estimates``, thinned on the linear estimates of the crossings
    (within a band cell of them, so kept ``spacing + step`` from the seeds),
    and only the kept edges are searched for their root.
    """
    from rdmesh import core
    from scipy.spatial import cKDTree

    before = surface.evaluations
    if not estimates:
        points, _, step = band_crossings(surface, rng, resolution, cell)
        n, far = len(points), spacing
    else:
        origin, direction, fa, fb, _, step = band_edges(surface, rng, resolution, cell)
        points = origin + (step * fa / (fa - fb))[:, None] * direction
        n, far = len(points), spacing + step
    keep = np.ones(n, bool)
    if len(seeds) and n:
        keep = cKDTree(seeds).query(points)[0] > far
    pick = np.flatnonzero(keep)[
        core.select_independent(points[keep], np.full(keep.sum(), spacing))
    ]
    if estimates:
        points, pick = _roots(surface, origin[pick], direction[pick], step), slice(None)
    return points[pick], n, surface.evaluations - before, step


def band(name: str, radius: float, spacings: list[float], cell: float, estimates: bool) -> None:
    """Runs seeded from a fine band grid's crossings, thinned to each spacing."""
    from rdmesh.refine import methods
    from rdmesh.sampling.grid import GridScan

    first, wall = _mesh(name, radius)
    print(json.dumps(_row(first, wall, surface=name, run="first", spacing=None)), flush=True)
    scan = methods._scan
    try:
        for spacing in spacings:
            info: dict = {}

            def seeded(surface, rng, resolution, *args, spacing=spacing, info=info, **kwargs):
                found, discovery = scan(surface, rng, resolution, *args, **kwargs)
                t0 = time.perf_counter()
                extra, n, evaluations, step = band_seeds(
                    surface, np.random.default_rng(7), resolution, cell * radius,
                    spacing * radius, found.seeds, estimates,
                )  # fmt: skip
                info.update(band_s=round(time.perf_counter() - t0, 3), band_crossings=n,
                            band_seeds=len(extra), band_evaluations=evaluations,
                            band_step=step)  # fmt: skip
                seeds = np.concatenate([found.seeds, extra])
                return GridScan(seeds, found.crossings, found.spacing), discovery

            methods._scan = seeded
            mesh, wall = _mesh(name, radius)
            wall -= info["band_s"]
            row = _row(mesh, wall, surface=name, run="band", spacing=spacing, **info)
            print(json.dumps(row), flush=True)
    finally:
        methods._scan = scan


def _build_replay() -> Path:
    cmake = shutil.which("cmake")
    if cmake is None:
        sys.exit("levers.py: cmake not found on PATH")
    for cmd in (
        [cmake, "-S", str(REPLAY_SOURCE), "-B", str(REPLAY_BUILD), "-DCMAKE_BUILD_TYPE=Release"],
        [cmake, "--build", str(REPLAY_BUILD), "--parallel", "2"],
    ):
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
        if done.returncode:
            sys.exit(f"levers.py: {' '.join(cmd[:2])} failed:\n{done.stdout[-2000:]}{done.stderr}")
    return REPLAY_BUILD / "insertion_replay"


def insertion(name: str, radius: float, threads: int, repeats: int) -> None:
    """One run's batches replayed: sequential, parallel (TBB) and bulk."""
    from rdmesh.refine.samples import Samples

    exe = _build_replay()
    batches: list[np.ndarray] = []
    insert = Samples.insert

    def recording(self, points, stage):
        batches.append(np.array(points, np.float64))
        return insert(self, points, stage)

    Samples.insert = recording
    try:
        mesh, wall = _mesh(name, radius)
    finally:
        Samples.insert = insert
    surface = _surface(name)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "batches.bin"
        head = [len(batches), *np.asarray(surface.centre, float), float(surface.radius)]
        parts = [np.array(head)]
        for b in batches:
            parts += [np.array([len(b)], float), b.ravel()]
        np.concatenate(parts).astype("<f8").tofile(path)
        cmd = [str(exe), str(path), "--threads", str(threads), "--repeats", str(repeats)]
        done = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if done.returncode:
        sys.exit(f"levers.py: insertion_replay failed: {done.stderr.strip()}")
    replay = json.loads(done.stdout)
    row = _row(mesh, wall, surface=name, batch_sizes=[len(b) for b in batches], replay=replay)
    print(json.dumps(row), flush=True)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = p.add_subparsers(dest="lever", required=True)
    s = sub.add_parser("seeds", help="seed with a share of a first run's vertices")
    s.add_argument("surface")
    s.add_argument("radius", type=float)
    s.add_argument("--shares", type=float, nargs="+", default=[0.0, 0.5, 0.8, 1.0])
    r = sub.add_parser("resolution", help="finer seeding grids (seed_resolution)")
    r.add_argument("surface")
    r.add_argument("radius", type=float)
    r.add_argument("--resolutions", type=int, nargs="+", default=[64, 150])
    b = sub.add_parser("band", help="seed from a fine grid in a band around the surface")
    b.add_argument("surface")
    b.add_argument("radius", type=float)
    b.add_argument(
        "--spacings",
        type=float,
        nargs="+",
        default=[1.0, 2.0, 2.6],
        help="least distance between band seeds, times the radius bound",
    )
    b.add_argument(
        "--cell",
        type=float,
        default=1.0,
        help="finest band cell, at most this times the radius bound",
    )
    b.add_argument(
        "--estimates",
        action="store_true",
        help="thin on linear estimates of the crossings; search only the kept edges",
    )
    i = sub.add_parser("insertion", help="replay one run's batches")
    i.add_argument("surface")
    i.add_argument("radius", type=float)
    i.add_argument("--threads", type=int, default=2)
    i.add_argument("--repeats", type=int, default=2)
    args = p.parse_args(argv)

    from rdmesh import surfaces

    if args.surface not in surfaces.SURFACES:
        p.error(f"unknown surface {args.surface!r}; use one of {', '.join(surfaces.SURFACES)}")
    if not args.radius > 0:
        p.error("radius must be positive")
    if args.lever == "seeds":
        if any(not 0 <= x <= 1 for x in args.shares):
            p.error("shares lie in [0, 1]")
        seeds(args.surface, args.radius, args.shares)
    elif args.lever == "resolution":
        if any(x < 2 for x in args.resolutions):
            p.error("resolutions need at least 2")
        resolution(args.surface, args.radius, args.resolutions)
    elif args.lever == "band":
        if any(not x > 0 for x in args.spacings) or not args.cell > 0:
            p.error("--spacings and --cell must be positive")
        band(args.surface, args.radius, args.spacings, args.cell, args.estimates)
    else:
        if args.threads < 1 or args.repeats < 1:
            p.error("--threads and --repeats need at least 1")
        insertion(args.surface, args.radius, args.threads, args.repeats)
    return 0


if __name__ == "__main__":
    sys.exit(main())
