"""The feature check after refinement: did the mesh keep every protected curve?

Every pair of consecutive ball centres must be a mesh edge with two triangles
(one on a curve that bounds the mesh), and every corner a mesh vertex. This is
an exact combinatorial check of the output, not a sample.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from scipy.spatial import cKDTree

from .graph import FeatureGraph
from .protect import Balls


@dataclass
class MeshFeatures:
    """The protected feature curves of a mesh and whether the mesh kept them.

    Attributes
    ----------
    curves : list of (k,) int64
        Each curve as mesh vertex indices in order along it (a closed curve
        repeats its first vertex last); -1 where a ball centre is not a mesh
        vertex.
    corners : (c,) int64
        The corners as mesh vertex indices (-1 where one is not a vertex).
    sources : list of str
        Where each curve came from ("given", "clip boundary", "volume box",
        "box edge", "mesh", "volume kink").
    held : bool
        True when every consecutive pair of centres is a mesh edge with the
        right number of triangles and every corner is a vertex.
    edges, edges_kept : int
        Consecutive centre pairs, and those kept as mesh edges.
    corners_kept : int
    failed : (k, 3) float64
        Midpoints of the pairs that are not mesh edges (or not with the right
        number of triangles), and corners that are not vertices.
    repairs : int
        Times the balls were shrunk and the mesh made again because the
        check failed.
    unresolved : (k, 3) float64
        Places where the search for creases in an expression or CSG tree
        could neither exclude nor trace one (``report["creases"]``).
    angle_held : bool
        Whether the balls were small enough (at most 0.3 size bounds apart)
        for the angle bound to be held next to them where the refinement
        point lands out; otherwise Mesh_3's relaxation (20 degrees floor).
    """

    curves: list[np.ndarray] = field(default_factory=list)
    corners: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    sources: list[str] = field(default_factory=list)
    held: bool = True
    edges: int = 0
    edges_kept: int = 0
    corners_kept: int = 0
    failed: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    repairs: int = 0
    balls: int = 0
    unresolved: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))
    angle_held: bool = False

    def as_report(self) -> dict[str, Any]:
        """The report's ``features`` entry (plain types)."""
        return {
            "curves": len(self.curves),
            "corners": len(self.corners),
            "balls": self.balls,
            "held": self.held,
            "edges": self.edges,
            "edges_kept": self.edges_kept,
            "corners_kept": self.corners_kept,
            "failed": np.round(self.failed, 12).tolist(),
            "repairs": self.repairs,
            "unresolved": len(self.unresolved),
            "sources": sorted(set(self.sources)),
            "level": "proven" if self.held else "failed",
            "angle_at_balls": "held where refinement can (small balls)"
            if self.angle_held
            else "relaxed as in Mesh_3, 20 degrees floor",
            "what": "every consecutive pair of ball centres is a mesh edge with two triangles "
            "(one on a boundary curve) and every corner a mesh vertex (checked on the output)",
        }


