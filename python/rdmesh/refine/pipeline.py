"""The facet pipeline: changed facets -> crossings and criteria -> flags in the core.

After each insertion the core reports the facets whose dual changed, in
chunks, with each dual segment already sampled. While Python evaluates one
chunk (``f`` once at the chunk's Voronoi vertices, once at its samples), a
background thread, with the GIL released, hands the previous chunk's flags to
the core and computes the next chunk, so both cores work. The thread runs its
jobs in order, as the core requires.

A failure or a Ctrl-C in the middle of a round waits until the worker has run
its queued jobs, even through further Ctrl-Cs, so that nothing touches the
core from two threads and the round can be restarted.

With ``workers > 1`` the slices of a chunk are evaluated on a pool of that
many threads, started with the pipeline and stopped by :meth:`close`.
"""

from __future__ import annotations

import signal
import sys
import threading
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from contextlib import contextmanager

import numpy as np

from .. import core
from ..sampling.boundary import BOUNDARY_ANGLE_FLOOR
from ..sampling.fine_clearing import FineClearing
from ..sampling.grid import check_sphere_ends
from ..sampling.screen import SlopeBound
from ..surfaces._mesh_tents import tent_slack
from ..surfaces.oracle import ImplicitSurface
from .criteria import FacetCriteria
from .facets import SAMPLING, DualSamples, evaluate_facets
from .methods import at_boundary, boundary_sizing
from .timing import PhaseTimer

#: Facets per chunk from the core, and per evaluation slice: bound the memory
#: of a round's temporaries (32k: 8 % less peak memory than 64k on the sphere
#: at 89k samples; each chunk costs a call of find_root, about 3.5 ms).
CORE_CHUNK = 1 << 15
CHUNK = 1 << 15
#: A small first chunk: Python waits for it with nothing to overlap.
FIRST_CHUNK = 1 << 13
#: The same with exact crossings (closed meshes): a chunk costs no root
#: search, and the main thread waits for each round's first chunk, so smaller
#: ones keep both threads busy (bone at 0.3 %: 0.12 s of waiting instead of
#: 0.27 s, 2.16-2.28 s instead of 2.21-2.42 s a run; the same mesh).
EXACT_FIRST_CHUNK, EXACT_CHUNK = 1 << 12, 1 << 13
#: What changed_facets takes when the surface gives exact crossings: one
#: interval per segment, no interior samples.
NO_SAMPLES = {**SAMPLING, "min_intervals": 1, "max_intervals": 1}


