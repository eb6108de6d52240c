"""Issue 29's block-wise volume benchmark: ``mesh_volume_blocks`` beside one process.

One command runs, in one process (so that the runs share the machine's load):

1. **whole**: ``mesh_surface(VolumeSurface(volume))`` in a child process whose
   address space is capped (``--whole-memory-gb``), with its peak memory;
2. **blocks**: ``rdmesh.mesh_volume_blocks`` on a local cluster of 1 and of 2
   worker processes (1 thread each): closed, the whole run's components and
   Euler characteristics, the same mesh bit for bit for both worker counts,
   the angles at the seams and elsewhere, each worker's peak memory, and the
   distance between the welded mesh and the whole run's;
3. **marching cubes in blocks** (scikit-image), as microscopy pipelines do:
   the blocks' meshes concatenated (the seams stay open) and welded (vertices
   equal to 1e-6 merged), with their open edges, topology and angles.

The volume is generated: two linked tori and a ball (Euler characteristics
0, 0 and 2), scaled to ``n`` samples a side so that every block plane cuts
them; the size bound is in samples, so the mesh grows as ``n^2``. Prints a
Markdown table and writes ``results/volume-blocks-<date>.json``::

    python benchmarks/volume_blocks.py --n 129 --block 64
    python benchmarks/volume_blocks.py --n 257 --block 128 --radius-bound 2.5
"""

from __future__ import annotations

import argparse
import datetime
import hashlib
import json
import logging
import resource
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
sys.path.insert(0, str(ROOT))

log = logging.getLogger("volume_blocks")


def volume(n: int) -> np.ndarray:
    """Two linked tori and a ball in an ``n^3`` volume, positive inside.

    Float32 samples, built slab by slab (no ``n^3`` float64 temporaries)."""
    s = (n - 1) / 40.0
    out = np.empty((n, n, n), np.float32)
    y, z = np.mgrid[0:n, 0:n].astype(np.float64) / s
    for i in range(n):
        x = i / s
        a = 3.0 - np.hypot(np.hypot(x - 16.3, y - 19.6) - 10.0, z - 20.4)
        b = 3.0 - np.hypot(np.hypot(x - 26.3, z - 20.4) - 10.0, y - 19.6)
        c = 5.0 - np.sqrt((x - 14.1) ** 2 + (y - 30.5) ** 2 + (z - 31.0) ** 2)
        out[i] = s * np.maximum(np.maximum(a, b), c)
    return out


def digest(v: np.ndarray, f: np.ndarray) -> str:
    h = hashlib.sha256(np.ascontiguousarray(v, np.float64).tobytes())
    h.update(np.ascontiguousarray(f, np.int64).tobytes())
    return h.hexdigest()[:16]


def mesh_figures(v: np.ndarray, f: np.ndarray) -> dict[str, Any]:
    """Size, open and non-manifold edges, topology, angles of a triangle mesh."""
    from rdmesh._geometry import min_angles
    from rdmesh.topology.complex import component_topology

    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, counts = np.unique(e[:, 0].astype(np.int64) * len(v) + e[:, 1], return_counts=True)
    chi, loops = component_topology(f, len(v))
    ang = min_angles(v[f])
    ok = np.isfinite(ang)
    return {
        "vertices": int(len(v)),
        "faces": int(len(f)),
        "open_edges": int((counts == 1).sum()),
        "nonmanifold_edges": int((counts > 2).sum()),
        "components": len(chi),
        "euler": sorted(chi),
        "boundary_loops": int(sum(loops)),
        "min_angle": round(float(ang[ok].min()), 2) if ok.any() else None,
        "below_20": int((ang[ok] < 20.0).sum()),
        "below_1": int((ang[ok] < 1.0).sum()),
        "degenerate": int((~ok).sum()),
    }


def whole_child(n: int, opts: dict, path: Path) -> None:
    """The single-process run (in a child process): its mesh and figures to ``path``."""
    import rdmesh

    vol = volume(n)
    t = time.perf_counter()
    cpu0 = _cpu_seconds()
    m = rdmesh.mesh_surface(
        rdmesh.VolumeSurface(vol, isovalue=0.0),
        radius_bound=opts["radius_bound"],
        distance_bound=opts["distance_bound"],
    )
    seconds = time.perf_counter() - t
    cpu = _cpu_seconds() - cpu0
    from rdmesh.blocks.tasks import peak_memory_mb

    peak = peak_memory_mb()  # this process's own peak (VmHWM), not the parent's at the fork
    np.savez(path, vertices=m.vertices, faces=m.faces, seconds=seconds, complete=m.complete,
             peak_mb=peak, cpu=cpu)  # fmt: skip


