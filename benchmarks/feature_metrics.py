# SPDX-License-Identifier: GPL-3.0-or-later
"""Feature (crease and corner) metrics of a triangle mesh, for issue 27's benchmark.

Everything is vectorised numpy/scipy on plain arrays ``vertices (V, 3)`` and
``faces (F, 3)``, so the same code measures every mesher's output.

Ground-truth curves
-------------------
A curve is any object with ``length`` (float), ``closed`` (bool) and
``project(points) -> (distance, s)``: the distance of each point to the curve
and the arc-length parameter ``s`` in ``[0, length]`` of its closest point.
Three kinds are here:

- :class:`Segment` ``(a, b)``: a straight crease (a box edge), exact;
- :class:`Arc` ``(centre, start, end, normal)``: a circular arc (where a
  sphere meets a plane), exact;
- :class:`Polyline` ``(points)``: a polyline, exact as itself (a CAD mesh's
  sharp edges are its own edges); a closed loop repeats its first point last.

:func:`as_curves` accepts a list mixing these with ``(m, 3)`` arrays (made
Polylines).

Metrics
-------
- :func:`crease_coverage`: the share of the curves' length covered by mesh
  edges lying on them.  An edge ``ab`` lies on curve ``c`` when ``a`` and
  ``b`` are within ``tol`` of ``c``, the curve length ``lam`` between their
  closest points is at most ``(1 + slack) |ab| + 2 tol`` (the edge follows
  the curve: it does not jump across a loop or between two far parts of one
  curve), and the midpoint of ``ab`` is within ``tol + sqrt(lam^2 - |ab|^2) /
  2`` of ``c``.  For straight curves ``lam = |ab|`` and this is "both ends
  and the midpoint within ``tol``"; on a curved one the allowance is the
  largest distance a curve of length ``lam`` between the two ends can have
  from the chord (it lies in the ellipse with foci ``a``, ``b`` and major
  axis ``lam``), so chords of an exact arc count.  The covered length is the
  union of the parameter intervals ``[s_a, s_b]`` of the edges on each curve
  (overlaps counted once), over the total length.
- :func:`crease_vertex_distance`: the vertices within ``near`` of a curve,
  their count and their largest distance to it (how exactly the crease
  vertices sit on the true curve).
- :func:`corner_hits`: how many corners have a mesh vertex within ``tol``.
- :func:`surface_distance`: the largest ``|sdf|`` sampled on the triangles
  (vertices, centroids and uniform samples; ``metrics.mesh_samples``).
- :func:`mesh_hausdorff`: the sampled two-sided Hausdorff distance between
  two meshes, with exact point-to-mesh distances (CGAL's AABB tree through
  ``rdmesh.MeshSurface.closest_points``).
- :func:`angles_away_from`: the smallest angle overall and over the
  triangles with no vertex within ``radius`` of a curve
  (``metrics.triangle_angles``).
- :func:`topology`: closed manifold, components, Euler characteristic
  (``metrics.topology_stats``) and the genus of a closed orientable mesh.
- :func:`sharp_edges`: the mesh edges whose two faces' normals differ by an
  angle or more (CGAL's ``detect_features`` rule).

Distances of vertices to the curves are computed exactly only for vertices
that a k-d tree of dense curve samples finds near a curve (within the
tolerance plus the sample spacing), so the cost scales with the number of
vertices near the curves, not with V times the curves' segments.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np
from metrics import mesh_samples, topology_stats, triangle_angles
from scipy.spatial import cKDTree

__all__ = [
    "Arc",
    "Circle",
    "Curve",
    "Polyline",
    "Segment",
    "angles_away_from",
    "as_curves",
    "corner_hits",
    "crease_coverage",
    "crease_vertex_distance",
    "curve_distance",
    "mesh_edges",
    "mesh_hausdorff",
    "sharp_edges",
    "surface_distance",
    "topology",
]

# Points per block in the point-to-segment distance computations.
_BLOCK = 1 << 19


class Curve(Protocol):
    length: float
    closed: bool

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...

    def sample(self, n: int) -> np.ndarray: ...


def _points(p: Any) -> np.ndarray:
    return np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 3)


def _segments_project(
    points: np.ndarray, a: np.ndarray, b: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Closest segment of each point among ``a[i] b[i]``: (distance, segment, t in [0, 1])."""
    ab = b - a
    den = np.einsum("ij,ij->i", ab, ab)
    n, m = len(points), len(a)
    dist = np.empty(n)
    seg = np.empty(n, np.int64)
    tt = np.empty(n)
    step = max(1, _BLOCK // max(m, 1))
    for s in range(0, n, step):
        p = points[s : s + step]
        ap = p[:, None, :] - a[None, :, :]  # (B, m, 3)
        t = np.einsum("bmj,mj->bm", ap, ab) / np.where(den > 0, den, 1.0)
        t = np.clip(t, 0.0, 1.0)
        d = ap - t[..., None] * ab[None]
        d2 = np.einsum("bmj,bmj->bm", d, d)
        k = np.argmin(d2, axis=1)
        rows = np.arange(len(p))
        dist[s : s + step] = np.sqrt(d2[rows, k])
        seg[s : s + step] = k
        tt[s : s + step] = t[rows, k]
    return dist, seg, tt


@dataclass(frozen=True)
class Segment:
    """The straight curve from ``a`` to ``b``."""

    a: tuple[float, float, float]
    b: tuple[float, float, float]
    closed: bool = False

    @property
    def length(self) -> float:
        return float(np.linalg.norm(np.subtract(self.b, self.a)))

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        a, b = np.asarray(self.a, float)[None], np.asarray(self.b, float)[None]
        d, _, t = _segments_project(_points(points), a, b)
        return d, t * self.length

    def sample(self, n: int) -> np.ndarray:
        """``n + 1`` points, ``n`` equal segments, the ends exactly ``a`` and ``b``."""
        t = np.linspace(0.0, 1.0, n + 1)[:, None]
        a, b = np.asarray(self.a, float), np.asarray(self.b, float)
        out = a + t * (b - a)
        out[0], out[-1] = a, b
        return out


@dataclass(frozen=True)
class Arc:
    """The circular arc about ``centre`` from ``start`` to ``end`` (both at the
    same distance from ``centre``), turning about ``normal`` (right-hand rule)
    by less than 2 pi."""

    centre: tuple[float, float, float]
    start: tuple[float, float, float]
    end: tuple[float, float, float]
    normal: tuple[float, float, float]
    closed: bool = False

    def _frame(self):
        c = np.asarray(self.centre, float)
        n = np.asarray(self.normal, float)
        n = n / np.linalg.norm(n)
        u = np.asarray(self.start, float) - c
        r = float(np.linalg.norm(u))
        u = u / r
        v = np.cross(n, u)
        e = np.asarray(self.end, float) - c
        sweep = float(np.arctan2(e @ v, e @ u)) % (2 * np.pi)
        return c, n, u, v, r, sweep

    @property
    def radius(self) -> float:
        return self._frame()[4]

    @property
    def sweep(self) -> float:
        """The arc's angle in radians."""
        return self._frame()[5]

    @property
    def length(self) -> float:
        _, _, _, _, r, sweep = self._frame()
        return r * sweep

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance to the arc: to the circle's point above the point's
        in-plane angle when that lies on the arc, else to the nearer end."""
        p = _points(points)
        c, n, u, v, r, sweep = self._frame()
        q = p - c
        h = q @ n
        x, y = q @ u, q @ v
        rho = np.hypot(x, y)
        ang = np.arctan2(y, x) % (2 * np.pi)
        on = ang <= sweep
        d_in = np.hypot(h, rho - r)
        d0 = np.linalg.norm(p - np.asarray(self.start, float), axis=1)
        d1 = np.linalg.norm(p - np.asarray(self.end, float), axis=1)
        dist = np.where(on, d_in, np.minimum(d0, d1))
        s = np.where(on, ang * r, np.where(d0 <= d1, 0.0, sweep * r))
        return dist, s

    def sample(self, n: int) -> np.ndarray:
        """``n + 1`` points on the arc at equal angles (``n`` chords), the
        ends exactly ``start`` and ``end``.  The chords are off the arc by
        at most ``r (1 - cos(sweep / 2n))`` (the sagitta)."""
        c, _, u, v, r, sweep = self._frame()
        t = np.linspace(0.0, sweep, n + 1)[:, None]
        out = c + r * (np.cos(t) * u + np.sin(t) * v)
        out[0], out[-1] = self.start, self.end
        return out

    def sagitta(self, n: int) -> float:
        """Largest distance between the arc and its ``n``-chord sample."""
        return self.radius * (1.0 - np.cos(self.sweep / (2 * n)))


@dataclass(frozen=True)
class Circle:
    """The whole circle about ``centre`` of ``radius`` in the plane normal to
    ``normal`` (a closed curve: an edge across any point of it is on it)."""

    centre: tuple[float, float, float]
    radius: float
    normal: tuple[float, float, float]
    closed: bool = True

    def _frame(self):
        n = np.asarray(self.normal, float)
        n = n / np.linalg.norm(n)
        u = np.cross(n, np.eye(3)[int(np.argmin(np.abs(n)))])
        u /= np.linalg.norm(u)
        return np.asarray(self.centre, float), n, u, np.cross(n, u)

    @property
    def length(self) -> float:
        return 2 * np.pi * self.radius

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact distance to the circle and the arc length of the nearest point."""
        c, n, u, v = self._frame()
        q = _points(points) - c
        x, y = q @ u, q @ v
        dist = np.hypot(q @ n, np.hypot(x, y) - self.radius)
        return dist, (np.arctan2(y, x) % (2 * np.pi)) * self.radius

    def sample(self, n: int) -> np.ndarray:
        """``n + 1`` points at equal angles, the last one the first (``n`` chords)."""
        c, _, u, v = self._frame()
        t = np.linspace(0.0, 2 * np.pi, n + 1)[:, None]
        out = c + self.radius * (np.cos(t) * u + np.sin(t) * v)
        out[-1] = out[0]
        return out


class Polyline:
    """A polyline through ``points`` ``(m, 3)``, ``m >= 2``; closed when the
    last point equals the first."""

    def __init__(self, points: Any) -> None:
        pts = _points(points)
        if len(pts) < 2:
            raise ValueError(f"a polyline needs at least 2 points, got {len(pts)}")
        if not np.all(np.isfinite(pts)):
            raise ValueError("a polyline has a non-finite coordinate")
        self.points = pts
        self.closed = bool(len(pts) > 2 and np.array_equal(pts[0], pts[-1]))
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        self._cum = np.concatenate([[0.0], np.cumsum(seg)])
        self.length = float(self._cum[-1])

    def project(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        d, k, t = _segments_project(_points(points), self.points[:-1], self.points[1:])
        s = self._cum[k] + t * (self._cum[k + 1] - self._cum[k])
        return d, s

    def sample(self, n: int) -> np.ndarray:
        """The polyline's own points (``n`` is ignored: it is exact as itself)."""
        return self.points.copy()

    def __repr__(self) -> str:
        return f"Polyline({len(self.points)} points, closed={self.closed})"


def as_curves(curves: Any) -> list:
    """Curves from a list of curve objects and ``(m, 3)`` point arrays."""
    out = []
    for c in curves:
        out.append(c if hasattr(c, "project") else Polyline(c))
    if not out:
        raise ValueError("no curves")
    return out


def _dense_samples(curves: list, spacing: float) -> tuple[np.ndarray, np.ndarray]:
    """Points on the curves at most ``spacing`` apart along each, and their
    curve index.  A point within ``tol`` of curve ``c`` is within
    ``tol + spacing`` of one of its samples (half the spacing along it, plus
    the chord's sagitta for polylines' own points, which are on it)."""
    pts, idx = [], []
    for i, c in enumerate(curves):
        if isinstance(c, Polyline):
            # Subdivide each of its segments.
            a, b = c.points[:-1], c.points[1:]
            n = np.maximum(1, np.ceil(np.linalg.norm(b - a, axis=1) / spacing)).astype(int)
            rep = np.repeat(np.arange(len(a)), n)
            start = np.repeat(np.cumsum(n) - n, n)
            t = ((np.arange(n.sum()) - start) / n[rep])[:, None]
            p = np.vstack([a[rep] + t * (b[rep] - a[rep]), c.points[-1:]])
        else:
            p = c.sample(max(1, int(np.ceil(c.length / spacing))))
        pts.append(p)
        idx.append(np.full(len(p), i))
    return np.vstack(pts), np.concatenate(idx)


def curve_distance(
    points: Any, curves: Any, within: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Distances of points to each curve, computed where they are at most
    ``within``.

    Returns ``dist (N, C)`` (``inf`` where the point is farther than about
    ``within`` from the curve, exact elsewhere), ``s (N, C)`` (the arc-length
    parameters, ``nan`` where ``dist`` is ``inf``) and ``nearest (N,)`` (the
    smallest distance over the curves).
    """
    p = _points(points)
    cs = as_curves(curves)
    total = sum(c.length for c in cs)
    spacing = max(total / 20000.0, within, 1e-12)
    samples, which = _dense_samples(cs, spacing)
    tree = cKDTree(samples)
    near = tree.query_ball_point(p, r=within + 2 * spacing, return_length=True) > 0
    dist = np.full((len(p), len(cs)), np.inf)
    s = np.full((len(p), len(cs)), np.nan)
    idx = np.flatnonzero(near)
    if idx.size:
        for i, c in enumerate(cs):
            d, si = c.project(p[idx])
            dist[idx, i] = d
            s[idx, i] = si
    return dist, s, dist.min(axis=1) if len(cs) else np.full(len(p), np.inf)


def mesh_edges(faces: Any) -> np.ndarray:
    """The unique undirected edges ``(E, 2)`` of a triangle mesh, sorted pairs."""
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    e = np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]])
    return np.unique(np.sort(e, axis=1), axis=0)


def _bbox_diagonal(vertices: np.ndarray) -> float:
    return float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))


def _union_length(lo: np.ndarray, hi: np.ndarray) -> float:
    """Total length of the union of the intervals ``[lo[i], hi[i]]``."""
    if lo.size == 0:
        return 0.0
    order = np.argsort(lo)
    lo, hi = lo[order], hi[order]
    reach = np.maximum.accumulate(hi)
    prev = np.concatenate([[-np.inf], reach[:-1]])
    return float(np.sum(np.maximum(0.0, hi - np.maximum(lo, prev))))


def crease_coverage(
    vertices: Any,
    faces: Any,
    curves: Any,
    tol: float | None = None,
    *,
    slack: float = 0.05,
) -> dict[str, Any]:
    """The share of the curves' length covered by mesh edges lying on them.

    ``tol``: default ``1e-6`` times the mesh's bounding-box diagonal.  See the
    module docstring for when an edge lies on a curve.  Returns ``coverage``
    (covered / total length, 0 to 1), ``covered_length``, ``total_length``,
    ``per_curve`` (each curve's share), ``edges_on_curves`` and ``tol``.
    """
    v = _points(vertices)
    cs = as_curves(curves)
    if tol is None:
        tol = 1e-6 * _bbox_diagonal(v)
    edges = mesh_edges(faces)
    dist, s, nearest = curve_distance(v, cs, tol)
    cand = edges[(nearest[edges[:, 0]] <= tol) & (nearest[edges[:, 1]] <= tol)]
    a, b = v[cand[:, 0]], v[cand[:, 1]]
    ell = np.linalg.norm(b - a, axis=1)
    mid = 0.5 * (a + b)
    covered, on_count = [], np.zeros(len(cand), bool)
    for i, c in enumerate(cs):
        ok = (dist[cand[:, 0], i] <= tol) & (dist[cand[:, 1], i] <= tol)
        sa, sb = s[cand[:, 0], i], s[cand[:, 1], i]
        lo, hi = np.minimum(sa, sb), np.maximum(sa, sb)
        lam = hi - lo
        wrap = np.zeros(len(cand), bool)
        if c.closed:
            wrap = lam > c.length - lam
            lam = np.where(wrap, c.length - lam, lam)
        ok &= lam <= (1.0 + slack) * ell + 2 * tol
        if np.any(ok):
            dm, _ = c.project(mid[ok])
            allow = tol + 0.5 * np.sqrt(np.maximum(lam[ok] ** 2 - ell[ok] ** 2, 0.0))
            sub = np.flatnonzero(ok)
            ok[sub[dm > allow]] = False
        on_count |= ok
        # Intervals; on a closed curve a wrapping edge covers [hi, L] and [0, lo].
        plain = ok & ~wrap
        w = ok & wrap
        ilo = np.concatenate([lo[plain], hi[w], np.zeros(np.count_nonzero(w))])
        ihi = np.concatenate([hi[plain], np.full(np.count_nonzero(w), c.length), lo[w]])
        covered.append(min(_union_length(ilo, ihi), c.length))
    total = float(sum(c.length for c in cs))
    cov = float(sum(covered))
    return {
        "coverage": cov / total if total > 0 else None,
        "covered_length": cov,
        "total_length": total,
        "per_curve": [
            x / c.length if c.length > 0 else None for x, c in zip(covered, cs, strict=True)
        ],
        "edges_on_curves": int(np.count_nonzero(on_count)),
        "tol": float(tol),
    }


def crease_vertex_distance(vertices: Any, curves: Any, near: float | None = None) -> dict:
    """The vertices within ``near`` of a curve: their count and largest and
    mean distance to it (``near`` default ``1e-6`` times the bounding-box
    diagonal).  ``max_distance`` is None when no vertex is near a curve."""
    v = _points(vertices)
    if near is None:
        near = 1e-6 * _bbox_diagonal(v)
    _, _, nearest = curve_distance(v, curves, near)
    d = nearest[nearest <= near]
    return {
        "count": int(d.size),
        "max_distance": float(d.max()) if d.size else None,
        "mean_distance": float(d.mean()) if d.size else None,
        "near": float(near),
    }


def corner_hits(vertices: Any, corners: Any, tol: float | None = None) -> dict:
    """How many ``corners (K, 3)`` have a mesh vertex within ``tol`` (default
    ``1e-6`` times the bounding-box diagonal), and the largest distance from a
    corner to its nearest vertex."""
    v = _points(vertices)
    c = _points(corners)
    if tol is None:
        tol = 1e-6 * _bbox_diagonal(v)
    if len(c) == 0:
        return {"corners": 0, "hit": 0, "max_distance": None, "tol": float(tol)}
    d, _ = cKDTree(v).query(c)
    return {
        "corners": int(len(c)),
        "hit": int(np.count_nonzero(d <= tol)),
        "max_distance": float(d.max()),
        "tol": float(tol),
    }


def surface_distance(
    vertices: Any, faces: Any, sdf, *, n_random: int | None = None, seed: int = 0
) -> dict:
    """The largest ``|sdf|`` over samples of the triangles: every vertex,
    every centroid and ``n_random`` points uniform by area (default the number
    of faces).  ``sdf``: a vectorised ``(N, 3) -> (N,)`` signed distance."""
    v = _points(vertices)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    if n_random is None:
        n_random = len(f)
    samples = mesh_samples(v, f, n_random, seed)
    d = np.abs(np.asarray(sdf(samples), dtype=np.float64))
    return {
        "max": float(d.max()),
        "vertex_max": float(d[: len(v)].max()),
        "mean": float(d.mean()),
        "samples": int(len(samples)),
    }


def _point_mesh_distance(points: np.ndarray, vertices: np.ndarray, faces: np.ndarray):
    import rdmesh

    closest, _ = rdmesh.MeshSurface((vertices, faces)).closest_points(points)
    return np.linalg.norm(points - closest, axis=1)


def mesh_hausdorff(
    vertices: Any,
    faces: Any,
    ref_vertices: Any,
    ref_faces: Any,
    *,
    n_random: int = 200_000,
    seed: int = 0,
) -> dict:
    """Sampled two-sided Hausdorff distance between a mesh and a reference mesh.

    Samples on each (vertices, centroids and ``n_random`` uniform points,
    ``metrics.mesh_samples``); each sample's distance to the other mesh is
    exact (CGAL's AABB tree, ``rdmesh.MeshSurface.closest_points``).
    Returns ``to_reference`` and ``from_reference`` ({max, mean}) and
    ``two_sided`` (the larger maximum); lower estimates of the true value.
    """
    v, f = _points(vertices), np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    rv, rf = _points(ref_vertices), np.asarray(ref_faces, dtype=np.int64).reshape(-1, 3)
    d_to = _point_mesh_distance(mesh_samples(v, f, n_random, seed), rv, rf)
    d_from = _point_mesh_distance(mesh_samples(rv, rf, n_random, seed + 1), v, f)
    return {
        "to_reference": {"max": float(d_to.max()), "mean": float(d_to.mean())},
        "from_reference": {"max": float(d_from.max()), "mean": float(d_from.mean())},
        "two_sided": float(max(d_to.max(), d_from.max())),
    }


def angles_away_from(vertices: Any, faces: Any, curves: Any, radius: float) -> dict:
    """Smallest triangle angle (degrees) overall, and over the triangles with
    no vertex within ``radius`` of a curve (``None`` when there are none),
    with how many triangles are away."""
    v = _points(vertices)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    smallest = triangle_angles(v, f).min(axis=1)
    _, _, nearest = curve_distance(v, curves, radius)
    away = np.all(nearest[f] > radius, axis=1)
    return {
        "min_angle": float(smallest.min()) if len(f) else None,
        "min_angle_away": float(smallest[away].min()) if np.any(away) else None,
        "faces_away": int(np.count_nonzero(away)),
        "radius": float(radius),
    }


def topology(vertices: Any, faces: Any) -> dict:
    """``metrics.topology_stats`` plus ``genus``: ``(2 components - chi) / 2``
    for a closed manifold (None otherwise)."""
    v = _points(vertices)
    t = topology_stats(v, np.asarray(faces, dtype=np.int64).reshape(-1, 3))
    genus = None
    if t["closed_manifold"]:
        g2 = 2 * t["components"] - t["euler"]
        genus = g2 // 2 if g2 % 2 == 0 else g2 / 2
    return {
        "closed_manifold": t["closed_manifold"],
        "components": t["components"],
        "euler": t["euler"],
        "genus": genus,
    }


def sharp_edges(vertices: Any, faces: Any, angle: float) -> np.ndarray:
    """The edges ``(E, 2)`` (sorted vertex pairs) in exactly two faces whose
    unit normals differ by ``angle`` degrees or more (CGAL's
    ``detect_features(angle)`` rule, ``PMP::detect_sharp_edges``: the cosine
    of the normals' angle at most ``cos(angle)``; a flat edge is 0, a cube
    edge 90)."""
    v = _points(vertices)
    f = np.asarray(faces, dtype=np.int64).reshape(-1, 3)
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    e = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    owner = np.tile(np.arange(len(f)), 3)
    uniq, inv, counts = np.unique(e, axis=0, return_inverse=True, return_counts=True)
    inv = inv.ravel()
    two = counts[inv] == 2
    order = np.argsort(inv[two], kind="stable")
    pairs = owner[two][order].reshape(-1, 2)
    keys = inv[two][order][::2]
    cos = np.einsum("ij,ij->i", n[pairs[:, 0]], n[pairs[:, 1]])
    sharp = cos <= np.cos(np.radians(angle))
    return uniq[keys[sharp]]
