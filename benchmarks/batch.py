"""Issue 29's batch benchmark: many jobs on a 2-worker local Dask cluster.

One command runs, in this order and in one process (so that the serial and
the parallel times share the machine's load):

1. the jobs: the public surfaces at three sizes and with the topological-ball
   method, random sums of Gaussian spheres and tori (expressions, one per
   seed), marching-cubes meshes of known surfaces written to files
   (remeshed), sampled volumes (.npy), and bad or runaway jobs (a raising
   ``f``, three worker killers: ``os._exit``, SIGSEGV, ``abort``; a sleeping
   ``f`` that only the hard timeout ends; tiny budgets; NaN, empty and
   escaping surfaces; bad lines in the job file);
2. **serial**: every good job meshed in this process, one after the other
   (the time, and a hash of each mesh);
3. **parallel**: the good jobs by ``rdmesh.mesh_many`` on a local cluster of
   2 worker processes (1 thread each): every one "ok" and identical to its
   serial mesh, and the time against the serial time;
4. **isolation**: every job, good and bad, on the same cluster, with one
   worker killed from outside (SIGKILL) in the middle of a good job: each
   bad job "failed" or "stopped" with its reason, the killed worker loses
   only the job it ran, every other good job "ok" and identical;
5. **resume**: ``rdmesh batch JOBS.jsonl --out DIR --workers 2`` on the jobs
   a file can hold, killed (SIGKILL to its process group) once a third of
   them are recorded, run again (it skips what the manifest holds as done and
   runs the rest) and a third time (it runs only the failed jobs again); the
   meshes are the serial ones, byte for byte after PLY's float32.

Prints a Markdown table and writes ``results/batch-<date>.json``::

    python benchmarks/batch.py            # about 10 minutes on the 2-core machine
    python benchmarks/batch.py --quick    # a few jobs of each kind, to check the harness
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import logging
import os
import platform
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent

#: Sizes of the public surfaces: radius bounds of R/k.
PUBLIC_SIZES = (20, 40, 80)
#: Generated shapes, and the two size bounds they alternate.
GENERATED = 150
GENERATED_SIZES = (0.1, 0.06)
#: Marching-cubes meshes to remesh, at R/k.
MESH_SURFACES = ("sphere", "torus", "tanglecube", "two_spheres", "ellipsoid", "blob_line")
MESH_SIZES = (15, 25)
#: The time limit of the sleeping job: its hard timeout is the default, 2 x this + 30 s.
SLEEPER_TIME_LIMIT = 2.0


@dataclass
class Case:
    """One job: its line of the job file (None if a file cannot say it), or a
    Python surface; what it must end as, and a word that its error must hold."""

    name: str
    kind: str
    line: dict[str, Any] | None = None
    surface: Any = None
    expect: str = "ok"
    reason: str = ""
    options: dict[str, Any] = field(default_factory=dict)


# -- the jobs ---------------------------------------------------------------------------


def blobs(seed: int) -> str:
    """A random smooth shape: 0.4 minus a sum of 2-4 Gaussian spheres and tori."""
    rng = np.random.default_rng(seed)
    terms = []
    for _ in range(int(rng.integers(2, 5))):
        cx, cy, cz = (round(float(v), 3) for v in rng.uniform(-0.7, 0.7, 3))
        if rng.random() < 0.3:
            big = round(float(rng.uniform(0.5, 0.8)), 3)
            s2 = round(float(rng.uniform(0.2, 0.3)) ** 2, 4)
            terms.append(
                f"exp(-((sqrt((x - {cx})**2 + (y - {cy})**2) - {big})**2 + (z - {cz})**2) / {s2})"
            )
        else:
            s2 = round(float(rng.uniform(0.35, 0.6)) ** 2, 4)
            terms.append(f"exp(-((x - {cx})**2 + (y - {cy})**2 + (z - {cz})**2) / {s2})")
    return "0.4 - (" + " + ".join(terms) + ")"


#: Lines of the job file that are not jobs.
BAD_LINES = (
    '{"name": "broken", "surface": "torus"',
    '{"name": "typo", "surface": "torus", "radius": 0.1}',
    '{"name": "sphere-r20", "surface": "sphere"}',  # a duplicate name
)


def write_inputs(folder: Path, quick: bool) -> list[Case]:
    """Write the meshes and volumes the jobs read; returns their cases."""
    from rdmesh.surfaces import SURFACES
    from skimage.measure import marching_cubes

    folder.mkdir(parents=True, exist_ok=True)
    cases = []
    for name in MESH_SURFACES[: 2 if quick else None]:
        surface = SURFACES[name].make()
        c, r = surface.centre, surface.radius
        g = np.linspace(-r, r, 40)
        grid = np.stack(np.meshgrid(g + c[0], g + c[1], g + c[2], indexing="ij"), -1)
        values = surface(grid.reshape(-1, 3)).reshape(grid.shape[:3])
        v, f, _, _ = marching_cubes(values, 0.0, spacing=(g[1] - g[0],) * 3)
        path = folder / f"mc_{name}.ply"
        import trimesh

        trimesh.Trimesh(v + (c - r), f, process=False).export(path)
        for k in MESH_SIZES:
            line = {"name": f"mesh-{name}-r{k}", "input": str(path), "radius_bound": r / k}
            cases.append(Case(line["name"], "mesh", line))
    x, y, z = np.mgrid[-1.2:1.2:48j, -1.2:1.2:48j, -1.2:1.2:48j]
    volumes = {
        "torus": (np.hypot(x, y) - 0.7) ** 2 + z**2,
        "ball": x**2 + y**2 + z**2,
        "blobs": np.exp(-((x - 0.4) ** 2 + y**2 + z**2) / 0.2)
        + np.exp(-((x + 0.4) ** 2 + y**2 + z**2) / 0.2),
    }
    for name, values in volumes.items():
        np.save(folder / f"vol_{name}.npy", values)
    iso = {"torus": (0.06, "less"), "ball": (0.6, "less"), "blobs": (0.5, "greater")}
    for name, (level, inside) in iso.items():
        line = {"name": f"volume-{name}", "input": str(folder / f"vol_{name}.npy"),
                "isovalue": level, "inside": inside, "radius_bound": 2.0}  # fmt: skip
        cases.append(Case(line["name"], "volume", line))
    line = {"name": "volume-torus-fine", "input": str(folder / "vol_torus.npy"),
            "isovalue": 0.06, "inside": "less", "radius_bound": 1.2}  # fmt: skip
    cases.append(Case(line["name"], "volume", line))
    return cases


def good_cases(folder: Path, quick: bool) -> list[Case]:
    from rdmesh.surfaces import SURFACES

    cases = []
    names = list(SURFACES)[: 3 if quick else None]
    for name in names:
        radius = SURFACES[name].make().radius
        for k in PUBLIC_SIZES:
            line = {"name": f"{name}-r{k}", "surface": name, "radius_bound": radius / k}
            cases.append(Case(line["name"], "public", line))
        line = {"name": f"{name}-tb", "surface": name, "method": "topological-ball",
                "radius_bound": radius / 20}  # fmt: skip
        cases.append(Case(line["name"], "public", line))
    for seed in range(6 if quick else GENERATED):
        size = GENERATED_SIZES[seed % len(GENERATED_SIZES)]
        line = {"name": f"blobs-{seed:03d}", "expression": blobs(seed), "bound": 3,
                "radius_bound": size, "seed": seed}  # fmt: skip
        cases.append(Case(line["name"], "generated", line))
    return cases + write_inputs(folder, quick)


def bad_file_cases(folder: Path) -> list[Case]:
    """Bad jobs a job file can hold."""
    return [
        *(
            Case(f"budget-time-{i}", "time limit",
                 {"name": f"budget-time-{i}", "surface": "torus", "radius_bound": 0.004,
                  "time_limit": 0.5, "seed": i}, expect="stopped", reason="time_limit=0.5s")
            for i in range(3)
        ),
        Case("budget-vertices", "vertex budget",
             {"name": "budget-vertices", "surface": "tanglecube", "radius_bound": 0.02,
              "max_vertices": 300}, expect="stopped", reason="max_vertices=300"),
        *(
            Case(f"nan-{i}", "NaN f", {"name": f"nan-{i}", "expression": f"sqrt(x - {5 + i})",
                                       "bound": 2}, expect="failed", reason="OracleError")
            for i in range(2)
        ),
        Case("empty", "no surface", {"name": "empty", "expression": "x**2 + y**2 + z**2 + 1",
                                     "bound": 2}, expect="failed", reason="EmptySurfaceError"),
        Case("escapes", "leaves the sphere",
             {"name": "escapes", "expression": "x**2 + y**2 + z**2 - 1", "bound": 0.8},
             expect="failed", reason="BoundingSphereError"),
        Case("volume-out-of-range", "no isosurface",
             {"name": "volume-out-of-range", "input": str(folder / "vol_ball.npy"),
              "isovalue": 99.0}, expect="failed", reason="EmptySurfaceError"),
    ]  # fmt: skip


def _raise(p):
    raise RuntimeError("a bug in the surface function")


def _exit(p):
    os._exit(3)


def _segfault(p):
    os.kill(os.getpid(), signal.SIGSEGV)
    time.sleep(60)


def _abort(p):
    os.abort()


def _sleep(p):
    time.sleep(3600)


def python_cases() -> list[Case]:
    """Bad jobs only Python can make: they need their own f."""
    import rdmesh

    def surface(f, name):
        return rdmesh.ImplicitSurface(f, ((0, 0, 0), 2.0), name=name)

    return [
        Case("raises", "f raises", surface=surface(_raise, "raises"), expect="failed",
             reason="a bug in the surface function"),
        Case("exits", "worker killer: os._exit", surface=surface(_exit, "exits"),
             expect="failed", reason="worker process died"),
        Case("segfault", "worker killer: SIGSEGV", surface=surface(_segfault, "segfault"),
             expect="failed", reason="worker process died"),
        Case("aborts", "worker killer: abort()", surface=surface(_abort, "aborts"),
             expect="failed", reason="worker process died"),
        Case("sleeps", "f never returns", surface=surface(_sleep, "sleeps"), expect="failed",
             reason="hard timeout", options={"time_limit": SLEEPER_TIME_LIMIT}),
    ]  # fmt: skip


# -- measuring ----------------------------------------------------------------------------


def digest(vertices: np.ndarray, faces: np.ndarray, dtype=np.float64) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(vertices, dtype=dtype).tobytes())
    h.update(np.ascontiguousarray(faces, dtype=np.int64).tobytes())
    return h.hexdigest()[:16]


def load() -> str:
    """The load average over 1, 5 and 15 minutes, as uptime gives it."""
    return " ".join(f"{v:.2f}" for v in os.getloadavg())


def job_line(case: Case):
    from rdmesh.batch.jobfile import parse_line

    return parse_line(json.dumps(case.line), 1, "/")


def as_job(case: Case):
    import rdmesh

    if case.line is None:
        return rdmesh.Job(case.surface, name=case.name, **case.options)
    line = job_line(case)
    return rdmesh.Job(line.spec, name=case.name, **line.options)


def _warm_up() -> None:
    import rdmesh.api  # noqa: F401
    import rdmesh.cli  # noqa: F401


def _cpu_seconds() -> float:
    """CPU time of this process (on a worker: the worker's), all threads."""
    import psutil

    times = psutil.Process().cpu_times()
    return times.user + times.system


def serial(cases: list[Case]) -> dict[str, tuple[str, str]]:
    """Mesh every case here; each mesh's hashes (float64, float32)."""
    import rdmesh

    hashes = {}
    for case in cases:
        line = job_line(case)
        mesh = rdmesh.mesh_surface(line.spec(), **line.options)
        hashes[case.name] = (
            digest(mesh.vertices, mesh.faces),
            digest(mesh.vertices, mesh.faces, np.float32),
        )
    return hashes


def check(results, cases, hashes, lost: set[int] = frozenset()) -> dict[str, Any]:
    """Count the outcomes against the expectations (a job in ``lost`` may have
    failed with its killed worker; if it is ok, it is checked as any other)."""
    wrong = []
    identical = bad_as_expected = 0
    for r, case in zip(results, cases, strict=True):
        if r.index in lost and r.status != "ok":
            continue
        if r.status != case.expect or (case.reason and case.reason not in (r.error or "")):
            wrong.append(f"{case.name}: {r.status}: {r.error}")
            continue
        bad_as_expected += case.expect != "ok"
        if case.expect == "ok":
            if digest(r.mesh.vertices, r.mesh.faces) == hashes[case.name][0]:
                identical += 1
            else:
                wrong.append(f"{case.name}: not identical to the serial mesh")
    return {"wrong": wrong, "identical": identical, "bad_as_expected": bad_as_expected}


class WorkerKiller(threading.Thread):
    """Kills one worker (SIGKILL) while it holds a good job, once ``after`` jobs ended.

    A worker holds two jobs (the one it runs and the next): the one that had
    started is lost, the other is sent again. ``killed`` is (worker, the good
    jobs it held)."""

    def __init__(self, client, good: set[int], after: int) -> None:
        super().__init__(daemon=True)
        self.client, self.good, self.after = client, good, after
        self.ended = 0
        self.go = threading.Event()
        self.killed: tuple[str, list[int]] | None = None

    def on_result(self, result) -> None:
        self.ended += 1
        if self.ended >= self.after:
            self.go.set()

    def run(self) -> None:
        self.go.wait()
        for _ in range(200):
            time.sleep(0.05)
            pids = self.client.run(os.getpid)
            for worker, keys in self.client.processing().items():
                jobs = [int(str(k).rsplit("-", 1)[1]) for k in keys]  # ...-a<attempt>-<index>
                good = [i for i in jobs if i in self.good]
                if good and worker in pids:
                    os.kill(pids[worker], signal.SIGKILL)
                    self.killed = (worker, good)
                    return


def run_cli(jobs: Path, out: Path, *extra: str, kill_after: int | None = None) -> dict[str, Any]:
    """``rdmesh batch`` in a new process group; killed (SIGKILL) once ``kill_after``
    records are in the manifest, if given."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONWARNINGS"}
    cmd = [sys.executable, "-m", "rdmesh", "batch", str(jobs), "--out", str(out), *extra]
    manifest = out / "manifest.jsonl"
    before = len(manifest.read_text().splitlines()) if manifest.exists() else 0
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
        start_new_session=True,
    )  # fmt: skip
    killed = False
    if kill_after is not None:
        while proc.poll() is None:
            time.sleep(0.2)
            if manifest.exists() and len(manifest.read_text().splitlines()) >= kill_after:
                os.killpg(proc.pid, signal.SIGKILL)
                killed = True
                break
    stdout, stderr = proc.communicate(timeout=3600)
    records = [json.loads(t) for t in manifest.read_text().splitlines()[before:] if t.strip()]
    return {
        "status": proc.returncode,
        "killed": killed,
        "seconds": time.perf_counter() - t0,
        "stdout": stdout.strip(),
        "stderr_lines": [s for s in stderr.splitlines() if s.strip()],
        "records": records,
    }


# -- the run -----------------------------------------------------------------------------


def timed(good: list[Case], client) -> tuple[dict[str, Any], dict[str, tuple[str, str]]]:
    """Serial and parallel runs of the good jobs: serial then parallel on one half,
    parallel then serial on the other, so that a load that drifts falls on both."""
    import rdmesh

    client.run(_warm_up)  # the workers import rdmesh, as this process has
    wall = {"serial": 0.0, "parallel": 0.0}
    cpu = {"serial": 0.0, "workers": 0.0, "client": 0.0}
    hashes: dict[str, tuple[str, str]] = {}
    by_name = {}
    for k, half in enumerate([good[0::2], good[1::2]]):
        for mode in ("serial", "parallel") if k == 0 else ("parallel", "serial"):
            t0, c0 = time.perf_counter(), time.process_time()
            if mode == "serial":
                hashes.update(serial(half))
                cpu["serial"] += time.process_time() - c0
            else:
                w0 = sum(client.run(_cpu_seconds).values())
                t0, c0 = time.perf_counter(), time.process_time()
                for r in rdmesh.mesh_many([as_job(c) for c in half], client=client):
                    by_name[r.name] = r
                cpu["client"] += time.process_time() - c0
                cpu["workers"] += sum(client.run(_cpu_seconds).values()) - w0
            wall[mode] += time.perf_counter() - t0
            print(f"  {mode}, half {k}: load {load()}", file=sys.stderr)
    results = [by_name[c.name] for c in good]
    out = check(results, good, hashes)
    out.update(
        serial_seconds=wall["serial"],
        parallel_seconds=wall["parallel"],
        ratio=wall["parallel"] / wall["serial"],
        worker_seconds=sum(r.seconds for r in results),
        cpu_seconds=cpu,
    )
    return out, hashes


def isolation(cases: list[Case], client, hashes) -> dict[str, Any]:
    """Every job, good and bad, with one worker killed from outside mid-batch."""
    import rdmesh

    good = {i for i, c in enumerate(cases) if c.expect == "ok"}
    killer = WorkerKiller(client, good, after=len(good) // 4)
    killer.start()
    t0 = time.perf_counter()
    results = rdmesh.mesh_many(
        [as_job(c) for c in cases], client=client, on_result=killer.on_result
    )
    seconds = time.perf_counter() - t0
    killer.join(timeout=60)
    out = check(results, cases, hashes, lost=set(killer.killed[1]) if killer.killed else set())
    lost = [r for r in results if r.index in good and r.status != "ok"]
    out.update(
        seconds=seconds,
        results=len(results),
        killed=killer.killed,
        lost=[(r.index, r.name, r.error) for r in lost],
        outcomes={c.name: (r.status, r.error) for r, c in zip(results, cases, strict=True)
                  if c.expect != "ok"},
    )  # fmt: skip
    return out


def command_line(cases: list[Case], hashes, work: Path) -> dict[str, Any]:
    """``rdmesh batch`` killed a third of the way, resumed, then run once more."""
    jobs = work / "jobs.jsonl"
    lines = [json.dumps(c.line) for c in cases]
    lines[5:5] = BAD_LINES
    jobs.write_text("\n".join(lines) + "\n", encoding="utf-8")
    out = work / "out"
    crash = run_cli(jobs, out, "--workers", "2", kill_after=len(cases) // 3)
    resume = run_cli(jobs, out, "--workers", "2")
    rerun = run_cli(jobs, out, "--workers", "2")
    result = cli_checks(cases, hashes, out, crash, resume, rerun)
    result["runs"] = {
        name: {k: run[k] for k in ("status", "killed", "seconds", "stdout")}
        for name, run in (("crash", crash), ("resume", resume), ("rerun", rerun))
    }
    return result


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--quick", action="store_true", help="a few jobs of each kind")
    p.add_argument(
        "--work",
        default=str(HERE / "results" / "tmp" / "batch"),
        help="folder for the inputs and the command line's meshes (emptied first)",
    )
    p.add_argument("--record", help="the JSON record (default results/batch-<date>.json)")
    args = p.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    logging.getLogger("distributed").propagate = False  # mesh_many quiets its own handlers

    from rdmesh.batch.runner import _cluster

    work = Path(args.work)
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    from record import git_commit

    commit = git_commit()
    record: dict[str, Any] = {
        "date": datetime.date.today().isoformat(),
        "commit": commit,
        "command": " ".join(["python benchmarks/batch.py", *(argv or sys.argv[1:])]),
        "machine": {"cores": os.cpu_count(), "python": platform.python_version()},
        "load_start": load(),
        "cpu_pressure_start": pressure(),
    }
    suffix = "-quick" if args.quick else ""
    path = Path(args.record or HERE / "results" / f"batch-{record['date']}{suffix}.json")
    path.parent.mkdir(parents=True, exist_ok=True)  # before minutes of work, not after
    print(f"batch benchmark, {record['date']}, commit {commit}, load {record['load_start']}")
    good = good_cases(work / "inputs", args.quick)
    bad_file = bad_file_cases(work / "inputs")
    bad_python = python_cases()
    record["jobs"] = {
        "good": len(good),
        "bad": len(bad_file) + len(bad_python),
        "bad_lines": len(BAD_LINES),
    }
    print(f"{len(good)} good jobs, {record['jobs']['bad']} bad jobs, {len(BAD_LINES)} bad lines")

    t0 = time.perf_counter()
    with _cluster(None, 2, "auto") as client:
        record["cluster_start_seconds"] = time.perf_counter() - t0
        record["parallel"], hashes = timed(good, client)
        print(f"timed: {_short(record['parallel'])}")
        half = len(good) // 2
        cases = good[:half] + bad_python + bad_file + good[half:]
        record["isolation"] = isolation(cases, client, hashes)
        print(f"isolation: {_short(record['isolation'])}")
    record["cli"] = command_line(good + bad_file, hashes, work)
    print(f"command line: {_short(record['cli'])}")
    record["load_end"] = load()
    record["cpu_pressure_end"] = pressure()

    print(table(record, cases))
    wrong = record["parallel"]["wrong"] + record["isolation"]["wrong"] + record["cli"]["wrong"]
    if wrong:
        print("WRONG:", *wrong, sep="\n  ")
    path.write_text(json.dumps(record, indent=1, default=str) + "\n", encoding="utf-8")
    print(f"record: {path}")
    return 0 if not wrong and len(record["isolation"]["lost"]) <= 1 else 1


def _short(part: dict[str, Any]) -> str:
    return ", ".join(f"{k} {v}" for k, v in part.items() if k not in ("outcomes", "runs"))


def pressure() -> str:
    """The kernel's CPU pressure (share of time some task waited for a CPU)."""
    try:
        return Path("/proc/pressure/cpu").read_text().splitlines()[0]
    except OSError:
        return "unknown"


def cli_checks(cases, hashes, out: Path, crash, resume, rerun) -> dict[str, Any]:
    """The command line's runs against the expectations and the serial meshes."""
    import trimesh

    wrong = []
    final = {}
    for run in (crash, resume, rerun):
        for rec in run["records"]:
            final[rec["name"]] = rec
    done_first = {r["name"] for r in crash["records"] if r["status"] in ("ok", "stopped")}
    again = done_first & {r["name"] for r in resume["records"]}
    if again:
        wrong.append(f"the resumed run ran again: {sorted(again)}")
    identical = 0
    for case in cases:
        rec = final.get(case.name)
        if rec is None:
            wrong.append(f"{case.name}: no record")
            continue
        if rec["status"] != case.expect or case.reason not in (rec["error"] or ""):
            wrong.append(f"{case.name}: {rec['status']}: {rec['error']}")
            continue
        if case.expect == "ok":
            mesh = trimesh.load(out / rec["output"], process=False)
            written = digest(np.asarray(mesh.vertices, np.float32), mesh.faces, np.float32)
            if written == hashes[case.name][1]:
                identical += 1
            else:
                wrong.append(f"{case.name}: the file is not the serial mesh")
    failed = sorted(c.name for c in cases if c.expect == "failed")
    rerun_ran = sorted(r["name"] for r in rerun["records"])
    if rerun_ran != failed:
        wrong.append(f"the rerun ran {rerun_ran}, not the failed jobs {failed}")
    return {
        "wrong": wrong,
        "identical": identical,
        "crash_recorded": len(crash["records"]),
        "resume_ran": len(resume["records"]),
        "rerun_ran": len(rerun["records"]),
        "bad_lines_reported": [s for s in resume["stderr_lines"] if "jobs.jsonl:" in s],
        "exit": [crash["status"], resume["status"], rerun["status"]],
    }


def table(record: dict[str, Any], cases: list[Case]) -> str:
    """The Markdown tables of the run."""
    par, iso, cli = record["parallel"], record["isolation"], record["cli"]
    cpu = par["cpu_seconds"]
    jobs = record["jobs"]
    n_good, n_bad = jobs["good"], sum(c.expect != "ok" for c in cases)
    rows = [
        ("jobs", f"{n_good} good, {jobs['bad']} bad, {jobs['bad_lines']} bad lines"),
        ("serial, this process", f"{par['serial_seconds']:.1f} s"),
        (
            "2 workers, mesh_many",
            f"{par['parallel_seconds']:.1f} s = {par['ratio']:.2f} x serial (the cluster "
            f"started in {record['cluster_start_seconds']:.1f} s before)",
        ),
        ("workers busy", f"{par['worker_seconds']:.1f} s of 2 x {par['parallel_seconds']:.1f} s"),
        (
            "CPU time, serial; 2 workers",
            f"{cpu['serial']:.1f} s; {cpu['workers']:.1f} s on the workers + "
            f"{cpu['client']:.1f} s here (client, scheduler, nannies) = "
            f"{(cpu['workers'] + cpu['client']) / cpu['serial']:.2f} x serial",
        ),
        ("good jobs ok, identical to serial", f"{par['identical']}/{n_good}"),
        ("all jobs, one worker killed (SIGKILL)", f"{iso['seconds']:.1f} s"),
        ("- good jobs ok, identical to serial", f"{iso['identical']}/{n_good - len(iso['lost'])}"),
        ("- jobs lost with the killed worker", ", ".join(n for _, n, _ in iso["lost"]) or "none"),
        ("- bad jobs failed or stopped, reason given", f"{iso['bad_as_expected']}/{n_bad}"),
        ("- hangs", f"0 ({iso['results']} results for {len(cases)} jobs)"),
        ("rdmesh batch, killed (SIGKILL) at", f"{cli['crash_recorded']} records"),
        ("- resumed: ran", f"{cli['resume_ran']} jobs (the rest), none twice"),
        ("- run again: ran", f"{cli['rerun_ran']} jobs (the failed ones)"),
        ("- meshes identical to serial (PLY)", f"{cli['identical']}/{n_good}"),
        ("- exit statuses", ", ".join(str(e) for e in cli["exit"])),
        ("load average at start, end", f"{record['load_start']}; {record['load_end']}"),
    ]
    lines = ["| | |", "| --- | --- |", *(f"| {a} | {b} |" for a, b in rows)]
    lines += ["", "| bad job | expected | got | reason |", "| --- | --- | --- | --- |"]
    for c in cases:
        if c.expect != "ok":
            status, error = iso["outcomes"][c.name]
            lines.append(f"| {c.name} ({c.kind}) | {c.expect} | {status} | {error} |")
    return "\n".join(lines)


if __name__ == "__main__":
    sys.exit(main())
