"""The protecting balls' spacing: small by default on a mesh input where they
cost little, and whether the angle bound is held next to them.

With balls at most :data:`~rdmesh.refine.criteria.SMALL_BALL` times the radius
bound apart, the angle bound is held next to them too
(``FacetCriteria.hold_at_small_balls``): on the features benchmark's shapes it
left 5 to 90 times fewer triangles below 30 degrees, for more vertices along
the curves (1.5 to 5 times the vertices where creases dominate). A mesh whose
creases are short against its area gets such balls by default, when they add
at most :data:`SMALL_BALL_COST` of the vertices the radius bound asks for;
the others keep balls the radius bound apart. Rims of kept holes do not: there
small balls made the smallest angles worse (benchmarks/RESULTS.md).
"""

from __future__ import annotations

import logging
from dataclasses import replace

import numpy as np

from .._vectors import row_norms
from ..surfaces._mesh_input import area_vectors
from .criteria import SMALL_BALL, FacetCriteria

log = logging.getLogger("rdmesh")

#: Small balls by default when their count is at most this fraction of the
#: vertex count the radius bound asks for (about area / radius_bound**2): the
#: thin-handled genus-2 benchmark solid's crease needs 1.1 % at 1 % of its
#: diagonal, the CAD shapes' creases 10-20 %.
SMALL_BALL_COST = 0.02


def small_by_default(surface, radius_bound) -> bool:
    """Whether ``surface`` (a :class:`~rdmesh.MeshSurface` whose curves are its
    sharp edges alone: no given curves, no kept holes) gets protecting balls
    :data:`SMALL_BALL` times a numeric ``radius_bound`` apart by default."""
    curves = getattr(surface, "sharp_curves", None)
    if not curves or radius_bound is None or callable(radius_bound):
        return False
    if isinstance(surface.features, list) and len(surface.features):
        return False  # given curves: the user's
    holes = getattr(surface, "holes", None)
    if holes is not None and len(holes.curves):
        return False  # kept rims: small balls made their angles worse
    length = float(sum(row_norms(np.diff(c, axis=0)).sum() for c in curves))
    faces = surface.faces[: surface.input_face_count]  # not the caps over holes
    area = float(row_norms(area_vectors(surface.vertices, faces)).sum())
    balls = length / (SMALL_BALL * radius_bound)
    return balls <= SMALL_BALL_COST * area / radius_bound**2


def small_balls(edge_size, radius_bound) -> bool:
    """Whether the protecting balls are at most :data:`SMALL_BALL` times the
    radius bound apart (numbers both; no radius bound: not small), so that
    the angle bound is held next to them too."""
    if edge_size is None or radius_bound is None or callable(edge_size) or callable(radius_bound):
        return False
    return edge_size <= SMALL_BALL * radius_bound


def with_ball_spacing(surface, criteria: FacetCriteria, edge_size):
    """``(criteria, edge_size)`` for a run: the default spacing where none is
    given (:func:`small_by_default`), and the criteria holding the angle bound
    next to small balls (:func:`small_balls`)."""
    if edge_size is None and small_by_default(surface, criteria.radius_bound):
        edge_size = SMALL_BALL * criteria.radius_bound
        log.info("features: protecting balls %.3g apart (short creases: small balls)", edge_size)
    if small_balls(edge_size, criteria.radius_bound):
        criteria = replace(criteria, hold_at_small_balls=True)
    return criteria, edge_size
