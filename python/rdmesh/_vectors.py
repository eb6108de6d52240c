"""Scale-safe row norms: no squaring, so no overflow or underflow at extreme scales."""

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
