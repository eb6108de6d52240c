"""The topological ball property (Cheng-Dey-Ramos-Ray) and the topology report.

A sample set has the topological ball property (TBP) when every Voronoi face
meets the surface in a closed ball of one dimension less, transversally; the
restricted Delaunay triangulation is then homeomorphic to the surface
(Edelsbrunner-Shah). The tests, in the order the refinement repairs them
(algorithm.md, 3.2-3.4):

``voronoi_edge`` (T1)
    A restricted facet whose dual Voronoi edge crosses the surface more than
    once, or tangentially (the facet's ``TOPO`` flag). Repair: the crossing
    with the largest surface Delaunay ball.
``voronoi_facet`` (T2, crossing count)
    The boundary of the Voronoi facet dual to a Delaunay edge ``pq`` crosses
    the surface as often as the dual edges of the facets around ``pq`` do;
    with T1 holding that is the number of restricted facets at ``pq``. One arc
    means exactly 2 (0 means no arc or a closed loop); 1, 3 or 4 and more are
    violations. Repair: the largest incident surface ball.
``voronoi_loop`` (T2, loops and folds)
    A closed loop of the surface inside a Voronoi facet, or an arc that turns
    back along its chord, found by damped Newton from a few seeds per facet
    (:mod:`rdmesh.voronoi_loops`). Repair: the point of the facet's
    intersection found farthest from ``p``, the centre of an empty ball.
``disk`` (T3)
    The restricted triangles at a sample must form one disk (one fan).
    Repair: the largest incident surface ball.
``isolated`` (T3)
    A sample with no restricted triangle. Repair: a crossing of a shot from the
    sample that lies in its Voronoi cell.
``silhouette`` (T3)
    A point of the surface in the Voronoi cell ``V_p`` whose normal makes an
    angle of 90 degrees or more with the normal at ``p`` (a silhouette point
    of ``W_p = V_p ∩ Σ`` seen along ``n_p``; without one a connected ``W_p``
    bounded by one cycle is a disk). Tested on probes: a dense point set on the
    surface, assigned to cells by nearest sample. Refinement uses a stricter
    angle (:data:`CELL_NORMAL_ANGLE`). Repair: the probe of the cell farthest
    from ``p``, the centre of an empty ball since it lies in ``V_p``.

The crossing-count, disk and isolated tests are exact combinatorial tests on
the restricted complex; the Voronoi-edge crossings they rest on are found by
sampling each edge (with a dip search), the loop test samples each facet with
Newton seeds, and the silhouette test samples each cell with the probes.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from .._tol import SHOT_ATOL, SHOT_OFFSET, SILHOUETTE_SLACK
from .._vectors import ring_directions, unit_rows
from ..sampling.probes import Probes
from ..sampling.roots import crossings_along_segments
from .complex import largest_incident, marked
from .loops import loop_test

#: The tests, in repair order.
TESTS = ("voronoi_edge", "voronoi_facet", "voronoi_loop", "disk", "isolated", "silhouette")
#: Refinement threshold of the silhouette test (degrees between the normal at a
#: probe and at its nearest sample). Below 90 so that probes see a silhouette
#: before it lies between two probes; lower values also bound normal deviation.
CELL_NORMAL_ANGLE = 80.0
#: The report's silhouette test: a probe normal at 90 degrees or more.
SILHOUETTE_ANGLE = 90.0
#: Wanted number of probes on the surface.
PROBE_TARGET = 30000


@dataclass
class Violations:
    """One test's outcome: how many elements fail, and their refinement points.

    ``centres``/``radii`` are empty balls (centre on the surface, no sample
    inside), at most one per failing element.
    """

    kind: str
    count: int
    centres: np.ndarray
    radii: np.ndarray
    #: ``(m, 3)``: where failing elements have no refinement point (the sample
    #: of an isolated sample or a silhouette cell); never silently dropped.
    stuck: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)))


def _none(kind: str) -> Violations:
    return Violations(kind, 0, np.zeros((0, 3)), np.zeros(0))


def voronoi_edge_test(tri, centres, radii, flags, topo_bit: int) -> Violations:
    """T1: restricted facets whose dual edge crosses several times or tangentially."""
    bad = (flags & topo_bit) != 0
    return Violations("voronoi_edge", int(bad.sum()), centres[bad], radii[bad])


def voronoi_facet_test(status, centres, radii, allow_boundary: bool = False) -> Violations:
    """T2 crossing count: complex edges with other than 2 restricted triangles
    (only more than 2 with ``allow_boundary``, as CGAL's Manifold_with_boundary_tag)."""
    bad = status.bad_edges(allow_boundary)
    if bad.size == 0:
        return _none("voronoi_facet")
    f_idx, slot = np.nonzero(marked(len(status.edge_key), bad)[status.facet_edges])
    pick = largest_incident(status.facet_edges[f_idx, slot], f_idx, radii)
    return Violations("voronoi_facet", int(bad.size), centres[pick], radii[pick])


def voronoi_loop_test(
    surface, rdt, vertices, tri, centres, status, probes=None, tree=None, memo=None
) -> Violations:
    """T2 loops and folds inside Voronoi facets (:func:`rdmesh.voronoi_loops.loop_test`)."""
    v = loop_test(surface, rdt, vertices, tri, centres, status, probes, tree, memo)
    return Violations("voronoi_loop", len(v.edges), v.centres, v.radii)


def disk_test(status, tri, centres, radii) -> Violations:
    """T3 disk test: samples whose restricted triangles form more than one fan."""
    bad = np.flatnonzero(status.vertex_fans > 1)
    if bad.size == 0:
        return _none("disk")
    f_idx, corner = np.nonzero(marked(len(status.vertex_fans), bad)[tri])
    pick = largest_incident(tri[f_idx, corner], f_idx, radii)
    return Violations("disk", int(bad.size), centres[pick], radii[pick])


def isolated_samples(tri: np.ndarray, n_vertices: int) -> np.ndarray:
    """Ids of the samples without a restricted triangle."""
    used = np.zeros(n_vertices, bool)
    used[tri.ravel()] = True
    return np.flatnonzero(~used)


def isolated_test(surface, vertices, tri, tree=None, weights=None) -> Violations:
    """T3: samples with no restricted triangle, with a point of their cell each.

    Shoots from each such sample p along and around -n and +n; the first
    crossing whose nearest sample is p lies in p's Voronoi cell, so it is the
    centre of an empty ball of radius |x - p|. Samples none of whose shots
    lands in their cell count as violations without a point. With protecting
    balls (``weights``), balls are not tested (the feature check covers
    them), and a crossing counts only where no ball has smaller power.
    """
    lonely = _lonely(tri, len(vertices), weights)
    if lonely.size == 0:
        return _none("isolated")
    tree = cKDTree(vertices) if tree is None else tree
    balls = None if weights is None else np.flatnonzero(weights > 0)
    parts = [
        _shots_in_cells(surface, vertices, lonely[i : i + SHOT_CHUNK], tree, weights, balls)
        for i in range(0, len(lonely), SHOT_CHUNK)
    ]
    x, r, got = (np.concatenate(a) for a in zip(*parts, strict=True))
    stuck = vertices[np.setdiff1d(lonely, got)]
    return Violations("isolated", int(lonely.size), x, r, stuck)


def isolated_count(vertices, tri, weights=None) -> Violations:
    """T3's count alone, without shooting for a point of each cell (a run
    stopped by its time limit): the samples, balls left out, with no
    restricted triangle, all without a point."""
    lonely = _lonely(tri, len(vertices), weights)
    if lonely.size == 0:
        return _none("isolated")
    none = np.zeros((0, 3))
    return Violations("isolated", int(lonely.size), none, np.zeros(0), vertices[lonely])


def _lonely(tri, n_vertices: int, weights) -> np.ndarray:
    """:func:`isolated_samples` that are not protecting balls."""
    lonely = isolated_samples(tri, n_vertices)
    return lonely if weights is None else lonely[weights[lonely] == 0]


#: Samples shot from at a time by :func:`isolated_test`: each has 26 shots of
#: 65 samples, so this bounds the test's memory (a run stopped by its budget
#: can leave hundreds of thousands of isolated samples).
SHOT_CHUNK = 4096
#: Samples of ``f`` along a shot where its crossings are searched for
#: (:func:`~rdmesh.sampling.roots.crossings_along_segments`; a mesh's are exact).
SHOT_SAMPLES = 64
#: Protecting balls compared with the crossings at a time.
BALL_CHUNK = 1024


def _shots_in_cells(surface, vertices, ids, tree, weights, balls):
    """:func:`shoot_from` for ``ids``, without crossings where a protecting
    ball has smaller power than the sample."""
    x, r, got = shoot_from(surface, vertices, ids, tree)
    if balls is not None and len(x) and len(balls):
        power = np.full(len(x), np.inf)
        for i in range(0, len(balls), BALL_CHUNK):
            b = balls[i : i + BALL_CHUNK]
            d = x[:, None, :] - vertices[b][None, :, :]
            power = np.minimum(power, (np.einsum("ijk,ijk->ij", d, d) - weights[b]).min(axis=1))
        ok = power > r * r
        x, r, got = x[ok], r[ok], got[ok]
    return x, r, got


def shoot_from(surface, vertices, ids, tree=None):
    """For each sample in ``ids``: the farthest first crossing of its shots that
    lies in its Voronoi cell, ``(x (k, 3), r (k,), sample ids (k,))`` for the
    samples that have one."""
    p = vertices[ids]
    n = unit_rows(surface.grad(p))
    dirs = shot_directions(n)  # (len(p), D, 3)
    D = dirs.shape[1]
    owner = np.repeat(np.arange(len(p)), D)
    d = dirs.reshape(-1, 3)
    R = surface.radius
    start = p[owner] + SHOT_OFFSET * R * d
    # Run each shot to the bounding sphere.
    f = start - surface.centre
    b = np.einsum("ij,ij->i", f, d)
    c = np.einsum("ij,ij->i", f, f) - R * R
    length = -b + np.sqrt(np.maximum(b * b - c, 0.0))
    rows = np.flatnonzero(length > 0)
    hit, point = crossings_along_segments(
        surface, start[rows], d[rows], length[rows], SHOT_SAMPLES, SHOT_ATOL * R
    )
    if hit.size == 0:
        return np.zeros((0, 3)), np.zeros(0), np.zeros(0, np.int64)
    first = np.r_[True, hit[1:] != hit[:-1]]
    seg, x = rows[hit[first]], point[first]
    _, nearest = (tree or cKDTree(vertices)).query(x)
    me = ids[owner[seg]]
    valid = nearest == me
    seg, x, me = seg[valid], x[valid], me[valid]
    r = np.linalg.norm(x - vertices[me], axis=1)
    pick = largest_incident(me, np.arange(len(x)), r)
    return x[pick], r[pick], me[pick]


def shot_directions(n: np.ndarray) -> np.ndarray:
    """Directions at 0, 30 and 60 degrees around -n and +n, ``(k, 26, 3)``."""
    tilts = (np.pi / 6, np.pi / 3)
    back, front = ring_directions(n, -1.0, tilts), ring_directions(n, 1.0, tilts)
    return np.concatenate([back, front], axis=1)


def silhouette_test(
    probes: Probes, vertices: np.ndarray, vnormals: np.ndarray, angle: float, tree=None
) -> Violations:
    """T3 silhouette proxy: cells holding a probe whose normal is ``angle`` or more
    degrees from the sample's normal (or a sample or probe without a normal).

    Every probe is assigned to its nearest sample (exactly membership of the
    Voronoi cell). The point of a failing cell is its probe farthest from the
    sample: on the surface and in ``V_p``, so the centre of an empty ball.
    """
    if len(probes.points) == 0 or len(vertices) == 0:
        return _none("silhouette")
    dist, owner = (tree or cKDTree(vertices)).query(probes.points)
    dot = np.einsum("ij,ij->i", probes.normals, vnormals[owner])
    unknown = ~np.any(probes.normals != 0, axis=1) | ~np.any(vnormals[owner] != 0, axis=1)
    bad_probe = (dot <= math.cos(math.radians(angle)) + SILHOUETTE_SLACK) | unknown
    bad_cell = np.zeros(len(vertices), bool)
    bad_cell[owner[bad_probe]] = True
    sel = np.flatnonzero(bad_cell[owner] & (dist > 0))
    count = int(bad_cell.sum())
    pointed = np.zeros(len(vertices), bool)
    pointed[owner[sel]] = True
    stuck = vertices[bad_cell & ~pointed]
    if sel.size == 0:
        return Violations("silhouette", count, np.zeros((0, 3)), np.zeros(0), stuck)
    pick = largest_incident(owner[sel], sel, dist)
    return Violations("silhouette", count, probes.points[pick], dist[pick], stuck)
