"""Proven root isolation along segments by interval bisection (Snyder; algorithm.md 4.3, 5.3).

For an expression surface, ``g(t) = f(a + t (b - a))`` on ``t in [0, 1]`` is
bounded on a piece ``[t0, t1]`` by the interval enclosure of ``f`` over the
box around that piece of the segment, and ``g'`` by the gradient enclosure
dotted with ``b - a``. A piece is settled when

- ``0`` is not in the bounds of ``g``: no root on it (proven); or
- ``0`` is not in the bounds of ``g'`` (``g`` strictly monotone) and the
  enclosures of ``g`` at both ends exclude ``0``: one root if their signs
  differ, none otherwise (proven), and that root is transversal.

Other pieces are halved, down to a floor length; a piece still unsettled there
(a near-tangency, a singular point, a root at an end) is *unresolved*: the
count of its segment is not proven. All segments and pieces of one level go
through one vectorised interval evaluation; with the core's evaluator the
whole bisection runs in the core (``core.isolate_segment_roots``), segment
by segment over the cores, with the same pieces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import isolate_segment_roots
from ..surfaces.expressions import Expression
from ..surfaces.intervals import dot_bounds, native_program

#: Pieces kept at one level at most (bounds the memory of a call; numpy path).
MAX_PIECES = 1 << 21
#: Pieces bounded per segment at most (the core's path); a segment that needs
#: more keeps its unsettled pieces pending.
BUDGET = 1 << 16


@dataclass
class Isolation:
    """Result of :func:`isolate_roots` on ``n`` segments.

    Attributes
    ----------
    segment, lo, hi : (m,) arrays
        Brackets ``[lo, hi]`` in ``t`` of segment ``segment``, each holding
        exactly one root, transversal, with opposite proven signs at its ends
        (sorted by segment, then ``t``).
    count : (n,) int
        The proven number of roots of each segment (meaningful where
        ``resolved``).
    resolved : (n,) bool
        False where some piece of the segment stayed unsettled.
    pending_segment, pending_lo, pending_hi : (u,) arrays
        The unsettled pieces.
    boxes : int
        Interval evaluations spent (boxes and end points).
    """

    segment: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    count: np.ndarray
    resolved: np.ndarray
    pending_segment: np.ndarray
    pending_lo: np.ndarray
    pending_hi: np.ndarray
    boxes: int


def isolate_roots(
    expr: Expression,
    a: np.ndarray,
    b: np.ndarray,
    min_length: float,
    pieces: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None,
) -> Isolation:
    """Isolate every root of ``f`` on the segments ``[a[i], b[i]]``, with proof.

    Parameters
    ----------
    expr : Expression
        The surface's function.
    a, b : (n, 3) segment ends.
    min_length : float
        Pieces shorter than this are not halved again: if unsettled, they are
        reported as pending and their segment as unresolved.
    pieces : (segment, t0, t1), optional
        Search only these pieces ``[t0, t1]`` of the segments (at most one
        per segment and place: they must not overlap); the caller has proven
        that the rest holds no root. Default: every segment whole.

    Returns
    -------
    Isolation
        Brackets, counts and pending pieces of the ``n`` segments.
    """
    a = np.asarray(a, np.float64).reshape(-1, 3)
    b = np.asarray(b, np.float64).reshape(-1, 3)
    n = len(a)
    if pieces is None:
        seg, t0, t1 = np.arange(n), None, None
        pa, pb = a, b
    else:
        seg, t0, t1 = (np.asarray(x) for x in pieces)
        pa, pb = a[seg], b[seg]
    program = native_program(expr)
    if program is None:
        if t0 is None:
            t0, t1 = np.zeros(n), np.ones(n)
        fs, flo, fhi, ps, plo, phi, boxes = _isolate_numpy(expr, pa, pb, t0, t1, min_length)
    else:
        fs, flo, fhi, ps, plo, phi, boxes = isolate_segment_roots(
            *program, pa, pb, min_length, BUDGET, t0, t1
        )
        expr.count_boxes(boxes)
    return _isolation(n, seg[fs], flo, fhi, seg[ps], plo, phi, boxes)


def _isolate_numpy(expr: Expression, a, b, t0, t1, min_length: float):
    """What the core's ``isolate_segment_roots`` does, level by level in numpy,
    for expressions the core cannot bound (and to check the core against)."""
    n = len(a)
    d = b - a
    length = np.sqrt(np.einsum("ij,ij->i", d, d))
    seg = np.arange(n)
    t0, t1 = np.array(t0, np.float64), np.array(t1, np.float64)
    found: list[tuple[np.ndarray, ...]] = []
    pending: list[tuple[np.ndarray, ...]] = []
    boxes = 0
    while len(seg):
        p0 = a[seg] + t0[:, None] * d[seg]
        p1 = a[seg] + t1[:, None] * d[seg]
        enc = expr.interval_gradient(np.minimum(p0, p1), np.maximum(p0, p1), mean_value=True)
        boxes += len(seg)
        has0 = (enc.lo <= 0) & (enc.hi >= 0)
        dlo, dhi = dot_bounds(enc.glo, enc.ghi, d[seg])
        mono = has0 & ~enc.undefined & ((dlo > 0) | (dhi < 0))
        # The ends of monotone pieces: their signs decide.
        ends = np.concatenate([p0[mono], p1[mono]])
        e = expr.interval(ends, ends)
        boxes += len(ends)
        k = int(mono.sum())
        s0 = _sign(e.lo[:k], e.hi[:k], e.undefined[:k])
        s1 = _sign(e.lo[k:], e.hi[k:], e.undefined[k:])
        settled = (s0 != 0) & (s1 != 0)
        idx = np.flatnonzero(mono)
        root = idx[settled & (s0 != s1)]
        found.append((seg[root], t0[root], t1[root]))
        open_ = has0.copy()
        open_[idx[settled]] = False
        # Halve the rest, unless too short (or too many).
        short = (t1 - t0) * length[seg] <= min_length
        stop = open_ & short
        pending.append((seg[stop], t0[stop], t1[stop]))
        go = np.flatnonzero(open_ & ~short)
        if 2 * len(go) > MAX_PIECES:
            pending.append((seg[go], t0[go], t1[go]))
            break
        mid = 0.5 * (t0[go] + t1[go])
        seg = np.repeat(seg[go], 2)
        t0 = np.column_stack([t0[go], mid]).ravel()
        t1 = np.column_stack([mid, t1[go]]).ravel()
    fs, flo, fhi = (np.concatenate(c) for c in zip(*found, strict=True)) if found else _none(3)
    ps, plo, phi = (np.concatenate(c) for c in zip(*pending, strict=True)) if pending else _none(3)
    return fs, flo, fhi, ps, plo, phi, boxes


def _isolation(n, fs, flo, fhi, ps, plo, phi, boxes) -> Isolation:
    """The result, brackets and pending pieces sorted by segment, then ``t``."""
    order = np.lexsort((flo, fs))
    count = np.bincount(fs, minlength=n)
    resolved = np.ones(n, bool)
    resolved[ps] = False
    wait = np.lexsort((plo, ps))
    return Isolation(
        fs[order], flo[order], fhi[order], count, resolved, ps[wait], plo[wait], phi[wait], boxes
    )


def _sign(lo: np.ndarray, hi: np.ndarray, undefined: np.ndarray) -> np.ndarray:
    """+1 / -1 where the enclosure proves the sign, 0 where it does not."""
    s = np.where(lo > 0, 1, np.where(hi < 0, -1, 0))
    return np.where(undefined, 0, s)


def _none(k: int) -> tuple[np.ndarray, ...]:
    return (np.zeros(0, np.int64),) + tuple(np.zeros(0) for _ in range(k - 1))
