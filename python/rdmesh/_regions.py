"""Named regions: clusters of points, to say where a problem is."""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

#: Half of the 26 voxel neighbours (the other half is found from the other side).
_STEPS = (-1, 0, 1)
_HALF = np.array(
    [(i, j, k) for i in _STEPS for j in _STEPS for k in _STEPS if (i, j, k) > (0, 0, 0)]
)


def regions(points: np.ndarray, link: float) -> list[dict[str, Any]]:
    """Clusters of points, largest first: ``centre``, ``radius`` and ``points``
    of each, to name where problems are.

    Points within ``link`` of each other always share a cluster (points up to
    about ``3.5 link`` apart may too): clusters are the connected sets of
    occupied voxels of side ``link``. O(n log n) in the number of points, so
    it scales to the millions of points a runaway run leaves.
    """
    n = len(points)
    if n == 0:
        return []
    vox = np.floor((points - points.min(axis=0)) / link).astype(np.int64) + 1
    cells, inverse = np.unique(vox, axis=0, return_inverse=True)
    inverse = inverse.ravel()
    dims = cells.max(axis=0) + 2
    code = (cells[:, 0] * dims[1] + cells[:, 1]) * dims[2] + cells[:, 2]
    order = np.argsort(code)
    sorted_code = code[order]
    rows, cols = [], []
    for off in _HALF:
        nb = code + (off[0] * dims[1] + off[1]) * dims[2] + off[2]
        at = np.minimum(np.searchsorted(sorted_code, nb), len(code) - 1)
        hit = sorted_code[at] == nb
        rows.append(np.flatnonzero(hit))
        cols.append(order[at[hit]])
    m = len(cells)
    r, c = np.concatenate(rows), np.concatenate(cols)
    g = coo_matrix((np.ones(len(r), np.int8), (r, c)), shape=(m, m))
    _, cell_label = connected_components(g, directed=False)
    label = cell_label[inverse]
    count = np.bincount(label)
    centre = np.stack([np.bincount(label, weights=points[:, a]) for a in range(3)], axis=1)
    centre /= count[:, None]
    radius = np.zeros(len(count))
    np.maximum.at(radius, label, np.linalg.norm(points - centre[label], axis=1))
    return [
        {
            "centre": [round(float(v), 6) for v in centre[k]],
            "radius": float(radius[k]),
            "points": int(count[k]),
        }
        for k in np.argsort(-count, kind="stable")
    ]


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
