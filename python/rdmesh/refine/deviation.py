"""The distance bound measured between the output and a closed input mesh, both ways.

The facet stage applies CGAL's distance criterion: one point per facet, its
circumcentre against the centre of its surface Delaunay ball. On a mesh
input the surface is piecewise flat, and its edges are small creases: an
output edge can cut across one, and an input vertex can stand out of the
output, farther than the bound, while every facet passes that test.

A mesh input knows its surface exactly (closest points from CGAL's AABB
tree), so once every other stage is satisfied, :class:`DeviationStage`
measures where the deviation is largest on piecewise-flat surfaces: from the
input's vertices and points along its creased edges to the output, and from
the midpoints of the output's edges to the input. Where one is farther than
the distance bound, it proposes the point of the input there (the input's
point itself, or the point of the input closest to the output's), unless it
lies within ``MIN_GAP`` bounds of a sample, which bounds how many it can add.
It proposes twice (the second time, what the repairs around the first
points left beyond the bound), then measures once more for the statistics.
Where points were refused below the spacing floor, it proposes once, only
the farthest points up to a budget, none near the refused points or the
input's folds; an input with folds is always checked so (:data:`BUDGET`).
A closed input that intersects itself is remeshed as the union it encloses,
whose surface lies on the input's faces that separate inside from outside
(:class:`~rdmesh.surfaces._mesh_sides.FaceSides`): only points of those are
measured.
These are points checked, not every point of either surface: the stage
narrows the two-sided Hausdorff distance, it does not prove a bound on it.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from itertools import chain

import numpy as np
from scipy.spatial import cKDTree

from .. import core
from .._vectors import RowSet, unit_rows
from ..features.sharp_edges import sharp_edges
from ..topology import Snapshot
from .stages import Candidates

log = logging.getLogger("rdmesh")

#: Points of the input closer than this times the bound to a sample are not
#: proposed (they could not move the output by much; they are counted as left).
MIN_GAP = 0.5
#: Points along the input's creased edges are measured this many distance
#: bounds apart (about the radius bound at the usual ratio), and at least at
#: each edge's midpoint. Two bounds apart measured 4 times as many points on
#: the bone benchmark input, for a few percent less Hausdorff distance.
EDGE_SPACING = 10.0
#: Edges whose faces' normals differ by at least this many degrees are creased
#: (flat ones cannot stand out of the output between their ends).
CREASE_ANGLE = 1e-4
#: A budgeted check proposes no point within this many distance bounds
#: (twice the radius bound at the usual ratio) of a point refused this round
#: or of a fold of the input: refinement would follow the sheets closer than
#: the floor, or the fold, below the spacing floor.
CLEARANCE = 20.0
#: Where points were refused below the spacing floor (the run ends
#: incomplete), the check is budgeted: it proposes once, at most this
#: fraction of the output's vertex count, the farthest points first, none
#: within :data:`CLEARANCE`. Unbudgeted, on the fsaverage5 pial surface (593
#: points refused where sulcal banks touch; radius bound 0.3 % of the
#: diagonal) the output grew from 164,934 to 250,212 vertices; budgeted, to
#: 173,063, and its sampled Hausdorff distance went from 0.00074 to 0.00045
#: of the diagonal (benchmarks/RESULTS.md). An input with folds (razor-thin
#: wedges: noise) is checked on the budget too, away from its folds: checked
#: everywhere, refinement around the noise's spikes ends below the floor (a
#: noisy two-sphere input of the tests ended with 132 points unresolved);
#: unchecked, the fsaverage5 left white surface (one fold) at 1 % had a sampled
#: Hausdorff distance of 2.9 times the bound, and 1.6 times checked on the
#: budget (4 % more vertices, still complete).
BUDGET = 0.005
#: Points within this times a protecting ball's radius of its centre are not
#: proposed. Within one radius the ball would hide them; within a few, they
#: would make triangles with the ball's vertex, where the angle bound is
#: relaxed (as in Mesh_3): 2 radii let 21-degree angles through on the
#: genus-2 benchmark solid, 4 did not.
BALL_CLEARANCE = 4.0


@dataclass
class DeviationStage:
    """Input points and output edge midpoints farther from the other surface
    than ``bound`` (see the module's docstring).

    ``surface`` is a closed :class:`~rdmesh.MeshSurface` (its ``vertices``,
    ``closest_points`` and ``crossing_faces``); ``balls`` the protecting balls, if any.

    After the first check, only what changed is measured again: the input is
    fixed, so an output edge found within the bound stays so; an input point's
    distance grows only where its nearest facet is gone, else shrinks to a new one's.
    """

    surface: object
    bound: float
    balls: object = None
    name: str = "distance"
    #: Checks that may propose points (one when budgeted); the next only measures.
    #: The second proposes what the repairs left (bone at 0.3 %: 23 points left
    #: after one, none after two, for 0.2 % more vertices).
    rounds: int = 2
    #: Points refused this round (set by :class:`~rdmesh.refine.phases.Phases`),
    #: the ends and midpoints of the input's folds: see :data:`BUDGET`.
    unresolved: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)
    folds: np.ndarray = field(init=False, repr=False)
    budgeted: bool = False
    #: What the checks found (``SurfaceMesh.stats["distance_check"]``).
    checks: int = 0
    proposed: int = 0
    left: int = 0
    largest: float = 0.0
    #: The input's points measured: its vertices, and points along its creased edges.
    _probes: np.ndarray = field(init=False, repr=False)
    _free: np.ndarray = field(init=False, repr=False)
    #: Output edges (sorted vertex ids) found within the bound.
    _ok_edges: RowSet = field(init=False, repr=False)
    #: The output's facets at the last check; each input vertex's distance
    #: to it and its nearest facet there.
    _tri: RowSet | None = field(default=None, init=False, repr=False)
    _d_in: np.ndarray = field(init=False, repr=False)
    _near: np.ndarray = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # The input's own faces: the caps and tents over its holes are cut off.
        m = self.surface.input_face_count
        v, f = self.surface.vertices, self.surface.faces[:m]
        # A closed mesh that intersects itself: only the faces on its union's surface.
        sides = self.surface._face_sides
        kept = None if sides is None else sides.code[:m] == 1
        self._probes = input_probes(v, f, EDGE_SPACING * self.bound, kept)
        n = len(self._probes)
        # Input points next to a protecting ball are never proposed.
        self._free = np.ones(n, bool)
        if self.balls is not None and len(self.balls):
            self._free = ~self.balls.inside(self._probes, BALL_CLEARANCE)
        self.folds = _ends_and_midpoints(v[self.surface.fold_edges])
        self._ok_edges = RowSet(np.zeros((0, 2), np.int64))
        self._d_in = np.full(n, np.inf)
        self._near = np.full((n, 3), -1, np.int64)

    def candidates(self, snap: Snapshot) -> Candidates:
        self.budgeted |= len(self.unresolved) > 0 or len(self.folds) > 0  # see BUDGET
        self.checks += 1
        tri = np.sort(snap.facets(0)[0], axis=1)
        V = snap.vertices
        if len(tri) == 0:
            return _none(self.name)
        # The output's edges: the snapshot's status has them (the edge and
        # vertex tests computed it for this snapshot).
        keys = snap.status.edge_key
        edges = np.stack([keys // len(V), keys % len(V)], axis=1)
        d_out, near = self._output_to_input(V, edges)
        d_in = self._input_to_output(V, tri, snap.tree)
        self.largest = float(max(d_in.max(initial=0.0), d_out.max(initial=0.0)))
        far_in = d_in > self.bound
        far_out = d_out > self.bound
        near, dist_out = near[far_out], d_out[far_out]
        if self.balls is not None and len(self.balls):
            clear = ~self.balls.inside(near, BALL_CLEARANCE)  # input points: _free
            near, dist_out = near[clear], dist_out[clear]
        points = np.concatenate([self._probes[far_in & self._free], near])
        dist = np.concatenate([d_in[far_in & self._free], dist_out])
        over = int(far_in.sum() + far_out.sum())
        if len(points) == 0 or self.checks > (1 if self.budgeted else self.rounds):
            self.left = over
            return _none(self.name)
        gap = snap.tree.query(points)[0]
        keep = gap >= MIN_GAP * self.bound
        if self.budgeted:
            blocked = np.concatenate([self.unresolved, self.folds])
            keep = _in_budget(points, dist, keep, blocked, self.bound, len(V))
        points, gap = points[keep], gap[keep]
        self.proposed += len(points)
        self.left = over - len(points)
        log.debug(
            "distance check %d: %d input vertices, %d output points beyond %.3g; %d proposed",
            self.checks, int(far_in.sum()), int(far_out.sum()), self.bound, len(points),
        )  # fmt: skip
        return Candidates(self.name, points, gap, False, over)

    def _output_to_input(self, V: np.ndarray, edges: np.ndarray):
        """Midpoints of ``edges`` not yet within the bound: distances, closest points."""
        edges = edges[~self._ok_edges.contains(edges)]
        if len(edges) == 0:
            return np.zeros(0), np.zeros((0, 3))
        on_face = _on_one_face(self.surface, V, edges)
        settled, edges = edges[on_face], edges[~on_face]
        probes = 0.5 * (V[edges[:, 0]] + V[edges[:, 1]])
        near, face = self.surface.closest_points(probes)
        d = np.linalg.norm(probes - near, axis=1)
        d[face >= self.surface.input_face_count] = 0.0  # nearest a cap or tent: cut off
        self._ok_edges.add(np.concatenate([settled, edges[d <= self.bound]]))
        return d, near

    def _input_to_output(self, V: np.ndarray, tri: np.ndarray, tree) -> np.ndarray:
        """Each input point's distance to the output (its last value where
        its nearest facet is still there and it was within the bound);
        ``tree`` is a k-d tree of ``V``."""
        again, kept = np.ones(len(self._d_in), bool), np.zeros(len(self._d_in), bool)
        local, now = tri, RowSet(tri)
        if self._tri is not None:
            kept = now.contains(self._near)  # the nearest facet is still there
            again = ~kept | ((self._d_in > self.bound) & self._free)
            # Every new facet touches a vertex of a new one (local holds them).
            fresh = tri[~self._tri.contains(tri)]
            touched = np.zeros(len(V), bool)
            touched[fresh.ravel()] = True
            local = tri[touched[tri].any(axis=1)]
        self._tri = now
        idx = np.flatnonzero(again)
        upper = np.full(len(idx), np.inf)
        if len(idx) and len(local) < len(tri):
            last = self._d_in[idx], self._near[idx]
            new = _distances(V, local, self._probes[idx])
            self._d_in[idx], self._near[idx] = _nearer(kept[idx], last, *new)
            # Nearest facet gone, beyond the bound: measured where the nearest can be.
            idx = idx[~kept[idx] & (self._d_in[idx] > self.bound)]
            upper = self._d_in[idx]
        if len(idx):
            around = _around(V, tri, tree, self._probes[idx], upper)
            self._d_in[idx], self._near[idx] = _distances(V, around, self._probes[idx])
        return self._d_in

    def stats(self) -> dict:
        """``checks`` made, points ``proposed``, points beyond the bound ``left``
        at the last check (next to protecting balls, too near a sample, or
        made by the repairs after the last proposing check), the
        ``largest`` distance measured there, and whether the check was
        ``budgeted`` (:data:`BUDGET`)."""
        keys = ("bound", "checks", "proposed", "left", "largest", "budgeted")
        return {k: getattr(self, k) for k in keys}


def input_probes(
    vertices: np.ndarray, faces: np.ndarray, spacing: float, kept: np.ndarray | None = None
) -> np.ndarray:
    """The vertices of the input's ``faces``, then points along its creased
    edges (whose two faces are not coplanar), at most ``spacing`` apart and at
    least the midpoint: a long crease can stand out of the output between its
    ends. With ``kept`` ((m,) bool), only vertices and edges all of whose
    vertices' faces are kept."""
    v = vertices
    normals = unit_rows(np.cross(v[faces[:, 1]] - v[faces[:, 0]], v[faces[:, 2]] - v[faces[:, 0]]))
    creased = sharp_edges(faces, normals, CREASE_ANGLE)
    ok = np.zeros(len(v), bool)
    ok[faces.reshape(-1)] = True
    if kept is not None:
        np.logical_and.at(ok, faces.reshape(-1), np.repeat(kept, 3))
        creased = creased[ok[creased].all(axis=1)]
    p, q = v[creased[:, 0]], v[creased[:, 1]]
    parts = np.maximum(np.ceil(np.linalg.norm(q - p, axis=1) / spacing), 2).astype(np.int64)
    owner = np.repeat(np.arange(len(p)), parts - 1)
    step = np.arange(len(owner)) - np.repeat(np.cumsum(parts - 1) - (parts - 1), parts - 1) + 1
    t = (step / parts[owner])[:, None]
    return np.concatenate([v[ok], p[owner] + t * (q[owner] - p[owner])])