def check_features(
    balls: Balls, graph: FeatureGraph, ball_ids: np.ndarray, sample_ids: np.ndarray,
    faces: np.ndarray, n_vertices: int,
) -> MeshFeatures:  # fmt: skip
    """Check the mesh ``faces`` (mesh vertex indices) against the balls.

    Parameters
    ----------
    balls : Balls
    graph : FeatureGraph
    ball_ids : (b,) the core's sample id of each ball.
    sample_ids : (n_vertices,) the core's sample id of each mesh vertex (increasing).
    faces : (F, 3) mesh faces.
    n_vertices : number of mesh vertices.
    """
    b = len(balls)
    mesh_of = np.full(b, -1, np.int64)
    at = np.searchsorted(sample_ids, ball_ids)
    ok = (at < len(sample_ids)) & (ball_ids >= 0)
    ok[ok] = sample_ids[at[ok]] == ball_ids[ok]
    mesh_of[ok] = at[ok]
    # Edge counts of the mesh.
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    key = e[:, 0].astype(np.int64) * n_vertices + e[:, 1]
    keys, counts = np.unique(key, return_counts=True)
    u, v = mesh_of[balls.pairs[:, 0]], mesh_of[balls.pairs[:, 1]]
    present = (u >= 0) & (v >= 0)
    pk = np.minimum(u, v) * n_vertices + np.maximum(u, v)
    j = np.clip(np.searchsorted(keys, pk), 0, max(len(keys) - 1, 0))
    found = present & (len(keys) > 0)
    found[found] = keys[j[found]] == pk[found]
    count = np.where(found, counts[j] if len(keys) else 0, 0)
    want = np.where(balls.boundary[balls.pair_curve], 1, 2) if len(balls.pairs) else np.zeros(0)
    kept = count == want
    corner_balls = np.flatnonzero(balls.corner >= 0)
    corners = mesh_of[corner_balls]
    failed = [
        0.5 * (balls.centres[balls.pairs[~kept, 0]] + balls.centres[balls.pairs[~kept, 1]]),
        balls.centres[corner_balls[corners < 0]],
    ]
    return MeshFeatures(
        curves=[mesh_of[c] for c in balls.chains],
        corners=corners,
        sources=[c.source for c in graph.curves],
        held=bool(kept.all() and (corners >= 0).all()),
        edges=len(kept),
        edges_kept=int(kept.sum()),
        corners_kept=int((corners >= 0).sum()),
        failed=np.concatenate(failed),
        balls=b,
    )


def repair_sites(
    mesh, angle: float, soft: tuple[np.ndarray, np.ndarray] | None = None,
    rim_balls: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:  # fmt: skip
    """Where to shrink the balls of a mesh: the failed places of its feature
    check, and the ball centres of triangles below ``angle`` degrees.
    Returns ``(points (k, 3), radii (k,))``: each place and the radius about
    it within which balls shrink. The ``rim_balls`` (mesh vertex ids of the
    balls on an open mesh's rims only) start no angle repair: the input's rim
    bounds the angles there (a cut rim turns sharply, and its corners can be a
    tiny edge apart). Places whose nearest ball is one of the
    ``soft`` balls (``(centres, is_soft)``: a volume's kink curves) are left
    out: beside a thin wedge, smaller balls make the wedge thinner at their
    edge, so refinement stops at the spacing floor in more places and the
    angles next to them do not rise (measured: RESULTS.md, issue 30). For
    the same reason, places whose shrinking reach holds a point the run left
    unresolved (``mesh.unresolved``: sheets closer than the floor, or a
    singular point, as where two solids of a union touch) are left out."""
    f = mesh.features
    w = mesh.weights
    r_max = float(np.sqrt(w.max())) if w is not None and len(w) and w.max() > 0 else 0.0
    pts = [f.failed]
    rad = [np.full(len(f.failed), 2.0 * r_max)]
    if len(mesh.faces):
        low = mesh.angles < angle
        heavy = w[mesh.faces] > 0
        if rim_balls is not None and len(rim_balls):
            heavy &= ~np.isin(mesh.faces, rim_balls)
        hit = low[:, None] & heavy
        ids = np.unique(mesh.faces[hit])
        pts.append(mesh.vertices[ids])
        rad.append(2.0 * np.sqrt(w[ids]))
    pts, rad = np.concatenate(pts), np.concatenate(rad)
    if soft is not None and len(pts) and soft[1].any():
        _, j = cKDTree(soft[0]).query(pts)
        pts, rad = pts[~soft[1][j]], rad[~soft[1][j]]
    unresolved = getattr(mesh, "unresolved", None)
    if unresolved is not None and len(unresolved) and len(pts):
        d, _ = cKDTree(unresolved).query(pts)
        pts, rad = pts[d > rad], rad[d > rad]
    return pts, rad
