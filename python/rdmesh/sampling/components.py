"""Which proven component search a surface gets (issue 30).

Expression surfaces get the interval subdivision
(:mod:`rdmesh.sampling.discovery`), closed volumes the search on their
interpolant (:mod:`rdmesh.sampling.volume_components`), closed mesh inputs
that do not intersect themselves up to six vertices of each of their components
(:func:`mesh_components`); other surfaces none (their seeding is the grid
scan's, sampled).
"""

from __future__ import annotations

import numpy as np

from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .discovery import Discovery, discover


def find_components(
    surface: ImplicitSurface,
    rng: np.random.Generator,
    clipped: bool = False,
    seeds: np.ndarray | None = None,
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
    seeds : (k, 3) points on the surface that the run has already (the grid
        scan's), or None: a mesh input then only needs seeds on the
        components they miss.

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
    if getattr(surface, "topology_known", False):
        return mesh_components(surface, seeds)
    return None


def mesh_components(surface, seeds: np.ndarray | None = None) -> Discovery:
    """Vertices of each component of a closed mesh input that does not
    intersect itself (:attr:`~rdmesh.MeshSurface.topology_known`) and that
    none of ``seeds`` (points on the surface) lies on: each input component
    is a component of the surface, and its vertices lie on it (``f = 0``), so
    with ``seeds`` every component has a seed, however small."""
    from .._mesh_components import labelled_components

    count, _, label = labelled_components(surface.faces, len(surface.vertices))
    seeded = np.zeros(count, bool)
    if seeds is not None and len(seeds):
        # input_components numbers the components as labelled_components does.
        seeded[surface.input_components(np.asarray(seeds, dtype=float).reshape(-1, 3))] = True
    return Discovery(
        points=surface.vertices[_extremes(surface.vertices, label, ~seeded)],
        proven=True,
        unresolved=np.zeros((0, 3)),
        boxes=0,
        side=0.0,
        evaluations=0,
        basis="the grid's seeds, and vertices of each component of the closed input mesh (which "
        f"does not intersect itself) that they miss: a seed on every component ({count})",
    )


def _extremes(vertices: np.ndarray, label: np.ndarray, wanted: np.ndarray) -> np.ndarray:
    """Vertex ids: the lowest and highest vertex of each ``wanted`` component
    along each axis (up to six, spread over it, so that its seeds alone span
    restricted facets)."""
    used = np.flatnonzero((label >= 0) & wanted[np.maximum(label, 0)])
    if len(used) == 0:
        return np.zeros(0, np.int64)
    out = []
    for axis in range(3):
        order = used[np.lexsort((vertices[used, axis], label[used]))]
        lab = label[order]
        starts = np.flatnonzero(np.r_[True, lab[1:] != lab[:-1]])
        ends = np.r_[starts[1:], len(order)] - 1
        out += [order[starts], order[ends]]
    return np.unique(np.concatenate(out))
