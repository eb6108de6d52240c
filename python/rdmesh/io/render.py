"""Shaded pictures of meshes, drawn with matplotlib's Agg canvas (headless).

Only :class:`matplotlib.figure.Figure` and the Agg canvas are used, never
``pyplot``: rendering needs no display, opens no window and leaves the
caller's matplotlib backend and figures alone.
"""

from __future__ import annotations

import os

import numpy as np

#: Faces drawn at most; larger meshes are drawn from an even subset of faces
#: (dense enough to read the shape, fast enough for a preview).
MAX_DRAWN_FACES = 150_000
#: Edges are drawn (faintly) up to this many faces; beyond, they would only darken.
MAX_EDGED_FACES = 20_000

_BASE_COLOUR = np.array([0.35, 0.55, 0.85])
_ELEV, _AZIM = 25.0, -60.0


def _shading(tri: np.ndarray, view: np.ndarray) -> np.ndarray:
    """Face colours ``(M, 3)``: a key light from the viewer's upper left plus ambient."""
    n = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    n /= np.maximum(np.linalg.norm(n, axis=1), 1e-300)[:, None]
    light = view + np.array([0.3, -0.2, 0.6])
    light /= np.linalg.norm(light)
    diffuse = np.clip(n @ light, 0.0, 1.0)
    # Faces turned away from the viewer (the inside, seen through a hole of a
    # partial mesh) are darker and warmer, so holes read as holes.
    back = (n @ view) < 0
    colours = (0.25 + 0.75 * diffuse)[:, None] * _BASE_COLOUR
    colours[back] = (0.15 + 0.35 * diffuse[back])[:, None] * np.array([0.9, 0.55, 0.3])
    return np.clip(colours, 0.0, 1.0)


def render(
    vertices: np.ndarray,
    faces: np.ndarray,
    path: str | os.PathLike,
    title: str | None = None,
    size: int = 800,
) -> None:
    """Write a shaded picture of a triangle mesh.

    Parameters
    ----------
    vertices : (N, 3) float
    faces : (M, 3) int
        Oriented outward (sets the shading). An empty mesh gives a picture
        that says so.
    path : str or path
        Output file; the format follows the extension (PNG recommended).
    title : str, optional
        A caption above the picture.
    size : int, default 800
        Width and height in pixels.

    Raises
    ------
    ValueError
        Bad arrays or size, or an extension matplotlib cannot write.
    OSError
        The file cannot be written.
    ImportError
        If matplotlib is not installed (``pip install 'rdmesh[render]'``).
    """
    try:
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
        from mpl_toolkits.mplot3d.art3d import Poly3DCollection
    except ImportError as exc:  # pragma: no cover - depends on the install
        raise ImportError("rendering needs matplotlib: pip install 'rdmesh[render]'") from exc

    if isinstance(size, bool) or int(size) != size or not 16 <= size <= 10_000:
        raise ValueError(f"size must be an integer number of pixels in [16, 10000], got {size!r}")
    size = int(size)
    vertices = np.asarray(vertices, dtype=np.float64)
    faces = np.asarray(faces)
    if vertices.ndim != 2 or vertices.shape[1] != 3:
        raise ValueError(f"vertices must have shape (N, 3), got {vertices.shape}")
    if faces.size == 0:
        faces = np.zeros((0, 3), dtype=np.int64)
    if faces.ndim != 2 or faces.shape[1] != 3:
        raise ValueError(f"faces must have shape (M, 3), got {faces.shape}")
    if len(faces) and (faces.min() < 0 or faces.max() >= len(vertices)):
        raise ValueError("faces index vertices that do not exist")
    if len(faces) > MAX_DRAWN_FACES:
        faces = faces[:: int(np.ceil(len(faces) / MAX_DRAWN_FACES))]

    fig = Figure(figsize=(size / 100, size / 100), dpi=100, facecolor="white")
    FigureCanvasAgg(fig)
    if title:
        fig.suptitle(title, fontsize=max(8, size // 50), y=0.97)
    if len(faces) == 0:
        fig.text(0.5, 0.5, "empty mesh", ha="center", va="center", fontsize=max(8, size // 30))
    else:
        tri = vertices[faces]
        e, a = np.radians(_ELEV), np.radians(_AZIM)
        view = np.array([np.cos(e) * np.cos(a), np.cos(e) * np.sin(a), np.sin(e)])
        edged = len(faces) <= MAX_EDGED_FACES
        ax = fig.add_axes((0.0, 0.0, 1.0, 0.92 if title else 1.0), projection="3d")
        ax.add_collection3d(
            Poly3DCollection(
                tri,
                facecolors=_shading(tri, view),
                edgecolors=(0, 0, 0, 0.15) if edged else "none",
                linewidths=0.1 if edged else 0.0,
            )
        )
        # A box around the mesh with equal scales on the three axes: flat
        # shapes fill the frame too.
        lo, hi = tri.reshape(-1, 3).min(axis=0), tri.reshape(-1, 3).max(axis=0)
        extent = np.maximum(hi - lo, 0.05 * max((hi - lo).max(), 1e-12))
        mid = (lo + hi) / 2
        ax.set_xlim(mid[0] - extent[0] / 2, mid[0] + extent[0] / 2)
        ax.set_ylim(mid[1] - extent[1] / 2, mid[1] + extent[1] / 2)
        ax.set_zlim(mid[2] - extent[2] / 2, mid[2] + extent[2] / 2)
        ax.set_box_aspect(tuple(extent), zoom=1.2)
        ax.view_init(elev=_ELEV, azim=_AZIM)
        ax.set_axis_off()
    fig.savefig(os.fspath(path), dpi=100, facecolor="white")
