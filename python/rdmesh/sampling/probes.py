"""Probes: a dense point set on the surface with unit normals, for the cell tests."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._newton import damped_step
from .._tol import ON_SURFACE, TINY
from .._vectors import row_norms, unit_rows
from ..surfaces.oracle import ImplicitSurface, forward_gradient


@dataclass
class Probes:
    """Points on the surface with unit normals, for the cell tests.

    Attributes
    ----------
    points : (n, 3)
    normals : (n, 3) unit gradients (zero where the gradient vanishes).
    spacing : the scale they resolve (the seeding grid spacing).
    """

    points: np.ndarray
    normals: np.ndarray
    spacing: float

    @classmethod
    def on(cls, surface: ImplicitSurface, points: np.ndarray, spacing: float) -> Probes:
        return cls(points, unit_normals(surface, points), spacing)


def unit_normals(surface: ImplicitSurface, x: np.ndarray) -> np.ndarray:
    """Unit gradients at ``(n, 3)`` points; zero rows where the gradient is zero.
    Without a gradient function, by forward differences (four evaluations per
    point, not six: a direction needs no more)."""
    if len(x) == 0:
        return np.zeros((0, 3))
    return unit_rows(forward_gradient(surface, x))


#: Newton projections per probe.
_PROJECT_STEPS = 8


def surface_probes(
    surface: ImplicitSurface,
    crossings: np.ndarray,
    spacing: float,
    rng: np.random.Generator,
    target: int,
) -> np.ndarray:
    """A dense point set on the surface: the grid crossings plus jittered copies
    projected back onto the surface (a narrow band around the crossings).

    Parameters
    ----------
    crossings : (c, 3) grid crossings (on the surface).
    spacing : the grid spacing h; copies are jittered by up to h/2 per axis.
    target : wanted number of probes (at most 8 copies per crossing are made).

    Returns
    -------
    (p, 3) probes, every one with ``|f| / |grad f| <= ON_SURFACE R``.
    """
    copies = int(np.clip(np.ceil(target / max(len(crossings), 1)) - 1, 0, 8))
    if copies == 0 or len(crossings) == 0:
        return crossings
    R = surface.radius
    x0 = np.repeat(crossings, copies, axis=0)
    x = x0 + rng.uniform(-0.5 * spacing, 0.5 * spacing, size=x0.shape)
    for _ in range(_PROJECT_STEPS):
        f = surface(x)
        g = surface.grad(x)
        gn = np.maximum(row_norms(g), TINY)
        step = -(f / gn)[:, None] * (g / gn[:, None])
        x, _ = damped_step(x, step, spacing)
    f = surface(x)
    gn = row_norms(surface.grad(x))
    ok = (np.abs(f) <= ON_SURFACE * R * gn) & (np.linalg.norm(x - x0, axis=1) <= 2.0 * spacing)
    ok &= np.linalg.norm(x - surface.centre, axis=1) < R
    return np.concatenate([crossings, x[ok]])
