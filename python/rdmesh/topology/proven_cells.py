"""The loop and silhouette tests with proof, by interval arithmetic (issue 13, 5).

Both tests cover a region with boxes, drop the boxes that provably do not
matter, and prove a sign condition on the gradient in the rest; boxes that
settle neither way are halved along their longest side, down to a floor side,
and are violations there.

``voronoi_loop`` (T2)
    Voronoi facet ``F_pq`` (in the bisector plane of ``p`` and ``q``): a box
    matters when it meets the plane, lies inside ``V_p`` (not wholly beyond the
    bisector with another neighbour of ``p``) and ``0`` is in the bounds of
    ``f``. It is settled when ``0`` is not in ``grad f(X) . e``, for one
    in-plane direction ``e`` chosen per facet. Then every point of
    ``F ∩ Σ`` has ``df/de > 0`` (or every one ``< 0``), so each line along
    ``e`` meets ``F ∩ Σ`` at most once (two zeros in a row cannot both be
    upward): no closed loop and no second arc through any line, so ``F ∩ Σ``
    is a set of arcs that are graphs across ``e``, each ending on ``∂F``: one
    arc for the two boundary crossings of a restricted edge, none for zero.
    T2 holds, given T1 (the boundary counts).
``silhouette`` (T3)
    Voronoi cell ``V_p`` of a sample ``p`` with normal ``n_p``: a box matters
    when it lies inside ``V_p`` and ``0`` is in the bounds of ``f``; it is
    settled when ``0`` is not in ``grad f(X) . n_p``. Then no point of
    ``W_p = V_p ∩ Σ`` is a silhouette point along ``n_p``; with the disk test
    (the boundary of ``W_p`` is one cycle) the silhouette lemma makes ``W_p``
    a disk, and a closed component inside ``V_p`` is ruled out too (it would
    have a silhouette point along every direction).

Boxes start as the bounding box of each Voronoi facet's polygon, or of each
cell's vertices, cut to the cube around the bounding sphere. A
violation's refinement point is the centre of an unsettled box moved onto the
surface by Newton's method, with the empty ball reaching its nearest sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._newton import damped_step
from .._tol import ON_SURFACE, PROOF_BOX_FLOOR, PROOF_BOX_RELATIVE, TINY
from .._vectors import row_index, row_norms
from ..core import boxes_outside_cells, prove_boxes
from ..surfaces.expressions import Expression
from ..surfaces.intervals import dot_bounds, native_program
from ..surfaces.oracle import ImplicitSurface
from .tests import Violations

#: Boxes kept at one level at most, over all facets or cells (numpy path).
MAX_BOXES = 1 << 21
#: Boxes bounded per facet or cell at most (the core's path); an owner that
#: needs more is a violation.
BUDGET = 1 << 16
#: Newton steps that move an unsettled box's centre onto the surface.
NEWTON_STEPS = 12
#: Newton steps towards the surface for a facet's direction: any direction is
#: valid (a poor one only costs boxes), so a rough surface point will do.
DIRECTION_STEPS = 3


@dataclass
class ProofMemo:
    """Voronoi facets and cells proven clean at an earlier snapshot, kept across rounds.

    A Voronoi facet or cell changes only when a sample is inserted in the star
    of its Delaunay edge or sample (the core's ``delaunay_edges`` of the new
    samples list exactly those edges), so one proven clean and not touched
    since stays proven: it is not tested again (the surface is fixed).
    """

    edge_samples: int = 0  # samples at the last loop proof
    cell_samples: int = 0  # samples at the last silhouette proof
    clean_edges: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    clean_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    _dirty: tuple | None = None

    def touched(self, rdt, since: int, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
        """Keys of the Delaunay edges, and the samples, whose Voronoi facet or
        cell changed since there were ``since`` samples (computed once per pair)."""
        if self._dirty is None or self._dirty[0] != (since, n_samples):
            new = np.arange(since, n_samples, dtype=np.int64)
            edges = rdt.delaunay_edges(new) if len(new) else np.zeros((0, 2), np.int64)
            cells = np.union1d(np.unique(edges), new)
            self._dirty = ((since, n_samples), np.sort(_edge_keys(edges)), cells)
        return self._dirty[1], self._dirty[2]


def _edge_keys(edges: np.ndarray) -> np.ndarray:
    e = edges.astype(np.int64)
    return (e[:, 0] << 32) | e[:, 1]


@dataclass
class CellGeometry:
    """Delaunay edges between samples, their Voronoi facets' bounding boxes,
    and each sample's neighbours as CSR (the half-spaces of its cell)."""

    edges: np.ndarray  # (m, 2) sorted sample pairs
    lo: np.ndarray  # (m, 3) bounding box of each facet polygon, cut to the cube
    hi: np.ndarray
    offsets: np.ndarray  # (n + 1,) CSR of each sample's neighbours
    neighbour: np.ndarray  # (2 m,)

    @classmethod
    def of(cls, rdt, vertices: np.ndarray, centre: np.ndarray, radius: float) -> CellGeometry:
        edges, box = rdt.voronoi_facet_boxes()
        # Circumcentres are rounded: widen a little.
        lo = np.clip(box[:, 0] - 1e-9 * radius, centre - radius, centre + radius)
        hi = np.clip(box[:, 1] + 1e-9 * radius, centre - radius, centre + radius)
        n = len(vertices)
        src = np.concatenate([edges[:, 0], edges[:, 1]])
        dst = np.concatenate([edges[:, 1], edges[:, 0]])
        order = np.argsort(src, kind="stable")
        offsets = np.r_[0, np.cumsum(np.bincount(src, minlength=n))]
        return cls(edges, lo, hi, offsets, dst[order])