def _on_one_face(surface, V: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """(k,) bool: ``edges`` of ``V`` whose two ends were found as crossings
    on one face of ``surface``; the face is flat, so their midpoints are on it."""
    face = surface.crossing_faces(V)
    a, b = face[edges[:, 0]], face[edges[:, 1]]
    return (a >= 0) & (a == b)


def _around(V: np.ndarray, tri: np.ndarray, tree, points: np.ndarray, upper: np.ndarray):
    """The facets of ``tri`` that can hold the point nearest to each of
    ``points`` given ``upper`` bounds on those distances (all of ``tri``
    where a bound is infinite). A facet at distance ``d`` from a point has
    every vertex within ``d`` plus its longest edge of it (a triangle's
    diameter), so the facets with a vertex within ``upper`` plus the longest
    edge of every facet hold the nearest points."""
    if len(tri) == 0 or not np.isfinite(upper).all():
        return tri
    corners = V[tri]
    longest = np.sqrt(max(
        np.einsum("ij,ij->i", d, d).max() for d in (
            corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 1],
            corners[:, 0] - corners[:, 2],
        )
    ))  # fmt: skip
    # A relative margin for rounding in the bounds and the tree's distances.
    reach = (upper + longest) * (1.0 + 1e-9) + 1e-300
    found = tree.query_ball_point(points, reach, return_sorted=False)
    near = np.zeros(len(V), bool)
    near[np.fromiter(chain.from_iterable(found), np.int64)] = True
    return tri[near[tri].any(axis=1)]


