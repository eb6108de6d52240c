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
from ..core import segment_pieces
from ..sampling.isolate import isolate_roots
from ..sampling.roots import refine_brackets
from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .proven_cells import CellProof
from .tests import Violations

#: Slack, in t, around a segment's part inside a leaf box (covers rounding).
_SLACK = 1e-9


def proven_edge_test(
    surface: ImplicitSurface,
    rdt,
    vertices: np.ndarray,
    tri: np.ndarray,
    centres: np.ndarray,
    cells: CellProof | None = None,
) -> Violations:
    """T1 on every Voronoi edge, by interval root isolation.

    Parameters
    ----------
    surface : ImplicitSurface whose ``f`` is an :class:`Expression`.
    rdt : the core.
    vertices : (n, 3) the samples.
    tri, centres : the restricted facets (any vertex order) and their surface centres.
    cells : CellProof, optional
        Proven Voronoi cells: a Voronoi edge lies in the cell of each of its
        facet's vertices, so where one of them is proven, only the parts of
        the edge inside that cell's leaves can hold a crossing, and only
        those are searched.

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
    pieces = None if cells is None else _pieces(cells, all_tri, a, b)
    iso = isolate_roots(expr, a, b, PROOF_FLOOR * R, pieces)
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


def _pieces(cells: CellProof, tri: np.ndarray, a: np.ndarray, b: np.ndarray):
    """The parts ``(segment, t0, t1)`` of the Voronoi edges ``a b`` (dual to
    the facets ``tri``) that can hold a crossing.

    An edge with a proven cell among its facet's vertices (the one with the
    fewest leaves) can cross the surface only inside that cell's leaves: its
    parts in them, widened by ``_SLACK`` and merged where they meet (so no
    crossing is counted twice). Other edges are searched whole.
    """
    leaves = np.diff(cells.first)
    cost = np.where(cells.seeded[tri], leaves[tri], np.iinfo(np.int64).max)
    host = tri[np.arange(len(tri)), np.argmin(cost, axis=1)]
    host = np.where(cells.seeded[host], host, -1)
    return segment_pieces(a, b, host, cells.first, cells.lo, cells.hi, _SLACK)
