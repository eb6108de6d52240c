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
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .. import core
from .._tol import MIN_SPACING, TB_FLOOR, TB_SEED_SPACING, TOPOLOGY_FLOOR
from ..sampling.boxes import interval_boxes
from ..sampling.critical import CriticalPoints, critical_points
from ..sampling.grid import GridScan, grid_scan
from ..sampling.probes import Probes, surface_probes
from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from ..topology.tests import CELL_NORMAL_ANGLE, PROBE_TARGET, TESTS
from .criteria import FacetCriteria
from .stages import FacetStage, Stage, TestStage

log = logging.getLogger("rdmesh")

TOPOLOGIES = ("manifold", "manifold-with-boundary", "non-manifold")


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
    """

    seeds: np.ndarray
    phases: list[list[Stage]]
    topology_floor: float
    report_probes: Callable[[], Probes]
    critical: CriticalPoints | None = None
    floor_report: dict | None = None


def boissonnat_oudot(
    surface: ImplicitSurface,
    criteria: FacetCriteria,
    topology: str,
    rng: np.random.Generator,
    resolution: int,
) -> Plan:
    """Seeds from the grid scan; stages as CGAL's Surface_mesher with its manifold tags."""
    spacing = criteria.radius_bound if isinstance(criteria.radius_bound, float) else None
    scan = _scan(surface, rng, resolution, spacing)
    stages: list[Stage] = [FacetStage("facet", core.BAD | core.TOPO, "unless-bad")]
    if topology != "non-manifold":
        allow = topology == "manifold-with-boundary"
        stages += [
            TestStage("edge", "voronoi_facet", allow_boundary=allow),
            TestStage("vertex", "disk"),
        ]
    stages.append(TestStage("isolated", "isolated"))
    return Plan(
        seeds=scan.seeds,
        phases=[stages],
        topology_floor=MIN_SPACING * surface.radius,
        report_probes=lambda: Probes.on(surface, scan.crossings, scan.spacing),
    )


def topological_ball(
    surface: ImplicitSurface,
    criteria: FacetCriteria,
    topology: str,
    rng: np.random.Generator,
    resolution: int,
) -> Plan:
    """Seeds from the grid scan plus the critical points of a random height;
    the topological-ball tests, then the criteria while keeping them."""
    R = surface.radius
    bound = criteria.radius_bound
    spacing = bound if isinstance(bound, float) else None
    if bound is None:
        # No size bound: seeds only need to find the components; the tests
        # add what the topology needs.
        spacing = TB_SEED_SPACING * R
    scan = _scan(surface, rng, resolution, spacing)
    h, seeds = scan.spacing, scan.seeds
    crit = critical_points(surface, np.concatenate([seeds, scan.crossings]), rng, h)
    if len(crit.points):
        # Grid seeds right next to a critical point only add short edges.
        d, _ = cKDTree(crit.points).query(seeds)
        seeds = np.concatenate([crit.points, seeds[d > 0.5 * h]])
    probes = Probes.on(surface, surface_probes(surface, scan.crossings, h, rng, PROBE_TARGET), h)

    def tests(kinds: tuple[str, ...]) -> list[Stage]:
        return [TestStage(k, k, probes=probes, angle=CELL_NORMAL_ANGLE) for k in kinds]

    geometric: list[Stage] = [
        FacetStage("voronoi_edge", core.TOPO, True),
        FacetStage("facet", core.BAD, False),
        *tests(TESTS[1:]),
    ]
    floor = TB_FLOOR * R
    return Plan(
        seeds=seeds,
        phases=[tests(TESTS), geometric],
        topology_floor=floor,
        report_probes=lambda: probes,
        critical=crit,
        floor_report={"topology": f"{TOPOLOGY_FLOOR:g} x radius_bound"}
        if bound is not None
        else {"topology": floor},
    )


def _scan(
    surface: ImplicitSurface, rng: np.random.Generator, resolution: int, spacing: float | None
) -> GridScan:
    """The grid scan; for expression surfaces, plus a point in each box of the
    interval subdivision that may hold the surface and has no grid crossing
    near it (small components the grid misses)."""
    scan = grid_scan(surface, rng, resolution, spacing=spacing)
    if not isinstance(surface.f, Expression):
        return scan
    found = interval_boxes(surface, surface.f, scan.spacing, rng, scan.crossings).points
    if len(found) == 0:
        return scan
    d, _ = cKDTree(scan.crossings).query(found)
    extra = found[d > scan.spacing]
    if len(extra):
        log.info("interval boxes: %d seeds away from every grid crossing", len(extra))
    return GridScan(
        np.concatenate([scan.seeds, extra]),
        np.concatenate([scan.crossings, extra]),
        scan.spacing,
    )


#: The methods by name.
METHODS: dict[str, Callable[..., Plan]] = {
    "boissonnat-oudot": boissonnat_oudot,
    "topological-ball": topological_ball,
}
