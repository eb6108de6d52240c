"""``mesh_volume_blocks``: a volume meshed block by block on a Dask cluster, seamlessly."""

from __future__ import annotations

import logging
import time
from typing import Any

import numpy as np

from .._validate import integer
from ..io.result import SurfaceMesh
from ..refine.ball_spacing import small_balls
from .field import halo
from .layout import Layout
from .options import MIN_BLOCK, check_border, criteria_of, parse_options, trace_spacing
from .passes import Blocks
from .report import whole_report
from .source import Source
from .weld import seam_check, weld

log = logging.getLogger("rdmesh")


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
        the tasks themselves, so the volume is never in one process (an
        ``h5py`` dataset is reopened on the workers from its file's name,
        which must be the same path there).
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
    vol, mesh_opts = parse_options(options)
    source = Source(volume, vol["interpolation"])
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
    criteria, edge = criteria_of(mesh_opts, radius)
    from ..batch.runner import _cluster

    with _cluster(client, workers, "auto") as dask_client:
        run = Blocks(dask_client, source, layout, radius, vol, mesh_opts)
        run.parameters()
        traces = run.trace(trace_spacing(mesh_opts, layout))
        check_border(layout, traces, vol["border"])
        results, net, repairs = run.mesh(traces, edge, criteria.distance_bound)
    mesh = weld(results)
    seams = seam_check(mesh, net, layout)
    # The blocks' runs held the angle bound next to small balls (mesh_surface's rule).
    small = small_balls(mesh_opts.get("edge_size"), criteria.radius_bound)
    mesh.features.angle_held = bool(len(net.balls)) and small
    mesh.report = whole_report(mesh, layout, results, seams, net, vol, repairs)
    _finish(mesh, results, seams, run, t0, repairs)
    return mesh


def _finish(mesh, results, seams, run: Blocks, t0: float, repairs: dict) -> None:
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
