"""The refinement loop: update, ask the stages, select independent points, insert.

Each round the facet pipeline evaluates the facets whose dual changed; the
stages of the method's current phase are asked in order, and the points of
the first stage that has any above the spacing floor are inserted together:
the largest balls first, keeping only points outside each other's balls,
which equals a valid sequential run (algorithm.md 2.5). The run ends when
every stage of the last phase is satisfied, or a budget runs out.
"""

from __future__ import annotations

import logging
import os
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .. import core
from .._errors import BudgetExceeded, Interrupted, RefinementStalled
from .._regions import describe_regions, regions
from .._tol import REGION_LINK
from .._vectors import row_index
from ..creases.search import CreaseSearch
from ..features.check import check_features, repair_sites
from ..io.result import SurfaceMesh
from ..sampling.boundary import BoundaryCurve, guard_boundary
from ..sampling.domain import clip_box
from ..sampling.fine_clearing import fine_clearing
from ..sampling.grid import check_sphere_near
from ..sampling.screen import clear_in_core, slope_bound
from ..surfaces.oracle import ImplicitSurface
from ..surfaces.volume import VolumeSurface
from ..topology import Snapshot, topology_report
from ..topology.defects import ComplexDefects
from ..topology.loops import LoopMemo
from ..topology.pockets import (
    UNBOUNDED_SIZE,
    Pockets,
    drop_pockets,
    drop_specks,
    pocket_reason,
)
from ..topology.proven_cells import ProofMemo
from ..topology.relabel import Relabelled, relabel_pinches
from ..topology.snapshot import confirm_defects
from .check import CHECK_MAX_SAMPLES, check_restricted
from .criteria import FacetCriteria
from .deviation import DeviationStage
from .feature_curves import kink_balls
from .floor import SpacingFloor
from .hole_cut import cut_caps, rim_balls
from .memory import shortfall
from .methods import METHODS, Plan, boundary_sizing
from .phases import Phases
from .pipeline import FacetPipeline
from .samples import Samples
from .stages import Candidates
from .timing import PhaseTimer

log = logging.getLogger("rdmesh")

#: Feature repairs (meshing again with smaller balls) at most, and the
#: smallest angle next to a ball below which a ball is shrunk.
MAX_REPAIRS, REPAIR_ANGLE = 3, 20.0

#: Building the mesh after the last round (snapshot, relabelling, report)
#: costs about this share of the loop's time per vertex (0.07-0.13 on the
#: torus, tanglecube and double torus, 2026-12-06): a time limit reserves it.
FINISH_SHARE = 0.15
#: A round predicted to end past the time limit inserts the part that fits
#: when that is at least this many points and this share of the round.
MIN_PARTIAL_ROUND = (1000, 0.1)

#: Safety cap on rounds; smooth inputs need tens. Reaching it ends the run
#: with the remaining points unresolved, like the spacing floor.
MAX_ROUNDS = 2000


@dataclass
class Budget:
    """The user's limits on a run (None means unlimited), and the memory available."""

    max_vertices: int | None = None
    time_limit: float | None = None

    def exceeded(
        self,
        vertices: int,
        seconds: float,
        next_round: float = 0.0,
        points: int = 0,
        finish: float = 0.0,
    ) -> str | None:
        """Which budget has run out, in words, or None.

        ``next_round`` is the predicted time of another round (inserting
        ``points``) and ``finish`` that of building the mesh after it: a round
        that would end past the time limit, or not fit in the memory
        available (:func:`~rdmesh.refine.memory.shortfall`), is not started,
        and the message says so.
        """
        if self.time_limit is not None and seconds + next_round + finish > self.time_limit:
            if seconds >= self.time_limit:
                return f"time_limit={self.time_limit:g}s reached after {seconds:.1f}s"
            return (
                f"time_limit={self.time_limit:g}s reached: stopped after {seconds:.1f}s, "
                f"before a round of {points} points predicted to take {next_round:.1f}s "
                f"(and {finish:.1f}s to build the mesh) would end past the limit"
            )
        if self.max_vertices is not None and vertices >= self.max_vertices:
            return f"max_vertices={self.max_vertices} reached"
        return shortfall(vertices, points) if points else None

    def left(self, seconds: float) -> float:
        """Seconds left of the time limit after ``seconds`` (inf without one)."""
        return np.inf if self.time_limit is None else self.time_limit - seconds


