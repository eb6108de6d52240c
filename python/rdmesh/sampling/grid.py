"""Initial sample: a rotated grid scan that finds the components crossing grid edges.

``f`` is evaluated once on a randomly rotated and shifted grid covering the
bounding ball. Every grid edge with a sign change gives a crossing (one
vectorised root search, or a mesh input's exact crossings); the crossings are
thinned per connected band of the grid so that every component keeps several
samples (algorithm.md, 2.4). The same evaluation checks that ``f > 0`` on the
bounding sphere and beyond it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy import ndimage
from scipy.spatial.transform import Rotation

from .. import core
from .._errors import BoundingSphereError, EmptySurfaceError
from .._newton import damped_step
from .._tol import SHOT_ATOL
from .._vectors import row_norms
from ..surfaces.oracle import ImplicitSurface
from .domain import clip_box, depth
from .roots import crossings_along_segments
from .screen import SlopeField

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
    slopes : the local slopes of ``f`` between the grid's nodes (for a
        Lipschitz ``f``, its constant and proven lower bounds of ``|f|``).
    """

    seeds: np.ndarray
    crossings: np.ndarray
    spacing: float
    slopes: SlopeField | None = None


def grid_scan(
    surface: ImplicitSurface,
    rng: np.random.Generator,
    resolution: int = 64,
    spacing: float | None = None,
    clipped: bool = False,
) -> GridScan:
    """Points on the components of the surface that cross grid edges (every component
    wider than about sqrt(3) grid spacings; smaller ones only by chance).

    Parameters
    ----------
    surface : ImplicitSurface
    rng : numpy Generator for the grid's rotation and shift.
    resolution : grid cells across the bounding ball's diameter.
    spacing : float, optional
        Target distance between kept crossings on large components;
        default three grid cells.
    clipped : bool
        The surface may cross the bounding sphere, or its clip box
        (``topology="manifold-with-boundary"``): no sphere check, and only
        crossings inside the ball (the box) are kept.

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
    lipschitz = getattr(surface, "lipschitz", None)
    if lipschitz is None:
        values = surface(np.concatenate([nodes.reshape(-1, 3), on_sphere]))
        F = values[: nodes[..., 0].size].reshape(n, n, n)
    else:
        F, lower = _lipschitz_grid(surface, nodes, h, float(lipschitz))
        values = np.concatenate([F.ravel(), surface(on_sphere)])
    Fs = values[nodes[..., 0].size :]
    dist = np.linalg.norm(local, axis=-1)
    outside_ball = dist >= R
    bad = np.concatenate([F[outside_ball & (F <= 0)], Fs[Fs <= 0]])
    if bad.size and not clipped:
        where = np.concatenate([nodes[outside_ball & (F <= 0)], on_sphere[Fs <= 0]])[0]
        raise BoundingSphereError(
            f"f <= 0 at {len(bad)} sampled points on or outside the bounding sphere "
            f"(e.g. {np.round(where, 6).tolist()}): the surface must lie strictly inside "
            "the sphere and f must be positive outside the surface; enlarge the radius "
            "or flip the sign of f (or mesh the part inside with "
            'topology="manifold-with-boundary")'
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
    # Each edge has a sign change: exact crossings on a mesh, else one root each.
    segment, points = crossings_along_segments(
        surface, origin, direction, np.full(len(origin), h), 1, SHOT_ATOL * surface.radius,
        each_crosses=True,
    )  # fmt: skip
    cell = cell[segment]
    if clipped:
        within = depth(surface, points) > 0
        points, cell = points[within], cell[within]
        if len(points) == 0:
            where = "sphere" if clip_box(surface) is None else "clip box"
            raise EmptySurfaceError(
                f"f changes sign only outside the bounding {where} at grid spacing "
                f"{h:.3g}: no surface found inside it"
            )
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
    # Not so far apart that a band keeps fewer than the four points a
    # tetrahedron needs (a size bound larger than the surface).
    spacing = min(spacing, MAX_SEED_SPACING * R)
    keep = np.zeros(len(points), bool)
    keep[core.select_independent(points, np.full(len(points), spacing))] = True
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
    if lipschitz is None:
        slopes = SlopeField(F, h, c0, rot, R + h - shift, ~outside_ball)
    else:
        slopes = SlopeField.proven(lower, h, c0, rot, R + h - shift, float(lipschitz))
    return GridScan(out, points, h, slopes)


#: Seeds are thinned to at most this fraction of the bounding radius apart.
MAX_SEED_SPACING = 0.5

#: Stride of the coarse grid of :func:`_lipschitz_grid`.
COARSE_STRIDE = 4


def _lipschitz_grid(
    surface: ImplicitSurface, nodes: np.ndarray, h: float, lip: float
) -> tuple[np.ndarray, np.ndarray]:
    """``f`` on the grid's nodes ``(n, n, n, 3)`` where its sign could be
    in doubt; elsewhere a value of the same sign. And a proven lower bound on
    ``|f|`` with that sign at every node (``f`` itself where evaluated).

    ``f`` is ``lip``-Lipschitz (a signed distance: 1). A node whose nearest
    node of the coarse grid (every :data:`COARSE_STRIDE`-th) has
    ``|f| > lip * distance`` has the coarse node's sign (``f`` cannot reach 0
    in between), and gets its value; the others are evaluated. The grid
    scan uses only the signs of the nodes, so its result is that of the full
    grid, for a fraction of the evaluations.
    """
    n = nodes.shape[0]
    k = COARSE_STRIDE
    coarse_idx = np.unique(np.append(np.arange(0, n, k), n - 1))
    C = surface(nodes[np.ix_(coarse_idx, coarse_idx, coarse_idx)].reshape(-1, 3))
    C = C.reshape(len(coarse_idx), len(coarse_idx), len(coarse_idx))
    # Nearest coarse index per fine index, and the distance along one axis.
    near = coarse_idx[np.argmin(np.abs(np.arange(n)[:, None] - coarse_idx[None, :]), axis=1)]
    pos = np.searchsorted(coarse_idx, near)
    gap = np.abs(np.arange(n) - near) * h
    Fc = C[np.ix_(pos, pos, pos)]
    dist = np.sqrt(gap[:, None, None] ** 2 + gap[None, :, None] ** 2 + gap[None, None, :] ** 2)
    sure = np.abs(Fc) > lip * dist * (1.0 + 1e-9) + 1e-300
    F = Fc.copy()
    doubt = ~sure
    F[doubt] = surface(nodes[doubt])
    lower = np.where(sure, np.sign(Fc) * (np.abs(Fc) - lip * dist * (1.0 + 1e-9)), F)
    log.debug(
        "seeding grid: %d of %d nodes evaluated (Lipschitz %g)",
        int(doubt.sum()) + C.size,
        F.size,
        lip,
    )
    return F, lower


#: A segment end this close to the bounding sphere (times R) was clipped to it.
ON_SPHERE = 1e-9


def check_sphere_ends(surface: ImplicitSurface, ends: np.ndarray, values: np.ndarray) -> None:
    """Raise BoundingSphereError if ``f <= 0`` where a dual segment was clipped
    to the bounding sphere.

    Every Voronoi edge that leaves the ball is cut at the sphere, so as
    refinement goes on these ends sample the sphere ever more densely near the
    surface: a surface that pokes out of the sphere shows there (sampled, like
    the grid check of :func:`grid_scan`).

    Parameters
    ----------
    ends : (u, 3) distinct ends of a chunk's dual segments (Voronoi vertices
        and points on the sphere).
    values : (u,) ``f`` there.
    """
    c0, R = surface.centre, surface.radius
    # Only ends with f <= 0 can fail; ends lie within 4 R of the centre, so
    # squares neither overflow nor underflow.
    rows = np.flatnonzero(values <= 0)
    if len(rows) == 0:
        return
    d = ends[rows] - c0
    r = np.sqrt(np.einsum("ij,ij->i", d, d))
    bad = rows[np.abs(r - R) <= ON_SPHERE * R]
    if len(bad):
        where = ends[bad[0]]
        raise BoundingSphereError(
            f"f <= 0 at {len(bad)} points where Voronoi edges meet the bounding "
            f"sphere (e.g. {np.round(where, 6).tolist()}): the surface reaches the sphere; "
            "enlarge the radius, flip the sign of f if it is negative outside, or mesh "
            'the part inside with topology="manifold-with-boundary"'
        )


#: Starts of the search for f <= 0 on the bounding sphere: the samples farthest
#: from the centre, projected onto the sphere.
SPHERE_STARTS = 64
SPHERE_ITERATIONS = 20


def check_sphere_near(surface: ImplicitSurface, samples: np.ndarray) -> None:
    """Raise BoundingSphereError if a search finds ``f <= 0`` on the bounding sphere.

    The samples farthest from the centre, where the surface comes closest to
    the sphere, are projected onto it, and Newton steps along the sphere (the
    tangential gradient) drive ``f`` towards zero from there. A point found
    with ``f <= 0`` proves that the surface reaches the sphere; finding none
    proves nothing (a search from samples). Nothing to search where the
    surface proves ``f > 0`` there (``sphere_clear``: a closed mesh, whose
    vertices lie inside the sphere and whose side is "outside" beyond their
    hull).
    """
    if len(samples) == 0 or getattr(surface, "sphere_clear", False):
        return
    c0, R = surface.centre, surface.radius
    d = samples - c0
    r = row_norms(d)
    pick = np.argsort(-r, kind="stable")[:SPHERE_STARTS]
    pick = pick[r[pick] > 0]
    x = c0 + R * d[pick] / r[pick, None]
    for _ in range(SPHERE_ITERATIONS + 1):
        f = surface(x)
        if (f <= 0).any():
            where = x[int(np.argmax(f <= 0))]
            raise BoundingSphereError(
                f"f <= 0 at {np.round(where, 6).tolist()} on the bounding sphere: the "
                "surface reaches the sphere; enlarge the radius, flip the sign of f if it "
                "is negative outside, or mesh the part inside with "
                'topology="manifold-with-boundary"'
            )
        n = (x - c0) / R
        g = surface.grad(x)
        gt = g - np.einsum("ij,ij->i", g, n)[:, None] * n
        gn = row_norms(gt)
        # No tangential slope (f constant along the sphere there): no step.
        moving = gn > 1e-12 * row_norms(g)
        step = np.zeros_like(x)
        step[moving] = -(f[moving] / gn[moving])[:, None] * (gt[moving] / gn[moving, None])
        x, _ = damped_step(x, step, 0.05 * R)
        x = c0 + R * (x - c0) / np.linalg.norm(x - c0, axis=1)[:, None]


def seeds_around(surface: ImplicitSurface, points: np.ndarray, reach: float) -> np.ndarray:
    """Crossings of the surface on segments of length ``reach`` from each of
    ``points`` towards the 26 neighbours of a grid node: more seeds beside a
    component's only point, where the grid found none (a tetrahedron needs
    four)."""
    unit = (-1, 0, 1)
    steps = np.array([(i, j, k) for i in unit for j in unit for k in unit if i or j or k], float)
    steps /= np.linalg.norm(steps, axis=1)[:, None]
    points = np.asarray(points, float).reshape(-1, 3)
    origin = np.repeat(points, len(steps), axis=0)
    direction = np.ascontiguousarray(np.tile(steps, (len(points), 1)))
    _, found = crossings_along_segments(
        surface, origin, direction, np.full(len(origin), reach), AROUND_SAMPLES,
        SHOT_ATOL * surface.radius,
    )  # fmt: skip
    # Not next to the points or to each other (on the surface, a segment's
    # start is a crossing): near-duplicate samples. The points go first.
    gap = AROUND_GAP * reach
    both = np.concatenate([points, found])
    radii = np.r_[np.full(len(points), 2.0 * gap), np.full(len(found), gap)]
    keep = core.select_independent(both, radii)
    return both[np.sort(keep[keep >= len(points)])]


#: Samples along each segment of :func:`seeds_around`, and the smallest gap
#: between its seeds and to the points they surround (times ``reach``).
AROUND_SAMPLES, AROUND_GAP = 8, 1e-3
