"""Feature curves and corners (creases, boundary curves), and the protecting
balls that keep them in the mesh (../shared/design/creases.md)."""

from .check import MeshFeatures
from .given import ProtectingBalls
from .graph import FeatureCurve, FeatureError, FeatureGraph
from .protect import Balls, protect

__all__ = [
    "Balls",
    "FeatureCurve",
    "FeatureError",
    "FeatureGraph",
    "MeshFeatures",
    "ProtectingBalls",
    "protect",
]