class Mesher:
    """One meshing run: owns the core, the samples and the loop.

    Parameters are those of :func:`rdmesh.mesh_surface` (checked there).
    """

    def __init__(
        self,
        surface: ImplicitSurface,
        criteria: FacetCriteria,
        *,
        method: str = "boissonnat-oudot",
        topology: str = "manifold",
        seed: int = 0,
        budget: Budget | None = None,
        seed_resolution: int = 64,
        progress: Callable[[dict], None] | None = None,
        workers: int = 1,
        certify: bool = False,
        edge_size: float | Callable[[np.ndarray], np.ndarray] | None = None,
        creases: CreaseSearch | None = None,
    ) -> None:
        self.surface, self.edge_size, self.creases = surface, edge_size, creases
        self.criteria = criteria
        self.method = method
        self.topology = topology
        self.seed = seed
        self.budget = budget or Budget()
        self.seed_resolution = seed_resolution
        self.progress = progress
        self.workers = workers
        self.certify = certify
        self.timer = PhaseTimer()
        #: The surface may leave the ball; the mesh is the part inside.
        self.clipped = topology == "manifold-with-boundary"
        self.rounds = 0
        #: Times the feature check failed and the run began again with smaller balls.
        self.repairs = 0
        _fresh(self)
        #: Debug mode: check the bookkeeping every round (small runs only).
        self.check = os.environ.get("RDMESH_CHECK", "") not in ("", "0")

    def run(self) -> SurfaceMesh:
        """Mesh the surface; raises BudgetExceeded or Interrupted with the partial mesh.

        With protecting balls, a mesh whose feature check fails, or with a
        triangle next to a ball below :data:`REPAIR_ANGLE`, is made again with
        the balls there shrunk (DelPSC), at most :data:`MAX_REPAIRS` times.
        """
        t0 = time.perf_counter()
        evals0 = self.surface.evaluations
        ivals0 = getattr(self.surface.f, "interval_evaluations", 0)
        #: Exact segment queries before the run (closed meshes; see stats).
        self.segment_queries0 = getattr(self.surface, "segment_queries", 0)
        shrink: list[tuple[np.ndarray, np.ndarray]] = []
        while True:
            mesh = _attempt(self, t0, evals0, ivals0, shrink)
            fixed = mesh.features is None or self.plan.balls_given  # balls placed beforehand
            sites = None if fixed else _repair_sites(mesh, self.plan)
            if sites is None or not len(sites[0]) or self.repairs == MAX_REPAIRS:
                return mesh
            if self.budget.exceeded(len(mesh.vertices), time.perf_counter() - t0):
                return mesh
            log.info("features: shrinking balls at %d places and meshing again", len(sites[0]))
            shrink.append(sites)
            self.repairs += 1
            _fresh(self)

    def _loop(self, plan: Plan, t0: float, stop: str | None) -> str | None:
        """Refinement rounds until nothing is left to refine or a budget runs out."""
        floor = SpacingFloor(self.criteria, self.surface.radius, plan.topology_floor)
        phases = Phases(plan.phases, floor, _boundary_placer(self, plan))
        self.pipeline.parity_floor = floor.topology if plan.parity else None
        cap = self.budget.max_vertices
        cycle_start, loop_start, done = t0, time.perf_counter(), 0
        while stop is None:
            self.rounds += 1
            self.pipeline.update(self.vertices, self.weights)
            # No local reference: the snapshot's arrays and trees go with the
            # next insertion, before the next round's peak.
            if self.check:
                check_restricted(self.snapshot())
            with self.timer("candidates"):
                found, self.unresolved = phases.ask(self.snapshot())
                if found is None and confirm_defects(self.snapshot()):
                    log.warning("a count of every facet found defects the local counts missed")
                    continue
            if found is None:
                break
            if self.rounds > MAX_ROUNDS:
                # No budget of the user's: end like the spacing floor does.
                log.warning("ended at the cap of %d rounds; see unresolved", MAX_ROUNDS)
                self.unresolved.append(found.centres)
                break
            with self.timer("select"):
                pick = core.select_independent(found.centres, found.radii)
                batch, stages = found.centres[pick], found.stages(pick)
            now, n = time.perf_counter(), len(self.vertices)
            ahead = _ahead(now - loop_start, now - cycle_start, done, n, len(batch))
            stop = self.budget.exceeded(n, now - t0, ahead[0], len(batch), ahead[1])
            fit = _fit(self.budget, now - t0, n, ahead, len(batch)) if stop else 0
            if stop and not fit:
                break
            if fit:  # the time left holds part of the round: as many points as fit
                batch, stages, stop = batch[:fit], stages[:fit], _partial(self.budget, fit, batch)
            cycle_start, done = now, done + len(batch)
            if cap is not None and len(self.vertices) + len(batch) > cap:
                room = max(0, cap - len(self.vertices))
                batch, stages = batch[:room], stages[:room]
                stop = f"max_vertices={cap} reached"
            if _insert_stages(self, batch, stages) == 0 and len(batch):
                # Repeating the batch would add nothing again (CGAL's "element
                # survives its own refinement point" error).
                self.stalled, stop = True, _no_progress(found.stage, len(batch))
            log.debug(
                "round %d: %s stage, %d samples", self.rounds, found.stage, len(self.vertices)
            )
            if self.progress is not None:
                self.progress(_progress(self.rounds, found.stage, len(batch), self.vertices, t0))
        if stop:
            self.pipeline.update(self.vertices, self.weights)
        return stop

    @property
    def vertices(self) -> np.ndarray:
        """The samples, indexed by the core's vertex ids."""
        return self.samples.points

    @property
    def weights(self) -> np.ndarray | None:
        """The vertices' weights when some are protecting balls, else None."""
        return self.samples.weights if self.samples.weighted else None

    def _insert(self, points: np.ndarray, stage: str, weights: np.ndarray | None = None) -> int:
        self._snap = None
        with self.timer("insert"):
            return self.samples.insert(points, stage, weights)

    def snapshot(self) -> Snapshot:
        if self._snap is None:
            self.defects.check = self.check and len(self.vertices) <= CHECK_MAX_SAMPLES
            self._snap = Snapshot(
                self.surface, self.rdt, self.vertices, self.memo, self.proofs, self.weights,
                self.defects,
            )  # fmt: skip
        return self._snap


