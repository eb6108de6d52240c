"""The phases' order of stages, and the edge and vertex repairs that join a
round whose first stage offers few points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
import rdmesh
import volumes
from rdmesh.refine import mesher, phases
from rdmesh.refine.phases import JOIN_BELOW, Phases
from rdmesh.refine.stages import Candidates


@dataclass
class _Stage:
    name: str
    n: int
    radius: float = 1.0

    def candidates(self, snap) -> Candidates:
        x = np.full((self.n, 3), float(len(self.name)))
        x[:, 0] += np.arange(self.n)
        return Candidates(self.name, x, np.full(self.n, self.radius), True, self.n)


class _Floor:
    """Keeps points whose radius is above 0.5."""

    def keep(self, cand: Candidates) -> np.ndarray:
        return cand.radii > 0.5


def _ask(*stages):
    return Phases([list(stages)], _Floor()).ask(snap=None)


def test_few_facet_points_are_joined_by_the_edge_and_vertex_repairs():
    found, unresolved = _ask(_Stage("facet", 3), _Stage("edge", 2), _Stage("vertex", 4),
                             _Stage("isolated", 5))  # fmt: skip
    assert found.stage == "facet" and len(found) == 9
    names = found.stages(np.arange(len(found)))
    assert names.tolist() == ["facet"] * 3 + ["edge"] * 2 + ["vertex"] * 4
    assert found.violations == 9 and unresolved == []


def test_many_facet_points_keep_their_round_to_themselves():
    found, _ = _ask(_Stage("facet", JOIN_BELOW), _Stage("edge", 2), _Stage("vertex", 4))
    assert len(found) == JOIN_BELOW
    assert set(found.stages(np.arange(len(found)))) == {"facet"}


def test_joined_points_below_the_floor_are_unresolved():
    found, unresolved = _ask(_Stage("facet", 1), _Stage("edge", 2, radius=0.1))
    assert len(found) == 1
    assert len(np.concatenate(unresolved)) == 2


def test_without_joining_only_the_first_stage_is_asked(monkeypatch):
    monkeypatch.setattr(phases, "JOIN_BELOW", 0)
    found, _ = _ask(_Stage("facet", 3), _Stage("edge", 2))
    assert len(found) == 3 and found.origin is None


def test_a_joined_run_counts_each_stage_and_stays_closed(monkeypatch):
    joined = []
    insert = mesher._insert_stages

    def spy(m, points, stages):
        joined.append(len(set(stages)) > 1)
        return insert(m, points, stages)

    monkeypatch.setattr(mesher, "_insert_stages", spy)
    surface = rdmesh.VolumeSurface(volumes.kinked_lens(), isovalue=0.0, interpolation="linear")
    m = rdmesh.mesh_surface(surface, radius_bound=1.0)
    assert any(joined)
    inserted = m.stats["inserted"]
    assert inserted.get("edge", 0) > 0 and inserted.get("vertex", 0) > 0
    assert sum(inserted.values()) == m.stats["samples"]
    assert m.report["closed_manifold"] and m.complete


@pytest.mark.parametrize("cap", [5, 40])
def test_a_vertex_cap_cuts_a_joined_batch(cap):
    with pytest.raises(rdmesh.BudgetExceeded) as err:
        rdmesh.mesh_surface(rdmesh.surfaces.torus(), radius_bound=0.05, max_vertices=cap)
    assert len(err.value.mesh.vertices) <= cap
