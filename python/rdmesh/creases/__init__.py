"""Creases and corners found in expressions and CSG trees (issue 28).

A surface whose function is an expression or a tree made by
:mod:`rdmesh.csg` is smooth except where a ``min``, ``max`` or ``abs`` node
switches branch. :func:`find_creases` finds those curves and their corners
exactly (:mod:`rdmesh.creases.search`); :mod:`rdmesh.features` then protects
them like any other feature curve.

Modules: :mod:`~rdmesh.creases.search` (seeds, the search, the result),
:mod:`~rdmesh.creases.system` (the equations of a crease and a corner),
:mod:`~rdmesh.creases.tracing` (Gauss-Newton projection, predictor-corrector
tracing), :mod:`~rdmesh.creases.boxes` (the interval octree that excludes
creases from boxes).
"""

from .search import CreaseSearch, find_creases, piece_model

__all__ = ["CreaseSearch", "find_creases", "piece_model"]