def _ahead(loop: float, last: float, done: int, n: int, k: int) -> tuple[float, float, float]:
    """Predicted seconds of the next round of ``k`` points on ``n`` samples,
    of building the mesh after it, and per point, from the loop's ``loop``
    seconds so far (``done`` points inserted) and the ``last`` round's; zeros
    before any round. A round's cost (insert, update, stages, select) grows
    with the points it inserts: it is predicted from the loop's cost per point
    inserted or present (one round's is unstable: a test round that inserts a
    few points into a large mesh costs much per point), and at least as long
    as the last round."""
    if not done:
        return 0.0, 0.0, 0.0
    per_point = loop / max(done, n, 1)
    return max(last, per_point * k), FINISH_SHARE * per_point * (n + k), per_point


def _partial(budget: Budget, fit: int, batch: np.ndarray) -> str:
    """The stop message after a last round of ``fit`` of ``batch``'s points."""
    return (
        f"time_limit={budget.time_limit:g}s reached: the last round inserted {fit} of its "
        f"{len(batch)} points, as many as were predicted to fit"
    )


def _fit(budget: Budget, seconds: float, n: int, ahead: tuple, k: int) -> int:
    """How many of a round's ``k`` points fit in the time left after
    ``seconds``, building the mesh included, when time is what the round
    lacks (``ahead``: :func:`_ahead`'s prediction); 0 otherwise, or when fewer
    than :data:`MIN_PARTIAL_ROUND` (points, and share of the round) fit."""
    per_point, left = ahead[2], budget.left(seconds)
    if per_point <= 0 or ahead[0] + ahead[1] <= left:
        return 0
    fit = min(k - 1, int((left - FINISH_SHARE * per_point * n) / (per_point * (1 + FINISH_SHARE))))
    return fit if fit >= max(MIN_PARTIAL_ROUND[0], MIN_PARTIAL_ROUND[1] * k) else 0


def _insert_stages(m: Mesher, points: np.ndarray, stages: np.ndarray) -> int:
    """Insert points joined from several stages, each counted for its own."""
    names = list(dict.fromkeys(stages))
    if len(names) == 1:
        return m._insert(points, names[0])
    return sum(m._insert(points[stages == name], name) for name in names)


