"""What a worker runs for one job: make the surface, mesh it, write it.

Everything a job can raise becomes its :class:`JobResult`; only the death of
the worker process (or its restart after the hard timeout) escapes, and the
client records that.
"""

from __future__ import annotations

import logging
import os
import time
from dataclasses import dataclass, field
from typing import Any

from .._errors import BudgetExceeded
from ..io.result import SurfaceMesh
from ..surfaces.oracle import ImplicitSurface
from .job import JobResult, summarise
from .transport import loads

log = logging.getLogger("rdmesh")


@dataclass
class Task:
    """A job as the worker receives it (pickled by :mod:`.transport`)."""

    index: int
    name: str
    surface: Any
    options: dict[str, Any] = field(default_factory=dict)
    output: str | None = None


def announce(topic: str | None) -> str | None:
    """Tell the client (through the scheduler's events) that this job started here;
    returns the worker's address, or None outside a Dask worker."""
    try:
        from distributed import get_worker

        worker = get_worker()
    except (ImportError, ValueError):
        return None
    if topic:
        # Through the worker's client, which waits for the scheduler to have it:
        # the worker's own log_event is sent a few ms later, and a job that kills
        # its worker at once would then look as if it had never started.
        from distributed import get_client

        msg = {"key": str(worker.get_current_task()), "worker": worker.address}
        get_client().log_event(topic, msg)
    return worker.address


def run_task(payload: bytes, index: int, name: str, topic: str | None = None) -> JobResult:
    """Run the pickled :class:`Task` ``payload`` (job ``index``, called ``name``);
    the function the client submits."""
    address = announce(topic)
    t0 = time.perf_counter()
    try:
        task: Task = loads(payload)
    except Exception as exc:  # noqa: BLE001 - e.g. a module missing on this worker
        result = JobResult(
            index,
            name,
            "failed",
            error=f"the job could not be unpickled on the worker (is everything it uses "
            f"importable there?): {type(exc).__name__}: {_one_line(exc)}",
        )
    else:
        result = run(task)
    result.seconds = time.perf_counter() - t0
    result.worker = address
    return result


def run(task: Task) -> JobResult:
    """Mesh one job in this process and record its outcome."""
    from ..api import mesh_surface

    def failed(why: str) -> JobResult:
        log.info("job %d (%s) failed: %s", task.index, task.name, why)
        return JobResult(task.index, task.name, "failed", error=why)

    try:
        surface = task.surface
        if not isinstance(surface, ImplicitSurface):
            surface = surface()
            if not isinstance(surface, ImplicitSurface):
                return failed(
                    "the job's surface function must return an rdmesh.ImplicitSurface, "
                    f"got {type(surface).__name__}"
                )
        mesh, status, error = mesh_surface(surface, **task.options), "ok", None
    except BudgetExceeded as exc:
        mesh, status, error = exc.mesh, "stopped", _one_line(exc.reason or exc)
    except MemoryError as exc:
        return failed(f"out of memory (MemoryError{': ' + _one_line(exc) if str(exc) else ''})")
    except Exception as exc:  # noqa: BLE001 - a job may raise anything; it is recorded
        return failed(f"{type(exc).__name__}: {_one_line(exc)}")
    result = JobResult(task.index, task.name, status, error=error)
    if mesh is None:
        return result
    result.stats, result.report, result.topology = mesh.stats, mesh.report, summarise(mesh)
    if task.output is None:
        result.mesh = mesh
        return result
    try:
        write(mesh, task.output)
    except (OSError, ValueError) as exc:
        return failed(f"cannot write {task.output!r}: {_one_line(exc)}")
    result.output = task.output
    return result


def write(mesh: SurfaceMesh, path: str) -> None:
    """Write ``mesh`` to ``path`` through a temporary file in the same folder, so
    that ``path`` is either the whole mesh or absent."""
    folder, base = os.path.split(os.path.abspath(path))
    stem, ext = os.path.splitext(base)
    os.makedirs(folder, exist_ok=True)
    temporary = os.path.join(folder, f".{stem}.{os.getpid()}.partial{ext}")
    try:
        mesh.save(temporary)
        os.replace(temporary, path)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)


def _one_line(what: Any) -> str:
    return " ".join(str(what).split()) or type(what).__name__
