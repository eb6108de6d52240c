"""rdmesh.mesh_many on a 2-process Dask LocalCluster: results, isolation, pickling.

The cluster is shared by the module; every job is a tiny mesh. A job that
kills its worker costs a worker restart (a second or two, in the background);
the hard timeout waits for the restart (a few seconds) and is marked slow.
"""

from __future__ import annotations

import hashlib
import multiprocessing
import os
import time

import numpy as np
import pytest
import rdmesh
import trimesh
from rdmesh.batch import transport
from rdmesh.surfaces import SURFACES

distributed = pytest.importorskip("distributed")
from dask_cluster import local_cluster  # noqa: E402

dask = pytest.importorskip("dask")


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of 2 worker processes, 1 thread each, as mesh_many starts one."""
    cluster = local_cluster(allowed_failures=0)
    with cluster, distributed.Client(cluster) as c:
        yield c


def digest(mesh: rdmesh.SurfaceMesh) -> str:
    """A hash of the vertices and faces, bit for bit."""
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


def ball() -> rdmesh.ImplicitSurface:
    return rdmesh.ImplicitSurface.from_expression("x**2 + y**2 + z**2 - 1", ((0, 0, 0), 2.0))


def plain_sphere() -> rdmesh.ImplicitSurface:
    """A unit sphere as a plain numpy function (a closure: pickled by value)."""
    radius = 1.0

    def f(p):
        return np.einsum("ij,ij->i", p, p) - radius * radius

    return rdmesh.ImplicitSurface(f, ((0, 0, 0), 2.0), name="plain sphere")


def surface_of(f, name: str) -> rdmesh.ImplicitSurface:
    return rdmesh.ImplicitSurface(f, ((0, 0, 0), 2.0), name=name)


# -- results ----------------------------------------------------------------------------


def test_meshes_identical_to_serial_runs_in_job_order(client):
    icosphere = trimesh.creation.icosphere(subdivisions=1)
    jobs = [
        rdmesh.Job(SURFACES["torus"].make(), radius_bound=0.15),
        rdmesh.Job(ball(), radius_bound=0.3, seed=3),
        plain_sphere(),  # a bare surface takes the defaults
        rdmesh.Job(
            rdmesh.MeshSurface(icosphere, name="icosphere"), radius_bound=0.4, seed_resolution=24
        ),
        rdmesh.Job(SURFACES["sphere"].make, method="topological-ball", radius_bound=0.5),
    ]
    results = rdmesh.mesh_many(jobs, client=client, radius_bound=0.25)
    assert [r.index for r in results] == list(range(len(jobs)))
    assert [r.status for r in results] == ["ok"] * len(jobs), [r.error for r in results]
    assert [r.name for r in results] == [
        "torus",
        "x**2 + y**2 + z**2 - 1",
        "plain sphere",
        "icosphere",
        "job 4",
    ]
    serial = [
        rdmesh.mesh_surface(SURFACES["torus"].make(), radius_bound=0.15),
        rdmesh.mesh_surface(ball(), radius_bound=0.3, seed=3),
        rdmesh.mesh_surface(plain_sphere(), radius_bound=0.25),
        rdmesh.mesh_surface(rdmesh.MeshSurface(icosphere), radius_bound=0.4, seed_resolution=24),
        rdmesh.mesh_surface(
            SURFACES["sphere"].make(), method="topological-ball", radius_bound=0.5
        ),
    ]
    for result, mesh in zip(results, serial, strict=True):
        assert digest(result.mesh) == digest(mesh), result.name
        assert result.stats["vertices"] == len(mesh.vertices)
        assert result.report["tbp_holds"] == mesh.report["tbp_holds"]
        assert result.topology["components"] == mesh.topology()["components"]
        assert result.topology["euler"] == mesh.topology()["euler"]
        assert result.worker is not None and result.worker.startswith("tcp://")
        assert result.seconds > 0
    # The defaults reached the bare surface; a job's own option won over them.
    assert results[2].stats["vertices"] != results[1].stats["vertices"]


def test_output_is_written_on_the_worker_and_not_sent_back(client, tmp_path):
    out = tmp_path / "nested" / "ball.ply"
    [result] = rdmesh.mesh_many([rdmesh.Job(ball(), output=out, radius_bound=0.3)], client=client)
    assert result.status == "ok"
    assert result.mesh is None
    assert result.output == str(out)
    written = trimesh.load(out, process=False)
    mesh = rdmesh.mesh_surface(ball(), radius_bound=0.3)
    # PLY holds float32 coordinates.
    assert np.array_equal(written.vertices, mesh.vertices.astype(np.float32))
    assert np.array_equal(written.faces, mesh.faces)
    assert result.topology["vertices"] == len(mesh.vertices)
    assert [p.name for p in out.parent.iterdir()] == ["ball.ply"]  # no temporary left


def test_on_result_and_progress_see_every_job_once(client, capsys):
    seen = []
    results = rdmesh.mesh_many(
        [ball(), plain_sphere(), ball()],
        client=client,
        radius_bound=0.4,
        progress=True,
        on_result=seen.append,
    )
    assert sorted(r.index for r in seen) == [0, 1, 2]
    assert all(a is b for a, b in zip(sorted(seen, key=lambda r: r.index), results, strict=True))
    assert "3/3" in capsys.readouterr().err


# -- isolation --------------------------------------------------------------------------


def test_a_job_that_raises_fails_with_its_message(client):
    def f(p):
        raise ValueError("the oracle is broken at 42")

    results = rdmesh.mesh_many([surface_of(f, "raiser"), ball()], client=client, radius_bound=0.4)
    assert [r.status for r in results] == ["failed", "ok"]
    assert "the oracle is broken at 42" in results[0].error
    assert results[0].mesh is None and results[0].stats == {}


def test_a_job_that_kills_its_worker_fails_and_the_others_go_on(client):
    def f(p):
        os._exit(1)

    results = rdmesh.mesh_many(
        [ball(), surface_of(f, "killer"), plain_sphere(), ball()],
        client=client,
        radius_bound=0.4,
    )
    assert [r.status for r in results] == ["ok", "failed", "ok", "ok"], [r.error for r in results]
    assert "worker process died" in results[1].error
    assert "KilledWorker" in results[1].error


def test_a_job_that_kills_its_worker_at_once_is_not_sent_again(client, tmp_path):
    """Its start reached the scheduler before it ran (or it would be taken for a
    job that waited behind the killer, and sent again to kill another worker)."""
    runs = tmp_path / "runs"

    def f(p):
        with open(runs, "a") as out:
            out.write("ran\n")
        os._exit(1)

    results = rdmesh.mesh_many(
        [surface_of(f, "killer"), ball(), ball()], client=client, radius_bound=0.4
    )
    assert [r.status for r in results] == ["failed", "ok", "ok"], [r.error for r in results]
    assert runs.read_text().splitlines() == ["ran"]


def test_a_job_past_its_time_limit_is_stopped_with_its_partial_mesh(client):
    torus = SURFACES["torus"].make()
    results = rdmesh.mesh_many(
        [rdmesh.Job(torus, radius_bound=0.004, time_limit=0.3), ball()],
        client=client,
        radius_bound=0.4,
    )
    stopped, ok = results
    assert stopped.status == "stopped" and ok.status == "ok"
    assert "time_limit" in stopped.error
    assert stopped.mesh is not None and not stopped.mesh.complete
    assert len(stopped.mesh.faces) > 0
    assert stopped.topology["vertices"] == len(stopped.mesh.vertices)


@pytest.mark.slow  # the worker's restart takes a few seconds
def test_a_job_that_never_answers_is_ended_by_the_hard_timeout(client):
    def f(p):
        time.sleep(3600)  # time_limit cannot interrupt a call of f

    results = rdmesh.mesh_many(
        [surface_of(f, "sleeper"), ball()], client=client, radius_bound=0.4, hard_timeout=2
    )
    assert [r.status for r in results] == ["failed", "ok"]
    assert "hard timeout of 2 s" in results[0].error
    assert "restarted" in results[0].error
    # The cluster works after the restart.
    [after] = rdmesh.mesh_many([ball()], client=client, radius_bound=0.4)
    assert after.status == "ok"


def test_without_a_client_a_local_cluster_is_started_and_closed():
    before = {p.pid for p in multiprocessing.active_children()}  # the module's cluster
    results = rdmesh.mesh_many(
        [ball(), plain_sphere()], n_workers=1, memory_limit="2GiB", radius_bound=0.4
    )
    assert [r.status for r in results] == ["ok", "ok"]
    assert results[0].worker == results[1].worker  # one worker
    assert {p.pid for p in multiprocessing.active_children()} == before  # its worker is gone


@pytest.mark.slow  # its own cluster, and a worker restart
def test_a_job_over_the_memory_limit_fails_and_the_others_go_on():
    hoard = []

    def f(p):
        while True:  # 40 MB more every few milliseconds, touched, until the nanny steps in
            hoard.append(np.ones(5_000_000))
            time.sleep(0.005)

    results = rdmesh.mesh_many(
        [surface_of(f, "hoarder"), ball()], n_workers=1, memory_limit="1GiB", radius_bound=0.4
    )
    assert [r.status for r in results] == ["failed", "ok"]
    assert results[0].error.startswith("out of memory: its worker used")


def test_a_job_whose_worker_died_before_it_started_is_sent_again_a_few_times():
    from rdmesh.batch.runner import UNSTARTED_RETRIES, _Runner, _Running
    from rdmesh.batch.worker import Task

    class Died:
        key = "rdmesh-job-x-a0-0"

        def result(self):
            raise distributed.KilledWorker(self.key, None, 0)

    recorded = []
    runner = _Runner(None, [Task(0, "victim", None)], [None], recorded.append)
    for attempt in range(UNSTARTED_RETRIES):
        runner.pending.clear()
        runner._threads_at = time.monotonic()
        runner._collect(Died(), _Running(0, time.monotonic(), attempt=attempt))
        assert list(runner.pending) == [0] and runner.attempts == [attempt + 1]
        assert recorded == []
        assert runner._threads_at is None  # the cluster's size is asked again
    runner.pending.clear()
    runner._collect(Died(), _Running(0, time.monotonic(), attempt=UNSTARTED_RETRIES))
    assert [r.status for r in recorded] == ["failed"] and not runner.pending
    assert "worker process died" in recorded[0].error
    # A job that had started is not sent again: it may be what killed its worker.
    recorded.clear()
    runner._starts[Died.key] = (time.monotonic(), "tcp://worker")
    runner._collect(Died(), _Running(0, time.monotonic()))
    assert [r.status for r in recorded] == ["failed"] and not runner.pending
    assert recorded[0].worker == "tcp://worker"


def test_the_cluster_size_is_asked_at_most_once_per_ttl(monkeypatch):
    from types import SimpleNamespace

    from rdmesh.batch import runner as R

    class Cluster:
        asked = 0

        def nthreads(self):
            Cluster.asked += 1
            return {"tcp://a": 1, "tcp://b": 1}

    clock = [100.0]
    monkeypatch.setattr(R, "time", SimpleNamespace(monotonic=lambda: clock[0]))
    runner = R._Runner(Cluster(), [], [], lambda _: None)
    assert [runner._capacity() for _ in range(5)] == [2] * 5 and Cluster.asked == 1
    clock[0] += R.CAPACITY_TTL / 2
    assert runner._capacity() == 2 and Cluster.asked == 1
    clock[0] += R.CAPACITY_TTL
    assert runner._capacity() == 2 and Cluster.asked == 2


def test_the_local_cluster_runs_its_workers_without_dask_profiler():
    from rdmesh.batch.runner import _cluster

    with _cluster(None, 1, "1GiB") as c:
        profiled = c.run(lambda dask_worker: "profile" in dask_worker.periodic_callbacks)
        config = c.run(lambda: dask.config.get("distributed.worker.profile.enabled"))
    assert list(profiled.values()) == [False] and list(config.values()) == [False]


def test_the_default_hard_timeout_follows_the_time_limit():
    from rdmesh.batch.runner import HARD_TIMEOUT_FACTOR, HARD_TIMEOUT_MARGIN, _hard_limit

    assert _hard_limit("auto", None) is None
    assert _hard_limit("auto", 10) == HARD_TIMEOUT_FACTOR * 10 + HARD_TIMEOUT_MARGIN
    assert _hard_limit(5.0, 10) == 5.0
    assert _hard_limit(None, 10) is None


def test_a_surface_function_that_returns_no_surface_fails(client):
    results = rdmesh.mesh_many([lambda: "not a surface", ball()], client=client, radius_bound=0.4)
    assert [r.status for r in results] == ["failed", "ok"]
    assert "must return an rdmesh.ImplicitSurface, got str" in results[0].error


# -- pickling ----------------------------------------------------------------------------


def test_a_job_that_does_not_pickle_fails_clearly_and_the_others_run(client):
    unpicklable = (i for i in range(3))  # a generator does not pickle

    def f(p):
        return np.einsum("ij,ij->i", p, p) - 1 + 0 * next(unpicklable, 0)

    results = rdmesh.mesh_many([surface_of(f, "generator"), ball()], client=client)
    assert [r.status for r in results] == ["failed", "ok"]
    assert "cannot be sent to a worker" in results[0].error
    assert "generator" in results[0].error


def test_a_volume_surface_is_refused_with_advice_and_a_function_making_it_works(client):
    x, y, z = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    values = x * x + y * y + z * z

    def make():
        return rdmesh.VolumeSurface(values, isovalue=0.5)

    results = rdmesh.mesh_many([make(), make], client=client, radius_bound=3.0)
    assert [r.status for r in results] == ["failed", "ok"]
    assert "VolumeSurface" in results[0].error and "function that makes it" in results[0].error
    assert digest(results[1].mesh) == digest(rdmesh.mesh_surface(make(), radius_bound=3.0))


def test_transport_gives_a_surface_a_new_lock_and_a_mesh_surface_its_triangles():
    surface = plain_sphere()
    copy = transport.loads(transport.dumps(surface))
    assert copy._lock is not surface._lock and not copy._lock.locked()
    points = np.random.default_rng(0).normal(size=(500, 3))
    assert np.array_equal(copy(points), surface(points))

    mesh = rdmesh.MeshSurface(trimesh.creation.icosphere(subdivisions=2), name="ico")
    mesh.name = "renamed after construction"
    mesh.exact_crossings(np.array([[[0.0, 0.0, 0.0], [2.0, 0.1, 0.05]]]))  # one face held
    back = transport.loads(transport.dumps(mesh))
    assert type(back) is rdmesh.MeshSurface
    assert mesh._on_face.size == 1 and back._on_face.size == 0  # a table of its own
    assert back.name == "renamed after construction"
    assert back.f.__self__ is back  # its bound methods point at the new surface
    assert np.array_equal(back(points), mesh(points))
    assert np.array_equal(back.grad(points), mesh.grad(points))


# -- arguments ---------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("call", "error", "match"),
    [
        (lambda: rdmesh.mesh_many([ball()], radius=0.1), TypeError, "unexpected keyword 'radius'"),
        (lambda: rdmesh.Job(ball(), progress=True), TypeError, "cannot be set per job"),
        (lambda: rdmesh.mesh_many([ball()], progress_bar=1), TypeError, "unexpected keyword"),
        (lambda: rdmesh.mesh_many([3]), TypeError, "job 0: expected an rdmesh.Job"),
        (lambda: rdmesh.Job("sphere"), TypeError, "must be an rdmesh.ImplicitSurface"),
        (lambda: rdmesh.mesh_many([ball()], hard_timeout=0), ValueError, "hard_timeout"),
        (lambda: rdmesh.mesh_many([ball()], hard_timeout="1s"), ValueError, "hard_timeout"),
        (lambda: rdmesh.mesh_many([ball()], n_workers=0), ValueError, "n_workers"),
        (lambda: rdmesh.mesh_many([ball()], n_workers=1.5), ValueError, "n_workers"),
        (
            lambda: rdmesh.mesh_many([ball()], client=object(), n_workers=2),
            ValueError,
            "with a client",
        ),
    ],
)
def test_bad_arguments_raise_before_anything_runs(call, error, match):
    with pytest.raises(error, match=match):
        call()


def test_no_jobs_start_no_cluster():
    assert rdmesh.mesh_many([]) == []


def test_job_options_follow_mesh_surface_keywords():
    from rdmesh.batch.job import mesh_surface_options

    options = mesh_surface_options()
    assert {"radius_bound", "time_limit", "max_vertices", "seed", "method"} <= set(options)
    assert "progress" not in options and "surface" not in options
