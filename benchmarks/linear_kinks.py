"""Linear volumes with and without the protection of their sharp kinks (issue 30).

Meshes, with ``interpolation="linear"`` and radius bound 1 voxel, each with
the kink curves protected (the default) and without them (the kink tracer
switched off for the run): a lens whose rim lies on a grid plane (one-sided
normals 164 degrees apart there, as in ``tests/test_trilinear_kinks.py``),
and a 30^3 crop of nilearn's MNI152 grey-matter map padded by 2 voxels
(RESULTS.md, "where the refused points lie"). One run each, in this process.

    python benchmarks/linear_kinks.py [--full]

``--full`` adds the whole grey-matter map (several minutes).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
import rdmesh
from rdmesh.refine import feature_curves


def lens() -> np.ndarray:
    i = np.arange(25, dtype=float)
    x, y, z = np.meshgrid(i, i, i, indexing="ij")
    return 1.0 - np.abs(x - 12.0) - 0.01 * ((y - 12.0) ** 2 + (z - 12.0) ** 2)


def grey(full: bool) -> np.ndarray:
    from nilearn import datasets

    gm = np.asarray(datasets.load_mni152_gm_template(resolution=2).get_fdata(), float)
    return gm if full else np.pad(gm[30:60, 40:70, 25:55], 2)


def run(name: str, volume: np.ndarray, kinks: bool) -> dict:
    tracer = feature_curves.kink_curves
    if not kinks:
        feature_curves.kink_curves = lambda surface: []
    try:
        s = rdmesh.VolumeSurface(volume, isovalue=0.5, interpolation="linear")
        t = time.perf_counter()
        m = rdmesh.mesh_surface(s, radius_bound=1.0)
        sec = time.perf_counter() - t
    finally:
        feature_curves.kink_curves = tracer
    f = m.features
    kink = f is not None and "volume kink" in f.sources
    return {
        "case": name, "kinks": kinks, "vertices": len(m.vertices), "seconds": round(sec, 2),
        "unresolved": len(m.unresolved), "closed": m.report["closed_manifold"],
        "min_angle": round(float(m.angles.min()), 1) if len(m.faces) else None,
        "below_30": int((m.angles < 30.0 - 1e-9).sum()),
        "kink_edges": f"{f.edges_kept}/{f.edges}" if kink else "",
    }  # fmt: skip


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--full", action="store_true", help="also the whole grey-matter map")
    args = ap.parse_args()
    cases = [("lens, rim normals 164 degrees apart", lens()), ("grey matter, crop", grey(False))]
    if args.full:
        cases.append(("grey matter, whole", grey(True)))
    cols = ["case", "kinks", "vertices", "seconds", "unresolved", "closed", "min_angle",
            "below_30", "kink_edges"]  # fmt: skip
    print("| " + " | ".join(cols) + " |")
    print("|" + "---|" * len(cols))
    for name, vol in cases:
        for kinks in (True, False):
            row = run(name, vol, kinks)
            print("| " + " | ".join(str(row[c]) for c in cols) + " |", flush=True)


if __name__ == "__main__":
    main()
