"""The volume's interpolant, evaluated the same way in every task.

:class:`rdmesh.VolumeSurface` prefilters the whole volume for its cubic
B-spline (``scipy.ndimage.spline_filter``: a recursive filter over every
sample of each line). A task that holds only its block cannot do that, so the
blocks use the prefilter's impulse response truncated at :data:`HALF_WIDTH`
samples, ``h[k] = sqrt(3) (sqrt(3) - 2)^|k|`` for ``|k| <= HALF_WIDTH``
(normalised to sum to 1), applied along each axis to the volume mirrored at
its ends as ``mode="mirror"`` does. Each B-spline coefficient is then a fixed
function of the samples within ``HALF_WIDTH`` of it, computed by the same
operations whichever window holds it, and every value and gradient of the
interpolant is a fixed function of the point: two tasks evaluating one point
get the same bits (the coordinates go through one formula, and window offsets
are whole samples, subtracted exactly). The interpolant differs from
VolumeSurface's by at most about ``4.7 x 0.268^(HALF_WIDTH + 1)`` times the
range of the data (1.7e-7 for 12), a fraction of a sample in position far
below any mesh size. Linear interpolation needs no prefilter.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import ndimage

from ..core import VolumeSampler

#: Samples on each side of the truncated cubic prefilter.
HALF_WIDTH = 12
#: Extra coefficients on each side of what a region's points need.
MARGIN = 2


def fir(half_width: int = HALF_WIDTH) -> np.ndarray:
    """The truncated prefilter ``(2 half_width + 1,)``, summing to 1."""
    z = np.sqrt(3.0) - 2.0
    k = np.arange(-half_width, half_width + 1)
    w = np.sqrt(3.0) * z ** np.abs(k)
    return w / w.sum()


def halo(degree: int) -> int:
    """Samples a region's window reaches beyond the region on each side."""
    return (HALF_WIDTH if degree == 3 else 0) + MARGIN + 2


def raw_range(lo: np.ndarray, hi: np.ndarray, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """The samples ``[a, b]`` (inclusive, may run past the volume: mirrored)
    whose window lets every point of the sample box ``[lo, hi]`` be evaluated."""
    h = halo(degree)
    return np.asarray(lo, np.int64) - h, np.asarray(hi, np.int64) + h


def mirrored(a: np.ndarray, b: np.ndarray, shape) -> tuple[list[slice], list[tuple[int, int]]]:
    """The part of ``[a, b]`` inside the volume (slices) and the padding on each
    side that mirrors it beyond (``np.pad`` with ``mode="reflect"``)."""
    sl, pads = [], []
    for k in range(3):
        n = int(shape[k])
        lo, hi = max(int(a[k]), 0), min(int(b[k]), n - 1)
        sl.append(slice(lo, hi + 1))
        pads.append((lo - int(a[k]), int(b[k]) - hi))
    return sl, pads


def as_float(raw) -> np.ndarray:
    """Samples as a C-contiguous float64 array (booleans become 0 and 1)."""
    arr = np.asarray(raw)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.float64)
    return np.ascontiguousarray(arr, dtype=np.float64)


def coefficients(raw: np.ndarray, degree: int) -> np.ndarray:
    """B-spline coefficients of a raw window, trimmed by :data:`HALF_WIDTH` on
    every side (the coefficients nearer its sides are not exact).

    Each axis is trimmed as soon as it is filtered, so the next axes filter
    fewer lines (half the work on a face's thin window); every coefficient
    kept is the same sum of the same samples, whichever window holds it.
    """
    if degree == 1:
        return raw
    w = fir()
    cut = HALF_WIDTH
    out = raw
    for axis in range(3):
        out = ndimage.correlate1d(out, w, axis=axis, mode="nearest", output=np.float64)
        keep = [slice(None)] * 3
        keep[axis] = slice(cut, -cut)
        out = out[tuple(keep)]
    return out


@dataclass
class Params:
    """What defines ``f`` for every block: ``f = sign (isovalue - v) / value_scale``."""

    isovalue: float
    sign: float
    value_scale: float
    degree: int


