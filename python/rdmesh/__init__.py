"""rdmesh: guaranteed-quality triangle meshes of implicit surfaces.

Restricted Delaunay refinement (Boissonnat-Oudot) over CGAL's 3D Delaunay
triangulation, driven from Python with vectorised surface evaluations.
"""

import logging

from . import surfaces
from ._errors import (
    BoundingSphereError,
    BudgetExceeded,
    CGALError,
    EmptySurfaceError,
    Interrupted,
    OracleError,
    RdmeshError,
)
from ._rdt import CGAL_VERSION
from .api import mesh_surface
from .criteria import FacetCriteria
from .expressions import ExpressionError
from .oracles import ImplicitSurface
from .result import SurfaceMesh

logging.getLogger("rdmesh").addHandler(logging.NullHandler())

__version__ = "0.1.0"
__all__ = [
    "BoundingSphereError",
    "BudgetExceeded",
    "CGALError",
    "CGAL_VERSION",
    "EmptySurfaceError",
    "ExpressionError",
    "FacetCriteria",
    "ImplicitSurface",
    "Interrupted",
    "OracleError",
    "RdmeshError",
    "SurfaceMesh",
    "mesh_surface",
    "surfaces",
]
