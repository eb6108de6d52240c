"""Row-wise array helpers: scale-safe norms (no squaring, so no overflow or
underflow at extreme scales) and the lookup of integer rows in a table."""

from __future__ import annotations

import numpy as np


def row_norms(v: np.ndarray) -> np.ndarray:
    """Euclidean norm of each row of ``(n, 3)`` ``v``, by ``hypot``."""
    return np.hypot(np.hypot(v[:, 0], v[:, 1]), v[:, 2])


def unit_rows(v: np.ndarray) -> np.ndarray:
    """Each row of ``(n, 3)`` ``v`` scaled to unit length; zero rows where the
    norm is zero or not finite."""
    n = row_norms(v)
    ok = np.isfinite(n) & (n > 0)
    out = np.zeros_like(v, dtype=np.float64)
    out[ok] = v[ok] / n[ok, None]
    return out


def row_index(rows: np.ndarray, table: np.ndarray) -> np.ndarray:
    """Index in ``table`` of each of ``rows`` (rows of integers), -1 where absent."""
    both = np.concatenate([table, rows]).astype(np.int64)
    _, inv = np.unique(both, axis=0, return_inverse=True)
    inv = inv.ravel()
    pos = np.full(inv.max() + 1 if len(inv) else 0, -1, np.int64)
    pos[inv[: len(table)]] = np.arange(len(table))
    return pos[inv[len(table) :]]
