"""The oracle half of :class:`~rdmesh.VolumeSurface`: the interpolated volume, its box and ``f``.

:class:`VolumeOracle` evaluates the compiled sampler (values and exact
gradients), the signed distance to the box, and the two forms of ``f``: the
volume's alone (``border="clipped"``) and ``max(f_volume, d_box)``
(``border="closed"``). :class:`~rdmesh.VolumeSurface` checks the arguments,
builds the sampler and sets the attributes these methods read.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

#: Samples per block side of the slope tables behind :meth:`VolumeOracle.gradient_bound`.
BOUND_BLOCK = 4
#: Coefficients beyond a point's cell that its value and gradient may read
#: (cubic: one below and two above the cell, mirrored at the ends; 2 covers both).
_SUPPORT = 2


class VolumeOracle:
    """Values, gradients and ``f`` of an interpolated volume closed (or clipped) by its box.

    A base of :class:`~rdmesh.VolumeSurface`, which sets the attributes below.

    Attributes
    ----------
    isovalue : float
        The level meshed.
    value_scale : float
        ``f`` is ``(isovalue - v) / value_scale``, times ``_sign``.
    box : (2, 3) float64
        The lowest and highest corners of the box of the samples.
    border : {"closed", "clipped"}
        Which ``f`` :meth:`_border_oracle` gives.
    _sign : float
        1.0 for ``inside="greater"``, -1.0 for "less".
    _sampler : rdmesh.core.VolumeSampler
        The compiled sampler of the interpolant.
    """

    # -- the interpolant ------------------------------------------------------------

    def values(self, points: np.ndarray) -> np.ndarray:
        """The interpolated data value ``v`` at ``(N, 3)`` points, ``(N,)``.

        Points outside the box get the value at the nearest point of the box.
        """
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        return self._sampler.sample(pts, False)[0]

    def value_gradients(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The interpolated value ``(N,)`` and its exact gradient ``(N, 3)``.

        Outside the box the gradient is that of the nearest point of the box,
        without the components that point out of it.
        """
        pts = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
        return self._sampler.sample(pts, True)

    def f_volume(self, points: np.ndarray) -> np.ndarray:
        """``f`` without the box: ``(isovalue - v) / value_scale``, sign per ``inside``."""
        return (self.isovalue - self.values(points)) * (self._sign / self.value_scale)

    def box_distance(self, points: np.ndarray) -> np.ndarray:
        """Signed distance to the box, negative inside, ``(N,)``."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        q = np.maximum(self.box[0] - pts, pts - self.box[1])  # > 0 outside that slab
        d_in = q.max(axis=1)
        np.maximum(q, 0.0, out=q)
        return np.sqrt(np.einsum("ij,ij->i", q, q)) + np.minimum(d_in, 0.0)

    def box_gradient(self, points: np.ndarray) -> np.ndarray:
        """Gradient of :meth:`box_distance`, ``(N, 3)``: on and inside the box, the
        outward normal of the nearest face."""
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        below = self.box[0] - pts
        above = pts - self.box[1]
        q = np.maximum(below, above)
        sign = np.where(above > below, 1.0, -1.0)
        out = np.maximum(q, 0.0)
        norm = np.linalg.norm(out, axis=1)
        g = out * sign / np.maximum(norm, 1e-300)[:, None]
        rows = np.flatnonzero(norm == 0.0)  # on or inside the box
        axis = np.argmax(q[rows], axis=1)
        g[rows] = 0.0
        g[rows, axis] = sign[rows, axis]
        return g

    # -- a proven slope bound -------------------------------------------------------

    def gradient_bound(self, centres: np.ndarray, radius: float) -> np.ndarray:
        """A proven bound on ``|grad f|`` in the axis-aligned box of half-side
        ``radius`` about each of ``(k, 3)`` centres, ``(k,)``.

        Along each axis the interpolant's derivative is a weighted mean
        (nonnegative weights summing to 1: the B-spline of one degree lower
        times the others) of the differences of neighbouring coefficients, so
        it is at most their largest size among those a point reads; outside
        the box the gradient is that of the nearest box point or less. The
        largest sizes come from tables of block maxima (made on first use,
        then kept), so the bound may take in a few more coefficients than
        the box reads. With the box
        closing the surface, ``f`` is the larger of ``f_volume`` and the
        box's distance (1-Lipschitz), so the bound is at least 1.
        """
        c = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
        n = np.asarray(self.shape, dtype=np.int64)
        spacing, origin = np.asarray(self.spacing), np.asarray(self.origin)
        with np.errstate(invalid="ignore"):
            lo = np.floor((c - radius - origin) / spacing)
            hi = np.floor((c + radius - origin) / spacing)
        # NaN centres take the whole volume.
        lo = np.where(np.isnan(lo), 0, np.clip(lo, 0, n - 2)).astype(np.int64) - _SUPPORT
        hi = np.where(np.isnan(hi), n, np.clip(hi, 0, n - 2)).astype(np.int64) + _SUPPORT
        if getattr(self, "_slopes", None) is None:
            self._slopes = _slope_tables(self._sampler.coefficients())
        square = np.zeros(len(c))
        for axis, table in enumerate(self._slopes):
            top = n - 1
            top[axis] -= 1  # differences along this axis: one fewer
            a, b = np.clip(lo, 0, top) // BOUND_BLOCK, np.clip(hi, 0, top) // BOUND_BLOCK
            width = tuple(int(w) for w in (b - a).max(axis=0) + 1) if len(c) else (1, 1, 1)
            steep = _window_max(table, width)[a[:, 0], a[:, 1], a[:, 2]]
            square += (steep / spacing[axis]) ** 2
        bound = np.sqrt(square) / self.value_scale
        return bound if self.border == "clipped" else np.maximum(bound, 1.0)

    # -- the oracle -----------------------------------------------------------------

    def _border_oracle(
        self,
    ) -> tuple[Callable[[np.ndarray], np.ndarray], Callable[[np.ndarray], np.ndarray],
               np.ndarray | None]:  # fmt: skip
        """``f``, its gradient and the clip box for ``border``: the volume's alone,
        clipped by the box, or closed by the box (no clip box)."""
        if self.border == "clipped":
            return self.f_volume, self._volume_gradient, self.box
        return self._f, self._gradient, None

    def _f(self, points: np.ndarray) -> np.ndarray:
        return np.maximum(self.f_volume(points), self.box_distance(points))

    def _volume_gradient(self, points: np.ndarray) -> np.ndarray:
        """Gradient of :meth:`f_volume` (the clipped border's ``f``)."""
        _, gv = self.value_gradients(points)
        gv *= -self._sign / self.value_scale
        return gv

    def _gradient(self, points: np.ndarray) -> np.ndarray:
        v, gv = self.value_gradients(points)
        k = self._sign / self.value_scale
        fv = (self.isovalue - v) * k
        gv *= -k
        box = self.box_distance(points) > fv
        gv[box] = self.box_gradient(points[box])
        return gv


def _slope_tables(coefficients: np.ndarray) -> list[np.ndarray]:
    """Per axis, the largest ``|c[i + 1] - c[i]|`` of the coefficients in each
    block of ``BOUND_BLOCK^3``."""
    tables = []
    for axis in range(3):
        d = np.abs(np.diff(coefficients, axis=axis))
        for k in range(3):
            d = np.maximum.reduceat(d, np.arange(0, d.shape[k], BOUND_BLOCK), axis=k)
        tables.append(d)
    return tables


def _window_max(table: np.ndarray, width: tuple[int, int, int]) -> np.ndarray:
    """``out[i, j, k]``: the largest of ``table[i : i + wi, j : j + wj, k : k + wk]``."""
    out = table
    for axis, w in enumerate(width):
        acc = out.copy()
        for shift in range(1, w):
            head = [slice(None)] * 3
            tail = [slice(None)] * 3
            head[axis], tail[axis] = slice(0, -shift), slice(shift, None)
            np.maximum(acc[tuple(head)], out[tuple(tail)], out=acc[tuple(head)])
        out = acc
    return out
