"""What the workers run: read a window of the volume, then trace, project or mesh.

Every task gets a :class:`Piece` per window it needs: the samples themselves
(a numpy input, sliced by the client) or a lazy ``dask.array`` slice that the
task computes in its own process (a zarr or HDF5 input, a generated array),
so the volume is read where it is used and never held whole by one process.
"""

from __future__ import annotations

import logging
import resource
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .._errors import EmptySurfaceError, StoppedEarly
from ..features.check import repair_sites
from ..features.given import ProtectingBalls
from ..surfaces.oracle import ImplicitSurface
from .field import Field, Params, as_float, block_slopes, block_stats
from .layout import Block, Face, Layout
from .trace import FaceTrace, project_on_face, trace_face

log = logging.getLogger("rdmesh")

#: Triangles next to a ball below this angle (degrees) are places to repair.
REPAIR_ANGLE = 20.0
#: Entries of a block's report sent back, to be summed over the blocks.
REPORT_KEYS = (
    "seeding", "probes", "singular_points", "spacing_floor", "unresolved_regions",
    "violation_regions",
)  # fmt: skip


@dataclass
class Piece:
    """One window of samples ``[a, b]`` (inclusive; past the volume's ends it is
    mirrored): ``data`` (numpy, or a lazy dask array of the part inside the
    volume) and the mirror padding ``pads`` on each side."""

    data: Any
    a: np.ndarray
    pads: list[tuple[int, int]]

    def read(self) -> np.ndarray:
        data = self.data
        if hasattr(data, "dask"):  # a dask array: read it here, in this process
            data = data.compute(scheduler="sync")
        arr = as_float(data)
        if any(p != (0, 0) for p in self.pads):
            arr = np.pad(arr, self.pads, mode="reflect")
        return arr


