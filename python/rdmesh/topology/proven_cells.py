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

A cell's boxes start as the bounding box of its vertices, cut to the cube
around the bounding sphere. The cells are proven first (:func:`prove_cells`):
a proven cell's *leaves*, the boxes its gradient bounds settled, hold all of
its part of the surface, since every other box was dropped for lying outside
the cell or holding no zero. A facet lies in the cell of its lower sample, so
its boxes start as that cell's leaves cut to the facet polygon's bounding box
(or as that box alone where the cell is not proven): the way down to the
surface is taken once per cell, not once per facet. A violation's refinement
point is the centre of an unsettled box moved onto the surface by Newton's
method, with the empty ball reaching its nearest sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .._newton import damped_step
from .._tol import ON_SURFACE, PROOF_BOX_FLOOR, PROOF_BOX_RELATIVE, TINY
from .._vectors import row_norms
from ..core import prove_boxes
from ..surfaces.expressions import Expression
from ..surfaces.intervals import program_of
from ..surfaces.oracle import ImplicitSurface
from .tests import Violations

#: Boxes bounded per facet or cell at most; an owner that needs more is a
#: violation.
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
    cells: CellProof | None = None  # the last silhouette proof, with every clean cell's leaves
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
    cell_lo: np.ndarray  # (n, 3) bounding box of each sample's Voronoi cell, cut to the cube
    cell_hi: np.ndarray

    @classmethod
    def of(cls, rdt, vertices: np.ndarray, centre: np.ndarray, radius: float) -> CellGeometry:
        edges, box, cell_box = rdt.voronoi_boxes()
        lo, hi = _cut(box, centre, radius)
        cell_lo, cell_hi = _cut(cell_box, centre, radius)
        n = len(vertices)
        src = np.concatenate([edges[:, 0], edges[:, 1]])
        dst = np.concatenate([edges[:, 1], edges[:, 0]])
        order = np.argsort(src, kind="stable")
        offsets = np.r_[0, np.cumsum(np.bincount(src, minlength=n))]
        return cls(edges, lo, hi, offsets, dst[order], cell_lo, cell_hi)


def _cut(box: np.ndarray, centre: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Boxes ``(k, 2, 3)`` of circumcentres widened a little (they are rounded)
    and cut to the cube around the bounding sphere: ``(lo, hi)``."""
    pad = 1e-9 * radius
    lo = np.clip(box[:, 0] - pad, centre - radius, centre + radius)
    hi = np.clip(box[:, 1] + pad, centre - radius, centre + radius)
    return lo, hi


def proven_loop_test(
    surface: ImplicitSurface,
    vertices,
    geometry: CellGeometry,
    tree,
    tri=None,
    centres=None,
    memo: ProofMemo | None = None,
    rdt=None,
    cells: CellProof | None = None,
) -> Violations:
    """T2 loops on every Voronoi facet, with proof (module docstring).

    ``tri`` and ``centres`` (the restricted facets and their surface centres)
    give the facets of complex edges their direction: across the chord
    between the arc's two ends. With ``cells``, a facet whose cell (that of
    its lower sample) is proven starts from that cell's leaves instead of
    its own box: the way down to the surface is not taken again per facet.
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
        rows, chord = _chords(keys, tri, centres)
        across = np.cross(normal[rows], chord)
        ok = row_norms(across) > TINY
        direction[rows[ok]] = across[ok] / row_norms(across[ok])[:, None]

    plane = np.column_stack([normal, np.einsum("ij,ij->i", mid, normal)])[live]
    lo, hi = geometry.lo[live], geometry.hi[live]
    out = _prove(
        "proven_voronoi_loop", surface, vertices, tree, geometry, lo, hi, live,
        cell=e[live, 0], direction=direction[live], floor=_floor(surface, lo, hi),
        skip=e[live, 1], plane=plane, seeds=cells,
    )  # fmt: skip
    if memo is not None:
        bad = np.zeros(len(e), bool)
        bad[out.owners] = True
        memo.clean_edges = np.sort(keys[~bad])
        memo.edge_samples = len(vertices)
    return out


