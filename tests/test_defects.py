"""The complex's defects kept across rounds (topology/defects.py)."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import rdmesh.refine.phases as phases
import rdmesh.topology.defects as defects
import volumes
from rdmesh._errors import InternalCheckError
from rdmesh.topology.complex import complex_status, is_closed_manifold, largest_per_group


@pytest.fixture
def instances(monkeypatch):
    made = []
    init = defects.ComplexDefects.__init__

    def record(self, *args, **kwargs):
        init(self, *args, **kwargs)
        made.append(self)

    monkeypatch.setattr(defects.ComplexDefects, "__init__", record)
    return made


def _mesh_lens():
    s = rdmesh.VolumeSurface(volumes.kinked_lens(), isovalue=0.0, interpolation="linear")
    return rdmesh.mesh_surface(s, radius_bound=1.0)


def test_local_recount_matches_a_full_count_on_a_real_run(instances):
    """Under RDMESH_CHECK (set by conftest) every local update is compared
    with a count over every facet and raises on a difference."""
    m = _mesh_lens()
    assert m.report["closed_manifold"] and len(m.unresolved) == 0
    d = instances[-1]
    assert d.check and d.local_counts > 0 and d.full_counts > 0
    # The final tables describe the final complex: clean.
    assert len(d.edges.ids) == 0 and len(d.vertices.ids) == 0


def test_a_wrong_local_recount_is_caught(instances, monkeypatch):
    """Dropping the recounted rows makes the local tables wrong; the check
    must notice."""
    monkeypatch.setattr(defects, "_merged", lambda kept, new: kept)
    # Stages asked one after the other, as before they were joined: the lens
    # then has local recounts with failing edges to lose.
    monkeypatch.setattr(phases, "JOIN_BELOW", 0)
    with pytest.raises(InternalCheckError, match="counted around the touched samples"):
        _mesh_lens()


def test_a_run_ends_on_a_count_of_every_facet(instances, monkeypatch):
    """Without the check, a local count that finds nothing is not confirmed
    each round, but the run ends only after a count of every facet."""
    monkeypatch.setenv("RDMESH_CHECK", "0")
    m = _mesh_lens()
    d = instances[-1]
    assert not d.check and d.local_counts > 0
    assert d.confirmed
    assert m.report["closed_manifold"] and len(d.edges.ids) == len(d.vertices.ids) == 0


def test_defects_that_local_counts_miss_are_refined_before_the_run_ends(
    instances, monkeypatch, caplog
):
    """Local recounts that lose their rows make the run end on a complex they
    call clean; the final count of every facet finds the defects, and the run
    goes on to refine them."""
    monkeypatch.setenv("RDMESH_CHECK", "0")
    monkeypatch.setattr(defects, "_merged", lambda kept, new: kept)
    monkeypatch.setattr(phases, "JOIN_BELOW", 0)
    with caplog.at_level("WARNING", logger="rdmesh"):
        m = _mesh_lens()
    assert any("local counts missed" in r.getMessage() for r in caplog.records)
    assert instances[-1].confirmed
    assert m.report["closed_manifold"] and is_closed_manifold(m.faces, len(m.vertices))


def test_tables_list_each_failing_edge_and_vertex_with_its_largest_facet():
    """Two fans meeting at vertex 0 (a bowtie), plus a fin on edge (1, 2)."""
    tri = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 1], [0, 4, 5], [0, 5, 6], [0, 6, 4],
                    [1, 2, 7]])  # fmt: skip
    n = 8
    rng = np.random.default_rng(0)
    centres = rng.normal(size=(len(tri), 3))
    radii = np.array([1.0, 2.0, 3.0, 4.0, 0.5, 0.5, 5.0])
    edges, vertices = defects._tables(tri, centres, radii, n, None)
    st = complex_status(tri, n)
    bad = st.edge_count != 2
    assert len(edges.ids) == bad.sum()
    rows = zip(edges.ids, edges.count, edges.facet, edges.radius, strict=True)
    for ends, count, facet, r in rows:
        inside = [k for k, t in enumerate(tri) if set(ends) <= set(t)]
        assert count == len(inside)
        k = max(inside, key=lambda k: radii[k])
        assert r == radii[k] and list(facet) == sorted(tri[k])
    # Vertex 0 has two fans; its largest facet is (0, 4, 5).
    assert vertices.ids[:, 0].tolist() == [0] and vertices.count.tolist() == [2]
    assert vertices.facet.tolist() == [[0, 4, 5]] and vertices.radius[0] == 4.0
    # With ``near``, only rows touching a near vertex are listed.
    near = np.zeros(n, bool)
    near[7] = True
    e_near, v_near = defects._tables(tri, centres, radii, n, near)
    assert all(7 in ends for ends in e_near.ids) and len(v_near.ids) == 0
    assert len(e_near.ids) == 2  # (1, 7) and (2, 7), each in one facet


def test_largest_facet_ties_do_not_depend_on_facet_order():
    tri = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4]])
    radii = np.ones(3)
    picks = set()
    for order in ([0, 1, 2], [2, 1, 0], [1, 2, 0]):
        t = tri[order]
        ties = tuple(np.sort(t, axis=1).T)
        pick = largest_per_group(np.zeros(3, np.int64), np.arange(3), radii[order], ties)
        picks.add(tuple(t[pick[0]]))
    assert picks == {(0, 3, 4)}
