"""Remeshing benchmark: rdmesh.MeshSurface + mesh_surface against other remeshers.

Inputs are marching-cubes meshes of built-in surfaces (scikit-image), plus a
decimated (vertex clustering) and a noisy (displacement along the normals)
version of each. Remeshers:

- ``input``: the input mesh itself, measured the same way;
- ``rdmesh``: ``mesh_surface(MeshSurface(m), angle_bound=30, radius_bound=r,
  distance_bound=r/10)`` with ``r = R/40`` (R the bounding radius);
- ``pymeshlab``: MeshLab's isotropic explicit remeshing (10 iterations) with
  the target edge length set to the mean edge length of rdmesh's output and
  the surface distance check at rdmesh's distance bound, if pymeshlab imports;
  once with its default feature angle (30 degrees: sharper edges are kept)
  and once without feature edges (180 degrees);
- ``pygalmesh``: ``pygalmesh.remesh_surface`` (CGAL Mesh_3 on the input as a
  polyhedral domain) with the same bounds, if pygalmesh imports.

Measured: smallest angle, share of angles below 30 degrees, Hausdorff distance
to the input (both directions, exact point-to-mesh distances from 20k
area-weighted samples plus the vertices), topology kept (closed manifold,
components and genus equal to the surface's), vertices, wall time.

Run: ``python benchmarks/remesh.py`` (about two minutes). Prints a Markdown
table and writes ``benchmarks/results/remesh-<date>.json``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import logging
import os
import tempfile
import time
from pathlib import Path

import numpy as np
import rdmesh
import trimesh
from rdmesh import MeshSurface
from rdmesh.surfaces import SURFACES
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from skimage.measure import marching_cubes

RESULTS = Path(__file__).with_name("results")
#: The built-in surfaces whose marching-cubes meshes are remeshed (also the
#: suite's remeshing cases, ``input_remesh.py``), and the versions of each.
DEFAULT_SURFACES = ("sphere", "torus", "double_torus")
VARIANTS = ("plain", "decimated", "noisy")


# -- inputs ---------------------------------------------------------------------------


def mc_input(name: str, n: int) -> tuple[np.ndarray, np.ndarray]:
    s = SURFACES[name].make()
    ax = np.linspace(-s.radius, s.radius, n)
    grid = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3) + s.centre
    v, f, _, _ = marching_cubes(s(grid).reshape(n, n, n), 0.0, spacing=(ax[1] - ax[0],) * 3)
    return v + (s.centre - s.radius), f.astype(np.int64)


def mean_edge(v, f) -> float:
    return float(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1).mean())


def decimate(v, f, cell):
    _, label = np.unique(np.floor(v / cell).astype(np.int64), axis=0, return_inverse=True)
    label = label.reshape(-1)
    nv = np.stack([np.bincount(label, weights=v[:, k]) for k in range(3)], axis=1)
    nv /= np.bincount(label)[:, None]
    nf = label[f]
    keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
    return nv, nf[keep]


def variants(name: str, n: int):
    """(variant, (vertices, faces)) for each of VARIANTS: the marching-cubes mesh
    of the built-in surface ``name`` on an ``n``-per-axis grid, decimated, noisy."""
    v, f = mc_input(name, n)
    yield "plain", (v, f)
    yield "decimated", decimate(v, f, 2.5 * mean_edge(v, f))
    normals = trimesh.Trimesh(v, f, process=False).vertex_normals
    rng = np.random.default_rng(7)
    yield "noisy", (v + rng.normal(scale=0.1 * mean_edge(v, f), size=(len(v), 1)) * normals, f)


# -- metrics --------------------------------------------------------------------------


def angles(v, f) -> np.ndarray:
    t = v[f]
    out = []
    for i in range(3):
        a, b = t[:, (i + 1) % 3] - t[:, i], t[:, (i + 2) % 3] - t[:, i]
        cos = np.einsum("ij,ij->i", a, b) / (
            np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1) + 1e-300
        )
        out.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return np.concatenate(out)


def topology(v, f) -> dict:
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, dcount = np.unique(directed, axis=0, return_counts=True)
    edges, ucount = np.unique(np.sort(directed, axis=1), axis=0, return_counts=True)
    closed = bool(np.all(ucount == 2) and np.all(dcount == 1))
    m = len(f)
    size = m + len(v)
    g = coo_matrix(
        (np.ones(3 * m), (np.repeat(np.arange(m), 3), f.ravel() + m)), shape=(size, size)
    )
    _, label = connected_components(g, directed=False)
    comp = np.unique(label[:m], return_inverse=True)[1].reshape(-1)
    chi = []
    for k in range(comp.max() + 1):
        sub = f[comp == k]
        e = np.unique(
            np.sort(np.concatenate([sub[:, [0, 1]], sub[:, [1, 2]], sub[:, [2, 0]]]), 1), axis=0
        )
        chi.append(len(np.unique(sub)) - len(e) + len(sub))
    return {"closed_manifold": closed, "components": len(chi), "euler": sorted(chi)}


def samples(v, f, n=20_000, seed=0):
    rng = np.random.default_rng(seed)
    a = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    pick = rng.choice(len(f), n, p=a / a.sum())
    r = rng.random((n, 2))
    flip = r.sum(1) > 1
    r[flip] = 1 - r[flip]
    t = v[f[pick]]
    return np.vstack(
        [t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0]), v]
    )


def measure(v, f, ref: MeshSurface, info, seconds) -> dict:
    ang = angles(v, f)
    out = MeshSurface((v, f))
    to_in = float(np.abs(ref.signed_distance(samples(v, f))).max())
    to_out = float(np.abs(out.signed_distance(samples(ref.vertices, ref.faces))).max())
    topo = topology(v, f)
    kept = (
        topo["closed_manifold"]
        and topo["components"] == info.components
        and sum(topo["euler"]) == info.euler
    )
    return {
        "vertices": len(v),
        "min_angle": float(ang.min()),
        "below_30": float((ang < 30).mean()),
        "hausdorff": max(to_in, to_out),
        "to_input": to_in,
        "to_output": to_out,
        "topology_kept": bool(kept),
        **topo,
        "seconds": seconds,
    }


# -- remeshers ------------------------------------------------------------------------


def run_rdmesh(ms: MeshSurface, rb: float, db: float):
    t = time.perf_counter()
    m = rdmesh.mesh_surface(ms, angle_bound=30, radius_bound=rb, distance_bound=db)
    return m.vertices, m.faces, time.perf_counter() - t


def run_pymeshlab(v, f, edge: float, db: float, feature_angle: float = 30.0):
    import pymeshlab

    mset = pymeshlab.MeshSet()
    mset.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f.astype(np.int32)))
    t = time.perf_counter()
    mset.meshing_isotropic_explicit_remeshing(
        iterations=10,
        targetlen=pymeshlab.PureValue(edge),
        maxsurfdist=pymeshlab.PureValue(db),
        featuredeg=feature_angle,
    )
    seconds = time.perf_counter() - t
    m = mset.current_mesh()
    return m.vertex_matrix(), m.face_matrix().astype(np.int64), seconds


def run_pygalmesh(v, f, edge: float, rb: float, db: float):
    import pygalmesh

    with tempfile.TemporaryDirectory() as tmp:
        path = os.path.join(tmp, "in.off")
        trimesh.Trimesh(v, f, process=False).export(path)
        t = time.perf_counter()
        m = pygalmesh.remesh_surface(
            path,
            max_edge_size_at_feature_edges=edge,
            min_facet_angle=30,
            max_radius_surface_delaunay_ball=rb,
            max_facet_distance=db,
            verbose=False,
        )
        seconds = time.perf_counter() - t
    return m.points, m.get_cells_type("triangle").astype(np.int64), seconds


def available(module: str) -> str | None:
    try:
        __import__(module)
    except ImportError as exc:
        return f"{module} not importable: {exc}"
    return None


def picture(path: str, grid: int, fraction: float) -> None:
    """Input (noisy marching-cubes torus) and rdmesh's remesh side by side, as one PNG."""
    import matplotlib.image as mpimg
    from rdmesh.io.render import render

    v, f = dict(variants("torus", grid))["noisy"]
    ref = MeshSurface((v, f))
    rb = ref.radius / fraction
    m = rdmesh.mesh_surface(ref, angle_bound=30, radius_bound=rb, distance_bound=rb / 10)
    with tempfile.TemporaryDirectory() as tmp:
        a, b = os.path.join(tmp, "a.png"), os.path.join(tmp, "b.png")
        render(ref.vertices, ref.faces, a, title=f"input: noisy marching cubes, {len(v)} vertices")
        render(
            m.vertices,
            m.faces,
            b,
            title=f"rdmesh remesh: {len(m.vertices)} vertices, min angle {m.min_angle:.1f}°",
        )
        mpimg.imsave(path, np.hstack([mpimg.imread(a), mpimg.imread(b)]))


