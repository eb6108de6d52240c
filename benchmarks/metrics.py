# SPDX-License-Identifier: GPL-3.0-or-later
"""Quality metrics of a triangle mesh of an implicit surface, for the benchmarks.

Everything here is vectorised numpy/scipy and works on plain arrays, so the
same code measures the output of every mesher (rdmesh, the CGAL reference,
pygalmesh, marching cubes):

- :func:`compact` drops unused vertices (CGAL's OFF output may keep some).
- :func:`angle_stats`: smallest angle, fraction of angles below 30 degrees and
  a histogram of each triangle's smallest angle.
- :func:`topology_stats`: closed manifold (or with boundary: loops), components and Euler
  characteristic against the expected values (``rdmesh.topology.complex`` helpers).
- :func:`hausdorff`: the sampled two-sided Hausdorff distance between the mesh
  and the surface ``f = 0``.

Hausdorff method
----------------
*Mesh to surface.*  Samples on the mesh: every vertex, every face centroid and
``n`` points drawn uniformly by area (seeded).  Each sample ``p`` is projected
onto the surface by Newton's method along the line through ``p`` in the
direction of ``grad f(p)`` (a 1-D root search ``f(p + t n) = 0`` started at
the first-order estimate ``t = -f / |grad f|``).  The root found is a point of
the surface, so ``|t|`` is an upper bound of the distance to the surface, and
for the distances met here (far below the local feature size) it equals the
true distance up to terms of order ``t^2 * curvature``.  Samples where the
line search fails (no convergence, a point leaving the bounding sphere) fall
back to a projection along the gradient path, ``q <- q - f grad f / |grad
f|^2``; the number of samples that needed it is reported.

*Surface to mesh.*  Reference points on the surface, independent of any
mesher: the vertices of a fine marching-cubes mesh of ``f`` over the surface's
bounding box (grid spacing chosen for the requested number of points),
projected onto the surface as above (:func:`surface_reference`; the suite
caches them per surface).  For each reference point the exact distance to the
mesh is the smallest point-to-triangle distance over candidate triangles: the
``k`` triangles whose centroids are nearest (``scipy.spatial.cKDTree``).  A
minimum over a subset is again an upper bound; with ``k = 16`` it is exact
unless a triangle far longer than its neighbours passes closer than all of
them.

Both directions are sampled, so the maxima are lower estimates of the true
Hausdorff distance; the true value lies between the reported one and that plus
about the sample spacing times the local slope of the distance.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from scipy.spatial import cKDTree

__all__ = [
    "ANGLE_HIST_EDGES",
    "angle_stats",
    "compact",
    "distance_to_surface",
    "hausdorff",
    "mesh_area",
    "mesh_samples",
    "point_triangle_distance",
    "surface_reference",
    "surface_to_mesh",
    "topology_stats",
    "triangle_angles",
]

#: Bins of the smallest-angle histograms: 0.5 degree wide, 0 to 60 degrees
#: (a triangle's smallest angle is at most 60).
ANGLE_HIST_EDGES = np.linspace(0.0, 60.0, 121)

# Points per block in the projections and distance queries (memory bound).
_BLOCK = 1 << 20


def compact(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Drop vertices no face uses; returns ``(vertices, faces)`` renumbered."""
    vertices = np.asarray(vertices, dtype=np.float64).reshape(-1, 3)
    faces = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    used = np.unique(faces)
    if len(used) == len(vertices):
        return vertices, faces
    remap = np.full(len(vertices), -1, np.int64)
    remap[used] = np.arange(len(used))
    return vertices[used], remap[faces]


