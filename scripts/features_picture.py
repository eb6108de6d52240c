"""The README's picture of feature curves: a box meshed without and with its
12 edges given, and an L-shaped bracket remeshed without and with its sharp
edges (rdmesh's renderer, four panels in one PNG).

    python scripts/features_picture.py [OUT.png]   # default docs/features.png
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.image as mpimg  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import rdmesh  # noqa: E402

CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
EDGES = [
    np.array([a, b])
    for i, a in enumerate(CORNERS)
    for b in CORNERS[i + 1 :]
    if np.sum(a != b) == 1
]


def box(p):
    x, y, z = np.abs(p).T
    return np.maximum(np.maximum(x, y), z) - 1


def bracket():
    profile = np.array([[0, 0], [1.6, 0], [1.6, 0.5], [0.5, 0.5], [0.5, 1.4], [0, 1.4]]) - 0.7
    n = len(profile)
    v = np.r_[np.c_[profile, np.full(n, -0.4)], np.c_[profile, np.full(n, 0.4)]]
    caps = [[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]]
    f = [[a, c, b] for a, b, c in caps] + [[a + n, b + n, c + n] for a, b, c in caps]
    for i in range(n):
        j = (i + 1) % n
        f += [[i, j, j + n], [i, j + n, i + n]]
    return v, np.array(f)


def main(out: str = "docs/features.png") -> None:
    v, f = bracket()
    runs = [
        ("box, no features: chamfered",
         rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features="none"), 0.1, 0.01),
        ("box, 12 edges given: kept",
         rdmesh.ImplicitSurface(box, ((0, 0, 0), 2.0), features=EDGES), 0.1, 0.01),
        ("bracket, feature_angle=None: chamfered",
         rdmesh.MeshSurface((v, f), feature_angle=None), 0.06, 0.006),
        ("bracket, sharp edges found: kept", rdmesh.MeshSurface((v, f)), 0.06, 0.006),
    ]  # fmt: skip
    fig, axes = plt.subplots(2, 2, figsize=(10, 10))
    with tempfile.TemporaryDirectory() as tmp:
        for ax, (title, s, r, d) in zip(axes.ravel(), runs, strict=True):
            m = rdmesh.mesh_surface(s, radius_bound=r, distance_bound=d)
            png = Path(tmp) / "panel.png"
            m.render(png, title=f"{title}\n{len(m.vertices)} vertices, min angle "
                               f"{m.min_angle:.1f} deg", size=600)  # fmt: skip
            ax.imshow(mpimg.imread(png))
            ax.axis("off")
            print(title, len(m.vertices), f"{m.min_angle:.2f}",
                  None if m.features is None else m.features.held)  # fmt: skip
    fig.tight_layout()
    fig.savefig(out, dpi=80)


if __name__ == "__main__":
    main(*sys.argv[1:])
