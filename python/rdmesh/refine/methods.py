"""The two refinement methods: their seeds and their ordered stages.

``boissonnat-oudot`` (algorithm.md 2): bad facets (criteria, or several or
tangential crossings), then, unless non-manifold output is allowed, singular
and boundary edges and non-manifold vertices as CGAL's Manifold_tag does, then
samples without facets.

``topological-ball`` (Cheng-Dey-Ramos-Ray, algorithm.md 3): first the
topological-ball tests, in order, until all hold; then Voronoi-edge
violations, bad facets, and the tests again (a batch can break the
property). The run ends when nothing fails.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy.spatial import cKDTree

from .. import core
from .._errors import EmptySurfaceError
from .._tol import MIN_SPACING, TB_FLOOR, TB_SEED_SPACING, TOPOLOGY_FLOOR
from ..creases.search import CreaseSearch
from ..features import Balls, FeatureError, FeatureGraph, ProtectingBalls, protect
from ..sampling.boundary import SEED_BAND, BoundaryCurve, boundary_curve, box_grid
from ..sampling.components import find_components
from ..sampling.critical import CriticalPoints, critical_points
from ..sampling.discovery import Discovery
from ..sampling.domain import clip_box, depth, on_clip_surface
from ..sampling.grid import GridScan, fibonacci_sphere, grid_scan, seeds_around
from ..sampling.probes import Probes, surface_probes, unit_normals
from ..sampling.screen import SlopeField
from ..surfaces.oracle import ImplicitSurface
from ..surfaces.volume import VolumeSurface
from ..topology.tests import CELL_NORMAL_ANGLE, PROBE_TARGET, TESTS
from .criteria import FacetCriteria, Sizing
from .deviation import deviation_stage
from .feature_curves import (
    check_on_surface,
    feature_graph,
    has_given_curves,
    without_kinks_near,
)
from .stages import FacetStage, Stage, TestStage

log = logging.getLogger("rdmesh")

TOPOLOGIES = ("manifold", "manifold-with-boundary", "non-manifold")
#: The tests proven by interval arithmetic in certify mode, in repair order.
PROVEN_TESTS = ("proven_voronoi_edge", "proven_voronoi_loop", "proven_silhouette")
#: A mesh input without a distance bound is still checked both ways at this
#: times the radius bound: where the input has a part thinner than the bound,
#: no sample may land on it and the part is left out of the output (a rod of
#: radius 0.4 r between two balls: 2 components instead of 1), and the
#: input's points there lie farther than the bound from the output.
COVERAGE = 1.0


@dataclass
class Plan:
    """What a method does on one surface.

    Attributes
    ----------
    seeds : (m, 3) the initial sample.
    phases : ordered lists of stages; the run moves to the next phase when
        every stage of the current one is satisfied, and ends after the last.
    topology_floor : floor of topology-driven points without a sizing field.
    report_probes : the probes the report's sampled tests use.
    critical : critical points of a height function, when the method seeds with them.
    floor_report : what the report says of the spacing floor.
    discovery : the interval subdivision that seeded every component (certify mode).
    """

    seeds: np.ndarray
    phases: list[list[Stage]]
    topology_floor: float
    report_probes: Callable[[], Probes]
    critical: CriticalPoints | None = None
    floor_report: dict | None = None
    discovery: Discovery | None = None
    #: The sampled curve where the surface leaves the ball (manifold-with-boundary).
    boundary: BoundaryCurve | None = None
    #: The feature curves, and their protecting balls (inserted before the seeds).
    features: FeatureGraph | None = None
    balls: Balls | None = None
    #: Why curves rdmesh found could not be protected (then features is None).
    features_abandoned: str | None = None
    #: The balls were placed beforehand (``features=ProtectingBalls``): not repaired.
    balls_given: bool = False
    #: The seeding grid's local slopes of f (:class:`GridScan`), if measured.
    slopes: SlopeField | None = None
    #: Facets crossed an even number of times below the topology floor are
    #: left out (:func:`rdmesh.refine.pipeline._cut_by_parity`).
    parity: bool = False


def boissonnat_oudot(
    surface: ImplicitSurface,
    criteria: FacetCriteria,
    topology: str,
    rng: np.random.Generator,
    resolution: int,
    certify: bool = False,
    edge_size: float | Sizing | None = None,
    shrink: list | None = None,
    creases: CreaseSearch | None = None,
) -> Plan:
    """Seeds from the grid scan (and, to certify, from the interval subdivision);
    stages as CGAL's Surface_mesher with its manifold tags.

    With ``topology="manifold-with-boundary"`` the surface may leave the ball
    (or the surface's clip box): the curve where it meets the sphere (the box
    faces) is traced first (:mod:`rdmesh.sampling.boundary`). Feature curves
    (that curve, given ones, a closed volume's box, the ``creases`` found in
    an expression or CSG tree) get protecting balls
    (:mod:`rdmesh.features`), inserted before the seeds; with
    ``features="none"`` the boundary curve's samples are the first seeds
    instead, and refinement points near it are moved onto it. Balls placed
    beforehand (:class:`~rdmesh.features.ProtectingBalls`) replace all of
    this: nothing is traced, and they may be the only seeds.
    """
    spacing = criteria.radius_bound if isinstance(criteria.radius_bound, float) else None
    clipped = topology == "manifold-with-boundary"
    given = surface.features if isinstance(surface.features, ProtectingBalls) else None
    try:
        scan, found = _scan(surface, rng, resolution, spacing, certify, clipped)
    except EmptySurfaceError:
        if given is None or not len(given):
            raise
        none = np.zeros((0, 3))
        scan, found = GridScan(none, none, 2.0 * surface.radius / resolution), None
    boundary = None
    if clipped and given is None:
        size = _boundary_spacing(surface, criteria)
        field = criteria.sizing if callable(criteria.radius_bound) else None
        boundary = boundary_curve(surface, size, criteria.distance_bound, resolution, field)
    graph, balls, abandoned = None, None, None
    if given is not None and len(given):
        given.check_on_surface(surface)
        graph, balls = given.graph, given.balls
        log.info("features: %d protecting balls placed beforehand", len(balls))
    elif surface.features != "none" and given is None:
        volume_curve = _volume_box_curve(surface, criteria, resolution)
        try:
            graph = feature_graph(
                surface, boundary=boundary if clipped else None, volume_curve=volume_curve,
                creases=creases,
            )  # fmt: skip
            if not graph.empty:
                graph, balls = _protect(surface, criteria, graph, scan, edge_size, shrink)
        except FeatureError as exc:
            if has_given_curves(surface):
                raise
            # Curves rdmesh found itself (clip boundary, volume box, a mesh's
            # sharp edges, an expression's creases): mesh without them, as
            # features="none", and say so.
            log.warning("feature curves not protected, meshed without them: %s", exc)
            graph, abandoned = None, str(exc)
    if balls is not None:
        # A seed in a ball would be hidden, or a vertex next to a curve.
        clear = SMALL_BALL_SEED_CLEARANCE if criteria.hold_at_small_balls else SEED_CLEARANCE
        scan = replace(scan, seeds=scan.seeds[~balls.inside(scan.seeds, clear)])
    if clipped and balls is None and boundary is not None and len(boundary.points):
        # Unprotected: seeds in the band along the clipping surface could be
        # boundary vertices, so the boundary's samples come first.
        size = _boundary_spacing(surface, criteria)
        inner = scan.seeds[depth(surface, scan.seeds) >= SEED_BAND * size]
        seeds = np.concatenate([boundary.points, _away(inner, boundary.points, 0.5 * size)])
        scan = replace(scan, seeds=seeds)
    soft = _angle_only_at_boundary(surface, criteria) if clipped and balls is None else None
    stages: list[Stage] = [FacetStage("facet", core.BAD | core.TOPO, "unless-bad", soft)]
    if topology != "non-manifold":
        allow = topology == "manifold-with-boundary"
        stages += [
            TestStage("edge", "voronoi_facet", allow_boundary=allow),
            TestStage("vertex", "disk"),
        ]
    # The distance check before the isolated-sample test: that test shoots
    # rays from the samples, and asked last it runs once, after the check's
    # points, not before and again after them.
    stages += _deviation(surface, criteria, balls)
    stages.append(TestStage("isolated", "isolated"))
    if certify:
        stages += [TestStage(k, k, only_if_clean=True) for k in PROVEN_TESTS]
    return Plan(
        seeds=scan.seeds,
        phases=[stages],
        topology_floor=MIN_SPACING * surface.radius,
        report_probes=lambda: Probes.on(surface, scan.crossings, scan.spacing),
        discovery=found,
        boundary=boundary,
        features=graph,
        balls=balls,
        features_abandoned=abandoned,
        balls_given=given is not None,
        slopes=scan.slopes,
        # Certification proves crossings facet by facet: nothing is left out.
        parity=not certify,
    )


def _deviation(surface: ImplicitSurface, criteria: FacetCriteria, balls=None) -> list[Stage]:
    """The distance check against a closed input mesh: at the distance bound,
    or without one at :data:`COVERAGE` times a numeric radius bound."""
    bound = criteria.distance_bound
    if bound is None and isinstance(criteria.radius_bound, (int, float)):
        bound = COVERAGE * criteria.radius_bound
    stage = deviation_stage(surface, bound, balls)
    return [] if stage is None else [stage]


def _protect(
    surface, criteria, graph, scan, edge_size, shrink
) -> tuple[FeatureGraph, Balls | None]:
    """The graph and its protecting balls (FeatureError when they would be
    smaller than the floor). A volume's kink curves are ours to leave out:
    where they cannot be protected, those near the place are dropped and
    the rest protected again (at most :data:`KINK_RETRIES` times; no balls
    when nothing is left)."""
    check_on_surface(surface, graph.curves)
    size = _edge_sizing(surface, criteria, edge_size)
    sheets = (scan.crossings, unit_normals(surface, scan.crossings))
    for attempt in range(KINK_RETRIES + 1):
        try:
            balls = protect(graph, size, surface.radius, sheets,
                            distance=criteria.distance_bound, shrink=shrink)  # fmt: skip
            break
        except FeatureError as exc:
            fewer = (
                None
                if attempt == KINK_RETRIES
                else without_kinks_near(graph, exc.where, surface.radius, _grid_spacing(surface))
            )
            if fewer is None:
                raise
            log.info("features: %d volume kink curves near %s left out (%s)",
                     len(graph) - len(fewer), np.round(exc.where, 6).tolist(), exc)  # fmt: skip
            graph = fewer
            if graph.empty:
                return graph, None
    log.info(
        "features: %d curves, %d corners, %d protecting balls (radii %.3g to %.3g)",
        len(graph.curves), len(graph.corners), len(balls), balls.radii.min(), balls.radii.max(),
    )  # fmt: skip
    return graph, balls


def _grid_spacing(surface: ImplicitSurface) -> float:
    """A volume's smallest sample spacing (the bounding radius for other surfaces)."""
    spacing = getattr(surface, "spacing", None)
    return surface.radius if spacing is None else float(np.min(spacing))