def _repair_sites(mesh: SurfaceMesh, plan: Plan):
    """Where the next attempt shrinks the balls (:func:`repair_sites`)."""
    return repair_sites(mesh, REPAIR_ANGLE, kink_balls(plan), rim_balls(mesh, plan))


def restart(m: Mesher, surface: ImplicitSurface) -> None:
    """Make ``m`` mesh ``surface`` from scratch on its next :meth:`Mesher.run`."""
    forget_crossings(m.surface)
    m.surface, m.rounds, m.repairs = surface, 0, 0
    _fresh(m)


def forget_crossings(surface) -> None:
    """Drop what ``surface`` remembers of a run's crossings (a mesh input's
    faces of its exact crossings), if anything."""
    forget = getattr(surface, "forget_crossings", None)
    if forget is not None:
        forget()


def _fresh(m: Mesher) -> None:
    """A new core, samples and pipeline (at the start, and for a repair)."""
    surface = m.surface
    forget_crossings(surface)  # a run must not depend on an earlier run's crossings
    m.rdt = core.RestrictedDelaunay(surface.centre, surface.radius)
    box = clip_box(surface)
    if box is not None:  # checked by mesh_surface: inside the ball, with a boundary
        m.rdt.set_clip_box(box[0], box[1])
    m.samples = Samples(m.rdt)
    m.memo = LoopMemo()
    m.proofs = ProofMemo()
    m.defects = ComplexDefects()
    m.pipeline = FacetPipeline(m.rdt, surface, m.criteria, m.workers, m.timer, clipped=m.clipped)
    m.ball_ids = np.zeros(0, np.int64)
    m.unresolved: list[np.ndarray] = []
    m._snap: Snapshot | None = None
    m.stalled = False


def _attempt(m: Mesher, t0: float, evals0: int, ivals0: int, shrink: list) -> SurfaceMesh:
    """One meshing run from the seeds (the first, or a repair's with ``shrink``)."""
    rng = np.random.default_rng(m.seed)
    with m.timer("seeding"):
        plan = METHODS[m.method](
            m.surface, m.criteria, m.topology, rng, m.seed_resolution,
            m.certify, edge_size=m.edge_size, shrink=shrink, creases=m.creases,
        )  # fmt: skip
    m.plan = plan
    m.pipeline.slope = slope_bound(m.surface, plan.slopes)
    fine = None
    if clear_in_core(m.rdt, m.pipeline.slope):
        fine = fine_clearing(m.rdt, m.pipeline.surface, m.pipeline.slope)
    m.pipeline.fine = fine
    seeds, stop = plan.seeds, None
    cap = m.budget.max_vertices
    if cap is not None and len(seeds) > cap:
        seeds, stop = seeds[:cap], f"max_vertices={cap} reached"
    interrupted = False
    try:
        try:
            if plan.balls is not None:
                # Balls first: they must not hide a vertex (the core refuses).
                m._insert(plan.balls.centres, "protect", plan.balls.weights)
                m.ball_ids = m.samples.last_ids
                m.pipeline.protected = True
            m._insert(seeds, "seeds")
            stop = m._loop(plan, t0, stop)
            if not m.clipped:
                check_sphere_near(m.surface, m.vertices)
        except KeyboardInterrupt:
            interrupted, stop = True, "interrupted"
            _restart_round(m)
        mesh = _result(m, plan, t0, evals0, ivals0, stop)
    finally:
        m.pipeline.close()
    if stop:
        raise _stopped(stop, mesh, interrupted, m.stalled)
    return mesh


def _slope_stats(bound) -> dict | None:
    """What ``stats["slope_bound"]`` says of the bound that thinned the samples."""
    if bound is None:
        return None
    return {"value": bound.value, "proven": bound.proven}


def _fine_stats(pipeline: FacetPipeline) -> dict | None:
    """What ``stats["fine_clearing"]`` says of the core's finer clearing level
    (:mod:`rdmesh.sampling.fine_clearing`): cubes filled and segments they
    cleared, None without one."""
    if pipeline.fine is None:
        return None
    cubes, cleared = pipeline.rdt.fine_clearing_stats
    return {"cubes": int(cubes), "cleared": int(cleared)}


def _distance_stats(plan: Plan) -> dict | None:
    """What ``stats["distance_check"]`` says of the check against a closed
    input mesh (:mod:`rdmesh.refine.deviation`), None without one or when
    nothing was checked."""
    for phase in plan.phases:
        for stage in phase:
            if isinstance(stage, DeviationStage):
                return stage.stats() if stage.checks else None
    return None


