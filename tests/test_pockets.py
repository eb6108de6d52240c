"""Pockets that a closed input's topology rules out, dropped from the remesh.

Two unit spheres whose surfaces are 1e-5 apart, given as one closed mesh, meet
where the gap is far thinner than the spacing floor: the relabelled complex
there seals off single Delaunay cells of the gap as tiny closed components.
The input's components are known (two closed, non-self-intersecting spheres),
so output components smaller than the size bound on input components that a
larger output component covers are dropped, and the report says so.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.refine import mesher
from rdmesh.topology.complex import component_topology, is_closed_manifold
from rdmesh.topology.pockets import drop_pockets

RADIUS_BOUND = 0.1


def _two_spheres(gap: float) -> rdmesh.MeshSurface:
    a = trimesh.creation.icosphere(subdivisions=4)
    b = a.copy()
    a.apply_translation([0.0, 0.0, 1.0 + gap / 2])
    b.apply_translation([0.0, 0.0, -1.0 - gap / 2])
    return rdmesh.MeshSurface(trimesh.util.concatenate([a, b]), feature_angle=None)


def _remesh(surface: rdmesh.MeshSurface) -> rdmesh.SurfaceMesh:
    return rdmesh.mesh_surface(
        surface, radius_bound=RADIUS_BOUND, distance_bound=RADIUS_BOUND / 10, seed=0
    )


@pytest.fixture(scope="module")
def touching():
    return _two_spheres(1e-5)


@pytest.fixture(scope="module")
def pruned(touching):
    return _remesh(touching)


@pytest.fixture(scope="module")
def unpruned(touching):
    patch = pytest.MonkeyPatch()
    patch.setattr(mesher, "_pockets", lambda m, faces: None)
    try:
        return _remesh(touching)
    finally:
        patch.undo()


def _parts(mesh: rdmesh.SurfaceMesh) -> list[trimesh.Trimesh]:
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    return sorted(tm.split(only_watertight=False), key=lambda p: len(p.faces))


def test_without_dropping_the_gap_holds_tiny_components(unpruned):
    parts = _parts(unpruned)
    assert len(parts) > 2
    small = parts[:-2]
    assert all(np.ptp(p.vertices, axis=0).max() < RADIUS_BOUND for p in small)
    assert unpruned.report["pockets"] is None


def test_dropped_pockets_are_reported_and_the_rest_is_kept(pruned, unpruned):
    rep = pruned.report["pockets"]
    assert rep is not None and rep["dropped"] >= 1 and rep["ruled_out"] is True
    assert rep["largest"] < RADIUS_BOUND
    assert "output components smaller than the size bound" in pruned.report["statement"]
    assert not pruned.report["tbp_holds"]
    # Exactly the small components are gone; every large one is kept.
    before, after = _parts(unpruned), _parts(pruned)
    assert len(before) - len(after) == rep["dropped"]
    assert sum(len(p.faces) for p in before) - len(pruned.faces) == rep["faces"]
    big = [len(p.faces) for p in before if np.ptp(p.vertices, axis=0).max() >= RADIUS_BOUND]
    assert sorted(big) == sorted(len(p.faces) for p in after)
    assert pruned.report["components"] == len(after)


def test_pruned_mesh_is_closed_without_unused_vertices(pruned):
    assert is_closed_manifold(pruned.faces, len(pruned.vertices))
    assert pruned.report["closed_manifold"]
    assert len(np.unique(pruned.faces)) == len(pruned.vertices)
    chi, _ = component_topology(pruned.faces, len(pruned.vertices))
    assert chi == pruned.report["euler"]


def test_pockets_of_a_self_intersecting_input_are_dropped_below_the_bound(monkeypatch):
    """Two spheres overlapping by 1e-5: the input intersects itself, so its
    topology is unknown; the union's tiny pockets are still dropped (below
    the size bound), and the report says the topology did not rule them out."""
    overlapping = _two_spheres(-1e-5)
    assert not overlapping.topology_known and len(overlapping.self_intersections)
    mesh = _remesh(overlapping)
    rep = mesh.report["pockets"]
    assert rep is not None and rep["dropped"] >= 1 and rep["ruled_out"] is False
    assert mesh.report["components"] == 1 and mesh.report["euler"] == [2]
    assert "winding number" in mesh.report["statement"]
    monkeypatch.setattr(mesher, "_pockets", lambda m, faces: None)
    assert _remesh(overlapping).report["components"] > 1


def test_separated_input_keeps_both_components():
    mesh = _remesh(_two_spheres(0.05))
    assert mesh.report["pockets"] is None
    assert mesh.report["components"] == 2
    assert mesh.report["euler"] == [2, 2]


def test_input_components_and_known_topology(touching):
    assert touching.topology_known
    top = touching.input_components(np.array([[0.0, 0.0, 2.0], [0.0, 0.0, -2.0]]))
    assert top[0] != top[1]
    open_half = trimesh.creation.icosphere(subdivisions=3)
    keep = open_half.triangles_center[:, 2] > -0.5
    cut = (open_half.vertices, open_half.faces[keep])
    assert not rdmesh.MeshSurface(cut, feature_angle=None, holes="fill").topology_known
    # Its hole kept, it is capped while meshing: closed, so its topology is known.
    assert rdmesh.MeshSurface(cut, feature_angle=None).topology_known


# drop_pockets alone, on hand-made faces: an icosphere and a small tetrahedron.


def _sphere_and_tet(offset: float, scale: float):
    s = trimesh.creation.icosphere(subdivisions=2)
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float) * scale
    tet += [0.0, 0.0, offset]
    verts = np.concatenate([s.vertices, tet])
    n = len(s.vertices)
    tfaces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + n
    return verts, np.concatenate([s.faces, tfaces]), len(s.faces)


def _bound(value: float):
    return lambda p: np.full(len(p), value)


def test_drop_pockets_drops_a_small_component_on_a_covered_input():
    v, f, n_sphere = _sphere_and_tet(1.0, 0.01)
    p = drop_pockets(v, f, lambda q: np.zeros(len(q), np.int64), _bound(0.1))
    assert p is not None
    assert p.keep[:n_sphere].all() and not p.keep[n_sphere:].any()
    assert p.faces == 4 and len(p.centres) == 1
    assert p.sizes[0] == pytest.approx(0.01)


def test_drop_pockets_keeps_components_at_or_above_the_bound():
    v, f, _ = _sphere_and_tet(1.0, 0.01)
    assert drop_pockets(v, f, lambda q: np.zeros(len(q), np.int64), _bound(0.01)) is None


def test_drop_pockets_keeps_the_only_component_of_an_input():
    v, f, _ = _sphere_and_tet(3.0, 0.01)

    # The tetrahedron lies on an input component of its own.
    def label(q):
        return (q[:, 2] > 2.0).astype(np.int64)

    assert drop_pockets(v, f, label, _bound(0.1)) is None


def test_drop_pockets_keeps_the_component_with_most_faces_even_when_small():
    v, f, n_sphere = _sphere_and_tet(1.0, 0.01)
    # Both components are below the bound: the one with the most faces stays.
    p = drop_pockets(v, f, lambda q: np.zeros(len(q), np.int64), _bound(100.0))
    assert p is not None
    assert p.keep[:n_sphere].all() and not p.keep[n_sphere:].any()


def test_drop_pockets_single_component_is_none():
    s = trimesh.creation.icosphere(subdivisions=1)
    zero = np.zeros(len(s.vertices), np.int64)
    assert drop_pockets(s.vertices, s.faces, lambda q: zero[: len(q)], _bound(9.0)) is None


def test_drop_pockets_does_not_query_the_input_without_a_small_component():
    v, f, _ = _sphere_and_tet(1.0, 0.01)

    def never(q):
        raise AssertionError("the input was queried")

    assert drop_pockets(v, f, never, _bound(0.001)) is None


@settings(max_examples=40, deadline=None)
@given(
    sizes=st.lists(st.floats(0.001, 2.0), min_size=1, max_size=6),
    labels=st.lists(st.integers(0, 2), min_size=7, max_size=7),
    bound=st.floats(0.01, 3.0),
)
def test_drop_pockets_properties(sizes, labels, bound):
    """A sphere and tetrahedra of random sizes on random input components:
    what is dropped is below the bound and not the largest on any input
    component, and every input component keeps an output component."""
    s = trimesh.creation.icosphere(subdivisions=1)
    verts, faces = [s.vertices], [s.faces]
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    for i, size in enumerate(sizes):
        faces.append(np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + sum(map(len, verts)))
        verts.append(tet * size + [5.0 * (i + 1), 0.0, 0.0])
    v, f = np.concatenate(verts), np.concatenate(faces)
    comp_of_vertex = np.concatenate([np.full(len(x), i) for i, x in enumerate(verts)])
    lab_of = np.asarray(labels)

    def input_components(q):
        # Component i lies at x in [5 i - 1, 5 i + 2]: its input component by place.
        return lab_of[np.rint(q[:, 0] / 5.0).astype(np.int64)]

    p = drop_pockets(v, f, input_components, _bound(bound))
    face_comp = comp_of_vertex[f[:, 0]]
    n_faces = np.bincount(face_comp)
    extent = np.array([np.ptp(x, axis=0).max() for x in verts])
    dropped = set() if p is None else set(np.unique(face_comp[~p.keep]).tolist())
    for c in dropped:
        assert extent[c] < bound
        lab = labels[c]
        rivals = [d for d in range(len(verts)) if labels[d] == lab]
        best = max(rivals, key=lambda d: (n_faces[d], -d))
        assert best != c
    for lab in set(labels[: len(verts)]):
        assert any(labels[d] == lab and d not in dropped for d in range(len(verts)))
    if p is not None:
        assert p.faces == int((~p.keep).sum()) and len(p.centres) == len(dropped)


# -- specks next to unresolved points (any input) ----------------------------------


def _sphere_and_tetrahedron(offset):
    a = trimesh.creation.icosphere(subdivisions=2)
    tet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]) * 0.01 + offset
    v = np.concatenate([a.vertices, tet])
    tf = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]) + len(a.vertices)
    f = np.concatenate([a.faces, tf])
    return v, f


def _size(p):  # specks are below a tenth of it
    return np.full(len(p), 0.2)


@pytest.mark.parametrize("away, dropped", [(0.005, True), (0.05, False)])
def test_a_speck_is_dropped_only_next_to_unresolved_points(away, dropped):
    from rdmesh.topology.pockets import drop_specks

    v, f = _sphere_and_tetrahedron([1.5, 0.0, 0.0])
    unresolved = np.array([[1.5 + away, 0.005, 0.005], [0.0, 0.0, 1.0]])
    p = drop_specks(v, f, unresolved, _size)
    if not dropped:
        assert p is None
        return
    assert p.specks and not p.ruled_out and p.faces == 4
    assert np.array_equal(np.flatnonzero(~p.keep), np.arange(len(f) - 4, len(f)))
    assert np.allclose(p.centres, [[1.5025, 0.0025, 0.0025]])


def test_no_speck_without_unresolved_points_or_above_the_size_bound():
    from rdmesh.topology.pockets import drop_specks

    v, f = _sphere_and_tetrahedron([1.5, 0.0, 0.0])
    near = np.array([[1.505, 0.005, 0.005]])
    assert drop_specks(v, f, np.zeros((0, 3)), _size) is None
    assert drop_specks(v, f, near, lambda p: np.full(len(p), 0.1)) is None
    # The largest component is never a speck, however small and close.
    assert drop_specks(v[-4:], f[-4:] - (len(v) - 4), near, _size) is None


def test_specks_are_dropped_from_functions_but_never_from_volumes():
    """The same tiny component next to refused points: a speck of a function's
    gap, but a volume's interpolant has real components that small."""
    from types import SimpleNamespace

    from rdmesh.refine.criteria import FacetCriteria

    v, f = _sphere_and_tetrahedron([1.5, 0.0, 0.0])
    near = [np.array([[1.505, 0.005, 0.005]])]
    criteria = FacetCriteria(radius_bound=0.2)
    fn = rdmesh.surfaces.sphere()
    vol = rdmesh.VolumeSurface(np.ones((4, 4, 4)) * np.arange(4), isovalue=1.5)
    for surface, dropped in ((fn, True), (vol, False)):
        m = SimpleNamespace(
            clipped=False, surface=surface, criteria=criteria, vertices=v, unresolved=near
        )
        p = mesher._pockets(m, f)
        assert (p is not None and p.specks and p.faces == 4) if dropped else p is None
