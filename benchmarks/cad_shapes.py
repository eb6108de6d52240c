# SPDX-License-Identifier: GPL-3.0-or-later
"""Test shapes with known creases for issue 27's feature benchmark.

CAD-like closed triangle meshes (trimesh), each with its ground-truth sharp
edges as polylines split at the corners, and its genus:

- :func:`box`: the cube ``[-1, 1]^3`` (12 triangles), genus 0; its 12 edges.
- :func:`box_with_hole`: a square slab with a round hole drilled through it,
  genus 1.  The hole is a regular polygon of ``HOLE_SIDES`` = 64 sides
  (adjacent wall faces turn by 5.6 degrees, not a crease); its two rims are
  sharp closed loops (90 degrees) with no corner.
- :func:`l_bracket`: an L-shaped bracket (an L profile extruded), genus 0;
  six vertical edges (one re-entrant) and the two L outlines.
- :func:`fillet_chamfer`: a square block with one vertical edge rounded
  (a quarter circle of radius 0.5 in ``FILLET_SEGMENTS`` = 16 segments,
  turns of 5.6 degrees: neither the arc nor its tangent joins are creases)
  and one vertical edge chamfered at 45 degrees, which leaves two vertical
  creases of dihedral angle 135 degrees (the normals differ by 45 degrees),
  genus 0.  With CGAL's ``detect_features(60)`` those two are NOT detected
  (45 < 60); a feature angle below 45 finds them.

The extruded shapes are made exactly: a shapely polygon (with the hole as an
interior ring) extruded with ``trimesh.creation.extrude_polygon`` (the caps
triangulated by mapbox-earcut, which adds no vertex), so every crease is an
edge of the mesh.  The creases are built from the 2-D profile, independently
of the mesh: the outlines of the two caps (always 90 degrees) and the
vertical edges at profile vertices whose two wall faces' normals differ by
more than ``SHARP_ANGLE`` = 30 degrees (the ground-truth rule here; the
profile's turn at the vertex).  Corners are the ends of the vertical creases.
Each shape is then centred on its bounding box and scaled so that its
farthest vertex is at distance 1 from the origin (``box`` is not scaled).

The implicit surfaces of ``cgal_reference`` with creases, their exact curves
(:mod:`feature_metrics` curves, whose ``project`` gives exact distances):

- :func:`box_curves`: the 12 edges of ``max(|x|,|y|,|z|) - 1``, split at the
  8 corners;
- :func:`box_ball_curves`: ``min(box, |p - (1,1,1)| - 0.8)``: the 9 box edges
  the ball does not touch, the 3 edges through (1,1,1) cut at 0.2 where the
  ball meets them, and the 3 quarter circles (radius 0.8 about (1,1,1)) where
  the sphere meets the faces x = 1, y = 1, z = 1; 15 curves meeting at 10
  corners (the 7 untouched cube corners and the 3 cut points).

:func:`curve_polylines` turns them into polylines for ``mesh_3_features``
(each arc sampled by ``Arc.sample(64)``: 64 chords, sagitta 6.0e-5 for these
arcs, as the design note's measurement), with the end points shared exactly.
:func:`box_sdf` and :func:`box_ball_sdf` are the exact signed distances
(the union's is ``min`` of the two, exact outside and on the surface).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from feature_metrics import Arc, Polyline, Segment

__all__ = [
    "CAD_SHAPES",
    "FILLET_SEGMENTS",
    "HOLE_SIDES",
    "SHARP_ANGLE",
    "CadShape",
    "box",
    "box_ball_corners",
    "box_ball_curves",
    "box_ball_sdf",
    "box_corners",
    "box_curves",
    "box_sdf",
    "box_with_hole",
    "curve_polylines",
    "fillet_chamfer",
    "l_bracket",
]

#: Ground-truth rule of the CAD shapes: an edge is a crease when the normals
#: of its two faces differ by more than this many degrees.
SHARP_ANGLE = 30.0
#: Sides of the drilled hole's polygon.
HOLE_SIDES = 64
#: Segments of the fillet's quarter circle.
FILLET_SEGMENTS = 16

BALL_CENTRE = (1.0, 1.0, 1.0)
BALL_RADIUS = 0.8


@dataclass
class CadShape:
    """A closed triangle mesh with its creases.

    ``curves``: polylines ``(m, 3)`` in order, split at the corners (a closed
    loop repeats its first point last); ``angles``: each curve's normal
    difference in degrees (90 for a cube edge, 45 for a 135-degree chamfer
    edge); ``corners`` ``(K, 3)``: the curves' end points; ``genus`` of the
    closed surface.
    """

    name: str
    vertices: np.ndarray
    faces: np.ndarray
    curves: list[np.ndarray]
    angles: list[float]
    corners: np.ndarray
    genus: int
    description: str = ""
    scale: float = 1.0
    extra: dict = field(default_factory=dict)

    @property
    def diagonal(self) -> float:
        """The bounding-box diagonal."""
        return float(np.linalg.norm(self.vertices.max(axis=0) - self.vertices.min(axis=0)))

    def curve_objects(self) -> list[Polyline]:
        return [Polyline(c) for c in self.curves]

    def curves_sharper_than(self, angle: float) -> list[np.ndarray]:
        """The curves whose normals differ by more than ``angle`` degrees
        (what ``detect_features(angle)`` can find)."""
        return [c for c, a in zip(self.curves, self.angles, strict=True) if a > angle]


# ---------------------------------------------------------------------------
# Extrusions
# ---------------------------------------------------------------------------


def _turns(ring: np.ndarray) -> np.ndarray:
    """The turn in degrees at each vertex of a closed 2-D ring (no repeated
    last point): the angle between the incoming and the outgoing edge, which
    is the angle between the normals of the two wall faces meeting there."""
    d_in = ring - np.roll(ring, 1, axis=0)
    d_out = np.roll(ring, -1, axis=0) - ring
    cos = np.einsum("ij,ij->i", d_in, d_out) / (
        np.linalg.norm(d_in, axis=1) * np.linalg.norm(d_out, axis=1)
    )
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _ring_creases(ring: np.ndarray, heights: tuple[float, float]):
    """Creases of one profile ring extruded between two heights: the vertical
    edges at sharp vertices, and the ring at both heights split there."""
    turns = _turns(ring)
    sharp = np.flatnonzero(turns > SHARP_ANGLE)
    curves, angles, corners = [], [], []
    z0, z1 = heights
    for k in sharp:
        x, y = ring[k]
        curves.append(np.array([[x, y, z0], [x, y, z1]]))
        angles.append(float(turns[k]))
        corners += [(x, y, z0), (x, y, z1)]
    n = len(ring)
    for z in (z0, z1):
        pts3 = np.column_stack([ring, np.full(n, z)])
        if len(sharp) == 0:
            curves.append(np.vstack([pts3, pts3[:1]]))
            angles.append(90.0)
            continue
        for j, k in enumerate(sharp):
            nxt = sharp[(j + 1) % len(sharp)]
            idx = np.arange(k, nxt + (n if nxt <= k else 0) + 1) % n
            curves.append(pts3[idx])
            angles.append(90.0)
    return curves, angles, corners


def _extruded(
    name: str,
    exterior: np.ndarray,
    holes: list[np.ndarray],
    height: float,
    genus: int,
    description: str,
) -> CadShape:
    import shapely.geometry
    import trimesh

    poly = shapely.geometry.Polygon(exterior, holes)
    if not poly.is_valid:
        raise ValueError(f"{name}: invalid profile")
    mesh = trimesh.creation.extrude_polygon(poly, height, engine="earcut")
    v = np.asarray(mesh.vertices, dtype=np.float64)
    f = np.asarray(mesh.faces, dtype=np.int64)
    curves, angles, corners = [], [], []
    for ring in [exterior, *holes]:
        c, a, k = _ring_creases(np.asarray(ring, dtype=np.float64), (0.0, float(height)))
        curves += c
        angles += a
        corners += k
    # Centre on the bounding box, farthest vertex at distance 1; the same
    # operations on the curves, so their points stay equal to mesh vertices.
    centre = 0.5 * (v.min(axis=0) + v.max(axis=0))
    scale = 1.0 / float(np.linalg.norm(v - centre, axis=1).max())
    v = (v - centre) * scale
    curves = [(c - centre) * scale for c in curves]
    corners_arr = (np.unique(np.asarray(corners, dtype=np.float64), axis=0) - centre) * scale
    return CadShape(name, v, f, curves, angles, corners_arr, genus, description, scale)


def box_with_hole(sides: int = HOLE_SIDES) -> CadShape:
    """A 2 x 2 x 1 slab with a round hole of radius 0.4 drilled through its
    middle (a ``sides``-gon), scaled to radius 1.  Genus 1; creases: 4
    vertical edges, the outer outlines of both faces split at the 8 corners,
    and the hole's two rims (closed loops)."""
    sq = np.array([[-1.0, -1.0], [1.0, -1.0], [1.0, 1.0], [-1.0, 1.0]])
    t = 2 * np.pi * np.arange(sides) / sides
    hole = 0.4 * np.column_stack([np.cos(t), np.sin(t)])
    return _extruded(
        "box_with_hole",
        sq,
        [hole[::-1]],
        1.0,
        1,
        f"2 x 2 x 1 slab, hole radius 0.4 ({sides}-gon), scaled to radius 1",
    )


