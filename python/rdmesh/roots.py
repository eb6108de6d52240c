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
_BUCKETS = (4, 8, 16, 32, 64)


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
) -> list[tuple[np.ndarray, np.ndarray]]:
    """Group segments by sample count and build their sample positions.

    Parameters
    ----------
    lengths : (k,) segment lengths.
    n_intervals : (k,) wanted number of intervals; rounded up to a bucket size.
    warp : callable, optional
        ``warp(rows, u)`` maps uniform fractions ``u`` of shape ``(len(rows), n+1)``
        to distances along those segments. Default: uniform spacing.

    Returns
    -------
    list of (rows, S)
        ``rows`` indexes the segments of a bucket, ``S`` is ``(len(rows), n+1)``
        distances from each segment's start, ``S[:, 0] = 0`` and ``S[:, -1] = length``.
    """
    want = np.clip(n_intervals, _BUCKETS[0], _BUCKETS[-1])
    sizes = np.asarray(_BUCKETS)
    which = np.searchsorted(sizes, want)
    out = []
    for b, n in enumerate(_BUCKETS):
        rows = np.flatnonzero(which == b)
        if rows.size == 0:
            continue
        u = np.linspace(0.0, 1.0, n + 1)[None, :]
        if warp is None:
            S = u * lengths[rows, None]
        else:
            S = warp(rows, np.broadcast_to(u, (rows.size, n + 1)))
            S[:, 0] = 0.0
            S[:, -1] = lengths[rows]
        out.append((rows, S))
    return out


def line_crossings(
    surface: ImplicitSurface,
    origin: np.ndarray,
    direction: np.ndarray,
    samples: list[tuple[np.ndarray, np.ndarray]],
    xatol: float,
) -> Crossings:
    """Find every sign change of ``f`` along segments ``origin + s * direction``.

    Parameters
    ----------
    surface : ImplicitSurface
    origin : (k, 3) segment starts.
    direction : (k, 3) unit directions.
    samples : list of (rows, S) from :func:`bucket_samples`.
    xatol : absolute tolerance on each crossing's position.

    Returns
    -------
    Crossings
    """
    if not samples:
        return _empty()
    pts = [origin[rows, None, :] + S[:, :, None] * direction[rows, None, :] for rows, S in samples]
    values = surface(np.concatenate([p.reshape(-1, 3) for p in pts]))
    seg, lo, hi, rising = [], [], [], []
    start = 0
    for rows, S in samples:
        F = values[start : start + S.size].reshape(S.shape)
        start += S.size
        inside = F < 0.0
        r, j = np.nonzero(inside[:, :-1] != inside[:, 1:])
        seg.append(rows[r])
        lo.append(S[r, j])
        hi.append(S[r, j + 1])
        rising.append(inside[r, j])
    seg = np.concatenate(seg)
    if seg.size == 0:
        return _empty()
    lo, hi, rising = np.concatenate(lo), np.concatenate(hi), np.concatenate(rising)
    o = origin[seg]
    d = direction[seg]

    def g(s, ox, oy, oz, dx, dy, dz):
        x = np.stack([ox + s * dx, oy + s * dy, oz + s * dz], axis=-1)
        return surface(x.reshape(-1, 3)).reshape(s.shape)

    res = elementwise.find_root(
        g,
        (lo, hi),
        args=(o[:, 0], o[:, 1], o[:, 2], d[:, 0], d[:, 1], d[:, 2]),
        tolerances={"xatol": xatol, "xrtol": 0.0},
    )
    s = np.where(res.status == 0, res.x, 0.5 * (res.bracket[0] + res.bracket[1]))
    if np.any(res.status != 0):
        log.debug("find_root: %d brackets did not converge", int(np.sum(res.status != 0)))
    order = np.lexsort((s, seg))
    seg, s, rising = seg[order], s[order], rising[order]
    return Crossings(seg, s, origin[seg] + s[:, None] * direction[seg], rising)


def _empty() -> Crossings:
    return Crossings(
        np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool)
    )
