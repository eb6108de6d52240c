"""The passes over the blocks on one cluster: statistics, trace, protect and project, mesh."""

from __future__ import annotations

import dataclasses
import logging
import time

import numpy as np

from .._errors import EmptySurfaceError
from ..features.given import ProtectingBalls
from .field import Params, value_scale
from .layout import Layout
from .network import (
    Network,
    centres_to_project,
    protect_network,
    set_centres,
    settle,
    share,
)
from .run import run_all
from .source import Source, face_box
from .tasks import (
    BlockResult,
    FaceJob,
    MeshJob,
    mesh_task,
    project_task,
    stats_task,
    trace_task,
)

log = logging.getLogger("rdmesh")

#: Times the seams' balls are shrunk where a block's feature check failed (or a
#: triangle at a ball fell below 20 degrees) and the blocks there meshed again.
MAX_REPAIRS = 3


class Blocks:
    """The passes over the blocks, on one cluster."""

    def __init__(self, client, source: Source, layout: Layout, radius: float, vol, opts):
        self.client, self.source, self.layout = client, source, layout
        self.radius, self.vol, self.opts = radius, vol, opts
        self.blocks = layout.blocks()
        self.names = [f"block {b}" for b in self.blocks]
        self.seconds: dict[str, float] = {}
        self.degree = 3 if vol["interpolation"] == "cubic" else 1
        self.params: Params | None = None
        self.peak_mb = 0.0

    def _run(self, fn, items, stage):
        t = time.perf_counter()
        out = run_all(self.client, fn, items, stage, self.names, prepare=self._load)
        self.seconds[stage] = self.seconds.get(stage, 0.0) + time.perf_counter() - t
        return out

    def _load(self, item):
        """A job with its windows read (sliced from a numpy volume, or lazy
        slices of any other), just before it is submitted: the jobs hold only
        where their windows are until then, so the windows in memory at once
        are those of the tasks in flight."""
        if isinstance(item, FaceJob):
            return dataclasses.replace(item, pieces=[self.source.piece(*w) for w in item.pieces])
        if isinstance(item, MeshJob):
            return dataclasses.replace(item, piece=self.source.piece(*item.piece))
        window, *rest = item
        return (self.source.piece(*window), *rest)

    def parameters(self) -> Params:
        """The isovalue (checked against the data's range) and the value scale."""
        lay, iso = self.layout, self.vol["isovalue"]

        def jobs(with_iso):
            out = []
            for blk in self.blocks:
                lo, hi = lay.index_box(blk)
                out.append(((lo, hi, None), lo, with_iso, lay.spacing))
            return out

        stats = self._run(_stats, jobs(iso), "statistics")
        bad = [(s, b) for s, b in zip(stats, self.blocks, strict=True) if s.get("bad")]
        if any("dtype" in s for s in stats):
            raise ValueError(f"volume must hold real numbers, got dtype {stats[0]['dtype']}")
        if bad:
            total = sum(s["bad"] for s, _ in bad)
            raise ValueError(
                f"volume must be finite: {total} NaN or infinite samples, the first at index "
                f"{bad[0][0]['where']}"
            )
        lo, hi = min(s["min"] for s in stats), max(s["max"] for s in stats)
        if lo == hi:
            raise EmptySurfaceError(f"the volume is constant ({lo:g}): it has no isosurface")
        if iso is None:
            iso = 0.5 * (lo + hi)
            stats = self._run(_stats, jobs(iso), "statistics")
        if not lo < iso < hi:
            raise EmptySurfaceError(
                f"isovalue {iso:g} is outside the range of the volume's data, ({lo:g}, {hi:g}): "
                "there is no isosurface"
            )
        scale = value_scale([s["slopes"] for s in stats])
        sign = 1.0 if self.vol["inside"] == "greater" else -1.0
        self.params = Params(float(iso), sign, scale, self.degree)
        self.range = (lo, hi)
        log.info("blocks: %d blocks %s, isovalue %g, value scale %g", len(self.blocks),
                 lay.counts, iso, scale)  # fmt: skip
        return self.params

    def _face_jobs(self, faces_of) -> list[FaceJob]:
        jobs = []
        for blk in self.blocks:
            faces = faces_of(blk)
            pieces = [(*face_box(self.layout, f), self.degree) for f in faces]
            jobs.append(FaceJob(blk, self.layout, self.params, faces, pieces, radius=self.radius))
        return jobs

    def trace(self, h: float) -> list:
        """Every face's curves, in the layout's order of faces."""
        jobs = self._face_jobs(self.layout.owned_faces)
        for j in jobs:
            j.h = h
        out = self._run(trace_task, jobs, "trace")
        self.peak_mb = max([self.peak_mb] + [o[1] for o in out])
        return [t for o in out for t in o[0]]

    def project(self, net: Network) -> dict:
        """Put the network's curve balls on the true curves (by the faces' tracers)."""
        index = {f: i for i, f in enumerate(net.faces)}
        which = {f: centres_to_project(net, index[f]) for f in net.faces}
        jobs = self._face_jobs(
            lambda blk: [f for f in self.layout.owned_faces(blk) if len(which[f])]
        )
        for j in jobs:
            j.centres = [net.balls.centres[which[f]] for f in j.faces]
        jobs = [j for j in jobs if j.faces]
        out = self._run(project_task, jobs, "project") if jobs else []
        stuck = 0
        for j, res in zip(jobs, out, strict=True):
            for f, (x, on) in zip(j.faces, res, strict=True):
                stuck += set_centres(net, which[f], x, on)
        settled = settle(net.balls)
        ProtectingBalls(net.balls, net.graph)  # the invariants the core relies on
        return {"unprojected_centres": stuck, "radii_settled": settled}

    def mesh(self, traces, edge, distance) -> tuple[list[BlockResult], Network, dict]:
        """Protect, project, mesh; repair where a block's check failed."""
        lay = self.layout
        face_ids = {f: i for i, f in enumerate(tr.face for tr in traces)}
        shrink: list = []
        results: list[BlockResult | None] = [None] * len(self.blocks)
        given: list[ProtectingBalls | None] = [None] * len(self.blocks)
        repairs = {"rounds": 0, "meshed": 0}
        while True:
            t = time.perf_counter()
            net = protect_network(lay, traces, self.radius, edge, distance, shrink)
            self.seconds["protect"] = self.seconds.get("protect", 0.0) + time.perf_counter() - t
            repairs.update(self.project(net))
            shares = [share(net, [face_ids[f] for f in lay.faces_of(b)]) for b in self.blocks]
            todo = [i for i, s in enumerate(shares) if given[i] is None or not _same(given[i], s)]
            if not todo:  # shrinking changed no block's balls: meshing again changes nothing
                return results, net, repairs  # type: ignore[return-value]
            jobs = [
                MeshJob(self.blocks[i], i, lay, self.params,
                        (*lay.index_box(self.blocks[i]), self.degree),
                        shares[i], self.opts)
                for i in todo
            ]  # fmt: skip
            names = self.names
            self.names = [names[i] for i in todo]
            try:
                out = self._run(mesh_task, jobs, "mesh")
            finally:
                self.names = names
            for i, r in zip(todo, out, strict=True):
                results[i], given[i] = r, shares[i]
                self.peak_mb = max(self.peak_mb, r.peak_mb)
            repairs["meshed"] += len(todo)
            sites = [r.sites for r in results if r is not None and len(r.sites[0])]
            if not sites or repairs["rounds"] == MAX_REPAIRS:
                return results, net, repairs  # type: ignore[return-value]
            shrink.append((np.concatenate([s[0] for s in sites]),
                           np.concatenate([s[1] for s in sites])))  # fmt: skip
            repairs["rounds"] += 1
            log.info("blocks: shrinking seam balls at %d places, meshing again",
                     len(shrink[-1][0]))  # fmt: skip


def _stats(job):
    piece, first, iso, spacing = job
    return stats_task(piece, first, iso, spacing)


def _same(a: ProtectingBalls, b: ProtectingBalls) -> bool:
    """The same balls (a block with them need not be meshed again)."""
    x, y = a.balls, b.balls
    return (
        np.array_equal(x.centres, y.centres)
        and np.array_equal(x.radii, y.radii)
        and np.array_equal(x.pairs, y.pairs)
    )
