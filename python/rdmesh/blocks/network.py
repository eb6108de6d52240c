"""The seams as one network of curves, protected once, and each block's share of it.

The curves traced on every block face (:mod:`rdmesh.blocks.trace`) form one
:class:`~rdmesh.features.FeatureGraph`: curves on faces between blocks
("block seam") and on the volume's own box ("clip boundary"), meeting at the
corners where the isosurface crosses a block edge (each shared by the faces
around that edge, up to four). :func:`rdmesh.features.protect` places the
balls of the whole network at once, so Mesh_3's rules hold across faces
(balls of curves on two faces around a block edge stay apart, corners get one
ball). The centres are then put on the true curve by Newton steps within
their face, by the task that traced it (:func:`project_on_face`), and each
block gets exactly the balls of its six faces (:func:`share`): the two blocks
at a face insert the same centres, so their meshes have the same boundary
vertices and edges there.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._vectors import row_norms
from ..features import Balls, FeatureCurve, FeatureGraph, ProtectingBalls, protect
from ..features.graph import build_graph
from .layout import Face, Layout
from .trace import FaceTrace

log = logging.getLogger("rdmesh")

#: Sources of the network's curves.
SEAM, OUTER = "block seam", "clip boundary"


@dataclass
class Network:
    """The protected seam curves of every face.

    Attributes
    ----------
    graph : the curves and corners.
    balls : their protecting balls (centres projected once :func:`set_centres` ran).
    faces : every face, in the layout's order.
    curve_face : (curves,) int64 the face of each curve (an index into ``faces``).
    """

    graph: FeatureGraph
    balls: Balls
    faces: list[Face]
    curve_face: np.ndarray


def network_graph(layout: Layout, traces: list[FaceTrace], radius: float) -> tuple:
    """The graph of every traced curve, and the face of each of its curves.

    Returns ``(graph, curve_face)``; curves on the volume's own box are
    "clip boundary" curves, the others "block seam"."""
    curves, where = [], {}
    for i, tr in enumerate(traces):
        source = OUTER if layout.is_outer(tr.face) else SEAM
        for n, (p, closed) in enumerate(zip(tr.curves, tr.closed, strict=True)):
            label = f"the curve {n} on block face {tr.face}"
            curves.append(FeatureCurve(p, closed, source, None, label))
            where[label] = i
    if not curves:
        return FeatureGraph(), np.zeros(0, np.int64)
    graph = build_graph(curves, radius)
    return graph, np.array([where[c.label] for c in graph.curves], np.int64)


def protect_network(
    layout: Layout,
    traces: list[FaceTrace],
    radius: float,
    edge_size: Callable[[np.ndarray], np.ndarray],
    distance: float | None,
    shrink: list[tuple[np.ndarray, np.ndarray]],
) -> Network:
    """Protecting balls on every traced curve, placed once for the whole volume
    (centres on the traced polylines until :func:`set_centres`)."""
    graph, curve_face = network_graph(layout, traces, radius)
    faces = [tr.face for tr in traces]
    if graph.empty:
        return Network(graph, _no_balls(), faces, curve_face)
    balls = protect(graph, edge_size, radius, None, (OUTER,), distance, shrink)
    log.info(
        "blocks: %d seam curves, %d corners, %d protecting balls (radii %.3g to %.3g)",
        len(graph.curves), len(graph.corners), len(balls), balls.radii.min(), balls.radii.max(),
    )  # fmt: skip
    return Network(graph, balls, faces, curve_face)


def _no_balls() -> Balls:
    i0 = np.zeros(0, np.int64)
    return Balls(np.zeros((0, 3)), np.zeros(0), i0, i0, np.zeros((0, 2), np.int64), i0, index=i0)


def centres_to_project(net: Network, face_index: int) -> np.ndarray:
    """The balls on the curves of one face (indices), corners excepted."""
    on = net.balls.curve >= 0
    face = np.full(len(net.balls), -1)
    face[on] = net.curve_face[net.balls.curve[on]]
    return np.flatnonzero(face == face_index)


def set_centres(net: Network, which: np.ndarray, x: np.ndarray, on: np.ndarray) -> int:
    """Move the balls ``which`` to their projections ``x``; a centre whose
    projection did not converge goes to the nearest traced point of its curve
    instead (a root of ``f`` on a grid edge). Returns how many did so."""
    b = net.balls
    b.centres[which[on]] = x[on]
    stuck = which[~on]
    for i in stuck:
        pts = net.graph.curves[b.curve[i]].points
        b.centres[i] = pts[int(np.argmin(row_norms(pts - b.centres[i])))]
    return len(stuck)


def settle(balls: Balls) -> int:
    """Mesh_3's invariants made to hold again after the centres moved: balls
    that meet but are not consecutive shrink to their distance / 2.1, and
    consecutive balls to 0.9 times their distance where one holds the
    other's centre (the core would hide it). Returns how many radii changed
    (a centre moves by at most the traced polyline's sagitta, a few hundredths
    of its segment, so this is rare; a consecutive pair that no longer
    overlaps then fails the blocks' feature check, which shrinks the balls
    there and meshes again)."""
    c, r = balls.centres, balls.radii
    if len(c) < 2:
        return 0
    before = r.copy()
    tree = cKDTree(c)
    pairs = np.array(sorted(tree.query_pairs(2.0 * float(r.max()))), np.int64).reshape(-1, 2)
    if not len(pairs):
        return 0
    n = len(c)
    i, j = pairs[:, 0], pairs[:, 1]
    d = row_norms(c[i] - c[j])
    p = np.sort(balls.pairs, axis=1)
    cons = np.isin(i * n + j, p[:, 0] * n + p[:, 1])
    meet = ~cons & (d <= (r[i] + r[j]) * (1.0 + 1e-9))
    np.minimum.at(r, i[meet], d[meet] / 2.1)
    np.minimum.at(r, j[meet], d[meet] / 2.1)
    hold = cons & (d <= np.maximum(r[i], r[j]) * (1.0 + 1e-9))
    np.minimum.at(r, i[hold], 0.9 * d[hold])
    np.minimum.at(r, j[hold], 0.9 * d[hold])
    return int((r != before).sum())


def share(net: Network, face_ids: list[int]) -> ProtectingBalls:
    """The balls of the curves on the given faces (a block's six), with the
    corners they end at, renumbered; every curve bounds the block's mesh."""
    b, g = net.balls, net.graph
    curves = np.flatnonzero(np.isin(net.curve_face, face_ids))
    if not len(curves):
        return ProtectingBalls(_no_balls(), FeatureGraph())
    ends = g.ends[curves]
    corners = np.unique(ends[ends >= 0])
    keep = np.isin(b.curve, curves) | np.isin(b.corner, corners) & (b.corner >= 0)
    old = np.flatnonzero(keep)
    new = np.full(len(b), -1, np.int64)
    new[old] = np.arange(len(old))
    curve_new = np.full(len(g.curves), -1, np.int64)
    curve_new[curves] = np.arange(len(curves))
    corner_new = np.full(len(g.corners), -1, np.int64)
    corner_new[corners] = np.arange(len(corners))
    mine = np.isin(b.pair_curve, curves)
    sub = Balls(
        centres=b.centres[old].copy(),
        radii=b.radii[old].copy(),
        curve=np.where(b.curve[old] >= 0, curve_new[np.maximum(b.curve[old], 0)], -1),
        corner=np.where(b.corner[old] >= 0, corner_new[np.maximum(b.corner[old], 0)], -1),
        pairs=new[b.pairs[mine]],
        pair_curve=curve_new[b.pair_curve[mine]],
        chains=[new[b.chains[i]] for i in curves],
        boundary=np.ones(len(curves), bool),
        index=b.index[old].copy(),
    )
    graph = FeatureGraph(
        [g.curves[i] for i in curves],
        g.corners[corners],
        np.where(ends >= 0, corner_new[np.maximum(ends, 0)], -1),
    )
    return ProtectingBalls(sub, graph)
