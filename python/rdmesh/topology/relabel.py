"""Pinched vertices of the final complex made one disk by relabelling cells (issue 30).

Below the spacing floor, where two sheets of the surface come closer than the
samples can separate (a neck or a wedge of a linear volume's interpolant), the
restricted complex can be pinched: an edge in four triangles, or a vertex
with two fans. There the parity rule (:func:`rdmesh.refine.pipeline._cut_by_parity`)
has made the complex the boundary of the Delaunay cells whose Voronoi vertex
is inside, so it is made one disk at each pinched vertex by moving a group
of the cells around it to the other side (the core's ``relabel_stars``): the
group whose circumcentres lie nearest the surface, so that a neck thinner
than the floor is cut, or a gap thinner than it filled, whichever moves the
surface least. The faces so changed are not restricted
Delaunay facets; the report says where.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from .. import core
from .._geometry import circumcentres
from .._vectors import row_index, row_norms
from ..surfaces.oracle import ImplicitSurface, forward_gradient
from .complex import ComplexStatus, complex_status

#: Passes of relabelling: a flip can pinch a vertex of the flipped cells,
#: which the next pass repairs (the grey-matter map needs one).
MAX_PASSES = 4


@dataclass
class Relabelled:
    """The faces after relabelling, and what changed.

    Attributes
    ----------
    faces : (F, 3) sample ids, outward.
    centres : (F, 3) surface centre of each face; a face the relabelling
        added has its circumcentre (its Voronoi edge need not cross the surface).
    cells : number of cell flips.
    changed : (k, 3) centroids of the faces added or removed.
    pinched : number of distinct vertices found pinched.
    left : (m,) sample ids still pinched.
    timed_out : the time allowed ended the relabelling before every pinched
        vertex was visited.
    """

    faces: np.ndarray
    centres: np.ndarray
    cells: int
    changed: np.ndarray
    pinched: int
    left: np.ndarray
    timed_out: bool = False


def pinched_vertices(status: ComplexStatus, n_vertices: int) -> np.ndarray:
    """Sample ids at an edge in three or more faces, or with two or more fans."""
    edges = status.edge_key[status.bad_edges(allow_boundary=True)]
    fans = np.flatnonzero(status.vertex_fans > 1)
    return np.unique(np.concatenate([edges // n_vertices, edges % n_vertices, fans]))


def surface_distance(surface: ImplicitSurface, points: np.ndarray) -> np.ndarray:
    """``|f| / |grad f|`` at ``points``, a first-order estimate of their distance
    to the surface; +inf outside the bounding sphere (never evaluated there)
    or where the gradient vanishes."""
    out = np.full(len(points), np.inf)
    inside = row_norms(points - surface.centre) < surface.radius
    if inside.any():
        p = points[inside]
        g = row_norms(forward_gradient(surface, p))
        with np.errstate(divide="ignore", invalid="ignore"):
            d = np.abs(surface(p)) / g
        out[inside] = np.where(g > 0, d, np.inf)
    return out


def relabel_pinches(
    rdt: core.RestrictedDelaunay,
    surface: ImplicitSurface,
    vertices: np.ndarray,
    faces: np.ndarray,
    centres: np.ndarray,
    status: ComplexStatus | None = None,
    seconds: float = np.inf,
) -> Relabelled | None:
    """Relabel cells at the pinched vertices of ``faces``; None when none is pinched.

    Parameters
    ----------
    rdt : the core whose Delaunay cells ``faces`` bound.
    surface : the surface; the group of cells moved at a vertex is the one
        whose circumcentres lie nearest it (:func:`surface_distance`, the
        largest of the group), so the mesh moves least.
    vertices : (n, 3) the samples.
    faces : (F, 3) restricted facets, outward.
    centres : (F, 3) their surface centres.
    status : :func:`complex_status` of ``faces``, if known.
    seconds : the time allowed (a run's ``time_limit``): the vertices not
        reached by then (in id order) are left pinched, and ``timed_out`` says so.
    """
    end = time.perf_counter() + seconds
    n = len(vertices)
    st = complex_status(faces, n) if status is None else status
    todo = pinched_vertices(st, n)
    if not len(todo):
        return None
    seen, out, flips, timed_out = [todo], faces, 0, False
    for _ in range(MAX_PASSES):
        timed_out = time.perf_counter() >= end
        if timed_out:
            break
        cells, cc = rdt.star_cells(todo)
        cost = surface_distance(surface, cc)
        left = max(end - time.perf_counter(), 0.0)
        out, flipped, timed_out = rdt.relabel_stars(out, todo, cells, cost, left)
        flips += len(flipped)
        todo = pinched_vertices(complex_status(out, n), n)
        if timed_out or not len(flipped) or not len(todo):
            break
        seen.append(todo)
    before, after = np.sort(faces, axis=1), np.sort(out, axis=1)
    kept = row_index(after, before)
    gone = row_index(before, after) < 0
    new_centres = np.empty((len(out), 3))
    new_centres[kept >= 0] = centres[kept[kept >= 0]]
    new_centres[kept < 0] = circumcentres(vertices[out[kept < 0]])
    changed = np.concatenate([vertices[faces[gone]], vertices[out[kept < 0]]]).mean(axis=1)
    return Relabelled(
        faces=out,
        centres=new_centres,
        cells=flips,
        changed=changed,
        pinched=len(np.unique(np.concatenate(seen))),
        left=todo,
        timed_out=timed_out,
    )
