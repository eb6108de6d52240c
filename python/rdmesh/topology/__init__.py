"""Topology: the restricted complex, the topological-ball tests and the report.

- :mod:`~rdmesh.topology.complex`: edge and fan counts of the restricted complex;
- :mod:`~rdmesh.topology.tests`: the topological-ball tests (Cheng-Dey-Ramos-Ray);
- :mod:`~rdmesh.topology.loops`: the loop test inside Voronoi facets;
- :mod:`~rdmesh.topology.snapshot`: one round's view, derived data computed once;
- :mod:`~rdmesh.topology.report`: the report and its statement.
"""

from .report import topology_report
from .snapshot import Snapshot
from .tests import CELL_NORMAL_ANGLE, SILHOUETTE_ANGLE, TESTS, Violations

__all__ = [
    "CELL_NORMAL_ANGLE",
    "SILHOUETTE_ANGLE",
    "TESTS",
    "Snapshot",
    "Violations",
    "topology_report",
]