class FacetPipeline:
    """Evaluates the facets whose dual changed and stores their flags in the core.

    Parameters
    ----------
    rdt : the core.
    surface : ImplicitSurface
    criteria : FacetCriteria
    workers : threads that evaluate slices of a chunk at once.
    timer : where the phases' times go.
    clipped : the surface may cross the bounding sphere (no sphere check).
    """

    def __init__(
        self,
        rdt: core.RestrictedDelaunay,
        surface: ImplicitSurface,
        criteria: FacetCriteria,
        workers: int,
        timer: PhaseTimer,
        clipped: bool = False,
        protected: bool = False,
    ) -> None:
        self.rdt = rdt
        self.surface = surface
        self.criteria = criteria
        self.workers = workers
        self.timer = timer
        #: The surface may leave the ball: no check at the sphere.
        self.clipped = clipped
        #: Protecting balls keep the boundary (if any): no angle exemption there.
        self.protected = protected
        #: The local size bound at the boundary (the angle bound's floor there).
        self.boundary_sizing = (
            boundary_sizing(surface, criteria) if clipped and not protected else None
        )
        #: Facets evaluated so far.
        self.evaluated = 0
        self._weights: np.ndarray | None = None
        #: Dual segments whose root search failed (never used as surface points).
        self.failed = 0
        #: A bound on |grad f| that thins the segments' samples, or None.
        self.slope: SlopeBound | None = None
        #: Fills the core's finer clearing level where the grid clears too little.
        self.fine: FineClearing | None = None
        #: The topology floor at given centres, when facets below it follow the
        #: parity of their crossings (:func:`_cut_by_parity`); else None.
        self.parity_floor: Callable[[np.ndarray], np.ndarray] | None = None
        #: Sample-id triples of the facets so left out (may repeat, may be stale).
        self.cut: list[np.ndarray] = []
        self._worker = ThreadPoolExecutor(1, thread_name_prefix="rdmesh-core")
        #: Evaluates the slices of a chunk at once (workers > 1).
        self._pool = (
            ThreadPoolExecutor(workers, thread_name_prefix="rdmesh-eval") if workers > 1 else None
        )

    def update(self, vertices: np.ndarray, weights: np.ndarray | None = None) -> None:
        """Evaluate every facet whose dual changed since the last update.

        ``vertices`` are the samples, indexed by the core's vertex ids, and
        ``weights`` their weights when some are protecting balls. On any
        exception the core's pending jobs are settled before it propagates.
        """
        self._weights = weights
        try:
            self._update(vertices)
        except BaseException:
            self._settle()
            raise

    def close(self) -> None:
        """Settle the core's jobs and stop the worker thread and the pool."""
        self._settle()
        self._worker.shutdown(wait=False)
        if self._pool is not None:
            self._pool.shutdown(wait=False)

    def _settle(self) -> None:
        """Wait until the worker has run every queued core job, through Ctrl-C.

        The wait is for a no-op job queued last: the worker runs jobs in
        order, so when it has run, every earlier job has ended (the round is
        then restarted, so what they did is redone). Ctrl-C is held off during
        the wait: a KeyboardInterrupt raised inside ``concurrent.futures``
        could leave a future's lock taken and the worker blocked on it.
        """
        with _ctrl_c_deferred():
            self._worker.submit(_nothing).result()

    def _update(self, vertices: np.ndarray) -> None:
        rdt, timed = self.rdt, self.timer
        updates = []
        changed = self._on_worker("core_changed_facets", rdt.changed_facets)
        update = self._on_worker("core_update_facets", rdt.update_facets)
        # Exact crossings (closed meshes) need neither samples nor f at the ends;
        # with a slope bound only the segments it does not clear are sampled
        # (evaluate_facets asks for their samples).
        exact = getattr(self.surface, "exact_crossings", None) is not None
        sampling = NO_SAMPLES if exact or self.slope is not None else SAMPLING
        if self.slope is not None and self.slope.field is not None:
            # A bound raised last round reaches the core now, while its worker
            # is idle: a change during a round would race the next chunk.
            rdt.set_clearing_cap(self.slope.value)
        first, size = (EXACT_FIRST_CHUNK, EXACT_CHUNK) if exact else (FIRST_CHUNK, CORE_CHUNK)
        job = self._worker.submit(changed, first, **sampling)
        last_f = None  # f at the previous chunk's ends
        while True:
            with timed("changed_facets"):
                tri, seg, end_index, ends, rho, samples, f_ends, prev = job.result()
            if len(tri) == 0:
                break
            if self.fine is not None:
                # The worker is idle: its update jobs ran before this chunk was made.
                with timed("fine_clearing"):
                    self.fine.refine()
            job = self._worker.submit(changed, size, **sampling)
            with timed("evaluate"):
                bound = None if self.slope is None else self.slope.for_segments(seg)
                end_f = None
                if exact:
                    f_ends = None
                else:
                    if last_f is not None:
                        # The previous chunk was not updated when this one was made.
                        again = np.flatnonzero((prev >= 0) & np.isnan(f_ends))
                        f_ends[again] = last_f[prev[again]]
                    end_f = _end_values(self, ends, end_index, f_ends)
                    last_f = f_ends
                dual = DualSamples(*samples) if sampling is SAMPLING else None
                flags, centres = _chunk_flags(self, vertices, tri, seg, end_f, rho, dual, bound)
            updates.append(self._worker.submit(update, flags, centres, f_ends))
            self.evaluated += len(tri)
        with timed("update_facets"):
            for u in updates:
                u.result()  # re-raises a failure

    def _on_worker(self, phase: str, call):
        """``call`` timed as ``phase`` (the core thread's busy time, which
        overlaps the main thread's phases)."""
        timed = self.timer

        def run(*args, **kwargs):
            with timed(phase):
                return call(*args, **kwargs)

        return run