#: Times kink curves near a place that cannot be protected are dropped.
KINK_RETRIES = 20


#: Seeds closer to a protecting ball than this, times its radius, are dropped.
SEED_CLEARANCE = 1.2
#: The same where the angle bound is held next to small balls
#: (``FacetCriteria.hold_at_small_balls``): seeds 1.2-1.5 radii out make a
#: ring of triangles at the ball's centre too thin to hold the bound and too
#: small to refine (two spheres' union: 24.8 degrees with 1.2, 30.0 with 2).
SMALL_BALL_SEED_CLEARANCE = 2.0


def _edge_sizing(
    surface: ImplicitSurface, criteria: FacetCriteria, edge_size: float | Sizing | None
) -> Sizing:
    """The largest spacing of protecting balls along the curves: ``edge_size``
    (a number or a sizing field), by default the radius bound (or its field;
    a twentieth of R without one)."""
    if edge_size is None:
        if criteria.radius_bound is None:
            return lambda x: np.full(len(x), surface.radius / 20.0)
        return criteria.sizing
    if callable(edge_size):
        return FacetCriteria(0.0, edge_size).sizing
    return lambda x: np.full(len(x), float(edge_size))


def _volume_box_curve(surface: ImplicitSurface, criteria: FacetCriteria, resolution: int):
    """For a volume closed by its box: the curve where its isosurface meets the
    box, traced on the box (None otherwise)."""
    if not isinstance(surface, VolumeSurface) or surface.border != "closed":
        return None
    clipped = ImplicitSurface(
        surface.f_volume, surface.bounding_sphere, gradient=surface._volume_gradient,
        clip_box=surface.box,
    )  # fmt: skip
    size = _boundary_spacing(clipped, criteria)
    return boundary_curve(clipped, size, criteria.distance_bound, resolution)