def l_bracket() -> CadShape:
    """An L profile (legs 2 and 1.5 long, 0.5 thick) extruded by 1, scaled to
    radius 1.  Genus 0; creases: 6 vertical edges (one re-entrant) and both
    L outlines split at the 12 corners."""
    prof = np.array([[0.0, 0.0], [2.0, 0.0], [2.0, 0.5], [0.5, 0.5], [0.5, 1.5], [0.0, 1.5]])
    return _extruded(
        "l_bracket", prof, [], 1.0, 0, "L profile 2 x 1.5, 0.5 thick, depth 1, scaled"
    )


def fillet_chamfer(segments: int = FILLET_SEGMENTS) -> CadShape:
    """A 2 x 2 x 1 block with the vertical edge at (1, 1) filleted (radius
    0.5, ``segments`` segments) and the one at (1, -1) chamfered at 45
    degrees (legs 0.4), scaled to radius 1.  Genus 0; creases: the vertical
    edges at (-1, -1) and (-1, 1) (90 degrees), the chamfer's two vertical
    edges (normals differ by 45 degrees) and both outlines split at the 8
    corners; the fillet's arc and its tangent joins are smooth."""
    rho, c = 0.5, 0.4
    t = np.linspace(0.0, 0.5 * np.pi, segments + 1)
    arc = np.column_stack([1 - rho + rho * np.cos(t), 1 - rho + rho * np.sin(t)])
    arc[0], arc[-1] = (1.0, 1 - rho), (1 - rho, 1.0)
    prof = np.vstack([[[-1.0, -1.0], [1 - c, -1.0], [1.0, -1 + c]], arc, [[-1.0, 1.0]]])
    return _extruded(
        "fillet_chamfer",
        prof,
        [],
        1.0,
        0,
        f"2 x 2 x 1 block, fillet radius 0.5 ({segments} segments), 45-degree chamfer "
        "with legs 0.4, scaled",
    )


