"""Which proven component search a surface gets (issue 30).

Expression surfaces get the interval subdivision
(:mod:`rdmesh.sampling.discovery`), closed volumes the search on their
interpolant (:mod:`rdmesh.sampling.volume_components`); other surfaces none
(their seeding is the grid scan's, sampled).
"""

from __future__ import annotations

import numpy as np

from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .discovery import Discovery, discover


def find_components(
    surface: ImplicitSurface, rng: np.random.Generator, clipped: bool = False
) -> Discovery | None:
    """Seeds with a point on every component, where a proof is available.

    Parameters
    ----------
    surface : ImplicitSurface
    rng : numpy Generator (the interval subdivision's random shift).
    clipped : bool
        The run meshes the part inside the ball or a clip box
        (``manifold-with-boundary``): no search (the proofs assume a closed
        surface inside the ball).

    Returns
    -------
    Discovery or None
        None when the surface has no proven search.
    """
    if clipped or getattr(surface, "clip_box", None) is not None:
        return None
    if isinstance(surface.f, Expression):
        return discover(surface, surface.f, rng)
    from ..surfaces.volume import VolumeSurface

    if isinstance(surface, VolumeSurface) and surface.border == "closed":
        from .volume_components import volume_components

        return volume_components(surface)
    return None
