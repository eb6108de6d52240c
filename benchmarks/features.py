# SPDX-License-Identifier: GPL-3.0-or-later
"""Creases and corners (issue 27): meshers against shapes whose creases are known.

Cases (``CASES``):

- ``box``: the implicit cube ``max(|x|,|y|,|z|) - 1``, its 12 edges given as
  2-point polylines (exact);
- ``box_ball``: ``min(box, |p - (1,1,1)| - 0.8)``, its 12 straight creases
  and 3 quarter circles given as polylines, each arc as 64 chords
  (``cad_shapes.box_ball_curves``); the metrics measure against the exact
  arcs, so vertices on the arcs are up to the chords' sagitta (6.0e-5) off;
- ``box_mesh``, ``box_with_hole``, ``l_bracket``, ``fillet_chamfer``: the
  closed CAD meshes of ``cad_shapes`` to remesh, their sharp edges to be
  found by the mesher (feature angle 60); ``fillet_chamfer@40`` is the last
  one with feature angle 40, which finds its chamfer's two 45-degree creases.
- ``box_rotated``, ``cylinder``, ``lens``, ``box_dimple``, ``box_hole``
  (issue 28, ``crease_shapes``): expressions (``box_hole``: a
  ``rdmesh.csg.difference`` of two numpy callables) whose creases rdmesh
  finds by itself; given to the other meshers as polylines (circles as
  closed polylines of 512 chords, sagitta 1.9e-5 for a unit circle).

The ``rdmesh_found`` mesher meshes every implicit case from its expression
(or CSG tree) with nothing given: ``features="auto"`` finds the creases
(issue 28). Its rows add the curves and corners found, the search's seconds
and the places it left unresolved.

Settings: implicit cases angle 30, radius bound 0.1, distance bound 0.01,
edge size 0.1 (Mesh_3's oracle error bound 1e-8, as the design note's
measurement); mesh cases r = ``--cad-size`` (default 0.01) times the bounding
box diagonal, distance r / 10, edge size r.

Measured (``feature_metrics``), each against the exact curves: vertices;
crease coverage (share of the crease length covered by mesh edges lying on
it, within ``tol``); crease vertices (within ``tol`` of a curve: count and
largest distance); corners that are mesh vertices; for implicit cases the
largest ``|sdf|`` sampled on the triangles (exact SDF), for meshes the
sampled two-sided Hausdorff distance to the input (exact point-to-mesh
distances), also as a multiple of the distance bound; smallest angle overall
and away from the creases (triangles with no vertex within the edge size of
a curve); closed manifold, Euler characteristic, genus; the mesher's own
seconds.  ``tol`` is 1e-6 times the bounding-box diagonal, except box_ball's
1e-4 (above its polylines' sagitta).

Run: ``python benchmarks/features.py`` (about a minute after the CGAL
reference is built; building it takes about 4 minutes the first time).
Prints a markdown table and writes ``benchmarks/results/features-<date>.json``
(``-2``, ``-3``, ... for later runs of the same day); the output meshes go to
``<out>/tmp/features/`` (git-ignored).

Meshers register in ``MESHERS`` with :func:`register`::

    @register("name", kinds=("implicit", "mesh"), label="what it is")
    def run_name(case: Case, work: Path, timeout: float) -> MeshRun:
        ...

A mesher is a function of a :class:`Case` (``kind`` "implicit": ``f`` the
numpy function (``(N, 3) -> (N,)``, negative inside), ``bounding_sphere``,
``surface`` (the reference program's name), ``polylines`` (the creases it
is given: a list of ``(m, 3)`` arrays in order, meeting only at end points,
a closed loop repeating its first point last); ``kind`` "mesh": ``shape``
(a ``cad_shapes.CadShape``: ``vertices``, ``faces``) and ``feature_angle``;
both: ``angle``, ``radius``, ``distance``, ``edge_size``, ``seed``), a
scratch directory and a timeout; it returns a :class:`MeshRun` (vertices,
faces, its own meshing seconds, and any extra information for the JSON) or
raises :class:`Unavailable` (not installed: recorded, not an error).  Any
other exception is recorded as a failure of that run.  An rdmesh row is one
such function: ``rdmesh.mesh_surface`` on ``ImplicitSurface(case.f,
bounding_sphere=case.bounding_sphere, features=case.polylines)`` or on
``MeshSurface((case.shape.vertices, case.shape.faces),
feature_angle=case.feature_angle)``, with ``edge_size=case.edge_size``.
"""

