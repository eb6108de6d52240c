"""rdmesh: guaranteed-quality triangle meshes of implicit surfaces.

Restricted Delaunay refinement (Boissonnat-Oudot) over CGAL's 3D Delaunay
triangulation, driven from Python with vectorised surface evaluations.
"""

import logging

from . import csg, surfaces
from ._errors import (
    BoundingSphereError,
    BudgetExceeded,
    CGALError,
    EmptySurfaceError,
    InternalCheckError,
    Interrupted,
    MeshInputError,
    OracleError,
    RdmeshError,
    RefinementStalled,
    StoppedEarly,
)
from .api import mesh_surface
from .batch import Job, JobResult, mesh_many
from .blocks import mesh_volume_blocks
from .core import CGAL_VERSION
from .features import FeatureError, MeshFeatures
from .io.result import SurfaceMesh
from .refine.criteria import FacetCriteria
from .surfaces.expressions import ExpressionError
from .surfaces.mesh import MeshSurface
from .surfaces.oracle import ImplicitSurface
from .surfaces.volume import VolumeSurface

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
    "FeatureError",
    "ImplicitSurface",
    "InternalCheckError",
    "Interrupted",
    "Job",
    "JobResult",
    "MeshFeatures",
    "MeshInputError",
    "MeshSurface",
    "OracleError",
    "RdmeshError",
    "RefinementStalled",
    "StoppedEarly",
    "SurfaceMesh",
    "VolumeSurface",
    "csg",
    "mesh_many",
    "mesh_volume_blocks",
    "mesh_surface",
    "surfaces",
]
