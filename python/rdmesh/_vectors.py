"""Row-wise array helpers: scale-safe norms (no squaring, so no overflow or
underflow at extreme scales), unique rows, and the lookup of integer rows in a
table."""

from __future__ import annotations

import numpy as np


def row_norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of ``(n, 3)`` ``v``, by ``hypot``."""
    return np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2])


def segment_directions(d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Length and unit direction of each row of ``(n, 3)`` ``d`` (zero rows
    stay zero), in the core's order of operations (``cpp/sampling.cpp``):
    ``sqrt((x*x + y*y) + z*z)`` and ``d / length``. So ``start + s * u`` has
    the same bits here and in the core's sample points."""
    length = np.sqrt((d[:, 0] * d[:, 0] + d[:, 1] * d[:, 1]) + d[:, 2] * d[:, 2])
    return length, d / np.where(length > 0, length, 1.0)[:, None]


def unit_rows(v: np.ndarray) -> np.ndarray:
    """Each row of ``(n, 3)`` ``v`` scaled to unit length; zero rows where the
    norm is zero or not finite."""
    n = row_norms(v)
    ok = np.isfinite(n) & (n > 0)
    out = np.zeros_like(v, dtype=np.float64)
    out[ok] = v[ok] / n[ok, None]
    return out


def unique_rows(v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.unique(v, axis=0, return_inverse=True)`` by one lexsort (numpy's
    row-wise unique is several times slower on large meshes)."""
    order = np.lexsort(v.T[::-1])
    ordered = v[order]
    new = np.r_[True, np.any(ordered[1:] != ordered[:-1], axis=1)]
    inverse = np.empty(len(v), np.int64)
    inverse[order] = np.cumsum(new) - 1
    return ordered[new], inverse


def row_index(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Index in ``table`` of each of ``rows`` (rows of integers), -1 where absent
    (the last one where ``table`` repeats a row)."""
    rows = np.asarray(rows, dtype=np.int64)
    table = np.asarray(table, dtype=np.int64)
    if len(rows) == 0 or len(table) == 0:
        return np.full(len(rows), -1, np.int64)
    both = np.concatenate([table, rows])
    low = both.min(axis=0)
    span = both.max(axis=0) - low + 1
    if float(np.prod(span.astype(np.float64))) >= 2.0**62:
        # Too wide for one integer key: sort the rows themselves.
        _, inv = np.unique(both, axis=0, return_inverse=True)
        inv = inv.ravel()
        pos = np.full(inv.max() + 1, -1, np.int64)
        pos[inv[: len(table)]] = np.arange(len(table))
        return pos[inv[len(table) :]]
    # One integer key per row, then a binary search in the sorted table.
    key = np.ravel_multi_index(tuple((both - low).T), tuple(int(s) for s in span))
    tk, rk = key[: len(table)], key[len(table) :]
    order = np.argsort(tk, kind="stable")
    sorted_keys = tk[order]
    at = np.searchsorted(sorted_keys, rk, side="right") - 1
    found = (at >= 0) & (sorted_keys[np.maximum(at, 0)] == rk)
    return np.where(found, order[np.maximum(at, 0)], -1)


#: Bits of an int64 key shared by a row's columns (:func:`row_keys`): 21 per
#: id in rows of 3 (up to 2,097,152 vertices), 31 in rows of 2.
KEY_BITS = 63


class RowSet:
    """Rows of vertex ids (each row sorted), for membership tests: one int64
    key per row, kept sorted, where the ids fit (:func:`row_keys`); the rows
    themselves and :func:`row_index` where they do not."""

    def __init__(self, rows: np.ndarray) -> None:
        self._hold(np.asarray(rows, np.int64))

    def contains(self, rows: np.ndarray) -> np.ndarray:
        """Whether each of ``rows`` is in the set."""
        keys = row_keys(rows)
        if keys is None or self.keys is None:
            return row_index(rows, self.rows) >= 0
        if len(self.keys) == 0:
            return np.zeros(len(keys), bool)
        at = np.minimum(np.searchsorted(self.keys, keys), len(self.keys) - 1)
        return self.keys[at] == keys

    def add(self, rows: np.ndarray) -> None:
        """Add ``rows`` (not already in the set)."""
        rows = np.asarray(rows, np.int64).reshape(-1, self.rows.shape[1])
        new = row_keys(rows) if self.keys is not None else None
        if new is None:
            self._hold(np.concatenate([self.rows, rows]))
            return
        # Two sorted runs: the stable sort (timsort) merges them in linear time.
        new.sort()
        self.rows = np.concatenate([self.rows, rows])
        self.keys = np.concatenate([self.keys, new])
        self.keys.sort(kind="stable")

    def _hold(self, rows: np.ndarray) -> None:
        self.rows, self.keys = rows, row_keys(rows)
        if self.keys is not None:
            self.keys.sort()


def row_keys(rows: np.ndarray) -> np.ndarray | None:
    """One int64 key per row of non-negative integers, in the rows'
    lexicographic order (:data:`KEY_BITS` bits per column); None where an
    entry does not fit."""
    rows = np.asarray(rows, np.int64)
    bits = KEY_BITS // max(rows.shape[1], 1)
    if len(rows) and (rows.min() < 0 or rows.max() >> bits):
        return None
    keys = rows[:, 0].copy()
    for j in range(1, rows.shape[1]):
        keys <<= bits
        keys |= rows[:, j]
    return keys


def ring_directions(n: np.ndarray, sign: float, tilts, ring: int = 6) -> np.ndarray:
    """``sign * n`` and, for each tilt in ``tilts`` (radians), ``ring``
    directions tilted that far from it, evenly around it: ``(k, 1 + ring
    len(tilts), 3)`` for unit ``(k, 3)`` ``n``. The frame around the axis comes
    from ``n`` (the same for either sign)."""
    helper = np.where(np.abs(n[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    t1 = np.cross(n, helper)
    t1 /= np.linalg.norm(t1, axis=1)[:, None]
    t2 = np.cross(n, t1)
    out = [sign * n]
    for tilt in tilts:
        for phi in np.arange(ring) * np.pi / (ring / 2):
            around = np.cos(phi) * t1 + np.sin(phi) * t2
            out.append(sign * np.cos(tilt) * n + np.sin(tilt) * around)
    return np.stack(out, axis=1)
