"""Debug self-checks of the restricted Delaunay bookkeeping (``RDMESH_CHECK=1``).

The core's own check (the Delaunay property and the symmetry of the facet
flags) plus the empty surface Delaunay ball check of algorithm.md 1.2: no
sample lies inside the ball of a restricted facet, centred at its surface
centre. Both cost a pass over the whole mesh, so they run only below
:data:`CHECK_MAX_SAMPLES`.
"""

from __future__ import annotations

import numpy as np

from .._errors import InternalCheckError
from ..topology import Snapshot

#: Larger runs are not checked (the checks are O(n log n) every round).
CHECK_MAX_SAMPLES = 50_000
#: Relative slack of the empty-ball check (rounding of centres and radii).
BALL_SLACK = 1e-9


def check_restricted(snap: Snapshot) -> None:
    """Raise InternalCheckError if the core's bookkeeping is inconsistent."""
    if len(snap.vertices) > CHECK_MAX_SAMPLES:
        return
    try:
        snap.rdt.check()
    except RuntimeError as exc:
        raise InternalCheckError(f"core check failed: {exc}") from exc
    tri, centres, _ = snap.facets(0)
    if len(tri) == 0:
        return
    radii = snap.radii(0)
    # The facet's own three vertices lie on its ball (up to the root
    # tolerance); the fourth nearest sample is the first that may not.
    # With protecting balls: by power, over the samples nearest in distance
    # and every ball that could reach the centre.
    k = min(4, len(snap.vertices))
    d, idx = snap.tree.query(centres, k=k)
    d, idx = d.reshape(len(tri), k), idx.reshape(len(tri), k)
    w = snap.weights
    if w is not None:
        balls = np.flatnonzero(w > 0)
        idx = np.concatenate([idx, np.broadcast_to(balls, (len(tri), len(balls)))], axis=1)
        diff = centres[:, None, :] - snap.vertices[idx]
        d = np.sqrt(np.maximum(np.einsum("ijk,ijk->ij", diff, diff) - w[idx], 0.0))
    own = (idx[:, :, None] == tri[:, None, :]).any(axis=2)
    d = np.where(own, np.inf, d)
    j = np.argmin(d, axis=1)
    rows = np.arange(len(tri))
    d, nearest = d[rows, j], idx[rows, j]
    bad = d < radii * (1.0 - BALL_SLACK)
    if bad.any():
        i = int(np.argmax(bad))
        raise InternalCheckError(
            f"{int(bad.sum())} surface Delaunay balls are not empty: the ball of facet "
            f"{tri[i].tolist()} (centre {centres[i].tolist()}, radius {radii[i]:.6g}) "
            f"contains sample {int(nearest[i])} at distance {d[i]:.6g}"
        )
