"""Initial sample: a rotated grid scan that finds every component of the surface.

``f`` is evaluated once on a randomly rotated and shifted grid covering the
bounding ball. Every grid edge with a sign change gives a crossing (one
vectorised root search); the crossings are thinned per connected band of the
grid so that every component keeps several samples (algorithm.md, 2.4). The
same evaluation checks that ``f > 0`` on the bounding sphere and beyond it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from . import _rdt
from ._errors import BoundingSphereError, EmptySurfaceError
from .oracles import ImplicitSurface
from .roots import SegmentSamples, line_crossings

log = logging.getLogger("rdmesh")

#: A connected band of the grid with at most this many crossings keeps them all.
SMALL_COMPONENT = 12


def fibonacci_sphere(n: int) -> np.ndarray:
    """``n`` nearly uniform unit vectors, ``(n, 3)``."""
    i = np.arange(n) + 0.5
    phi = np.arccos(1.0 - 2.0 * i / n)
    theta = np.pi * (1.0 + 5**0.5) * i
    return np.column_stack([np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)])


@dataclass
class GridScan:
    """Result of :func:`grid_scan`.

    Attributes
    ----------
    seeds : (m, 3) the thinned crossings: the initial sample.
    crossings : (c, 3) every grid-edge crossing (a probe set on the surface).
    spacing : grid spacing h.
    """

    seeds: np.ndarray
    crossings: np.ndarray
    spacing: float


def grid_scan(
    surface: ImplicitSurface,
    rng: np.random.Generator,
    resolution: int = 64,
    spacing: float | None = None,
) -> GridScan:
    """Points on every component of the surface thicker than the grid spacing.

    Parameters
    ----------
    surface : ImplicitSurface
    rng : numpy Generator for the grid's rotation and shift.
    resolution : grid cells across the bounding ball's diameter.
    spacing : float, optional
        Target distance between kept crossings on large components;
        default three grid cells.

    Returns
    -------
    GridScan

    Raises
    ------
    BoundingSphereError
        If ``f <= 0`` somewhere on or outside the bounding sphere.
    EmptySurfaceError
        If ``f`` has no sign change inside the ball.
    """
    c0, R = surface.centre, surface.radius
    h = 2.0 * R / resolution
    n = resolution + 3
    rot = Rotation.random(random_state=rng).as_matrix()
    shift = rng.uniform(0.0, h, size=3)
    axis = np.arange(n) * h - (R + h) + shift[None, :].T  # (3, n), per axis
    gx, gy, gz = np.meshgrid(axis[0], axis[1], axis[2], indexing="ij")
    local = np.stack([gx, gy, gz], axis=-1)
    nodes = c0 + local @ rot.T
    m_sphere = max(2000, 8 * resolution**2 // 4)
    on_sphere = c0 + R * fibonacci_sphere(m_sphere)
    values = surface(np.concatenate([nodes.reshape(-1, 3), on_sphere]))
    F = values[: nodes[..., 0].size].reshape(n, n, n)
    Fs = values[nodes[..., 0].size :]
    dist = np.linalg.norm(local, axis=-1)
    outside_ball = dist >= R
    bad = np.concatenate([F[outside_ball & (F <= 0)], Fs[Fs <= 0]])
    if bad.size:
        where = np.concatenate([nodes[outside_ball & (F <= 0)], on_sphere[Fs <= 0]])[0]
        raise BoundingSphereError(
            f"f <= 0 at {len(bad)} sampled points on or outside the bounding sphere "
            f"(e.g. {np.round(where, 6).tolist()}): the surface must lie strictly inside "
            "the sphere and f must be positive outside the surface; enlarge the radius "
            "or flip the sign of f"
        )
    inside = F < 0
    origins, dirs, lows, highs, cells = [], [], [], [], []
    for ax in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[ax] = slice(0, -1)
        b[ax] = slice(1, None)
        idx = np.argwhere(inside[tuple(a)] != inside[tuple(b)])
        if idx.size == 0:
            continue
        origins.append(nodes[tuple(idx.T)])
        dirs.append(np.broadcast_to(rot[:, ax], (len(idx), 3)))
        lows.append(np.zeros(len(idx)))
        highs.append(np.full(len(idx), h))
        cells.append(np.minimum(idx, n - 2))
    if not origins:
        raise EmptySurfaceError(
            "f does not change sign inside the bounding sphere at grid spacing "
            f"{h:.3g}: no surface found (f must be negative inside, positive outside; "
            "raise seed_resolution for components smaller than that)"
        )
    origin = np.concatenate(origins)
    direction = np.ascontiguousarray(np.concatenate(dirs))
    cell = np.concatenate(cells)
    samples = SegmentSamples.uniform(np.full(len(origin), h), 1)
    cr = line_crossings(surface, origin, direction, samples, xatol=1e-9 * R)
    points, cell = cr.point, cell[cr.segment]
    # Connected bands of grid cells that contain the surface.
    corners = [
        inside[i : n - 1 + i, j : n - 1 + j, k : n - 1 + k]
        for i in (0, 1)
        for j in (0, 1)
        for k in (0, 1)
    ]
    mixed = np.any(corners, axis=0) & ~np.all(corners, axis=0)
    labels, n_labels = ndimage.label(mixed, structure=np.ones((3, 3, 3)))
    lab = labels[tuple(cell.T)]
    # Thin large bands to mutually distant points; keep small bands whole.
    spacing = 3.0 * h if spacing is None else max(spacing, h)
    keep = np.zeros(len(points), bool)
    keep[_rdt.select_independent(points, np.full(len(points), spacing))] = True
    small = np.bincount(lab, minlength=n_labels + 1) <= SMALL_COMPONENT
    keep |= small[lab]
    out = points[keep]
    log.info(
        "seeding: %d crossings on a %d^3 grid, %d bands, %d seeds",
        len(points),
        resolution,
        n_labels,
        len(out),
    )
    return GridScan(out, points, h)


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


def _hessian_columns(surface: ImplicitSurface, x: np.ndarray, dirs: list, h: float) -> list:
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
    h = 1e-5 * R
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
        he1, he2 = _hessian_columns(surface, xi, [e1, e2], h)
        G = np.column_stack([f, g @ e1, g @ e2])
        J = np.stack([g, he1, he2], axis=1)
        gn = np.linalg.norm(g, axis=1)
        ok = np.abs(np.linalg.det(J)) > 1e-300
        step = np.zeros_like(xi)
        step[ok] = np.linalg.solve(J[ok], -G[ok][:, :, None])[:, :, 0]
        norm = np.linalg.norm(step, axis=1)
        scale = np.minimum(1.0, spacing / np.maximum(norm, 1e-300))
        x[idx] = xi + step * scale[:, None]
        conv = ok & (norm <= 1e-10 * R) & (gn > 0)
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
    gn = np.linalg.norm(g, axis=1)
    on = (np.abs(f) <= 1e-8 * R * gn) & (np.linalg.norm(np.cross(g, d), axis=1) <= 1e-6 * gn)
    x, g = x[on], g[on]
    if len(x) == 0:
        return empty
    x = x[np.sort(_rdt.select_independent(x, np.full(len(x), 1e-6 * R + 1e-3 * spacing)))]
    g = surface.grad(x)
    he1, he2 = _hessian_columns(surface, x, [e1, e2], h)
    a, b, c = he1 @ e1, he1 @ e2, he2 @ e2
    det = a * c - b * b
    scale = np.maximum(np.abs(a) + np.abs(b) + np.abs(c), 1e-300) ** 2
    log.info("critical points: %d for direction %s", len(x), np.round(d, 4).tolist())
    return CriticalPoints(d, x, det < 0, np.abs(det) <= 1e-6 * scale)


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
    (p, 3) probes, every one with ``|f| / |grad f| <= 1e-8 R``.
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
        g2 = np.maximum(np.einsum("ij,ij->i", g, g), 1e-300)
        step = -(f / g2)[:, None] * g
        norm = np.linalg.norm(step, axis=1)
        x = x + step * np.minimum(1.0, spacing / np.maximum(norm, 1e-300))[:, None]
    f = surface(x)
    gn = np.linalg.norm(surface.grad(x), axis=1)
    ok = (np.abs(f) <= 1e-8 * R * gn) & (np.linalg.norm(x - x0, axis=1) <= 2.0 * spacing)
    ok &= np.linalg.norm(x - surface.centre, axis=1) < R
    return np.concatenate([crossings, x[ok]])
