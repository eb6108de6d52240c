"""``mesh_many``: many independent jobs on a Dask cluster, each isolated from the others.

The client side. It keeps at most as many jobs in flight as the cluster has
worker threads, so that a job never waits on a worker behind another: a
worker that dies then takes only its own job down, and a job's hard timeout
runs from the moment it starts (each job announces its start through the
scheduler's events). A freed worker's next job is sent before the results
are fetched, and the cluster's size is asked at most once a second, so that a
worker waits one round trip between jobs. Dask schedules; nothing here chooses
a worker.
"""

from __future__ import annotations

import contextlib
import logging
import os
import threading
import time
import uuid
from collections import deque
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass
from typing import Any

from ..surfaces.oracle import ImplicitSurface
from .bar import JobBar
from .job import Job, JobResult, check_options
from .transport import NotSendable, dumps
from .worker import Task, run_task

log = logging.getLogger("rdmesh")

#: Worker deaths a task may cause before Dask gives up on it, on the local
#: cluster that mesh_many starts: 0, since only the job a worker runs can kill it
#: (one waiting behind it, as after a restart or with AHEAD, is sent again).
ALLOWED_FAILURES = 0
#: The default hard timeout of a job with a ``time_limit``: this many times it...
HARD_TIMEOUT_FACTOR = 2.0
#: ... plus this many seconds (making the surface, the report, writing).
HARD_TIMEOUT_MARGIN = 30.0
#: Times a job whose worker died before the job started (so it cannot have killed
#: it: it waited there behind another job, as can happen while a worker restarts) is
#: sent again. A job whose start was announced is never sent again.
UNSTARTED_RETRIES = 3
#: Jobs in flight per worker thread beyond the one it runs. 1 let a worker start
#: its next job without the client's round trip (busy 97 % instead of 92 %), but
#: on 2 cores it gained no wall time (benchmarks/batch_ahead.py, before the next
#: job was sent ahead of fetching results), and a job queued behind a long one
#: waits while another worker may be free. So 0.
AHEAD = 0
#: Seconds between checks of the hard timeouts and of the cluster's size.
POLL = 0.25
#: Seconds the cluster's thread count is reused before it is asked again (one
#: round trip to the scheduler, which would otherwise delay every next job).
CAPACITY_TTL = 1.0
#: Give up on the jobs left when the cluster has had no worker for this long.
NO_WORKERS_TIMEOUT = 300.0
#: Seconds a restarted worker's nanny gets to end the old process.
RESTART_TIMEOUT = 30.0

#: Environment variables that Dask's nannies set in their workers and that slow rdmesh.
_SLOW_ENVIRON = ("MALLOC_TRIM_THRESHOLD_",)

_INSTALL = "mesh_many needs Dask: pip install 'rdmesh[dask]' (dask[distributed])"


