"""A closed input's topology kept where it has parts thinner than the radius
bound (issue 30): the output is checked against the input's components and
Euler characteristics, the input is checked against the output at the radius
bound when no distance bound is given, and a run that loses the topology at a
thin part is made again with the bound lowered there."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import rdmesh.api
import trimesh
from rdmesh.refine import methods
from rdmesh.surfaces._mesh_thin import thin_parts
from rdmesh.surfaces._mesh_topology import component_euler, topology_against_input

RADIUS = 0.1


def dumbbell(rod: float, n_theta: int = 48, n_x: int = 400) -> tuple[np.ndarray, np.ndarray]:
    """Two balls of radius 0.45 at x = -0.6 and 0.6 joined by a rod of radius
    ``rod``: a closed surface of revolution about the x axis (genus 0)."""
    x = np.linspace(-1.05, 1.05, n_x)[1:-1]
    rho = np.maximum(np.sqrt(np.clip(0.45**2 - (np.abs(x) - 0.6) ** 2, 0.0, None)), rod)
    t = np.linspace(0, 2 * np.pi, n_theta, endpoint=False)
    cos, sin = np.outer(rho, np.cos(t)).ravel(), np.outer(rho, np.sin(t)).ravel()
    ring = np.stack([np.repeat(x, n_theta), cos, sin], axis=1)
    v = np.concatenate([ring, [[-1.05, 0.0, 0.0], [1.05, 0.0, 0.0]]])
    j = np.arange(n_theta)
    a = (np.arange(len(x) - 1)[:, None] * n_theta + j).ravel()
    b = (np.arange(len(x) - 1)[:, None] * n_theta + (j + 1) % n_theta).ravel()
    side = np.concatenate([np.c_[a, b, b + n_theta], np.c_[a, b + n_theta, a + n_theta]])
    last = (len(x) - 1) * n_theta
    cap0 = np.c_[np.full(n_theta, len(v) - 2), (j + 1) % n_theta, j]
    cap1 = np.c_[np.full(n_theta, len(v) - 1), last + j, last + (j + 1) % n_theta]
    return v, np.concatenate([side, cap0, cap1])


def test_the_dumbbell_is_a_closed_genus_0_input():
    mesh = trimesh.Trimesh(*dumbbell(0.015), process=False)
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.euler_number == 2


def test_euler_characteristic_of_each_component():
    sphere = trimesh.creation.icosphere(subdivisions=1)
    torus = trimesh.creation.torus(1.0, 0.3)
    both = trimesh.util.concatenate([sphere, torus])
    from rdmesh._mesh_components import labelled_components

    count, label, _ = labelled_components(np.asarray(both.faces, np.int64), len(both.vertices))
    chi = component_euler(both.faces, label, count, len(both.vertices))
    assert sorted(chi.tolist()) == [0, 2]


def test_an_output_without_the_inputs_topology_is_found():
    """The input sphere itself has its topology; with a face cut out (a disk
    removed: Euler 1) or split in two pieces it has not."""
    ico = trimesh.creation.icosphere(subdivisions=2)
    surface = rdmesh.MeshSurface(ico, feature_angle=None)
    v, f = surface.vertices, surface.faces
    same = topology_against_input(surface, v, f)
    assert same["kept"] and same["oriented"]
    assert not topology_against_input(surface, v, np.r_[f[:1, ::-1], f[1:]])["oriented"]
    holed = topology_against_input(surface, v, f[1:])
    assert not holed["kept"] and holed["output"]["euler"] == [1]
    assert "does not have the input's topology" in holed["statement"]
    far = f[(v[f].mean(axis=1)[:, 2] > 0.2) | (v[f].mean(axis=1)[:, 2] < -0.2)]
    split = topology_against_input(surface, v, far)
    assert not split["kept"] and split["output"]["components"] == 2


def test_a_self_intersecting_input_has_no_known_topology_to_check():
    a = trimesh.creation.icosphere(subdivisions=2)
    b = a.copy()
    b.apply_translation([1.0, 0, 0])
    both = trimesh.util.concatenate([a, b])
    surface = rdmesh.MeshSurface((both.vertices, both.faces), feature_angle=None)
    assert topology_against_input(surface, surface.vertices, surface.faces) is None


def test_thin_parts_are_found_on_the_rod_only():
    surface = rdmesh.MeshSurface(dumbbell(0.015))
    thin = thin_parts(surface, RADIUS, RADIUS / 32)
    assert thin is not None
    # Rod, and the balls' rims where they meet it (within a bound of x = 0).
    assert np.abs(thin.points[:, 0]).max() < 0.15 + RADIUS
    assert np.all(thin.sizes < RADIUS / 2)
    centres = np.array([[0.0, 0.0, 0.0], [-0.6, 0.0, 0.45], [0.6, 0.45, 0.0]])
    size = thin.sizing(centres)
    assert size[0] < RADIUS / 2 and np.all(size[1:] == RADIUS)
    assert thin_parts(rdmesh.MeshSurface(trimesh.creation.icosphere(3)), 0.2, 0.01) is None


def test_a_thin_rod_is_kept_by_meshing_again_with_the_bound_lowered():
    surface = rdmesh.MeshSurface(dumbbell(0.015))
    mesh = rdmesh.mesh_surface(surface, radius_bound=RADIUS)
    assert mesh.complete and mesh.is_closed_manifold()
    assert mesh.report["components"] == 1 and mesh.report["euler"] == [2]
    assert mesh.report["input"]["topology"]["kept"]
    thin = mesh.report["thin_parts"]
    assert thin["probes"] > 0 and thin["least_bound"] < RADIUS / 2
    assert "radius bound was lowered" in mesh.report["statement"]
    assert "input's topology (1 component, Euler 2): kept; radius bound lowered" in mesh.summary()
    # The rod is in the mesh: vertices all along it, on its surface.
    on_rod = mesh.vertices[np.abs(mesh.vertices[:, 0]) < 0.1]
    assert len(on_rod) and np.allclose(np.linalg.norm(on_rod[:, 1:], axis=1), 0.015, atol=2e-3)
    assert np.ptp(on_rod[:, 0]) > 0.18


def test_without_the_second_run_the_lost_topology_is_reported(monkeypatch):
    monkeypatch.setattr(rdmesh.api, "_thin_parts_kept", lambda mesher, mesh: mesh)
    mesh = rdmesh.mesh_surface(rdmesh.MeshSurface(dumbbell(0.015)), radius_bound=RADIUS)
    topo = mesh.report["input"]["topology"]
    assert not topo["kept"] and topo["input"] == {"components": 1, "euler": [2]}
    assert not mesh.complete
    assert "does not have the input's topology" in mesh.stats["stop_reason"]
    assert "thin_parts" not in mesh.report
    assert "input's topology (1 component, Euler 2): NOT kept" in mesh.summary()


def rod_and_leg(rod: float = 0.03, n: int = 160) -> tuple[np.ndarray, np.ndarray]:
    """Marching cubes of two balls joined by a rod, with a leg and a foot on
    one (rods of radius ``rod``): a closed genus-0 input whose grid seeds (at
    ``n = 160``) miss the rod."""
    from skimage import measure

    x = np.linspace(-1.3, 1.3, n)
    X, Y, Z = np.meshgrid(x, x, x, indexing="ij")
    f = np.minimum.reduce([
        np.sqrt((X + 0.6) ** 2 + Y**2 + Z**2) - 0.45,
        np.sqrt((X - 0.6) ** 2 + Y**2 + Z**2) - 0.45,
        np.maximum(np.sqrt(Y**2 + Z**2) - rod, np.abs(X) - 0.7),
        np.maximum(np.sqrt((X + 0.6) ** 2 + Y**2) - rod, np.abs(Z + 0.8) - 0.4),
        np.sqrt((X + 0.6) ** 2 + Y**2 + (Z + 1.15) ** 2) - 0.1,
    ])  # fmt: skip
    v, faces, _, _ = measure.marching_cubes(f, 0.0, spacing=(x[1] - x[0],) * 3)
    return v - 1.3, faces


def test_without_a_distance_bound_the_input_is_checked_at_the_radius_bound(monkeypatch):
    """No sample lands on the rod at the bound; the check at the bound puts
    some there, and the rod is in the mesh."""
    monkeypatch.setattr(rdmesh.api, "_thin_parts_kept", lambda mesher, mesh: mesh)
    surface = rdmesh.MeshSurface(rod_and_leg())
    r = surface.radius / 20
    mesh = rdmesh.mesh_surface(surface, radius_bound=r)
    check = mesh.stats["distance_check"]
    assert check["bound"] == pytest.approx(methods.COVERAGE * r) and check["proposed"] > 0
    assert mesh.report["components"] == 1 and mesh.complete
    assert mesh.report["input"]["topology"]["kept"]
    monkeypatch.setattr(methods, "COVERAGE", 1e6)  # never beyond: nothing proposed
    unchecked = rdmesh.mesh_surface(surface, radius_bound=r)
    assert unchecked.report["components"] == 2 and not unchecked.complete
    assert not unchecked.report["input"]["topology"]["kept"]