def peak_memory_mb() -> float:
    """This process's peak resident memory so far, in MiB.

    On Linux, ``VmHWM`` of ``/proc/self/status``: the peak of this process's
    own memory. ``getrusage``'s ``ru_maxrss`` is not used there: a worker
    process forked from a large parent and then exec'd keeps the parent's
    resident size at the fork as its maximum (the client's volume would count
    as every worker's memory).
    """
    try:
        with open("/proc/self/status", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("VmHWM:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        pass
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 1024


# -- statistics -------------------------------------------------------------------------


def stats_task(piece: Piece, first: np.ndarray, isovalue: float | None, spacing) -> dict:
    """A block's smallest and largest sample and non-finite samples; with an
    isovalue, also the quantiles of its slopes across the isosurface."""
    data = piece.data.compute(scheduler="sync") if hasattr(piece.data, "dask") else piece.data
    out = block_stats(np.asarray(data), first)
    if isovalue is not None and "min" in out and not out["bad"]:
        out["slopes"] = block_slopes(data, isovalue, spacing)
    return out


# -- tracing and projecting the seams ---------------------------------------------------


@dataclass
class FaceJob:
    """The faces one block traces (or whose ball centres it projects)."""

    block: Block
    layout: Layout
    params: Params
    faces: list[Face]
    #: Per face: its window, read (a Piece) when the job is submitted; until
    #: then ``(lo, hi, degree)``, where it is.
    pieces: list[Any]
    h: float = 0.0
    #: Per face: the centres to project (k, 3), for a projection job.
    centres: list[np.ndarray] = field(default_factory=list)
    radius: float = 1.0


def _field(job: FaceJob, piece: Piece) -> Field:
    lay = job.layout
    return Field(piece.read(), piece.a, lay.origin, lay.spacing, job.params)


def trace_task(job: FaceJob) -> tuple[list[FaceTrace], float]:
    """Trace the block's faces; returns the traces and the process's peak memory."""
    out = [
        trace_face(_field(job, p), job.layout, f, job.h, job.radius)
        for f, p in zip(job.faces, job.pieces, strict=True)
    ]
    return out, peak_memory_mb()


def project_task(job: FaceJob) -> list[tuple[np.ndarray, np.ndarray]]:
    """Project each face's centres onto its curve: ``(points, converged)`` per face."""
    out = []
    for f, p, x in zip(job.faces, job.pieces, job.centres, strict=True):
        if len(x) == 0:
            out.append((x, np.zeros(0, bool)))
            continue
        out.append(project_on_face(_field(job, p), job.layout, f, x, job.radius))
    return out


# -- meshing a block --------------------------------------------------------------------


@dataclass
class MeshJob:
    """One block to mesh with the balls of its faces."""

    block: Block
    index: int
    layout: Layout
    params: Params
    #: The block's window, as for FaceJob.pieces.
    piece: Any
    balls: ProtectingBalls
    options: dict


@dataclass
class BlockResult:
    """A block's mesh and what its run reported.

    Attributes
    ----------
    vertices, faces, facet_centres, unresolved : the block's mesh (empty when
        the block holds no surface).
    complete : False when a budget stopped it, its feature check failed or
        points were left unresolved.
    stop_reason : why, or None.
    held : the feature check (None without balls).
    failed : (k, 3) where the feature check failed.
    sites : ((k, 3), (k,)): places to shrink the balls (failed check, and
        triangles at a ball below :data:`REPAIR_ANGLE`).
    stats : the run's statistics (seconds, rounds, evaluations, ...).
    report : the run's report entries that add up over blocks
        (:data:`REPORT_KEYS`).
    peak_mb : the worker process's peak memory after the run, in MiB.
    """

    block: Block
    index: int
    vertices: np.ndarray
    faces: np.ndarray
    facet_centres: np.ndarray
    unresolved: np.ndarray
    complete: bool = True
    stop_reason: str | None = None
    held: bool | None = None
    failed: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    sites: tuple = field(default_factory=lambda: (np.zeros((0, 3)), np.zeros(0)))
    stats: dict = field(default_factory=dict)
    report: dict = field(default_factory=dict)
    peak_mb: float = 0.0


def block_surface(job: MeshJob) -> ImplicitSurface:
    """The block's surface: ``f`` of the volume on the block's window, clipped
    to the block's box, with the balls of its faces."""
    lay = job.layout
    fld = _field(job, job.piece)  # type: ignore[arg-type]
    box = lay.box(job.block)
    centre = 0.5 * (box[0] + box[1])
    radius = 1.1 * 0.5 * float(np.linalg.norm(box[1] - box[0]))
    return ImplicitSurface(
        fld.f, (centre, radius), gradient=fld.gradient, name=f"block {job.block}",
        clip_box=box, features=job.balls,
    )  # fmt: skip


def mesh_task(job: MeshJob) -> BlockResult:
    """Mesh one block (``mesh_surface`` with ``topology="manifold-with-boundary"``)."""
    from ..api import mesh_surface

    t0 = time.perf_counter()
    surface = block_surface(job)
    try:
        mesh = mesh_surface(surface, topology="manifold-with-boundary", **job.options)
    except EmptySurfaceError:
        none = np.zeros((0, 3))
        res = BlockResult(job.block, job.index, none, np.zeros((0, 3), np.int64), none, none)
        res.stats = {"seconds": time.perf_counter() - t0, "vertices": 0, "empty": True}
        res.peak_mb = peak_memory_mb()
        return res
    except StoppedEarly as exc:
        mesh = exc.mesh
    res = BlockResult(
        job.block, job.index, mesh.vertices, mesh.faces, mesh.facet_centres, mesh.unresolved,
        complete=mesh.complete, stop_reason=mesh.stats.get("stop_reason"),
    )  # fmt: skip
    if mesh.features is not None:
        res.held = mesh.features.held
        res.failed = mesh.features.failed
        if mesh.complete:  # a stopped run's thin triangles say nothing about its balls
            res.sites = repair_sites(mesh, REPAIR_ANGLE)
    keep = ("seconds", "rounds", "evaluations", "samples", "vertices", "faces", "unresolved")
    res.stats = {k: mesh.stats[k] for k in keep if k in mesh.stats}
    res.stats["balls"] = len(job.balls)
    res.report = {k: mesh.report.get(k) for k in REPORT_KEYS}
    res.stats["min_angle"] = mesh.min_angle if len(mesh.faces) else None
    res.peak_mb = peak_memory_mb()
    return res
