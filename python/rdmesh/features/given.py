"""Protecting balls placed beforehand: a surface meshed with balls it did not place.

:class:`ProtectingBalls` holds a :class:`~rdmesh.features.protect.Balls` and
its :class:`~rdmesh.features.graph.FeatureGraph`. Handed to a surface as
``ImplicitSurface(..., features=ProtectingBalls(...))``, the balls replace the
surface's own feature curves: nothing is traced (not even a clip boundary)
and nothing is protected, the balls are inserted as they are, and the feature
check runs on them as on balls the run placed. Meshes made with the same
balls then share the vertices and edges along the curves: the blocks of a
volume (:func:`rdmesh.mesh_volume_blocks`) are meshed this way, each with the
balls of its faces, so that neighbouring blocks meet exactly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._vectors import row_norms
from .graph import FeatureError, FeatureGraph
from .protect import Balls

#: A centre must lie within this (times R) of the surface: |f| / |grad f|.
ON_SURFACE = 1e-6


@dataclass
class ProtectingBalls:
    """Protecting balls of a surface, placed beforehand.

    Parameters
    ----------
    balls : Balls
        The balls: ``centres (b, 3)`` on the curves, ``radii (b,)``, the curve
        (-1 for a corner) and corner (-1 for a curve ball) of each, the
        consecutive ``pairs (e, 2)`` along each curve with ``pair_curve (e,)``,
        the ``chains`` (each curve's balls in order, its end corners
        included) and ``boundary``, the curves that bound the mesh (one
        triangle per edge; two elsewhere).
    graph : FeatureGraph
        The curves the balls protect (their ``source`` names them in the
        feature check) and the corners, one corner ball each.

    Raises
    ------
    FeatureError
        (a ValueError) arrays of the wrong shape or with non-finite values,
        radii that are not positive, indices out of range, a corner count
        that differs from the graph's, or a centre inside another ball (the
        regular triangulation would hide it).

    Notes
    -----
    The balls replace every feature curve of the surface, its clip boundary
    included: a surface meshed with them traces and protects nothing else,
    and a mesh whose feature check fails is not repaired (the run cannot
    move balls it did not place): it comes back with ``complete=False``,
    ``SurfaceMesh.features.failed`` saying where, for the caller to place
    smaller balls there (:func:`rdmesh.features.check.repair_sites`).
    Boissonnat-Oudot only: :func:`rdmesh.mesh_surface` refuses them with
    the topological-ball method and ``certify``.
    """

    balls: Balls
    graph: FeatureGraph

    def __post_init__(self) -> None:
        b = self.balls
        if not isinstance(b, Balls) or not isinstance(self.graph, FeatureGraph):
            raise FeatureError("ProtectingBalls needs a Balls and a FeatureGraph")
        n = len(b.centres)
        c = np.asarray(b.centres, dtype=np.float64)
        r = np.asarray(b.radii, dtype=np.float64)
        if c.shape != (n, 3) or r.shape != (n,) or not np.all(np.isfinite(c)):
            raise FeatureError(f"balls: centres must be (b, 3) finite and radii (b,), got "
                               f"{c.shape} and {r.shape}")  # fmt: skip
        if n and not (np.all(np.isfinite(r)) and r.min() > 0):
            raise FeatureError("balls: every radius must be positive and finite")
        k = len(self.graph.curves)
        for name in ("curve", "corner", "index"):
            if np.shape(getattr(b, name)) != (n,):
                raise FeatureError(f"balls: {name} must have one entry per ball ({n})")
        pairs = np.asarray(b.pairs, dtype=np.int64).reshape(-1, 2)
        if len(pairs) and (pairs.min() < 0 or pairs.max() >= n):
            raise FeatureError("balls: pairs must index the balls")
        pc = np.asarray(b.pair_curve, dtype=np.int64)
        if pc.shape != (len(pairs),) or (len(pc) and (pc.min() < 0 or pc.max() >= k)):
            raise FeatureError("balls: pair_curve must give each pair a curve of the graph")
        if np.shape(b.boundary) != (k,):
            raise FeatureError(f"balls: boundary must have one flag per curve ({k})")
        if int((np.asarray(b.corner) >= 0).sum()) != len(self.graph.corners):
            raise FeatureError("balls: one corner ball per corner of the graph")
        self.balls.centres, self.balls.radii, self.balls.pairs = c, r, pairs
        _refuse_hidden(c, r)

    def __len__(self) -> int:
        return len(self.balls)

    def check_on_surface(self, surface) -> None:
        """FeatureError unless every centre lies on ``surface`` (|f| / |grad f|
        at most :data:`ON_SURFACE` times its bounding radius)."""
        c = self.balls.centres
        if not len(c):
            return
        f = surface(c)
        dist = np.abs(f) / np.maximum(row_norms(surface.grad(c)), 1e-300)
        off = dist > ON_SURFACE * surface.radius
        if off.any():
            i = int(np.argmax(dist))
            raise FeatureError(
                f"protecting ball {i} is not on the surface: its centre "
                f"{np.round(c[i], 9).tolist()} is about {dist[i]:.3g} from it (at most "
                f"{ON_SURFACE * surface.radius:.3g} is allowed)"
            )


def _refuse_hidden(c: np.ndarray, r: np.ndarray) -> None:
    """FeatureError when a centre lies inside another ball."""
    if len(c) < 2:
        return
    tree = cKDTree(c)
    d, j = tree.query(c, k=2)
    if np.any(d[:, 1] == 0.0):
        i = int(np.argmax(d[:, 1] == 0.0))
        raise FeatureError(f"balls {i} and {int(j[i, 1])} have the same centre")
    reach = float(r.max())
    pairs = np.array(sorted(tree.query_pairs(reach)), np.int64).reshape(-1, 2)
    if not len(pairs):
        return
    d = row_norms(c[pairs[:, 0]] - c[pairs[:, 1]])
    hid = d < np.maximum(r[pairs[:, 0]], r[pairs[:, 1]])
    if hid.any():
        a, b = pairs[int(np.argmax(hid))]
        raise FeatureError(
            f"the centre of ball {b} lies inside ball {a} (or the other way round) at "
            f"{np.round(c[b], 9).tolist()}: a weighted point there would be hidden"
        )


__all__ = ["ProtectingBalls"]
