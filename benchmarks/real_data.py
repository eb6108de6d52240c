# SPDX-License-Identifier: GPL-3.0-or-later
"""Real data beside the tools users run today (issue 30): remeshing and volumes.

Inputs that install here with packages, and small synthetic look-alikes made
by code (shipped in the repo as code, not data):

- remeshing (``MeshSurface``, radius bound ``r`` = 1 % and 0.3 % of the
  bounding-box diagonal, distance bound ``r / 10``) beside pymeshlab's
  isotropic explicit remeshing (10 iterations, target length ``sqrt(3) r``,
  the edge of an equilateral triangle of circumradius ``r``, surface distance
  ``r / 10``): pymeshlab's sample bunny (a scan) and bone, nilearn's fsaverage5
  left pial surface (a cortex), a thin-handled genus-2 solid and a
  brain-like folded surface (both marching cubes of implicit functions);
- volumes (``VolumeSurface``, radius bound 1 voxel, cubic and linear)
  beside marching cubes (scikit-image): nilearn's MNI152 brain mask and grey-
  matter probability map (2 mm) and a ball with one-voxel specks; the
  reference components and Euler characteristic are those of marching cubes
  on the interpolant resampled twice as fine (a sampled reference;
  ``--reference-factor`` for finer: on the grey-matter map the cubic count is
  253, 235, 226, 222 and 226 at factors 2 to 6, so it is not converged), and
  each row records whether the mesh's sampled topological-ball tests held.

Each row: vertices, seconds, components, Euler characteristics, closed,
smallest angle, two-sided Hausdorff distance to the input (remeshing, as a
fraction of the diagonal), evaluations per vertex, whether the run is
complete, the seeding's level::

    python benchmarks/real_data.py [--quick] [--out results/real-data-DATE.json]
        [--only remesh|volume] [--cases bone,genus-2] [--sizes 0.01,0.003]
        [--repeat 3] [--inputs standard|more|all] [--edge-size 0.3]

``--edge-size K`` gives rdmesh protecting balls ``K`` times the radius bound
apart (``edge_size``; default: the radius bound): at 0.3 or less the angle
bound is held next to them too (``rdmesh.refine.criteria.SMALL_BALL``).

``--repeat N`` remeshes each case N times with each tool, alternating, and
records the median time (every time in ``times``): on a shared machine one
run of either can be 20 % off.

``--inputs more`` remeshes other real meshes instead (:func:`more_mesh_inputs`:
pymeshlab's other sample meshes and nilearn's other fsaverage5 surfaces).

``--quick`` runs the 1 % size only and leaves out the grey-matter map.
Needs ``pymeshlab``, ``nilearn`` and ``scikit-image`` (``pip install
pymeshlab nilearn scikit-image``); cases whose package is missing are
skipped with a note.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent


# -- inputs --------------------------------------------------------------------------


def _mc(f, lo, hi, h: float) -> tuple[np.ndarray, np.ndarray]:
    """Marching cubes of ``f < 0`` on a grid of spacing ``h`` over the box ``[lo, hi]``."""
    from skimage import measure

    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    n = np.ceil((hi - lo) / h).astype(int) + 1
    axes = [lo[a] + h * np.arange(n[a]) for a in range(3)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    v, faces, _, _ = measure.marching_cubes(f(pts).reshape(*n), 0.0, spacing=(h, h, h))
    return v + lo, faces.astype(np.int64)


def genus2_thin(h: float = 0.015) -> tuple[np.ndarray, np.ndarray]:
    """Two tori (major radius 1, tube radius 0.12) joined at one place: a genus-2 solid
    with thin handles (tube radius about 2.6 % of the diagonal)."""

    def f(p):
        x, y, z = p.T
        a = np.hypot(np.hypot(x - 1.05, y) - 1.0, z) - 0.12
        b = np.hypot(np.hypot(x + 1.05, y) - 1.0, z) - 0.12
        return np.minimum(a, b)

    return _mc(f, (-2.3, -1.25, -0.25), (2.3, 1.25, 0.25), h)


def folded(h: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """A brain-like folded closed surface: a sphere with deep sulci."""

    def f(p):
        r = np.linalg.norm(p, axis=1)
        return r - 1.0 - 0.07 * np.sin(9 * p[:, 0]) * np.sin(9 * p[:, 1]) * np.sin(9 * p[:, 2])

    return _mc(f, (-1.15,) * 3, (1.15,) * 3, h)


def height_sheet(kind: str, n: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """An open sheet over a grid of ``n`` x ``n`` vertices on [-1, 1]^2: ``"wavy"``
    (z = 0.15 sin 3x cos 2y, its sides tilted opposite ways) or ``"terrain"``
    (a few hills and a valley on a 2:1 rectangle)."""
    u, w = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    if kind == "wavy":
        z = 0.15 * np.sin(3 * u) * np.cos(2 * w)
    else:
        w = 0.5 * w
        hills = ((0.3, 0.2, 0.25, 0.3), (-0.4, -0.1, 0.15, 0.2), (0.5, -0.3, 0.2, -0.12))
        z = sum(a * np.exp(-((u - x) ** 2 + (w - y) ** 2) / s**2) for x, y, s, a in hills)
    v = np.c_[u.ravel(), w.ravel(), z.ravel()]
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    return v, np.r_[np.c_[a, b, c], np.c_[a, c, d]].astype(np.int64)


def cut_holes(v: np.ndarray, f: np.ndarray, k: int = 3, frac: float = 0.03):
    """``(v, f)`` without the faces within ``frac`` of the diagonal of ``k`` of its
    vertices (evenly spaced in index order): an open scan with ``k`` holes. Both
    rdmesh (``holes="keep"``) and pymeshlab keep them."""
    diag = np.linalg.norm(np.ptp(v, axis=0))
    centres = v[f].mean(axis=1)
    keep = np.ones(len(f), bool)
    for i in np.linspace(0, len(v) - 1, k + 2)[1:-1].astype(int):
        keep &= np.linalg.norm(centres - v[i], axis=1) > frac * diag
    return v, f[keep]


def specks(n: int = 48) -> np.ndarray:
    """A binary ball with five one-voxel specks beside it (6 components)."""
    g = np.indices((n, n, n)).transpose(1, 2, 3, 0) - n / 2
    vol = (np.linalg.norm(g - [-4, 0, 0], axis=-1) < 11).astype(float)
    for p in [(5, 5, 5), (42, 5, 36), (5, 42, 12), (36, 36, 40), (8, 24, 42)]:
        vol[p] = 1.0
    return vol


def mesh_inputs() -> dict[str, tuple[np.ndarray, np.ndarray] | str]:
    """name -> (vertices, faces), or a note saying why it is missing."""
    out: dict = {}
    try:
        import pymeshlab

        base = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes"
        for name, file in (("bunny (scan)", "bunny.obj"), ("bone", "bone.ply")):
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(str(base / file))
            m = ms.current_mesh()
            out[name] = (m.vertex_matrix().copy(), m.face_matrix().astype(np.int64))
        out["bunny, 3 holes cut (open scan)"] = cut_holes(*out["bunny (scan)"])
    except ImportError:
        out["bunny (scan)"] = out["bone"] = "pymeshlab not installed"
        out["bunny, 3 holes cut (open scan)"] = "pymeshlab not installed"
    try:
        from nilearn import datasets

        pial = datasets.load_fsaverage("fsaverage5")["pial"].parts["left"]
        out["cortex (fsaverage5 pial, left)"] = (
            np.asarray(pial.coordinates, float),
            np.asarray(pial.faces, np.int64),
        )
    except ImportError:
        out["cortex (fsaverage5 pial, left)"] = "nilearn not installed"
    out["genus-2, thin handles (synthetic)"] = genus2_thin()
    out["folded, brain-like (synthetic)"] = folded()
    return out


def more_mesh_inputs() -> dict[str, tuple[np.ndarray, np.ndarray] | str]:
    """More real meshes (``--inputs more``): pymeshlab's other sample meshes (a
    low-poly cow whose head's faces cross, an airplane, a 12-triangle cube, a
    10k bunny with its base open, a range scan), nilearn's fsaverage5
    surfaces (white matter, pial, inflated, sphere; both hemispheres: the right
    white and pial surfaces intersect themselves) and open sheets
    (:func:`height_sheet`, :func:`corner_sheets`)."""
    out: dict = {}
    try:
        import pymeshlab

        base = Path(pymeshlab.__file__).parent / "tests" / "sample_meshes"
        for file in ("cow.obj", "airplane.obj", "cube.obj", "bunny10k_textured.obj",
                     "rangemaps/face000.ply"):  # fmt: skip
            ms = pymeshlab.MeshSet()
            ms.load_new_mesh(str(base / file))
            m = ms.current_mesh()
            out[f"{Path(file).stem} (pymeshlab)"] = (
                m.vertex_matrix().copy(), m.face_matrix().astype(np.int64)
            )  # fmt: skip
    except ImportError:
        out["pymeshlab samples"] = "pymeshlab not installed"
    try:
        from nilearn import datasets

        fs = datasets.load_fsaverage("fsaverage5")
        for kind in ("white_matter", "pial", "inflated", "sphere"):
            for side in ("left", "right"):
                if (kind, side) == ("pial", "left"):
                    continue  # the standard set's cortex
                part = fs[kind].parts[side]
                out[f"fsaverage5 {kind}, {side}"] = (
                    np.asarray(part.coordinates, float), np.asarray(part.faces, np.int64)
                )  # fmt: skip
    except ImportError:
        out["fsaverage5"] = "nilearn not installed"
    out["open sheet, wavy (synthetic)"] = height_sheet("wavy")
    out["open sheet, terrain (synthetic)"] = height_sheet("terrain")
    out["open sheets, two sharing a corner (synthetic)"] = corner_sheets()
    return out


def corner_sheets(n: int = 120) -> tuple[np.ndarray, np.ndarray]:
    """The wavy :func:`height_sheet` and its copy turned half a turn about its corner
    (1, 1): two sheets whose rims touch at that point."""
    v, f = height_sheet("wavy", n)
    return np.r_[v, v * [-1, -1, 1] + [2, 2, 0]], np.r_[f, f + len(v)]


def volume_inputs(quick: bool) -> dict[str, np.ndarray | str]:
    out: dict = {}
    try:
        from nilearn import datasets

        mask = datasets.load_mni152_brain_mask(resolution=2)
        out["MNI152 brain mask (2 mm)"] = np.asarray(mask.get_fdata(), float)
        if not quick:
            gm = datasets.load_mni152_gm_template(resolution=2)
            out["MNI152 grey matter p=0.5 (2 mm)"] = np.asarray(gm.get_fdata(), float)
    except ImportError:
        out["MNI152 brain mask (2 mm)"] = "nilearn not installed"
    out["ball with one-voxel specks (synthetic)"] = specks()
    return out


# -- measures ------------------------------------------------------------------------


def topology(v: np.ndarray, f: np.ndarray) -> dict:
    """Components, Euler characteristic per component, closed (every edge in two faces)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    used, f = np.unique(f, return_inverse=True)
    f = f.reshape(-1, 3)
    n = len(used)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    edges, counts = np.unique(e, axis=0, return_counts=True)
    g = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    k, comp = connected_components(g, directed=False)
    chi = (
        np.bincount(comp, minlength=k)
        - np.bincount(comp[edges[:, 0]], minlength=k)
        + np.bincount(comp[f[:, 0]], minlength=k)
    )
    return {
        "components": int(k),
        "euler": sorted(int(c) for c in chi),
        "closed": bool(np.all(counts == 2)),
    }


