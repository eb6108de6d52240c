"""The Boissonnat-Oudot refinement driver (algorithm.md, section 2).

Each round: the C++ core reports the facets whose dual changed; their duals
are searched for crossings (one vectorised pass of ``f``); the criteria mark
bad facets; the worst candidates that are independent under the batching rule
(no chosen centre inside another chosen ball) are inserted together, which
equals a valid sequential run. When no facet is bad, the manifold stage
refines singular edges, boundary edges, non-manifold vertices and samples
without facets, as CGAL's Manifold_tag does, plus the isolated-sample rule.

``method="topological-ball"`` (Cheng-Dey-Ramos-Ray, algorithm.md 3) runs the
same loop with other stages: first the topological-ball tests of
:mod:`rdmesh.topology` until all hold, then the facet criteria; when no facet
is bad the tests run again, and the run ends when both are satisfied.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from . import _rdt
from ._errors import BudgetExceeded, Interrupted
from .complex import complex_status
from .criteria import FacetCriteria
from .facets import SAMPLING, DualSamples, evaluate_facets
from .oracles import ImplicitSurface
from .result import SurfaceMesh
from .seeding import critical_points, grid_scan, surface_probes
from .topology import (
    CELL_NORMAL_ANGLE,
    PROBE_TARGET,
    Probes,
    describe_regions,
    disk_test,
    isolated_test,
    regions,
    run_tests,
    topology_report,
    voronoi_facet_test,
)
from .voronoi_loops import LoopMemo

log = logging.getLogger("rdmesh")

RESTRICTED, BAD, OUTWARD, TOPO = 1, 2, 4, 8
TOPOLOGIES = ("manifold", "manifold-with-boundary", "non-manifold")
#: Refinement points closer than this (times the bounding radius) are refused.
MIN_SPACING = 1e-7
#: Points driven only by topology are refused below this fraction of the size bound.
TOPOLOGY_FLOOR = 0.01
#: Facets per chunk from the core, and per evaluation slice: bound the memory
#: of a round's temporaries (32k: 8 % less peak memory than 64k on the sphere
#: at 89k samples; each chunk costs a call of find_root, about 3.5 ms).
CORE_CHUNK = 1 << 15
CHUNK = 1 << 15
FIRST_CHUNK = 1 << 13
#: Names of the Boissonnat-Oudot manifold stages (CGAL's words) per topology test.
BO_STAGES = {"voronoi_facet": "edge", "disk": "vertex", "isolated": "isolated"}
#: Safety cap on rounds; smooth inputs need tens.
MAX_ROUNDS = 2000
METHODS = ("boissonnat-oudot", "topological-ball")
#: Topological-ball method without a size bound: points driven by topology are
#: refused below this fraction of the bounding radius (the spacing floor that
#: ends refinement at singular points); they go to SurfaceMesh.unresolved.
TB_FLOOR = 1e-4
#: Topological-ball method without a size bound: grid seeds on large bands are
#: thinned to this fraction of the bounding radius (small bands keep all).
TB_SEED_SPACING = 0.25


@dataclass
class Budget:
    """Limits on a run; None means unlimited."""

    max_vertices: int | None = None
    time_limit: float | None = None
    max_rounds: int = MAX_ROUNDS


@dataclass
class _State:
    rdt: _rdt.RestrictedDelaunay
    vertices: np.ndarray
    rounds: int = 0
    changed: int = 0
    inserted: dict[str, int] = field(default_factory=dict)
    timing: dict[str, float] = field(default_factory=dict)
    unresolved: list[np.ndarray] = field(default_factory=list)
    crossings: np.ndarray | None = None
    grid_spacing: float = 0.0
    probes: Probes | None = None
    critical: object = None
    phase: str = "tbp"
    loops: LoopMemo = field(default_factory=LoopMemo)


class Refiner:
    """One meshing run: owns the triangulation and the refinement loop."""

    def __init__(
        self,
        surface: ImplicitSurface,
        criteria: FacetCriteria,
        topology: str = "manifold",
        seed: int = 0,
        budget: Budget | None = None,
        seed_resolution: int = 64,
        progress: Callable[[dict], None] | None = None,
        workers: int = 1,
        method: str = "boissonnat-oudot",
    ) -> None:
        if method not in METHODS:
            raise ValueError(f"unknown method {method!r}; use one of {', '.join(METHODS)}")
        if topology not in TOPOLOGIES:
            raise ValueError(f"unknown topology {topology!r}; use one of {', '.join(TOPOLOGIES)}")
        self.surface = surface
        self.criteria = criteria
        self.topology = topology
        self.seed = seed
        self.budget = budget or Budget()
        self.seed_resolution = seed_resolution
        self.h_min = MIN_SPACING * surface.radius
        self.progress = progress
        self.workers = workers
        self.method = method
        self.tb = method == "topological-ball"
        #: Floor of topology-driven points when there is no size bound.
        self.topo_floor = TB_FLOOR * surface.radius if self.tb else self.h_min

    def run(self) -> SurfaceMesh:
        t0 = time.perf_counter()
        surface = self.surface
        evals0 = surface.evaluations
        rng = np.random.default_rng(self.seed)
        spacing = (
            self.criteria.radius_bound if isinstance(self.criteria.radius_bound, float) else None
        )
        if self.tb and self.criteria.radius_bound is None:
            # No size bound: seeds only need to find the components; the tests
            # add what the topology needs.
            spacing = TB_SEED_SPACING * surface.radius
        st = _State(_rdt.RestrictedDelaunay(surface.centre, surface.radius), np.zeros((0, 3)))
        with _timed(st, "seeding"):
            scan = grid_scan(surface, rng, self.seed_resolution, spacing=spacing)
            seeds, st.crossings, st.grid_spacing = scan.seeds, scan.crossings, scan.spacing
            if self.tb:
                seeds = self._tb_seeds(st, rng, seeds)
        stop = None
        cap = self.budget.max_vertices
        if cap is not None and len(seeds) > cap:
            seeds, stop = seeds[:cap], f"max_vertices={cap} reached"
        self._insert(st, seeds, "seeds")
        interrupted = False
        try:
            stop = self._loop(st, t0, stop)
        except KeyboardInterrupt:
            # Keep the samples inserted so far and evaluate the interrupted
            # round again from its start, so the partial mesh is consistent.
            interrupted, stop = True, "interrupted"
            st.vertices = st.rdt.samples()
            st.rdt.restart_round()
            self._update(st)
        mesh = self._finish(st, t0, evals0, stop)
        if interrupted:
            raise Interrupted("refinement interrupted", mesh=mesh, reason=stop)
        if stop:
            raise BudgetExceeded(f"refinement stopped early: {stop}", mesh=mesh, reason=stop)
        return mesh

    def _loop(self, st: _State, t0: float, stop: str | None) -> str | None:
        """Refinement rounds until nothing is bad or a budget runs out."""
        cap = self.budget.max_vertices
        while stop is None:
            st.rounds += 1
            self._update(st)
            with _timed(st, "candidates"):
                centres, radii, stage = self._candidates(st)
            if len(centres) == 0:
                break
            stop = self._check_budget(st, t0)
            if stop:
                break
            with _timed(st, "select"):
                batch = centres[_rdt.select_independent(centres, radii)]
            if cap is not None and len(st.vertices) + len(batch) > cap:
                batch = batch[: max(0, cap - len(st.vertices))]
                stop = f"max_vertices={cap} reached"
            self._insert(st, batch, stage)
            log.debug("round %d: %s stage, %d samples", st.rounds, stage, len(st.vertices))
            if self.progress is not None:
                self.progress(
                    {
                        "round": st.rounds,
                        "stage": stage,
                        "inserted": len(batch),
                        "vertices": len(st.vertices),
                        "seconds": time.perf_counter() - t0,
                    }
                )
        if stop:
            self._update(st)
        return stop

    def _tb_seeds(self, st: _State, rng: np.random.Generator, seeds: np.ndarray) -> np.ndarray:
        """Grid seeds plus the critical points of a random height; probes for the tests."""
        surface, h = self.surface, st.grid_spacing
        crit = critical_points(surface, np.concatenate([seeds, st.crossings]), rng, h)
        st.critical = crit
        if len(crit.points):
            # Grid seeds right next to a critical point only add short edges.
            d, _ = cKDTree(crit.points).query(seeds)
            seeds = np.concatenate([crit.points, seeds[d > 0.5 * h]])
        st.probes = Probes.on(
            surface, surface_probes(surface, st.crossings, h, rng, PROBE_TARGET), h
        )
        st.phase = "tbp"
        return seeds

    def _finish(self, st: _State, t0: float, evals0: int, stop: str | None) -> SurfaceMesh:
        mesh = self._mesh(st)
        with _timed(st, "report"):
            _rdt.trim_heap()
            mesh.report = self._report(st, mesh, complete=not stop)
        # The loop test's own time (refinement rounds and report).
        st.timing["voronoi_loop"] = st.loops.seconds
        if len(mesh.unresolved):
            log.warning(
                "%d refinement points were below the spacing floor and not inserted "
                "(near-singular surface?): %s; see SurfaceMesh.unresolved",
                len(mesh.unresolved),
                describe_regions(regions(mesh.unresolved, 0.05 * self.surface.radius)),
            )
        mesh.stats.update(
            seconds=time.perf_counter() - t0,
            rounds=st.rounds,
            evaluations=self.surface.evaluations - evals0,
            samples=len(st.vertices),
            inserted=dict(st.inserted),
            facets_evaluated=st.changed,
            phase_seconds={k: round(v, 4) for k, v in st.timing.items()},
            unresolved=len(mesh.unresolved),
            loop_facets_tested=st.loops.tested,
            method=self.method,
            topology=self.topology,
        )
        if stop:
            mesh.complete = False
            mesh.stats["stop_reason"] = stop
        return mesh

    # -- steps --------------------------------------------------------------

    def _insert(self, st: _State, points: np.ndarray, stage: str) -> None:
        n0 = len(st.vertices)
        with _timed(st, "insert"):
            # A round's freed temporaries stay with malloc (two threads: two
            # arenas) and add up to the peak: 270 -> 227 MB at 89k samples
            # on the sphere.
            _rdt.trim_heap()
            ids = st.rdt.insert(points)
        new = ids >= n0
        grown = np.empty((st.rdt.number_of_samples, 3))
        grown[:n0] = st.vertices
        grown[ids[new]] = points[new]
        st.vertices = grown
        st.inserted[stage] = st.inserted.get(stage, 0) + int(new.sum())

    def _update(self, st: _State) -> None:
        """Evaluate the facets whose dual changed and hand the flags to C++.

        The core hands out the changed facets in chunks (bounded memory), with
        their dual segments sampled. While Python evaluates one chunk, a
        background thread (GIL released) hands the flags of the previous chunk
        to the core and computes the next chunk, so both cores work; the
        thread runs its jobs in order, as the core requires. ``f`` is evaluated
        once for all Voronoi vertices of a chunk, then once for all samples.
        """
        updates = []
        with ThreadPoolExecutor(1) as core:
            # A small first chunk: Python waits for it with nothing to overlap.
            job = core.submit(st.rdt.changed_facets, FIRST_CHUNK, **SAMPLING)
            while True:
                with _timed(st, "changed_facets"):
                    tri, seg, end_index, ends, rho, samples = job.result()
                if len(tri) == 0:
                    break
                job = core.submit(st.rdt.changed_facets, CORE_CHUNK, **SAMPLING)
                with _timed(st, "evaluate"):
                    end_f = self.surface(ends)[end_index]
                    flags, centres = self._evaluate(
                        st, tri, seg, end_f, rho, DualSamples(*samples)
                    )
                updates.append(core.submit(st.rdt.update_facets, flags, centres))
                st.changed += len(tri)
        with _timed(st, "update_facets"):
            for u in updates:
                u.result()  # re-raises a failure

    def _evaluate(self, st, tri, seg, end_f, rho, samples):
        """Flags (restricted, bad, topology, outward) and surface centres."""
        k = len(tri)
        flags = np.zeros(k, np.uint8)
        centres = np.zeros((k, 3))

        def work(sl: slice) -> None:
            t = tri[sl]
            ev = evaluate_facets(
                self.surface, st.vertices[t[:, 0]], seg[sl], rho[sl], end_f[sl], samples.take(sl)
            )
            r = ev.restricted
            bad = np.zeros(len(t), bool)
            bad[r] = self.criteria.bad(st.vertices[t[r]], ev.centre[r], ev.radius[r])
            topo = r & ((ev.n_cross >= 2) | ev.tangential)
            flags[sl] = (
                (r * RESTRICTED) | (bad * BAD) | (topo * TOPO) | ((r & ev.outward) * OUTWARD)
            )
            centres[sl] = ev.centre

        step = CHUNK if self.workers == 1 else -(-k // self.workers)
        slices = [slice(i, min(i + step, k)) for i in range(0, k, step)]
        if self.workers > 1 and len(slices) > 1:
            with ThreadPoolExecutor(self.workers) as pool:
                list(pool.map(work, slices))
        else:
            for sl in slices:
                work(sl)
        return flags, centres

    def _report(self, st: _State, mesh: SurfaceMesh, complete: bool) -> dict:
        """The topology report, from the tests re-run on the final samples."""
        tri, centres, flags = st.rdt.facets(0)
        probes = st.probes
        if probes is None and st.crossings is not None:
            probes = Probes.on(self.surface, st.crossings, st.grid_spacing)
        sizing = self.criteria.radius_bound
        floor = None
        if self.tb:
            floor = (
                {"topology": f"{TOPOLOGY_FLOOR:g} x radius_bound"}
                if sizing is not None
                else {"topology": self.topo_floor}
            )
        return topology_report(
            method=self.method,
            surface=self.surface,
            vertices=st.vertices,
            tri=tri,
            centres=centres,
            flags=flags,
            probes=probes,
            topo_bit=TOPO,
            faces=mesh.faces,
            n_mesh_vertices=len(mesh.vertices),
            repaired=st.inserted,
            unresolved=mesh.unresolved,
            complete=complete,
            critical=st.critical,
            floor=floor,
            rdt=st.rdt,
            memo=st.loops,
        )

    def _tb_candidates(self, st: _State) -> tuple[np.ndarray, np.ndarray, str]:
        """Topological-ball stages (algorithm.md 3.2).

        Phase "tbp": the tests of :mod:`rdmesh.topology` in order until all
        hold. Phase "geometric": Voronoi-edge violations, then bad facets, and
        when none is left the tests again (a batch can break the property);
        the run ends when nothing fails.
        """
        st.unresolved = []
        tests = None
        if st.phase == "geometric":
            tri, centres, flags = st.rdt.facets(TOPO)
            found = self._floor(
                st, centres, self._radii(st, tri, centres), topo=True, stage="voronoi_edge"
            )
            if found is not None:
                return found
            tri, centres, _ = st.rdt.facets(BAD)
            found = self._floor(
                st, centres, self._radii(st, tri, centres), topo=False, stage="facet"
            )
            if found is not None:
                return found
            tests = ("voronoi_facet", "voronoi_loop", "disk", "isolated", "silhouette")
        tri, centres, flags = st.rdt.facets(0)
        kw = {} if tests is None else {"only": tests}
        for v in run_tests(
            self.surface,
            st.vertices,
            tri,
            centres,
            flags,
            st.probes,
            TOPO,
            silhouette_angle=CELL_NORMAL_ANGLE,
            rdt=st.rdt,
            memo=st.loops,
            **kw,
        ):
            found = self._floor(st, v.centres, v.radii, topo=True, stage=v.kind)
            if found is not None:
                return found
        if st.phase == "tbp":
            log.debug("topological ball property holds at %d samples", len(st.vertices))
            st.phase = "geometric"
            unresolved = st.unresolved
            out = self._tb_candidates(st)
            st.unresolved = unresolved + st.unresolved
            return out
        return np.zeros((0, 3)), np.zeros(0), "done"

    def _candidates(self, st: _State) -> tuple[np.ndarray, np.ndarray, str]:
        """Refinement points with their ball radii, from the first stage that has any.

        Stages: bad facets (criteria, or several/tangential crossings), then
        unless non-manifold output is allowed singular and boundary edges and
        non-manifold vertices, then samples without facets. Points closer to
        the mesh than the floor are refused and kept in ``st.unresolved``.
        """
        if self.tb:
            return self._tb_candidates(st)
        st.unresolved = []
        tri, centres, flags = st.rdt.facets(BAD | TOPO)
        radii = self._radii(st, tri, centres)
        found = self._floor(st, centres, radii, topo=(flags & BAD) == 0, stage="facet")
        if found is not None:
            return found
        tri, centres, _ = st.rdt.facets(0)
        radii = self._radii(st, tri, centres)
        for v in self._manifold_defects(st, tri, centres, radii):
            found = self._floor(st, v.centres, v.radii, topo=True, stage=BO_STAGES[v.kind])
            if found is not None:
                return found
        return np.zeros((0, 3)), np.zeros(0), "done"

    def _manifold_defects(self, st: _State, tri, centres, radii):
        """Violations of the manifold stages in CGAL's order (edges, then vertices),
        then samples without facets; lazily, so later stages cost only when reached."""
        if self.topology != "non-manifold":
            status = complex_status(tri, len(st.vertices))
            allow = self.topology == "manifold-with-boundary"
            yield voronoi_facet_test(status, centres, radii, allow_boundary=allow)
            yield disk_test(status, tri, centres, radii)
        yield isolated_test(self.surface, st.vertices, tri)

    def _floor(self, st, centres, radii, topo, stage):
        """Keep the points whose ball is above the spacing floor; None if none are.

        Criteria-driven points stop at a numerical floor; points driven only by
        topology stop at a fraction of the size bound, so singular surfaces
        terminate (algorithm.md 7.1).
        """
        if len(centres) == 0:
            return None
        floor = np.full(len(centres), self.h_min)
        topo = np.broadcast_to(topo, len(centres))
        if topo.any():
            psi = self.criteria.sizing(centres[topo])
            if psi is not None:
                floor[topo] = np.maximum(self.h_min, TOPOLOGY_FLOOR * psi)
            else:
                floor[topo] = self.topo_floor
        keep = radii > floor
        if not keep.all():
            st.unresolved.append(centres[~keep])
        if not keep.any():
            return None
        return centres[keep], radii[keep], stage

    def _radii(self, st: _State, tri: np.ndarray, centres: np.ndarray) -> np.ndarray:
        return np.linalg.norm(centres - st.vertices[tri[:, 0]], axis=1)

    def _check_budget(self, st: _State, t0: float) -> str | None:
        b = self.budget
        if st.rounds > b.max_rounds:
            return f"max_rounds={b.max_rounds} reached"
        if b.time_limit is not None and time.perf_counter() - t0 > b.time_limit:
            return f"time_limit={b.time_limit:g}s reached"
        if b.max_vertices is not None and len(st.vertices) >= b.max_vertices:
            return f"max_vertices={b.max_vertices} reached"
        return None

    def _mesh(self, st: _State) -> SurfaceMesh:
        tri, centres, _ = st.rdt.facets(0)
        used, faces = np.unique(tri, return_inverse=True)
        faces = faces.reshape(-1, 3).astype(np.int64)
        # Deterministic output: each face starts at its smallest id (orientation
        # kept), faces sorted by ids.
        shift = np.argmin(faces, axis=1)
        faces = faces[np.arange(len(faces))[:, None], (shift[:, None] + np.arange(3)) % 3]
        order = np.lexsort(faces.T[::-1])
        unresolved = np.concatenate(st.unresolved) if st.unresolved else np.zeros((0, 3))
        mesh = SurfaceMesh(
            vertices=st.vertices[used],
            faces=faces[order],
            facet_centres=centres[order],
            unresolved=unresolved,
        )
        mesh.stats.update(vertices=len(used), faces=len(faces))
        return mesh


@contextmanager
def _timed(st: _State, phase: str):
    t = time.perf_counter()
    try:
        yield
    finally:
        st.timing[phase] = st.timing.get(phase, 0.0) + time.perf_counter() - t
