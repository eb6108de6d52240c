"""Every crossing of the surface along many line segments at once.

Each segment is sampled (one call of ``f`` for all samples), every sign change
between neighbouring samples becomes a bracket, and all brackets are refined in
one vectorised call of :func:`scipy.optimize.elementwise.find_root`
(Chandrupatla's method). Inside means ``f < 0``; ``f == 0`` counts as outside.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
from scipy.optimize import elementwise

from .oracles import ImplicitSurface

log = logging.getLogger("rdmesh")

#: Sample-count buckets per segment; segments are grouped so arrays stay rectangular.
_BUCKETS = (3, 4, 6, 8, 12, 16, 24, 32, 48, 64)


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

    def count(self, n_segments: int) -> np.ndarray:
        """Number of crossings on each of ``n_segments`` segments."""
        return np.bincount(self.segment, minlength=n_segments)


def bucket_samples(
    lengths: np.ndarray, n_intervals: np.ndarray, warp=None
) -> tuple[np.ndarray, list[tuple[slice, np.ndarray]]]:
    """Group segments by sample count and build their sample positions.

    Parameters
    ----------
    lengths : (k,) segment lengths.
    n_intervals : (k,) wanted number of intervals; rounded up to a bucket size.
    warp : callable, optional
        ``warp(rows, u)`` maps uniform fractions ``u`` of shape ``(len(rows), n+1)``
        to distances along the segments ``rows`` (indices into the inputs).
        Default: uniform spacing.

    Returns
    -------
    order : (k,) int
        Segment order that makes every bucket contiguous; the slices below
        index segments permuted by ``order``.
    buckets : list of (slice, S)
        ``S`` is ``(len, n+1)`` distances from each segment's start, with
        ``S[:, 0] = 0`` and ``S[:, -1] = length``.
    """
    want = np.clip(n_intervals, _BUCKETS[0], _BUCKETS[-1])
    which = np.searchsorted(np.asarray(_BUCKETS), want)
    order = np.argsort(which, kind="stable")
    counts = np.bincount(which, minlength=len(_BUCKETS))
    out, start = [], 0
    for n, c in zip(_BUCKETS, counts, strict=False):
        if c == 0:
            continue
        rows = order[start : start + c]
        u = np.linspace(0.0, 1.0, n + 1)[None, :]
        if warp is None:
            S = u * lengths[rows, None]
        else:
            S = warp(rows, u)
            S[:, 0] = 0.0
            S[:, -1] = lengths[rows]
        out.append((slice(start, start + c), S))
        start += c
    return order, out


def line_crossings(
    surface: ImplicitSurface,
    origin: np.ndarray,
    direction: np.ndarray,
    samples: list[tuple[np.ndarray, np.ndarray]],
    xatol: float,
    end_values: np.ndarray | None = None,
) -> Crossings:
    """Find every sign change of ``f`` along segments ``origin + s * direction``.

    Besides the sign changes between samples, a sample where ``|f|`` dips
    towards zero without changing sign is searched for a hidden pair of
    crossings with :func:`scipy.optimize.elementwise.find_minimum`.

    Parameters
    ----------
    surface : ImplicitSurface
    origin : (k, 3) segment starts.
    direction : (k, 3) unit directions.
    samples : list of (rows, S)
        ``rows`` a slice of the segments, ``S`` their sample distances (see
        :func:`bucket_samples`; the segments must be in its ``order``).
    xatol : absolute tolerance on each crossing's position.
    end_values : (k, 2) float, optional
        ``f`` at both ends of every segment, when already known.

    Returns
    -------
    Crossings
    """
    if not samples:
        return _empty()
    values = _sample_values(surface, origin, direction, samples, end_values)
    seg, lo, hi, rising, dips = [], [], [], [], []
    for (rows, S), F in zip(samples, values, strict=False):
        inside = F < 0.0
        r, j = np.nonzero(inside[:, :-1] != inside[:, 1:])
        seg.append(rows.start + r)
        lo.append(S[r, j])
        hi.append(S[r, j + 1])
        rising.append(inside[r, j])
        dips.append(_dips(rows, S, F, inside))
    extra = _split_dips(surface, origin, direction, *map(np.concatenate, zip(*dips, strict=False)))
    for part, add in zip((seg, lo, hi, rising), extra, strict=False):
        part.append(add)
    seg = np.concatenate(seg)
    if seg.size == 0:
        return _empty()
    lo, hi, rising = np.concatenate(lo), np.concatenate(hi), np.concatenate(rising)
    s = _roots(surface, origin[seg], direction[seg], lo, hi, xatol)
    order = np.lexsort((s, seg))
    seg, s, rising = seg[order], s[order], rising[order]
    return Crossings(seg, s, origin[seg] + s[:, None] * direction[seg], rising)


def _sample_values(surface, origin, direction, samples, end_values):
    """``f`` at every sample position, in one call; ``(m, n+1)`` per bucket."""
    inner = slice(None) if end_values is None else slice(1, -1)
    pts = [
        origin[rows, None, :] + S[:, inner, None] * direction[rows, None, :] for rows, S in samples
    ]
    flat = surface(np.concatenate([p.reshape(-1, 3) for p in pts]))
    out, start = [], 0
    for (rows, S), p in zip(samples, pts, strict=False):
        F = np.empty(S.shape)
        F[:, inner] = flat[start : start + p.shape[0] * p.shape[1]].reshape(p.shape[:2])
        start += p.shape[0] * p.shape[1]
        if end_values is not None:
            F[:, 0] = end_values[rows, 0]
            F[:, -1] = end_values[rows, 1]
        out.append(F)
    return out


def _line_function(surface):
    def g(s, ox, oy, oz, dx, dy, dz):
        x = np.stack([ox + s * dx, oy + s * dy, oz + s * dz], axis=-1)
        return surface(x.reshape(-1, 3)).reshape(s.shape)

    return g


def _coords(o: np.ndarray, d: np.ndarray) -> tuple:
    return (o[:, 0], o[:, 1], o[:, 2], d[:, 0], d[:, 1], d[:, 2])


def _roots(surface, o, d, lo, hi, xatol):
    res = elementwise.find_root(
        _line_function(surface),
        (lo, hi),
        args=_coords(o, d),
        tolerances={"xatol": xatol, "xrtol": 0.0},
    )
    failed = res.status != 0
    if failed.any():
        log.debug("find_root: %d brackets did not converge", int(failed.sum()))
    return np.where(failed, 0.5 * (res.bracket[0] + res.bracket[1]), res.x)


#: A same-sign sample is a dip when |f| there is a local minimum below this
#: fraction of |f| at its larger neighbour.
DIP_FRACTION = 0.25


def _dips(rows, S, F, inside):
    """Samples where |f| has a deep local minimum without a sign change."""
    if S.shape[1] < 3:
        return (np.zeros(0, np.int64),) + (np.zeros(0),) * 4
    a = np.abs(F)
    mid = a[:, 1:-1]
    dip = (
        (mid < DIP_FRACTION * np.maximum(a[:, :-2], a[:, 2:]))
        & (mid < a[:, :-2])
        & (mid < a[:, 2:])
    )
    dip &= (inside[:, :-2] == inside[:, 1:-1]) & (inside[:, 1:-1] == inside[:, 2:])
    r, j = np.nonzero(dip)
    j = j + 1
    return rows.start + r, S[r, j - 1], S[r, j], S[r, j + 1], np.where(inside[r, j], -1.0, 1.0)


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
    return Crossings(np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool))
