"""Pockets dropped from a remesh: tiny components on a covered input (issue 30).

Where two sheets of an input mesh come closer than the spacing floor (the
banks of a brain's sulcus, a fold where a model's faces cross), the final
complex can hold tiny closed components: a Delaunay cell or two of the thin
gap, sealed off by the relabelling of pinched vertices
(:mod:`rdmesh.topology.relabel`). An input that is a closed,
non-self-intersecting mesh has a known topology: each of its components is
one closed surface. So an output component that is smaller than the size
bound and lies on input components that a larger output component already
covers is not part of that topology, and is dropped. On an open or
self-intersecting input (its solid comes from the winding number) such a
component may be a piece of that solid, but one smaller than the size bound,
which the refinement cannot resolve there (its points are refused below the
spacing floor); it is dropped as well, and the report says which reason
applies. Only mesh inputs (:meth:`MeshSurface.input_components`) are pruned
so; functions and expressions, whose small components can be real, lose only
the specks of :func:`drop_specks`: components below a tenth of the size
bound made entirely of vertices next to points the run left unresolved, where
two solids of a union touch (at a point or along a line, the gap between
their sheets goes below the floor) or the surface is singular. Volumes lose
nothing: their interpolant has real components of any size there.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from .._mesh_components import labelled_components

#: Without a size bound, components smaller than this times the bounding
#: radius are candidates.
UNBOUNDED_SIZE = 0.01

#: A speck is smaller than this fraction of the size bound (ten times the
#: topology floor; measured 0.02-0.04 on unions of touching solids, where a
#: one-voxel speck of a volume meshed at one voxel is about 1), and its
#: vertices lie within SPECK_REACH times its extent of unresolved points
#: (measured 1.0-1.8 there; RESULTS.md).
SPECK_SIZE, SPECK_REACH = 0.1, 2.0


@dataclass
class Pockets:
    """What :func:`drop_pockets` removed.

    Attributes
    ----------
    keep : (F,) bool, the faces kept.
    centres : (k, 3) the centroid of each dropped component.
    sizes : (k,) the largest extent of each along an axis.
    faces : number of faces dropped.
    ruled_out : whether the input's known topology rules them out (a closed,
        non-self-intersecting input), or they are only below the size bound.
    specks : they are :func:`drop_specks`' (any input), not pockets on a
        covered input component.
    """

    keep: np.ndarray
    centres: np.ndarray
    sizes: np.ndarray
    faces: int
    ruled_out: bool = True
    specks: bool = False


@dataclass
class _Components:
    """The output's components: each face's and used vertex's label, and each
    component's largest extent along an axis, centroid and face count."""

    count: int
    face_label: np.ndarray
    comp: np.ndarray  # (m,) the component of each used vertex
    pts: np.ndarray  # (m, 3) the used vertices
    extent: np.ndarray
    centre: np.ndarray
    faces: np.ndarray  # (count,) faces of each component

    @classmethod
    def of(cls, vertices: np.ndarray, faces: np.ndarray) -> _Components | None:
        """None with fewer than two components."""
        count, face_label, vertex_label = labelled_components(
            np.asarray(faces, np.int64), len(vertices)
        )
        if count < 2:
            return None
        used = np.flatnonzero(vertex_label >= 0)
        comp, pts = vertex_label[used], vertices[used]
        lo = np.full((count, 3), np.inf)
        hi = np.full((count, 3), -np.inf)
        np.minimum.at(lo, comp, pts)
        np.maximum.at(hi, comp, pts)
        centre = np.stack([np.bincount(comp, pts[:, a], count) for a in range(3)], axis=1)
        centre /= np.bincount(comp, minlength=count)[:, None]
        nfaces = np.bincount(face_label, minlength=count)
        return cls(count, face_label, comp, pts, (hi - lo).max(axis=1), centre, nfaces)

    def dropped(self, drop: np.ndarray, **why: bool) -> Pockets | None:
        """The :class:`Pockets` of the components ``drop`` (bool), or None."""
        if not drop.any():
            return None
        keep = ~drop[self.face_label]
        return Pockets(
            keep=keep,
            centres=self.centre[drop],
            sizes=self.extent[drop],
            faces=int((~keep).sum()),
            **why,
        )


def pocket_reason(ruled_out: bool, specks: bool = False) -> str:
    """Why pockets were dropped, for logs and the report."""
    if specks:
        return (
            "every vertex of each lies next to points refused below the spacing floor (two "
            "sheets closer than the floor, as where two solids of a union touch, or a "
            "singular point), so no sample resolves them"
        )
    if ruled_out:
        return (
            "on input components that a larger output component covers: the closed "
            "input's topology rules them out"
        )
    return (
        "on input components that a larger output component covers: the input is open or "
        "intersects itself, so they may be pieces of the solid its winding number bounds, "
        "too small for the size bound to resolve"
    )


def drop_pockets(
    vertices: np.ndarray,
    faces: np.ndarray,
    input_components: Callable[[np.ndarray], np.ndarray],
    size: Callable[[np.ndarray], np.ndarray],
    ruled_out: bool = True,
) -> Pockets | None:
    """The output components that are pockets; None when there are none.

    Parameters
    ----------
    vertices : (n, 3) sample positions.
    faces : (F, 3) the output faces (sample ids).
    input_components : maps ``(k, 3)`` points on the input to the input
        component they lie on, ``(k,)`` int.
    size : the size bound at ``(k, 3)`` points, ``(k,)``.
    ruled_out : recorded in the result (see :class:`Pockets`).

    A component is a pocket when it is the largest output component (by
    faces; the first on ties) of none of the input components its vertices
    lie on, and its largest extent along an axis is below the size bound at
    its centroid.
    """
    c = _Components.of(vertices, faces)
    if c is None:
        return None
    small = c.extent < size(c.centre)
    if not small.any():
        return None  # no candidate: the input is not queried
    # The output components on each input component, largest first.
    pairs = np.unique(np.stack([input_components(c.pts), c.comp], axis=1), axis=0)
    order = np.lexsort((pairs[:, 1], -c.faces[pairs[:, 1]], pairs[:, 0]))
    pairs = pairs[order]
    first = np.r_[True, pairs[1:, 0] != pairs[:-1, 0]]
    main = np.zeros(c.count, bool)
    main[pairs[first, 1]] = True
    return c.dropped(~main & small, ruled_out=ruled_out)


def drop_specks(
    vertices: np.ndarray,
    faces: np.ndarray,
    unresolved: np.ndarray,
    size: Callable[[np.ndarray], np.ndarray],
) -> Pockets | None:
    """The output components that are specks; None when there are none.

    A component other than the largest (by faces) is a speck when its largest
    extent along an axis is below :data:`SPECK_SIZE` times the size bound at
    its centroid and each of its vertices lies within :data:`SPECK_REACH`
    times that extent of one of the ``unresolved`` points ``(k, 3)`` (refused
    below the spacing floor): a cell or two of a gap thinner than the floor,
    sealed off by the parity rule or the relabelling of pinched vertices.
    """
    if not len(unresolved):
        return None
    c = _Components.of(vertices, faces)
    if c is None:
        return None
    small = c.extent < SPECK_SIZE * size(c.centre)
    small[np.argmax(c.faces)] = False
    if not small.any():
        return None
    at = np.flatnonzero(small[c.comp])
    d, _ = cKDTree(unresolved).query(c.pts[at])
    far = np.zeros(c.count, bool)
    far[c.comp[at][d > SPECK_REACH * c.extent[c.comp[at]]]] = True
    return c.dropped(small & ~far, ruled_out=False, specks=True)
