"""A triangle mesh's sharp edges, chained into feature curves.

An edge is sharp when its two faces' normals differ by at least the feature
angle (CGAL's ``detect_features`` rule). Sharp edges are chained into
polylines split at corners: vertices with other than two sharp edges, and
vertices where the chain turns by at least the feature angle.
"""

from __future__ import annotations

import logging

import numpy as np

from .._vectors import row_norms

log = logging.getLogger("rdmesh")


def sharp_edges(faces: np.ndarray, normals: np.ndarray, angle: float) -> np.ndarray:
    """Edges ``(E, 2)`` (sorted vertex pairs) shared by exactly two faces whose
    unit ``normals`` differ by at least ``angle`` degrees."""
    e, cos = _edge_cosines(faces, normals)
    return e[cos <= np.cos(np.radians(angle)) + 1e-12]


def _edge_cosines(faces: np.ndarray, normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges shared by exactly two faces (sorted vertex pairs) and the
    cosine of the angle between those faces' unit ``normals``."""
    e, pair, _ = two_face_edges(faces)
    return e, np.einsum("ij,ij->i", normals[pair[:, 0]], normals[pair[:, 1]])


def two_face_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The edges shared by exactly two faces: ``(E, 2)`` sorted vertex pairs,
    in order; ``(E, 2)`` their two faces; ``(E, 2)`` bool, whether each face
    runs along the edge from its lower vertex to its higher."""
    f = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    owner = np.tile(np.arange(len(f)), 3)
    e = np.sort(directed, axis=1)
    order = np.lexsort((e[:, 1], e[:, 0]))
    e, owner, forward = e[order], owner[order], (directed[:, 0] < directed[:, 1])[order]
    same = np.all(e[1:] == e[:-1], axis=1)
    # Pairs (i, i + 1) of the same edge, and only two faces on it.
    first = np.flatnonzero(same)
    triple = np.zeros(len(first), bool)
    if len(first):
        nxt = first + 2
        triple |= (nxt < len(e)) & np.all(e[np.minimum(nxt, len(e) - 1)] == e[first], axis=1)
        prv = first - 1
        triple |= (prv >= 0) & np.all(e[np.maximum(prv, 0)] == e[first], axis=1)
    first = first[~triple]
    both = np.c_[first, first + 1]
    return e[first], owner[both], forward[both]


def chain_edges(
    vertices: np.ndarray, edges: np.ndarray, turn: float
) -> tuple[list[np.ndarray], list[bool]]:
    """Sharp edges as polylines in order, split at corners (vertices of other
    than two sharp edges, or turning by at least ``turn`` degrees).

    Returns the polylines (vertex index arrays) and whether each is a closed
    loop (its first vertex not repeated)."""
    if len(edges) == 0:
        return [], []
    n = len(vertices)
    deg = np.bincount(edges.ravel(), minlength=n)
    # The two sharp neighbours of each vertex of degree 2.
    src = np.concatenate([edges[:, 0], edges[:, 1]])
    dst = np.concatenate([edges[:, 1], edges[:, 0]])
    o = np.lexsort((dst, src))
    src, dst = src[o], dst[o]
    start = np.searchsorted(src, np.arange(n))
    two = np.flatnonzero(deg == 2)
    nb = np.full((n, 2), -1, np.int64)
    nb[two, 0] = dst[start[two]]
    nb[two, 1] = dst[start[two] + 1]
    corner = (deg > 0) & (deg != 2)
    if len(two):
        u = vertices[two] - vertices[nb[two, 0]]
        w = vertices[nb[two, 1]] - vertices[two]
        cos = np.einsum("ij,ij->i", u, w) / np.maximum(row_norms(u) * row_norms(w), 1e-300)
        corner[two[cos <= np.cos(np.radians(turn))]] = True
    polylines, closed = [], []
    # Open chains: from each corner along each of its sharp edges.
    c_src = src[corner[src]]
    c_dst = dst[corner[src]]
    walks = [list(pair) for pair in zip(c_src.tolist(), c_dst.tolist(), strict=True)]
    done_edges = set()
    for w in walks:
        a, b = w
        key = (min(a, b), max(a, b))
        if key in done_edges and corner[b]:
            continue
        path = [a, b]
        prev, cur = a, b
        while not corner[cur]:
            n0, n1 = nb[cur]
            nxt = n0 if n0 != prev else n1
            path.append(int(nxt))
            prev, cur = cur, int(nxt)
        key_end = (min(path[-2], path[-1]), max(path[-2], path[-1]))
        if key in done_edges or key_end in done_edges:
            continue
        for p, q in zip(path[:-1], path[1:], strict=True):
            done_edges.add((min(p, q), max(p, q)))
        polylines.append(np.array(path, np.int64))
        closed.append(False)
    # Loops without a corner.
    left = np.zeros(n, bool)
    for p in polylines:
        left[p] = True
    rest = np.flatnonzero((deg == 2) & ~corner & ~left)
    seen = np.zeros(n, bool)
    for v0 in rest.tolist():
        if seen[v0]:
            continue
        path, prev, cur = [v0], -1, v0
        seen[v0] = True
        while True:
            n0, n1 = nb[cur]
            nxt = int(n0 if n0 != prev else n1)
            if nxt == v0:
                break
            path.append(nxt)
            seen[nxt] = True
            prev, cur = cur, nxt
        polylines.append(np.array(path, np.int64))
        closed.append(True)
    return polylines, closed


#: Sharp-edge chains shorter than this (edges) with a dangling end are noise.
MIN_CHAIN_EDGES = 4
#: feature_angle="auto": sharp edges are the surface's roughness, not creases,
#: when more than ROUGH_RATIO times as many edges are nearly as sharp (normals
#: between half the angle and the angle apart). A CAD part's creases stand
#: apart (almost no edge between 30 and 60 degrees); a coarse organic mesh's
#: sharpest edges are the tail of a spread (the cow, a cortical white surface:
#: 3.3 and 6.5 times; a marching-cubes union of two tori: 1.04).
ROUGH_RATIO = 2.0
#: feature_angle="auto": this angle, and no sharp edges at all when they look
#: like noise: at least NOISE_CURVES curves, the median at most NOISE_CHAIN
#: edges long, and fewer than NOISE_SHARE of all edges sharp (a CAD part's
#: creases are long, or a large share of its edges).
AUTO_FEATURE_ANGLE, NOISE_CURVES, NOISE_CHAIN, NOISE_SHARE = 60.0, 50, 2, 0.2


def _rough(cos: np.ndarray, sharp: np.ndarray, angle: float) -> bool:
    """Whether the sharp edges look like the surface's roughness (see
    :data:`ROUGH_RATIO`); logs a warning when they do."""
    near = int(np.count_nonzero(~sharp & (cos <= np.cos(np.radians(angle / 2)))))
    count = int(np.count_nonzero(sharp))
    if count == 0 or near <= ROUGH_RATIO * count:
        return False
    log.warning(
        "MeshSurface: %d sharp edges look like the surface's roughness, not creases: %d "
        "more edges are nearly as sharp (normals %g to %g degrees apart); none are kept "
        "(give feature_angle= to keep them)", count, near, angle / 2, angle,
    )  # fmt: skip
    return True


def feature_angle_of(angle) -> float | None:
    """The checked ``feature_angle``: None, or a number of degrees in (0, 180)
    ("auto" is resolved by :func:`sharp_curves`)."""
    if angle is None:
        return None
    try:
        a = float(angle)
    except (TypeError, ValueError):
        a = float("nan")
    if isinstance(angle, bool) or not 0.0 < a < 180.0:
        raise ValueError(
            f"feature_angle must be None, 'auto' or degrees in (0, 180), got {angle!r}"
        )
    return a


def sharp_curves(
    vertices: np.ndarray, faces: np.ndarray, feature_angle
) -> tuple[float | None, np.ndarray, list[np.ndarray]]:
    """A mesh's sharp edges chained into curves, for ``MeshSurface``.

    Returns ``(angle, edges (E, 2), curves)``: the angle used, the kept sharp
    edges, and their chains as polylines (a closed loop repeats its first
    point). Chains of fewer than :data:`MIN_CHAIN_EDGES` edges with a dangling
    end are left out as noise; with ``feature_angle="auto"`` everything is
    left out when the whole looks like noise (see :data:`NOISE_CURVES`) or
    like the surface's roughness (see :data:`ROUGH_RATIO`).
    """
    auto = isinstance(feature_angle, str) and feature_angle == "auto"
    angle = AUTO_FEATURE_ANGLE if auto else feature_angle_of(feature_angle)
    none = (angle, np.zeros((0, 2), np.int64), [])
    if angle is None:
        return none
    a = np.cross(
        vertices[faces[:, 1]] - vertices[faces[:, 0]],
        vertices[faces[:, 2]] - vertices[faces[:, 0]],
    )
    n = a / np.maximum(np.linalg.norm(a, axis=1), 1e-300)[:, None]
    edges, cos = _edge_cosines(faces, n)
    sharp = cos <= np.cos(np.radians(angle)) + 1e-12
    if auto and _rough(cos, sharp, angle):
        return none
    edges = edges[sharp]
    chains, closed = chain_edges(vertices, edges, angle)
    deg = np.bincount(edges.ravel(), minlength=len(vertices))
    keep = [
        cl or len(c) - 1 >= MIN_CHAIN_EDGES or (deg[c[0]] >= 3 and deg[c[-1]] >= 3)
        for c, cl in zip(chains, closed, strict=True)
    ]
    dropped = len(keep) - sum(keep)
    chains = [c for c, k in zip(chains, keep, strict=True) if k]
    closed = [cl for cl, k in zip(closed, keep, strict=True) if k]
    if not chains:
        return none
    kept = np.concatenate(
        [
            np.c_[c, np.roll(c, -1)] if cl else np.c_[c[:-1], c[1:]]
            for c, cl in zip(chains, closed, strict=True)
        ]
    )
    curves = [
        vertices[np.r_[c, c[:1]]] if cl else vertices[c]
        for c, cl in zip(chains, closed, strict=True)
    ]
    lengths = [len(c) - 1 for c in curves]
    if auto and (
        len(lengths) >= NOISE_CURVES
        and float(np.median(lengths)) <= NOISE_CHAIN
        and len(kept) < NOISE_SHARE * 1.5 * len(faces)
    ):
        log.warning(
            "MeshSurface: %d sharp edges in %d short curves look like noise; none are kept "
            "(give feature_angle= to keep them)", len(kept), len(curves),
        )  # fmt: skip
        return none
    log.info(
        "MeshSurface: %d sharp edges (normals %g degrees apart or more) in %d curves; %d short "
        "dangling chains left out (noise)", len(kept), angle, len(curves), dropped,
    )  # fmt: skip
    return angle, np.sort(kept, axis=1), curves
