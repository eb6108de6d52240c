"""Completeness of the crease search for expressions, by interval arithmetic.

The seeds of :mod:`rdmesh.creases.search` come from a grid: a
crease shorter than a cell, or a small loop, can fall between its crossings.
Here an octree of boxes over the bounding ball settles every place:

- A box holds no crease when ``0`` is not in ``f(box)``, or when, for every
  decision node, ``0`` is not in its switch over the box or the node cannot
  reach ``f`` there (a ``min``/``max`` above it provably takes its other
  branch over the whole box). The bounds are the core's interval enclosures
  (``rdmesh.core.evaluate_intervals``, mean-value form): these boxes are
  *excluded*, proven.
- Boxes that remain at the size of a grid cell are settled per node that may
  switch in them: *traced* when a crease of that node was traced within a box
  of them; otherwise Gauss-Newton from the box centre looks for a crease of
  that node (a new one is traced, and the box rechecked) or a tie with
  parallel gradients there (*smooth*: a smooth join, sampled).
- Boxes still unsettled are split in eight, down to :data:`FLOOR` ``x R``
  (and while a level has at most :data:`MAX_BOXES`); what remains there is
  *unresolved* (reported, with its place).

So every crease point lies in a box that is excluded by proof, holds a traced
crease of the same node (or lies within one box of one), is a sampled smooth
join, or is reported unresolved.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from .. import core
from .._vectors import row_norms
from ..surfaces.interval_program import compile_program
from ..surfaces.intervals import program_of
from ..surfaces.ir import Sum

#: Boxes of the first level per axis.
START = 4
#: Unsettled boxes are split down to this size, times R, then reported.
FLOOR = 1e-4
#: Boxes per level at most: past it the boxes left are reported unresolved
#: (a surface whose bounds settle nothing must not take the machine's memory).
MAX_BOXES = 200_000
#: Outcomes of projecting a point onto a crease (``_Search.classify``): Newton
#: failed (or went too far, or the pieces touch), a crease point, a tie where
#: the pieces' gradients are parallel (a smooth join).
NOTHING, CREASE, SMOOTH = 0, 1, 2


class _Switches:
    """Interval bounds of ``f`` and of every decision node's switch, and
    which nodes may switch in a box."""

    def __init__(self, expr, model) -> None:
        self.f = program_of(expr)
        self.model = model
        self.programs = []
        for node in model.nodes:
            if node.name == "abs":
                tree = node.a
            else:
                tree = Sum([(node.args[0], False), (node.args[1], True)])
            self.programs.append(compile_program(tree))

    def candidates(self, lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
        """``(n, D)`` bool: node ``d`` may switch on the surface in box ``i``
        (a box with no True is proven to hold no crease)."""
        n, d = len(lo), self.model.size
        flo, fhi, _, _, undef = core.evaluate_intervals(*self.f, lo, hi, False, True)
        on = ((flo <= 0) & (fhi >= 0)) | undef.view(bool)
        out = np.zeros((n, d), bool)
        idx = np.flatnonzero(on)
        if not len(idx):
            return out
        blo, bhi = lo[idx], hi[idx]
        zero = np.zeros((len(idx), d), bool)
        neg = np.zeros((len(idx), d), bool)  # the switch may be <= 0
        pos = np.zeros((len(idx), d), bool)  # ... >= 0
        for k, (ops, consts) in enumerate(self.programs):
            slo, shi, _, _, su = core.evaluate_intervals(ops, consts, blo, bhi, False, True)
            su = su.view(bool)
            neg[:, k] = (slo <= 0) | su
            pos[:, k] = (shi >= 0) | su
            zero[:, k] = neg[:, k] & pos[:, k]
        reach = np.ones((len(idx), d), bool)
        kinds = self.model.kinds
        for k, path in enumerate(self.model.above):
            for m, branch in path:
                # min(a, b) takes a where a - b <= 0; max(a, b) where a - b >= 0.
                first = neg[:, m] if kinds[m] == "min" else pos[:, m]
                second = pos[:, m] if kinds[m] == "min" else neg[:, m]
                reach[:, k] &= first if branch == 0 else second
        out[idx] = zero & reach
        return out


def settle(expr, search) -> dict:
    """Settle every box of the bounding ball's cube for the crease search
    ``search`` (an ``search._Search`` on ``expr``'s pieces),
    tracing the creases found on the way; returns the boxes by outcome and
    adds the unresolved ones to ``search.lost``."""
    model, R = search.model, search.R
    switches = _Switches(expr, model)
    leaf, floor = search.spacing, FLOOR * R
    counts = {"excluded": 0, "traced": 0, "smooth": 0, "unresolved": 0}
    # Level by level down to the leaf size: keep the boxes that may hold a crease.
    size = 2.0 * R / START
    g = np.arange(START) * size - R
    lo = search.centre + np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    while True:
        cand = switches.candidates(lo, lo + size)
        keep = cand.any(axis=1)
        counts["excluded"] += int((~keep).sum())
        lo, cand = lo[keep], cand[keep]
        if size <= leaf or not len(lo) or 8 * len(lo) > MAX_BOXES:
            break
        lo, size = _split(lo, size)
    # At the leaf size and below: traced, smooth, or split again.
    while len(lo):
        cand &= ~_traced(search, lo, size, cand)
        settled = ~cand.any(axis=1)
        counts["traced"] += int(settled.sum())
        lo, cand = lo[~settled], cand[~settled]
        if not len(lo):
            break
        smooth = _look(search, lo, size, cand)
        cand &= ~_traced(search, lo, size, cand) & ~smooth
        done = ~cand.any(axis=1)
        counts["smooth"] += int((done & smooth.any(axis=1)).sum())
        counts["traced"] += int((done & ~smooth.any(axis=1)).sum())
        lo = lo[~done]
        if not len(lo):
            break
        if size / 2 < floor or 8 * len(lo) > MAX_BOXES:
            counts["unresolved"] += len(lo)
            search.lost.append(lo + 0.5 * size)
            break
        lo, size = _split(lo, size)
        cand = switches.candidates(lo, lo + size)
        keep = cand.any(axis=1)
        counts["excluded"] += int((~keep).sum())
        lo, cand = lo[keep], cand[keep]
    counts["leaf"] = leaf
    counts["floor"] = floor
    return counts


def _split(lo: np.ndarray, size: float) -> tuple[np.ndarray, float]:
    half = 0.5 * size
    offsets = np.array([[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]) * half
    return (lo[:, None, :] + offsets[None]).reshape(-1, 3), half


def _traced(search, lo: np.ndarray, size: float, cand: np.ndarray) -> np.ndarray:
    """``(n, D)``: a traced crease of node ``d`` passes within one box of box ``i``."""
    out = np.zeros_like(cand)
    if not search.traced:
        return out
    pts, node = _dense(search, 0.25 * size)
    centre = lo + 0.5 * size
    for d in np.unique(node):
        rows = np.flatnonzero(cand[:, d])
        if not len(rows):
            continue
        tree = cKDTree(pts[node == d])
        hits = tree.query_ball_point(centre[rows], 1.5 * size, p=np.inf, return_length=True)
        out[rows, d] = hits > 0
    return out


def _look(search, lo: np.ndarray, size: float, cand: np.ndarray) -> np.ndarray:
    """Gauss-Newton from each box centre onto each candidate node's crease
    (its branches as at the centre, the path to the node forced): new crease
    points become seeds and are traced; returns ``(n, D)``, True where the
    node's tie there is a smooth join inside the box (enlarged by half)."""
    model = search.model
    rows, nodes = np.nonzero(cand)
    centre = lo[rows] + 0.5 * size
    key = model.evaluate(centre).label
    for d in np.unique(nodes):
        mine = nodes == d
        for m, branch in model.above[d]:
            key[mine, m] = branch
    key[np.arange(len(rows)), nodes] = 0
    y, outcome = search.classify(centre, key, nodes)
    inside = np.abs(y - centre).max(axis=1) <= size
    if (outcome == CREASE).any():
        search.run()
    smooth = np.zeros_like(cand)
    smooth[rows, nodes] = (outcome == SMOOTH) & inside
    return smooth


def _dense(search, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points of every traced curve at most ``spacing`` apart, and the
    node whose switch each curve is: ``(points (p, 3), node (p,))``."""
    pts, nodes = [np.zeros((0, 3))], [np.zeros(0, np.int64)]
    for line, closed, c in search.traced:
        ring = np.r_[line, line[:1]] if closed else line
        seg = ring[1:] - ring[:-1]
        per = np.maximum(np.ceil(row_norms(seg) / spacing), 1).astype(np.int64)
        t = (np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per)) / np.repeat(per, per)
        start, step = np.repeat(ring[:-1], per, axis=0), np.repeat(seg, per, axis=0)
        pts.append(np.r_[start + t[:, None] * step, ring[-1:]])
        nodes.append(np.full(len(pts[-1]), search.node[c]))
    return np.concatenate(pts), np.concatenate(nodes)
