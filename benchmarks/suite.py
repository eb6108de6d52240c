#!/usr/bin/env python
# SPDX-License-Identifier: GPL-3.0-or-later
"""The rdmesh benchmark suite: rdmesh against CGAL, pygalmesh and marching cubes.

One command runs every mesher on every surface at every size, repeated, and
writes ``<out>/<date>.json`` (all runs), ``<out>/<date>.md`` (the report) and
``<out>/<date>-*.png`` (plots)::

    python benchmarks/suite.py                     # 8 surfaces x 1e4, 1e5, 1e6 (hours)
    python benchmarks/suite.py --quick             # 3 surfaces, small sizes, 1 repeat (< 2 min)
    python benchmarks/suite.py --surfaces torus tanglecube --sizes 1e4 1e5 --repeats 5

Meshers (see benchmarks/README.md):

- ``rdmesh``: ``rdmesh.mesh_surface`` with angle 30, radius bound r,
  distance bound r.
- ``cgal_surface_mesher`` / ``cgal_mesh_3``: the CGAL reference program
  (``cgal_reference/``, built on first use) with the same criteria.
- ``pygalmesh``: ``pygalmesh.generate_surface_mesh`` with the same numpy
  function, called point by point (optional; skipped with a note when it is
  not importable).
- ``marching_cubes``: ``skimage.measure.marching_cubes`` on a grid whose
  spacing gives about the same number of vertices; its time includes
  evaluating f on the grid.

A size is a target vertex count.  The radius bound for it comes from a
calibration run of rdmesh per surface (vertices ~ C * area / r^2, cached in
``<out>/tmp/cache``); CGAL and pygalmesh get the same r.  Every run is a fresh
process; its peak RSS comes from ``wait4``.  Meshers alternate run by run
(the order is reversed every other repeat) and the median is reported.
Quality (angles, topology, Hausdorff distance; ``metrics.py``) is measured
once per case, on the first successful run (all meshers are deterministic for
a fixed seed).  Failures and timeouts are recorded, not raised.
"""

from __future__ import annotations

import argparse
import contextlib
import datetime as _dt
import json
import math
import os
import platform
import signal
import statistics
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Any

HERE = Path(__file__).resolve().parent
if str(HERE) not in sys.path:
    sys.path.insert(0, str(HERE))

from cgal_runner import SURFACES as ALL_SURFACES  # noqa: E402

SCHEMA = "rdmesh-benchmark-suite/1"
MESHERS = ("rdmesh", "cgal_surface_mesher", "cgal_mesh_3", "pygalmesh", "marching_cubes")
CGAL_MESHERS = {"cgal_surface_mesher": "surface_mesher", "cgal_mesh_3": "mesh_3"}
DEFAULT_SIZES = (1e4, 1e5, 1e6)
QUICK_SIZES = (2e3, 1e4)
QUICK_SURFACES = ("sphere", "torus", "tanglecube")
#: Marching cubes gives about this many vertices per (area / spacing^2): one
#: per grid edge the surface crosses, 1.5 on average over normal directions.
MC_VERTICES_PER_CELL_AREA = 1.5


# ---------------------------------------------------------------------------
# Running a child process and measuring it
# ---------------------------------------------------------------------------


# The meshers are started through this small launcher.  Linux carries the
# high-water RSS of the process that calls exec over into the new program's
# ru_maxrss (exec_mmap records the old mm's peak), so a child forked straight
# from this (large) Python process would report at least the parent's RSS.
# The launcher is a bare interpreter (-I -S, about 10 MB); since ru_maxrss is
# a maximum, not a sum, the grandchild's figure is exact once it exceeds that.
_LAUNCHER = r"""
import os, sys
pid = os.fork()
if pid == 0:
    try:
        limit = int(sys.argv[2])
        if limit > 0:
            import resource
            resource.setrlimit(resource.RLIMIT_AS, (limit, limit))
        os.execvp(sys.argv[3], sys.argv[3:])
    finally:
        os._exit(127)
_, status, usage = os.wait4(pid, 0)
with open(sys.argv[1], "w") as fh:
    fh.write("%d %d\n" % (os.waitstatus_to_exitcode(status), usage.ru_maxrss))
"""