def mesh_many(
    jobs: Iterable[Job | ImplicitSurface | Callable[[], ImplicitSurface]],
    *,
    client: Any = None,
    n_workers: int | None = None,
    memory_limit: str | float | int | None = "auto",
    hard_timeout: float | str | None = "auto",
    progress: bool = False,
    on_result: Callable[[JobResult], None] | None = None,
    **defaults: Any,
) -> list[JobResult]:
    """Mesh many surfaces in parallel on a Dask cluster, each job isolated.

    Parameters
    ----------
    jobs : iterable of Job, ImplicitSurface or callable
        Each item is a :class:`Job`, or a surface (anything
        :func:`mesh_surface` takes), or a function of no arguments that makes
        a surface on the worker. Everything must pickle (cloudpickle: lambdas
        and closures do; see :class:`Job` for surfaces that hold C++ state).
    client : distributed.Client, optional
        The cluster to run on, for example ``Client("tcp://scheduler:8786")``;
        it is left open. Default: a local cluster of ``n_workers`` worker
        processes with one thread each, started here and closed at the end.
    n_workers : int, optional
        Worker processes of the local cluster; default one per core
        (``os.cpu_count()``). Not allowed with ``client``.
    memory_limit : str, float, int or None, default "auto"
        Memory of each worker of the local cluster (``"4GiB"``, a number of
        bytes, or "auto": the machine's memory divided by ``n_workers``; None
        or 0: no limit). A worker that goes over 95% of it is restarted by
        its nanny, and its job fails with "out of memory". Not allowed with
        ``client`` (set it where the workers start).
    hard_timeout : float, "auto" or None, default "auto"
        Seconds after which a job that has not answered (a surface function
        that never returns, which ``time_limit`` cannot interrupt) fails and
        its worker is restarted. "auto": twice the job's ``time_limit`` plus
        30 s, or no limit for a job without ``time_limit``. None: no limit.
    progress : bool, default False
        Show a progress bar over the jobs on stderr (tqdm).
    on_result : callable, optional
        Called with each :class:`JobResult` as soon as its job ends, in the
        order the jobs end (in this thread); for example to record it.
    **defaults
        Keyword arguments of :func:`mesh_surface` for every job
        (``radius_bound``, ``time_limit``, ``seed``, ...); a :class:`Job`'s
        own options take precedence. ``progress`` is refused.

    Returns
    -------
    list of JobResult
        One per job, in the order of ``jobs``: ``status`` "ok", "stopped"
        (a budget ended it; ``mesh`` is the partial mesh) or "failed"
        (``error`` says why), the mesh or its output path, its statistics,
        its topology report and the time it took.

    Raises
    ------
    TypeError
        An item that is not a job, a surface or a function, or a keyword
        that ``mesh_surface`` does not take.
    ValueError
        A bad ``n_workers`` or ``hard_timeout``, or ``n_workers`` or
        ``memory_limit`` given with ``client``.
    ImportError
        Dask (``dask[distributed]``) is not installed: ``pip install
        'rdmesh[dask]'``.

    Notes
    -----
    Isolation: a job that raises, runs out of memory, kills its worker
    process (an exit, a segfault, a C++ abort) or passes its hard timeout is
    "failed" with what happened, and the other jobs go on. The local cluster
    lets each task kill at most one worker (Dask's
    ``distributed.scheduler.allowed-failures`` is 0 there: a poisoned job is
    not retried); on a cluster of your own, that setting of its scheduler
    decides how many workers such a job kills before it fails (3 by default).
    A job past its ``time_limit`` is "stopped", with the partial mesh. Each
    job's mesh is the one :func:`mesh_surface` makes in this process with the
    same options and seed: the batch changes where it runs, not what it makes.

    At most as many jobs run at once as the cluster has worker threads, so no
    job waits on a worker behind another one; an adaptive cluster does not
    grow for the batch (scale it first). A worker that the hard timeout
    restarts has to have a nanny (the default); one without is only closed.

    The surface of each job is pickled here and sent to its worker; large
    ones (meshes of millions of triangles) are better made on the worker by a
    function that reads them from a file the workers can reach.

    Examples
    --------
    >>> import rdmesh
    >>> from rdmesh.surfaces import sphere, torus
    >>> results = rdmesh.mesh_many([sphere(), torus()], radius_bound=0.1)  # doctest: +SKIP
    >>> [r.status for r in results]  # doctest: +SKIP
    ['ok', 'ok']
    """
    defaults = check_options(defaults, "mesh_many")
    items = [_as_job(item, i) for i, item in enumerate(jobs)]
    if hard_timeout not in ("auto", None):
        hard_timeout = _positive("hard_timeout", hard_timeout)
    if client is not None and (n_workers is not None or memory_limit != "auto"):
        raise ValueError(
            "n_workers and memory_limit set up the local cluster; with a client, set them "
            "where its workers start"
        )
    if n_workers is not None and (
        isinstance(n_workers, bool) or not isinstance(n_workers, int) or n_workers < 1
    ):
        raise ValueError(f"n_workers must be a positive integer, got {n_workers!r}")
    tasks = [
        Task(
            index=i,
            name=_name(job, i),
            surface=job.surface,
            options={**defaults, **job.options},
            output=job.output,
        )
        for i, job in enumerate(items)
    ]
    if not tasks:
        return []
    limits = [_hard_limit(hard_timeout, t.options.get("time_limit")) for t in tasks]
    with (
        _cluster(client, n_workers, memory_limit) as dask_client,
        JobBar(len(tasks), disable=not progress) as bar,
    ):

        def finish(result: JobResult) -> None:
            bar.update(result)
            if on_result is not None:
                on_result(result)

        return _Runner(dask_client, tasks, limits, finish).run()


