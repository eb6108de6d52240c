"""rdmesh.SurfaceMesh on hand-built meshes, and the test suite's own checkers.

The checkers in meshcheck.py must be able to fail: each broken mesh below is
rejected by both them and the library's report.
"""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from meshcheck import closed_manifold_problems, euler_per_component
from rdmesh import SurfaceMesh

TET_V = np.array([[0.0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]])
TET_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])  # outward


def _mesh(v, f):
    v = np.asarray(v, float)
    f = np.asarray(f, np.int64)
    centres = v[f].mean(axis=1)  # any points will do for the combinatorics
    return SurfaceMesh(vertices=v, faces=f, facet_centres=centres)


def _torus_grid(n=6, m=5):
    """A triangulated n x m torus (Euler characteristic 0)."""
    u, v = np.meshgrid(np.arange(n) * 2 * np.pi / n, np.arange(m) * 2 * np.pi / m, indexing="ij")
    pts = np.stack([(2 + np.cos(v)) * np.cos(u), (2 + np.cos(v)) * np.sin(u), np.sin(v)], -1)
    idx = np.arange(n * m).reshape(n, m)
    faces = []
    for i in range(n):
        for j in range(m):
            a, b = idx[i, j], idx[(i + 1) % n, j]
            c, d = idx[(i + 1) % n, (j + 1) % m], idx[i, (j + 1) % m]
            faces += [[a, b, c], [a, c, d]]
    return pts.reshape(-1, 3), np.array(faces)


def test_tetrahedron():
    m = _mesh(TET_V, TET_F)
    assert closed_manifold_problems(m.faces, 4) == []
    assert m.is_closed_manifold()
    topo = m.topology()
    assert topo["components"] == 1 and topo["euler"] == [2] and topo["genus"] == [0]
    assert m.to_trimesh().volume == pytest.approx(1 / 6)
    assert m.min_angle == pytest.approx(45.0)
    assert np.allclose(np.sort(m.angles), [45, 45, 45, 60])


def test_torus_grid_and_two_components():
    v, f = _torus_grid()
    m = _mesh(v, f)
    assert closed_manifold_problems(f, len(v)) == []
    assert m.is_closed_manifold()
    assert m.topology()["euler"] == [0] and m.topology()["genus"] == [1]
    # Add a disjoint tetrahedron: two components.
    v2 = np.concatenate([v, TET_V + 10])
    f2 = np.concatenate([f, TET_F + len(v)])
    m2 = _mesh(v2, f2)
    assert m2.is_closed_manifold()
    assert m2.topology()["components"] == 2
    assert sorted(m2.topology()["euler"]) == [0, 2]
    assert euler_per_component(f2, len(v2)) == [2, 0]


def test_open_mesh_is_rejected():
    m = _mesh(TET_V, TET_F[:3])
    assert not m.is_closed_manifold()
    assert any("not in exactly 2 faces" in p for p in closed_manifold_problems(m.faces, 4))
    assert not m.to_trimesh().is_watertight


def test_bowtie_vertex_is_rejected():
    """Two tetrahedra sharing one vertex: every edge has two faces, but the
    shared vertex's link is two cycles."""
    v = np.concatenate([TET_V, TET_V[1:] * -1.0])
    other = TET_F.copy()
    other[other > 0] += 3
    f = np.concatenate([TET_F, other[:, ::-1]])
    problems = closed_manifold_problems(f, len(v))
    assert problems == ["1 vertices whose link is not one cycle"]
    m = _mesh(v, f)
    assert not m.is_closed_manifold()
    assert not m.topology()["closed_manifold"]


def test_singular_edge_and_bad_winding_are_rejected():
    # A third face on an edge of the tetrahedron.
    v = np.concatenate([TET_V, [[1.0, 1.0, -1.0]]])
    f = np.concatenate([TET_F, [[0, 1, 4]]])
    assert not _mesh(v, f).is_closed_manifold()
    assert closed_manifold_problems(f, len(v)) != []
    # One face flipped: still watertight, but inconsistently wound.
    f = TET_F.copy()
    f[0] = f[0, ::-1]
    assert any("winding" in p for p in closed_manifold_problems(f, 4))
    assert not trimesh.Trimesh(TET_V, f, process=False).is_winding_consistent


def test_empty_mesh():
    m = SurfaceMesh(np.zeros((0, 3)), np.zeros((0, 3), np.int64), np.zeros((0, 3)))
    assert not m.is_closed_manifold()
    assert m.topology()["components"] == 0
    assert np.isnan(m.min_angle)


def test_ball_radii():
    c = np.array([[0.0, 0.0, 0.0]])
    v = np.array([[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]])
    m = SurfaceMesh(v, np.array([[0, 1, 2]]), c)
    assert m.ball_radii.tolist() == [1.0]


@pytest.mark.parametrize("ext", ["ply", "obj", "stl", "off"])
def test_save_round_trip(tmp_path, sphere_case, ext):
    m = sphere_case.mesh
    path = tmp_path / f"mesh.{ext}"
    m.save(path)
    back = trimesh.load(path, force="mesh", process=True)
    assert back.is_watertight
    assert len(back.faces) == len(m.faces)
    assert back.area == pytest.approx(m.to_trimesh().area, rel=1e-5)
    assert back.volume == pytest.approx(m.to_trimesh().volume, rel=1e-5)


def test_save_unknown_format(tmp_path, sphere_case):
    with pytest.raises(ValueError, match=r"unknown mesh format 'xyz'"):
        sphere_case.mesh.save(tmp_path / "mesh.xyz")
    assert not (tmp_path / "mesh.xyz").exists()


def test_summary_mentions_size_and_topology(sphere_case):
    m = sphere_case.mesh
    text = m.summary()
    assert f"vertices {len(m.vertices)}, faces {len(m.faces)}" in text
    assert "closed manifold: yes" in text
    assert "INCOMPLETE" not in text


def test_phase_seconds_count_the_core_thread_apart(torus_case):
    phases = torus_case.mesh.stats["phase_seconds"]
    wall = torus_case.mesh.stats["seconds"]
    # The core thread's jobs are timed on their own: they overlap the main
    # thread's phases, so together they are at most the run's wall time, as
    # are the main thread's phases (the loop test's time is inside them).
    core = phases["core_changed_facets"] + phases["core_update_facets"]
    assert phases["core_changed_facets"] > 0 and phases["core_update_facets"] > 0
    assert core <= wall
    main = [v for k, v in phases.items() if not k.startswith("core_") and k != "voronoi_loop"]
    assert sum(main) <= wall + 1e-3