def proven_loop_test(
    surface: ImplicitSurface,
    vertices,
    geometry: CellGeometry,
    tree,
    tri=None,
    centres=None,
    memo: ProofMemo | None = None,
    rdt=None,
) -> Violations:
    """T2 loops on every Voronoi facet, with proof (module docstring).

    ``tri`` and ``centres`` (the restricted facets and their surface centres)
    give the facets of complex edges their direction: across the chord
    between the arc's two ends.
    """
    if not isinstance(surface.f, Expression):
        raise TypeError("proven_voronoi_loop needs an expression surface")
    e = geometry.edges
    p, q = vertices[e[:, 0]], vertices[e[:, 1]]
    normal = q - p
    normal /= np.maximum(row_norms(normal), TINY)[:, None]
    mid = 0.5 * (p + q)

    live = np.flatnonzero(np.all(geometry.lo <= geometry.hi, axis=1))
    keys = _edge_keys(e)
    if memo is not None and len(memo.clean_edges):
        dirty, _ = memo.touched(rdt, memo.edge_samples, len(vertices))
        known = np.isin(keys, memo.clean_edges) & ~np.isin(keys, dirty)
        live = live[~known[live]]
    # A facet whose whole box has 0 outside the bounds of f misses the surface:
    # proven clean without a direction (about half of them).
    enc = surface.f.interval(geometry.lo[live], geometry.hi[live])
    live = live[enc.undefined | ((enc.lo <= 0) & (enc.hi >= 0))]
    direction = np.zeros((len(e), 3))
    direction[live] = _in_plane_direction(
        surface, geometry.lo[live], geometry.hi[live], mid[live], normal[live]
    )
    if tri is not None and len(tri):
        rows, chord = _chords(e, tri, centres)
        across = np.cross(normal[rows], chord)
        ok = row_norms(across) > TINY
        direction[rows[ok]] = across[ok] / row_norms(across[ok])[:, None]

    plane = np.column_stack([normal, np.einsum("ij,ij->i", mid, normal)])
    out = _prove(
        "proven_voronoi_loop", surface, vertices, tree, geometry,
        geometry.lo[live], geometry.hi[live], live,
        cell=e[live, 0], direction=direction[live], skip=e[live, 1], plane=plane[live],
    )  # fmt: skip
    if memo is not None:
        bad = np.zeros(len(e), bool)
        bad[out.owners] = True
        memo.clean_edges = np.sort(keys[~bad])
        memo.edge_samples = len(vertices)
    return out


def proven_silhouette_test(
    surface: ImplicitSurface,
    rdt,
    vertices,
    normals,
    geometry: CellGeometry,
    tree,
    cells,
    memo: ProofMemo | None = None,
) -> Violations:
    """The silhouette test on the Voronoi cells of ``cells`` (sample ids), with proof."""
    cells = np.asarray(cells, np.int64)
    done = cells[:0]
    if memo is not None and len(memo.clean_cells):
        _, dirty = memo.touched(rdt, memo.cell_samples, len(vertices))
        known = np.isin(cells, memo.clean_cells) & ~np.isin(cells, dirty)
        done, cells = cells[known], cells[~known]
    # Each cell's bounding box (its vertices are circumcentres, rounded: widen
    # a little), cut to the cube around the bounding sphere.
    box = rdt.voronoi_cell_boxes(cells)
    c, R = surface.centre, surface.radius
    pad = 1e-9 * R
    lo = np.clip(box[:, 0] - pad, c - R, c + R)
    hi = np.clip(box[:, 1] + pad, c - R, c + R)

    out = _prove(
        "proven_silhouette", surface, vertices, tree, geometry, lo, hi, cells,
        cell=cells, direction=normals[cells],
    )  # fmt: skip
    if memo is not None:
        memo.clean_cells = np.union1d(done, np.setdiff1d(cells, out.owners))
        memo.cell_samples = len(vertices)
    return out