def min_angle(v: np.ndarray, f: np.ndarray) -> float:
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    angles = []
    for p, q, r in ((a, b, c), (b, c, a), (c, a, b)):
        u, w = q - p, r - p
        cos = np.einsum("ij,ij->i", u, w) / (
            np.linalg.norm(u, axis=1) * np.linalg.norm(w, axis=1) + 1e-300
        )
        angles.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
    return float(np.min(angles))


def input_faces(ref) -> np.ndarray:
    """The input's faces of a MeshSurface (without the caps over its holes)."""
    return ref.faces[: ref.input_face_count]


def hausdorff(v, f, ref, n: int = 20000, seed: int = 0) -> float:
    """Two-sided Hausdorff distance between a mesh and the input ``ref``
    (a MeshSurface), from area-weighted samples plus the vertices both ways."""
    import rdmesh

    def samples(v, f):
        rng = np.random.default_rng(seed)
        a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        i = rng.choice(len(f), n, p=area / area.sum())
        u, w = rng.random((2, n))
        flip = u + w > 1
        u[flip], w[flip] = 1 - u[flip], 1 - w[flip]
        inside = a[i] + u[:, None] * (b[i] - a[i]) + w[:, None] * (c[i] - a[i])
        return np.concatenate([inside, v[np.unique(f)]])  # the faces' vertices too

    # Unsigned distances (no inside needed: an open sheet has none), to the
    # input's faces, not to what closed its holes.
    faces = input_faces(ref)
    to_out = rdmesh.core.MeshDistance(v, f, side=False)
    to_ref = rdmesh.core.MeshDistance(ref.vertices, faces, side=False)
    d1 = to_ref.query(samples(v, f))[0].max()
    d2 = to_out.query(samples(ref.vertices, faces))[0].max()
    return float(max(d1, d2))


