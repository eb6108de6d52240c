"""Local feature size of a triangle mesh, from shrinking medial balls (issue 30).

For each sample ``p`` of the surface with unit normal ``n``, the largest ball
touching the surface at ``p`` from inside (centre ``p - r n``) and the one from
outside (``p + r n``) without another sample inside are found by shrinking
(Ma, Bae and Choi, "3D medial axis point approximation using nearest
neighbors and the normal field", 2012): start from a large radius, find the
sample ``q`` nearest the centre; if it is closer than ``r``, the ball through
``p`` and ``q`` tangent at ``p`` has radius ``|p - q|^2 / (2 n . (p - q))``;
repeat until no sample is inside. The smaller of the two radii estimates the
distance from ``p`` to the medial axis, the local feature size. It is an
estimate (sampled): features finer than the samples' spacing are not seen.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

#: Shrinking steps per ball.
STEPS = 30
#: Samples added per face at most, so that large flat faces are sampled too.
FACE_SAMPLES = 4


def surface_samples(vertices: np.ndarray, faces: np.ndarray, normals: np.ndarray, spacing: float):
    """Vertices plus points on faces larger than ``spacing``, with unit normals.

    Returns
    -------
    points : (k, 3)
    point_normals : (k, 3)
    """
    vn = np.zeros_like(vertices)
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
    for i in range(3):
        np.add.at(vn, faces[:, i], normals * area[:, None])
    vn /= np.maximum(np.linalg.norm(vn, axis=1), 1e-300)[:, None]
    big = np.flatnonzero(area > spacing**2)
    pts, nrm = [vertices], [vn]
    if len(big):
        k = np.minimum(FACE_SAMPLES, np.ceil(area[big] / spacing**2)).astype(int)
        face = np.repeat(big, k)
        rng = np.random.default_rng(0)
        u, w = rng.random((2, len(face)))
        flip = u + w > 1
        u[flip], w[flip] = 1 - u[flip], 1 - w[flip]
        pts.append(a[face] + u[:, None] * (b[face] - a[face]) + w[:, None] * (c[face] - a[face]))
        nrm.append(normals[face])
    return np.concatenate(pts), np.concatenate(nrm)


def medial_radii(points: np.ndarray, normals: np.ndarray, start: float) -> np.ndarray:
    """Radii ``(k, 2)`` of the inner and outer shrinking balls at each point.

    Parameters
    ----------
    points, normals : (k, 3) surface samples and their unit (outward) normals.
    start : the initial radius (and the largest returned).
    """
    tree = cKDTree(points)
    out = np.empty((len(points), 2))
    idx = np.arange(len(points))
    for side, sign in enumerate((-1.0, 1.0)):
        r = np.full(len(points), start)
        active = np.ones(len(points), bool)
        for _ in range(STEPS):
            i = idx[active]
            if not len(i):
                break
            centre = points[i] + sign * r[i, None] * normals[i]
            d, j = tree.query(centre, workers=-1)
            inside = (d < r[i] * (1 - 1e-9)) & (j != i)
            q = points[j[inside]] - points[i[inside]]
            dn = sign * np.einsum("ij,ij->i", q, normals[i[inside]])
            new = np.where(dn > 0, np.einsum("ij,ij->i", q, q) / (2 * np.maximum(dn, 1e-300)), 0)
            shrink = i[inside]
            r[shrink] = np.minimum(r[shrink], np.maximum(new, 0.0))
            active[:] = False
            active[shrink] = True
        out[:, side] = r
    return out