def topological_ball(
    surface: ImplicitSurface,
    criteria: FacetCriteria,
    topology: str,
    rng: np.random.Generator,
    resolution: int,
    certify: bool = False,
    edge_size: float | Sizing | None = None,
    shrink: list | None = None,
    creases: CreaseSearch | None = None,
) -> Plan:
    """Seeds from the grid scan (to certify, from the interval subdivision
    instead) plus the critical points of a random height; the
    topological-ball tests, then the criteria while keeping them. Feature
    curves are not protected (the tests assume a smooth surface;
    :func:`rdmesh.mesh_surface` refuses given curves with this method, and
    meshes a surface with creases found by Boissonnat-Oudot instead)."""
    R = surface.radius
    bound = criteria.radius_bound
    spacing = bound if isinstance(bound, float) else None
    if bound is None:
        # No size bound: seeds only need to find the components; the tests
        # add what the topology needs.
        spacing = TB_SEED_SPACING * R
    scan, found = _scan(surface, rng, resolution, spacing, certify)
    h, seeds = scan.spacing, scan.seeds
    crit = critical_points(surface, np.concatenate([seeds, scan.crossings]), rng, h)
    if len(crit.points):
        # Seeds right next to a critical point only add short edges (the
        # discovery's points, which prove every component seeded, stay).
        proof = found.points if found is not None else np.zeros((0, 3))
        anchors = np.concatenate([proof, _away(crit.points, proof, 0.5 * h)])
        seeds = np.concatenate([anchors, _away(seeds, anchors, 0.5 * h)])
    probes = Probes.on(surface, surface_probes(surface, scan.crossings, h, rng, PROBE_TARGET), h)

    def tests(kinds: tuple[str, ...]) -> list[Stage]:
        return [TestStage(k, k, probes=probes, angle=CELL_NORMAL_ANGLE) for k in kinds]

    geometric: list[Stage] = [
        FacetStage("voronoi_edge", core.TOPO, True),
        FacetStage("facet", core.BAD, False),
        *tests(TESTS[1:]),
        *_deviation(surface, criteria),
    ]
    if certify:
        geometric += [TestStage(k, k, only_if_clean=True) for k in PROVEN_TESTS]
    floor = TB_FLOOR * R
    return Plan(
        seeds=seeds,
        phases=[tests(TESTS), geometric],
        topology_floor=floor,
        report_probes=lambda: probes,
        critical=crit,
        discovery=found,
        floor_report={"topology": f"{TOPOLOGY_FLOOR:g} x radius_bound"}
        if bound is not None
        else {"topology": floor},
        slopes=scan.slopes,
    )