def _as_job(item: Any, index: int) -> Job:
    if isinstance(item, Job):
        return item
    if isinstance(item, ImplicitSurface) or callable(item):
        return Job(item)
    raise TypeError(
        f"job {index}: expected an rdmesh.Job, an ImplicitSurface or a function that makes "
        f"one, got {type(item).__name__}"
    )


def _name(job: Job, index: int) -> str:
    if job.name:
        return str(job.name)
    name = getattr(job.surface, "name", None)
    return name if isinstance(name, str) and name else f"job {index}"


def _positive(name: str, value: Any) -> float:
    ok = isinstance(value, (int, float)) and not isinstance(value, bool) and value > 0
    if not ok or value != value or value == float("inf"):
        raise ValueError(
            f"{name} must be a positive number of seconds, 'auto' or None, got {value!r}"
        )
    return float(value)


def _hard_limit(hard_timeout: float | str | None, time_limit: Any) -> float | None:
    """The hard timeout of one job, in seconds, or None."""
    if hard_timeout != "auto":
        return hard_timeout  # type: ignore[return-value]
    if time_limit is None:
        return None
    return HARD_TIMEOUT_FACTOR * float(time_limit) + HARD_TIMEOUT_MARGIN


@contextlib.contextmanager
def _cluster(client: Any, n_workers: int | None, memory_limit: Any) -> Iterator[Any]:
    """``client``, or a client of a new local cluster that is closed afterwards."""
    if client is not None:
        yield client
        return
    try:
        import dask
        from distributed import Client, LocalCluster
        from distributed.utils import silence_logging_cmgr
    except ImportError as exc:
        raise ImportError(_INSTALL) from exc
    n = n_workers or os.cpu_count() or 1
    log.info("starting a local Dask cluster of %d worker processes", n)
    # Read as the scheduler and the nannies start. Dask's nannies set
    # MALLOC_TRIM_THRESHOLD_ in their workers, which turns glibc's adaptive mmap
    # threshold off: numpy's large temporaries are then mapped and unmapped on every
    # use, and rdmesh runs about 30% slower. The BLAS thread limits stay.
    environ = dask.config.get("distributed.nanny.pre-spawn-environ", default={}) or {}
    environ = {k: v for k, v in environ.items() if k not in _SLOW_ENVIRON}
    settings = {
        "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
        "distributed.nanny.pre-spawn-environ": environ,
        # The workers' statistical profiler samples every thread 100 times a second,
        # taking the GIL from the job; nothing here reads its profiles.
        "distributed.worker.profile.enabled": False,
    }
    with dask.config.set(settings):
        cluster = LocalCluster(
            n_workers=n,
            threads_per_worker=1,
            processes=True,
            memory_limit=memory_limit,
            # Its HTTP server on a free port (8787 may be taken), without the dashboard.
            dashboard_address=":0",
            scheduler_kwargs={"dashboard": False},
            silence_logs=logging.CRITICAL,
        )
    try:
        # A worker that dies or is restarted is expected here and recorded in its
        # job's result: the cluster's own log handlers need not shout about it.
        with Client(cluster) as local, silence_logging_cmgr(logging.CRITICAL):
            yield local
    finally:
        cluster.close()


@dataclass
class _Running:
    index: int
    submitted: float
    attempt: int = 0
    started: float | None = None
    worker: str | None = None


