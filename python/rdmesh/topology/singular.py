"""Singular points of the surface: where the gradient of f vanishes on it."""

from __future__ import annotations

import numpy as np

from .. import core
from .._newton import damped_step
from .._tol import (
    HESSIAN_STEP,
    SINGULAR_DAMPING,
    SINGULAR_F,
    SINGULAR_GRADIENT,
    SINGULAR_MERGE,
    TINY,
)
from .._vectors import row_norms
from ..sampling.probes import Probes
from ..surfaces.oracle import ImplicitSurface

#: Starts of the singular-point search: probes with the weakest gradient, plus
#: as many random ones.
SINGULAR_STARTS = 256
SINGULAR_ITERATIONS = 25


def singular_points(surface: ImplicitSurface, probes: Probes, seed: int = 0) -> np.ndarray:
    """Points of the surface where the gradient vanishes, found by Newton's method.

    Solves ``grad f = 0`` (Hessian by central differences of the gradient,
    damped least squares, so curves of singular points work too) from the
    probes with the weakest gradient and from random probes, and keeps the
    solutions where ``f`` is zero to within ``1e-6 R`` times the median probe
    gradient. Sampled: a singular point with no start nearby is missed.

    Returns
    -------
    (k, 3) singular points (de-duplicated to about ``1e-3 R``).
    """
    pts = probes.points
    if len(pts) == 0 or getattr(surface, "unit_gradient", False):
        # A signed distance (MeshSurface) has a unit gradient wherever it has one.
        return np.zeros((0, 3))
    R = surface.radius
    gn = row_norms(surface.grad(pts))
    scale = float(np.median(gn))
    if not scale > 0:
        return np.zeros((0, 3))
    rng = np.random.default_rng(seed)
    # Starts only where the gradient may vanish (an open mesh: next to its holes).
    unit_at = getattr(surface, "unit_gradient_at", None)
    cand = np.arange(len(pts)) if unit_at is None else np.flatnonzero(~unit_at(pts))
    if len(cand) == 0:
        return np.zeros((0, 3))
    weak = cand[np.argsort(gn[cand], kind="stable")[:SINGULAR_STARTS]]
    rand = rng.choice(cand, min(SINGULAR_STARTS, len(cand)), replace=False)
    x = pts[np.unique(np.concatenate([weak, rand]))].copy()
    h = HESSIAN_STEP * R
    eye = np.eye(3)
    for _ in range(SINGULAR_ITERATIONS):
        # Divided by the typical gradient: the step is scale-free, and H^T H
        # neither overflows nor underflows for f scaled by 1e+-200.
        g = surface.grad(x) / scale
        cols = (
            surface.grad(
                np.concatenate([x + s * h * eye[k] for k in range(3) for s in (1.0, -1.0)])
            ).reshape(3, 2, len(x), 3)
            / scale
        )
        H = np.stack([(cols[k, 0] - cols[k, 1]) / (2 * h) for k in range(3)], axis=2)
        HtH = np.einsum("nji,njk->nik", H, H)
        mu = SINGULAR_DAMPING * np.maximum(np.einsum("nii->n", HtH), TINY)
        A = HtH + mu[:, None, None] * eye
        step = -np.linalg.solve(A, np.einsum("nji,nj->ni", H, g)[:, :, None])[:, :, 0]
        x, _ = damped_step(x, step, probes.spacing)
        inside = np.linalg.norm(x - surface.centre, axis=1) < R
        x = x[inside]
        if len(x) == 0:
            return np.zeros((0, 3))
    f = surface(x)
    g = row_norms(surface.grad(x))
    sing = (np.abs(f) <= SINGULAR_F * R * scale) & (g <= SINGULAR_GRADIENT * scale)
    x = x[sing]
    if len(x) == 0:
        return x
    return x[np.sort(core.select_independent(x, np.full(len(x), SINGULAR_MERGE * R)))]