from __future__ import annotations

import argparse
import datetime
import logging
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))

import cad_shapes  # noqa: E402
import cgal_runner  # noqa: E402
import crease_shapes  # noqa: E402
import feature_metrics as fm  # noqa: E402
import record  # noqa: E402
from meshfile import read_off  # noqa: E402

logger = logging.getLogger("features")

__all__ = ["CASES", "MESHERS", "Case", "MeshRun", "Mesher", "Unavailable", "main", "register"]


# ---------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------


@dataclass
class Case:
    """One shape with known creases and the criteria to mesh it with."""

    name: str
    kind: str  # "implicit" or "mesh"
    curves: list  # exact curves (feature_metrics), the ground truth
    corners: np.ndarray
    tol: float
    angle: float
    radius: float
    distance: float
    edge_size: float
    expected_genus: int
    description: str = ""
    # implicit cases
    surface: str | None = None
    expression: str | None = None  # what rdmesh_found meshes (issue 28)
    csg: Callable[[], Any] | None = None  # or this rdmesh surface
    f: Callable[[np.ndarray], np.ndarray] | None = None
    sdf: Callable[[np.ndarray], np.ndarray] | None = None
    bounding_sphere: tuple | None = None
    polylines: list[np.ndarray] | None = None
    error_bound: float | None = None
    # mesh cases
    shape: cad_shapes.CadShape | None = None
    feature_angle: float | None = None
    seed: int = 0
    extra: dict = field(default_factory=dict)


def _f_box(p: np.ndarray) -> np.ndarray:
    x, y, z = np.abs(np.asarray(p, dtype=np.float64)).T
    return np.maximum(np.maximum(x, y), z) - 1.0


def _f_box_ball(p: np.ndarray) -> np.ndarray:
    x, y, z = np.asarray(p, dtype=np.float64).T
    ball = np.sqrt((x - 1) ** 2 + (y - 1) ** 2 + (z - 1) ** 2) - cad_shapes.BALL_RADIUS
    return np.minimum(_f_box(p), ball)


def _implicit_case(name: str, curves, corners, f, sdf, tol: float, description: str) -> Case:
    return Case(
        name=name,
        kind="implicit",
        curves=curves,
        corners=corners,
        tol=tol,
        angle=30.0,
        radius=0.1,
        distance=0.01,
        edge_size=0.1,
        expected_genus=0,
        description=description,
        surface=name,
        f=f,
        sdf=sdf,
        bounding_sphere=cgal_runner.BOUNDING_SPHERES[name],
        polylines=cad_shapes.curve_polylines(curves, arc_segments=64),
        error_bound=1e-8,
        expression=crease_shapes.EXPRESSIONS.get(name),
    )


def _found_case(name: str) -> Case:
    """A shape of ``crease_shapes``: tol 1e-4 with circles (above their
    polylines' sagitta), else 1e-6 times the diagonal."""
    shape = crease_shapes.SHAPES[name]()
    circles = any(isinstance(c, fm.Circle) for c in shape.curves)
    case = _implicit_case(
        name, shape.curves, shape.corners, shape.f, shape.sdf,
        1e-4 if circles else 1e-6 * np.sqrt(12.0), shape.description,
    )  # fmt: skip
    case.polylines = crease_shapes.polylines(shape.curves)
    case.expression, case.csg = shape.expression, shape.csg
    case.expected_genus = shape.genus
    return case


def _mesh_case(name: str, shape_name: str, feature_angle: float, cad_size: float) -> Case:
    shape = cad_shapes.CAD_SHAPES[shape_name]()
    diag = shape.diagonal
    r = cad_size * diag
    return Case(
        name=name,
        kind="mesh",
        curves=shape.curve_objects(),
        corners=shape.corners,
        tol=1e-6 * diag,
        angle=30.0,
        radius=r,
        distance=r / 10,
        edge_size=r,
        expected_genus=shape.genus,
        description=shape.description,
        shape=shape,
        feature_angle=feature_angle,
        extra={"diagonal": diag, "crease_angles": shape.angles},
    )


#: The volume case: a ball of this radius sampled on VOLUME_N^3 points of
#: [-1, 1]^3 (so the box cuts it in six circles), meshed as a VolumeSurface
#: closed by its box.
VOLUME_BALL, VOLUME_N = 1.3, 48


