"""``mesh_volume_blocks``: a volume meshed block by block on a Dask cluster, seamlessly."""

from __future__ import annotations

import dataclasses
import logging
import math
import time
from typing import Any

import numpy as np

from .._errors import EmptySurfaceError
from .._validate import choice, integer
from ..features.given import ProtectingBalls
from ..io.result import SurfaceMesh
from ..refine.criteria import FacetCriteria
from .field import Params, halo, raw_range, value_scale
from .layout import Layout, others
from .network import (
    Network,
    centres_to_project,
    protect_network,
    set_centres,
    settle,
    share,
)
from .report import whole_report
from .run import run_all
from .tasks import (
    BlockResult,
    FaceJob,
    MeshJob,
    Piece,
    mesh_task,
    project_task,
    stats_task,
    trace_task,
)
from .weld import seam_check, weld

log = logging.getLogger("rdmesh")

#: Volume options (as :class:`rdmesh.VolumeSurface` takes them).
VOLUME_OPTIONS = ("spacing", "origin", "isovalue", "inside", "interpolation", "border", "name")
#: mesh_surface options passed to every block.
MESH_OPTIONS = (
    "angle_bound", "radius_bound", "distance_bound", "edge_size", "seed", "seed_resolution",
    "max_vertices", "time_limit", "method", "topology", "certify",
)  # fmt: skip
#: Times the seams' balls are shrunk where a block's feature check failed (or a
#: triangle at a ball fell below 20 degrees) and the blocks there meshed again.
MAX_REPAIRS = 3
#: The face grid's spacing: at most this fraction of the edge size ...
TRACE_FRACTION = 0.25
#: ... and of the smallest sample spacing.
TRACE_SAMPLES = 0.5
#: Smallest block, in cells.
MIN_BLOCK = 8