class _Runner:
    """Submits the tasks a few at a time, collects them, ends the stuck ones."""

    def __init__(
        self,
        client: Any,
        tasks: list[Task],
        limits: list[float | None],
        finish: Callable[[JobResult], None],
    ) -> None:
        self.client = client
        self.tasks = tasks
        self.limits = limits
        self.finish = finish
        self.results: list[JobResult | None] = [None] * len(tasks)
        self.pending = deque(range(len(tasks)))
        self.attempts = [0] * len(tasks)
        self.running: dict[Any, _Running] = {}
        self.token = uuid.uuid4().hex[:12]
        self.topic = f"rdmesh-batch-{self.token}"
        self._lock = threading.Lock()
        self._starts: dict[str, tuple[float, str]] = {}
        self._empty_since: float | None = None
        self._threads = 0
        self._threads_at: float | None = None

    # -- the loop -------------------------------------------------------------------

    def run(self) -> list[JobResult]:
        from distributed import wait

        self.client.subscribe_topic(self.topic, self._on_start)
        try:
            while self.pending or self.running:
                self._submit()
                if not self.running:
                    time.sleep(POLL)  # no worker yet
                else:
                    try:
                        done, _ = wait(
                            list(self.running), timeout=POLL, return_when="FIRST_COMPLETED"
                        )
                    except TimeoutError:
                        done = set()
                    ended = [(future, self.running.pop(future)) for future in done]
                    # The freed workers get their next jobs before these results are
                    # fetched: each fetch is a round trip they would otherwise wait for.
                    if ended:
                        self._submit()
                    for future, run in ended:
                        self._collect(future, run)
                _enforce_hard_timeouts(self)
                _check_workers(self)
        finally:
            if self.running:  # interrupted: leave nothing behind on the cluster
                self.client.cancel(list(self.running))
            self.client.unsubscribe_topic(self.topic)
        return self.results  # type: ignore[return-value]

    def _record(self, result: JobResult) -> None:
        self.results[result.index] = result
        if result.status == "failed":
            log.info("job %d (%s) failed: %s", result.index, result.name, result.error)
        self.finish(result)

    def _on_start(self, event: tuple[float, dict]) -> None:
        """Scheduler event handler (the client's event loop thread)."""
        msg = event[1]
        with self._lock:
            self._starts[msg["key"]] = (time.monotonic(), msg["worker"])

    def _capacity(self) -> int:
        """The cluster's worker threads, asked of the scheduler at most every
        CAPACITY_TTL seconds (and after a worker died)."""
        now = time.monotonic()
        if self._threads_at is None or now - self._threads_at > CAPACITY_TTL:
            self._threads = sum(self.client.nthreads().values())
            self._threads_at = now
        return self._threads

    # -- submitting and collecting ----------------------------------------------------

    def _submit(self) -> None:
        import dask

        free = self._capacity() * (1 + AHEAD) - len(self.running)
        while self.pending and free > 0:
            i = self.pending.popleft()
            task = self.tasks[i]
            try:
                payload = dumps(task)
            except NotSendable as exc:
                self._record(JobResult(i, task.name, "failed", error=str(exc)))
                continue
            # A job's pickled surface can be large (a mesh); it is meant to travel.
            with dask.config.set({"distributed.admin.large-graph-warning-threshold": "4GiB"}):
                future = self.client.submit(
                    run_task,
                    payload,
                    i,
                    task.name,
                    self.topic,
                    key=f"rdmesh-job-{self.token}-a{self.attempts[i]}-{i}",
                    pure=False,
                )
            self.running[future] = _Running(i, time.monotonic(), self.attempts[i])
            free -= 1

    def _collect(self, future: Any, run: _Running) -> None:
        from distributed import KilledWorker

        task = self.tasks[run.index]
        self._started(future, run)
        try:
            result = future.result()
        except KilledWorker as exc:
            self._threads_at = None  # the cluster has lost a worker, for now
            if run.started is None and run.attempt < UNSTARTED_RETRIES:
                log.info("job %d (%s): its worker died before it started; again", run.index,
                         task.name)  # fmt: skip
                self.attempts[run.index] += 1
                self.pending.appendleft(run.index)
                return
            result = _failed(run, task, _death(self.client, exc), run.worker or _address(exc))
        except Exception as exc:  # noqa: BLE001 - whatever reached the client is recorded
            why = f"{type(exc).__name__}: {' '.join(str(exc).split())}"
            result = _failed(run, task, why, run.worker)
        self._record(result)

    def _started(self, future: Any, run: _Running) -> None:
        if run.started is None:
            with self._lock:
                start = self._starts.pop(future.key, None)
            if start is not None:
                run.started, run.worker = start