def mesh_area(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Total area of the triangles."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    return float(0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1).sum())


# ---------------------------------------------------------------------------
# Angles
# ---------------------------------------------------------------------------


def triangle_angles(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """The three angles of every triangle in degrees, ``(F, 3)``.

    Column ``i`` is the angle at corner ``i``.  Degenerate triangles (a
    zero-length edge) get angle 0 at the corners next to that edge.
    """
    out = np.empty((len(faces), 3))
    for i in range(3):
        p = vertices[faces[:, i]]
        u = vertices[faces[:, (i + 1) % 3]] - p
        v = vertices[faces[:, (i + 2) % 3]] - p
        # atan2(|u x v|, u.v) is accurate for small and large angles alike.
        s = np.linalg.norm(np.cross(u, v), axis=1)
        c = np.einsum("ij,ij->i", u, v)
        out[:, i] = np.degrees(np.arctan2(s, c))
    return out


def angle_stats(vertices: np.ndarray, faces: np.ndarray, bound: float = 30.0) -> dict[str, Any]:
    """Smallest angle, share of angles below ``bound`` and a histogram.

    Returns ``min_angle`` (degrees), ``frac_angles_below_30`` (of all 3F
    angles; the key names the default bound), ``frac_faces_below_30`` (faces
    whose smallest angle is below it) and ``min_angle_hist``: counts of each
    face's smallest angle in the bins :data:`ANGLE_HIST_EDGES`.
    """
    if len(faces) == 0:
        return {
            "min_angle": None,
            "frac_angles_below_30": None,
            "frac_faces_below_30": None,
            "min_angle_hist": [0] * (len(ANGLE_HIST_EDGES) - 1),
        }
    ang = triangle_angles(vertices, faces)
    smallest = ang.min(axis=1)
    hist, _ = np.histogram(np.clip(smallest, 0.0, 60.0), bins=ANGLE_HIST_EDGES)
    return {
        "min_angle": float(smallest.min()),
        "frac_angles_below_30": float(np.count_nonzero(ang < bound) / ang.size),
        "frac_faces_below_30": float(np.count_nonzero(smallest < bound) / len(smallest)),
        "min_angle_hist": hist.astype(int).tolist(),
    }


# ---------------------------------------------------------------------------
# Topology
# ---------------------------------------------------------------------------


def topology_stats(
    vertices: np.ndarray,
    faces: np.ndarray,
    expected_components: int | None = None,
    expected_euler: int | None = None,
    *,
    expected_loops: int | None = None,
    expected_per_component: list[int] | None = None,
) -> dict[str, Any]:
    """Closed manifold, components, Euler characteristic (V - E + F), boundary loops.

    ``closed_manifold``: every edge has exactly two faces and every used
    vertex one fan of faces (``rdmesh.topology.complex.complex_status``);
    ``manifold_with_boundary``: the same but with some edges in one face.
    ``euler`` is the total and ``euler_per_component`` the list, as
    ``rdmesh.topology.complex.euler_characteristics`` gives it;
    ``boundary_loops`` the total number of boundary loops.

    ``topology_ok`` is True when the mesh has the expected number of
    components and Euler characteristic (and, with
    ``expected_per_component``, the same sorted Euler characteristics per
    component) and is a closed manifold, or with ``expected_loops`` a
    manifold with that many boundary loops (closed for 0); None when
    nothing is expected.
    """
    from rdmesh.topology.complex import boundary_loops, complex_status, euler_characteristics

    n = len(vertices)
    faces = np.asarray(faces, dtype=np.int64)
    if len(faces) == 0:
        closed = with_boundary = False
        chi: list[int] = []
        loops = 0
    else:
        st = complex_status(faces, n)
        used = np.unique(faces)
        manifold = bool(np.all(st.edge_count <= 2) and np.all(st.vertex_fans[used] == 1))
        open_edges = bool(np.any(st.edge_count == 1))
        closed = manifold and not open_edges
        with_boundary = manifold and open_edges
        chi = euler_characteristics(faces, n)
        loops = sum(boundary_loops(faces, n)) if open_edges else 0
    res: dict[str, Any] = {
        "closed_manifold": closed,
        "manifold_with_boundary": with_boundary,
        "components": len(chi),
        "euler": int(sum(chi)),
        "euler_per_component": chi,
        "boundary_loops": int(loops),
        "expected_components": expected_components,
        "expected_euler": expected_euler,
        "expected_loops": expected_loops,
        "expected_per_component": expected_per_component,
    }
    if expected_components is None or expected_euler is None:
        res["topology_ok"] = None
        return res
    shape_ok = (with_boundary and loops == expected_loops) if expected_loops else closed
    ok = shape_ok and len(chi) == expected_components and sum(chi) == expected_euler
    if expected_per_component is not None:
        ok = ok and sorted(chi) == sorted(expected_per_component)
    res["topology_ok"] = bool(ok)
    return res


# ---------------------------------------------------------------------------
# Distance to the surface
# ---------------------------------------------------------------------------


def _values(surface, p: np.ndarray) -> np.ndarray:
    return np.asarray(surface.f(p), dtype=np.float64)


def _line_roots(surface, p, n, t, tol: float, max_iter: int):
    """Newton on ``f(p + t n) = 0`` from ``t``; returns (t, converged)."""
    t = t.copy()
    active = np.isfinite(t)
    converged = np.zeros(len(p), bool)
    limit = 0.5 * surface.radius
    for _ in range(max_iter):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        q = p[idx] + t[idx, None] * n[idx]
        fq = _values(surface, q)
        dq = np.einsum("ij,ij->i", surface.grad(q), n[idx])
        ok = np.abs(dq) > 0
        step = np.where(ok, fq / np.where(ok, dq, 1.0), 0.0)
        t[idx] -= step
        bad = ~ok | ~np.isfinite(t[idx]) | (np.abs(t[idx]) > limit)
        done = ~bad & (np.abs(step) <= tol)
        converged[idx[done]] = True
        active[idx[done | bad]] = False
    return t, converged


def _unit(g: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    gn = np.linalg.norm(g, axis=1)
    good = gn > 0
    n = np.zeros_like(g)
    n[good] = g[good] / gn[good, None]
    return n, good


def _project_block(surface, p: np.ndarray, tol: float, max_iter: int, refine: int = 3):
    """Closest surface point of each point; returns (distance, ok, foot).

    Newton along the gradient line of ``p``, then ``refine`` more line
    searches along the normal at the foot found, which converge to the
    orthogonal projection (the gradient of ``f`` off the surface need not
    point at the closest surface point).
    """
    n, good = _unit(surface.grad(p))
    gn = np.linalg.norm(surface.grad(p), axis=1)
    t0 = np.where(good, -_values(surface, p) / np.where(good, gn, 1.0), np.nan)
    t, converged = _line_roots(surface, p, n, t0, tol, max_iter)
    for _ in range(refine):
        idx = np.flatnonzero(converged)
        if idx.size == 0:
            break
        foot = p[idx] + t[idx, None] * n[idx]
        m, ok = _unit(surface.grad(foot))
        # Start from the current foot, written along the new direction.
        t_new, conv = _line_roots(
            surface, p[idx], m, np.einsum("ij,ij->i", foot - p[idx], m), tol, max_iter
        )
        keep = ok & conv
        t[idx[keep]] = t_new[keep]
        n[idx[keep]] = m[keep]
    foot = p + np.where(np.isfinite(t), t, 0.0)[:, None] * n
    # A line root counts only if f really vanishes there (to first order).
    if converged.any():
        idx = np.flatnonzero(converged)
        q = foot[idx]
        gq = np.linalg.norm(surface.grad(q), axis=1)
        resid = np.abs(_values(surface, q)) / np.where(gq > 0, gq, np.inf)
        converged[idx[~(resid <= 10 * tol)]] = False
    dist = np.abs(np.where(np.isfinite(t), t, 0.0))
    # Fallback: Newton along the gradient path, q <- q - f grad / |grad|^2.
    idx = np.flatnonzero(~converged)
    if idx.size:
        q = p[idx].copy()
        for _ in range(max_iter):
            gq = surface.grad(q)
            g2 = np.einsum("ij,ij->i", gq, gq)
            fq = _values(surface, q)
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(g2 > 0, fq / g2, 0.0)[:, None] * gq
            step[~np.isfinite(step)] = 0.0
            q -= step
            if np.all(np.linalg.norm(step, axis=1) <= tol):
                break
        foot[idx] = q
        dist[idx] = np.linalg.norm(q - p[idx], axis=1)
    return dist, converged, foot


def distance_to_surface(
    surface, points: np.ndarray, *, tol: float | None = None, max_iter: int = 30
) -> tuple[np.ndarray, np.ndarray, int]:
    """Distance of each point to the surface ``f = 0``, and the foot points.

    Parameters
    ----------
    surface : rdmesh ImplicitSurface (uses ``.f``, ``.grad`` and ``.radius``).
    points : (N, 3) points near the surface.
    tol : Newton step size at which to stop; default ``1e-12 * radius``.

    Returns
    -------
    distance : (N,) float64
    foot : (N, 3) the surface points found.
    fallbacks : how many points needed the gradient-path projection.
    """
    points = np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 3)
    if tol is None:
        tol = 1e-12 * float(surface.radius)
    dist = np.empty(len(points))
    foot = np.empty_like(points)
    fallbacks = 0
    for s in range(0, len(points), _BLOCK):
        d, ok, q = _project_block(surface, points[s : s + _BLOCK], tol, max_iter)
        dist[s : s + _BLOCK] = d
        foot[s : s + _BLOCK] = q
        fallbacks += int(np.count_nonzero(~ok))
    return dist, foot, fallbacks


def mesh_samples(
    vertices: np.ndarray, faces: np.ndarray, n_random: int, seed: int = 0
) -> np.ndarray:
    """Vertices, face centroids and ``n_random`` uniform-by-area points, ``(S, 3)``."""
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    parts = [vertices, (a + b + c) / 3.0]
    if n_random > 0 and len(faces):
        area = 0.5 * np.linalg.norm(np.cross(b - a, c - a), axis=1)
        total = area.sum()
        rng = np.random.default_rng(seed)
        if total > 0:
            which = rng.choice(len(faces), size=n_random, p=area / total)
        else:
            which = rng.integers(0, len(faces), n_random)
        r1 = np.sqrt(rng.random(n_random))
        r2 = rng.random(n_random)
        parts.append(
            (1 - r1)[:, None] * a[which]
            + (r1 * (1 - r2))[:, None] * b[which]
            + (r1 * r2)[:, None] * c[which]
        )
    return np.concatenate(parts)


# ---------------------------------------------------------------------------
# Distance to the mesh
# ---------------------------------------------------------------------------


def _dot(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return np.einsum("...j,...j->...", u, v)


def _segment_distance2(p, a, b):
    ab = b - a
    den = _dot(ab, ab)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(den > 0, _dot(p - a, ab) / den, 0.0)
    t = np.clip(t, 0.0, 1.0)
    d = p - (a + t[..., None] * ab)
    return _dot(d, d)


def point_triangle_distance(
    p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray
) -> np.ndarray:
    """Exact Euclidean distance from points to triangles, broadcast over rows.

    ``p``, ``a``, ``b``, ``c``: ``(..., 3)``.  Inside the triangle's prism the
    distance is the one to its plane, otherwise the smallest distance to its
    three edges; degenerate triangles use the edges only.
    """
    ab, ac, ap = b - a, c - a, p - a
    n = np.cross(ab, ac)
    nn = _dot(n, n)
    d00, d01, d11 = _dot(ab, ab), _dot(ab, ac), _dot(ac, ac)
    d20, d21 = _dot(ap, ab), _dot(ap, ac)
    den = d00 * d11 - d01 * d01
    with np.errstate(divide="ignore", invalid="ignore"):
        v = (d11 * d20 - d01 * d21) / den
        w = (d00 * d21 - d01 * d20) / den
        plane2 = _dot(ap, n) ** 2 / nn
    inside = (nn > 0) & (den > 0) & (v >= 0) & (w >= 0) & (v + w <= 1)
    edge2 = np.minimum(
        np.minimum(_segment_distance2(p, a, b), _segment_distance2(p, b, c)),
        _segment_distance2(p, c, a),
    )
    return np.sqrt(np.where(inside, plane2, edge2))


def surface_to_mesh(
    points: np.ndarray, vertices: np.ndarray, faces: np.ndarray, k: int = 16
) -> np.ndarray:
    """Distance from each point to the triangle mesh, ``(N,)``.

    The minimum of the exact point-triangle distances over the ``k``
    triangles with the nearest centroids (an upper bound, exact in practice).
    """
    centroids = vertices[faces].mean(axis=1)
    tree = cKDTree(centroids)
    k = min(k, len(faces))
    out = np.empty(len(points))
    step = max(1, _BLOCK // k)
    for s in range(0, len(points), step):
        p = points[s : s + step]
        _, idx = tree.query(p, k=k)
        idx = idx.reshape(len(p), k)
        tri = vertices[faces[idx]]  # (m, k, 3, 3)
        d = point_triangle_distance(p[:, None, :], tri[:, :, 0], tri[:, :, 1], tri[:, :, 2])
        out[s : s + step] = d.min(axis=1)
    return out


# ---------------------------------------------------------------------------
# Reference points on the surface
# ---------------------------------------------------------------------------


def evaluate_grid(surface, lo: np.ndarray, spacing: float, shape: tuple) -> np.ndarray:
    """``f`` on the grid ``lo + (i, j, k) * spacing``, shape ``shape``, in slabs."""
    nx, ny, nz = (int(s) for s in shape)
    vol = np.empty((nx, ny, nz))
    ys = lo[1] + spacing * np.arange(ny)
    zs = lo[2] + spacing * np.arange(nz)
    yy, zz = np.meshgrid(ys, zs, indexing="ij")
    yz = np.column_stack([yy.ravel(), zz.ravel()])
    rows = max(1, (1 << 22) // (ny * nz))
    for i0 in range(0, nx, rows):
        i1 = min(nx, i0 + rows)
        xs = lo[0] + spacing * np.arange(i0, i1)
        pts = np.empty(((i1 - i0) * ny * nz, 3))
        pts[:, 0] = np.repeat(xs, ny * nz)
        pts[:, 1:] = np.tile(yz, (i1 - i0, 1))
        vol[i0:i1] = _values(surface, pts).reshape(i1 - i0, ny, nz)
    return vol


def surface_bbox(surface, resolution: int = 96) -> tuple[np.ndarray, np.ndarray]:
    """Axis-aligned box around the surface, from a sign scan of its bounding cube.

    Cells of a ``resolution``-cube grid over the bounding sphere's cube where
    ``f`` changes sign, padded by two cells.
    """
    c, r = np.asarray(surface.centre, float), float(surface.radius)
    h = 2 * r / (resolution - 1)
    lo = c - r
    vol = evaluate_grid(surface, lo, h, (resolution,) * 3)
    neg = vol < 0
    mixed = np.zeros_like(neg)
    # A grid node touches a sign change if a neighbour along any axis differs.
    for ax in range(3):
        d = np.diff(neg, axis=ax)
        sl_lo = [slice(None)] * 3
        sl_hi = [slice(None)] * 3
        sl_lo[ax] = slice(0, -1)
        sl_hi[ax] = slice(1, None)
        mixed[tuple(sl_lo)] |= d
        mixed[tuple(sl_hi)] |= d
    idx = np.argwhere(mixed)
    if len(idx) == 0:
        raise ValueError(f"no sign change of f found on a {resolution}^3 grid")
    box_lo = lo + (idx.min(axis=0) - 2) * h
    box_hi = lo + (idx.max(axis=0) + 2) * h
    return np.maximum(box_lo, c - r), np.minimum(box_hi, c + r)


def marching_cubes_mesh(surface, lo, hi, spacing: float) -> tuple[np.ndarray, np.ndarray, int]:
    """Marching cubes (scikit-image, Lewiner) of ``f`` on a grid over ``[lo, hi]``.

    Returns outward-oriented ``(vertices, faces, grid points evaluated)``.
    """
    from skimage.measure import marching_cubes

    lo = np.asarray(lo, float)
    shape = tuple(int(np.ceil((b - a) / spacing)) + 1 for a, b in zip(lo, hi, strict=True))
    vol = evaluate_grid(surface, lo, spacing, shape)
    # f < 0 inside: the exterior is greater, which skimage calls "ascent".
    verts, faces, _, _ = marching_cubes(
        vol, level=0.0, spacing=(spacing,) * 3, gradient_direction="ascent"
    )
    return verts.astype(np.float64) + lo, faces.astype(np.int64), int(vol.size)


def surface_reference(surface, n_points: int, bbox=None) -> np.ndarray:
    """About ``n_points`` points on the surface, independent of any mesher.

    The vertices of a marching-cubes mesh of ``f`` with spacing
    ``sqrt(1.5 * area / n_points)`` (about one vertex per grid edge the
    surface crosses; ``area`` from a coarse pass), projected onto the surface
    with :func:`distance_to_surface`.
    """
    lo, hi = bbox if bbox is not None else surface_bbox(surface)
    coarse = float(np.max(np.asarray(hi) - np.asarray(lo))) / 64
    v, f, _ = marching_cubes_mesh(surface, lo, hi, coarse)
    area = mesh_area(v, f)
    spacing = float(np.sqrt(1.5 * area / n_points))
    v, _, _ = marching_cubes_mesh(surface, lo, hi, spacing)
    _, foot, _ = distance_to_surface(surface, v)
    return foot


def hausdorff(
    surface,
    vertices: np.ndarray,
    faces: np.ndarray,
    reference: np.ndarray,
    *,
    n_random: int | None = None,
    seed: int = 0,
    k: int = 16,
) -> dict[str, Any]:
    """Sampled two-sided Hausdorff distance between a mesh and the surface.

    ``reference``: points on the surface (:func:`surface_reference`).
    ``n_random``: random mesh samples in addition to vertices and centroids;
    default ``len(faces)`` (capped at 4 million).

    Returns ``mesh_to_surface`` {max, mean, rms}, ``vertex_to_surface_max``
    (how far the vertices themselves are off), ``surface_to_mesh`` {max, mean,
    rms}, ``two_sided`` (the larger maximum), the sample counts and
    ``projection_fallbacks``.
    """
    if n_random is None:
        n_random = min(len(faces), 4_000_000)
    samples = mesh_samples(vertices, faces, n_random, seed)
    d_ms, _, fallbacks = distance_to_surface(surface, samples)
    d_sm = surface_to_mesh(reference, vertices, faces, k=k)

    def summary(d):
        return {
            "max": float(d.max()),
            "mean": float(d.mean()),
            "rms": float(np.sqrt(np.mean(d * d))),
        }

    ms, sm = summary(d_ms), summary(d_sm)
    return {
        "mesh_to_surface": ms,
        "vertex_to_surface_max": float(d_ms[: len(vertices)].max()),
        "surface_to_mesh": sm,
        "two_sided": max(ms["max"], sm["max"]),
        "mesh_samples": int(len(samples)),
        "surface_samples": int(len(reference)),
        "projection_fallbacks": fallbacks,
    }
