# SPDX-License-Identifier: GPL-3.0-or-later
"""Which sampler should :class:`rdmesh.VolumeSurface` use? Timings per point.

Compares, on the same prefiltered cubic B-spline coefficients (and on the raw
samples for trilinear):

- ``scipy.ndimage.map_coordinates(order=3, prefilter=False, mode="mirror")``:
  values only (compiled);
- ``rdmesh.core.VolumeSampler``: the compiled sampler (cpp/volume_sampler.cpp),
  values only and values with the exact gradient, the GIL released;
- ``rdmesh.surfaces.volume.tensor_spline``: the vectorised numpy
  tensor-product evaluator, values only and values with the exact gradient
  (64 taps per point, one gather for both);
- the gradient by central differences of map_coordinates (6 more calls; not
  exact, for reference);
- the whole oracle (``VolumeSurface.__call__`` and ``.grad``), and the share
  of a meshing run spent in it.

Prints a markdown table (best of ``--repeats``) and checks that the
evaluators agree. Usage::

    python benchmarks/volume_sampler.py [--size 64] [--points 100000 1000000] [--repeats 5]
"""

from __future__ import annotations

import argparse
import json
import platform
import sys
import time
from pathlib import Path

import numpy as np
import rdmesh
from rdmesh.core import VolumeSampler
from rdmesh.surfaces.volume import tensor_spline
from scipy import ndimage

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT / "tests"))

import volumes  # noqa: E402


def best(fn, repeats: int) -> float:
    """Best wall time of ``repeats`` calls, seconds."""
    times = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t)
    return min(times)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=int, default=64, help="samples per axis (default 64)")
    ap.add_argument("--points", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--json", help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)

    rng = np.random.default_rng(0)
    n = args.size
    vol = rng.normal(size=(n, n, n))
    vol = ndimage.gaussian_filter(vol, 2.0)
    surf = rdmesh.VolumeSurface(vol)
    coef = ndimage.spline_filter(vol, order=3, mode="mirror")
    cpp3 = VolumeSampler(coef, 3, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    cpp1 = VolumeSampler(vol, 1, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0))
    rows = []
    for m in args.points:
        x = rng.uniform(0, n - 1, size=(m, 3))
        xt = np.ascontiguousarray(x.T)
        pts = surf.origin + x * surf.spacing

        def mc3(xt=xt):
            return ndimage.map_coordinates(coef, xt, order=3, mode="mirror", prefilter=False)

        def mc1(xt=xt):
            return ndimage.map_coordinates(vol, xt, order=1, mode="mirror", prefilter=False)

        def mc3_fd_grad(xt=xt, h=1e-4):
            out = [mc3(xt)]
            for a in range(3):
                for s in (h, -h):
                    y = xt.copy()
                    y[a] += s
                    out.append(mc3(y))
            return out

        def chunked(fn, x=x, chunk=1 << 16):
            for lo in range(0, len(x), chunk):
                fn(x[lo : lo + chunk])

        # Agreement first: the numbers below compare equal things.
        v_np, _ = tensor_spline(coef, x[:10_000], 3)
        assert np.allclose(v_np, mc3(xt[:, :10_000]), rtol=0, atol=1e-12)
        v_np1, _ = tensor_spline(vol, x[:10_000], 1)
        assert np.allclose(v_np1, mc1(xt[:, :10_000]), rtol=0, atol=1e-12)
        _, g_np = tensor_spline(coef, x[:10_000], 3, gradient=True)
        v_cpp, g_cpp = cpp3.sample(x[:10_000], True)
        assert np.allclose(v_cpp, v_np, rtol=0, atol=1e-12)
        assert np.allclose(g_cpp, g_np, rtol=0, atol=1e-12)

        cases = {
            "cubic value: map_coordinates": mc3,
            "cubic value: numpy tensor (64 taps)": lambda: chunked(
                lambda y: tensor_spline(coef, y, 3)
            ),
            "cubic value + exact gradient: numpy tensor": lambda: chunked(
                lambda y: tensor_spline(coef, y, 3, gradient=True)
            ),
            "cubic value + FD gradient: 7 x map_coordinates": mc3_fd_grad,
            "cubic value: C++ VolumeSampler": lambda x=x: cpp3.sample(x, False),
            "cubic value + exact gradient: C++ VolumeSampler": lambda x=x: cpp3.sample(x, True),
            "linear value: map_coordinates": mc1,
            "linear value + gradient: numpy tensor (8 taps)": lambda: chunked(
                lambda y: tensor_spline(vol, y, 1, gradient=True)
            ),
            "linear value: C++ VolumeSampler": lambda x=x: cpp1.sample(x, False),
            "linear value + gradient: C++ VolumeSampler": lambda x=x: cpp1.sample(x, True),
            "oracle f (VolumeSurface.__call__, cubic)": lambda pts=pts: surf(pts),
            "oracle gradient (VolumeSurface.grad, cubic)": lambda pts=pts: surf.grad(pts),
        }
        for name, fn in cases.items():
            t = best(fn, args.repeats)
            rows.append({"case": name, "points": m, "seconds": t, "ns_per_point": 1e9 * t / m})

    # Share of a meshing run spent in the oracle (the torus sampled on 40^3).
    vol_t, sp, org = volumes.sample(
        rdmesh.surfaces.torus(), (-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), 40
    )
    timed = {"f": 0.0, "grad": 0.0}
    base = rdmesh.VolumeSurface(vol_t, spacing=sp, origin=org, isovalue=0.0)

    def f(p):
        t = time.perf_counter()
        out = base._f(p)
        timed["f"] += time.perf_counter() - t
        return out

    def g(p):
        t = time.perf_counter()
        out = base._gradient(p)
        timed["grad"] += time.perf_counter() - t
        return out

    probe = rdmesh.ImplicitSurface(f, base.bounding_sphere, gradient=g)
    t0 = time.perf_counter()
    mesh = rdmesh.mesh_surface(probe, radius_bound=base.radius / 40)
    total = time.perf_counter() - t0

    print(f"volume {n}^3, {platform.processor() or platform.machine()}, best of {args.repeats}")
    print()
    print("| sampler | points | seconds | ns per point |")
    print("|---|---:|---:|---:|")
    for r in rows:
        print(f"| {r['case']} | {r['points']:,} | {r['seconds']:.4f} | {r['ns_per_point']:.0f} |")
    print()
    print(
        f"meshing the 40^3 torus volume at R/40: {total:.2f} s, {len(mesh.vertices)} vertices, "
        f"{mesh.stats['evaluations']:,} evaluations; f {timed['f']:.2f} s "
        f"({100 * timed['f'] / total:.0f}%), gradient {timed['grad']:.2f} s "
        f"({100 * timed['grad'] / total:.0f}%)"
    )
    if args.json:
        Path(args.json).write_text(
            json.dumps(
                {
                    "size": n,
                    "rows": rows,
                    "mesh_seconds": total,
                    "oracle_seconds": timed,
                    "vertices": len(mesh.vertices),
                },
                indent=1,
            )
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