def run_rdmesh_remesh(ref, r: float, edge: float | None = None) -> dict:
    import rdmesh

    t = time.perf_counter()
    try:
        size = None if edge is None else edge * r
        m = rdmesh.mesh_surface(ref, radius_bound=r, distance_bound=r / 10, edge_size=size)
        note = ""
    except rdmesh.BudgetExceeded as exc:
        m, note = exc.mesh, str(exc)
    sec = time.perf_counter() - t
    return {
        "mesh": m,
        "seconds": sec,
        "complete": m.complete,
        "evals_per_vertex": round(m.stats["evaluations"] / max(len(m.vertices), 1), 1),
        # Dual segments whose crossings a closed mesh gave exactly (not samples of f).
        "segments_per_vertex": round(
            m.stats.get("segment_queries", 0) / max(len(m.vertices), 1), 1
        ),
        "note": note or m.stats.get("stop_reason", ""),
        # The distance bound measured both ways (rdmesh.refine.deviation).
        "distance_check": m.stats.get("distance_check"),
    }


def run_pymeshlab(v, f, r: float):
    import pymeshlab

    ms = pymeshlab.MeshSet()
    ms.add_mesh(pymeshlab.Mesh(vertex_matrix=v, face_matrix=f.astype(np.int32)))
    t = time.perf_counter()
    ms.meshing_isotropic_explicit_remeshing(
        iterations=10,
        targetlen=pymeshlab.PureValue(math.sqrt(3) * r),
        maxsurfdist=pymeshlab.PureValue(r / 10),
    )
    sec = time.perf_counter() - t
    m = ms.current_mesh()
    return m.vertex_matrix().copy(), m.face_matrix().astype(np.int64), sec


