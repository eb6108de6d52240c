"""A batch job and its result: :class:`Job` and :class:`JobResult`."""

from __future__ import annotations

import inspect
import os
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

from ..io.result import SurfaceMesh
from ..surfaces.oracle import ImplicitSurface

Status = Literal["ok", "stopped", "failed"]

#: The outcomes of a job, in the order the summaries give them.
STATUSES: tuple[Status, ...] = ("ok", "stopped", "failed")

#: ``mesh_surface`` keywords a job may not set: a progress bar has no place on a worker.
_NOT_PER_JOB = ("progress",)


def mesh_surface_options() -> tuple[str, ...]:
    """The keyword arguments of :func:`rdmesh.mesh_surface` a job may set.

    Read from its signature, so that a keyword added to ``mesh_surface`` is a
    job option at once.
    """
    from ..api import mesh_surface

    params = inspect.signature(mesh_surface).parameters
    return tuple(
        name
        for name, p in params.items()
        if p.kind is inspect.Parameter.KEYWORD_ONLY and name not in _NOT_PER_JOB
    )


def check_options(options: Mapping[str, Any], where: str) -> dict[str, Any]:
    """``options`` as a dict, if every key is a keyword of ``mesh_surface``.

    Raises
    ------
    TypeError
        An unknown keyword (as a function call would), or ``progress``.
    """
    allowed = mesh_surface_options()
    for key in options:
        if key in _NOT_PER_JOB:
            raise TypeError(
                f"{where}: {key!r} cannot be set per job (the jobs run on workers); "
                "use mesh_many(progress=True) for a progress bar over the jobs"
            )
        if key not in allowed:
            raise TypeError(
                f"{where}: unexpected keyword {key!r}; mesh_surface takes {', '.join(allowed)}"
            )
    return dict(options)


class Job:
    """One surface to mesh in :func:`rdmesh.mesh_many`, with its own options.

    Parameters
    ----------
    surface : ImplicitSurface or callable
        The surface (anything :func:`rdmesh.mesh_surface` takes), or a
        function of no arguments that makes it on the worker. A function is
        the way for a surface that holds large data or C++ state: a
        :class:`~rdmesh.VolumeSurface` cannot be sent to a worker, but
        ``functools.partial(load, path)`` can, and the volume is then read
        where it is meshed. Either must pickle (with cloudpickle, which
        handles lambdas and closures).
    output : str or os.PathLike, optional
        Write the mesh (the partial mesh of a stopped job too) to this file,
        on the worker, in the format its extension names (``.ply``, ``.obj``,
        ...; see :meth:`SurfaceMesh.save`). The mesh is then not sent back:
        :attr:`JobResult.mesh` is None and :attr:`JobResult.output` holds the
        path. The file is written under a temporary name and renamed, so it
        is either whole or absent. On a cluster the path must be one that
        the workers can write.
    name : str, optional
        A label for the results and logs; default the surface's ``name``
        (or ``"job <index>"``).
    **options
        Keyword arguments of :func:`rdmesh.mesh_surface` (``radius_bound``,
        ``time_limit``, ``seed``, ...), over the defaults given to
        :func:`rdmesh.mesh_many`. ``progress`` is refused.

    Raises
    ------
    TypeError
        A keyword that ``mesh_surface`` does not take, or a surface that is
        neither an :class:`ImplicitSurface` nor callable.
    """

    def __init__(
        self,
        surface: ImplicitSurface | Callable[[], ImplicitSurface],
        output: str | os.PathLike | None = None,
        *,
        name: str | None = None,
        **options: Any,
    ) -> None:
        if not isinstance(surface, ImplicitSurface) and not callable(surface):
            raise TypeError(
                "a job's surface must be an rdmesh.ImplicitSurface or a function of no "
                f"arguments that makes one, got {type(surface).__name__}"
            )
        self.surface = surface
        self.output = None if output is None else os.fspath(output)
        self.name = name
        self.options = check_options(options, "Job")

    def __repr__(self) -> str:
        what = self.name or getattr(self.surface, "name", None) or type(self.surface).__name__
        extra = "".join(f", {k}={v!r}" for k, v in self.options.items())
        out = f", output={self.output!r}" if self.output else ""
        return f"Job({what!r}{out}{extra})"


@dataclass
class JobResult:
    """The outcome of one job of :func:`rdmesh.mesh_many`.

    Attributes
    ----------
    index : int
        The job's position in the list given to ``mesh_many``.
    name : str
        The job's label.
    status : {"ok", "stopped", "failed"}
        "ok": the mesh is complete. "stopped": a budget (``time_limit``,
        ``max_vertices``) or a stalled refinement ended the run
        (:class:`rdmesh.BudgetExceeded`); :attr:`mesh` is the partial mesh.
        "failed": no mesh, :attr:`error` says why: the surface or
        ``mesh_surface`` raised, the job could not be sent to a worker, its
        worker process died (an exit, a crash, the memory limit), or it did
        not answer within the hard timeout.
    error : str or None
        What went wrong ("failed"), or which budget ended the run ("stopped");
        None for "ok".
    mesh : SurfaceMesh or None
        The mesh, or the partial mesh of a stopped job; None when the job
        failed or wrote its mesh to :attr:`output`.
    output : str or None
        The file the mesh was written to (``Job(output=...)``).
    stats : dict
        The mesh's :attr:`SurfaceMesh.stats` (vertices, faces, rounds, ...);
        empty when the job failed.
    report : dict
        The mesh's topology report (:attr:`SurfaceMesh.report`); empty when
        the job failed.
    topology : dict
        A short summary of the mesh: ``vertices``, ``faces``,
        ``components``, ``euler`` (per component), ``genus`` (per
        component), ``closed_manifold``, ``min_angle`` (degrees),
        ``tbp_holds`` and ``certified`` (from the report); empty when the job
        failed.
    seconds : float
        Wall time of the job on its worker: making the surface, meshing,
        writing. For a job whose worker died or that timed out, the time
        from its start (or submission) until that was noticed.
    worker : str or None
        The address of the worker that ran it, when known.
    """

    index: int
    name: str
    status: Status
    error: str | None = None
    mesh: SurfaceMesh | None = None
    output: str | None = None
    stats: dict[str, Any] = field(default_factory=dict)
    report: dict[str, Any] = field(default_factory=dict)
    topology: dict[str, Any] = field(default_factory=dict)
    seconds: float = 0.0
    worker: str | None = None

    @property
    def ok(self) -> bool:
        """True when the job finished with a complete mesh (status "ok")."""
        return self.status == "ok"

    def __repr__(self) -> str:
        what = f", error={self.error!r}" if self.error else ""
        size = f", vertices={self.topology['vertices']}" if "vertices" in self.topology else ""
        return (
            f"JobResult({self.index}, {self.name!r}, {self.status!r}{size}{what}, "
            f"seconds={self.seconds:.2f})"
        )


def summarise(mesh: SurfaceMesh) -> dict[str, Any]:
    """The short, JSON-ready summary of a mesh that :attr:`JobResult.topology` holds."""
    topo = mesh.topology()
    report = mesh.report or {}
    angle = mesh.min_angle
    return {
        "vertices": len(mesh.vertices),
        "faces": len(mesh.faces),
        "components": int(topo["components"]),
        "euler": [int(c) for c in topo["euler"]],
        "genus": [float(g) for g in topo["genus"]],
        "closed_manifold": bool(topo["closed_manifold"]),
        "min_angle": None if angle != angle else round(float(angle), 4),
        "tbp_holds": bool(report.get("tbp_holds", False)),
        "certified": bool(report.get("certified", False)),
    }