def _scan(
    surface: ImplicitSurface,
    rng: np.random.Generator,
    resolution: int,
    spacing: float | None,
    certify: bool,
    clipped: bool = False,
) -> tuple[GridScan, Discovery | None]:
    """The grid scan (seeds, probes, the bounding-sphere check), plus, where
    the surface has one (expressions, closed volumes, closed mesh inputs; with
    or without ``certify``), the proven component search's points, which with
    the grid's seeds put one on every component when it is proven
    (:mod:`rdmesh.sampling.components`). Where the grid finds no surface, the
    search's points and crossings around them (:func:`seeds_around`) are the
    seeds; with no search, or nothing found, ``EmptySurfaceError`` stands."""
    try:
        scan = grid_scan(surface, rng, resolution, spacing=spacing, clipped=clipped)
    except EmptySurfaceError:
        # Components smaller than the grid: the proven search may still find them.
        found = find_components(surface, rng, clipped, None)
        if found is None or len(found.points) == 0:
            raise
        log.info("discovery: the grid found no surface, the component search %d seeds",
                 len(found.points))  # fmt: skip
        h = 2.0 * surface.radius / resolution
        pts = np.concatenate([found.points, seeds_around(surface, found.points, h)])
        return GridScan(pts, pts, h), found
    found = find_components(surface, rng, clipped, scan.seeds)
    if found is None or len(found.points) == 0:
        return scan, found
    # Grid seeds right next to a discovery point only add short edges.
    seeds = np.concatenate([found.points, _away(scan.seeds, found.points, 0.5 * scan.spacing)])
    log.info(
        "discovery: %d seeds, %d of them from the grid", len(seeds), len(seeds) - len(found.points)
    )
    scan = replace(scan, seeds=seeds, crossings=np.concatenate([scan.crossings, found.points]))
    return scan, found