def box() -> CadShape:
    """The cube ``[-1, 1]^3`` as 12 triangles; creases: its 12 edges."""
    import trimesh

    m = trimesh.creation.box(extents=(2.0, 2.0, 2.0))
    curves = [c.sample(1) for c in box_curves()]
    return CadShape(
        "box",
        np.asarray(m.vertices, dtype=np.float64),
        np.asarray(m.faces, dtype=np.int64),
        curves,
        [90.0] * len(curves),
        box_corners(),
        0,
        "the cube [-1, 1]^3, 12 triangles",
    )


#: The CAD meshes by name.
CAD_SHAPES = {
    "box": box,
    "box_with_hole": box_with_hole,
    "l_bracket": l_bracket,
    "fillet_chamfer": fillet_chamfer,
}


# ---------------------------------------------------------------------------
# The implicit surfaces' curves
# ---------------------------------------------------------------------------


def box_corners() -> np.ndarray:
    """The 8 corners of ``[-1, 1]^3``."""
    s = (-1.0, 1.0)
    return np.array([(x, y, z) for x in s for y in s for z in s])


def box_curves() -> list[Segment]:
    """The 12 edges of ``[-1, 1]^3``, each from its lower to its upper corner."""
    out = []
    for axis in range(3):
        o1, o2 = (a for a in range(3) if a != axis)
        for s1 in (-1.0, 1.0):
            for s2 in (-1.0, 1.0):
                p, q = [0.0] * 3, [0.0] * 3
                p[axis], q[axis] = -1.0, 1.0
                p[o1] = q[o1] = s1
                p[o2] = q[o2] = s2
                out.append(Segment(tuple(p), tuple(q)))
    return out


