"""Proven component discovery for expression surfaces (Plantinga-Vegter, Snyder; issue 13).

The cube around the bounding sphere is split into 8 again and again. With the
interval enclosures of ``f`` and of its gradient
(:mod:`rdmesh.surfaces.intervals`), a box is

- *empty* when ``0`` is not in the bounds of ``f`` on it: it holds no point
  of the surface (proven), and is dropped;
- *good* when some partial derivative ``df/dx_k`` excludes ``0`` on it, and
  on each of its two faces normal to ``x_k`` either ``f`` or an in-face
  partial derivative excludes ``0`` (Snyder's box condition);
- otherwise split, down to a floor side; boxes still neither empty nor good
  there are *unresolved*.

Why a good box yields a point on every component that meets it: let the
component ``S`` (a closed surface) meet a good box ``X``. ``S`` cannot lie in
the interior of ``X``: the region ``S`` bounds would be inside ``X``, and
``f``, zero on its boundary and not identically zero, would have an interior
extremum where ``grad f = 0``, but ``df/dx_k != 0`` on ``X``. So ``S`` meets
a face ``Q`` of ``X``. On ``Q``, ``f`` is strictly monotone along an in-face
axis (``x_k`` itself on the four faces parallel to it), so ``S`` meets ``Q``
in curves that are graphs over the other in-face axis; such a curve cannot
close up inside ``Q`` and ends on an edge of ``Q``. Every component inside the
bounding sphere meets some kept box, hence some box edge, and every root on
every box edge is isolated with proof (:mod:`rdmesh.sampling.isolate`) and
then located by root finding. When no box is unresolved and every edge is
settled, the returned points include one on every component: proven, up to
the root finder's tolerance. Boxes that reach the bounding sphere are split
until ``f > 0`` is proven on them, so the surface provably stays inside it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from .._tol import SHOT_ATOL
from .._vectors import row_norms
from ..surfaces.expressions import Expression
from ..surfaces.oracle import ImplicitSurface
from .isolate import isolate_roots
from .roots import refine_brackets

log = logging.getLogger("rdmesh")

#: Boxes kept at one level at most (memory: a few hundred bytes a box).
MAX_BOXES = 1 << 20
#: Boxes are not split below this side, times R (then unresolved).
FLOOR_SIDE = 2.0**-12
#: Roots closer than this (times R) are one point (found on two overlapping edges).
MERGE = 1e-6
#: Edge pieces are not halved below this length, times R.
EDGE_FLOOR = 1e-9

_CORNERS = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)], float)


@dataclass
class Discovery:
    """Result of :func:`discover`.

    Attributes
    ----------
    points : (m, 3) surface points, one per root on the kept boxes' edges.
    proven : bool
        True when every box was resolved and every edge settled: then
        ``points`` has a point on every component of the surface inside the
        bounding sphere (up to the root tolerance).
    unresolved : (u, 3) centres of unresolved boxes and of unsettled edge pieces.
    boxes : number of good boxes (leaves that may hold the surface).
    side : the smallest good box's side.
    evaluations : interval evaluations spent (boxes, faces, edge pieces).
    basis : what the seeding rests on, in words, when another search than the
        interval subdivision made it (volumes: :mod:`rdmesh.sampling.volume_components`).
    """

    points: np.ndarray
    proven: bool
    unresolved: np.ndarray
    boxes: int
    side: float
    evaluations: int
    basis: str | None = None


def discover(surface: ImplicitSurface, expr: Expression, rng: np.random.Generator) -> Discovery:
    """Subdivide until every box is empty or good, then isolate the roots on the good boxes' edges.

    Parameters
    ----------
    surface : ImplicitSurface whose ``f`` is ``expr``.
    expr : Expression
    rng : numpy Generator for a small random shift of the root cube (avoids
        boxes aligned with the surface's symmetries).

    Returns
    -------
    Discovery
    """
    c0, R = surface.centre, surface.radius
    half = R * (1.0 + 0.01 * rng.uniform())
    origin = c0 - half + 0.001 * R * rng.uniform(-1, 1, 3)
    lo, size = origin[None, :], 2.0 * half
    leaves: list[tuple[np.ndarray, float, np.ndarray]] = []
    unresolved = [np.zeros((0, 3))]
    evaluations = 0
    capped = False
    while len(lo):
        enc = expr.interval_gradient(lo, lo + size, mean_value=True)
        evaluations += len(lo)
        near = np.clip(c0, lo, lo + size)
        keep = (enc.lo <= 0) & (enc.hi >= 0) & (row_norms(near - c0) < R)
        lo = lo[keep]
        glo, ghi, undef = enc.glo[keep], enc.ghi[keep], enc.undefined[keep]
        good, more = _good(expr, lo, size, glo, ghi, undef)
        evaluations += more
        # A box reaching the sphere may hold surface that crosses it: split it
        # until f > 0 is proven there (or it is unresolved).
        far = np.maximum(np.abs(lo - c0), np.abs(lo + size - c0))
        good &= row_norms(far) < R
        mono = (((glo > 0) | (ghi < 0)) & ~undef[:, None])[good]
        leaves.append((lo[good], size, mono))
        bad = lo[~good]
        if len(bad) == 0:
            break
        if size * 0.5 < FLOOR_SIDE * R or 8 * len(bad) > MAX_BOXES:
            capped = 8 * len(bad) > MAX_BOXES
            unresolved.append(bad + 0.5 * size)
            break
        size *= 0.5
        lo = (bad[:, None, :] + size * _CORNERS[None]).reshape(-1, 3)
    height = _height_axis(leaves)
    polar = [(lo[_polar(m, height)], size) for lo, size, m in leaves]
    a, b, box_edges = _edges(polar, origin)
    iso = isolate_roots(expr, a, b, EDGE_FLOOR * R)
    evaluations += iso.boxes
    d = b[iso.segment] - a[iso.segment]
    longest = float(row_norms(d).max()) if len(d) else 1.0
    t, ok = refine_brackets(surface, a[iso.segment], d, iso.lo, iso.hi, SHOT_ATOL * R / longest)
    points = a[iso.segment] + t[:, None] * d
    label = _linked(points, iso, box_edges, MERGE * R)
    # One point per class of roots proven to share a component.
    first = np.unique(label[ok], return_index=True)[1]
    points = points[ok][np.sort(first)]
    mid = 0.5 * (iso.pending_lo + iso.pending_hi)
    pend = a[iso.pending_segment] + mid[:, None] * (b - a)[iso.pending_segment]
    unresolved.append(pend)
    unresolved = np.concatenate(unresolved)
    n_leaves = sum(len(x) for x, _, _ in leaves)
    proven = len(unresolved) == 0 and bool(ok.all()) and not capped
    log.info(
        "discovery: %d good boxes (smallest side %.3g), %d unresolved, %d edge roots, "
        "%d interval evaluations; %s",
        n_leaves, size, len(unresolved), len(points), evaluations,
        "every component has a point (proven)" if proven else "not proven",
    )  # fmt: skip
    return Discovery(points, proven, unresolved, n_leaves, size, evaluations)


def _good(expr, lo, size, glo, ghi, undefined) -> tuple[np.ndarray, int]:
    """Snyder's condition on each box (module docstring), and the evaluations spent."""
    mono = ((glo > 0) | (ghi < 0)) & ~undefined[:, None]
    # With two partials excluding 0 on the box, each also does on every face
    # of the box (a face's bounds lie within the box's): the face condition
    # holds without bounding the faces.
    good = mono.sum(axis=1) >= 2
    spent = 0
    for k in range(3):
        rows = np.flatnonzero(mono[:, k] & ~good)
        if len(rows) == 0:
            continue
        ok = np.ones(len(rows), bool)
        for side in (0.0, size):
            flo = lo[rows].copy()
            flo[:, k] += side
            fhi = lo[rows] + size
            fhi[:, k] = flo[:, k]
            e = expr.interval_gradient(flo, fhi, mean_value=True)
            spent += len(rows)
            empty = (e.lo > 0) | (e.hi < 0)
            inplane = [i for i in range(3) if i != k]
            flat = ((e.glo[:, inplane] > 0) | (e.ghi[:, inplane] < 0)).any(axis=1) & ~e.undefined
            ok &= empty | flat
        good[rows[ok]] = True
    return good, spent


def _height_axis(leaves) -> int:
    """The axis whose :func:`_polar` boxes are fewest."""
    counts = [sum(int(_polar(m, h).sum()) for _, _, m in leaves) for h in range(3)]
    return int(np.argmin(counts))


def _polar(mono: np.ndarray, height: int) -> np.ndarray:
    """Boxes where neither partial derivative across ``height`` is proven nonzero:
    the only boxes that can hold a point where the surface's normal is along ``height``."""
    return ~np.delete(mono, height, axis=1).any(axis=1)


def _edges(boxes, origin) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distinct edges of ``boxes`` (pairs of corners and sides), as start
    and end points, and each box's 12 edge indices (in :data:`_FACE_EDGES` order)."""
    boxes = [(lo, size) for lo, size in boxes if len(lo)]
    if not boxes:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros((0, 12), np.int64)
    unit = min(size for _, size in boxes)
    keys = []
    for lo, size in boxes:
        box = []
        m = int(round(size / unit))
        base = np.rint((lo - origin) / unit).astype(np.int64)
        for k in range(3):
            others = [i for i in range(3) if i != k]
            for u in (0, 1):
                for v in (0, 1):
                    off = np.zeros(3, np.int64)
                    off[others[0]], off[others[1]] = u * m, v * m
                    st = base + off
                    box.append(np.column_stack([st, np.full(len(st), k), np.full(len(st), m)]))
        keys.append(np.stack(box, axis=1))  # (n, 12, 5)
    key, inverse = np.unique(np.concatenate(keys).reshape(-1, 5), axis=0, return_inverse=True)
    a = origin + key[:, :3] * unit
    step = np.zeros((len(key), 3))
    step[np.arange(len(key)), key[:, 3]] = key[:, 4] * unit
    return a, a + step, inverse.reshape(-1, 12)


def _face_edges() -> np.ndarray:
    """(6, 4): the box edges (index ``4 k + 2 u + v``, as :func:`_edges` lists
    them) on each face (normal ``n``, side ``s``: index ``2 n + s``)."""
    out = []
    for n in range(3):
        for side in (0, 1):
            face = []
            for k in range(3):
                if k == n:
                    continue
                others = [i for i in range(3) if i != k]
                for w in (0, 1):
                    u, v = (side, w) if others[0] == n else (w, side)
                    face.append(4 * k + 2 * u + v)
            out.append(face)
    return np.array(out)


_FACE_EDGES = _face_edges()


def _linked(points, iso, box_edges, merge: float) -> np.ndarray:
    """Labels of the roots (``iso``'s brackets): equal labels are proven to lie
    on one component.

    On a face of a good box ``f`` is monotone along an in-face axis, so the
    surface meets it in curves that are graphs, each ending at two roots on
    the face's edges: a face with exactly two roots holds one curve, and its
    two roots are linked. Roots closer than ``merge`` (one root found on
    overlapping edges of boxes of two sizes) are linked too.
    """
    m = len(points)
    if m == 0:
        return np.zeros(0, np.int64)
    n_edges = len(iso.count)
    start = np.searchsorted(iso.segment, np.arange(n_edges))
    count = np.bincount(iso.segment, minlength=n_edges)
    faces = box_edges[:, _FACE_EDGES].reshape(-1, 4)  # (6 n, 4) edge ids
    total = count[faces].sum(axis=1)
    two = faces[total == 2]
    c, st = count[two], start[two]
    # Each face's root indices: up to two per edge, in edge order.
    cand = np.stack([st, st + 1], axis=2)  # (f, 4, 2)
    valid = np.stack([c > 0, c > 1], axis=2)
    pairs = cand[valid].reshape(-1, 2)
    near = cKDTree(points).query_pairs(merge, output_type="ndarray")
    links = np.concatenate([pairs, near.reshape(-1, 2)])
    g = coo_matrix((np.ones(len(links), np.int8), (links[:, 0], links[:, 1])), shape=(m, m))
    return connected_components(g, directed=False)[1]