def _prove(
    kind, surface, vertices, tree, geometry, lo, hi, owner, cell, direction, skip=None, plane=None
) -> Violations:
    """Subdivide each owner's box until every piece is irrelevant or settled.

    Owner ``i`` (row ``owner[i]`` of the facets, or a sample id) starts from
    box ``lo[i], hi[i]``. A piece is irrelevant when it lies off ``plane[i]``
    (normal and offset; facets only) or wholly outside the Voronoi cell of
    ``cell[i]`` (leaving out neighbour ``skip[i]``), or when ``0`` is not in
    the bounds of ``f``; it is settled when ``grad f . direction[i]`` keeps
    one sign. An owner is a violation when a piece at its floor is neither.
    """
    expr = surface.f
    if not isinstance(expr, Expression):
        raise TypeError(f"{kind} needs an expression surface")
    # Not below a fraction of the first box, nor below the absolute floor.
    floor = np.maximum(
        PROOF_BOX_FLOOR * surface.radius, PROOF_BOX_RELATIVE * (hi - lo).max(axis=1, initial=0.0)
    )
    program = native_program(expr)
    if program is None:
        failed, blo, bhi = _prove_numpy(
            expr, vertices, geometry, lo, hi, cell, direction, skip, plane, floor
        )
    else:
        failed, blo, bhi, boxes = prove_boxes(
            *program, lo, hi, cell, direction, floor, vertices,
            geometry.offsets, geometry.neighbour, skip, plane, BUDGET,
        )  # fmt: skip
        expr.count_boxes(int(boxes.sum()))
        failed = np.flatnonzero(failed)
        blo, bhi = blo[failed], bhi[failed]
    if not len(failed):
        return _Proof(kind, 0, np.zeros((0, 3)), np.zeros(0), owners=np.zeros(0, np.int64))
    start = 0.5 * (blo + bhi)
    x, ok = _onto_surface(surface, start, (bhi - blo).max(axis=1))
    dist, _ = tree.query(x[ok])
    return _Proof(kind, len(failed), x[ok], dist, start[~ok], owners=np.asarray(owner)[failed])


def _prove_numpy(expr, vertices, geometry, lo, hi, cell, direction, skip, plane, floor):
    """What the core's ``prove_boxes`` does, level by level in numpy, for
    expressions the core cannot bound: (failed rows, their first unsettled boxes)."""
    owner = np.arange(len(lo))
    done = np.zeros(len(lo), bool)
    bad_lo, bad_hi, bad_owner = [], [], []
    while len(lo):
        # One unsettled box makes an owner a violation: drop the rest of it.
        keep = ~done[owner]
        if plane is not None:
            a, b = _span(lo, hi, plane[owner, :3])
            c = plane[owner, 3]
            # A margin for rounding: a box must not be dropped if it may touch the plane.
            slack = 1e-12 * (np.abs(a) + np.abs(b) + np.abs(c)) + 1e-300
            keep &= (a <= c + slack) & (b >= c - slack)
        lo, hi, owner = lo[keep], hi[keep], owner[keep]
        keep = ~_outside_cell(
            lo, hi, cell[owner], vertices, geometry, None if skip is None else skip[owner]
        )
        lo, hi, owner = lo[keep], hi[keep], owner[keep]
        if not len(lo):
            break
        enc = expr.interval_gradient(lo, hi, mean_value=True)
        dlo, dhi = dot_bounds(enc.glo, enc.ghi, direction[owner])
        open_ = (enc.lo <= 0) & (enc.hi >= 0)
        open_ &= enc.undefined | ~((dlo > 0) | (dhi < 0))
        lo, hi, owner = lo[open_], hi[open_], owner[open_]
        side = hi - lo
        small = side.max(axis=1) <= floor[owner]
        if small.any() or 2 * len(lo) > MAX_BOXES:
            stop = small if 2 * len(lo) <= MAX_BOXES else np.ones(len(lo), bool)
            bad_lo.append(lo[stop])
            bad_hi.append(hi[stop])
            bad_owner.append(owner[stop])
            done[owner[stop]] = True
            stop |= done[owner]
            lo, hi, owner = lo[~stop], hi[~stop], owner[~stop]
            side = side[~stop]
        # Halve along the longest side.
        axis = np.argmax(side, axis=1)
        rows = np.arange(len(lo))
        cut = lo[rows, axis] + 0.5 * side[rows, axis]
        hi1 = hi.copy()
        hi1[rows, axis] = cut
        lo2 = lo.copy()
        lo2[rows, axis] = cut
        lo, hi = np.concatenate([lo, lo2]), np.concatenate([hi1, hi])
        owner = np.concatenate([owner, owner])
    if not bad_lo:
        return np.zeros(0, np.int64), np.zeros((0, 3)), np.zeros((0, 3))
    blo, bhi, bown = (np.concatenate(x) for x in (bad_lo, bad_hi, bad_owner))
    # One violation per owner: its first unsettled box.
    failed, first = np.unique(bown, return_index=True)
    return failed, blo[first], bhi[first]