def whole_run(n: int, opts: dict, memory_gb: float) -> tuple[Any, dict]:
    """``mesh_surface`` on the whole volume in a child process capped at
    ``memory_gb`` of address space; the mesh (or None) and its figures."""
    import tempfile

    import rdmesh

    path = Path(tempfile.mkdtemp()) / "whole.npz"
    cap = int(memory_gb * 2**30)

    def limit() -> None:
        resource.setrlimit(resource.RLIMIT_AS, (cap, cap))

    args = [sys.executable, __file__, "--whole-child", str(path), "--n", str(n)]
    args += ["--radius-bound", str(opts["radius_bound"])]
    args += ["--distance-bound", str(opts["distance_bound"])]
    t = time.perf_counter()
    done = subprocess.run(args, preexec_fn=limit, capture_output=True, text=True)
    wall = time.perf_counter() - t
    if done.returncode != 0 or not path.exists():
        tail = (done.stderr or "").strip().splitlines()[-1:] or ["no output"]
        return None, {"failed": f"exit {done.returncode}: {tail[0]}", "seconds": round(wall, 2),
                      "memory_cap_gb": memory_gb}  # fmt: skip
    z = np.load(path)
    m = rdmesh.SurfaceMesh(z["vertices"], z["faces"], np.zeros((len(z["faces"]), 3)))
    out = {"seconds": round(float(z["seconds"]), 2), **mesh_figures(m.vertices, m.faces)}
    out["complete"] = bool(z["complete"])
    out["peak_rss_mb"] = round(float(z["peak_mb"]), 1)
    out["cpu_seconds"] = round(float(z["cpu"]), 2)
    return m, out


def _cpu_seconds() -> float:
    """This process's CPU time (user and system), in seconds."""
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime


def blocks_run(vol: np.ndarray, block: int, workers: int, opts: dict) -> tuple[Any, dict]:
    """``mesh_volume_blocks`` on a local cluster of ``workers`` processes (as it
    starts one), with the CPU time of its workers and of this process."""
    import rdmesh
    from rdmesh.batch.runner import _cluster

    t = time.perf_counter()
    with _cluster(None, workers, "auto") as client:
        started = time.perf_counter()
        cpu0 = _cpu_seconds()
        before = client.run(_cpu_seconds)
        m = rdmesh.mesh_volume_blocks(vol, block, client=client, isovalue=0.0, **opts)
        workers_cpu = sum(client.run(_cpu_seconds).values()) - sum(before.values())
        client_cpu = _cpu_seconds() - cpu0
        meshing = time.perf_counter() - started
    seams = m.report["seams"]
    out = {
        "seconds": round(time.perf_counter() - t, 2),
        "seconds_on_the_cluster": round(meshing, 2),
        "cpu_seconds_workers": round(workers_cpu, 2),
        "cpu_seconds_client": round(client_cpu, 2),
        **mesh_figures(m.vertices, m.faces),
        "complete": bool(m.complete),
        "stop_reason": m.stats.get("stop_reason"),
        "blocks": m.report["blocks_layout"]["counts"],
        "seam_curves": seams["curves"],
        "seam_balls": seams["balls"],
        "seam_check_held": seams["held"],
        "repairs": seams["repairs"],
        "min_angle_at_seams": _round(seams.get("min_angle_at_seams")),
        "min_angle_elsewhere": _round(seams.get("min_angle_elsewhere")),
        "peak_worker_mb": m.stats["peak_worker_mb"],
        "phase_seconds": m.stats["phase_seconds"],
        "digest": digest(m.vertices, m.faces),
    }
    return m, out


def _round(x: float | None) -> float | None:
    return None if x is None else round(float(x), 2)


def marching_cubes_blocks(vol: np.ndarray, block: int) -> dict[str, Any]:
    """Block-wise marching cubes: concatenated, and welded at 1e-6."""
    from rdmesh.blocks.layout import Layout
    from skimage.measure import marching_cubes

    lay = Layout.of(vol.shape, block, (1, 1, 1), (0, 0, 0))
    t = time.perf_counter()
    vs, fs, n = [], [], 0
    for blk in lay.blocks():
        lo, hi = lay.index_box(blk)
        sub = vol[lo[0] : hi[0] + 1, lo[1] : hi[1] + 1, lo[2] : hi[2] + 1]
        if not (sub.min() < 0.0 < sub.max()):
            continue
        v, f, _, _ = marching_cubes(sub, 0.0)
        vs.append(v.astype(np.float64) + lo)
        fs.append(f + n)
        n += len(v)
    v, f = np.concatenate(vs), np.concatenate(fs).astype(np.int64)
    seconds = time.perf_counter() - t
    out = {"concatenated": {"seconds": round(seconds, 2), **mesh_figures(v, f)}}
    t = time.perf_counter()
    key = np.round(v * 1e6)
    _, first, inverse = np.unique(key, axis=0, return_index=True, return_inverse=True)
    wf = inverse.reshape(-1)[f]
    wf = wf[(wf[:, 0] != wf[:, 1]) & (wf[:, 1] != wf[:, 2]) & (wf[:, 2] != wf[:, 0])]
    out["welded"] = {
        "seconds": round(seconds + time.perf_counter() - t, 2),
        **mesh_figures(v[first], wf),
    }
    return out


