"""Critical points of a random height function on the surface (algorithm.md 2.4 b).

Every component of a smooth closed surface has at least a minimum and a
maximum of any height function, so these points put samples on components that
a grid scan can miss; their Morse count is a check of the mesh's Euler
characteristic.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from .. import core
from .._newton import damped_step
from .._tol import (
    CRITICAL_MERGE,
    CRITICAL_PARALLEL,
    CRITICAL_STEP_TOL,
    DEGENERATE_HESSIAN,
    HESSIAN_STEP,
    ON_SURFACE,
    TINY,
)
from .._vectors import row_norms
from ..surfaces.oracle import ImplicitSurface

log = logging.getLogger("rdmesh")

#: Newton iterations of the critical-point search.
CRITICAL_ITERATIONS = 30
#: At most this many starting points for the critical-point search.
CRITICAL_STARTS = 4000


@dataclass
class CriticalPoints:
    """Critical points of a height function on the surface (:func:`critical_points`).

    Attributes
    ----------
    direction : (3,) unit height direction d.
    points : (k, 3) points of the surface where grad f is parallel to d.
    saddle : (k,) bool, True at saddles (negative tangential Hessian determinant).
    degenerate : (k,) bool, True where that determinant is nearly zero (not Morse).
    """

    direction: np.ndarray
    points: np.ndarray
    saddle: np.ndarray
    degenerate: np.ndarray

    @property
    def euler(self) -> int:
        """Morse count #extrema - #saddles: the Euler characteristic when every
        critical point was found and all are non-degenerate."""
        return int(np.sum(~self.saddle) - np.sum(self.saddle))


def hessian_columns(surface: ImplicitSurface, x: np.ndarray, dirs: list, h: float) -> list:
    """H e for each unit vector e in ``dirs``: central differences of the gradient."""
    k = len(x)
    pts = np.concatenate([x + s * h * e for e in dirs for s in (1.0, -1.0)])
    g = surface.grad(pts).reshape(len(dirs), 2, k, 3)
    return [(g[i, 0] - g[i, 1]) / (2.0 * h) for i in range(len(dirs))]


def critical_points(
    surface: ImplicitSurface,
    starts: np.ndarray,
    rng: np.random.Generator,
    spacing: float,
) -> CriticalPoints:
    """Critical points of the height ``<x, d>`` on the surface, d random (algorithm.md 2.4 b).

    Newton's method on ``G(x) = (f, <grad f, e1>, <grad f, e2>)`` with
    ``e1, e2`` orthogonal to ``d``, from every start at once (one vectorised
    call of ``f`` and of the gradient per iteration; the Hessian by central
    differences of the gradient). Steps are capped at ``spacing``. Converged
    points are de-duplicated. Every component of a smooth closed surface has
    at least two critical points (a minimum and a maximum), so these seeds put
    samples on components that a grid scan can miss. The search is sampled:
    critical points with no start in their Newton basin are not found.

    Parameters
    ----------
    surface : ImplicitSurface
    starts : (m, 3) points on or near the surface.
    rng : numpy Generator for d (and the subset of starts when there are many).
    spacing : step cap and de-duplication scale (the grid spacing).
    """
    d = rng.normal(size=3)
    d /= np.linalg.norm(d)
    helper = np.array([1.0, 0, 0]) if abs(d[0]) < 0.9 else np.array([0, 1.0, 0])
    e1 = np.cross(d, helper)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(d, e1)
    empty = CriticalPoints(d, np.zeros((0, 3)), np.zeros(0, bool), np.zeros(0, bool))
    if len(starts) > CRITICAL_STARTS:
        starts = starts[np.sort(rng.choice(len(starts), CRITICAL_STARTS, replace=False))]
    if len(starts) == 0:
        return empty
    R, c0 = surface.radius, surface.centre
    h = HESSIAN_STEP * R
    x = np.array(starts, dtype=np.float64)
    alive = np.ones(len(x), bool)
    done = np.zeros(len(x), bool)
    for _ in range(CRITICAL_ITERATIONS):
        idx = np.flatnonzero(alive & ~done)
        if idx.size == 0:
            break
        xi = x[idx]
        f = surface(xi)
        g = surface.grad(xi)
        he1, he2 = hessian_columns(surface, xi, [e1, e2], h)
        G = np.column_stack([f, g @ e1, g @ e2])
        J = np.stack([g, he1, he2], axis=1)
        gn = row_norms(g)
        ok = np.abs(np.linalg.det(J)) > TINY
        step = np.zeros_like(xi)
        step[ok] = np.linalg.solve(J[ok], -G[ok][:, :, None])[:, :, 0]
        x[idx], norm = damped_step(xi, step, spacing)
        conv = ok & (norm <= CRITICAL_STEP_TOL * R) & (gn > 0)
        done[idx[conv]] = True
        alive[idx[~ok]] = False
        out = np.linalg.norm(x[idx] - c0, axis=1) >= R
        alive[idx[out]] = False
    x = x[done & alive]
    if len(x) == 0:
        return empty
    # Keep genuine solutions on the surface, then de-duplicate.
    f = surface(x)
    g = surface.grad(x)
    gn = row_norms(g)
    on = np.abs(f) <= ON_SURFACE * R * gn
    on &= row_norms(np.cross(g, d)) <= CRITICAL_PARALLEL * gn
    x, g = x[on], g[on]
    if len(x) == 0:
        return empty
    merge = np.full(len(x), CRITICAL_MERGE * R + 1e-3 * spacing)
    x = x[np.sort(core.select_independent(x, merge))]
    g = surface.grad(x)
    he1, he2 = hessian_columns(surface, x, [e1, e2], h)
    a, b, c = he1 @ e1, he1 @ e2, he2 @ e2
    det = a * c - b * b
    scale = np.maximum(np.abs(a) + np.abs(b) + np.abs(c), TINY) ** 2
    log.info("critical points: %d for direction %s", len(x), np.round(d, 4).tolist())
    return CriticalPoints(d, x, det < 0, np.abs(det) <= DEGENERATE_HESSIAN * scale)