def run_measured(
    cmd: list[str],
    timeout: float | None,
    env: dict[str, str] | None = None,
    memory_limit_mb: float | None = None,
) -> dict[str, Any]:
    """Run ``cmd`` in a new process group; wall time, peak RSS, output.

    ``memory_limit_mb`` caps the command's address space (RLIMIT_AS), so a
    run that would take the machine's memory fails instead (None: no cap).

    Returns ``returncode`` (None after a timeout), ``stdout``, ``stderr``,
    ``wall`` (seconds, launch to exit), ``peak_rss_mb`` (the command's maximum
    resident set size from ``wait4`` in a small launcher process, MiB; None
    if unknown) and ``timed_out``.  At the timeout the whole process group is
    killed.  KeyboardInterrupt kills it too, then propagates.
    """
    with (
        tempfile.TemporaryFile() as out,
        tempfile.TemporaryFile() as err,
        tempfile.TemporaryDirectory() as tmp,
    ):
        report = Path(tmp) / "rusage"
        limit = int(memory_limit_mb * 2**20) if memory_limit_mb else 0
        launcher = [sys.executable, "-I", "-S", "-c", _LAUNCHER, str(report), str(limit)]
        t0 = time.perf_counter()
        proc = subprocess.Popen(
            [*launcher, *cmd],
            stdout=out,
            stderr=err,
            stdin=subprocess.DEVNULL,
            env=env,
            start_new_session=True,
        )
        timed_out = threading.Event()

        def kill() -> None:
            timed_out.set()
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)

        timer = threading.Timer(timeout, kill) if timeout else None
        if timer is not None:
            timer.daemon = True
            timer.start()
        try:
            proc.wait()
        except KeyboardInterrupt:
            kill()
            proc.wait()
            raise
        finally:
            if timer is not None:
                timer.cancel()
        wall = time.perf_counter() - t0
        returncode, rss = proc.returncode, None
        try:
            code, kib = report.read_text().split()
            returncode, rss = int(code), int(kib) / 1024.0  # Linux: KiB
        except (OSError, ValueError):
            pass
        out.seek(0)
        err.seek(0)
        stdout = out.read().decode(errors="replace")
        stderr = err.read().decode(errors="replace")
    return {
        "returncode": None if timed_out.is_set() else returncode,
        "stdout": stdout,
        "stderr": stderr,
        "wall": wall,
        "peak_rss_mb": rss,
        "timed_out": timed_out.is_set(),
    }


def _last_line(text: str) -> str:
    lines = [ln.strip() for ln in text.strip().splitlines() if ln.strip()]
    return lines[-1] if lines else ""


# ---------------------------------------------------------------------------
# The child side: one mesher, one surface, one JSON line on stdout
# ---------------------------------------------------------------------------


def _maxrss_mb() -> float:
    import resource

    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _save_mesh(path: str | None, vertices, faces) -> None:
    if path:
        import numpy as np

        np.savez(path, vertices=np.asarray(vertices, float), faces=np.asarray(faces, np.int64))


def _child_rdmesh(spec: dict) -> dict:
    import numpy as np
    import rdmesh

    s = rdmesh.surfaces.get(spec["surface"])
    base = _maxrss_mb()
    t0 = time.perf_counter()
    m = rdmesh.mesh_surface(
        s,
        angle_bound=spec["angle"],
        radius_bound=spec["radius"],
        distance_bound=spec["distance"],
        seed=spec["seed"],
    )
    seconds = time.perf_counter() - t0
    _save_mesh(spec.get("out"), m.vertices, m.faces)
    return {
        "seconds": seconds,
        "vertices": int(len(np.unique(m.faces))),
        "faces": int(len(m.faces)),
        "evaluations": int(m.stats.get("evaluations", 0)),
        "baseline_rss_mb": base,
        "extra": {
            "rounds": m.stats.get("rounds"),
            "stats_seconds": m.stats.get("seconds"),
            "phase_seconds": m.stats.get("phase_seconds"),
            "complete": bool(m.complete),
        },
    }