def distances(a: Any, b: Any) -> dict[str, float]:
    """Largest distance from each mesh's vertices to the other's triangles."""
    from benchmarks.metrics import surface_to_mesh

    return {
        "blocks_to_whole": round(float(surface_to_mesh(a.vertices, b.vertices, b.faces).max()), 4),
        "whole_to_blocks": round(float(surface_to_mesh(b.vertices, a.vertices, a.faces).max()), 4),
    }


def table(res: dict) -> str:
    """The runs as a Markdown table; CPU is the workers' and this process's for blocks."""
    whole = res.get("whole", {})
    rows = [("whole, 1 process", whole, whole.get("cpu_seconds"))] if "vertices" in whole else []
    rows += [
        (f"blocks, {w} workers", r, round(r["cpu_seconds_workers"] + r["cpu_seconds_client"], 1))
        for w, r in sorted(res["blocks"].items())
    ]
    rows += [(f"marching cubes, {k}", v, v["seconds"]) for k, v in res["marching_cubes"].items()]
    head = (
        "| run | s | CPU s | vertices | open edges | components | Euler | min angle | < 20 deg |"
    )
    out = [head, "|---|---|---|---|---|---|---|---|---|"]
    for name, r, cpu in rows:
        out.append(
            f"| {name} | {r['seconds']} | {cpu} | {r['vertices']:,} | {r['open_edges']} | "
            f"{r['components']} | {r['euler'] if r['components'] < 6 else '...'} | "
            f"{r['min_angle']} | {r['below_20']} |"
        )
    return "\n".join(out)


def main(argv: list[str] | None = None) -> dict:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--n", type=int, default=129, help="samples a side")
    p.add_argument("--block", type=int, default=64, help="cells a block side")
    p.add_argument("--radius-bound", type=float, default=2.0, help="in samples")
    p.add_argument("--distance-bound", type=float, default=None, help="default radius / 10")
    p.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    p.add_argument("--skip-whole", action="store_true", help="too large for one process")
    p.add_argument("--whole-memory-gb", type=float, default=8.0)
    p.add_argument("--whole-child", type=Path, help=argparse.SUPPRESS)
    p.add_argument("--out", type=Path, default=None)
    a = p.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    logging.getLogger("distributed").setLevel(logging.WARNING)
    opts = {
        "radius_bound": a.radius_bound,
        "distance_bound": a.distance_bound or a.radius_bound / 10,
    }
    if a.whole_child:
        whole_child(a.n, opts, a.whole_child)
        return {}
    vol = volume(a.n)
    from record import git_commit

    commit = git_commit()
    res: dict[str, Any] = {
        "date": datetime.date.today().isoformat(),
        "commit": commit,
        "command": "python benchmarks/volume_blocks.py " + " ".join(argv or sys.argv[1:]),
        "n": a.n,
        "block": a.block,
        **opts,
        "blocks": {},
    }
    out = a.out or HERE / "results" / f"volume-blocks-{res['date']}-n{a.n}-b{a.block}.json"

    def save() -> None:  # after every stage: a long run that is stopped keeps what it measured
        out.write_text(json.dumps(res, indent=1) + "\n", encoding="utf-8")

    log.info("marching cubes")
    res["marching_cubes"] = marching_cubes_blocks(vol, a.block)
    save()
    meshes = {}
    for w in a.workers:
        log.info("blocks, %d workers", w)
        meshes[w], res["blocks"][w] = blocks_run(vol, a.block, w, opts)
        save()
    digests = {r["digest"] for r in res["blocks"].values()}
    res["identical_for_all_worker_counts"] = len(digests) == 1
    save()
    del vol
    if not a.skip_whole:
        log.info("whole")
        whole, res["whole"] = whole_run(a.n, opts, a.whole_memory_gb)
        if whole is not None:
            res["distance"] = distances(meshes[a.workers[0]], whole)
        save()
    print(table(res))
    print(json.dumps({k: v for k, v in res.items() if k != "marching_cubes"}, indent=1))
    return res


if __name__ == "__main__":
    main()
