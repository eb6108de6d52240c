# SPDX-License-Identifier: GPL-3.0-or-later
"""rdmesh.VolumeSurface against scikit-image's marching cubes on volumes of known topology.

Volumes (``tests/volumes.py``): built-in surfaces sampled on grids (a torus,
an anisotropic double torus, a noisy blurred torus), a small CT-like phantom
(three bones: Euler characteristics 0, 2, 2) and a tilted half-space whose
surface meets the border of the box.

Meshers: rdmesh (cubic B-spline at the default radius bound R/20 and at
R/60; trilinear at R/60), and ``skimage.measure.marching_cubes`` at the
volume's own resolution (its vertices are linear interpolations along grid
edges, so they lie on the trilinear interpolant).

Measured per mesh: topology (closed manifold, components, Euler characteristic
per component against the known ones), smallest angle and share of angles
below 30 degrees, the sampled two-sided Hausdorff distance to the cubic
interpolant closed by the box (``benchmarks/metrics.py``; in units of the
smallest sample spacing), vertices and wall time (median of ``--repeats``).
Marching cubes does not close surfaces at the border of the volume (one
would pad the volume), so on the half-space its mesh is open.

Prints a markdown table and writes ``results/volume-<date>.json``::

    python benchmarks/volume.py [--repeats 3] [--out benchmarks/results]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import platform
import statistics
import sys
import time
from pathlib import Path

import numpy as np
import rdmesh

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE))
sys.path.insert(0, str(HERE.parent / "tests"))

import input_volume  # noqa: E402
import metrics  # noqa: E402
import volumes  # noqa: E402


def cases() -> dict[str, tuple[np.ndarray, dict, list[int]]]:
    """name -> (volume, VolumeSurface keywords, Euler characteristic per component).

    The torus, the noisy torus and the phantom are the suite's volume cases
    (``input_volume.py``) at scales 1, 2 and 1.
    """
    out = {}
    vol, kw = input_volume.torus(1.0)
    out["torus 40^3"] = (vol, kw, [0])
    vol, sp, org = volumes.sample(
        rdmesh.surfaces.double_torus(), (-0.3, -1.0, -0.15), (2.3, 1.0, 0.15), 40
    )
    out["double torus 40^3, anisotropic"] = (
        vol,
        {"spacing": sp, "origin": org, "isovalue": 0.0},
        [-2],
    )
    vol, kw = input_volume.noisy_torus(2.0)
    out["noisy blurred torus 80^3"] = (vol, kw, [0])
    vol, kw = input_volume.phantom(1.0)
    out["CT phantom 48x48x32"] = (vol, kw, volumes.PHANTOM_EULER)
    n = 30
    p = volumes.grid((n, n, n), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    vol = p[..., 2] + 0.2 * p[..., 0] - 0.1 * p[..., 1]
    out["half-space 30^3, meets the border"] = (
        vol,
        {"isovalue": 0.6 * (n - 1), "inside": "less"},
        [2],
    )
    return out


def timed(fn, repeats: int):
    """(result of the last call, median wall time in seconds)."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t)
    return out, statistics.median(times)


def run_case(name: str, vol: np.ndarray, kw: dict, euler: list[int], repeats: int) -> list[dict]:
    from skimage.measure import marching_cubes

    cubic = rdmesh.VolumeSurface(vol, **kw)
    linear = rdmesh.VolumeSurface(vol, interpolation="linear", **kw)
    step = float(cubic.spacing.min())
    lo, hi = cubic.box
    pad = 0.05 * (hi - lo)
    reference = metrics.surface_reference(cubic, 20_000, bbox=(lo - pad, hi + pad))

    def mc():
        level = kw["isovalue"]
        v, f, _, _ = marching_cubes(vol, level, spacing=tuple(cubic.spacing))
        if kw.get("inside", "greater") == "greater":
            f = f[:, ::-1]  # skimage orients towards greater values; rdmesh outward
        return v + cubic.origin, f

    meshers = {
        "rdmesh cubic, R/20": lambda: rdmesh.mesh_surface(cubic),
        "rdmesh cubic, R/60": lambda: rdmesh.mesh_surface(cubic, radius_bound=cubic.radius / 60),
        "rdmesh linear, R/60": lambda: rdmesh.mesh_surface(
            linear, radius_bound=linear.radius / 60
        ),
        "marching cubes": mc,
    }
    rows = []
    for mesher, fn in meshers.items():
        out, seconds = timed(fn, repeats)
        if isinstance(out, rdmesh.SurfaceMesh):
            v, f = out.vertices, out.faces
        else:
            v, f = metrics.compact(*out)
        topo = metrics.topology_stats(v, f, len(euler), sum(euler))
        ang = metrics.angle_stats(v, f)
        h = metrics.hausdorff(cubic, v, f, reference, n_random=min(len(f), 200_000))
        rows.append(
            {
                "volume": name,
                "shape": list(vol.shape),
                "mesher": mesher,
                "vertices": len(v),
                "seconds": seconds,
                "closed_manifold": topo["closed_manifold"],
                "components": topo["components"],
                "euler_per_component": sorted(topo["euler_per_component"]),
                "expected_euler_per_component": sorted(euler),
                "topology_ok": bool(
                    topo["closed_manifold"]
                    and sorted(topo["euler_per_component"]) == sorted(euler)
                ),
                "min_angle": ang["min_angle"],
                "frac_angles_below_30": ang["frac_angles_below_30"],
                "hausdorff_voxels": h["two_sided"] / step,
                "mesh_to_surface_max_voxels": h["mesh_to_surface"]["max"] / step,
                "surface_to_mesh_max_voxels": h["surface_to_mesh"]["max"] / step,
            }
        )
    return rows


def table(rows: list[dict]) -> str:
    lines = [
        "| volume | mesher | vertices | time (s) | closed manifold | components "
        "| Euler per component (expected) | min angle | angles < 30° "
        "| Hausdorff (voxels) |",
        "|---|---|---:|---:|---|---:|---|---:|---:|---:|",
    ]
    for r in rows:
        lines.append(
            f"| {r['volume']} | {r['mesher']} | {r['vertices']:,} | {r['seconds']:.3f} "
            f"| {'yes' if r['closed_manifold'] else 'no'} | {r['components']} "
            f"| {r['euler_per_component']} ({r['expected_euler_per_component']}) "
            f"| {r['min_angle']:.1f}° | {100 * r['frac_angles_below_30']:.1f}% "
            f"| {r['hausdorff_voxels']:.3f} |"
        )
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=3, help="timed runs per mesh (median)")
    ap.add_argument("--out", default=str(HERE / "results"), help="folder of the JSON record")
    args = ap.parse_args(argv)
    rows = []
    for name, (vol, kw, euler) in cases().items():
        rows.extend(run_case(name, vol, kw, euler, args.repeats))
    import skimage

    header = {
        "date": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
        "machine": platform.machine(),
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scikit-image": skimage.__version__,
        "rdmesh": rdmesh.__version__,
        "repeats": args.repeats,
        "command": "python benchmarks/volume.py " + " ".join(argv or sys.argv[1:]),
    }
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / f"volume-{dt.date.today().isoformat()}.json"
    path.write_text(json.dumps({"header": header, "rows": rows}, indent=1))
    print(table(rows))
    print(f"\nwrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