def _boundary_placer(m: Mesher, plan: Plan):
    """Without protecting balls, the boundary guard of a clipped surface
    (:func:`onto_curve`), else None."""
    if not m.clipped or plan.balls is not None or plan.boundary is None:
        return None
    if not len(plan.boundary.points):
        return None
    curve, sizing = plan.boundary, boundary_sizing(m.surface, m.criteria)

    def place(found: Candidates, snap: Snapshot) -> tuple[Candidates, np.ndarray]:
        return onto_curve(m.surface, curve, found, snap, sizing)

    return place


def _restart_round(m: Mesher) -> None:
    """After Ctrl-C: keep the samples inserted so far and evaluate the
    interrupted round again from its start, so the partial mesh is consistent
    (the pipeline has settled the core's jobs)."""
    m.samples.reload()
    m.rdt.restart_round()
    m._snap = None
    m.pipeline.update(m.vertices, m.weights)


def _no_progress(stage: str, n: int) -> str:
    return f"no progress: the {stage} stage's {n} refinement points are all existing samples"


def onto_curve(
    surface: ImplicitSurface,
    curve: BoundaryCurve,
    found: Candidates,
    snap: Snapshot,
    sizing: Callable[[np.ndarray], np.ndarray],
) -> tuple[Candidates, np.ndarray]:
    """Refinement points that would become boundary vertices replaced by
    splits of the boundary curve's chords, or moved onto the curve
    (:func:`rdmesh.sampling.boundary.guard_boundary`); returns the points
    kept and those that cannot be placed (left unresolved; optional points
    are dropped instead)."""
    g = guard_boundary(
        surface, curve, found.centres, found.radii, snap.tree, snap.vertices, sizing, found.soft
    )
    if g.snapped.any():
        log.debug("%d refinement points moved onto the boundary curve", int(g.snapped.sum()))
    moved = Candidates(
        found.stage, g.points, g.radii, found.topological, found.violations, soft=found.soft
    )
    return moved.take(g.keep), g.points[~g.keep & ~g.dropped]


def _progress(rounds: int, stage: str, inserted: int, vertices: np.ndarray, t0: float) -> dict:
    """What the progress callback gets after a round."""
    return {
        "round": rounds,
        "stage": stage,
        "inserted": inserted,
        "vertices": len(vertices),
        "seconds": time.perf_counter() - t0,
    }


def _stopped(stop: str, mesh: SurfaceMesh, interrupted: bool, stalled: bool) -> Exception:
    """The exception that carries the partial mesh of a run that stopped early."""
    if interrupted:
        return Interrupted("refinement interrupted", mesh=mesh, reason=stop)
    if stalled:
        return RefinementStalled(f"refinement stopped: {stop}", mesh=mesh, reason=stop)
    return BudgetExceeded(f"refinement stopped early: {stop}", mesh=mesh, reason=stop)


def _cut_facets(m: Mesher, tri: np.ndarray) -> np.ndarray:
    """``(k, 3)`` sample ids of the facets left out by the parity rule that are
    still in the triangulation and not restricted (a facet evaluated again
    with no crossing is counted too: never fewer than there are)."""
    if not m.pipeline.cut:
        return np.zeros((0, 3), np.int64)
    cut = np.unique(np.concatenate(m.pipeline.cut), axis=0)  # sorted ids, as changed_facets
    cut = cut[m.rdt.is_facet(cut)]
    return cut[row_index(cut, np.sort(tri, axis=1)) < 0]


def _cut_centroids(m: Mesher, tri: np.ndarray) -> np.ndarray:
    """Centroids of the facets :func:`_cut_facets` lists; logged when any."""
    cut = m.vertices[_cut_facets(m, tri)].mean(axis=1)
    if len(cut):
        log.warning(
            "%d facets below the spacing floor, whose Voronoi edge crosses the surface an even "
            "number of times, were left out (a wedge or neck thinner than the floor is cut): %s",
            len(cut), describe_regions(regions(cut, REGION_LINK * m.surface.radius)),
        )  # fmt: skip
    return cut


