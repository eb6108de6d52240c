"""The topology report: what each test found on the final samples, and in words.

Each test has a ``basis``: ``exact`` (combinatorial, on the restricted
complex), ``exact given voronoi_edge``, or ``sampled`` (resting on samples of
the surface: a missed feature is possible). The ``statement`` separates what
holds exactly from what rests on sampling.

The report (:attr:`rdmesh.SurfaceMesh.report`) has the same fields for every
method:

``tbp_holds``
    True when every topological-ball test held (some only on samples),
    nothing was left unresolved and the run completed.
``certified``
    True only when, besides, every test is proven
    (:attr:`rdmesh.SurfaceMesh.topology_certified`).
``tests``
    Per test (``voronoi_edge``, ``voronoi_facet``, ``voronoi_loop``,
    ``disk``, ``isolated``, ``silhouette``): ``held``, ``level``
    (``proven``, ``sampled``, ``failed`` or ``not tested``), ``violations`` at
    the end, ``repaired`` (points inserted to repair it), ``basis`` ("exact",
    "sampled", ...) and what it checks. With ``certify``,
    ``voronoi_edge`` also has ``proof``: the interval check of every
    Voronoi edge's crossings.
``seeding``
    How the components were found: ``level`` ``proven`` (interval
    subdivision, certify mode: a seed on every component) or
    ``sampled`` (grid scan), with the boxes' figures.
``components``, ``euler``, ``boundary_loops``, ``closed_manifold``
    Of the output mesh.
``boundary``
    A surface that leaves the bounding sphere or its clip box
    (``topology="manifold-with-boundary"``): ``domain`` ("sphere" or
    "box"), ``curve_loops`` traced on it, ``edge_crossings`` (box:
    where the curve crosses a box edge, each a sample),
    ``mesh_loops``, ``loops_match``, ``genus`` per component from
    chi = 2 - 2g - b and ``euler_consistent`` (a whole genus, at
    least 0); None otherwise.
``unresolved_regions``, ``violation_regions``
    Where points were refused by the spacing floor, or tests still fail:
    ``centre``, ``radius`` and ``points`` of each cluster.
``critical_points``
    Topological-ball method: the height-function critical points used
    as seeds and whether their Morse count matches the mesh.
``statement``
    What is certified and what rests on sampling, in words.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from .._regions import describe_regions, regions
from .._tol import REGION_LINK
from ..sampling.boundary import BoundaryCurve
from ..sampling.critical import CriticalPoints
from ..sampling.discovery import Discovery
from ..sampling.probes import Probes
from .complex import component_topology, is_closed_manifold
from .pockets import Pockets, pocket_reason
from .relabel import Relabelled
from .singular import singular_points
from .snapshot import Snapshot
from .tests import TESTS, Violations

_BASIS = {
    "voronoi_edge": (
        "sampled",
        "each restricted facet's dual Voronoi edge meets the surface once, transversally; "
        "crossings are found by sampling the edge at the surface-ball spacing plus a "
        "search of |f| dips, not by interval arithmetic; a facet left out below the spacing "
        "floor because its edge crossed the surface an even number of times (cut_by_parity) "
        "counts as a violation",
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


def topology_report(
    snap: Snapshot,
    *,
    method: str,
    probes: Probes | None,
    faces: np.ndarray,
    n_mesh_vertices: int,
    repaired: dict[str, int],
    unresolved: np.ndarray,
    complete: bool,
    critical: CriticalPoints | None = None,
    floor: dict | float | None = None,
    quick: bool = False,
    discovery: Discovery | None = None,
    proof: bool = False,
    boundary: BoundaryCurve | None = None,
    cut: np.ndarray | None = None,
    relabelled: Relabelled | None = None,
    pockets: Pockets | None = None,
) -> dict[str, Any]:
    """The topology report of a finished run (see :attr:`SurfaceMesh.report`).

    Every test is evaluated on ``snap``, the final samples, at the report's
    settings (silhouette at 90 degrees, no boundary allowed); outcomes the
    refinement loop already computed on that snapshot are reused. ``faces``
    is the output mesh (restricted facets), for components and Euler
    characteristics. ``quick`` (a run stopped by its time limit) leaves out
    the sampled tests and the singular-point search, and counts isolated
    samples without shooting for a point of their cells, since their cost
    grows with the mesh, so that the limit holds; the report then certifies
    nothing.
    ``discovery`` (the interval subdivision's seeding) and ``proof`` (the
    Voronoi edges' crossings checked by interval arithmetic) make those steps
    ``proven`` where they held. ``boundary`` (a run with
    ``topology="manifold-with-boundary"``) adds the ``boundary`` entry: the
    mesh's boundary loops against the loops traced on the sphere; such a
    mesh is never certified. ``cut`` (``(k, 3)`` centroids) are facets left
    out because their dual edge crossed the surface an even number of times
    below the spacing floor: Voronoi-edge violations. ``relabelled`` says
    which faces differ from the restricted facets (pinched vertices made one
    disk); ``pockets`` which small components on a covered input component
    were dropped, and whether the input's known topology ruled them out
    (``ruled_out``; otherwise the input is open or self-intersecting), or
    which specks next to unresolved points (``specks``, any input). With
    either, the mesh's closedness is read from ``faces`` and the
    topological-ball property is not claimed (the faces are not the
    restricted Delaunay facets).
    """
    tests: dict[str, dict[str, Any]] = {}
    where = []
    surface = snap.surface
    sampled = () if quick else ("voronoi_loop", "silhouette")
    for kind in TESTS:
        if kind in ("voronoi_loop", "silhouette") and kind not in sampled:
            continue
        # A run stopped by its time limit counts isolated samples without
        # shooting for their cells' points (that can take minutes).
        v = snap.test("isolated_count" if quick and kind == "isolated" else kind, probes=probes)
        if v is None:
            continue
        basis, what = _BASIS[v.kind]
        tests[v.kind] = {
            "held": v.count == 0,
            "level": _level(v.count == 0, basis),
            "violations": v.count,
            "repaired": int(repaired.get(v.kind, 0)),
            "basis": basis,
            "tests": what,
        }
        where.append(v.centres)
    if cut is not None:
        edge = tests["voronoi_edge"]
        edge["cut_by_parity"] = len(cut)
        edge["violations"] += len(cut)
        edge["held"] = edge["violations"] == 0
        edge["level"] = _level(edge["held"], edge["basis"])
        where.append(cut)
    for kind in ("voronoi_loop", "silhouette"):
        if kind not in tests:
            tests[kind] = {
                "held": None,
                "level": "not tested",
                "violations": None,
                "repaired": 0,
                "basis": "not tested (time limit)" if quick else "not tested",
                "tests": _BASIS[kind][1],
            }
    tests = {k: tests[k] for k in TESTS}
    link = REGION_LINK * surface.radius
    if proof and not quick and complete and len(unresolved) == 0:
        _prove_edges(tests, snap.test("proven_voronoi_edge"), link)
        for kind in ("voronoi_loop", "silhouette"):
            _prove_test(tests[kind], snap.test("proven_" + kind), link)
    chi, loops = component_topology(faces, n_mesh_vertices)
    # The output faces are the restricted facets: every edge in two faces is
    # the Voronoi-facet test, one fan per vertex is the disk test.
    closed = bool(len(faces) and tests["voronoi_facet"]["held"] and tests["disk"]["held"])
    changed = relabelled is not None or pockets is not None
    if changed:
        closed = is_closed_manifold(faces, n_mesh_vertices)
    unresolved_regions = regions(unresolved, link)
    violation_regions = regions(np.concatenate(where) if where else np.zeros((0, 3)), link)
    search = probes is not None and not quick
    singular = singular_points(surface, probes) if search else np.zeros((0, 3))
    all_held = all(t["held"] is True for t in tests.values())
    seeding = _seeding(discovery, link)
    holds = bool(
        not changed
        and all_held
        and complete
        and len(unresolved) == 0
        and len(faces) > 0
        and len(singular) == 0
    )
    report: dict[str, Any] = {
        "method": method,
        "tbp_holds": holds,
        "certified": holds
        and boundary is None
        and all(t["level"] == "proven" for t in tests.values())
        and seeding["level"] == "proven",
        "tests": tests,
        "seeding": seeding,
        "components": len(chi),
        "euler": chi,
        "boundary_loops": loops,
        "closed_manifold": closed,
        "complete": complete,
        "unresolved": len(unresolved),
        "unresolved_regions": unresolved_regions,
        "violation_regions": violation_regions,
        "singular_points": {
            "count": len(singular),
            "regions": regions(singular, link),
            "basis": "not searched (time limit)"
            if quick
            else "sampled (Newton on grad f = 0 from the probes)",
        },
        "probes": None
        if probes is None
        else {"count": len(probes.points), "spacing": float(probes.spacing)},
        "spacing_floor": floor,
        "critical_points": None,
        "relabelled": None if relabelled is None else _relabelled(relabelled, link),
        "pockets": None if pockets is None else _pockets(pockets, link),
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
    # A closed surface meshed with this topology has no boundary to report.
    clipped = boundary is not None and (boundary.n_loops > 0 or sum(loops) > 0)
    report["boundary"] = _boundary(boundary, chi, loops) if clipped else None
    report["statement"] = _statement(report)
    return report


def _relabelled(r: Relabelled, link: float) -> dict[str, Any]:
    """``report["relabelled"]``: where the output faces are not restricted
    facets (a face added there has its circumcentre as its facet centre)."""
    return {
        "pinched_vertices": r.pinched,
        "cells_flipped": r.cells,
        "faces_changed": len(r.changed),
        "still_pinched": len(r.left),
        "timed_out": r.timed_out,
        "regions": regions(r.changed, link),
    }


def _pockets(p: Pockets, link: float) -> dict[str, Any]:
    """``report["pockets"]``: the output components dropped as pockets, and
    whether the input's known topology rules them out (``ruled_out``), or
    they are specks next to unresolved points (``specks``)."""
    return {
        "dropped": len(p.centres),
        "faces": p.faces,
        "largest": float(p.sizes.max()),
        "regions": regions(p.centres, link),
        "ruled_out": p.ruled_out,
        "specks": p.specks,
    }


def _boundary(curve: BoundaryCurve, chi: list[int], loops: list[int]) -> dict[str, Any]:
    """The boundary of a clipped mesh against the curve traced on the sphere
    (or the clip box's faces).

    Each component with ``b`` boundary loops has ``chi = 2 - 2 g - b``: the
    genus ``g`` it implies must be a whole number at least 0.
    """
    genus = [(2 - c - b) / 2 for c, b in zip(chi, loops, strict=True)]
    consistent = all(g >= 0 and float(g).is_integer() for g in genus)
    where = "the sphere" if curve.domain == "sphere" else "the box faces"
    return {
        "domain": curve.domain,
        "edge_crossings": len(curve.corners),
        "curve_loops": curve.n_loops,
        "mesh_loops": int(sum(loops)),
        "loops_match": int(sum(loops)) == curve.n_loops,
        "curve_samples": len(curve.points),
        "curve_spacing": curve.size,
        "genus": genus,
        "euler_consistent": consistent,
        "basis": f"sampled: the curve f = 0 on {where} was traced on a point grid "
        f"of spacing {curve.spacing:.3g}; loops smaller than that can be missed",
    }


def _prove_edges(tests: dict[str, dict[str, Any]], proven: Violations, link: float) -> None:
    """Raise voronoi_edge (and voronoi_facet, exact given it) to ``proven``
    where the interval check of every Voronoi edge held."""
    edge = tests["voronoi_edge"]
    held = proven.count == 0 and len(proven.stuck) == 0
    edge["proof"] = {
        "held": held,
        "violations": proven.count,
        "unsettled_regions": regions(proven.stuck, link),
        "basis": "interval arithmetic: Snyder's root isolation on every Voronoi edge",
    }
    if not edge["held"]:
        return
    if not held:
        edge.update(held=False, level="failed")
        return
    edge.update(
        level="proven",
        basis="proven",
        tests="every Voronoi edge crosses the surface as the restricted facets say: once, "
        "transversally, for each restricted facet's dual edge and never for the others "
        "(interval root isolation, proven up to the root tolerance)",
    )
    facet = tests["voronoi_facet"]
    if facet["held"]:
        facet["level"] = "proven"


def _prove_test(test: dict[str, Any], proven: Violations, link: float) -> None:
    """Raise a sampled test to ``proven`` where its interval version held
    (:mod:`rdmesh.topology.proven_cells`); a failed proof fails it."""
    held = proven.count == 0
    where = np.concatenate([proven.centres, proven.stuck])
    test["proof"] = {
        "held": held,
        "violations": proven.count,
        "regions": regions(where, link),
        "basis": _PROOF_BASIS[proven.kind],
    }
    if test["held"] is False:
        return
    if not held:
        test.update(held=False, level="failed")
        return
    test.update(level="proven", basis="proven")


_PROOF_BASIS = {
    "proven_voronoi_loop": "interval arithmetic: on every Voronoi facet, boxes covering its "
    "part near the surface, each with an in-plane gradient component bounded away from 0 "
    "(no closed loop, so one arc per two boundary crossings)",
    "proven_silhouette": "interval arithmetic: in every Voronoi cell with restricted "
    "triangles, boxes covering its part near the surface, each with grad f . n_p bounded "
    "away from 0 (no silhouette point: with the disk test, W_p is a disk)",
}


def _seeding(discovery: Discovery | None, link: float) -> dict[str, Any]:
    """How the components were found, and at which level."""
    if discovery is None:
        return {
            "level": "sampled",
            "basis": "a grid scan (and critical points of a height function): components "
            "smaller than about two grid cells can be missed",
        }
    basis = discovery.basis
    if basis is None:
        basis = (
            "interval subdivision (Snyder's box condition): a seed on every component"
            if discovery.proven
            else "interval subdivision left boxes or edges unresolved there: components may "
            "be missed there"
        )
    return {
        "level": "proven" if discovery.proven else "sampled",
        "basis": basis,
        "seeds": len(discovery.points),
        "boxes": discovery.boxes,
        "smallest_box": float(discovery.side),
        "interval_evaluations": discovery.evaluations,
        "unresolved_regions": regions(discovery.unresolved, link),
    }


def _level(held: bool, basis: str) -> str:
    """``proven`` (held, by an exact test), ``sampled`` (held on samples) or ``failed``."""
    if not held:
        return "failed"
    return "proven" if basis == "exact" else "sampled"


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
    bd = rep.get("boundary")
    if bd is not None:
        box = bd.get("domain") == "box"
        lines.append(
            f"The surface leaves the {'clip box' if box else 'bounding sphere'} "
            "(topology='manifold-with-boundary'): "
            f"the mesh is the part inside, with {bd['mesh_loops']} boundary loops "
            f"({bd['curve_loops']} traced on the {'box faces' if box else 'sphere'}"
            + (f", crossing box edges at {bd['edge_crossings']} points" if box else "")
            + "); the topological-ball tests and "
            "certificates assume a closed surface inside the sphere, so nothing is "
            "certified (the boundary edges, with one triangle each, fail the Voronoi-facet "
            "test by design)."
        )
    if rep["certified"]:
        lines.append(
            "The topology is certified: every topological-ball test is proven, so the mesh "
            "is homeomorphic to the surface (Edelsbrunner-Shah). Proven by interval "
            "arithmetic: every Voronoi edge crosses the surface as the restricted facets say "
            "(once, transversally), no Voronoi facet holds a closed loop, no Voronoi cell a "
            "silhouette point, and every component got a seed; exact (combinatorial): every "
            "complex edge has 2 triangles and every sample one disk of triangles. Up to the "
            "root tolerance and the floating-point rounding of the Voronoi vertices."
        )
    elif rep["tbp_holds"]:
        sampled = [k for k, t in tests.items() if t["level"] == "sampled"]
        if rep["seeding"]["level"] != "proven":
            sampled.append("seeding")
        lines.append(
            "The topology is NOT certified: every topological-ball test held, but "
            f"{', '.join(sampled)} held only on samples. The mesh is homeomorphic to the "
            "surface provided the sampled steps are right. Exact (combinatorial): every "
            "complex edge has 2 triangles (Voronoi-facet crossing count), every sample has "
            "one disk of triangles, no sample lacks triangles."
        )
        where = {
            "voronoi_edge": "one transversal crossing per Voronoi edge (edge sampling plus "
            "dip search)",
            "voronoi_loop": "no closed loop or folded arc inside a Voronoi facet (damped "
            "Newton from a few seeds per facet; facets without boundary crossings only "
            "where a probe is near them)",
            "silhouette": f"no silhouette point in any Voronoi cell ({probe_text})",
            "seeding": "a seed on every component (a grid scan, or an interval "
            "subdivision that left regions unresolved)",
        }
        said = [where[k] for k in sampled if k in where]
        if said:
            lines.append(
                "Sampled: " + "; ".join(said) + ". Features smaller than the sampling can "
                "be missed. Expression surfaces (certify=True) get these proven."
            )
    else:
        why = []
        if failed:
            why.append("tests failed: " + ", ".join(failed))
        if untested:
            why.append("not tested: " + ", ".join(untested))
        cut = tests["voronoi_edge"].get("cut_by_parity", 0)
        if cut:
            why.append(
                f"{cut} facets below the spacing floor whose Voronoi edge crossed the "
                "surface an even number of times were left out (a wedge or neck thinner "
                "than the floor is cut there)"
            )
        rel = rep.get("relabelled")
        if rel:
            why.append(
                f"{rel['pinched_vertices']} pinched vertices below the spacing floor were "
                f"made one disk by moving {rel['cells_flipped']} Delaunay cells across the "
                f"surface, so {rel['faces_changed']} faces are not restricted Delaunay facets "
                f"({describe_regions(rel['regions'])})"
                + (f"; {rel['still_pinched']} are still pinched" if rel["still_pinched"] else "")
                + (" (the time limit ended the relabelling)" if rel["timed_out"] else "")
            )
        pockets = rep.get("pockets")
        if pockets:
            why.append(
                f"output components smaller than the size bound were dropped: "
                f"{pockets['dropped']} (at most {pockets['largest']:.3g} across, "
                f"{describe_regions(pockets['regions'])}), "
                f"{pocket_reason(pockets['ruled_out'], pockets['specks'])}"
            )
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
