"""Issue 30's sweep of odd input: mesh inputs with repeated or turned faces or
flat components, surfaces the seeding grid cannot see, size bounds larger than
the surface."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
from hypothesis import given, settings
from hypothesis import strategies as st
from meshcheck import closed_manifold_problems, euler_per_component
from rdmesh.surfaces._mesh_input import is_closed_oriented
from rdmesh.surfaces._mesh_repair import coherently_oriented, without_duplicates


def icosphere(sub: int = 2, centre=(0.0, 0.0, 0.0), radius: float = 1.0):
    m = trimesh.creation.icosphere(sub, radius=radius)
    return np.asarray(m.vertices) + np.asarray(centre, float), np.asarray(m.faces, np.int64)


def moebius(n: int = 24):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    v = np.array(
        [[(1 + s * np.cos(a / 2)) * np.cos(a), (1 + s * np.cos(a / 2)) * np.sin(a),
          s * np.sin(a / 2)] for a in t for s in (-0.3, 0.3)]
    )  # fmt: skip
    f = []
    for i in range(n):
        j = (i + 1) % n
        a0, a1 = 2 * i, 2 * i + 1
        b0, b1 = (2 * j, 2 * j + 1) if j else (1, 0)  # the half twist
        f += [[a0, b0, a1], [a1, b0, b1]]
    return v, np.array(f, np.int64)


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 319), max_size=150, unique=True))
def test_turned_faces_are_turned_back(flipped):
    _, f = icosphere(2)  # 320 faces
    g = f.copy()
    g[flipped] = g[flipped][:, ::-1]
    out = coherently_oriented(g)
    assert is_closed_oriented(out)
    # Fewer than half turned: the original orientation wins everywhere.
    assert np.array_equal(out, f)


def test_a_moebius_strip_is_left_as_it_is():
    _, f = moebius()
    assert np.array_equal(coherently_oriented(f), f)
    # ... and stays refused: it has no inside.
    with pytest.raises(rdmesh.MeshInputError, match="too open"):
        rdmesh.MeshSurface(moebius())


def test_repeated_faces_keep_one_copy_and_opposite_pairs_cancel():
    _, f = icosphere(1)
    same = np.r_[f, f[:5]]
    assert np.array_equal(without_duplicates(same), f)
    # A face listed once each way is gone; listed twice one way and once the
    # other, one copy of the majority stays.
    both = np.r_[f, f[:3, ::-1]]
    assert np.array_equal(without_duplicates(both), f[3:])
    three = np.r_[f, f[:1], f[:1, [1, 0, 2]]]
    kept = without_duplicates(three)
    assert len(kept) == len(f) and np.array_equal(kept, f)


def test_a_mesh_with_repeated_and_turned_faces_remeshes_as_the_clean_one():
    v, f = icosphere(2)
    g = np.r_[f, f[:7]]
    g[10:20] = g[10:20, ::-1]
    clean = rdmesh.MeshSurface((v, f))
    messy = rdmesh.MeshSurface((v, g))
    assert messy.sign_method == clean.sign_method
    assert np.array_equal(messy.faces, clean.faces)
    m = rdmesh.mesh_surface(messy, radius_bound=0.2, distance_bound=0.02)
    assert closed_manifold_problems(m.faces, len(m.vertices)) == []
    assert euler_per_component(m.faces, len(m.vertices)) == [2]


def test_sheets_listed_both_ways_and_flat_solids_are_refused():
    sheet = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0.0]])
    faces = np.array([[0, 1, 2], [1, 3, 2], [0, 2, 1], [1, 2, 3]])
    with pytest.raises(rdmesh.MeshInputError, match="cancel"):
        rdmesh.MeshSurface((sheet, faces))
    v, f = icosphere(2)
    big, small = icosphere(2, centre=(3, 0, 0), radius=0.5)
    pancake = (np.r_[v, big * [1, 1, 1e-9]], np.r_[f, small + len(v)])
    with pytest.raises(rdmesh.MeshInputError, match="component 1 .* almost no volume"):
        rdmesh.MeshSurface(pancake)


def test_complex_vertices_are_refused():
    v, f = icosphere(1)
    with pytest.raises(rdmesh.MeshInputError, match="real numbers"):
        rdmesh.MeshSurface((v.astype(complex), f))


def test_components_the_grid_misses_are_meshed_from_the_mesh():
    # Two unit spheres 1e4 apart: the 64^3 grid's spacing is about 190.
    v, f = icosphere(2)
    far = (np.r_[v, v + [1e4, 0, 0]], np.r_[f, f + len(v)])
    s = rdmesh.MeshSurface(far)
    m = rdmesh.mesh_surface(s, radius_bound=0.3, distance_bound=0.03)
    assert closed_manifold_problems(m.faces, len(m.vertices)) == []
    assert euler_per_component(m.faces, len(m.vertices)) == [2, 2]
    near = m.vertices[:, 0] < 5e3
    assert np.allclose(m.vertices[near].mean(0), 0, atol=0.1)
    assert np.allclose(m.vertices[~near].mean(0), [1e4, 0, 0], atol=0.1)


@pytest.mark.parametrize("certify", [None, True])
def test_an_expression_smaller_than_the_grid_is_found(certify):
    # Radius 0.002 in a bounding sphere of radius 1: far below the grid's spacing.
    s = rdmesh.ImplicitSurface.from_expression(
        "(x-0.3)**2 + (y-0.2)**2 + z**2 - 0.002**2", ((0, 0, 0), 1.0)
    )
    m = rdmesh.mesh_surface(s, radius_bound=0.0007, certify=certify)
    assert euler_per_component(m.faces, len(m.vertices)) == [2]
    r = np.linalg.norm(m.vertices - [0.3, 0.2, 0], axis=1)
    assert np.allclose(r, 0.002, rtol=1e-6)
    if certify:
        assert m.report["certified"]


def test_an_empty_expression_is_still_refused():
    s = rdmesh.ImplicitSurface.from_expression("x**2 + y**2 + z**2 + 1", ((0, 0, 0), 1.0))
    with pytest.raises(rdmesh.EmptySurfaceError):
        rdmesh.mesh_surface(s, radius_bound=0.1)


@pytest.mark.parametrize("bound", [3.0, 1e9])
def test_a_size_bound_larger_than_the_surface_still_gives_a_closed_mesh(bound):
    # The grid's seeds used to be thinned to one point: no tetrahedron, no facet.
    s = rdmesh.ImplicitSurface.from_expression("x*x + y*y + z*z - 1", ((0, 0, 0), 2.0))
    m = rdmesh.mesh_surface(s, radius_bound=bound)
    assert m.complete
    assert closed_manifold_problems(m.faces, len(m.vertices)) == []
    assert euler_per_component(m.faces, len(m.vertices)) == [2]


def test_a_volume_thinner_than_the_seeding_grid_is_found():
    # A 5-voxel box in a volume 1000 times longer than wide: the grid's
    # spacing is about 40 times the box's width.
    a = np.zeros((12, 12, 12))
    a[3:8, 3:8, 3:8] = 1.0
    s = rdmesh.VolumeSurface(a, isovalue=0.5, spacing=(1, 1, 1000))
    m = rdmesh.mesh_surface(s, radius_bound=s.radius / 8)
    assert m.complete
    assert closed_manifold_problems(m.faces, len(m.vertices)) == []
    assert euler_per_component(m.faces, len(m.vertices)) == [2]
    assert np.abs(s(m.vertices)).max() < 1e-6


def test_f_cannot_change_the_points_it_is_given():
    def f(p):
        p[:, 0] = 0.0  # would move rdmesh's own samples
        return np.linalg.norm(p, axis=1) - 0.5

    s = rdmesh.ImplicitSurface(f, ((0, 0, 0), 1.0))
    with pytest.raises(rdmesh.OracleError, match="read-only"):
        rdmesh.mesh_surface(s, radius_bound=0.1)


def test_complex_values_of_f_are_refused():
    s = rdmesh.ImplicitSurface(
        lambda p: (np.linalg.norm(p, axis=1) - 0.5).astype(complex), ((0, 0, 0), 1.0)
    )
    with pytest.raises(rdmesh.OracleError, match="complex"):
        rdmesh.mesh_surface(s, radius_bound=0.1)


def test_a_run_stops_with_its_mesh_before_memory_runs_out(monkeypatch):
    import rdmesh.refine.memory as memory

    monkeypatch.setattr(memory, "available_bytes", lambda: 3 * 2**20)
    s = rdmesh.surfaces.get("torus")
    with pytest.raises(rdmesh.BudgetExceeded, match="memory: a round of") as info:
        rdmesh.mesh_surface(s, radius_bound=s.radius / 80)
    m = info.value.mesh
    assert info.value.reason.startswith("memory:")
    assert not m.complete and len(m.vertices) > 0
    # Enough memory: the same run ends, with more vertices.
    monkeypatch.setattr(memory, "available_bytes", lambda: 2**40)
    whole = rdmesh.mesh_surface(s, radius_bound=s.radius / 80)
    assert whole.complete and len(whole.vertices) > len(m.vertices)


def test_the_memory_available_is_read_on_linux():
    import sys

    from rdmesh.refine.memory import available_bytes

    room = available_bytes()
    if sys.platform.startswith("linux"):
        assert room is not None and room > 0


def test_a_block_too_small_says_how_large_it_must_be():
    from rdmesh.blocks.volume_blocks import MIN_BLOCK

    a = np.zeros((40, 40, 40))
    a[5:30, 5:30, 5:30] = 1.0
    with pytest.raises(ValueError, match=f"block must be an integer of at least {MIN_BLOCK}"):
        rdmesh.mesh_volume_blocks(a, block=1, isovalue=0.5)
