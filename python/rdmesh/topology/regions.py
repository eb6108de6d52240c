"""Named regions: clusters of points, to say where a problem is."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree


def regions(points: np.ndarray, link: float) -> list[dict[str, Any]]:
    """Clusters of points (single linkage at distance ``link``), largest first:
    ``centre``, ``radius`` and ``points`` of each, to name where problems are."""
    if len(points) == 0:
        return []
    pairs = cKDTree(points).query_pairs(link, output_type="ndarray")
    n = len(points)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    k, label = connected_components(g, directed=False)
    out = []
    for c in np.argsort(-np.bincount(label))[:k]:
        p = points[label == c]
        centre = p.mean(axis=0)
        out.append(
            {
                "centre": [round(float(v), 6) for v in centre],
                "radius": float(np.linalg.norm(p - centre, axis=1).max()),
                "points": len(p),
            }
        )
    return out


def describe_regions(rs: list[dict[str, Any]], limit: int = 5) -> str:
    """Short text naming regions, e.g. ``near (0, 0, 0) r 0.01 (12 points)``."""
    parts = [
        f"near ({', '.join(f'{v:.4g}' for v in r['centre'])}) radius {r['radius']:.3g} "
        f"({r['points']} points)"
        for r in rs[:limit]
    ]
    if len(rs) > limit:
        parts.append(f"and {len(rs) - limit} more")
    return "; ".join(parts)