def _chunk_flags(p: FacetPipeline, vertices, tri, seg, end_f, rho, samples, bound):
    """Flags (restricted, bad, topology, outward) and surface centres of a
    chunk (``bound``: the slope bound along each segment, or None)."""
    k = len(tri)
    flags = np.zeros(k, np.uint8)
    centres = np.zeros((k, 3))
    steep = np.zeros(k)

    def work(sl: slice) -> int:
        flags[sl], centres[sl], failed, steep[sl] = _slice_flags(
            p, vertices, tri[sl], seg[sl], rho[sl],
            None if end_f is None else end_f[sl],
            None if samples is None else samples.take(sl),
            None if bound is None else bound[sl],
        )  # fmt: skip
        return failed

    step = CHUNK if p._pool is None else -(-k // p.workers)
    slices = [slice(i, min(i + step, k)) for i in range(0, k, step)]
    if p._pool is not None and len(slices) > 1:
        p.failed += sum(p._pool.map(work, slices))
    else:
        p.failed += sum(work(sl) for sl in slices)
    if p.slope is not None:
        # After the whole chunk: the same bounds for any number of workers.
        p.slope.observe(seg, steep, bound)
    return flags, centres


def _end_values(p: FacetPipeline, ends, end_index, f_ends) -> np.ndarray:
    """``f`` at both ends of each segment (k, 2), from ``f_ends`` (u,): known
    where not NaN, the rest evaluated here and written into it. (Clearing a
    segment by one end's ``|f|`` alone, to skip its other end, saved 0.2
    evaluations per vertex on the torus: not done.)"""
    new = np.flatnonzero(np.isnan(f_ends))
    if len(new):
        f_ends[new] = p.surface(ends[new])
        if not p.clipped:
            check_sphere_ends(p.surface, ends[new], f_ends[new])
    return f_ends[end_index]


def _slice_flags(p: FacetPipeline, vertices, tri, seg, rho, end_f, samples, bound):
    """The flags and surface centres of a slice of a chunk, how many of its
    root searches failed, and the steepest slope of f its samples saw."""
    w = p._weights
    ev = evaluate_facets(
        p.surface, vertices[tri[:, 0]], seg, rho, end_f, samples,
        None if w is None else w[tri[:, 0]], bound,
    )  # fmt: skip
    r = ev.restricted
    if p.parity_floor is not None:
        r = r & ~_cut_by_parity(p, ev, tri)
    bad = np.zeros(len(tri), bool)
    corners = vertices[tri[r]]
    exempt = None
    if p.clipped and not p.protected:
        # Facets with an edge on the boundary curve (two vertices on the
        # clipping surface, the sphere or the clip box) are held to the angle
        # bound down to a floor of ball radius.
        exempt = at_boundary(p.surface, corners)
        if exempt.any():
            psi = p.boundary_sizing(ev.centre[r][exempt])
            exempt[exempt] = ev.radius[r][exempt] <= BOUNDARY_ANGLE_FLOOR * psi
    bad[r] = p.criteria.bad(
        corners, ev.centre[r], ev.radius[r], exempt, None if w is None else w[tri[r]],
        tent_slack(p.surface, ev.centre[r]),
    )  # fmt: skip
    topo = r & ((ev.n_cross >= 2) | ev.tangential)
    flags = (
        (r * core.RESTRICTED)
        | (bad * core.BAD)
        | (topo * core.TOPO)
        | ((r & ev.outward) * core.OUTWARD)
        | (ev.clean * core.KNOWN)
    )
    return flags, ev.centre, ev.failed, ev.steep


def _cut_by_parity(p: FacetPipeline, ev, tri: np.ndarray) -> np.ndarray:
    """(k,) bool: facets whose dual edge crosses the surface an even number of
    times, transversally, with a surface ball below the topology floor.

    Such a facet would be refined, and its point refused at the floor. Left
    out, the complex there follows the sign of f at the Voronoi vertices: it
    is the boundary of the cells whose Voronoi vertex is inside, as Mesh_3's
    surface is, so its edges have an even number of triangles where every
    facet around them follows that parity. The wedge or
    neck the two crossings bound, thinner than the floor, is cut (the report
    counts these facets as Voronoi-edge violations).
    """
    cut = ev.restricted & (ev.n_cross >= 2) & (ev.n_cross % 2 == 0) & ~ev.tangential
    idx = np.flatnonzero(cut)
    if len(idx):
        low = ev.radius[idx] <= p.parity_floor(ev.centre[idx])
        cut[idx[~low]] = False
        if low.any():
            p.cut.append(tri[idx[low]])
    return cut


@contextmanager
def _ctrl_c_deferred():
    """Hold SIGINT's Python handler off in the main thread; a Ctrl-C that came
    meanwhile is raised at the end, unless a KeyboardInterrupt is already on
    its way (it says the same)."""
    if threading.current_thread() is not threading.main_thread():
        yield  # KeyboardInterrupt is only ever raised in the main thread
        return
    came = []
    old = signal.signal(signal.SIGINT, lambda *_: came.append(True))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, old)
    if came and not isinstance(sys.exc_info()[1], KeyboardInterrupt) and callable(old):
        old(signal.SIGINT, None)


def _nothing() -> None:
    """The no-op job that marks the end of the worker's queue."""
