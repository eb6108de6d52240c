"""The mesh result: :class:`SurfaceMesh`, its exports and its picture."""

from .result import MESH_FORMATS, SurfaceMesh

__all__ = ["MESH_FORMATS", "SurfaceMesh"]
