"""Every crossing of the surface along many line segments at once.

Each segment is sampled (one call of ``f`` for all samples), every sign change
between neighbouring samples becomes a bracket, and all brackets are refined in
one vectorised call of :func:`scipy.optimize.elementwise.find_root`
(Chandrupatla's method). Inside means ``f < 0``; ``f == 0`` counts as outside.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np
from scipy.optimize import elementwise

from .. import core
from .._tol import DIP_FRACTION, GRADIENT_STEP
from ..surfaces.oracle import ImplicitSurface

log = logging.getLogger("rdmesh")


@dataclass
class Crossings:
    """Crossings found on a set of segments, in segment order then position.

    Attributes
    ----------
    segment : (m,) int64
        Index of the segment each crossing lies on.
    s : (m,) float64
        Distance of the crossing from the segment's start.
    point : (m, 3) float64
        The crossing.
    rising : (m,) bool
        True where ``f`` goes from inside to outside in the segment's direction.
    """

    segment: np.ndarray
    s: np.ndarray
    point: np.ndarray
    rising: np.ndarray
    #: Segments with a bracket whose root search did not converge: a sign
    #: change lies there, but no crossing of it is reported.
    failed: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    #: (m,) ``f``'s slope along the segment across the search's last bracket
    #: (the derivative somewhere in it), NaN where that bracket is wider than
    #: a central difference's span; None where not known.
    derivative: np.ndarray | None = None

    def count(self, n_segments: int) -> np.ndarray:
        """Number of crossings on each of ``n_segments`` segments."""
        return np.bincount(self.segment, minlength=n_segments)


@dataclass
class SegmentSamples:
    """Sample positions along k segments, flat.

    Segment ``i``'s distances from its start are ``s[offsets[i]:offsets[i + 1]]``:
    increasing, the first 0 and the last its length.
    """

    offsets: np.ndarray  # (k + 1,) int64
    s: np.ndarray  # (P,) float64

    @classmethod
    def uniform(cls, lengths: np.ndarray, n_intervals: np.ndarray) -> SegmentSamples:
        """``n_intervals`` (at least 1) equal intervals on each segment."""
        lengths = np.asarray(lengths, dtype=float)
        n = np.maximum(np.broadcast_to(n_intervals, lengths.shape).astype(np.int64), 1)
        offsets = np.zeros(len(lengths) + 1, np.int64)
        np.cumsum(n + 1, out=offsets[1:])
        seg = np.repeat(np.arange(len(lengths)), n + 1)
        j = np.arange(offsets[-1]) - offsets[seg]
        # j / n is exactly 1 at the last sample, so it lands on the length.
        return cls(offsets, lengths[seg] * (j / n[seg]))

    def segment_of(self) -> np.ndarray:
        """(P,) the segment of every sample."""
        return np.repeat(np.arange(len(self.offsets) - 1), np.diff(self.offsets))


def line_crossings(
    surface: ImplicitSurface,
    origin: np.ndarray,
    direction: np.ndarray,
    samples: SegmentSamples,
    xatol: float,
    values: np.ndarray | None = None,
    ends: np.ndarray | None = None,
) -> Crossings:
    """Find every sign change of ``f`` along segments ``origin + s * direction``.

    Besides the sign changes between samples, places where ``|f|`` dips
    towards zero without changing sign are searched for a hidden pair of
    crossings: a sample that is a deep local minimum of ``|f|`` (searched with
    :func:`scipy.optimize.elementwise.find_minimum`), and an interval, the
    first and last of a segment included, whose two ends are both much
    closer to zero than their outer neighbours (its midpoint is evaluated,
    then searched the same way). Sampled: a pair of crossings that leaves no
    such trace is missed. The scan over the samples runs in the core
    (:func:`rdmesh.core.scan_samples`).

    Parameters
    ----------
    surface : ImplicitSurface
    origin : (k, 3) segment starts.
    direction : (k, 3) unit directions.
    samples : SegmentSamples
        Where to sample each segment (at least its two ends).
    xatol : absolute tolerance on each crossing's position.
    values : (P,) float, optional
        ``f`` at every sample, when already known; otherwise one call of ``f``.
        With ``ends``, ``f`` at the interior samples only (all but each
        segment's two ends, in order).
    ends : (k, 2) float, optional
        ``f`` at each segment's start and end.

    Returns
    -------
    Crossings
    """
    if samples.s.size == 0:
        return _empty()
    if values is None:
        seg_of = samples.segment_of()
        values = surface(origin[seg_of] + samples.s[:, None] * direction[seg_of])
        ends = None
    (seg, lo, hi, rising, f_lo, f_hi), dips, valleys = core.scan_samples(
        samples.offsets, samples.s, values, ends, DIP_FRACTION
    )
    rising = rising.view(bool)
    pairs, triples = _valleys(surface, origin, direction, *valleys)
    # One minimum search for the dips and the valleys together.
    triples = [np.concatenate(p) for p in zip(dips, triples, strict=True)]
    for found in (_split_dips(surface, origin, direction, *triples), pairs):
        if found[0].size:
            parts = zip((seg, lo, hi, rising), found, strict=True)
            seg, lo, hi, rising = (np.concatenate(p) for p in parts)
            # f at the new brackets' ends is not kept: the search evaluates it.
            f_lo, f_hi = (np.r_[v, np.full(len(found[0]), np.nan)] for v in (f_lo, f_hi))
    if seg.size == 0:
        return _empty()
    # f at a segment's far end was taken at that end, which the search's
    # start + s u misses by a rounding: evaluated again there, so that the
    # search sees one function.
    last = samples.s[samples.offsets[1:] - 1]
    f_hi = np.where(hi == last[seg], np.nan, f_hi)
    found = search_brackets(surface, origin[seg], direction[seg], lo, hi, xatol, (f_lo, f_hi))
    ok = found.converged
    failed = np.unique(seg[~ok])
    seg, root, rising, slope = seg[ok], found.root[ok], rising[ok], found.derivative[ok]
    order = np.lexsort((root, seg))
    seg, root, rising, slope = seg[order], root[order], rising[order], slope[order]
    point = origin[seg] + root[:, None] * direction[seg]
    return Crossings(seg, root, point, rising, failed, slope)


def crossings_along_segments(
    surface: ImplicitSurface,
    origin: np.ndarray,
    direction: np.ndarray,
    length: np.ndarray,
    samples: int,
    xatol: float,
    each_crosses: bool = False,
) -> tuple[np.ndarray, np.ndarray]:
    """The crossings of the segments ``origin + s direction``, ``0 <= s <=
    length``: their segments and points, in segment order then along each.

    A mesh input gives them exactly (``exact_crossings``: every face a
    segment meets); the segments it is unsure of, and those of other
    surfaces, get :func:`line_crossings` with ``samples`` samples each. With
    ``each_crosses`` (every segment is known to cross), a segment without a
    hit is one the hits got wrong, and is searched too.
    """
    exact = getattr(surface, "exact_crossings", None)
    todo = np.arange(len(origin))
    segments, points = [np.zeros(0, np.int64)], [np.zeros((0, 3))]
    if exact is not None and len(origin):
        seg, _, point, _, _, unsure = exact(
            np.stack([origin, origin + length[:, None] * direction], axis=1)
        )
        if each_crosses:
            unsure |= np.bincount(seg, minlength=len(origin)) == 0
        segments.append(seg[~unsure[seg]])
        points.append(point[~unsure[seg]])
        todo = np.flatnonzero(unsure)
    if len(todo):
        cr = line_crossings(
            surface, origin[todo], direction[todo],
            SegmentSamples.uniform(length[todo], samples), xatol=xatol,
        )  # fmt: skip
        segments.append(todo[cr.segment])
        points.append(cr.point)
    segment, point = np.concatenate(segments), np.concatenate(points)
    order = np.argsort(segment, kind="stable")
    return segment[order], point[order]


def _line_function(surface):
    def g(s, ox, oy, oz, dx, dy, dz):
        x = np.stack([ox + s * dx, oy + s * dy, oz + s * dz], axis=-1)
        return surface(x.reshape(-1, 3)).reshape(s.shape)

    return g


def _known_first(g, known):
    """``g`` that answers its first calls from ``known``, a list of ``(s,
    f(s))`` (NaN where f is unknown), while they ask for exactly those ``s``
    in that order. scipy's searches start by evaluating the bracket's ends,
    one call each, and f is known there from the samples; should a search
    ask otherwise, every call evaluates."""
    pending = list(known)

    def h(s, *args):
        if pending:
            x, fx = pending.pop(0)
            if s.shape == x.shape and np.array_equal(s, x):
                out = np.array(fx, dtype=float)
                miss = np.isnan(out)
                if miss.any():
                    out[miss] = g(s[miss], *(a[miss] for a in args))
                return out
            pending.clear()
        return g(s, *args)

    return h


def _coords(o: np.ndarray, d: np.ndarray) -> tuple:
    return (o[:, 0], o[:, 1], o[:, 2], d[:, 0], d[:, 1], d[:, 2])


class BracketSearch(NamedTuple):
    """Roots found in brackets: each root ``s``, whether its search converged,
    and ``f``'s slope across its last bracket (see :attr:`Crossings.derivative`)."""

    root: np.ndarray
    converged: np.ndarray
    derivative: np.ndarray


def refine_brackets(surface, o, d, lo, hi, xatol, known=None):
    """Roots of ``f(o + s d)`` in the brackets ``[lo, hi]``: (s, converged).
    ``known``: f at ``lo`` and at ``hi`` where known (NaN elsewhere), which
    the search then takes instead of evaluating it."""
    found = search_brackets(surface, o, d, lo, hi, xatol, known)
    return found.root, found.converged


def search_brackets(surface, o, d, lo, hi, xatol, known=None) -> BracketSearch:
    """:func:`refine_brackets`, with the slope of ``f`` across each search's
    last bracket: by the mean value theorem the derivative along ``d`` at a
    point of that bracket, which holds the root; it costs no evaluation
    (NaN where the bracket is wider than ``2 GRADIENT_STEP R``, the span of
    a central difference)."""
    g = _line_function(surface)
    if known is not None:
        g = _known_first(g, [(lo, known[0]), (hi, known[1])])
    res = elementwise.find_root(
        g,
        (lo, hi),
        args=_coords(o, d),
        tolerances={"xatol": xatol, "xrtol": 0.0},
    )
    ok = res.status == 0
    if not ok.all():
        log.warning(
            "root finding: %d of %d brackets did not converge (status %s); their "
            "crossings are not used",
            int((~ok).sum()),
            len(ok),
            sorted(set(res.status[~ok].tolist())),
        )
    (a, b), (fa, fb) = res.bracket, res.f_bracket
    width = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        slope = (fb - fa) / width
    narrow = (width > 0) & (width <= 2.0 * GRADIENT_STEP * surface.radius) & np.isfinite(slope)
    return BracketSearch(res.x, ok, np.where(narrow, slope, np.nan))


def _valleys(surface, origin, direction, seg, lo, hi, inside, a_lo, a_hi):
    """Crossing pairs hidden inside the scan's valley intervals.

    The midpoint of each is evaluated (one call of ``f``). Returns ``(pairs,
    triples)``: brackets ``(seg, lo, hi, rising)`` where the midpoint changes
    sign, and ``(seg, left, middle, right, sign)`` triples for
    :func:`_split_dips` where ``|f|`` is smaller at the midpoint than at both
    ends.
    """
    no_triples = (np.zeros(0, np.int64), *([np.zeros(0)] * 4))
    no_pairs = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0, bool))
    if seg.size == 0:
        return no_pairs, no_triples
    inside = inside.view(bool)
    mid = 0.5 * (lo + hi)
    fm = surface(origin[seg] + mid[:, None] * direction[seg])
    c = (fm < 0.0) != inside
    lower = ~c & (np.abs(fm) < np.minimum(a_lo, a_hi))
    if c.any():
        log.debug("valleys: %d hidden crossing pairs found at midpoints", int(c.sum()))
    pairs = (
        np.concatenate([seg[c], seg[c]]),
        np.concatenate([lo[c], mid[c]]),
        np.concatenate([mid[c], hi[c]]),
        np.concatenate([inside[c], ~inside[c]]),
    )
    sgn = np.where(inside, -1.0, 1.0)
    return pairs, (seg[lower], lo[lower], mid[lower], hi[lower], sgn[lower])


def _split_dips(surface, origin, direction, seg, x1, x2, x3, sgn):
    """Brackets of crossing pairs hidden in dips: (seg, lo, hi, rising)."""
    empty = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0), np.zeros(0, bool))
    if seg.size == 0:
        return empty
    g = _line_function(surface)

    def h(s, sg, *coords):
        return sg * g(s, *coords)

    res = elementwise.find_minimum(
        h, (x1, x2, x3), args=(sgn,) + _coords(origin[seg], direction[seg])
    )
    hit = res.f_x < 0
    if not hit.any():
        return empty
    seg, x1, xm, x3, sgn = seg[hit], x1[hit], res.x[hit], x3[hit], sgn[hit]
    log.debug("dips: %d hidden crossing pairs found", int(hit.sum()))
    # Outside (sgn > 0) dipping inside: in, then out again.
    return (
        np.concatenate([seg, seg]),
        np.concatenate([x1, xm]),
        np.concatenate([xm, x3]),
        np.concatenate([sgn < 0, sgn > 0]),
    )


def _empty() -> Crossings:
    return Crossings(
        np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool),
        derivative=np.zeros(0),
    )  # fmt: skip
