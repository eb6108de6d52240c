"""The blocks' meshes welded into one, and what holds at the seams.

Neighbouring blocks inserted the same ball centres on their common face, so
their boundary vertices there are the same points, bit for bit: the weld
merges vertices with identical coordinates (nothing within a tolerance),
concatenating the blocks in block order and sorting vertices and faces, so
the output does not depend on which worker made which block. It then checks
the result exactly: every seam edge (consecutive centres on a face between
blocks) must have two triangles, every boundary edge must lie on the
volume's own box, and no edge may have more than two triangles.
"""

from __future__ import annotations

import numpy as np

from .._geometry import min_angles
from .._mesh_components import distinct_edges
from ..features.check import MeshFeatures, check_features
from ..io.result import SurfaceMesh
from .layout import Layout
from .network import Network
from .tasks import BlockResult

#: Places listed in the report at most.
MAX_PLACES = 20


def weld(results: list[BlockResult]) -> SurfaceMesh:
    """One mesh from the blocks' meshes (in block order), equal vertices merged."""
    vs = [r.vertices for r in results]
    offsets = np.r_[0, np.cumsum([len(v) for v in vs])]
    v = np.concatenate(vs) if vs else np.zeros((0, 3))
    f = np.concatenate([r.faces + o for r, o in zip(results, offsets, strict=False)])
    c = np.concatenate([r.facet_centres for r in results])
    unresolved = np.concatenate([r.unresolved for r in results])
    if not len(v):
        return SurfaceMesh(
            v, f.reshape(0, 3).astype(np.int64), c.reshape(0, 3), unresolved=unresolved
        )
    verts, inverse = np.unique(v, axis=0, return_inverse=True)
    faces = inverse.reshape(-1)[f].astype(np.int64)
    # Each face starts at its smallest vertex; faces sorted (as from_facets does).
    shift = np.argmin(faces, axis=1)
    faces = faces[np.arange(len(faces))[:, None], (shift[:, None] + np.arange(3)) % 3]
    order = np.lexsort(faces.T[::-1])
    mesh = SurfaceMesh(verts, faces[order], c[order], unresolved=unresolved)
    mesh.stats.update(vertices=len(verts), faces=len(faces), duplicates_merged=len(v) - len(verts))
    return mesh


def _rows(a: np.ndarray) -> np.ndarray:
    """Rows of ``(k, 3)`` float64 as one structured value each (compared field by field)."""
    a = np.ascontiguousarray(a, dtype=np.float64)
    return a.view([("x", "<f8"), ("y", "<f8"), ("z", "<f8")]).reshape(-1)


def find_rows(table: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """Index of each of ``rows`` in ``table`` (``(n, 3)``, sorted as by
    ``np.unique(axis=0)``), equal in every coordinate; -1 where absent."""
    if not len(table) or not len(rows):
        return np.full(len(rows), -1, np.int64)
    t, r = _rows(table), _rows(rows)
    i = np.minimum(np.searchsorted(t, r), len(t) - 1)
    return np.where(t[i] == r, i, -1).astype(np.int64)


def on_outer_box(layout: Layout, points: np.ndarray) -> np.ndarray:
    """Which points lie exactly on a face of the volume's box, ``(k, 6)``: one
    column per face (low x, high x, low y, ...)."""
    box = layout.whole_box
    cols = []
    for a in range(3):
        cols += [points[:, a] == box[0, a], points[:, a] == box[1, a]]
    return np.stack(cols, axis=1) if len(points) else np.zeros((0, 6), bool)


def seam_check(mesh: SurfaceMesh, net: Network, layout: Layout) -> dict:
    """The exact checks of the welded mesh; sets ``mesh.features``.

    Returns the report's ``seams`` entry: open edges (one triangle) away from
    the volume's box and non-manifold edges (three or more), with places; the
    feature check of every seam and outer curve against the welded mesh; the
    smallest angle of the triangles with a ball centre and of the others."""
    n = len(mesh.vertices)
    out: dict = {
        "open_edges": 0,
        "nonmanifold_edges": 0,
        "open_where": [],
        "nonmanifold_where": [],
    }
    if not len(mesh.faces):
        return out
    keys, counts = distinct_edges(mesh.faces, n)
    edges = np.c_[keys // n, keys % n]
    mid = 0.5 * (mesh.vertices[edges[:, 0]] + mesh.vertices[edges[:, 1]])
    # An edge with one triangle is a boundary edge where both ends lie on the
    # same face of the volume's box; anywhere else it is a hole.
    one = counts == 1
    ends = on_outer_box(layout, mesh.vertices)
    outer = (ends[edges[:, 0]] & ends[edges[:, 1]]).any(axis=1)
    hole = one & ~outer
    many = counts > 2
    out.update(
        open_edges=int(hole.sum()),
        nonmanifold_edges=int(many.sum()),
        open_where=np.round(mid[hole][:MAX_PLACES], 9).tolist(),
        nonmanifold_where=np.round(mid[many][:MAX_PLACES], 9).tolist(),
        boundary_edges_on_box=int((one & outer).sum()),
    )
    balls = net.balls
    if len(balls):
        at = find_rows(mesh.vertices, balls.centres)
        mesh.features = check_features(balls, net.graph, at, np.arange(n), mesh.faces, n)
        heavy = np.zeros(n, bool)
        heavy[at[at >= 0]] = True
        touch = heavy[mesh.faces].any(axis=1)
    else:
        mesh.features = MeshFeatures(held=True)
        touch = np.zeros(len(mesh.faces), bool)
    ang = min_angles(mesh.vertices[mesh.faces])
    out["min_angle_at_seams"] = float(ang[touch].min()) if touch.any() else None
    out["min_angle_elsewhere"] = float(ang[~touch].min()) if (~touch).any() else None
    out["held"] = bool(mesh.features.held and not hole.any() and not many.any())
    return out