def _boundary_spacing(surface: ImplicitSurface, criteria: FacetCriteria) -> float:
    """Largest spacing of the boundary curve's samples: the size bound (a
    sizing field's largest value on the sphere or the clip box, the field itself setting the
    spacing along the curve; a twentieth of R without one)."""
    bound = criteria.radius_bound
    if bound is None:
        return surface.radius / 20.0
    if not callable(bound):
        return float(bound)
    box = clip_box(surface)
    if box is None:
        on_boundary = surface.centre + surface.radius * fibonacci_sphere(4000)
    else:
        e = box[1] - box[0]
        on_boundary = box_grid(
            box, float(np.sqrt(2.0 * (e[0] * e[1] + e[1] * e[2] + e[0] * e[2]) / 4000))
        )[0]
    return float(np.max(criteria.sizing(on_boundary)))


def boundary_sizing(
    surface: ImplicitSurface, criteria: FacetCriteria
) -> Callable[[np.ndarray], np.ndarray]:
    """The local size bound at the boundary, ``(N, 3)`` points to ``N``
    lengths: the radius bound (a sizing field's value), or the boundary
    curve's spacing without one (:func:`_boundary_spacing`)."""
    if criteria.radius_bound is not None:
        return criteria.sizing
    size = _boundary_spacing(surface, criteria)
    return lambda x: np.full(len(x), size)


def at_boundary(surface: ImplicitSurface, corners: np.ndarray) -> np.ndarray:
    """Which triangles ``(k, 3, 3)`` have an edge on the boundary: two or
    three vertices on the clipping surface (the sphere or the clip box)."""
    on = on_clip_surface(surface, corners.reshape(-1, 3))
    return on.reshape(-1, 3).sum(axis=1) >= 2


def _angle_only_at_boundary(surface: ImplicitSurface, criteria: FacetCriteria):
    """Which bad facets fail only the angle bound at the boundary (optional
    refinement: :func:`rdmesh.sampling.boundary.guard_boundary` may drop their
    points); flags with ``TOPO`` are never optional."""

    def soft(corners, centres, radii, flags):
        other = criteria.bad(corners, centres, radii, at_boundary(surface, corners))
        return ~other & ((flags & core.TOPO) == 0)

    return soft


def _away(points: np.ndarray, anchors: np.ndarray, distance: float) -> np.ndarray:
    """The points farther than ``distance`` from every anchor."""
    if len(anchors) == 0 or len(points) == 0:
        return points
    d, _ = cKDTree(anchors).query(points)
    return points[d > distance]


#: The methods by name.
METHODS: dict[str, Callable[..., Plan]] = {
    "boissonnat-oudot": boissonnat_oudot,
    "topological-ball": topological_ball,
}