def _child_pygalmesh(spec: dict) -> dict:
    import numpy as np
    import pygalmesh
    import rdmesh.surfaces

    f = rdmesh.surfaces.get(spec["surface"]).f
    centre = np.asarray(spec["centre"], float)
    R = float(spec["sphere_radius"])

    class Domain(pygalmesh.DomainBase):
        # pygalmesh meshes inside a sphere about the origin: translate so the
        # CGAL reference's centre (inside the surface) is the origin.
        def __init__(self):
            super().__init__()
            self.evaluations = 0

        def eval(self, x):
            self.evaluations += 1
            return float(f(np.array([x]) + centre)[0])

        def get_bounding_sphere_squared_radius(self):
            return R * R

    domain = Domain()
    base = _maxrss_mb()
    t0 = time.perf_counter()
    mesh = pygalmesh.generate_surface_mesh(
        domain,
        bounding_sphere_radius=R,
        min_facet_angle=spec["angle"],
        max_radius_surface_delaunay_ball=spec["radius"],
        max_facet_distance=spec["distance"],
        verbose=False,
        seed=spec["seed"],
    )
    seconds = time.perf_counter() - t0
    faces = np.asarray(mesh.get_cells_type("triangle"), np.int64)
    vertices = np.asarray(mesh.points, float) + centre
    _save_mesh(spec.get("out"), vertices, faces)
    return {
        "seconds": seconds,
        "vertices": int(len(np.unique(faces))),
        "faces": int(len(faces)),
        "evaluations": int(domain.evaluations),
        "baseline_rss_mb": base,
        "extra": {"pygalmesh_version": getattr(pygalmesh, "__version__", None)},
    }


def _child_marching_cubes(spec: dict) -> dict:
    import numpy as np
    import rdmesh.surfaces
    import skimage.measure  # noqa: F401  (imported before the clock starts)
    from metrics import marching_cubes_mesh

    s = rdmesh.surfaces.get(spec["surface"])
    base = _maxrss_mb()
    t0 = time.perf_counter()
    v, f, n = marching_cubes_mesh(s, np.array(spec["lo"]), np.array(spec["hi"]), spec["spacing"])
    seconds = time.perf_counter() - t0
    _save_mesh(spec.get("out"), v, f)
    return {
        "seconds": seconds,
        "vertices": int(len(np.unique(f))),
        "faces": int(len(f)),
        "evaluations": int(n),
        "baseline_rss_mb": base,
        "extra": {"grid_points": int(n)},
    }