def _alternating(runs, repeat: int) -> list[list]:
    """Each of ``runs`` (callables) ``repeat`` times, alternating which goes
    first; the results per run."""
    out: list[list] = [[] for _ in runs]
    for k in range(repeat):
        order = range(len(runs)) if k % 2 == 0 else reversed(range(len(runs)))
        for i in order:
            out[i].append(runs[i]())
    return out


def _median_seconds(results: list, key) -> tuple[float, list[float]]:
    times = [round(key(r), 3) for r in results]
    return float(np.median(times)), times


def remesh_rows(
    sizes: tuple[float, ...],
    cases: str | None = None,
    repeat: int = 1,
    inputs: str = "standard",
    edge: float | None = None,
) -> list[dict]:
    import rdmesh

    rows = []
    meshes = {} if inputs == "more" else mesh_inputs()
    if inputs != "standard":
        meshes.update(more_mesh_inputs())
    for name, data in meshes.items():
        if cases and not any(c in name for c in cases.split(",")):
            continue
        if isinstance(data, str):
            rows.append({"kind": "remesh", "case": name, "note": data})
            continue
        v, f = data
        try:
            ref = rdmesh.MeshSurface((v, f))
        except rdmesh.MeshInputError as exc:
            rows.append({"kind": "remesh", "case": name, "note": f"refused: {exc}"})
            continue
        # The input's own vertices (not those of tents closing its holes).
        used, faces = np.unique(input_faces(ref), return_inverse=True)
        iv, faces = ref.vertices[used], faces.reshape(-1, 3)
        diag = float(np.linalg.norm(np.ptp(iv, axis=0)))
        inp = topology(iv, faces)
        intersects = len(ref.self_intersections)
        for frac in sizes:
            r = frac * diag
            base = {"kind": "remesh", "case": name, "size": f"{100 * frac:g} %", "input": inp,
                    "input_self_intersections": intersects}  # fmt: skip
            try:
                import pymeshlab  # noqa: F401

                runs = [partial(run_rdmesh_remesh, ref, r, edge),
                        partial(run_pymeshlab, iv, faces, r)]  # fmt: skip
            except ImportError:
                runs = [partial(run_rdmesh_remesh, ref, r, edge)]
            done = _alternating(runs, repeat)
            run = dict(done[0][0])
            m = run.pop("mesh")
            run.pop("seconds")
            sec, times = _median_seconds(done[0], lambda x: x["seconds"])
            rows.append({
                **base, "mesher": "rdmesh", "vertices": len(m.vertices),
                **topology(m.vertices, m.faces),
                "min_angle": round(min_angle(m.vertices, m.faces), 1),
                "hausdorff_diag": round(hausdorff(m.vertices, m.faces, ref) / diag, 5),
                "seconds": round(sec, 2), "times": times, **run,
            })  # fmt: skip
            if len(done) > 1:
                pv, pf, _ = done[1][0]
                sec, times = _median_seconds(done[1], lambda x: x[2])
                rows.append({
                    **base, "mesher": "pymeshlab", "vertices": len(pv), **topology(pv, pf),
                    "min_angle": round(min_angle(pv, pf), 1),
                    "hausdorff_diag": round(hausdorff(pv, pf, ref) / diag, 5),
                    "seconds": round(sec, 2), "times": times,
                })  # fmt: skip
            print(json.dumps(rows[-2:], default=str), file=sys.stderr, flush=True)
    return rows


