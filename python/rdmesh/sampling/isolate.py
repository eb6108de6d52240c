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
count of its segment is not proven. The whole bisection runs in the core
(``core.isolate_segment_roots``), segment by segment over the cores.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..core import isolate_segment_roots
from ..surfaces.expressions import Expression
from ..surfaces.intervals import program_of

#: Pieces bounded per segment at most; a segment that needs more keeps its
#: unsettled pieces pending.
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
    fs, flo, fhi, ps, plo, phi, boxes = isolate_segment_roots(
        *program_of(expr), pa, pb, min_length, BUDGET, t0, t1
    )
    expr.count_boxes(boxes)
    return _isolation(n, seg[fs], flo, fhi, seg[ps], plo, phi, boxes)


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