def _jsonable(obj):
    if isinstance(obj, dict):
        return {str(k): _jsonable(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [_jsonable(v) for v in obj]
    if hasattr(obj, "item") and callable(obj.item):  # numpy scalar
        return obj.item()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return obj


def child_main(spec: dict) -> int:
    """Run one mesher as described by ``spec``; print one JSON line."""
    runners = {
        "rdmesh": _child_rdmesh,
        "pygalmesh": _child_pygalmesh,
        "marching_cubes": _child_marching_cubes,
    }
    result = runners[spec["mesher"]](spec)
    print(json.dumps(_jsonable(result)))
    return 0


# ---------------------------------------------------------------------------
# Meshes written by the children
# ---------------------------------------------------------------------------


def read_off(path: str | os.PathLike) -> tuple:
    """Vertices and triangles of an OFF file (as written by the CGAL reference)."""
    import numpy as np

    with open(path) as fh:
        text = fh.read()
    lines = text.split("\n")
    i = 0
    header: list[str] = []
    # The "OFF" keyword and the counts, skipping comments and blank lines.
    while len(header) < 4 and i < len(lines):
        ln = lines[i].split("#", 1)[0].strip()
        i += 1
        if ln:
            header += ln.split()
    if not header or header[0] != "OFF":
        raise ValueError(f"{path}: not an OFF file")
    nv, nf = int(header[1]), int(header[2])
    data = np.array("\n".join(lines[i:]).split(), dtype=np.float64)
    vertices = data[: 3 * nv].reshape(nv, 3)
    rest = data[3 * nv : 3 * nv + 4 * nf].reshape(nf, 4)
    if nf and not np.all(rest[:, 0] == 3):
        raise ValueError(f"{path}: only triangle faces are supported")
    return vertices, rest[:, 1:].astype(np.int64)


def load_mesh(path: str | os.PathLike) -> tuple:
    import numpy as np

    path = str(path)
    if path.endswith(".off"):
        return read_off(path)
    with np.load(path) as z:
        return z["vertices"], z["faces"]


# ---------------------------------------------------------------------------
# Environment
# ---------------------------------------------------------------------------


def machine_info() -> dict[str, Any]:
    info: dict[str, Any] = {
        "platform": platform.platform(),
        "python": platform.python_version(),
        "cores": os.cpu_count(),
        "loadavg_start": list(os.getloadavg()),
    }
    try:
        for ln in Path("/proc/cpuinfo").read_text().splitlines():
            if ln.startswith("model name"):
                info["cpu"] = ln.split(":", 1)[1].strip()
                break
        for ln in Path("/proc/meminfo").read_text().splitlines():
            if ln.startswith("MemTotal"):
                info["memory_gb"] = round(int(ln.split()[1]) / 1024**2, 1)
                break
    except OSError:
        pass
    return info


def package_versions() -> dict[str, Any]:
    from importlib import metadata

    out: dict[str, Any] = {}
    for name in ("rdmesh", "numpy", "scipy", "scikit-image", "matplotlib", "trimesh"):
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = None
    try:
        import rdmesh

        out["rdmesh_cgal"] = getattr(rdmesh, "CGAL_VERSION", None)
    except ImportError:
        pass
    try:
        rev = subprocess.run(
            ["git", "-C", str(HERE), "describe", "--always", "--dirty"],
            capture_output=True,
            text=True,
            timeout=10,
            check=False,
        )
        out["git"] = rev.stdout.strip() or None
    except (OSError, subprocess.SubprocessError):
        out["git"] = None
    return out


# ---------------------------------------------------------------------------
# Calibration: target vertex count -> radius bound, marching-cubes spacing
# ---------------------------------------------------------------------------


def calibrate(surface_name: str, angle: float, target: int, seed: int) -> dict[str, Any]:
    """Small rdmesh runs; returns ``radius``/``vertices``/``area``/``C``/``bbox``.

    A first run at a fifteenth of the bounding radius, then two that aim at
    ``target`` vertices from the one before (``r <- r sqrt(V / target)``).
    ``C = vertices * radius^2 / area`` of the last one maps any target vertex
    count N to the radius bound ``sqrt(C * area / N)``.
    """
    import numpy as np
    import rdmesh
    from metrics import compact, mesh_area, surface_bbox

    s = rdmesh.surfaces.get(surface_name)
    r = float(s.radius) / 15.0
    runs = []
    for _ in range(3):
        m = rdmesh.mesh_surface(
            rdmesh.surfaces.get(surface_name),
            angle_bound=angle,
            radius_bound=r,
            distance_bound=r,
            seed=seed,
        )
        v, f = compact(m.vertices, m.faces)
        runs.append((r, len(v), mesh_area(v, f)))
        r = r * math.sqrt(len(v) / target)
    r, nv, area = runs[-1]
    lo, hi = surface_bbox(s)
    return {
        "radius": r,
        "vertices": nv,
        "area": area,
        "C": nv * r * r / area,
        "bbox": [np.asarray(lo).tolist(), np.asarray(hi).tolist()],
        "runs": [{"radius": a, "vertices": b, "area": c} for a, b, c in runs],
    }


# ---------------------------------------------------------------------------
# The suite
# ---------------------------------------------------------------------------


def _fmt_size(n: float) -> str:
    n = int(n)
    if n >= 1_000_000 and n % 1_000_000 == 0:
        return f"{n // 1_000_000}M"
    if n >= 1000 and n % 1000 == 0:
        return f"{n // 1000}k"
    return str(n)


class Suite:
    """Holds the settings, the results dict and the caches of one suite run."""

    def __init__(self, args: argparse.Namespace) -> None:
        self.args = args
        self.out = Path(args.out)
        self.tmp = self.out / "tmp"
        self.cache = self.tmp / "cache"
        self.cache.mkdir(parents=True, exist_ok=True)
        stamp = _dt.datetime.now().strftime("%Y-%m-%d")
        stem = stamp
        k = 2
        while (self.out / f"{stem}.json").exists():
            stem = f"{stamp}-{k}"
            k += 1
        self.stem = stem
        self.json_path = self.out / f"{stem}.json"
        self.unavailable: dict[str, str] = {}
        self.cgal_exe: Path | None = None
        self.references: dict[str, Any] = {}
        self.results: dict[str, Any] = {
            "schema": SCHEMA,
            "date": _dt.datetime.now().isoformat(timespec="seconds"),
            "command": [Path(sys.executable).name, *sys.argv],
            "machine": machine_info(),
            "versions": package_versions(),
            "settings": {
                "quick": args.quick,
                "surfaces": list(args.surfaces),
                "sizes": [int(s) for s in args.sizes],
                "meshers": list(args.meshers),
                "repeats": args.repeats,
                "angle": args.angle,
                "distance_over_radius": 1.0,
                "seed": args.seed,
                "timeout": args.timeout,
                "cgal_error_bound": args.cgal_error_bound,
                "pygalmesh_max_size": int(args.pygalmesh_max_size),
                "pygalmesh_repeats": args.pygalmesh_repeats,
                "pygalmesh_timeout": args.pygalmesh_timeout or args.timeout,
                "memory_limit_gb": args.memory_limit_gb,
                "pygalmesh_error_bound": 1e-3,
                "reference_samples": args.reference_samples,
            },
            "unavailable": self.unavailable,
            "calibration": {},
            "cases": [],
            "targets": [],
            "finished": False,
        }

    # -- output --------------------------------------------------------------

    def log(self, msg: str) -> None:
        print(msg, file=sys.stderr, flush=True)

    def save(self) -> None:
        tmp = self.json_path.with_suffix(".json.part")
        tmp.write_text(json.dumps(_jsonable(self.results), indent=1))
        tmp.replace(self.json_path)

    # -- availability --------------------------------------------------------

    def check_meshers(self) -> None:
        meshers = self.args.meshers
        if any(m in CGAL_MESHERS for m in meshers):
            from cgal_runner import CgalReferenceError, build_reference

            try:
                self.log("building the CGAL reference (first time: about a minute) ...")
                t0 = time.perf_counter()
                self.cgal_exe = build_reference()
                self.results["cgal_build_seconds"] = time.perf_counter() - t0
            except (CgalReferenceError, OSError) as exc:
                for m in CGAL_MESHERS:
                    self.unavailable[m] = f"CGAL reference not built: {_last_line(str(exc))}"
        if "pygalmesh" in meshers:
            probe = run_measured(
                [
                    self.args.pygalmesh_python,
                    "-c",
                    "import pygalmesh, rdmesh.surfaces; print(pygalmesh.__version__)",
                ],
                timeout=300,
            )
            if probe["returncode"] == 0:
                self.results["versions"]["pygalmesh"] = probe["stdout"].strip()
            else:
                self.unavailable["pygalmesh"] = (
                    f"pygalmesh is not importable by {self.args.pygalmesh_python} "
                    f"({_last_line(probe['stderr']) or 'timed out'}); "
                    "install it with `pip install pygalmesh` (builds against CGAL and "
                    "Eigen) or pass --pygalmesh-python"
                )
        if "marching_cubes" in meshers:
            try:
                import skimage  # noqa: F401
            except ImportError as exc:
                self.unavailable["marching_cubes"] = f"scikit-image is not installed ({exc})"
        for m, why in self.unavailable.items():
            self.log(f"note: {m} skipped: {why}")

    # -- calibration and reference samples ------------------------------------

    def calibration(self, surface: str) -> dict[str, Any]:
        target = int(min(max(min(self.args.sizes), 2000), 20000))
        key = f"{surface}|angle={self.args.angle:g}|target={target}|seed={self.args.seed}"
        path = self.cache / "calibration.json"
        cache = json.loads(path.read_text()) if path.exists() else {}
        if key in cache and not self.args.recalibrate:
            cal = cache[key]
        else:
            self.log(f"calibrating {surface} (rdmesh at about {target} vertices) ...")
            t0 = time.perf_counter()
            cal = calibrate(surface, self.args.angle, target, self.args.seed)
            cal["seconds"] = time.perf_counter() - t0
            cache[key] = cal
            path.write_text(json.dumps(cache, indent=1))
        self.results["calibration"][surface] = cal
        return cal

    def reference(self, surface: str, bbox) -> Any:
        import numpy as np
        import rdmesh
        from metrics import surface_reference

        if surface in self.references:
            return self.references[surface]
        n = int(self.args.reference_samples)
        path = self.cache / f"reference-{surface}-{n}.npy"
        if path.exists():
            ref = np.load(path)
        else:
            self.log(f"reference points on {surface} ({n}) ...")
            s = rdmesh.surfaces.get(surface)
            ref = surface_reference(s, n, (np.array(bbox[0]), np.array(bbox[1])))
            np.save(path, ref)
        self.references = {surface: ref}  # keep one surface in memory
        return ref

    # -- one run -------------------------------------------------------------

    def run_once(self, case: dict, repeat: int, keep_mesh: bool) -> dict[str, Any]:
        mesher, surface, p = case["mesher"], case["surface"], case["params"]
        mesh_path = None
        if keep_mesh:
            suffix = ".off" if mesher in CGAL_MESHERS else ".npz"
            mesh_path = str(self.tmp / f"{surface}-{case['size']}-{mesher}{suffix}")
        timeout = self.args.timeout
        cgal = None
        if mesher in CGAL_MESHERS:
            from cgal_runner import reference_command

            cmd = reference_command(
                self.cgal_exe,
                CGAL_MESHERS[mesher],
                surface,
                self.args.angle,
                p["radius"],
                p["distance"],
                self.args.cgal_error_bound,
                seed=self.args.seed,
                out=mesh_path,
            )
            cgal = True
        else:
            spec = {"mesher": mesher, "surface": surface, "out": mesh_path, **p}
            spec.update(angle=self.args.angle, seed=self.args.seed)
            python = self.args.pygalmesh_python if mesher == "pygalmesh" else sys.executable
            cmd = [python, str(Path(__file__).resolve()), "--child", json.dumps(spec)]
            if mesher == "pygalmesh":
                timeout = self.args.pygalmesh_timeout or timeout
        load = os.getloadavg()[0]
        limit = self.args.memory_limit_gb * 1024 if self.args.memory_limit_gb else None
        res = run_measured(cmd, timeout, memory_limit_mb=limit)
        run: dict[str, Any] = {
            "repeat": repeat,
            "status": "ok",
            "error": None,
            "process_seconds": res["wall"],
            "peak_rss_mb": res["peak_rss_mb"],
            "loadavg": load,
        }
        if res["timed_out"]:
            run.update(status="timeout", error=f"killed after {timeout} s")
            return run
        try:
            if cgal:
                from cgal_runner import parse_reference_output

                out = parse_reference_output(
                    res["returncode"], res["stdout"], res["stderr"], f"{mesher} on {surface}"
                )
                self.results["versions"]["cgal"] = out.get("cgal_version")
                child = {
                    "seconds": out["seconds"],
                    "vertices": out["vertices"],
                    "faces": out["faces"],
                    "evaluations": out["evaluations"],
                    "extra": {
                        "error_bound": out.get("error_bound"),
                        "bounding_sphere": out.get("bounding_sphere"),
                        "closed": out.get("closed"),
                        "components": out.get("components"),
                        "euler_characteristic": out.get("euler_characteristic"),
                    },
                }
            else:
                if res["returncode"] != 0:
                    raise RuntimeError(
                        f"exit {res['returncode']}: {_last_line(res['stderr']) or 'no message'}"
                    )
                child = json.loads(_last_line(res["stdout"]))
        except (RuntimeError, ValueError) as exc:
            run.update(status="failed", error=str(exc).strip()[-2000:])
            return run
        run.update(child)
        run["vertices_per_second"] = (
            child["vertices"] / child["seconds"] if child["seconds"] > 0 else None
        )
        if mesh_path is not None:
            run["mesh_file"] = mesh_path
        return run

    # -- quality -------------------------------------------------------------

    def quality(self, case: dict, mesh_file: str) -> dict[str, Any]:
        import rdmesh
        from metrics import angle_stats, compact, hausdorff, mesh_area, topology_stats

        surface = case["surface"]
        t0 = time.perf_counter()
        v, f = compact(*load_mesh(mesh_file))
        info = rdmesh.surfaces.SURFACES[surface]
        q: dict[str, Any] = {"vertices": int(len(v)), "faces": int(len(f))}
        q.update(angle_stats(v, f, self.args.angle))
        q["topology"] = topology_stats(v, f, info.components, info.euler)
        if len(f):
            q["area"] = mesh_area(v, f)
            cal = self.results["calibration"][surface]
            ref = self.reference(surface, cal["bbox"])
            q["hausdorff"] = hausdorff(
                rdmesh.surfaces.get(surface), v, f, ref, seed=self.args.seed
            )
        else:
            q["hausdorff"] = None
        q["seconds"] = time.perf_counter() - t0
        return q

    # -- the loop ------------------------------------------------------------

    def case_params(self, mesher: str, surface: str, size: int, cal: dict) -> dict[str, Any]:
        from cgal_runner import BOUNDING_SPHERES

        r = math.sqrt(cal["C"] * cal["area"] / size)
        if mesher == "marching_cubes":
            spacing = math.sqrt(MC_VERTICES_PER_CELL_AREA * cal["area"] / size)
            return {"spacing": spacing, "lo": cal["bbox"][0], "hi": cal["bbox"][1]}
        p = {"radius": r, "distance": r}
        if mesher == "pygalmesh":
            centre, R = BOUNDING_SPHERES[surface]
            p.update(centre=list(centre), sphere_radius=R)
        return p

    def skip_reason(self, mesher: str, surface: str, size: int) -> str | None:
        if mesher in self.unavailable:
            return self.unavailable[mesher]
        if mesher == "pygalmesh" and size > self.args.pygalmesh_max_size:
            return f"above --pygalmesh-max-size {_fmt_size(self.args.pygalmesh_max_size)}"
        # A mesher that failed or timed out on a smaller size is not tried again.
        for c in self.results["cases"]:
            if (
                c["mesher"] == mesher
                and c["surface"] == surface
                and c["size"] < size
                and c["status"] in ("failed", "timeout")
            ):
                return f"{c['status']} at size {_fmt_size(c['size'])}"
        return None

    def run(self) -> None:
        args = self.args
        self.check_meshers()
        self.save()
        for surface in args.surfaces:
            cal = self.calibration(surface)
            self.save()
            for size in sorted(int(s) for s in args.sizes):
                cases = {}
                for mesher in args.meshers:
                    case = {
                        "surface": surface,
                        "size": size,
                        "mesher": mesher,
                        "params": self.case_params(mesher, surface, size, cal),
                        "status": "pending",
                        "note": None,
                        "runs": [],
                        "summary": None,
                        "quality": None,
                    }
                    why = self.skip_reason(mesher, surface, size)
                    if why is not None:
                        case.update(
                            status="unavailable" if mesher in self.unavailable else "skipped",
                            note=why,
                        )
                    self.results["cases"].append(case)
                    cases[mesher] = case
                self.run_cases(cases)
        self.results["finished"] = True

    def run_cases(self, cases: dict[str, dict]) -> None:
        args = self.args
        for rep in range(args.repeats):
            order = list(args.meshers) if rep % 2 == 0 else list(reversed(args.meshers))
            for mesher in order:
                case = cases[mesher]
                if case["status"] in ("skipped", "unavailable"):
                    continue
                if mesher == "pygalmesh" and rep >= args.pygalmesh_repeats:
                    continue
                if any(r["status"] == "timeout" for r in case["runs"]):
                    continue  # do not spend another timeout on it
                keep = case["quality"] is None
                run = self.run_once(case, rep, keep)
                case["runs"].append(run)
                self.log(self.describe(case, run))
                if run["status"] == "ok" and case["quality"] is None and "mesh_file" in run:
                    try:
                        case["quality"] = self.quality(case, run["mesh_file"])
                    except Exception as exc:  # noqa: BLE001 - record, do not crash
                        case["quality"] = {"error": f"{type(exc).__name__}: {exc}"}
                if run.get("mesh_file"):
                    Path(run["mesh_file"]).unlink(missing_ok=True)
                    run.pop("mesh_file")
                self.summarise(case)
                self.save()

    def describe(self, case: dict, run: dict) -> str:
        head = f"{case['surface']:12s} {_fmt_size(case['size']):>5s} {case['mesher']:20s} "
        head += f"rep {run['repeat']}: "
        if run["status"] != "ok":
            return head + f"{run['status'].upper()} {run['error']}"
        rss = run["peak_rss_mb"]
        return head + (
            f"{run['seconds']:8.2f} s {run['vertices']:9d} vertices "
            + (f"{rss:8.0f} MB" if rss is not None else "    ? MB")
        )

    @staticmethod
    def summarise(case: dict) -> None:
        ok = [r for r in case["runs"] if r["status"] == "ok"]
        if not ok:
            case["status"] = case["runs"][-1]["status"] if case["runs"] else case["status"]
            case["summary"] = None
            return
        case["status"] = "ok"
        secs = [r["seconds"] for r in ok]
        med = statistics.median(secs)
        nv = ok[0]["vertices"]
        case["summary"] = {
            "n_ok": len(ok),
            "n_runs": len(case["runs"]),
            "seconds": med,
            "seconds_all": secs,
            "process_seconds": statistics.median(r["process_seconds"] for r in ok),
            "vertices": nv,
            "faces": ok[0]["faces"],
            "vertices_per_second": nv / med if med > 0 else None,
            "peak_rss_mb": (
                statistics.median(rss)
                if (rss := [r["peak_rss_mb"] for r in ok if r["peak_rss_mb"] is not None])
                else None
            ),
            "evaluations": ok[0]["evaluations"],
            "evaluations_per_vertex": ok[0]["evaluations"] / nv if nv else None,
            "deterministic": len({(r["vertices"], r["faces"]) for r in ok}) == 1,
        }

    def finish(self) -> dict[str, Path]:
        import plots
        import report

        self.results["machine"]["loadavg_end"] = list(os.getloadavg())
        self.results["targets"] = report.targets(self.results)
        self.save()
        files = plots.render_all(self.results, self.out, self.stem)
        md = report.build(self.results, {k: p.name for k, p in files.items()})
        md_path = self.out / f"{self.stem}.md"
        md_path.write_text(md)
        return {"json": self.json_path, "report": md_path, **files}


# ---------------------------------------------------------------------------
# Command line
# ---------------------------------------------------------------------------


def _size(text: str) -> int:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or v < 100:
        raise argparse.ArgumentTypeError(f"a size is a vertex count >= 100, got {text!r}")
    return int(round(v))


def _positive(text: str) -> float:
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise argparse.ArgumentTypeError(f"must be positive, got {text!r}")
    return v


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    p = argparse.ArgumentParser(
        prog="suite.py",
        description="rdmesh against CGAL, pygalmesh and marching cubes: tables and plots.",
    )
    p.add_argument(
        "--quick",
        action="store_true",
        help=f"sizes {' '.join(_fmt_size(s) for s in QUICK_SIZES)}, surfaces "
        f"{' '.join(QUICK_SURFACES)}, 1 repeat, short timeouts (< 2 min)",
    )
    p.add_argument(
        "--surfaces",
        nargs="+",
        choices=ALL_SURFACES,
        metavar="NAME",
        help=f"default: all ({' '.join(ALL_SURFACES)})",
    )
    p.add_argument(
        "--sizes",
        nargs="+",
        type=_size,
        metavar="N",
        help="target vertex counts, default 1e4 1e5 1e6",
    )
    p.add_argument(
        "--meshers",
        nargs="+",
        choices=MESHERS,
        default=list(MESHERS),
        metavar="NAME",
        help=f"default: all ({' '.join(MESHERS)})",
    )
    p.add_argument("--repeats", type=int, help="runs per case, median reported (default 3)")
    p.add_argument("--out", default=str(HERE / "results"), help="output directory")
    p.add_argument("--timeout", type=_positive, help="seconds per run (default 3600)")
    p.add_argument("--angle", type=_positive, default=30.0, help="angle bound, degrees")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument(
        "--cgal-error-bound",
        type=_positive,
        default=1e-6,
        help="relative error bound of CGAL's implicit oracle (default 1e-6)",
    )
    p.add_argument(
        "--pygalmesh-python",
        default=sys.executable,
        help="Python interpreter that imports pygalmesh and rdmesh",
    )
    p.add_argument(
        "--pygalmesh-max-size", type=_size, help="largest size run with pygalmesh (default 1e5)"
    )
    p.add_argument(
        "--pygalmesh-repeats",
        type=int,
        default=1,
        help="runs of pygalmesh per case (default 1: it is slow)",
    )
    p.add_argument(
        "--pygalmesh-timeout",
        type=_positive,
        help="seconds per pygalmesh run (default: --timeout)",
    )
    p.add_argument(
        "--reference-samples",
        type=int,
        help="surface points for the Hausdorff distance (default 1e6)",
    )
    p.add_argument(
        "--memory-limit-gb",
        type=_positive,
        help="cap each run's address space (RLIMIT_AS); default: none",
    )
    p.add_argument("--recalibrate", action="store_true", help="ignore the calibration cache")
    p.add_argument("--child", help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child:
        return args
    q = args.quick
    if args.surfaces is None:
        args.surfaces = list(QUICK_SURFACES if q else ALL_SURFACES)
    if args.sizes is None:
        args.sizes = [int(s) for s in (QUICK_SIZES if q else DEFAULT_SIZES)]
    if args.repeats is None:
        args.repeats = 1 if q else 3
    if args.repeats < 1:
        p.error("--repeats must be >= 1")
    if args.timeout is None:
        args.timeout = 60.0 if q else 3600.0
    if args.pygalmesh_max_size is None:
        args.pygalmesh_max_size = min(args.sizes) if q else 100_000
    if args.reference_samples is None:
        args.reference_samples = 50_000 if q else 1_000_000
    if args.reference_samples < 1000:
        p.error("--reference-samples must be >= 1000")
    # Keep the user's order but drop duplicates.
    args.surfaces = list(dict.fromkeys(args.surfaces))
    args.meshers = list(dict.fromkeys(args.meshers))
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child:
        return child_main(json.loads(args.child))
    suite = Suite(args)
    t0 = time.perf_counter()
    interrupted = False
    try:
        suite.run()
    except KeyboardInterrupt:
        interrupted = True
        suite.log("interrupted: writing what has been measured so far")
    suite.results["seconds"] = time.perf_counter() - t0
    files = suite.finish()
    import report

    print(report.tables(suite.results))
    print()
    for what, path in files.items():
        print(f"{what}: {path}")
    print(f"total {suite.results['seconds']:.0f} s")
    return 130 if interrupted else 0


if __name__ == "__main__":
    sys.exit(main())