def _volume_case() -> Case:
    """A ball cut by its volume's box: six circles of radius sqrt(1.3^2 - 1)
    on the faces, each given to the metrics as a 2048-chord polyline (the
    mesh follows the cubic interpolant's curve, about 1e-3 off the exact
    circle, so the tolerance is 2e-3)."""
    r = float(np.sqrt(VOLUME_BALL**2 - 1.0))
    t = np.linspace(0.0, 2 * np.pi, 2049)
    curves = []
    for axis in range(3):
        others = [k for k in range(3) if k != axis]
        for side in (-1.0, 1.0):
            p = np.zeros((len(t), 3))
            p[:, axis] = side
            p[:, others[0]] = r * np.cos(t)
            p[:, others[1]] = r * np.sin(t)
            p[-1] = p[0]
            curves.append(fm.Polyline(p))

    def sdf(q: np.ndarray) -> np.ndarray:
        ball = np.linalg.norm(q, axis=1) - VOLUME_BALL
        return np.maximum(ball, np.abs(q).max(axis=1) - 1.0)

    return Case(
        name="volume_ball", kind="volume", curves=curves, corners=np.zeros((0, 3)), tol=2e-3,
        angle=30.0, radius=0.1, distance=0.01, edge_size=0.1, expected_genus=0,
        description=f"ball of radius {VOLUME_BALL} sampled on {VOLUME_N}^3 points of [-1, 1]^3, "
        "closed by the box: 6 circles", sdf=sdf,
    )  # fmt: skip


def volume_surface(features=None):
    """The volume case's VolumeSurface."""
    import rdmesh

    g = np.linspace(-1.0, 1.0, VOLUME_N)
    x, y, z = np.meshgrid(g, g, g, indexing="ij")
    vol = VOLUME_BALL - np.sqrt(x * x + y * y + z * z)
    return rdmesh.VolumeSurface(
        vol, spacing=(2.0 / (VOLUME_N - 1),) * 3, origin=(-1.0, -1.0, -1.0), isovalue=0.0,
        features=features,
    )  # fmt: skip


def build_cases(cad_size: float = 0.01) -> dict[str, Callable[[], Case]]:
    """The cases by name, as constructors (a case is built only when run)."""
    cs = cad_shapes
    return {
        "box": lambda: _implicit_case(
            "box",
            cs.box_curves(),
            cs.box_corners(),
            _f_box,
            cs.box_sdf,
            1e-6 * np.sqrt(12.0),
            "max(|x|,|y|,|z|) - 1, 12 edges given",
        ),
        "box_ball": lambda: _implicit_case(
            "box_ball",
            cs.box_ball_curves(),
            cs.box_ball_corners(),
            _f_box_ball,
            cs.box_ball_sdf,
            1e-4,
            "min(box, |p - (1,1,1)| - 0.8), 12 segments + 3 arcs (64 chords) given",
        ),
        "box_mesh": lambda: _mesh_case("box_mesh", "box", 60.0, cad_size),
        "box_with_hole": lambda: _mesh_case("box_with_hole", "box_with_hole", 60.0, cad_size),
        "l_bracket": lambda: _mesh_case("l_bracket", "l_bracket", 60.0, cad_size),
        "fillet_chamfer": lambda: _mesh_case("fillet_chamfer", "fillet_chamfer", 60.0, cad_size),
        "fillet_chamfer@40": lambda: _mesh_case(
            "fillet_chamfer@40", "fillet_chamfer", 40.0, cad_size
        ),
        "volume_ball": _volume_case,
        **{name: (lambda name=name: _found_case(name)) for name in crease_shapes.SHAPES},
    }


CASES = tuple(build_cases())


# ---------------------------------------------------------------------------
# Meshers
# ---------------------------------------------------------------------------


@dataclass
class MeshRun:
    vertices: np.ndarray
    faces: np.ndarray
    seconds: float | None
    info: dict = field(default_factory=dict)


class Unavailable(RuntimeError):
    """The mesher cannot run here (not installed, not built)."""


@dataclass
class Mesher:
    name: str
    kinds: tuple[str, ...]
    label: str
    run: Callable[[Case, Path, float], MeshRun]


MESHERS: dict[str, Mesher] = {}