def _nearer(kept, last, d, near) -> tuple[np.ndarray, np.ndarray]:
    """Distances ``d`` to the new facets and those facets ``near``, or where
    ``kept`` (the nearest facet is still there) the ``last`` pair if nearer:
    the distance to the output is then exactly the smaller of the two, since
    every other facet was there before."""
    back = kept & (last[0] < d)
    return np.where(back, last[0], d), np.where(back[:, None], last[1], near)


def _distances(V: np.ndarray, tri: np.ndarray, points: np.ndarray):
    """Each of ``points``' distance to the facets ``tri`` of ``V`` and its
    nearest facet (inf and -1 without facets); the tree is built without a
    side or winding numbers."""
    if len(tri) == 0:
        return np.full(len(points), np.inf), np.full((len(points), 3), -1, np.int64)
    d, _, face, _ = core.MeshDistance(V, tri, side=False, winding=False).query(points)
    return d, tri[face]


def _ends_and_midpoints(ends: np.ndarray) -> np.ndarray:
    """``(3k, 3)``: the ends of ``(k, 2, 3)`` segments, then their midpoints."""
    return np.concatenate([ends[:, 0], ends[:, 1], ends.mean(axis=1)])


def _in_budget(points, dist, keep, blocked, bound: float, n: int) -> np.ndarray:
    """``keep`` without the ``points`` within :data:`CLEARANCE` ``bound`` of
    ``blocked``, then only the farthest (by ``dist``) :data:`BUDGET` ``n``."""
    budget = int(BUDGET * n)
    if len(blocked):
        clear = cKDTree(blocked).query(points, distance_upper_bound=CLEARANCE * bound)[0]
        keep = keep & np.isinf(clear)
    idx = np.flatnonzero(keep)
    if len(idx) > budget:
        keep = np.zeros_like(keep)
        keep[idx[np.argsort(-dist[idx], kind="stable")[:budget]]] = True
    return keep


def _none(name: str) -> Candidates:
    return Candidates(name, np.zeros((0, 3)), np.zeros(0), False)


def deviation_stage(surface, distance_bound: float | None, balls=None) -> DeviationStage | None:
    """The stage for a closed mesh input with a distance bound (one that
    intersects itself measured on the faces of its union's surface), None
    otherwise (an open mesh's hole patches are not on its faces)."""
    closed = getattr(surface, "sign_method", None) == "side"
    if distance_bound is None or not (closed or getattr(surface, "_face_sides", None) is not None):
        return None
    return DeviationStage(surface, float(distance_bound), balls)
