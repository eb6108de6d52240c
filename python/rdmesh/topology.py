"""The topological ball property (Cheng-Dey-Ramos-Ray) and the topology report.

A sample set has the topological ball property (TBP) when every Voronoi face
meets the surface in a closed ball of one dimension less, transversally; the
restricted Delaunay triangulation is then homeomorphic to the surface
(Edelsbrunner-Shah). The tests, in the order the refinement repairs them
(algorithm.md, 3.2-3.4):

``voronoi_edge`` (T1)
    A restricted facet whose dual Voronoi edge crosses the surface more than
    once, or tangentially (the facet's ``TOPO`` flag). Repair: the crossing
    with the largest surface Delaunay ball.
``voronoi_facet`` (T2, crossing count)
    The boundary of the Voronoi facet dual to a Delaunay edge ``pq`` crosses
    the surface as often as the dual edges of the facets around ``pq`` do;
    with T1 holding that is the number of restricted facets at ``pq``. One arc
    means exactly 2 (0 means no arc or a closed loop); 1, 3 or 4 and more are
    violations. Repair: the largest incident surface ball.
``voronoi_loop`` (T2, loops and folds)
    A closed loop of the surface inside a Voronoi facet, or an arc that turns
    back along its chord, found by damped Newton from a few seeds per facet
    (:mod:`rdmesh.voronoi_loops`). Repair: the point of the facet's
    intersection found farthest from ``p``, the centre of an empty ball.
``disk`` (T3)
    The restricted triangles at a sample must form one disk (one fan).
    Repair: the largest incident surface ball.
``isolated`` (T3)
    A sample with no restricted triangle. Repair: a crossing of a shot from the
    sample that lies in its Voronoi cell.
``silhouette`` (T3)
    A point of the surface in the Voronoi cell ``V_p`` whose normal makes an
    angle of 90 degrees or more with the normal at ``p`` (a silhouette point
    of ``W_p = V_p ∩ Σ`` seen along ``n_p``; without one a connected ``W_p``
    bounded by one cycle is a disk). Tested on probes: a dense point set on the
    surface, assigned to cells by nearest sample. Refinement uses a stricter
    angle (:data:`CELL_NORMAL_ANGLE`). Repair: the probe of the cell farthest
    from ``p``, the centre of an empty ball since it lies in ``V_p``.

The crossing-count, disk and isolated tests are exact combinatorial tests on
the restricted complex; the Voronoi-edge crossings they rest on are found by
sampling each edge (with a dip search), the loop test samples each facet with
Newton seeds, and the silhouette test samples each cell with the probes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .complex import complex_status, euler_characteristics, largest_incident
from .oracles import ImplicitSurface
from .roots import SegmentSamples, line_crossings
from .voronoi_loops import LoopMemo, loop_test

#: The tests, in repair order.
TESTS = ("voronoi_edge", "voronoi_facet", "voronoi_loop", "disk", "isolated", "silhouette")
#: Refinement threshold of the silhouette test (degrees between the normal at a
#: probe and at its nearest sample). Below 90 so that probes see a silhouette
#: before it lies between two probes; lower values also bound normal deviation.
CELL_NORMAL_ANGLE = 80.0
#: The report's silhouette test: a probe normal at 90 degrees or more.
SILHOUETTE_ANGLE = 90.0
#: Wanted number of probes on the surface.
PROBE_TARGET = 30000

_BASIS = {
    "voronoi_edge": (
        "sampled",
        "each restricted facet's dual Voronoi edge meets the surface once, transversally; "
        "crossings are found by sampling the edge at the surface-ball spacing plus a "
        "search of |f| dips, not by interval arithmetic",
    ),
    "voronoi_facet": (
        "exact given voronoi_edge",
        "every Voronoi facet's boundary crosses the surface 0 or 2 times (every complex "
        "edge has exactly 2 restricted triangles); what lies inside a facet is the "
        "voronoi_loop test's",
    ),
    "voronoi_loop": (
        "sampled",
        "no Voronoi facet meets the surface in a closed loop or in an arc that turns back "
        "along its chord: damped Newton on {f = 0, <grad f, e2> = 0} in the facet plane "
        "from a few seeds per facet (a loop or fold missed by every seed is not seen). "
        "Facets of complex edges (2 crossings a, b): a fold is also seen when the arc runs "
        "backwards along the chord at one crossing; a facet whose arc leaves both crossings "
        "within 60 degrees of the chord, in the same direction, with no turn predicted "
        "within one chord length of the chord's midpoint by the gradients at a and b "
        "(linearly interpolated), gets no seed; otherwise the seeds are that predicted turn "
        "(when inside the polygon) and, when the arc leaves a crossing at more than 60 "
        "degrees from the chord, the chord's quarter points and the polygon's centroid. "
        "Facets without crossings are tested only where a probe lies within the probe "
        "spacing of them (seeds: that probe and the centroid); without probes, not at all",
    ),
    "disk": (
        "exact",
        "the restricted triangles around every sample form one disk (one fan)",
    ),
    "isolated": ("exact", "every sample has restricted triangles"),
    "silhouette": (
        "sampled",
        "no probe in a Voronoi cell V_p has a normal at 90 degrees or more from the normal "
        "at p; probes sample the surface, so features smaller than their spacing can hide",
    ),
}


@dataclass
class Probes:
    """Points on the surface with unit normals, for the cell tests.

    Attributes
    ----------
    points : (n, 3)
    normals : (n, 3) unit gradients (zero where the gradient vanishes).
    spacing : the scale they resolve (the seeding grid spacing).
    """

    points: np.ndarray
    normals: np.ndarray
    spacing: float

    @classmethod
    def on(cls, surface: ImplicitSurface, points: np.ndarray, spacing: float) -> Probes:
        return cls(points, unit_normals(surface, points), spacing)


def unit_normals(surface: ImplicitSurface, x: np.ndarray) -> np.ndarray:
    """Unit gradients at ``(n, 3)`` points; zero rows where the gradient is zero."""
    if len(x) == 0:
        return np.zeros((0, 3))
    g = surface.grad(x)
    n = np.linalg.norm(g, axis=1)
    return g / np.where(n > 0, n, np.inf)[:, None]


@dataclass
class Violations:
    """One test's outcome: how many elements fail, and their refinement points.

    ``centres``/``radii`` are empty balls (centre on the surface, no sample
    inside), at most one per failing element.
    """

    kind: str
    count: int
    centres: np.ndarray
    radii: np.ndarray


def _none(kind: str) -> Violations:
    return Violations(kind, 0, np.zeros((0, 3)), np.zeros(0))


def voronoi_edge_test(tri, centres, radii, flags, topo_bit: int) -> Violations:
    """T1: restricted facets whose dual edge crosses several times or tangentially."""
    bad = (flags & topo_bit) != 0
    return Violations("voronoi_edge", int(bad.sum()), centres[bad], radii[bad])


def voronoi_facet_test(status, centres, radii, allow_boundary: bool = False) -> Violations:
    """T2 crossing count: complex edges with other than 2 restricted triangles
    (only more than 2 with ``allow_boundary``, as CGAL's Manifold_with_boundary_tag)."""
    bad = status.bad_edges(allow_boundary)
    if bad.size == 0:
        return _none("voronoi_facet")
    f_idx, slot = np.nonzero(np.isin(status.facet_edges, bad))
    pick = largest_incident(status.facet_edges[f_idx, slot], f_idx, radii)
    return Violations("voronoi_facet", int(bad.size), centres[pick], radii[pick])


def voronoi_loop_test(
    surface, rdt, vertices, tri, centres, status, probes=None, tree=None, memo=None
) -> Violations:
    """T2 loops and folds inside Voronoi facets (:func:`rdmesh.voronoi_loops.loop_test`)."""
    v = loop_test(surface, rdt, vertices, tri, centres, status, probes, tree, memo)
    return Violations("voronoi_loop", len(v.edges), v.centres, v.radii)


def disk_test(status, tri, centres, radii) -> Violations:
    """T3 disk test: samples whose restricted triangles form more than one fan."""
    bad = np.flatnonzero(status.vertex_fans > 1)
    if bad.size == 0:
        return _none("disk")
    f_idx, corner = np.nonzero(np.isin(tri, bad))
    pick = largest_incident(tri[f_idx, corner], f_idx, radii)
    return Violations("disk", int(bad.size), centres[pick], radii[pick])


def isolated_samples(tri: np.ndarray, n_vertices: int) -> np.ndarray:
    """Ids of the samples without a restricted triangle."""
    used = np.zeros(n_vertices, bool)
    used[tri.ravel()] = True
    return np.flatnonzero(~used)


def isolated_test(surface, vertices, tri, tree=None) -> Violations:
    """T3: samples with no restricted triangle, with a point of their cell each.

    Shoots from each such sample p along and around -n and +n; the first
    crossing whose nearest sample is p lies in p's Voronoi cell, so it is the
    centre of an empty ball of radius |x - p|. Samples none of whose shots
    lands in their cell count as violations without a point.
    """
    lonely = isolated_samples(tri, len(vertices))
    if lonely.size == 0:
        return _none("isolated")
    x, r = shoot_from(surface, vertices, lonely, tree)
    return Violations("isolated", int(lonely.size), x, r)


def shoot_from(surface, vertices, ids, tree=None):
    """For each sample in ``ids``: the farthest first crossing of its shots that
    lies in its Voronoi cell, ``(x (k, 3), r (k,))`` for the samples that have one."""
    p = vertices[ids]
    n = surface.grad(p)
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    dirs = shot_directions(n)  # (len(p), D, 3)
    D = dirs.shape[1]
    owner = np.repeat(np.arange(len(p)), D)
    d = dirs.reshape(-1, 3)
    R = surface.radius
    start = p[owner] + 1e-6 * R * d
    # Run each shot to the bounding sphere.
    f = start - surface.centre
    b = np.einsum("ij,ij->i", f, d)
    c = np.einsum("ij,ij->i", f, f) - R * R
    length = -b + np.sqrt(np.maximum(b * b - c, 0.0))
    rows = np.flatnonzero(length > 0)
    samples = SegmentSamples.uniform(length[rows], 64)
    cr = line_crossings(surface, start[rows], d[rows], samples, xatol=1e-9 * R)
    if cr.segment.size == 0:
        return np.zeros((0, 3)), np.zeros(0)
    first = np.r_[True, cr.segment[1:] != cr.segment[:-1]]
    seg, x = rows[cr.segment[first]], cr.point[first]
    _, nearest = (tree or cKDTree(vertices)).query(x)
    me = ids[owner[seg]]
    valid = nearest == me
    seg, x, me = seg[valid], x[valid], me[valid]
    r = np.linalg.norm(x - vertices[me], axis=1)
    pick = largest_incident(me, np.arange(len(x)), r)
    return x[pick], r[pick]


def shot_directions(n: np.ndarray) -> np.ndarray:
    """Directions at 0, 30 and 60 degrees around -n and +n, ``(k, 26, 3)``."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(n, t1)
    out = []
    for sgn in (-1.0, 1.0):
        out.append(sgn * n)
        for tilt in (np.pi / 6, np.pi / 3):
            for phi in np.arange(6) * np.pi / 3:
                out.append(
                    sgn * np.cos(tilt) * n + np.sin(tilt) * (np.cos(phi) * t1 + np.sin(phi) * t2)
                )
    return np.stack(out, axis=1)


def silhouette_test(
    probes: Probes, vertices: np.ndarray, vnormals: np.ndarray, angle: float, tree=None
) -> Violations:
    """T3 silhouette proxy: cells holding a probe whose normal is ``angle`` or more
    degrees from the sample's normal (or a sample or probe without a normal).

    Every probe is assigned to its nearest sample (exactly membership of the
    Voronoi cell). The point of a failing cell is its probe farthest from the
    sample: on the surface and in ``V_p``, so the centre of an empty ball.
    """
    if len(probes.points) == 0 or len(vertices) == 0:
        return _none("silhouette")
    dist, owner = (tree or cKDTree(vertices)).query(probes.points)
    dot = np.einsum("ij,ij->i", probes.normals, vnormals[owner])
    unknown = ~np.any(probes.normals != 0, axis=1) | ~np.any(vnormals[owner] != 0, axis=1)
    bad_probe = (dot <= math.cos(math.radians(angle)) + 1e-12) | unknown
    bad_cell = np.zeros(len(vertices), bool)
    bad_cell[owner[bad_probe]] = True
    sel = np.flatnonzero(bad_cell[owner] & (dist > 0))
    count = int(bad_cell.sum())
    if sel.size == 0:
        return Violations("silhouette", count, np.zeros((0, 3)), np.zeros(0))
    pick = largest_incident(owner[sel], sel, dist)
    return Violations("silhouette", count, probes.points[pick], dist[pick])


#: Starts of the singular-point search: probes with the weakest gradient, plus
#: as many random ones.
SINGULAR_STARTS = 256
SINGULAR_ITERATIONS = 25


def singular_points(surface: ImplicitSurface, probes: Probes, seed: int = 0) -> np.ndarray:
    """Points of the surface where the gradient vanishes, found by Newton's method.

    Solves ``grad f = 0`` (Hessian by central differences of the gradient,
    damped least squares, so curves of singular points work too) from the
    probes with the weakest gradient and from random probes, and keeps the
    solutions where ``f`` is zero to within ``1e-6 R`` times the median probe
    gradient. Sampled: a singular point with no start nearby is missed.

    Returns
    -------
    (k, 3) singular points (de-duplicated to about ``1e-3 R``).
    """
    pts = probes.points
    if len(pts) == 0:
        return np.zeros((0, 3))
    R = surface.radius
    gn = np.linalg.norm(surface.grad(pts), axis=1)
    scale = float(np.median(gn))
    if not scale > 0:
        return np.zeros((0, 3))
    rng = np.random.default_rng(seed)
    weak = np.argsort(gn, kind="stable")[:SINGULAR_STARTS]
    rand = rng.choice(len(pts), min(SINGULAR_STARTS, len(pts)), replace=False)
    x = pts[np.unique(np.concatenate([weak, rand]))].copy()
    h = 1e-5 * R
    eye = np.eye(3)
    for _ in range(SINGULAR_ITERATIONS):
        g = surface.grad(x)
        cols = surface.grad(
            np.concatenate([x + s * h * eye[k] for k in range(3) for s in (1.0, -1.0)])
        ).reshape(3, 2, len(x), 3)
        H = np.stack([(cols[k, 0] - cols[k, 1]) / (2 * h) for k in range(3)], axis=2)
        HtH = np.einsum("nji,njk->nik", H, H)
        mu = 1e-12 * np.maximum(np.einsum("nii->n", HtH), 1e-300)
        A = HtH + mu[:, None, None] * eye
        step = -np.linalg.solve(A, np.einsum("nji,nj->ni", H, g)[:, :, None])[:, :, 0]
        norm = np.linalg.norm(step, axis=1)
        x = x + step * np.minimum(1.0, probes.spacing / np.maximum(norm, 1e-300))[:, None]
        inside = np.linalg.norm(x - surface.centre, axis=1) < R
        x = x[inside]
        if len(x) == 0:
            return np.zeros((0, 3))
    f = surface(x)
    g = np.linalg.norm(surface.grad(x), axis=1)
    sing = (np.abs(f) <= 1e-6 * R * scale) & (g <= 1e-4 * scale)
    x = x[sing]
    if len(x) == 0:
        return x
    from . import _rdt

    return x[np.sort(_rdt.select_independent(x, np.full(len(x), 1e-3 * R)))]


def regions(points: np.ndarray, link: float) -> list[dict[str, Any]]:
    """Clusters of points (single linkage at distance ``link``), largest first:
    ``centre``, ``radius`` and ``points`` of each, to name where problems are."""
    if len(points) == 0:
        return []
    pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
    n = len(points)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    k, label = connected_components(g, directed=False)
    out = []
    for c in np.argsort(-np.bincount(label))[:k]:
        p = points[label == c]
        centre = p.mean(axis=0)
        out.append(
            {
                "centre": [round(float(v), 6) for v in centre],
                "radius": float(np.linalg.norm(p - centre, axis=1).max()),
                "points": len(p),
            }
        )
    return out


def describe_regions(rs: list[dict[str, Any]], limit: int = 5) -> str:
    """Short text naming regions, e.g. ``near (0, 0, 0) r 0.01 (12 points)``."""
    parts = [
        f"near ({', '.join(f'{v:.4g}' for v in r['centre'])}) radius {r['radius']:.3g} "
        f"({r['points']} points)"
        for r in rs[:limit]
    ]
    if len(rs) > limit:
        parts.append(f"and {len(rs) - limit} more")
    return "; ".join(parts)


def run_tests(
    surface: ImplicitSurface,
    vertices: np.ndarray,
    tri: np.ndarray,
    centres: np.ndarray,
    flags: np.ndarray,
    probes: Probes | None,
    topo_bit: int,
    silhouette_angle: float = SILHOUETTE_ANGLE,
    only: tuple[str, ...] = TESTS,
    rdt=None,
    memo: LoopMemo | None = None,
):
    """Yield the :class:`Violations` of each test in ``only``, in repair order.

    A generator, so that a caller that stops at the first failing test does
    not pay for the later ones. The loop test needs the core ``rdt`` (skipped
    without it); ``memo`` lets it skip facets unchanged since found clean.
    """
    radii = np.linalg.norm(centres - vertices[tri[:, 0]], axis=1) if len(tri) else np.zeros(0)
    status = None
    tree = None
    for kind in only:
        if kind == "voronoi_edge":
            yield voronoi_edge_test(tri, centres, radii, flags, topo_bit)
        elif kind in ("voronoi_facet", "voronoi_loop", "disk"):
            if status is None:
                status = complex_status(tri, len(vertices))
            if kind == "voronoi_facet":
                yield voronoi_facet_test(status, centres, radii)
            elif kind == "disk":
                yield disk_test(status, tri, centres, radii)
            elif rdt is not None:
                tree = tree or cKDTree(vertices)
                yield voronoi_loop_test(
                    surface, rdt, vertices, tri, centres, status, probes, tree, memo
                )
        elif kind == "isolated":
            tree = tree or cKDTree(vertices)
            yield isolated_test(surface, vertices, tri, tree)
        elif kind == "silhouette" and probes is not None:
            tree = tree or cKDTree(vertices)
            vn = unit_normals(surface, vertices)
            yield silhouette_test(probes, vertices, vn, silhouette_angle, tree)


def topology_report(
    *,
    method: str,
    surface: ImplicitSurface,
    vertices: np.ndarray,
    tri: np.ndarray,
    centres: np.ndarray,
    flags: np.ndarray,
    probes: Probes | None,
    topo_bit: int,
    faces: np.ndarray,
    n_mesh_vertices: int,
    repaired: dict[str, int],
    unresolved: np.ndarray,
    complete: bool,
    critical=None,
    floor: float | None = None,
    rdt=None,
    memo: LoopMemo | None = None,
) -> dict[str, Any]:
    """The topology report of a finished run (see :attr:`SurfaceMesh.report`).

    The tests are re-run on the final samples; ``faces`` is the output mesh
    (restricted facets) for components and Euler characteristics. The loop
    test needs the core ``rdt``; ``memo`` skips facets already found clean.
    """
    tests: dict[str, dict[str, Any]] = {}
    where = []
    for v in run_tests(
        surface, vertices, tri, centres, flags, probes, topo_bit, rdt=rdt, memo=memo
    ):
        basis, what = _BASIS[v.kind]
        tests[v.kind] = {
            "held": v.count == 0,
            "violations": v.count,
            "repaired": int(repaired.get(v.kind, 0)),
            "basis": basis,
            "tests": what,
        }
        where.append(v.centres)
    for kind in ("voronoi_loop", "silhouette"):
        if kind not in tests:
            tests[kind] = {
                "held": None,
                "violations": None,
                "repaired": 0,
                "basis": "not tested",
                "tests": _BASIS[kind][1],
            }
    tests = {k: tests[k] for k in TESTS}
    chi = euler_characteristics(faces, n_mesh_vertices)
    # The output faces are the restricted facets: every edge in two faces is
    # the Voronoi-facet test, one fan per vertex is the disk test.
    closed = bool(len(faces) and tests["voronoi_facet"]["held"] and tests["disk"]["held"])
    link = 0.05 * surface.radius
    unresolved_regions = regions(unresolved, link)
    violation_regions = regions(np.concatenate(where) if where else np.zeros((0, 3)), link)
    singular = singular_points(surface, probes) if probes is not None else np.zeros((0, 3))
    all_held = all(t["held"] is True for t in tests.values())
    holds = bool(
        all_held and complete and len(unresolved) == 0 and len(faces) > 0 and len(singular) == 0
    )
    report: dict[str, Any] = {
        "method": method,
        "tbp_holds": holds,
        "tests": tests,
        "components": len(chi),
        "euler": chi,
        "closed_manifold": closed,
        "complete": complete,
        "unresolved": len(unresolved),
        "unresolved_regions": unresolved_regions,
        "violation_regions": violation_regions,
        "singular_points": {
            "count": len(singular),
            "regions": regions(singular, link),
            "basis": "sampled (Newton on grad f = 0 from the probes)",
        },
        "probes": None
        if probes is None
        else {"count": len(probes.points), "spacing": float(probes.spacing)},
        "spacing_floor": floor,
        "critical_points": None,
    }
    if critical is not None:
        morse = critical.euler
        report["critical_points"] = {
            "direction": [float(v) for v in critical.direction],
            "count": len(critical.points),
            "saddles": int(critical.saddle.sum()),
            "degenerate": int(critical.degenerate.sum()),
            "morse_euler": morse,
            "agrees_with_mesh": bool(morse == sum(chi)) and not critical.degenerate.any(),
        }
    report["statement"] = _statement(report)
    return report


def _statement(rep: dict[str, Any]) -> str:
    """Plain wording of what the report certifies and what rests on sampling."""
    tests = rep["tests"]
    failed = [k for k, t in tests.items() if t["held"] is False]
    untested = [k for k, t in tests.items() if t["held"] is None]
    spacing = rep["probes"]["spacing"] if rep["probes"] else None
    probe_text = (
        f"probes on the surface at spacing about {spacing:.3g}" if spacing else "no probes"
    )
    lines = []
    if rep["tbp_holds"]:
        lines.append(
            "Every topological-ball test held on the final samples, so the mesh is "
            "homeomorphic to the surface provided the sampled tests are right: "
            "exact (combinatorial): every complex edge has 2 triangles (Voronoi-facet "
            "crossing count), every sample has one disk of triangles, no sample lacks "
            "triangles; sampled: one transversal crossing per Voronoi edge (edge "
            f"sampling plus dip search, no interval arithmetic), no closed loop or folded "
            "arc inside a Voronoi facet (damped Newton from a few seeds per facet; facets "
            "without boundary crossings only where a probe is near them), no silhouette "
            f"point in any Voronoi cell ({probe_text}). Features smaller than the probe "
            "spacing, and loops no seed leads to, can be missed."
        )
    else:
        why = []
        if failed:
            why.append("tests failed: " + ", ".join(failed))
        if untested:
            why.append("not tested: " + ", ".join(untested))
        if rep["unresolved"]:
            why.append(
                f"{rep['unresolved']} refinement points were below the spacing floor "
                f"({describe_regions(rep['unresolved_regions'])}); the surface may be "
                "singular or nearly singular there"
            )
        if rep["singular_points"]["count"]:
            why.append(
                "the gradient of f vanishes on the surface "
                + describe_regions(rep["singular_points"]["regions"])
                + ": the surface is singular there and no sampling certifies its topology"
            )
        if not rep["complete"]:
            why.append("the run stopped early (budget)")
        if not rep["components"]:
            why.append("the mesh is empty")
        lines.append("The topology is NOT certified: " + "; ".join(why) + ".")
        if rep["violation_regions"]:
            lines.append("Violations " + describe_regions(rep["violation_regions"]) + ".")
    cp = rep.get("critical_points")
    if cp is not None and not cp["agrees_with_mesh"]:
        lines.append(
            f"The critical points found (Morse count {cp['morse_euler']}) disagree with the "
            f"mesh's Euler characteristic {sum(rep['euler'])}: either a critical point was "
            "missed or degenerate, or the topology is wrong."
        )
    return " ".join(lines)
