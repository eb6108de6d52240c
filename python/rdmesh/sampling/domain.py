"""The clipping domain of a surface meshed with a boundary: the bounding ball,
or an axis-aligned box inside it (``ImplicitSurface.clip_box``).

With ``topology="manifold-with-boundary"`` the mesh is the part of the
surface inside this domain; its boundary lies on the domain's surface (the
sphere, or the box faces).
"""

from __future__ import annotations

import numpy as np

from .._vectors import row_norms
from ..surfaces.oracle import ImplicitSurface

#: A point this close to the clipping surface (times R) lies on it (a dual
#: segment end clipped to it, or a boundary curve sample).
ON_CLIP = 1e-9


def clip_box(surface: ImplicitSurface) -> np.ndarray | None:
    """The surface's clip box ``(2, 3)`` (lowest, highest corner), or None (the ball)."""
    box = getattr(surface, "clip_box", None)
    return None if box is None else np.asarray(box, dtype=np.float64)


def depth(surface: ImplicitSurface, points: np.ndarray) -> np.ndarray:
    """Distance from each point to the clipping surface, positive inside, ``(N,)``.

    Inside the box this is the distance to the nearest face (the box lies in
    the ball); outside it, only its sign is meaningful.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    d = surface.radius - row_norms(pts - surface.centre)
    box = clip_box(surface)
    if box is not None:
        d = np.minimum(d, np.minimum(pts - box[0], box[1] - pts).min(axis=1))
    return d


def on_clip_surface(surface: ImplicitSurface, points: np.ndarray) -> np.ndarray:
    """Which points lie on the clipping surface (to ``ON_CLIP`` times R), ``(N,)`` bool."""
    return np.abs(depth(surface, points)) <= ON_CLIP * surface.radius