def _relabel(m: Mesher, plan: Plan, snap: Snapshot, t0: float) -> Relabelled | None:
    """The final complex relabelled at its pinched vertices, when the parity
    rule made it the boundary of a cell labelling (closed surfaces only),
    within the run's time limit."""
    if not plan.parity or m.clipped:
        return None
    tri, centres, _ = snap.facets(0)
    seconds = m.budget.left(time.perf_counter() - t0)
    r = relabel_pinches(m.rdt, m.surface, m.vertices, tri, centres, snap.status, max(seconds, 0.0))
    if r is not None:
        log.warning(
            "%d pinched vertices below the spacing floor (an edge in 4 triangles or 2 fans) "
            "were relabelled: %d Delaunay cells moved across the surface, %d faces differ "
            "from the restricted Delaunay triangulation (%s)%s",
            r.pinched, r.cells, len(r.changed),
            describe_regions(regions(r.changed, REGION_LINK * m.surface.radius)),
            f"; {len(r.left)} vertices are still pinched" if len(r.left) else "",
        )  # fmt: skip
        if r.timed_out:
            log.warning("the time limit ended the relabelling of pinched vertices")
    return r


def _pockets(m: Mesher, faces: np.ndarray) -> Pockets | None:
    """Output components smaller than the size bound (without one, 1 % of the
    bounding radius) that are not kept: on a remeshed input, those on input
    components that a larger output component covers (ruled out by a closed
    input's topology, below the bound's resolution on an open or
    self-intersecting one); on a function or an expression, the specks next
    to unresolved points."""
    if m.clipped:
        return None

    def bound(p: np.ndarray) -> np.ndarray:
        s = m.criteria.sizing(p)
        return np.full(len(p), UNBOUNDED_SIZE * m.surface.radius) if s is None else s

    if hasattr(m.surface, "input_components"):
        p = drop_pockets(
            m.vertices, faces, m.surface.input_components, bound, m.surface.topology_known
        )
    elif isinstance(m.surface, VolumeSurface):
        # A volume's interpolant has real components of any size next to the
        # refused points (a node just above the isovalue): none is dropped.
        return None
    else:
        unresolved = np.concatenate(m.unresolved) if m.unresolved else np.zeros((0, 3))
        p = drop_specks(m.vertices, faces, unresolved, bound)
    if p is not None:
        log.warning(
            "output components smaller than the size bound were dropped: %d (%d faces), %s (%s)",
            len(p.centres), p.faces, pocket_reason(p.ruled_out, p.specks),
            describe_regions(regions(p.centres, REGION_LINK * m.surface.radius)),
        )  # fmt: skip
    return p