@dataclass
class _Proof(Violations):
    """Violations, plus which facets (rows of the edges) or cells (sample ids) failed."""

    owners: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def _chords(edges: np.ndarray, tri: np.ndarray, centres: np.ndarray):
    """For Delaunay edges in exactly two restricted facets: the edge's row in
    ``edges`` and the chord between the two facets' surface centres (the ends
    of the surface's arc in the edge's Voronoi facet)."""
    t = np.sort(tri, axis=1)
    pairs = np.concatenate([t[:, [0, 1]], t[:, [0, 2]], t[:, [1, 2]]])
    owner = np.tile(np.arange(len(t)), 3)
    key = _edge_keys(pairs)
    order = np.argsort(key, kind="stable")
    key, owner = key[order], owner[order]
    # Keys that occur exactly twice: the two restricted facets of a complex edge.
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]])
    count = np.diff(np.r_[start, len(key)])
    two = start[count == 2]
    a, b = centres[owner[two]], centres[owner[two + 1]]
    rows = row_index(pairs[order[two]], edges)
    ok = rows >= 0
    return rows[ok], (b - a)[ok]


def _in_plane_direction(surface, lo, hi, mid, normal) -> np.ndarray:
    """One direction per facet along which ``f`` should be monotone on the
    facet's part of the surface: the in-plane gradient at a surface point
    near the facet (its box centre, put on the plane, then moved onto the
    surface), or any in-plane unit vector where that vanishes."""
    x = 0.5 * (lo + hi)
    x -= np.einsum("ij,ij->i", x - mid, normal)[:, None] * normal
    x, _ = _onto_surface(surface, x, (hi - lo).max(axis=1), DIRECTION_STEPS)
    g = surface.grad(x)
    g -= np.einsum("ij,ij->i", g, normal)[:, None] * normal
    axis = np.where(np.abs(normal[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    fallback = np.cross(normal, axis)
    norm = row_norms(g)
    g = np.where(norm[:, None] > 0, g, fallback)
    return g / np.maximum(row_norms(g), TINY)[:, None]


def _onto_surface(
    surface: ImplicitSurface, x: np.ndarray, cap: np.ndarray, steps: int = NEWTON_STEPS
):
    """Newton from ``x`` onto ``f = 0``, each step at most ``cap``; (points, converged)."""
    R = surface.radius
    for _ in range(steps):
        fx = surface(x)
        g = surface.grad(x)
        gg = np.maximum(np.einsum("ij,ij->i", g, g), TINY)
        x, _ = damped_step(x, -(fx / gg)[:, None] * g, cap)
    gn = row_norms(surface.grad(x))
    ok = (np.abs(surface(x)) <= ON_SURFACE * R * gn) & (gn > 0)
    ok &= row_norms(x - surface.centre) < R
    return x, ok


def _span(lo, hi, w) -> tuple[np.ndarray, np.ndarray]:
    """Least and greatest ``x . w`` over the boxes."""
    a = np.where(w > 0, lo, hi)
    b = np.where(w > 0, hi, lo)
    return np.einsum("ij,ij->i", a, w), np.einsum("ij,ij->i", b, w)


def _outside_cell(lo, hi, p_ids, vertices, geometry: CellGeometry, skip=None) -> np.ndarray:
    """Boxes wholly beyond the bisector of ``p`` and one of its neighbours
    (other than ``skip``): outside the Voronoi cell of ``p`` (in the core, with
    a relative margin so that rounding never drops a box that touches the cell)."""
    owner = np.broadcast_to(np.asarray(p_ids, dtype=np.int64), (len(lo),))
    if skip is not None:
        skip = np.broadcast_to(np.asarray(skip, dtype=np.int64), (len(lo),))
    out = boxes_outside_cells(lo, hi, owner, vertices, geometry.offsets, geometry.neighbour, skip)
    return out.view(bool)
