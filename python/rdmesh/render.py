"""Shaded PNG pictures of meshes with headless matplotlib."""

from __future__ import annotations

import os

import numpy as np

#: Faces drawn at most; larger meshes are drawn from an even subset of faces
#: (dense enough to read the shape, fast enough for a preview).
MAX_DRAWN_FACES = 150_000


def render(
    vertices: np.ndarray,
    faces: np.ndarray,
    path: str | os.PathLike,
    title: str | None = None,
    size: int = 800,
) -> None:
    """Write a shaded picture of a triangle mesh to a PNG file.

    Parameters
    ----------
    vertices : (N, 3) float
    faces : (M, 3) int, oriented outward (sets the shading).
    path : output file; the format follows the extension (png recommended).
    title : optional caption.
    size : picture width and height in pixels.

    Raises
    ------
    ImportError
        If matplotlib is not installed (``pip install rdmesh[render]``).
    """
    try:
        import matplotlib

        matplotlib.use("Agg", force=False)
        import matplotlib.pyplot as plt
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError("rendering needs matplotlib: pip install 'rdmesh[render]'") from exc

    faces = np.asarray(faces)
    if len(faces) > MAX_DRAWN_FACES:
        faces = faces[:: int(np.ceil(len(faces) / MAX_DRAWN_FACES))]
    tri = np.asarray(vertices)[faces]
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    elev, azim = 25.0, -60.0
    e, a = np.radians(elev), np.radians(azim)
    view = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
    light = view + np.array([0.3, -0.2, 0.6])
    light /= np.linalg.norm(light)
    shade = 0.25 + 0.75 * np.clip(n @ light, 0.0, 1.0)
    base = np.array([0.35, 0.55, 0.85])
    colours = np.clip(shade[:, None] * base, 0, 1)
    # Painter's order: far faces first.
    order = np.argsort(tri.mean(axis=1) @ view)
    fig = plt.figure(figsize=(size / 100, size / 100), dpi=100)
    ax = fig.add_subplot(projection="3d")
    ax.add_collection3d(
        Poly3DCollection(
            tri[order], facecolors=colours[order], edgecolors=(0, 0, 0, 0.15), linewidths=0.1
        )
    )
    lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
    mid, half = (lo + hi) / 2, (hi - lo).max() / 2
    ax.set_xlim(mid[0] - half, mid[0] + half)
    ax.set_ylim(mid[1] - half, mid[1] + half)
    ax.set_zlim(mid[2] - half, mid[2] + half)
    ax.set_box_aspect((1, 1, 1))
    ax.view_init(elev=elev, azim=azim)
    ax.set_axis_off()
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.savefig(os.fspath(path))
    plt.close(fig)