def register(name: str, kinds: tuple[str, ...], label: str = ""):
    """Register ``fn(case, work, timeout) -> MeshRun`` as mesher ``name`` for
    the case kinds ``kinds`` ("implicit", "mesh")."""

    def deco(fn):
        MESHERS[name] = Mesher(name, tuple(kinds), label or name, fn)
        return fn

    return deco


_CGAL: dict[str, Any] = {}


def _cgal_exe() -> Path:
    """The reference program, built once per process (Unavailable if it fails)."""
    if "exe" not in _CGAL:
        try:
            _CGAL["exe"] = cgal_runner.build_reference()
        except cgal_runner.CgalReferenceError as exc:
            _CGAL["exe"] = None
            _CGAL["why"] = str(exc).splitlines()[0]
    if _CGAL["exe"] is None:
        raise Unavailable(f"CGAL reference not built: {_CGAL['why']}")
    return _CGAL["exe"]


def _cgal_result(cmd: list[str], out: Path, what: str, timeout: float) -> MeshRun:
    res = cgal_runner.run_command(cmd, what=what, timeout=timeout)
    v, f = read_off(out)
    return MeshRun(v, f, float(res["seconds"]), {"cgal": res})


@register("input", kinds=("mesh",), label="the input mesh")
def run_input(case: Case, work: Path, timeout: float) -> MeshRun:
    return MeshRun(case.shape.vertices, case.shape.faces, None)


@register("cgal_mesh_3_features", kinds=("implicit",), label="Mesh_3, polylines given")
def run_cgal_features(case: Case, work: Path, timeout: float) -> MeshRun:
    exe = _cgal_exe()
    pl, out = work / f"{case.name}.polylines.txt", work / f"{case.name}-cgal_features.off"
    cgal_runner.write_polylines(pl, case.polylines)
    cmd = cgal_runner.features_command(
        exe,
        case.surface,
        pl,
        case.edge_size,
        case.angle,
        case.radius,
        case.distance,
        case.error_bound,
        seed=case.seed,
        out=out,
    )
    return _cgal_result(cmd, out, f"mesh_3_features on {case.name}", timeout)


@register("cgal_mesh_3", kinds=("implicit",), label="Mesh_3, no features")
def run_cgal_plain(case: Case, work: Path, timeout: float) -> MeshRun:
    exe = _cgal_exe()
    out = work / f"{case.name}-cgal_plain.off"
    cmd = cgal_runner.reference_command(
        exe,
        "mesh_3_fast",
        case.surface,
        case.angle,
        case.radius,
        case.distance,
        case.error_bound,
        seed=case.seed,
        out=out,
    )
    return _cgal_result(cmd, out, f"mesh_3_fast on {case.name}", timeout)


@register("cgal_mesh_3_polyhedron", kinds=("mesh",), label="Mesh_3, detect_features")
def run_cgal_polyhedron(case: Case, work: Path, timeout: float) -> MeshRun:
    exe = _cgal_exe()
    inp, out = work / f"{case.name}.off", work / f"{case.name}-cgal_polyhedron.off"
    cgal_runner.write_off(inp, case.shape.vertices, case.shape.faces)
    cmd = cgal_runner.polyhedron_command(
        exe,
        inp,
        case.feature_angle,
        case.edge_size,
        case.angle,
        case.radius,
        case.distance,
        seed=case.seed,
        out=out,
    )
    return _cgal_result(cmd, out, f"mesh_3_polyhedron on {case.name}", timeout)


def _rdmesh_run(surface, case: Case, features: bool) -> MeshRun:
    import time

    import rdmesh

    t0 = time.perf_counter()
    try:
        m = rdmesh.mesh_surface(
            surface,
            angle_bound=case.angle,
            radius_bound=case.radius,
            distance_bound=case.distance,
            edge_size=case.edge_size if features else None,
            seed=case.seed,
        )
    except rdmesh.BudgetExceeded as exc:
        m = exc.mesh
    seconds = time.perf_counter() - t0
    info = {"complete": m.complete, "stats_seconds": m.stats.get("seconds")}
    if m.report.get("creases") is not None:
        info["creases"] = m.report["creases"]
    if m.features is not None:
        info["features"] = m.features.as_report()
    return MeshRun(m.vertices, m.faces, seconds, info)