# -- main -----------------------------------------------------------------------------


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--surfaces", nargs="+", default=list(DEFAULT_SURFACES))
    p.add_argument("--grid", type=int, default=48, help="marching cubes resolution")
    p.add_argument("--fraction", type=float, default=40, help="radius bound = R / fraction")
    p.add_argument("--out", default=None, help="JSON path (default results/remesh-DATE.json)")
    p.add_argument("--picture", metavar="PNG", help="only write the README picture")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")

    if args.picture:
        picture(args.picture, args.grid, args.fraction)
        return 0
    missing = {m: available(m) for m in ("pymeshlab", "pygalmesh")}
    rows = []
    for name in args.surfaces:
        info = SURFACES[name]
        for kind, (v, f) in variants(name, args.grid):
            ref = MeshSurface((v, f))
            rb = ref.radius / args.fraction
            db = rb / 10
            case = {"surface": name, "input": kind, "radius_bound": rb, "distance_bound": db}
            rows.append(
                {**case, "mesher": "input", **measure(ref.vertices, ref.faces, ref, info, 0.0)}
            )
            ov, of, sec = run_rdmesh(ref, rb, db)
            rows.append({**case, "mesher": "rdmesh", **measure(ov, of, ref, info, sec)})
            edge = mean_edge(ov, of)
            if missing["pymeshlab"] is None:
                pv, pf, sec = run_pymeshlab(ref.vertices, ref.faces, edge, db)
                rows.append({**case, "mesher": "pymeshlab", **measure(pv, pf, ref, info, sec)})
                # Without feature edges: the noise's creases are not kept.
                pv, pf, sec = run_pymeshlab(ref.vertices, ref.faces, edge, db, 180.0)
                row = measure(pv, pf, ref, info, sec)
                rows.append({**case, "mesher": "pymeshlab, no features", **row})
            if missing["pygalmesh"] is None:
                gv, gf, sec = run_pygalmesh(ref.vertices, ref.faces, edge, rb, db)
                rows.append({**case, "mesher": "pygalmesh", **measure(gv, gf, ref, info, sec)})

    head = (
        "| surface | input | mesher | vertices | min angle | angles < 30° | Hausdorff "
        "(to input / to output) | topology kept | time |"
    )
    print(head)
    print("|" + "---|" * 9)
    for r in rows:
        print(
            f"| {r['surface']} | {r['input']} | {r['mesher']} | {r['vertices']} | "
            f"{r['min_angle']:.2f}° | {100 * r['below_30']:.1f}% | "
            f"{r['to_input']:.4f} / {r['to_output']:.4f} | "
            f"{'yes' if r['topology_kept'] else 'no'} ({r['components']} comp., χ "
            f"{r['euler']}{'' if r['closed_manifold'] else ', not closed'}) | "
            f"{r['seconds']:.2f} s |"
        )
    for m, why in missing.items():
        if why:
            print(f"\n{m}: not run ({why})")
    RESULTS.mkdir(exist_ok=True)
    out = Path(args.out) if args.out else RESULTS / f"remesh-{datetime.date.today()}.json"
    meta = {
        "command": "python benchmarks/remesh.py " + " ".join(argv or []),
        "rdmesh": rdmesh.__version__,
        "cgal": rdmesh.CGAL_VERSION,
        "not_run": {m: why for m, why in missing.items() if why},
        "grid": args.grid,
        "fraction": args.fraction,
    }
    out.write_text(json.dumps({"meta": meta, "rows": rows}, indent=1))
    print(f"\nwrote {out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