def mesh_volume_blocks(
    volume: Any,
    block: int = 256,
    *,
    client: Any = None,
    workers: int | None = None,
    **options: Any,
) -> SurfaceMesh:
    """Mesh the isosurface of a volume block by block on a Dask cluster, with seams that match.

    The volume is cut into blocks of at most ``block`` cells along each axis.
    The curves where the isosurface meets the faces between blocks are
    traced once, protected once by balls placed for all of them together,
    and each block is meshed (``mesh_surface`` with the volume clipped to
    the block's box) with exactly the balls of its six faces; the two blocks
    at a face therefore have the same boundary vertices and edges there,
    and the blocks' meshes are welded by merging equal vertices into one
    mesh. Each task reads only its block (or face) and a halo around it.

    Parameters
    ----------
    volume : (n0, n1, n2) array_like
        The samples: a numpy array, a ``dask.array``, or anything
        ``dask.array.from_array`` takes (a zarr array, an HDF5 dataset).
        Real numbers (booleans count as 0 and 1). A numpy array is sliced
        here and each window sent with its task; anything else is read by
        the tasks themselves, so the volume is never in one process.
    block : int, default 256
        Largest block size in cells along each axis (at least 8). The blocks
        along an axis are as equal as can be.
    client : distributed.Client, optional
        The cluster to run on (it is left open). Default: a local cluster of
        ``workers`` worker processes, one thread each, started and closed
        here (Dask's ``MALLOC_TRIM_THRESHOLD_`` dropped, as in
        :func:`rdmesh.mesh_many`).
    workers : int, optional
        Worker processes of the local cluster; default one per core. Not
        allowed with ``client``.
    **options
        The volume's options, as :class:`rdmesh.VolumeSurface` takes them
        (``spacing``, ``origin``, ``isovalue``, ``inside``, ``interpolation``,
        ``border``, ``name``), and :func:`rdmesh.mesh_surface`'s for every
        block (``angle_bound``, ``radius_bound``, ``distance_bound``,
        ``edge_size``, ``seed``, ``seed_resolution``, ``max_vertices`` and
        ``time_limit``, both per block). ``radius_bound`` defaults to a
        twentieth of the whole volume's bounding radius, as
        ``mesh_surface(VolumeSurface(volume))`` would use.

    Returns
    -------
    SurfaceMesh
        The welded mesh. ``complete`` is False when a block stopped early
        (a budget), a seam failed its check, or an edge has one triangle
        away from the volume's box or more than two; ``stats["stop_reason"]``
        says which and ``report["seams"]`` where. ``features`` is the
        feature check of every seam and outer curve against the welded mesh.
        ``report`` holds the topology of the whole (``components``,
        ``euler``, ``boundary_loops``, ``closed_manifold``), ``seams`` and
        ``blocks`` (per block: its box, vertices, seconds, the worker's peak
        memory).

    Raises
    ------
    TypeError
        A ``client`` that is not a ``distributed.Client`` (an address string).
    ValueError
        A volume that is not 3-D, holds non-real or non-finite values, or has
        too few samples; a bad ``block``, unknown options, ``features``,
        ``method`` other than Boissonnat-Oudot, ``certify=True``, a topology
        that does not match the border; ``border="closed"`` (the default)
        for an isosurface that reaches the volume's faces (see Notes).
    rdmesh.EmptySurfaceError
        A constant volume or an isovalue outside the data range.
    rdmesh.FeatureError
        The seam curves cannot be protected (curves closer than ``1e-6 R``:
        a block face almost tangent to the isosurface, or crossing it
        exactly at a saddle); another block size moves the faces.
    ImportError
        Dask is not installed (``pip install 'rdmesh[dask]'``).

    Notes
    -----
    The interpolant is that of :class:`rdmesh.VolumeSurface`, except that
    the cubic B-spline's prefilter is truncated at 12 samples (so that a
    block needs only its halo); the two differ by about 1e-7 of the data
    range. The output does not depend on the number of workers: every task
    computes the same values from the same samples, and the weld runs in
    block order.

    ``border="clipped"`` meshes the part inside the volume's box, with a
    boundary on its faces (protected like the seams). ``border="closed"``
    closes the isosurface by the box in :class:`VolumeSurface`; in blocks
    this is done only when the isosurface does not reach the box (then the
    two borders give the same surface); otherwise ``ValueError`` names the
    fix (pad the volume with a layer of outside values, or use
    ``border="clipped"``).

    Where the isosurface is tangent to a block face, a loop of the curve
    smaller than the face grid (half a sample) can be missed; the blocks then
    mesh that place separately and the weld finds the open edges there:
    ``complete=False``, ``report["seams"]["open_where"]``.
    """
    t0 = time.perf_counter()
    vol, mesh_opts = _options(options)
    source = _Source(volume, vol["interpolation"])
    block = integer("block", block, lo=MIN_BLOCK)
    if client is not None and workers is not None:
        raise ValueError("workers sets up the local cluster; with a client, scale it instead")
    if client is not None and not (hasattr(client, "submit") and hasattr(client, "nthreads")):
        raise TypeError(
            "client must be a distributed.Client (for a scheduler address: "
            f"Client('tcp://host:8786')), got {type(client).__name__}"
        )
    if workers is not None:
        workers = integer("workers", workers, lo=1)
    layout = Layout.of(source.shape, block, vol["spacing"], vol["origin"])
    box = layout.whole_box
    radius = 1.1 * 0.5 * float(np.linalg.norm(box[1] - box[0]))
    criteria, edge = _criteria(mesh_opts, radius)
    from ..batch.runner import _cluster

    with _cluster(client, workers, "auto") as dask_client:
        run = _Blocks(dask_client, source, layout, radius, vol, mesh_opts)
        run.parameters()
        traces = run.trace(_trace_spacing(mesh_opts, layout))
        _check_border(layout, traces, vol["border"])
        results, net, repairs = run.mesh(traces, edge, criteria.distance_bound)
    mesh = weld(results)
    seams = seam_check(mesh, net, layout)
    mesh.report = whole_report(mesh, layout, results, seams, net, vol, repairs)
    _finish(mesh, results, seams, run, t0, repairs)
    return mesh


