"""T1 with proof: the crossings of every Voronoi edge, by interval arithmetic (issue 13, 4).

For an expression surface, every finite Delaunay facet's dual Voronoi edge
(clipped to the bounding sphere) goes through Snyder's root isolation
(:mod:`rdmesh.sampling.isolate`). The test holds when each edge has a proven
number of crossings, every crossing is transversal, restricted facets (those
the sampled search found crossed) have exactly one, and all others none. The
restricted Delaunay triangulation is then exactly the one the theory speaks
of, and T1 holds: proven, not sampled.

Violations, each with the crossing farthest from the facet's vertices as its
refinement point (the centre of an empty surface ball): an edge with two or
more crossings, and a facet whose crossing the sampled search missed. A
restricted facet whose edge has no crossing (a sampled root that is not one)
gets its sampled centre. Edges with an unsettled piece (a tangency, a
singular point) have no refinement point: they are ``stuck``.
"""

from __future__ import annotations

import numpy as np

from .._tol import PROOF_FLOOR, ROOT_ATOL
from .._vectors import row_index, row_norms
from ..sampling.isolate import isolate_roots
from ..sampling.roots import refine_brackets
from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .tests import Violations


def proven_edge_test(
    surface: ImplicitSurface,
    rdt,
    vertices: np.ndarray,
    tri: np.ndarray,
    centres: np.ndarray,
) -> Violations:
    """T1 on every Voronoi edge, by interval root isolation.

    Parameters
    ----------
    surface : ImplicitSurface whose ``f`` is an :class:`Expression`.
    rdt : the core.
    vertices : (n, 3) the samples.
    tri, centres : the restricted facets (any vertex order) and their surface centres.

    Returns
    -------
    Violations
        Kind ``proven_voronoi_edge``; ``stuck`` holds the midpoints of
        unsettled pieces.
    """
    expr = surface.f
    if not isinstance(expr, Expression):
        raise TypeError("proven_edge_test needs an expression surface")
    R = surface.radius
    all_tri, seg = rdt.all_facets()
    a, b = seg[:, 0], seg[:, 1]
    iso = isolate_roots(expr, a, b, PROOF_FLOOR * R)
    # Position of each facet among the restricted ones, -1 if not restricted.
    where = row_index(all_tri, np.sort(tri, axis=1))
    restricted = where >= 0
    count, ok = iso.count, iso.resolved
    multi = ok & (count >= 2)
    missed = ok & (count == 1) & ~restricted
    false = ok & (count == 0) & restricted
    # Refinement points: the located crossing farthest from the facet's vertices.
    rows = np.flatnonzero((multi | missed)[iso.segment])
    s = iso.segment[rows]
    d = b[s] - a[s]
    length = np.maximum(row_norms(d), 1e-300)
    xatol = ROOT_ATOL * R / float(length.max()) if len(s) else 1.0
    t, conv = refine_brackets(surface, a[s], d, iso.lo[rows], iso.hi[rows], xatol)
    point = a[s] + t[:, None] * d
    radius = row_norms(point - vertices[all_tri[s, 0]])
    order = np.lexsort((-radius, s))
    first = order[np.r_[True, s[order][1:] != s[order][:-1]]] if len(s) else order
    first = first[conv[first]]
    centre, rad = point[first], radius[first]
    # Sampled roots that are not roots: their sampled centres.
    fc = centres[where[false]]
    centre = np.concatenate([centre, fc])
    rad = np.concatenate([rad, row_norms(fc - vertices[all_tri[false, 0]])])
    mid = 0.5 * (iso.pending_lo + iso.pending_hi)
    stuck = a[iso.pending_segment] + mid[:, None] * (b - a)[iso.pending_segment]
    n_bad = int((multi | missed | false).sum()) + int((~ok).sum())
    return Violations("proven_voronoi_edge", n_bad, centre, rad, stuck)