#: Finer factors tried when a sample lies exactly on the isovalue.
REFERENCE_RETRIES = 3


def _reference(surface, factor: int = 2) -> dict:
    """Marching cubes of the interpolant resampled ``factor`` times finer, closed by the box.

    A sample exactly at the isovalue breaks marching cubes' output (a binary
    mask's cubic interpolant is 0.5 at many voxel midpoints, by symmetry: the
    MNI152 mask at factor 2 had 3,627 such samples and gave Euler -131, not
    closed; at 3, none). Then the next factor is taken, up to
    :data:`REFERENCE_RETRIES` more; ``factor`` and ``samples_at_isovalue`` say
    which was used and how many such samples it had.
    """
    from skimage import measure

    for k in range(factor, factor + REFERENCE_RETRIES + 1):
        axes = [np.linspace(0, n - 1, k * (n - 1) + 1) for n in surface.shape]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
        world = surface.origin + grid * surface.spacing
        u = (surface.values(world) - surface.isovalue) * surface._sign
        on_iso = int(np.count_nonzero(u == 0))
        if on_iso == 0:
            break
    u = np.pad(u.reshape([len(a) for a in axes]), 1, constant_values=-1.0)
    v, f, _, _ = measure.marching_cubes(u, 0.0)
    _, inv = np.unique(np.round(v, 9), axis=0, return_inverse=True)
    f = inv.reshape(-1)[f]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    return {**topology(v, f), "factor": k, "samples_at_isovalue": on_iso}


def volume_rows(quick: bool, cases: str | None = None, factor: int = 2) -> list[dict]:
    import rdmesh
    from skimage import measure

    rows = []
    for name, vol in volume_inputs(quick).items():
        if cases and not any(c in name for c in cases.split(",")):
            continue
        if isinstance(vol, str):
            rows.append({"kind": "volume", "case": name, "note": vol})
            continue
        t = time.perf_counter()
        mv, mf, _, _ = measure.marching_cubes(np.pad(vol, 1), 0.5)
        sec = time.perf_counter() - t
        rows.append({
            "kind": "volume", "case": name, "mesher": "marching cubes", "vertices": len(mv),
            **topology(mv, mf), "min_angle": round(min_angle(mv, mf), 1), "seconds": round(sec, 3),
        })  # fmt: skip
        for interp in ("cubic", "linear"):
            s = rdmesh.VolumeSurface(vol, isovalue=0.5, interpolation=interp)
            ref = _reference(s, factor)
            t = time.perf_counter()
            try:
                m = rdmesh.mesh_surface(s, radius_bound=1.0)
                note = m.stats.get("stop_reason", "")
            except rdmesh.BudgetExceeded as exc:
                m, note = exc.mesh, str(exc)
            sec = time.perf_counter() - t
            rows.append({
                "kind": "volume", "case": name, "mesher": f"rdmesh {interp}",
                "isovalue": s.isovalue, "reference": ref, "vertices": len(m.vertices),
                **topology(m.vertices, m.faces),
                "min_angle": round(min_angle(m.vertices, m.faces), 1),
                "seconds": round(sec, 2), "complete": m.complete,
                "unresolved": len(m.unresolved),
                "seeding": m.report["seeding"]["level"],
                "tbp_holds": bool(m.report.get("tbp_holds", False)),
                "evals_per_vertex": round(m.stats["evaluations"] / max(len(m.vertices), 1), 1),
                "note": note,
            })  # fmt: skip
            print(json.dumps(rows[-1], default=str), file=sys.stderr, flush=True)
    return rows