def _options(options: dict) -> tuple[dict, dict]:
    """The volume's options (checked, with defaults) and the blocks' mesh_surface options."""
    for k in options:
        if k == "features":
            raise ValueError(
                "features= is not available in blocks: the blocks' balls are the seams' "
                "(mesh the volume with VolumeSurface to keep given curves)"
            )
        if k not in VOLUME_OPTIONS and k not in MESH_OPTIONS:
            raise ValueError(
                f"unknown option {k!r}; volume options: {', '.join(VOLUME_OPTIONS)}; mesh "
                f"options: {', '.join(MESH_OPTIONS)}"
            )
    vol = {
        "spacing": _three("spacing", options.get("spacing", (1.0, 1.0, 1.0)), True),
        "origin": _three("origin", options.get("origin", (0.0, 0.0, 0.0)), False),
        "isovalue": options.get("isovalue"),
        "inside": choice("inside", options.get("inside", "greater"), ("greater", "less")),
        "interpolation": choice(
            "interpolation", options.get("interpolation", "cubic"), ("cubic", "linear")
        ),
        "border": choice("border", options.get("border", "closed"), ("closed", "clipped")),
        "name": str(options.get("name", "volume")),
    }
    if vol["isovalue"] is not None:
        try:
            iso = float(vol["isovalue"])
        except (TypeError, ValueError):
            raise ValueError(f"isovalue must be a number, got {vol['isovalue']!r}") from None
        if not math.isfinite(iso):
            raise ValueError(f"isovalue must be finite, got {vol['isovalue']!r}")
        vol["isovalue"] = iso
    mesh = {k: v for k, v in options.items() if k in MESH_OPTIONS}
    method = mesh.pop("method", "boissonnat-oudot")
    if method != "boissonnat-oudot":
        raise ValueError(
            f"method {method!r} cannot mesh blocks: each block is clipped to its box, which "
            "only method='boissonnat-oudot' meshes"
        )
    if mesh.pop("certify", None):
        raise ValueError("certify=True is not available for volumes (nothing is proven)")
    topology = mesh.pop("topology", None)
    want = "manifold" if vol["border"] == "closed" else "manifold-with-boundary"
    if topology not in (None, want):
        raise ValueError(
            f"topology {topology!r} does not match border={vol['border']!r}, whose mesh is "
            f"{want!r}"
        )
    return vol, mesh


def _three(name: str, value: Any, positive: bool) -> tuple[float, float, float]:
    try:
        v = np.asarray(value, dtype=np.float64).reshape(-1)
    except (TypeError, ValueError):
        v = np.full(0, np.nan)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or (positive and np.any(v <= 0)):
        what = "3 positive finite numbers" if positive else "3 finite numbers"
        raise ValueError(f"{name} must be {what}, one per volume axis, got {value!r}")
    return (float(v[0]), float(v[1]), float(v[2]))


def _criteria(opts: dict, radius: float):
    """The blocks' criteria (checked) and the balls' spacing along the seams."""
    if opts.get("radius_bound") is None:
        opts["radius_bound"] = radius / 20.0
    criteria = FacetCriteria(
        opts.get("angle_bound", 30.0), opts["radius_bound"], opts.get("distance_bound")
    )
    size = opts.get("edge_size")
    if size is None:
        return criteria, criteria.sizing
    if callable(size):
        return criteria, FacetCriteria(0.0, size).sizing
    s = FacetCriteria(0.0, size).radius_bound
    return criteria, lambda x: np.full(len(x), s)


def _trace_spacing(opts: dict, layout: Layout) -> float:
    """The face grids' spacing: a quarter of the edge size, at most half a sample."""
    h = TRACE_SAMPLES * min(layout.spacing)
    for k in ("edge_size", "radius_bound"):
        v = opts.get(k)
        if v is not None and not callable(v):
            return min(h, TRACE_FRACTION * float(v))
    return h


