"""Restricted-facet evaluation: where a facet's dual Voronoi edge meets the surface.

For every facet the dual segment is searched for *all* crossings. The facet is
restricted when there is at least one; its representative surface centre is the
crossing with the largest surface Delaunay ball (farthest from the facet's
vertices), and the facet is flagged when it has several crossings or a
tangential one (algorithm.md, 1.3 and 5.2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .oracles import ImplicitSurface
from .roots import bucket_samples, line_crossings

#: Samples per unit of asinh(distance / circumradius): spacing about r.
SAMPLES_PER_RADIUS = 1.0
#: A crossing whose direction makes |cos| below this with the gradient is tangential.
TANGENCY_COS = 1e-3
#: Root tolerance relative to the bounding radius. Fixed per run (not per
#: chunk) so that results do not depend on how facets are grouped.
ROOT_ATOL = 1e-10


@dataclass
class FacetEval:
    """Result of :func:`evaluate_facets` for k facets."""

    n_cross: np.ndarray  # (k,) int
    centre: np.ndarray  # (k, 3), zeros where not restricted
    radius: np.ndarray  # (k,), zeros where not restricted
    outward: np.ndarray  # (k,) bool: outside lies along the segment direction
    tangential: np.ndarray  # (k,) bool

    @property
    def restricted(self) -> np.ndarray:
        return self.n_cross > 0


def evaluate_facets(
    surface: ImplicitSurface,
    apex: np.ndarray,
    seg: np.ndarray,
    rho: np.ndarray,
    end_values: np.ndarray | None = None,
) -> FacetEval:
    """Find the crossings of each facet's dual segment.

    Parameters
    ----------
    surface : ImplicitSurface
    apex : (k, 3) one vertex of each facet.
    seg : (k, 2, 3) dual segments (clipped to the bounding sphere).
    rho : (k,) facet circumradii.
    end_values : (k, 2) float, optional
        ``f`` at both ends of each segment, when known (the core reports
        shared Voronoi vertices once, so ``f`` is evaluated once per vertex).

    Returns
    -------
    FacetEval
    """
    k = len(seg)
    out = FacetEval(
        np.zeros(k, np.int64), np.zeros((k, 3)), np.zeros(k), np.zeros(k, bool), np.zeros(k, bool)
    )
    if k == 0:
        return out
    start = seg[:, 0]
    d = seg[:, 1] - start
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    u = d / np.where(length > 0, length, 1.0)[:, None]
    rho = np.where(np.isfinite(rho) & (rho > 0), rho, np.maximum(length, 1e-300))
    # Distance along the line from the facet's circumcentre (the closest point
    # to its vertices); the ball radius there is sqrt(rho^2 + sigma^2), so
    # sampling evenly in asinh(sigma / rho) spaces samples by the ball radius.
    sigma0 = np.einsum("ij,ij->i", u, start - apex)
    w0 = np.arcsinh(sigma0 / rho)
    w1 = np.arcsinh((sigma0 + length) / rho)
    n = np.ceil((w1 - w0) * SAMPLES_PER_RADIUS).astype(np.int64)
    n[length == 0] = 0

    def warp(rows, frac):
        w = w0[rows, None] + frac * (w1 - w0)[rows, None]
        return rho[rows, None] * np.sinh(w) - sigma0[rows, None]

    order, buckets = bucket_samples(length, n, warp=warp)
    if end_values is not None:
        end_values = end_values[order]
    xatol = ROOT_ATOL * surface.radius
    cr = line_crossings(surface, start[order], u[order], buckets, xatol, end_values)
    if cr.segment.size == 0:
        return out
    segment = order[cr.segment]
    out.n_cross = np.bincount(segment, minlength=k)
    # Representative crossing: largest |sigma|, i.e. the largest ball.
    far = np.abs(sigma0[segment] + cr.s)
    pick_order = np.lexsort((far, segment))
    last = np.r_[segment[pick_order][1:] != segment[pick_order][:-1], True]
    pick = pick_order[last]
    rows = segment[pick]
    out.centre[rows] = cr.point[pick]
    out.radius[rows] = np.linalg.norm(cr.point[pick] - apex[rows], axis=1)
    out.outward[rows] = cr.rising[pick]
    g = surface.grad(cr.point[pick])
    gn = np.linalg.norm(g, axis=1)
    cos = np.abs(np.einsum("ij,ij->i", g, u[rows])) / np.where(gn > 0, gn, 1.0)
    out.tangential[rows] = (gn == 0) | (cos < TANGENCY_COS)
    return out
