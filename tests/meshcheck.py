"""Independent mesh checks for the test suite.

Nothing here uses rdmesh's own combinatorics (``rdmesh.topology.complex``) or
geometry helpers (``rdmesh.criteria``): every property is recomputed from the
raw vertex and face arrays so that a bug in the library cannot hide itself.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components


def edge_counts(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Directed and undirected edge multiplicities.

    Returns ``(undirected_edges (E, 2), undirected_count (E,), directed_count (D,))``.
    """
    f = np.asarray(faces, dtype=np.int64)
    directed = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    _, d_count = np.unique(directed, axis=0, return_counts=True)
    und = np.sort(directed, axis=1)
    edges, u_count = np.unique(und, axis=0, return_counts=True)
    return edges, u_count, d_count


def boundary_edges(faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The edges in exactly one face ``(B, 2)`` (each ``i < j``), and their vertex ids."""
    edges, count, _ = edge_counts(faces)
    b = edges[count == 1]
    return b, np.unique(b)


def _link_graph(faces: np.ndarray, n_vertices: int):
    """Every vertex's link as one graph: the link of ``v`` in face ``(v, w1, w2)``
    is the edge ``w1-w2``. Returns each link node's owner vertex, its degree
    and the label of its connected piece."""
    f = np.asarray(faces, dtype=np.int64)
    v = np.concatenate([f[:, 0], f[:, 1], f[:, 2]])
    w1 = np.concatenate([f[:, 1], f[:, 2], f[:, 0]])
    w2 = np.concatenate([f[:, 2], f[:, 0], f[:, 1]])
    n = np.int64(n_vertices)
    nodes, inv = np.unique(np.concatenate([v * n + w1, v * n + w2]), return_inverse=True)
    degree = np.bincount(inv, minlength=len(nodes))
    m = len(nodes)
    g = coo_matrix((np.ones(len(v)), (inv[: len(v)], inv[len(v) :])), shape=(m, m))
    _, label = connected_components(g, directed=False)
    return nodes // n, degree, label


def _pieces_per_vertex(owner, label, n_vertices: int) -> np.ndarray:
    pairs = np.unique(np.column_stack([owner, label]), axis=0)
    return np.bincount(pairs[:, 0], minlength=n_vertices)


def vertex_link_cycles(faces: np.ndarray, n_vertices: int) -> np.ndarray:
    """For each vertex, the number of cycles in its link, or -1 if the link is
    not a disjoint union of cycles (some link vertex has degree != 2).

    Vertices without faces get 0.
    """
    owner, degree, label = _link_graph(faces, n_vertices)
    cycles = _pieces_per_vertex(owner, label, n_vertices)
    cycles[np.unique(owner[degree != 2])] = -1
    return cycles


def closed_manifold_problems(faces: np.ndarray, n_vertices: int) -> list[str]:
    """Empty list when ``faces`` is a closed, consistently oriented 2-manifold."""
    f = np.asarray(faces, dtype=np.int64)
    problems = []
    if len(f) == 0:
        return ["no faces"]
    if f.min() < 0 or f.max() >= n_vertices:
        problems.append("face index out of range")
        return problems
    if np.any((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])):
        problems.append("degenerate face with a repeated vertex")
    if len(np.unique(np.sort(f, axis=1), axis=0)) != len(f):
        problems.append("duplicate faces")
    _, u_count, d_count = edge_counts(f)
    if np.any(u_count != 2):
        problems.append(
            f"{int(np.sum(u_count != 2))} edges not in exactly 2 faces "
            f"(counts {sorted(set(u_count.tolist()))})"
        )
    if np.any(d_count != 1):
        problems.append(
            f"{int(np.sum(d_count != 1))} directed edges repeated: inconsistent winding"
        )
    used = np.unique(f)
    cycles = vertex_link_cycles(f, n_vertices)[used]
    if np.any(cycles != 1):
        problems.append(f"{int(np.sum(cycles != 1))} vertices whose link is not one cycle")
    return problems


def vertex_link_paths(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, np.ndarray]:
    """For each vertex, the number of connected pieces of its link and the
    largest degree in it ``((V,), (V,))``.

    A vertex is a manifold vertex (inside or on the boundary) when its link is
    one piece of degree at most 2: one cycle, or one path. Vertices without
    faces get ``(0, 0)``.
    """
    owner, degree, label = _link_graph(faces, n_vertices)
    pieces = _pieces_per_vertex(owner, label, n_vertices)
    top = np.zeros(n_vertices, dtype=np.int64)
    np.maximum.at(top, owner, degree)
    return pieces, top


def manifold_with_boundary_problems(faces: np.ndarray, n_vertices: int) -> list[str]:
    """Empty list when ``faces`` is a consistently oriented 2-manifold with a
    non-empty boundary: every edge in one or two faces (some in one), every
    vertex's link one cycle or one path."""
    f = np.asarray(faces, dtype=np.int64)
    if len(f) == 0:
        return ["no faces"]
    problems = []
    if np.any((f[:, 0] == f[:, 1]) | (f[:, 1] == f[:, 2]) | (f[:, 0] == f[:, 2])):
        problems.append("degenerate face with a repeated vertex")
    _, u_count, d_count = edge_counts(f)
    if np.any(u_count > 2):
        problems.append(f"{int(np.sum(u_count > 2))} edges in more than 2 faces")
    if not np.any(u_count == 1):
        problems.append("no boundary edge")
    if np.any(d_count != 1):
        problems.append(
            f"{int(np.sum(d_count != 1))} directed edges repeated: inconsistent winding"
        )
    pieces, top = vertex_link_paths(f, n_vertices)
    used = np.unique(f)
    bad = (pieces[used] != 1) | (top[used] > 2)
    if bad.any():
        problems.append(f"{int(bad.sum())} vertices whose link is not one cycle or one path")
    return problems


def boundary_loop_count(faces: np.ndarray) -> int:
    """The number of boundary loops: connected pieces of the boundary edges."""
    b, verts = boundary_edges(faces)
    if len(b) == 0:
        return 0
    idx = np.searchsorted(verts, b)
    k = len(verts)
    g = coo_matrix((np.ones(len(b)), (idx[:, 0], idx[:, 1])), shape=(k, k))
    return int(connected_components(g, directed=False)[0])


def face_components(faces: np.ndarray, n_vertices: int) -> tuple[int, np.ndarray]:
    """Connected components of faces sharing a vertex: (count, label per face)."""
    f = np.asarray(faces, dtype=np.int64)
    F = len(f)
    rows = np.repeat(np.arange(F), 3)
    g = coo_matrix((np.ones(3 * F), (rows, f.ravel() + F)), shape=(F + n_vertices,) * 2)
    _, label = connected_components(g, directed=False)
    face_label = label[:F]
    uniq, dense = np.unique(face_label, return_inverse=True)
    return len(uniq), dense


def euler_per_component(faces: np.ndarray, n_vertices: int) -> list[int]:
    """V - E + F of each component, sorted descending."""
    f = np.asarray(faces, dtype=np.int64)
    count, label = face_components(f, n_vertices)
    out = []
    for k in range(count):
        sub = f[label == k]
        V = len(np.unique(sub))
        E = len(
            np.unique(
                np.sort(np.concatenate([sub[:, [0, 1]], sub[:, [1, 2]], sub[:, [2, 0]]]), axis=1),
                axis=0,
            )
        )
        out.append(V - E + len(sub))
    return sorted(out, reverse=True)


def triangle_angles_deg(corners: np.ndarray) -> np.ndarray:
    """The three interior angles (degrees) of each triangle, by arccos, ``(k, 3)``."""
    out = np.empty(corners.shape[:2])
    for i in range(3):
        p = corners[:, i]
        u = corners[:, (i + 1) % 3] - p
        v = corners[:, (i + 2) % 3] - p
        cos = np.einsum("ij,ij->i", u, v) / (np.linalg.norm(u, axis=1) * np.linalg.norm(v, axis=1))
        out[:, i] = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
    return out


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unnormalised right-hand normals ``(v1 - v0) x (v2 - v0)``."""
    p = vertices[faces]
    return np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])


def numeric_gradient(f, points: np.ndarray, h: float = 1e-6) -> np.ndarray:
    """Central differences of a vectorised ``f`` at ``(n, 3)`` points."""
    pts = np.asarray(points, dtype=float)
    g = np.empty_like(pts)
    for k in range(3):
        e = np.zeros(3)
        e[k] = h
        g[:, k] = (f(pts + e) - f(pts - e)) / (2 * h)
    return g


def distance_to_surface(f, grad, points: np.ndarray) -> np.ndarray:
    """First-order distance estimate ``|f| / |grad f|``."""
    return np.abs(f(points)) / np.linalg.norm(grad(points), axis=1)


def assert_good_mesh(
    mesh,
    f,
    grad,
    bounding_radius: float,
    *,
    angle_bound: float = 30.0,
    sizing=None,
    euler: list[int] | None = None,
    distance_bound: float | None = None,
) -> None:
    """Every guarantee of a finished run, checked independently.

    ``sizing`` maps ``(k, 3)`` points to the radius bound there (or is a number).
    ``euler`` is the expected Euler characteristic per component, largest first.
    """
    V, F, C = mesh.vertices, mesh.faces, mesh.facet_centres
    assert V.ndim == 2 and V.shape[1] == 3 and F.ndim == 2 and F.shape[1] == 3
    assert C.shape == F.shape
    assert mesh.complete
    assert len(mesh.unresolved) == 0
    # Closed, consistently oriented 2-manifold.
    assert closed_manifold_problems(F, len(V)) == []
    # Every vertex is used by a face.
    assert np.array_equal(np.unique(F), np.arange(len(V)))
    if euler is not None:
        assert euler_per_component(F, len(V)) == euler
    # Samples and surface centres lie on the surface.
    tol = 1e-6 * bounding_radius
    assert distance_to_surface(f, grad, V).max() <= tol
    assert distance_to_surface(f, grad, C).max() <= tol
    # The surface centre is on the facet's dual Voronoi edge: equal power to
    # the three corners (the distance, without protecting balls).
    w = np.zeros(len(V)) if mesh.weights is None else mesh.weights
    d = np.sqrt(np.maximum(np.sum((C[:, None, :] - V[F]) ** 2, axis=2) - w[F], 0.0))
    assert np.all(np.abs(d - d[:, :1]) <= 1e-7 * d[:, :1] + 1e-12)
    # The criteria hold on triangles without a protecting ball's centre;
    # those with one get Mesh_3's relaxation (at least 20 degrees, measured).
    free = ~(w[F] > 0).any(axis=1)
    if angle_bound > 0:
        angles = triangle_angles_deg(V[F])
        assert angles[free].min() >= angle_bound - 1e-9
        if not free.all():
            assert angles[~free].min() >= min(angle_bound, 20.0)
    # Size bound at each surface centre.
    if sizing is not None:
        psi = sizing(C) if callable(sizing) else np.full(len(C), float(sizing))
        assert np.all(d.max(axis=1)[free] <= psi[free] * (1 + 1e-9))
    # Distance bound: circumcentre of the triangle to its surface centre.
    if distance_bound is not None:
        gap = np.linalg.norm(circumcentre_ref(V[F]) - C, axis=1)
        assert np.all(gap[free] <= distance_bound * (1 + 1e-9))
    if mesh.features is not None:
        assert mesh.features.held
    # Outward orientation: the right-hand normal points towards f > 0.
    n = face_normals(V, F)
    assert np.all(np.einsum("ij,ij->i", n, grad(C)) > 0)


def circumcentre_ref(corners: np.ndarray) -> np.ndarray:
    """Circumcentres by solving the 3x3 linear system of each triangle."""
    a, b, c = corners[:, 0], corners[:, 1], corners[:, 2]
    n = np.cross(b - a, c - a)
    A = np.stack([b - a, c - a, n], axis=1)
    rhs = np.stack(
        [
            0.5 * np.einsum("ij,ij->i", b - a, b - a),
            0.5 * np.einsum("ij,ij->i", c - a, c - a),
            np.zeros(len(a)),
        ],
        axis=1,
    )
    return a + np.linalg.solve(A, rhs[:, :, None])[:, :, 0]


def restricted_delaunay_reference(f, vertices, centre, radius, n_samples=24):
    """The restricted Delaunay triangulation of ``vertices``, from scratch.

    Uses scipy's (Qhull) Delaunay triangulation of the vertices plus eight far
    points (as the library does, so that no dual is a ray inside the ball),
    clips every dual Voronoi edge to the bounding ball and counts the sign
    changes of ``f`` at ``n_samples + 1`` points along it.

    Returns
    -------
    keys : (k,) int64 sorted-triple keys ``a * n^2 + b * n + c`` of all facets
        between sample vertices whose clipped dual meets the ball.
    changes : (k,) number of sign changes found along each dual.
    """
    from scipy.spatial import Delaunay

    V = np.asarray(vertices, float)
    n = len(V)
    c0 = np.asarray(centre, float)
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    P = np.concatenate([V, c0 + 4.0 * radius * corners])
    dt = Delaunay(P)
    simp, nb = dt.simplices, dt.neighbors
    A = P[simp]
    M = A[:, 1:] - A[:, :1]
    rhs = 0.5 * np.einsum("ijk,ijk->ij", M, M)
    det = np.linalg.det(M)
    # Cells among the (cospherical) far points can be flat: no circumcentre.
    ok_cell = np.abs(det) > 1e-14 * np.einsum("ijk,ijk->i", M, M) ** 1.5
    cc = np.full((len(simp), 3), np.nan)
    cc[ok_cell] = A[ok_cell, 0] + np.linalg.solve(M[ok_cell], rhs[ok_cell][:, :, None])[:, :, 0]
    cell = np.repeat(np.arange(len(simp)), 4)
    opp = np.tile(np.arange(4), len(simp))
    other = nb[cell, opp]
    keep = (other >= 0) & (cell < other)
    cell, opp, other = cell[keep], opp[keep], other[keep]
    tri = np.stack([simp[cell, (opp + k) % 4] for k in (1, 2, 3)], axis=1)
    keep = np.all(tri < n, axis=1)
    tri, a, b = tri[keep], cc[cell[keep]], cc[other[keep]]
    # Clip [a, b] to the ball.
    d = b - a
    f0 = a - c0
    AA = np.einsum("ij,ij->i", d, d)
    BB = np.einsum("ij,ij->i", f0, d)
    CC = np.einsum("ij,ij->i", f0, f0) - radius * radius
    with np.errstate(invalid="ignore", divide="ignore"):
        disc = BB * BB - AA * CC
        sq = np.sqrt(np.where(disc > 0, disc, 0.0))
        lo = np.maximum(0.0, (-BB - sq) / AA)
        hi = np.minimum(1.0, (-BB + sq) / AA)
        ok = np.isfinite(disc) & (disc > 0) & (AA > 0) & (lo < hi)
    tri, a, d, lo, hi = tri[ok], a[ok], d[ok], lo[ok], hi[ok]
    t = lo[:, None] + (hi - lo)[:, None] * np.linspace(0.0, 1.0, n_samples + 1)[None, :]
    F = f((a[:, None, :] + t[:, :, None] * d[:, None, :]).reshape(-1, 3)).reshape(t.shape)
    inside = F < 0
    changes = np.sum(inside[:, 1:] != inside[:, :-1], axis=1)
    return triple_keys(tri, n), changes


def triple_keys(tri: np.ndarray, n: int) -> np.ndarray:
    """Order-independent int64 key of each vertex triple."""
    s = np.sort(np.asarray(tri, np.int64), axis=1)
    return (s[:, 0] * n + s[:, 1]) * n + s[:, 2]