class _Source:
    """The volume as tasks read it: numpy windows, or lazy dask slices."""

    def __init__(self, volume: Any, interpolation: str) -> None:
        self.lazy = not isinstance(volume, np.ndarray)
        if self.lazy:
            try:
                import dask.array as da
            except ImportError as exc:
                raise ImportError(
                    "mesh_volume_blocks needs Dask: pip install 'rdmesh[dask]'"
                ) from exc
            if not isinstance(volume, da.Array):
                if not hasattr(volume, "shape") or not hasattr(volume, "dtype"):
                    volume = np.asarray(volume)
                    self.lazy = False
                else:
                    volume = da.from_array(volume)
        self.data = volume
        self.shape = tuple(int(n) for n in volume.shape)
        dtype = np.dtype(volume.dtype)
        if len(self.shape) != 3:
            raise ValueError(f"volume must be a 3-D array, got {len(self.shape)}-D with shape "
                             f"{self.shape}")  # fmt: skip
        real = np.issubdtype(dtype, np.integer) or np.issubdtype(dtype, np.floating)
        if not (real or dtype == np.bool_):
            raise ValueError(
                f"volume must hold real numbers (integers, floats or booleans), got dtype {dtype}"
            )
        least = 4 if interpolation == "cubic" else 2
        if min(self.shape) < least:
            raise ValueError(
                f"volume must have at least {least} samples along each axis for "
                f"{interpolation} interpolation, got shape {self.shape}"
            )

    def piece(self, lo: np.ndarray, hi: np.ndarray, degree: int | None) -> Piece:
        """The window a region ``[lo, hi]`` of samples needs (``degree`` None:
        the region itself)."""
        a, b = (lo, hi) if degree is None else raw_range(lo, hi, degree)
        sl, pads = [], []
        for k in range(3):
            n = self.shape[k]
            s0, s1 = max(int(a[k]), 0), min(int(b[k]), n - 1)
            sl.append(slice(s0, s1 + 1))
            pads.append((s0 - int(a[k]), int(b[k]) - s1))
        data = self.data[tuple(sl)]
        if self.lazy:
            import dask

            (data,) = dask.optimize(data)
        else:
            data = np.array(data)
        return Piece(data, np.asarray(a, np.int64), pads)


def _face_box(layout: Layout, face) -> tuple[np.ndarray, np.ndarray]:
    a, p, (b0, b1), (c0, c1) = layout.rect(face)
    b, c = others(a)
    lo, hi = np.zeros(3, np.int64), np.zeros(3, np.int64)
    lo[a] = hi[a] = p
    lo[b], hi[b], lo[c], hi[c] = b0, b1, c0, c1
    return lo, hi


class _Blocks:
    """The passes over the blocks, on one cluster."""

    def __init__(self, client, source: _Source, layout: Layout, radius: float, vol, opts):
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
            pieces = [(*_face_box(self.layout, f), self.degree) for f in faces]
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


def _check_border(layout: Layout, traces: list, border: str) -> None:
    """ValueError for a closed border that the isosurface reaches."""
    if border != "closed":
        return
    for tr in traces:
        if layout.is_outer(tr.face) and (tr.curves or tr.inside):
            a, p, _, _ = layout.rect(tr.face)
            side = "low" if p == 0 else "high"
            raise ValueError(
                f"the isosurface reaches the volume's {side} face along axis {a} (block face "
                f"{tr.face}): border='closed' is not available in blocks for a surface closed "
                "by the volume's box; use border='clipped' (a boundary on the box), or pad "
                "the volume with a layer of outside values (numpy.pad with a value on the "
                "outside of the isovalue)"
            )


def _finish(mesh, results, seams, run: _Blocks, t0: float, repairs: dict) -> None:
    """Completeness and statistics of the whole."""
    stopped = [r for r in results if not r.complete and r.stop_reason]
    reasons = []
    if seams["open_edges"] or seams["nonmanifold_edges"]:
        reasons.append(
            f"{seams['open_edges']} open edges away from the volume's box and "
            f"{seams['nonmanifold_edges']} edges with more than two triangles "
            "(report['seams'] says where)"
        )
    if mesh.features is not None and not mesh.features.held:
        f = mesh.features
        reasons.append(f"seam check failed: {f.edges - f.edges_kept} of {f.edges} seam edges "
                       "not kept (SurfaceMesh.features.failed)")  # fmt: skip
    if stopped:
        reasons.append(f"{len(stopped)} blocks incomplete, e.g. {stopped[0].block}: "
                       f"{stopped[0].stop_reason}")  # fmt: skip
    mesh.complete = not reasons
    mesh.report["complete"] = mesh.complete
    if reasons:
        mesh.stats["stop_reason"] = "; ".join(reasons)
        log.warning("mesh_volume_blocks: %s", mesh.stats["stop_reason"])
    mesh.stats.update(
        seconds=time.perf_counter() - t0,
        blocks=len(results),
        phase_seconds={k: round(v, 3) for k, v in run.seconds.items()},
        evaluations=int(sum(r.stats.get("evaluations", 0) for r in results)),
        repairs=repairs["rounds"],
        blocks_meshed=repairs["meshed"],
        peak_worker_mb=round(run.peak_mb, 1),
        halo=halo(run.degree),
        method="boissonnat-oudot",
        topology="manifold" if run.vol["border"] == "closed" else "manifold-with-boundary",
    )
