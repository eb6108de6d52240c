"""Singular points of the surface: where the gradient of f vanishes on it."""

from __future__ import annotations

import numpy as np

from .. import core
from .._newton import damped_step
from .._tol import (
    CRITICAL_STEP_TOL,
    HESSIAN_STEP,
    SINGULAR_DAMPING,
    SINGULAR_F,
    SINGULAR_GRADIENT,
    SINGULAR_MERGE,
    SINGULAR_SETTLED,
    TINY,
)
from .._vectors import row_norms
from ..sampling.critical import hessian_columns
from ..sampling.probes import Probes
from ..surfaces.oracle import ImplicitSurface

#: Starts of the singular-point search: probes with the weakest gradient, plus
#: as many random ones.
SINGULAR_STARTS = 256
SINGULAR_ITERATIONS = 25


def singular_points(surface: ImplicitSurface, probes: Probes, seed: int = 0) -> np.ndarray:
    """Points of the surface where the gradient vanishes, found by Newton's method.

    Solves ``grad f = 0`` (Hessian by central differences of the gradient, or
    by a second-order stencil of ``f`` where no gradient is given; damped
    least squares, so curves of singular points work too) from the
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
    done = np.zeros((0, 3))
    for _ in range(SINGULAR_ITERATIONS):
        # Divided by the typical gradient: the step is scale-free, and H^T H
        # neither overflows nor underflows for f scaled by 1e+-200.
        g, H = _gradient_and_hessian(surface, x, h, scale)
        still = row_norms(g) <= SINGULAR_SETTLED
        if still.any():
            done = np.concatenate([done, x[still]])
            x, g, H = x[~still], g[~still], H[~still]
            if len(x) == 0:
                break
        HtH = np.einsum("nji,njk->nik", H, H)
        mu = SINGULAR_DAMPING * np.maximum(np.einsum("nii->n", HtH), TINY)
        A = HtH + mu[:, None, None] * np.eye(3)
        step = -np.linalg.solve(A, np.einsum("nji,nj->ni", H, g)[:, :, None])[:, :, 0]
        x, length = damped_step(x, step, probes.spacing)
        # A start whose step fell below the tolerance has converged: it moves
        # no further, so it costs no more evaluations (nor one at a critical
        # point, above).
        settled = length <= CRITICAL_STEP_TOL * R
        done = np.concatenate([done, x[settled]])
        x = x[~settled]
        x = x[np.linalg.norm(x - surface.centre, axis=1) < R]
        if len(x) == 0:
            break
    x = np.concatenate([done, x])
    x = x[np.linalg.norm(x - surface.centre, axis=1) < R]
    if len(x) == 0:
        return np.zeros((0, 3))
    f = surface(x)
    g = row_norms(surface.grad(x))
    sing = (np.abs(f) <= SINGULAR_F * R * scale) & (g <= SINGULAR_GRADIENT * scale)
    x = x[sing]
    if len(x) == 0:
        return x
    return x[np.sort(core.select_independent(x, np.full(len(x), SINGULAR_MERGE * R)))]


#: The second-order stencil of f alone: the centre, the six axis neighbours,
#: and the twelve diagonal ones (i < j, signs ++, +-, -+, --).
_AXES = np.array([(i, j) for i in range(3) for j in range(i + 1, 3)])
_SIGNS = np.array([(1.0, 1.0), (1.0, -1.0), (-1.0, 1.0), (-1.0, -1.0)])


def _gradient_and_hessian(surface, x, h, scale):
    """``grad f`` (n, 3) and its Jacobian (n, 3, 3) at ``x``, divided by
    ``scale``: the Jacobian by central differences of the gradient (step
    ``h``); without a gradient function, from one call of ``f`` at the 19
    points of the second-order stencil with step ``h`` (against 42 for
    central differences of central differences)."""
    n, eye = len(x), np.eye(3)
    if surface.gradient is not None:
        cols = hessian_columns(surface, x, list(eye), h)
        return surface.grad(x) / scale, np.stack(cols, axis=2) / scale
    axis = np.concatenate([eye, -eye]) * h  # (6, 3): +e0, +e1, +e2, -e0, -e1, -e2
    diag = (_SIGNS[:, None, :, None] * eye[_AXES][None]).sum(axis=2) * h  # (4, 3, 3)
    offsets = np.concatenate([np.zeros((1, 3)), axis, diag.reshape(-1, 3)])
    v = surface((x[None] + offsets[:, None]).reshape(-1, 3)).reshape(19, n) / scale
    f0, plus, minus, d = v[0], v[1:4], v[4:7], v[7:].reshape(4, 3, n)
    g = ((plus - minus) / (2 * h)).T
    H = np.empty((n, 3, 3))
    H[:, [0, 1, 2], [0, 1, 2]] = ((plus - 2 * f0 + minus) / (h * h)).T
    mixed = ((d[0] - d[1] - d[2] + d[3]) / (4 * h * h)).T  # (n, 3) for the pairs
    for k, (i, j) in enumerate(_AXES):
        H[:, i, j] = H[:, j, i] = mixed[:, k]
    return g, H
