"""Triangle geometry, vectorised over ``(k, 3, 3)`` corner arrays: angles,
circumcentres, circumradii. A leaf module: the criteria
(:mod:`rdmesh.refine.criteria`) and the result (:mod:`rdmesh.io.result`) both
use it, so that the result need not import the refinement package."""

from __future__ import annotations

import numpy as np


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise cross product of ``(k, 3)`` arrays (much faster than np.cross)."""
    out = np.empty(np.broadcast_shapes(a.shape, b.shape))
    out[:, 0] = a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1]
    out[:, 1] = a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2]
    out[:, 2] = a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]
    return out


def sin2_min_angle(corners: np.ndarray) -> np.ndarray:
    """Squared sine of each triangle's smallest angle, ``(k, 3, 3) -> (k,)``.

    ``4 A^2 min(l^2) / (l_ab^2 l_bc^2 l_ca^2)``, as in CGAL's Standard_criteria.
    """
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    ab, bc, ca = b - a, c - b, a - c
    l2 = np.stack([np.einsum("ij,ij->i", e, e) for e in (ab, bc, ca)], axis=1)
    cr = cross(ab, -ca)
    area4 = np.einsum("ij,ij->i", cr, cr)  # (2A)^2 = 4 A^2
    den = l2.prod(axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        q = area4 * l2.min(axis=1) / den
    return np.where(den > 0, q, 0.0)


def min_angles(corners: np.ndarray) -> np.ndarray:
    """Smallest angle of each triangle in degrees, ``(k, 3, 3) -> (k,)``."""
    return np.degrees(np.arcsin(np.sqrt(np.clip(sin2_min_angle(corners), 0.0, 1.0))))


def circumcentres(corners: np.ndarray) -> np.ndarray:
    """Circumcentre of each triangle, ``(k, 3, 3) -> (k, 3)``."""
    a = corners[:, 0]
    u, v = corners[:, 1] - a, corners[:, 2] - a
    w = cross(u, v)
    uu = np.einsum("ij,ij->i", u, u)
    vv = np.einsum("ij,ij->i", v, v)
    ww = np.einsum("ij,ij->i", w, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        off = (cross(w, u) * vv[:, None] + cross(v, w) * uu[:, None]) / (2 * ww[:, None])
    return a + off


def circumradii(corners: np.ndarray) -> np.ndarray:
    """Circumradius of each triangle, ``(k, 3, 3) -> (k,)``."""
    return np.linalg.norm(circumcentres(corners) - corners[:, 0], axis=1)


def ball_radii(
    vertices: np.ndarray, weights: np.ndarray | None, tri: np.ndarray, centres: np.ndarray
) -> np.ndarray:
    """Radius of each facet's surface Delaunay ball, ``(k,)``: the distance from
    its centre to a corner, or with vertex weights the power radius
    ``sqrt(max(|c - v|^2 - w, 0))`` (equal at all three corners)."""
    d = centres - vertices[tri[:, 0]]
    r2 = np.einsum("ij,ij->i", d, d)
    if weights is not None:
        r2 = np.maximum(r2 - weights[tri[:, 0]], 0.0)
    return np.sqrt(r2)