class Field:
    """The interpolant on one window of the volume: ``f`` and its gradient.

    Parameters
    ----------
    raw : (k0, k1, k2) float64
        The samples of the window ``[a, b]`` of :func:`raw_range`, mirrored
        past the volume's ends.
    a : (3,) int
        The window's first sample (negative when mirrored).
    origin, spacing : (3,) the volume's.
    params : Params
    """

    def __init__(self, raw: np.ndarray, a: np.ndarray, origin, spacing, params: Params) -> None:
        cut = HALF_WIDTH if params.degree == 3 else 0
        c = coefficients(raw, params.degree)
        self.offset = (np.asarray(a, np.int64) + cut).astype(np.float64)
        self.origin = np.asarray(origin, np.float64)
        self.spacing = np.asarray(spacing, np.float64)
        self.params = params
        # Sample coordinates are global indices less the window's offset.
        self._sampler = VolumeSampler(
            np.ascontiguousarray(c), params.degree, (0.0,) * 3, (1.0,) * 3
        )
        self._k = params.sign / params.value_scale

    def _local(self, points: np.ndarray) -> np.ndarray:
        x = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        return (x - self.origin) / self.spacing - self.offset

    def f(self, points: np.ndarray) -> np.ndarray:
        """``f`` at ``(N, 3)`` points, ``(N,)``."""
        v = self._sampler.sample(self._local(points), False)[0]
        return (self.params.isovalue - v) * self._k

    def gradient(self, points: np.ndarray) -> np.ndarray:
        """The gradient of ``f`` at ``(N, 3)`` points, ``(N, 3)``."""
        g = self._sampler.sample(self._local(points), True)[1]
        return g * (-self._k / self.spacing)


def block_stats(raw: np.ndarray, first: np.ndarray) -> dict:
    """Smallest and largest sample of a block, and its first non-finite sample
    (global index) if any."""
    arr = np.asarray(raw)
    if arr.dtype == np.bool_:
        arr = arr.astype(np.uint8)
    if not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
        return {"dtype": str(arr.dtype)}
    bad = ~np.isfinite(arr) if np.issubdtype(arr.dtype, np.floating) else None
    out: dict = {"bad": 0, "where": None}
    if bad is not None and bad.any():
        where = np.unravel_index(int(np.argmax(bad)), arr.shape)
        out["bad"] = int(bad.sum())
        out["where"] = tuple(int(i + f) for i, f in zip(where, first, strict=True))
        arr = arr[~bad]
    out["min"] = float(arr.min()) if arr.size else np.inf
    out["max"] = float(arr.max()) if arr.size else -np.inf
    return out


#: Quantiles of each block's slopes sent back for the value scale.
SLOPE_QUANTILES = 257


def block_slopes(raw: np.ndarray, isovalue: float, spacing) -> tuple[np.ndarray, int]:
    """|difference / spacing| over the grid edges of a block the isosurface
    crosses: ``SLOPE_QUANTILES`` quantiles and their count."""
    arr = as_float(raw)
    above = arr > isovalue
    slopes = []
    for axis in range(3):
        a = [slice(None)] * 3
        b = [slice(None)] * 3
        a[axis], b[axis] = slice(None, -1), slice(1, None)
        cross = above[tuple(a)] != above[tuple(b)]
        slopes.append(np.abs(arr[tuple(b)][cross] - arr[tuple(a)][cross]) / spacing[axis])
    s = np.concatenate(slopes)
    if not len(s):
        return np.zeros(0), 0
    return np.quantile(s, np.linspace(0.0, 1.0, SLOPE_QUANTILES)), len(s)


def value_scale(parts: list[tuple[np.ndarray, int]]) -> float:
    """The median slope over every block, from each block's quantiles weighted
    by its count (1 when the surface crosses no grid edge)."""
    q = [p for p in parts if p[1] > 0]
    if not q:
        return 1.0
    vals = np.concatenate([p[0] for p in q])
    wts = np.concatenate([np.full(len(p[0]), p[1] / len(p[0])) for p in q])
    order = np.argsort(vals, kind="stable")
    cum = np.cumsum(wts[order])
    return float(vals[order][np.searchsorted(cum, 0.5 * cum[-1])])