# -- the hard timeout and the cluster's health ---------------------------------------


def _enforce_hard_timeouts(r: _Runner) -> None:
    """Fail the jobs past their hard timeout and restart their workers."""
    now = time.monotonic()
    for future, run in list(r.running.items()):
        r._started(future, run)
        limit = r.limits[run.index]
        if limit is None or run.started is None or now - run.started <= limit:
            continue
        del r.running[future]
        future.cancel()
        task = r.tasks[run.index]
        what = f"no answer within its hard timeout of {limit:g} s"
        r._record(
            JobResult(
                run.index,
                task.name,
                "failed",
                error=f"{what}; its worker {run.worker} was restarted",
                seconds=now - run.started,
                worker=run.worker,
            )
        )
        _restart(r.client, run.worker)
        r._threads_at = None


def _address(exc: Any) -> str | None:
    worker = getattr(exc, "last_worker", None)
    return getattr(worker, "address", None)


def _death(client: Any, exc: Any) -> str:
    """Why a job's worker died, as far as the scheduler's events tell."""
    address = _address(exc)
    try:
        events = client.get_events("worker-restart-memory")
    except Exception:  # noqa: BLE001 - only to improve the message
        events = ()
    for _, msg in reversed(list(events)):
        if isinstance(msg, dict) and msg.get("worker") == address:
            rss = msg.get("rss", 0) / 2**30
            return (
                f"out of memory: its worker used {rss:.2f} GiB, over its memory limit, "
                "and was restarted"
            )
    deaths = getattr(exc, "allowed_failures", 0) + 1
    return (
        "its worker process died while running it (an exit, a crash such as a segfault "
        "or a C++ abort, or a kill, e.g. by the system for lack of memory); Dask's "
        f"KilledWorker after {deaths} worker death(s), the last on {address}"
    )


def _restart(client: Any, worker: str | None) -> None:
    log.info("restarting worker %s (a job passed its hard timeout)", worker)
    try:
        client.restart_workers([worker], timeout=RESTART_TIMEOUT, raise_for_error=False)
    except Exception as exc:  # noqa: BLE001 - the batch goes on
        log.warning("could not restart worker %s: %s", worker, exc)


def _check_workers(r: _Runner) -> None:
    """Fail every job left when the cluster has had no worker for a while."""
    if not (r.pending or r.running):
        return
    if r._capacity() > 0:
        r._empty_since = None
        return
    now = time.monotonic()
    if r._empty_since is None:
        r._empty_since = now
        return
    if now - r._empty_since < NO_WORKERS_TIMEOUT:
        return
    why = f"the cluster has had no worker for {NO_WORKERS_TIMEOUT:g} s"
    for future, run in list(r.running.items()):
        future.cancel()
        r._record(JobResult(run.index, r.tasks[run.index].name, "failed", error=why))
    r.running.clear()
    while r.pending:
        i = r.pending.popleft()
        r._record(JobResult(i, r.tasks[i].name, "failed", error=why))


def _failed(run: _Running, task: Task, error: str, worker: str | None) -> JobResult:
    """A failed job's result, timed from its start (or its submission)."""
    seconds = time.monotonic() - (run.started or run.submitted)
    return JobResult(run.index, task.name, "failed", error=error, seconds=seconds, worker=worker)
