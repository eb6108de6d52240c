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

from .criteria import circumradii
from .oracles import ImplicitSurface
from .roots import bucket_samples, line_crossings

#: Samples per unit of asinh(distance / circumradius): spacing about r / 2.
SAMPLES_PER_RADIUS = 2.0
#: A crossing whose direction makes |cos| below this with the gradient is tangential.
TANGENCY_COS = 1e-3
#: Root tolerance relative to the smallest facet circumradius of the call.
ROOT_RTOL = 1e-7


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
    surface: ImplicitSurface, corners: np.ndarray, seg: np.ndarray
) -> FacetEval:
    """Find the crossings of each facet's dual segment.

    Parameters
    ----------
    surface : ImplicitSurface
    corners : (k, 3, 3) facet vertex coordinates.
    seg : (k, 2, 3) dual segments (clipped to the bounding sphere).

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
    apex = corners[:, 0]
    d = seg[:, 1] - seg[:, 0]
    length = np.linalg.norm(d, axis=1)
    ok = length > 0
    u = np.zeros_like(d)
    u[ok] = d[ok] / length[ok, None]
    rho = circumradii(corners)
    rho = np.where(np.isfinite(rho) & (rho > 0), rho, np.maximum(length, 1e-300))
    # Distance along the line from the facet's circumcentre (the closest point
    # to its vertices); ball radius is sqrt(rho^2 + sigma^2), so sample evenly
    # in asinh(sigma / rho): steps of about half the local ball radius.
    sigma0 = np.einsum("ij,ij->i", u, seg[:, 0] - apex)
    w0 = np.arcsinh(sigma0 / rho)
    w1 = np.arcsinh((sigma0 + length) / rho)
    n = np.ceil((w1 - w0) * SAMPLES_PER_RADIUS).astype(np.int64)

    def warp(rows, frac):
        w = w0[rows, None] + frac * (w1 - w0)[rows, None]
        return rho[rows, None] * np.sinh(w) - sigma0[rows, None]

    rows_ok = np.flatnonzero(ok)
    buckets = [
        (rows_ok[r], S)
        for r, S in bucket_samples(length[rows_ok], n[rows_ok], warp=_subset(warp, rows_ok))
    ]
    xatol = ROOT_RTOL * float(np.min(rho[rows_ok])) if rows_ok.size else 0.0
    cr = line_crossings(surface, seg[:, 0], u, buckets, xatol)
    if cr.segment.size == 0:
        return out
    out.n_cross = cr.count(k)
    # Representative crossing: largest |sigma|, i.e. the largest ball.
    far = np.abs(sigma0[cr.segment] + cr.s)
    order = np.lexsort((far, cr.segment))
    last = np.r_[cr.segment[order][1:] != cr.segment[order][:-1], True]
    pick = order[last]
    rows = cr.segment[pick]
    out.centre[rows] = cr.point[pick]
    out.radius[rows] = np.linalg.norm(cr.point[pick] - apex[rows], axis=1)
    out.outward[rows] = cr.rising[pick]
    g = surface.grad(cr.point[pick])
    gn = np.linalg.norm(g, axis=1)
    cos = np.abs(np.einsum("ij,ij->i", g, u[rows])) / np.where(gn > 0, gn, 1.0)
    out.tangential[rows] = (gn == 0) | (cos < TANGENCY_COS)
    return out


def _subset(warp, rows_ok):
    """Adapt ``warp`` (indexed by facet) to rows of the ``rows_ok`` subset."""
    return lambda rows, frac: warp(rows_ok[rows], frac)