def table(rows: list[dict]) -> str:
    head = (
        "| case | size | mesher | vertices | s | comps | Euler | closed | min angle | "
        "Hausdorff / diag | evals/vertex | segments/vertex | note |"
    )
    lines = [head, "|" + "---|" * 13]
    for r in rows:
        if "mesher" not in r:
            lines.append(f"| {r['case']} | | skipped | | | | | | | | | | {r['note']} |")
            continue
        ref = r.get("reference") or r.get("input")
        want = f" (want {ref['components']}, {ref['euler']})" if ref else ""
        euler = r["euler"] if len(r["euler"]) <= 6 else f"sum {sum(r['euler'])}"
        if ref and len(ref["euler"]) > 6:
            want = f" (want {ref['components']}, sum {sum(ref['euler'])})"
        lines.append(
            f"| {r['case']} | {r.get('size', '1 voxel')} | {r['mesher']} | {r['vertices']} | "
            f"{r['seconds']} | {r['components']} | {euler}{want} | {r['closed']} | "
            f"{r['min_angle']} | {r.get('hausdorff_diag', '')} | "
            f"{r.get('evals_per_vertex', '')} | {r.get('segments_per_vertex', '')} | "
            f"{str(r.get('note', ''))[:90]} |"
        )
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--out", default=None)
    ap.add_argument("--only", choices=("remesh", "volume"), default=None)
    ap.add_argument("--cases", default=None, help="comma-separated parts of case names")
    ap.add_argument("--sizes", default=None, help="comma-separated fractions of the diagonal")
    ap.add_argument("--repeat", type=int, default=1, help="runs of each remesher (median)")
    ap.add_argument(
        "--inputs",
        choices=("standard", "more", "all"),
        default="standard",
        help="remeshing: the issue's inputs, more real meshes (more_mesh_inputs), or both",
    )
    ap.add_argument(
        "--edge-size",
        type=float,
        default=None,
        help="remeshing: rdmesh's edge_size as a fraction of the radius bound",
    )
    ap.add_argument(
        "--reference-factor",
        type=int,
        default=2,
        help="volumes: the reference resamples the interpolant this many times finer",
    )
    args = ap.parse_args(argv)
    if args.repeat < 1:
        ap.error("--repeat must be at least 1")
    if args.reference_factor < 1:
        ap.error("--reference-factor must be at least 1")
    if args.edge_size is not None and not args.edge_size > 0:
        ap.error("--edge-size must be positive")
    if args.out:
        Path(args.out).parent.mkdir(parents=True, exist_ok=True)  # before the runs, not after
    sizes = (0.01,) if args.quick else (0.01, 0.003)
    if args.sizes:
        sizes = tuple(float(x) for x in args.sizes.split(","))
    rows = []
    if args.only != "volume":
        rows += remesh_rows(sizes, args.cases, args.repeat, args.inputs, args.edge_size)
    if args.only != "remesh":
        rows += volume_rows(args.quick, args.cases, args.reference_factor)
    from record import git_commit

    commit = git_commit()
    print(f"real data, {time.strftime('%Y-%m-%d')}, commit {commit}\n")
    print(table(rows))
    if args.out:
        Path(args.out).write_text(json.dumps({"commit": commit, "rows": rows}, default=str))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