@register("rdmesh", kinds=("implicit", "mesh", "volume"), label="rdmesh, curves protected")
def run_rdmesh(case: Case, work: Path, timeout: float) -> MeshRun:
    import rdmesh

    if case.kind == "volume":
        return _rdmesh_run(volume_surface(), case, True)
    if case.kind == "implicit":
        s = rdmesh.ImplicitSurface(case.f, case.bounding_sphere, features=case.polylines)
    else:
        s = rdmesh.MeshSurface(
            (case.shape.vertices, case.shape.faces), feature_angle=case.feature_angle
        )
    return _rdmesh_run(s, case, True)


def _found_surface(case: Case):
    import rdmesh

    if case.csg is not None:
        return case.csg()
    return rdmesh.ImplicitSurface.from_expression(
        case.expression, case.bounding_sphere, name=case.name
    )


@register("rdmesh_found", kinds=("implicit",), label="rdmesh, creases found (nothing given)")
def run_rdmesh_found(case: Case, work: Path, timeout: float) -> MeshRun:
    run = _rdmesh_run(_found_surface(case), case, True)
    report = run.info.get("creases") or {}
    run.info["found"] = {
        k: report.get(k) for k in ("curves", "closed", "corners", "seconds", "level", "unresolved")
    }
    return run


@register("rdmesh_plain", kinds=("implicit", "mesh", "volume"), label="rdmesh, nothing protected")
def run_rdmesh_plain(case: Case, work: Path, timeout: float) -> MeshRun:
    import rdmesh

    if case.kind == "volume":
        return _rdmesh_run(volume_surface("none"), case, False)
    if case.kind == "implicit":
        s = rdmesh.ImplicitSurface(case.f, case.bounding_sphere, features="none")
    else:
        s = rdmesh.MeshSurface((case.shape.vertices, case.shape.faces), feature_angle=None)
    return _rdmesh_run(s, case, False)


# ---------------------------------------------------------------------------
# Measuring
# ---------------------------------------------------------------------------


def measure(case: Case, run: MeshRun, *, hausdorff_samples: int = 200_000) -> dict[str, Any]:
    """The feature metrics of one output (see the module docstring)."""
    v, f = run.vertices, run.faces
    cov = fm.crease_coverage(v, f, case.curves, case.tol)
    out: dict[str, Any] = {
        "vertices": int(len(np.unique(f))),
        "faces": int(len(f)),
        "seconds": run.seconds,
        "coverage": cov["coverage"],
        "coverage_per_curve": cov["per_curve"],
        "edges_on_curves": cov["edges_on_curves"],
        "tol": case.tol,
        "crease_vertices": fm.crease_vertex_distance(v, case.curves, case.tol),
        "corners": fm.corner_hits(v, case.corners, case.tol),
        "angles": fm.angles_away_from(v, f, case.curves, case.edge_size),
        "topology": fm.topology(v, f),
    }
    if case.kind == "mesh" and case.feature_angle is not None:
        sharp = [
            c
            for c, a in zip(case.curves, case.shape.angles, strict=True)
            if a > case.feature_angle
        ]
        if sharp and len(sharp) < len(case.curves):
            out["coverage_detectable"] = fm.crease_coverage(v, f, sharp, case.tol)["coverage"]
    if case.kind in ("implicit", "volume"):
        out["surface_distance"] = fm.surface_distance(v, f, case.sdf)
        out["distance_over_bound"] = out["surface_distance"]["max"] / case.distance
    else:
        h = fm.mesh_hausdorff(
            v, f, case.shape.vertices, case.shape.faces, n_random=hausdorff_samples
        )
        out["hausdorff"] = h
        out["distance_over_bound"] = h["two_sided"] / case.distance
    return out


def _fmt(x, spec: str = ".3g", none: str = "—") -> str:
    if x is None:
        return none
    return format(x, spec)


