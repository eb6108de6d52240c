"""``rdmesh batch JOBS.jsonl --out DIR``: job files, the manifest, resuming, exit codes.

Parsing and the manifest are tested without a cluster. The runs share one
2-process LocalCluster (``--scheduler``), except one run as a user starts it
(``python -m rdmesh batch --workers 2``), whose meshes must be byte for byte
those of ``rdmesh mesh`` and ``rdmesh remesh``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
import trimesh
from rdmesh import cli
from rdmesh.batch.jobfile import KEYS, LineError, parse_line, parse_lines, read_jobs
from rdmesh.batch.manifest import MANIFEST, FolderBusy, Manifest

distributed = pytest.importorskip("distributed")
from dask_cluster import local_cluster  # noqa: E402

dask = pytest.importorskip("dask")


@pytest.fixture(scope="module")
def scheduler():
    """The address of a LocalCluster of 2 worker processes, 1 thread each."""
    cluster = local_cluster(allowed_failures=0)
    with cluster:
        yield cluster.scheduler_address


def write_jobs(path, *jobs) -> str:
    """A JSONL file: dicts as JSON, strings as they are (bad lines)."""
    lines = [j if isinstance(j, str) else json.dumps(j) for j in jobs]
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return str(path)


def manifest(folder) -> list[dict]:
    text = (folder / MANIFEST).read_text(encoding="utf-8")
    return [json.loads(line) for line in text.splitlines()]


def batch(*args: str) -> tuple[int, str, str]:
    """``rdmesh batch ARGS`` in this process: (status, stdout, stderr)."""
    import contextlib
    import io

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        status = cli.main(["batch", *args])
    return status, out.getvalue(), err.getvalue()


@pytest.fixture
def inputs(tmp_path):
    """A mesh file and a volume next to the jobs file."""
    trimesh.creation.icosphere(subdivisions=1).export(tmp_path / "ico.ply")
    x, y, z = np.mgrid[-1:1:20j, -1:1:20j, -1:1:20j]
    np.save(tmp_path / "vol.npy", x * x + y * y + z * z)
    return tmp_path


# -- job files ----------------------------------------------------------------------------

GOOD = {"name": "ball", "expression": "x**2 + y**2 + z**2 - 1", "bound": 2}


@pytest.mark.parametrize(
    ("line", "match"),
    [
        ('{"name": "a", "surface": "torus"', "invalid JSON"),
        ("[1, 2]", "expected a JSON object, got list"),
        ({"name": "a", "surface": "torus", "radius": 0.1}, "unknown key 'radius'"),
        ({"surface": "torus"}, "missing name"),
        ({"name": "../up", "surface": "torus"}, "name must be a file name"),
        ({"name": ".hidden", "surface": "torus"}, "name must be a file name"),
        ({"name": 7, "surface": "torus"}, "name must be a file name"),
        ({"name": "a"}, "exactly one of expression, surface, input"),
        ({"name": "a", "surface": "torus", "input": "x.ply"}, "got surface and input"),
        ({"name": "a", "surface": "cube"}, "unknown surface 'cube'"),
        ({"name": "a", "expression": "x**2 + foo", "bound": 1}, "unknown name 'foo'"),
        ({"name": "a", "expression": "x**2 + y**2 + z**2 - 1"}, "needs a bounding sphere"),
        ({**GOOD, "sphere": [0, 0, 0, 2]}, "bound or sphere, not both"),
        ({**GOOD, "bound": -2}, "bound must be positive"),
        ({**GOOD, "bound": True}, "bound must be a finite number"),
        ({"name": "a", "expression": "x - 1", "sphere": [0, 0, 2]}, "list of 4 numbers"),
        ({"name": "a", "expression": "x - 1", "sphere": "0,0,0,-1"}, "radius must be positive"),
        ({**GOOD, "clip_box": [0, 0, 0, 1, -1, 1]}, "not on y"),
        ({**GOOD, "radius_bound": 0}, "radius_bound must be positive"),
        ({**GOOD, "angle_bound": 45}, "between 0 and 30"),
        ({**GOOD, "max_vertices": 0}, "max_vertices must be an integer of at least 1"),
        ({**GOOD, "max_vertices": 10.5}, "max_vertices must be an integer"),
        ({**GOOD, "seed": "1"}, "seed must be an integer"),
        ({**GOOD, "time_limit": "10"}, "time_limit must be a finite number"),
        ({**GOOD, "method": "marching-cubes"}, "method must be one of"),
        ({**GOOD, "topology": "closed"}, "topology must be one of"),
        ({**GOOD, "isovalue": 1}, "isovalue applies only to volumes"),
        ({"name": "a", "input": "missing.ply"}, "no such file"),
        ({"name": "a", "input": "ico.ply", "method": "topological-ball"}, "does not apply to a"),
        ({"name": "a", "input": "ico.ply", "bound": 2}, "bound does not apply to an input"),
        ({"name": "a", "input": "ico.ply", "isovalue": 1}, "applies only to volumes"),
        ({"name": "a", "input": "vol.npy", "spacing": [1, 0, 1]}, "3 positive numbers"),
        ({"name": "a", "input": "vol.npy", "inside": "above"}, "inside must be one of"),
    ],
)
def test_a_bad_line_is_an_error_naming_it(line, match, inputs):
    text = line if isinstance(line, str) else json.dumps(line)
    with pytest.raises(LineError, match=match) as info:
        parse_line(text, 7, str(inputs))
    assert info.value.line == 7
    assert str(info.value).startswith("line 7: ")
    assert "\n" not in str(info.value)


def test_bad_lines_do_not_stop_the_good_ones(inputs):
    jobs, errors = parse_lines(
        [
            json.dumps(GOOD),
            "\n",  # blank lines are skipped
            "not json\n",
            json.dumps({"name": "ball", "surface": "sphere"}),  # a duplicate name
            json.dumps({"name": "t", "surface": "Torus", "radius_bound": 0.1, "seed": 2}),
        ],
        str(inputs),
    )
    assert [(j.line, j.name) for j in jobs] == [(1, "ball"), (5, "t")]
    assert [(e.line, e.message.split(":")[0]) for e in errors] == [
        (3, "invalid JSON"),
        (4, "duplicate name 'ball' (first on line 1)"),
    ]
    assert jobs[1].spec.kind == "surface" and jobs[1].spec.source == "torus"
    assert jobs[1].options == {"radius_bound": 0.1, "seed": 2}


def test_every_key_is_accepted_somewhere(inputs):
    lines = [
        {**GOOD, "angle_bound": 25, "radius_bound": 0.3, "distance_bound": 0.1, "seed": 1,
         "method": "boissonnat-oudot", "topology": "manifold", "time_limit": 5,
         "max_vertices": 100, "edge_size": 0.3},
        {"name": "b", "expression": "x - 0.1", "sphere": "0,0,0,2",
         "clip_box": [-1] * 3 + [1] * 3},
        {"name": "e", "surface": "two-spheres", "bound": 3},
        {"name": "c", "input": "vol.npy", "isovalue": 0.5, "spacing": [1, 1, 2],
         "origin": [0, 0, -1], "inside": "less", "interpolation": "linear", "border": "closed"},
        {"name": "d", "input": os.path.join(str(inputs), "ico.ply")},
    ]  # fmt: skip
    used = set()
    for line in lines:
        used |= set(line)
        parse_line(json.dumps(line), 1, str(inputs))
    assert used == set(KEYS)


def test_relative_inputs_are_read_from_the_jobs_file_folder(inputs, tmp_path, monkeypatch):
    path = write_jobs(inputs / "jobs.jsonl", {"name": "v", "input": "vol.npy"})
    monkeypatch.chdir(tmp_path.parent)
    [job], errors = read_jobs(path)
    assert not errors
    assert job.spec.kind == "volume" and job.spec.source == str(inputs / "vol.npy")


def test_the_digest_changes_with_what_decides_the_mesh(inputs):
    def digest(**changes):
        line = {"name": "v", "input": "vol.npy", "isovalue": 0.5, **changes}
        return parse_line(json.dumps(line), 1, str(inputs)).digest

    same = digest()
    assert digest() == same
    assert digest(name="other") == same  # the name is the key, not the content
    assert digest(isovalue=0.4) != same
    assert digest(radius_bound=2) != same
    assert digest(seed=1) != same
    np.save(inputs / "vol.npy", np.zeros((3, 3, 3)))  # the input file changed
    assert digest() != same


# -- the manifest -------------------------------------------------------------------------


def test_the_manifest_survives_a_record_cut_short_by_a_crash(inputs):
    [job], _ = parse_lines([json.dumps({"name": "v", "input": "vol.npy"})], str(inputs))
    good = {"name": "v", "status": "ok", "output": "v.ply", "job": job.digest}
    (inputs / MANIFEST).write_text(json.dumps(good) + '\n{"name": "w", "sta', encoding="utf-8")
    (inputs / "v.ply").write_text("mesh", encoding="utf-8")
    with Manifest(inputs) as m:
        assert set(m.records) == {"v"}
        assert m.done(job)
        (inputs / "v.ply").unlink()
        assert not m.done(job)  # its mesh is gone: run it again


@pytest.mark.parametrize(
    ("status", "retry_stopped", "done"),
    [
        ("ok", False, True),
        ("stopped", False, True),
        ("stopped", True, False),
        ("failed", False, False),
    ],
)
def test_which_records_are_done(status, retry_stopped, done, inputs):
    [job], _ = parse_lines([json.dumps({"name": "v", "input": "vol.npy"})], str(inputs))
    (inputs / "v.ply").write_text("mesh", encoding="utf-8")
    with Manifest(inputs) as m:
        m.append({"name": "v", "status": status, "output": "v.ply", "job": job.digest})
        assert m.done(job, retry_stopped=retry_stopped) is done
        m.append({"name": "v", "status": status, "output": "v.ply", "job": "another"})
        assert not m.done(job, retry_stopped=retry_stopped)


def test_one_run_at_a_time_per_folder(tmp_path, capsys):
    jobs = write_jobs(tmp_path / "jobs.jsonl", GOOD)
    with Manifest(tmp_path / "out"):
        with pytest.raises(FolderBusy):
            Manifest(tmp_path / "out").__enter__()
        assert cli.main(["batch", jobs, "--out", str(tmp_path / "out")]) == 2
    assert "another rdmesh batch is writing to" in capsys.readouterr().err


# -- runs -------------------------------------------------------------------------------


def test_batch_meshes_are_those_of_rdmesh_mesh_and_remesh(inputs, scheduler):
    jobs = write_jobs(
        inputs / "jobs.jsonl",
        {**GOOD, "radius_bound": 0.3, "seed": 4},
        {"name": "torus", "surface": "torus", "radius_bound": 0.15},
        {"name": "ico", "input": "ico.ply", "radius_bound": 0.4},
        {"name": "vol", "input": "vol.npy", "isovalue": 0.5, "inside": "less", "radius_bound": 3},
    )
    status, stdout, stderr = batch(jobs, "--out", str(inputs / "out"), "--scheduler", scheduler)
    assert status == 0, stderr
    assert "4 jobs: 4 ok, 0 stopped, 0 failed" in stdout
    single = [
        ["mesh", GOOD["expression"], "--bound", "2", "--radius", "0.3", "--seed", "4"],
        ["mesh", "torus", "--radius", "0.15"],
        ["remesh", str(inputs / "ico.ply"), "--radius", "0.4"],
        [
            "mesh",
            str(inputs / "vol.npy"),
            "--isovalue",
            "0.5",
            "--inside",
            "less",
            "--radius",
            "3",
        ],
    ]
    for name, args in zip(["ball", "torus", "ico", "vol"], single, strict=True):
        path = inputs / f"{name}-single.ply"
        assert cli.main([*args, "-o", str(path), "--quiet"]) == 0
        assert (inputs / "out" / f"{name}.ply").read_bytes() == path.read_bytes(), name
    records = {r["name"]: r for r in manifest(inputs / "out")}
    assert set(records) == {"ball", "torus", "ico", "vol"}
    for rec in records.values():
        mesh = trimesh.load(inputs / "out" / rec["output"], process=False)
        assert rec["status"] == "ok" and rec["error"] is None
        assert rec["vertices"] == len(mesh.vertices) and rec["faces"] == len(mesh.faces)
        assert rec["seconds"] > 0 and rec["worker"].startswith("tcp://")
        assert rec["topology"]["closed_manifold"] is True
    assert records["torus"]["topology"]["euler"] == [0]
    assert records["vol"]["topology"]["euler"] == [2]


@pytest.mark.slow  # starts its own cluster in a new process
def test_a_users_run_starts_its_own_cluster(tmp_path):
    jobs = write_jobs(
        tmp_path / "jobs.jsonl",
        {**GOOD, "radius_bound": 0.4},
        {"name": "torus", "surface": "torus", "radius_bound": 0.2},
    )
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    run = subprocess.run(
        [sys.executable, "-m", "rdmesh", "batch", jobs, "--out", str(tmp_path / "out"),
         "--workers", "2"],
        capture_output=True, text=True, timeout=600, env=env,
    )  # fmt: skip
    assert run.returncode == 0, run.stderr
    assert "2 jobs: 2 ok, 0 stopped, 0 failed" in run.stdout
    assert run.stderr == ""  # no bar (not a terminal), no log of Dask's
    assert sorted(p.name for p in (tmp_path / "out").glob("*.ply")) == ["ball.ply", "torus.ply"]


def test_a_second_run_resumes(inputs, scheduler):
    out = inputs / "out"
    jobs = [
        {**GOOD, "radius_bound": 0.4},
        {"name": "budget", "surface": "torus", "radius_bound": 0.05, "max_vertices": 50},
        # Fails on the worker: the isovalue is outside the volume's values.
        {"name": "empty", "input": "vol.npy", "isovalue": 9.0},
        "{not json",
    ]
    path = write_jobs(inputs / "jobs.jsonl", *jobs)
    status, stdout, stderr = batch(path, "--out", str(out), "--scheduler", scheduler)
    assert status == 1
    assert "4 jobs: 1 ok, 1 stopped, 1 failed, 1 bad lines (0 done before" in stdout
    assert f"{path}:4: invalid JSON" in stderr
    assert "empty (line 3) failed: EmptySurfaceError: isovalue 9" in stderr
    assert "budget (line 2) stopped: max_vertices=50 reached" in stderr
    first = {r["name"]: r for r in manifest(out)}
    assert {n: r["status"] for n, r in first.items()} == {
        "ball": "ok",
        "budget": "stopped",
        "empty": "failed",
    }
    assert first["empty"]["output"] is None and not (out / "empty.ply").exists()
    assert first["budget"]["vertices"] <= 50 and (out / "budget.ply").exists()
    stamps = {n: (out / f"{n}.ply").stat().st_mtime_ns for n in ("ball", "budget")}

    # Again: only the failed job runs (and fails again).
    status, stdout, _ = batch(path, "--out", str(out), "--scheduler", scheduler)
    assert status == 1
    assert "1 ok, 1 stopped, 1 failed, 1 bad lines (2 done before, skipped)" in stdout
    assert [r["name"] for r in manifest(out)][len(first) :] == ["empty"]
    assert {n: (out / f"{n}.ply").stat().st_mtime_ns for n in stamps} == stamps

    # A changed line runs again; so does a stopped job with --retry-stopped.
    jobs[0] = {**GOOD, "radius_bound": 0.5}
    write_jobs(inputs / "jobs.jsonl", *jobs)
    status, stdout, _ = batch(path, "--out", str(out), "--scheduler", scheduler, "--retry-stopped")
    assert "(0 done before, skipped)" in stdout
    assert sorted(r["name"] for r in manifest(out)[len(first) + 1 :]) == [
        "ball",
        "budget",
        "empty",
    ]
    assert (out / "ball.ply").stat().st_mtime_ns != stamps["ball"]


def test_exit_status_0_when_every_job_is_ok_and_the_bar_on_request(tmp_path, scheduler):
    jobs = write_jobs(tmp_path / "jobs.jsonl", {**GOOD, "radius_bound": 0.4})
    status, stdout, stderr = batch(
        jobs, "--out", str(tmp_path / "out"), "--scheduler", scheduler, "--progress"
    )
    assert status == 0, stderr
    assert "1 jobs: 1 ok, 0 stopped, 0 failed (0 done before, skipped)" in stdout
    assert "rdmesh batch: 100%" in stderr and "1/1" in stderr


@pytest.mark.parametrize(
    ("args", "match"),
    [
        (["missing.jsonl", "--out", "out"], "cannot read 'missing.jsonl': no such file"),
        (["jobs.jsonl", "--out", "jobs.jsonl"], "is a file, not a folder"),
        (["jobs.jsonl", "--out", "out", "--workers", "2", "--scheduler", "tcp://x:1"],
         "not allowed with argument"),
        (["jobs.jsonl", "--out", "out", "--scheduler", "tcp://x:1", "--memory-limit", "1GiB"],
         "--memory-limit applies to the local cluster"),
        (["jobs.jsonl", "--out", "out", "--hard-timeout", "-1"], "must be positive"),
        (["jobs.jsonl", "--out", "out", "--memory-limit", "lots"], "a size such as 4GiB"),
        (["jobs.jsonl"], "required: --out"),
    ],
)  # fmt: skip
def test_usage_errors_exit_2_in_one_line(args, match, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    write_jobs(tmp_path / "jobs.jsonl", GOOD)
    status, stdout, stderr = batch(*args)
    assert status == 2
    assert match in stderr and len(stderr.splitlines()) == 1, stderr
    assert not (tmp_path / "out" / MANIFEST).exists()