def _result(
    m: Mesher, plan: Plan, t0: float, evals0: int, ivals0: int, stop: str | None
) -> SurfaceMesh:
    """The mesh of the final samples, with its topology report and statistics."""
    snap = m.snapshot()
    confirm_defects(snap)  # the report's edge and disk tests count every facet
    tri, centres, _ = snap.facets(0)
    relabelled = _relabel(m, plan, snap, t0)
    faces = tri
    if relabelled is not None:
        faces, centres = relabelled.faces, relabelled.centres
    pockets = _pockets(m, faces)
    if pockets is not None:
        faces, centres = faces[pockets.keep], centres[pockets.keep]
    caps = cut_caps(m.surface, plan.features, plan.balls, m.ball_ids, faces, centres)
    if caps is not None:  # an open mesh's holes, kept
        faces, centres = faces[caps.keep], centres[caps.keep]
    unresolved = np.concatenate(m.unresolved) if m.unresolved else np.zeros((0, 3))
    mesh = SurfaceMesh.from_facets(m.vertices, faces, centres, unresolved)
    if plan.balls is not None:
        ids = np.unique(faces)
        mesh.weights = m.samples.weights[ids]
        mesh.features = check_features(
            plan.balls, plan.features, m.ball_ids, ids, mesh.faces, len(mesh.vertices)
        )
        mesh.features.repairs = m.repairs
        mesh.features.angle_held = m.criteria.hold_at_small_balls
        if m.creases is not None:
            mesh.features.unresolved = m.creases.unresolved
    report_interrupted = False
    try:
        with m.timer("report"):
            core.trim_heap()
            mesh.report = topology_report(
                snap,
                method=m.method,
                probes=plan.report_probes(),
                faces=mesh.faces,
                n_mesh_vertices=len(mesh.vertices),
                repaired=m.samples.inserted,
                unresolved=mesh.unresolved,
                complete=not stop,
                critical=plan.critical,
                floor=plan.floor_report,
                discovery=plan.discovery,
                proof=m.certify,
                boundary=plan.boundary if m.clipped else None,
                quick=bool(stop and stop.startswith("time_limit")),
                cut=_cut_centroids(m, tri),
                relabelled=relabelled,
                pockets=pockets,
            )
        mesh.report["features"] = _features_report(mesh, plan)
        if caps is not None:
            mesh.report["holes"] = caps.as_report()
            mesh.report["statement"] += " " + caps.statement()
        if m.creases is not None:
            mesh.report["creases"] = m.creases.as_report()
    except KeyboardInterrupt:
        # The mesh is whole; only the report is missing.
        report_interrupted = True
    timing = m.timer.seconds
    # The loop test's own time (refinement rounds and report).
    timing["voronoi_loop"] = m.memo.seconds
    if len(mesh.unresolved):
        log.warning(
            "%d points left unresolved: refinement points below the spacing floor, or "
            "failing tests without a refinement point (near-singular surface?): %s; see "
            "SurfaceMesh.unresolved",
            len(mesh.unresolved),
            describe_regions(regions(mesh.unresolved, REGION_LINK * m.surface.radius)),
        )
    mesh.stats.update(
        seconds=time.perf_counter() - t0,
        rounds=m.rounds,
        evaluations=m.surface.evaluations - evals0,
        interval_evaluations=getattr(m.surface.f, "interval_evaluations", 0) - ivals0,
        segment_queries=getattr(m.surface, "segment_queries", 0) - m.segment_queries0,
        samples=len(m.vertices),
        inserted=dict(m.samples.inserted),
        facets_evaluated=m.pipeline.evaluated,
        facets_reused=m.pipeline.rdt.reused_facets,
        facets_cleared=m.pipeline.rdt.cleared_facets,
        fine_clearing=_fine_stats(m.pipeline),
        slope_bound=_slope_stats(m.pipeline.slope),
        distance_check=_distance_stats(plan),
        exact_circumcentres=m.pipeline.rdt.exact_circumcentres,
        phase_seconds={k: round(v, 4) for k, v in timing.items()},
        unresolved=len(mesh.unresolved),
        loop_facets_tested=m.memo.tested,
        method=m.method,
        topology=m.topology,
    )
    if report_interrupted:
        mesh.complete = False
        mesh.stats["stop_reason"] = "interrupted during the report"
        raise Interrupted("interrupted during the report", mesh=mesh, reason="interrupted")
    report = getattr(m.surface, "input_report", None)
    euler = None if mesh.report is None else mesh.report["euler"]
    output = (mesh.vertices, mesh.faces, euler)
    problems = None if report is None else report(mesh.unresolved, output)
    if problems is not None and mesh.report is not None:
        # What in the input stands in the way of its topology (issue 30).
        mesh.report["input"] = problems
        if problems["statement"]:
            mesh.report["statement"] += " The input: " + problems["statement"] + "."
    if stop:
        mesh.complete = False
        mesh.stats["stop_reason"] = stop
    elif plan.features_abandoned:
        mesh.complete = False
        mesh.stats["stop_reason"] = "feature curves not protected: " + plan.features_abandoned
    elif mesh.features is not None and not mesh.features.held:
        mesh.complete = False
        f = mesh.features
        mesh.stats["stop_reason"] = (
            f"feature check failed: {f.edges - f.edges_kept} of {f.edges} curve edges and "
            f"{len(f.corners) - f.corners_kept} corners not kept (SurfaceMesh.features.failed)"
        )
        log.warning("%s", mesh.stats["stop_reason"])
    elif problems is not None and problems["incomplete"]:
        mesh.complete = False
        mesh.stats["stop_reason"] = problems["statement"]
    elif len(mesh.unresolved):
        mesh.complete = False
        mesh.stats["stop_reason"] = (
            f"{len(mesh.unresolved)} points unresolved (below the spacing floor, or "
            "violations without a refinement point)"
        )
    return mesh


def _features_report(mesh: SurfaceMesh, plan: Plan) -> dict | None:
    """``report["features"]``: the check's outcome, or why the curves rdmesh
    found were left unprotected (their creases then cut by triangles)."""
    if mesh.features is not None:
        return mesh.features.as_report()
    if plan.features_abandoned:
        return {"held": False, "abandoned": plan.features_abandoned, "balls": 0}
    return None