def box_ball_corners() -> np.ndarray:
    """The 10 corners of box_ball: 7 cube corners and the 3 cut points."""
    cut = 1.0 - BALL_RADIUS
    kept = [c for c in box_corners() if not np.all(c == 1.0)]
    return np.array([*kept, (cut, 1.0, 1.0), (1.0, cut, 1.0), (1.0, 1.0, cut)])


def box_ball_curves() -> list[Segment | Arc]:
    """The 15 creases of ``min(box, |p - (1,1,1)| - 0.8)``: 12 straight
    pieces (3 cut at ``1 - 0.8``) and 3 quarter circles."""
    cut = 1.0 - BALL_RADIUS
    out: list[Segment | Arc] = []
    for seg in box_curves():
        q = np.asarray(seg.b)
        if np.all(q == 1.0):  # an edge through (1, 1, 1): cut where the ball starts
            axis = int(np.flatnonzero(np.asarray(seg.a) != q)[0])
            end = [1.0, 1.0, 1.0]
            end[axis] = cut
            out.append(Segment(seg.a, tuple(end)))
        else:
            out.append(seg)
    # Face x = 1: from (1, cut, 1) to (1, 1, cut); the arc bulges to y, z < 1.
    for axis in range(3):
        o1, o2 = (a for a in range(3) if a != axis)
        start, end = [1.0, 1.0, 1.0], [1.0, 1.0, 1.0]
        start[o1] = cut
        end[o2] = cut
        # Turning from -e_o1 to -e_o2 is a rotation about e_o1 x e_o2.
        normal = np.cross(np.eye(3)[o1], np.eye(3)[o2])
        out.append(Arc(BALL_CENTRE, tuple(start), tuple(end), tuple(normal)))
    return out


def curve_polylines(curves, arc_segments: int = 64) -> list[np.ndarray]:
    """Polylines of exact curves for ``mesh_3_features``: a segment as its two
    ends, an arc as ``arc_segments`` chords (ends exact, so curves that meet
    share their end points bit for bit)."""
    out = []
    for c in curves:
        out.append(c.sample(arc_segments) if isinstance(c, Arc) else c.sample(1))
    return out


def box_sdf(p: np.ndarray) -> np.ndarray:
    """Exact signed distance to the cube ``[-1, 1]^3`` (negative inside)."""
    q = np.abs(np.asarray(p, dtype=np.float64)) - 1.0
    outside = np.linalg.norm(np.maximum(q, 0.0), axis=1)
    inside = np.minimum(q.max(axis=1), 0.0)
    return outside + inside


def box_ball_sdf(p: np.ndarray) -> np.ndarray:
    """``min`` of the cube's and the ball's exact signed distances: exact
    outside the union and on its surface; inside, a lower bound of the depth
    (mesh samples near the surface are within it)."""
    p = np.asarray(p, dtype=np.float64)
    ball = np.linalg.norm(p - np.asarray(BALL_CENTRE), axis=1) - BALL_RADIUS
    return np.minimum(box_sdf(p), ball)