def table(runs: list[dict]) -> str:
    """The markdown table of the runs."""
    head = (
        "| case | mesher | vertices | crease coverage | crease vertices (max dist) | corners "
        "| surface dist. / Hausdorff (× bound) | min angle (away) | χ | genus | s |"
    )
    lines = [head, "|" + "---|" * 11]
    for r in runs:
        if r["status"] != "ok":
            lines.append(
                f"| {r['case']} | {r['mesher']} | {r['status']}: {r.get('error', '')} |" + " |" * 8
            )
            continue
        m = r["metrics"]
        cov = f"{100 * m['coverage']:.1f} %"
        if "coverage_detectable" in m:
            cov += f" ({100 * m['coverage_detectable']:.1f} % of the detectable)"
        cv = m["crease_vertices"]
        dist = (
            m["surface_distance"]["max"]
            if "surface_distance" in m
            else m["hausdorff"]["two_sided"]
        )
        ang = m["angles"]
        t = m["topology"]
        chi = str(t["euler"]) + ("" if t["closed_manifold"] else " (not closed)")
        lines.append(
            f"| {r['case']} | {r['mesher']} | {m['vertices']:,} | {cov} "
            f"| {cv['count']} ({_fmt(cv['max_distance'], '.1e')}) "
            f"| {m['corners']['hit']}/{m['corners']['corners']} "
            f"| {_fmt(dist, '.2g')} ({_fmt(m['distance_over_bound'], '.2g')}) "
            f"| {_fmt(ang['min_angle'], '.1f')}° ({_fmt(ang['min_angle_away'], '.1f')}°) "
            f"| {chi} | {_fmt(t['genus'], 'd')} | {_fmt(m['seconds'], '.2f')} |"
        )
    return "\n".join(lines)


def _out_path(out: Path) -> Path:
    stem = f"features-{datetime.date.today().isoformat()}"
    path, k = out / f"{stem}.json", 2
    while path.exists():
        path, k = out / f"{stem}-{k}.json", k + 1
    return path


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--cases", nargs="+", choices=CASES, default=list(CASES))
    p.add_argument("--meshers", nargs="+", choices=tuple(MESHERS), default=list(MESHERS))
    p.add_argument("--cad-size", type=float, default=0.01, help="r / bbox diagonal (meshes)")
    p.add_argument("--timeout", type=float, default=1800.0, help="seconds per run")
    p.add_argument("--hausdorff-samples", type=int, default=200_000)
    p.add_argument("--out", type=Path, default=HERE / "results")
    p.add_argument("--no-json", action="store_true", help="print the table only")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s", stream=sys.stderr)

    builders = build_cases(args.cad_size)
    work = args.out / "tmp" / "features"
    work.mkdir(parents=True, exist_ok=True)
    rec: dict[str, Any] = {
        "kind": "features",
        "date": datetime.datetime.now().isoformat(timespec="seconds"),
        "machine": record.machine_info(),
        "versions": record.package_versions(),
        "settings": {
            "cad_size": args.cad_size,
            "hausdorff_samples": args.hausdorff_samples,
            "implicit": {"angle": 30, "radius": 0.1, "distance": 0.01, "edge_size": 0.1},
            "arc_segments": 64,
            "circle_segments": crease_shapes.ARC_SEGMENTS,
        },
        "cases": {},
        "runs": [],
    }
    path = None if args.no_json else _out_path(args.out)
    for name in args.cases:
        case = builders[name]()
        rec["cases"][name] = {
            "kind": case.kind,
            "description": case.description,
            "curves": len(case.curves),
            "crease_length": float(sum(c.length for c in case.curves)),
            "corners": int(len(case.corners)),
            "tol": case.tol,
            "angle": case.angle,
            "radius": case.radius,
            "distance": case.distance,
            "edge_size": case.edge_size,
            "feature_angle": case.feature_angle,
            "error_bound": case.error_bound,
            "expected_genus": case.expected_genus,
            **case.extra,
        }
        for mname in args.meshers:
            mesher = MESHERS[mname]
            if case.kind not in mesher.kinds:
                continue
            entry: dict[str, Any] = {"case": name, "mesher": mname, "label": mesher.label}
            t0 = time.perf_counter()
            try:
                run = mesher.run(case, work, args.timeout)
                entry["status"] = "ok"
                entry["info"] = run.info
                entry["metrics"] = measure(case, run, hausdorff_samples=args.hausdorff_samples)
            except Unavailable as exc:
                entry["status"], entry["error"] = "unavailable", str(exc)
            except Exception as exc:  # a failed run is a result, not a crash
                logger.exception("%s on %s failed", mname, name)
                entry["status"] = "failed"
                entry["error"] = f"{type(exc).__name__}: {str(exc).splitlines()[0][:200]}"
            entry["wall_seconds"] = time.perf_counter() - t0
            rec["runs"].append(entry)
            logger.info(
                "%s / %s: %s (%.1f s)", name, mname, entry["status"], entry["wall_seconds"]
            )
            if path is not None:
                record.save(rec, path)
    print(table(rec["runs"]))
    if path is not None:
        print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