@dataclass
class CellProof:
    """The silhouette proof of some Voronoi cells, and what it leaves for the
    loop test: where each proven cell's part of the surface can be.

    A cell is ``seeded`` when its proof held: every zero of ``f`` in the cell
    then lies in its leaves (rows ``first[p]:first[p + 1]``), the boxes whose
    gradient bounds settled the test, since every other box of its subdivision
    was dropped for lying outside the cell or holding no zero.
    """

    violations: Violations
    seeded: np.ndarray  # (n_samples,) bool
    first: np.ndarray  # (n_samples + 1,) CSR of the leaves by sample id
    lo: np.ndarray  # (L, 3)
    hi: np.ndarray

    def leaves_of(self, host: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Every (i, leaf row) pair for the leaves of the cells ``host[i]``
        (none where a cell is not seeded), by ``i``."""
        count = np.where(self.seeded[host], np.diff(self.first)[host], 0)
        i = np.repeat(np.arange(len(host)), count)
        k = np.arange(len(i)) - np.repeat(np.cumsum(count) - count, count)
        return i, self.first[host[i]] + k


def prove_cells(
    surface: ImplicitSurface,
    rdt,
    vertices,
    normals,
    geometry: CellGeometry,
    tree,
    cells,
    memo: ProofMemo | None = None,
) -> CellProof:
    """The silhouette test on the Voronoi cells of ``cells`` (sample ids), with
    proof, keeping the proven cells' leaves (:class:`CellProof`)."""
    cells = np.asarray(cells, np.int64)
    done = cells[:0]
    if memo is not None and len(memo.clean_cells):
        _, dirty = memo.touched(rdt, memo.cell_samples, len(vertices))
        known = np.isin(cells, memo.clean_cells) & ~np.isin(cells, dirty)
        done, cells = cells[known], cells[~known]
    lo, hi = geometry.cell_lo[cells], geometry.cell_hi[cells]

    out, leaves = _prove(
        "proven_silhouette", surface, vertices, tree, geometry, lo, hi, cells,
        cell=cells, direction=normals[cells], floor=_floor(surface, lo, hi), leaves=True,
    )  # fmt: skip
    if memo is not None:
        memo.clean_cells = np.union1d(done, np.setdiff1d(cells, out.owners))
        memo.cell_samples = len(vertices)
    # The leaves by sample id; failed cells have none and are not seeded.
    n = len(vertices)
    seeded = np.zeros(n, bool)
    seeded[cells] = True
    seeded[out.owners] = False
    owner, blo, bhi = np.repeat(cells, np.diff(leaves[0])), leaves[1], leaves[2]
    last = None if memo is None else memo.cells
    if last is not None and len(done):
        # Cells known clean have not changed since: their leaves still hold.
        keep = done[done < len(last.seeded)]
        keep = keep[last.seeded[keep]]
        i, rows = last.leaves_of(keep)
        owner = np.concatenate([owner, keep[i]])
        blo, bhi = np.concatenate([blo, last.lo[rows]]), np.concatenate([bhi, last.hi[rows]])
        seeded[keep] = True
    order = np.argsort(owner, kind="stable")
    first = np.r_[0, np.cumsum(np.bincount(owner, minlength=n))]
    proof = CellProof(out, seeded, first, blo[order], bhi[order])
    if memo is not None:
        memo.cells = proof
    return proof


def _floor(surface: ImplicitSurface, lo, hi) -> np.ndarray:
    """Each owner's least box side: not below a fraction of its first box (its
    facet's or cell's), nor below the absolute floor."""
    return np.maximum(
        PROOF_BOX_FLOOR * surface.radius, PROOF_BOX_RELATIVE * (hi - lo).max(axis=1, initial=0.0)
    )


def _prove(
    kind, surface, vertices, tree, geometry, lo, hi, owner, cell, direction, floor,
    skip=None, plane=None, leaves=False, seeds: CellProof | None = None,
):  # fmt: skip
    """Subdivide each owner's box until every piece is irrelevant or settled.

    Owner ``i`` (row ``owner[i]`` of the facets, or a sample id) starts from
    box ``lo[i], hi[i]``, or, where ``seeds`` has proven its cell
    ``cell[i]``, from that cell's leaves cut to the box (they hold every zero
    of ``f`` in the cell). A piece is irrelevant when it lies off
    ``plane[i]`` (normal and offset; facets only) or wholly outside the
    Voronoi cell of ``cell[i]`` (leaving out neighbour ``skip[i]``), or when
    ``0`` is not in the bounds of ``f``; it is settled when
    ``grad f . direction[i]`` keeps one sign. An owner is a violation when a
    piece no longer than ``floor[i]`` is neither.

    Returns the violations, and with ``leaves`` also ``(first, lo, hi)``:
    each owner's settled pieces (none for a violation).
    """
    expr = surface.f
    if not isinstance(expr, Expression):
        raise TypeError(f"{kind} needs an expression surface")
    failed, blo, bhi, kept = _subdivide(
        expr, vertices, geometry, lo, hi, cell, direction, floor, skip, plane, leaves, seeds
    )
    if not len(failed):
        out = _Proof(kind, 0, np.zeros((0, 3)), np.zeros(0), owners=np.zeros(0, np.int64))
    else:
        start = 0.5 * (blo + bhi)
        x, ok = _onto_surface(surface, start, (bhi - blo).max(axis=1))
        dist, _ = tree.query(x[ok])
        out = _Proof(kind, len(failed), x[ok], dist, start[~ok], owners=np.asarray(owner)[failed])
    return (out, tuple(kept)) if leaves else out


def _subdivide(
    expr, vertices, geometry, lo, hi, cell, direction, floor, skip, plane, leaves, seeds
):
    """The core's subdivision (``prove_boxes``) of each owner's box: (failed
    owners, their first unsettled boxes lo and hi, and with ``leaves`` each
    owner's settled boxes as (first, lo, hi), else ())."""
    seed = None if seeds is None else (seeds.seeded, seeds.first, seeds.lo, seeds.hi)
    failed, blo, bhi, boxes, *kept = prove_boxes(
        *program_of(expr), lo, hi, cell, direction, floor, vertices,
        geometry.offsets, geometry.neighbour, skip, plane, BUDGET, leaves, seed,
    )  # fmt: skip
    expr.count_boxes(int(boxes.sum()))
    failed = np.flatnonzero(failed)
    return failed, blo[failed], bhi[failed], tuple(kept)


@dataclass
class _Proof(Violations):
    """Violations, plus which facets (rows of the edges) or cells (sample ids) failed."""

    owners: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def _chords(keys: np.ndarray, tri: np.ndarray, centres: np.ndarray):
    """For Delaunay edges (their :func:`_edge_keys` ``keys``) in exactly two
    restricted facets: the edge's row and the chord between the two facets'
    surface centres (the ends of the surface's arc in the edge's Voronoi facet)."""
    if len(keys) == 0:
        return np.zeros(0, np.int64), np.zeros((0, 3))
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
    # The edges come sorted (CellGeometry); sort them here otherwise.
    sorter = None if np.all(keys[1:] > keys[:-1]) else np.argsort(keys)
    at = np.searchsorted(keys, key[two], sorter=sorter)
    at = np.minimum(at, len(keys) - 1)
    rows = at if sorter is None else sorter[at]
    ok = keys[rows] == key[two]
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
