"""Exception types raised by rdmesh."""

from __future__ import annotations

from typing import Any


class RdmeshError(Exception):
    """Base class of every rdmesh-specific error."""


class OracleError(RdmeshError, ValueError):
    """The surface function misbehaved: it raised, returned the wrong shape,
    or returned NaN or infinity."""


class EmptySurfaceError(RdmeshError, ValueError):
    """No part of the surface was found inside the bounding sphere."""


class BoundingSphereError(RdmeshError, ValueError):
    """The surface reaches the bounding sphere (or f <= 0 outside the surface)."""


class MeshInputError(RdmeshError, ValueError):
    """A triangle mesh given to :class:`rdmesh.MeshSurface` is not usable: not a
    mesh (wrong shapes, empty, non-finite vertices, indices out of range, all
    faces of zero area) or too open to tell inside from outside."""


class CGALError(RdmeshError, RuntimeError):
    """CGAL reported a failure inside the C++ core."""


class ExpressionError(RdmeshError, ValueError):
    """The text is not an accepted expression (see
    :func:`rdmesh.surfaces.expressions.parse_expression`).

    Attributes
    ----------
    text : str
        The expression text.
    reason : str
        What is wrong, e.g. ``"unknown name 'os'"``.
    column : int or None
        1-based column of the offending part, when known.
    """

    def __init__(self, text: str, reason: str, column: int | None = None) -> None:
        shown = text if len(text) <= 60 else text[:57] + "..."
        where = f" (column {column})" if column is not None else ""
        super().__init__(f"invalid expression {shown!r}: {reason}{where}")
        self.text = text
        self.reason = reason
        self.column = column


class StoppedEarly(RdmeshError):
    """Refinement stopped before it finished: a budget ran out
    (:class:`BudgetExceeded`), it stalled (:class:`RefinementStalled`) or
    Ctrl-C interrupted it (:class:`Interrupted`). Catch this to get the
    partial mesh whatever the cause.

    Attributes
    ----------
    mesh : SurfaceMesh
        The mesh as it stood when refinement stopped, flagged
        ``complete=False``. It may not be watertight.
    reason : str
        Why refinement stopped.
    """

    def __init__(self, message: str, mesh: Any = None, reason: str = "") -> None:
        super().__init__(message)
        self.mesh = mesh
        self.reason = reason


class BudgetExceeded(StoppedEarly):
    """Refinement hit a budget (vertices, rounds or time) before it finished;
    ``.mesh`` holds the partial mesh, ``.reason`` says which budget ran out."""


class Interrupted(StoppedEarly):
    """Refinement was interrupted (Ctrl-C); ``.mesh`` holds the partial mesh.

    Not a :class:`BudgetExceeded`: code that catches a budget stop to go on
    with the partial mesh does not swallow a Ctrl-C.
    """


class RefinementStalled(BudgetExceeded):
    """A refinement batch added no new sample (its points were all existing
    samples): the run stops instead of repeating it. ``.mesh`` holds the mesh
    as it stood; ``.reason`` says which stage stalled."""


class InternalCheckError(RdmeshError, RuntimeError):
    """A self-check of the restricted Delaunay bookkeeping failed (debug mode,
    ``RDMESH_CHECK=1``): a bug in rdmesh, please report it."""
