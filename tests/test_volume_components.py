"""Proven seeds on every component of a volume's isosurface (issue 30).

The reference is the interpolant's own components: marching cubes on a
fine resampling of the interpolant, welded, counted by union-find.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import rdmesh.refine.methods as methods
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh.sampling.volume_components import _roots, volume_components
from rdmesh.surfaces.volume import tensor_spline
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

measure = pytest.importorskip("skimage.measure")

#: One-voxel specks around the ball of :func:`specks_volume`.
SPECKS = [(5, 5, 5), (34, 5, 30), (5, 34, 12), (30, 30, 33), (8, 20, 34)]


def specks_volume(n: int = 40) -> np.ndarray:
    """A binary ball with five one-voxel specks beside it (6 components)."""
    g = np.indices((n, n, n)).transpose(1, 2, 3, 0) - n / 2
    vol = (np.linalg.norm(g - [-4, 0, 0], axis=-1) < 9).astype(float)
    for p in SPECKS:
        vol[p] = 1.0
    return vol


def bubbles_volume(n: int = 32) -> np.ndarray:
    """A binary ball with two one-voxel holes inside (3 surface components)."""
    g = np.indices((n, n, n)).transpose(1, 2, 3, 0) - (n - 1) / 2
    vol = (np.linalg.norm(g, axis=-1) < 11).astype(float)
    vol[16, 16, 16] = 0.0
    vol[12, 14, 15] = 0.0
    return vol


def reference_components(
    volume: np.ndarray, interpolation: str, factor: int = 4, iso: float = 0.5
) -> tuple[int, int]:
    """Components and total Euler characteristic of the interpolant's
    isosurface at ``iso``, closed by the box: marching cubes on the
    interpolant resampled ``factor`` times finer."""
    degree = 3 if interpolation == "cubic" else 1
    if degree == 3:
        from scipy import ndimage

        coef = ndimage.spline_filter(volume, order=3, mode="mirror")
    else:
        coef = volume
    axes = [np.linspace(0, n - 1, factor * (n - 1) + 1) for n in volume.shape]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    vals = tensor_spline(np.ascontiguousarray(coef), pts, degree)[0]
    fine = np.pad(vals.reshape([len(a) for a in axes]), 1, constant_values=volume.min())
    verts, faces, _, _ = measure.marching_cubes(fine, iso)
    _, inverse = np.unique(np.round(verts, 9), axis=0, return_inverse=True)
    f = inverse.reshape(-1)[faces]
    f = f[(f[:, 0] != f[:, 1]) & (f[:, 1] != f[:, 2]) & (f[:, 0] != f[:, 2])]
    n = int(f.max()) + 1
    edges = np.concatenate([f[:, [0, 1]], f[:, [1, 2]]])
    graph = coo_matrix((np.ones(len(edges)), (edges[:, 0], edges[:, 1])), shape=(n, n))
    used = np.unique(f)
    _, comp = connected_components(graph, directed=False)
    undirected = np.unique(np.sort(np.concatenate([edges, f[:, [0, 2]]]), axis=1), axis=0)
    return len(np.unique(comp[used])), len(used) - len(undirected) + len(f)


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_reference_sees_the_specks(interpolation):
    # The specks are components of the interpolant itself, not of the voxels only.
    assert reference_components(specks_volume(), interpolation) == (1 + len(SPECKS), 12)


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
@pytest.mark.parametrize("inside", ["greater", "less"])
def test_every_speck_is_meshed(interpolation, inside):
    vol = specks_volume()
    vol = vol if inside == "greater" else 1.0 - vol
    surface = rdmesh.VolumeSurface(vol, interpolation=interpolation, inside=inside)
    mesh = rdmesh.mesh_surface(surface, radius_bound=1.0)
    rep = mesh.report
    assert rep["seeding"]["level"] == "proven"
    assert rep["components"] == 1 + len(SPECKS)
    assert sorted(rep["euler"]) == [2] * (1 + len(SPECKS))
    assert rep["closed_manifold"] and mesh.complete
    # Every speck has vertices within a voxel of it.
    for p in SPECKS:
        assert np.min(np.linalg.norm(mesh.vertices - np.asarray(p, float), axis=1)) < 1.0


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_one_voxel_cavities_are_meshed(interpolation):
    surface = rdmesh.VolumeSurface(bubbles_volume(), interpolation=interpolation)
    found = volume_components(surface)
    assert found.proven
    mesh = rdmesh.mesh_surface(surface, radius_bound=1.0)
    assert (mesh.report["components"], 6) == reference_components(bubbles_volume(), interpolation)
    assert mesh.report["components"] == 3
    assert sorted(mesh.report["euler"]) == [2, 2, 2]
    assert mesh.report["closed_manifold"]


def test_without_the_search_specks_are_lost(monkeypatch):
    # The same run with the grid scan alone: the test above can fail.
    monkeypatch.setattr(methods, "find_components", lambda *a, **k: None)
    surface = rdmesh.VolumeSurface(specks_volume())
    mesh = rdmesh.mesh_surface(surface, radius_bound=1.0)
    assert mesh.report["components"] < 1 + len(SPECKS)
    assert mesh.report["seeding"]["level"] == "sampled"


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_seeds_lie_on_the_surface(interpolation):
    surface = rdmesh.VolumeSurface(specks_volume(), interpolation=interpolation)
    found = volume_components(surface)
    assert len(found.points) >= 1 + len(SPECKS)
    assert np.max(np.abs(surface.f(found.points))) < 1e-9


def test_a_sample_at_the_isovalue_is_not_proven():
    vol = specks_volume()
    vol[20, 20, 20] = 0.5
    surface = rdmesh.VolumeSurface(vol, interpolation="linear", isovalue=0.5)
    found = volume_components(surface)
    assert not found.proven
    assert "isovalue" in found.basis


def test_clipped_volumes_get_no_search():
    surface = rdmesh.VolumeSurface(specks_volume(), border="clipped")
    from rdmesh.sampling.components import find_components

    assert find_components(surface, np.random.default_rng(0)) is None


@pytest.mark.parametrize("degree", [1, 3])
def test_ray_roots_match_a_scalar_loop(degree):
    rng = np.random.default_rng(3)
    bez = rng.normal(size=(400, degree + 1))
    (piece, t), (bad, _) = _roots(bez)
    assert len(bad) == 0
    binom = [1, 3, 3, 1] if degree == 3 else [1, 1]
    for i, b in enumerate(bez):
        # Power-basis coefficients of the Bernstein polynomial, highest first.
        poly = np.zeros(degree + 1)
        for k in range(degree + 1):
            term = np.polynomial.polynomial.polypow([0, 1], k)
            term = np.polynomial.polynomial.polymul(
                term, np.polynomial.polynomial.polypow([1, -1], degree - k)
            )
            poly[: len(term)] += binom[k] * b[k] * term
        roots = np.polynomial.polynomial.polyroots(poly)
        real = np.sort(roots.real[(abs(roots.imag) < 1e-12) & (roots.real > 0) & (roots.real < 1)])
        mine = np.sort(t[piece == i])
        assert len(mine) == len(real)
        assert np.allclose(mine, real, atol=1e-9)


# -- linear interpolation: the isosurface's pinch points (saddle values) ------------


def noise_mask(n: int = 40, seed: int = 1) -> np.ndarray:
    """A binary mask of thresholded smooth noise inside a ball (many diagonal faces)."""
    from scipy import ndimage

    rng = np.random.default_rng(seed)
    v = ndimage.gaussian_filter(rng.normal(size=(n, n, n)), 2.0)
    g = np.indices((n, n, n)).transpose(1, 2, 3, 0) - (n - 1) / 2
    return ((v > 0.0) & (np.linalg.norm(g, axis=-1) < 0.4 * n)).astype(float)


def test_face_saddle_of_a_checkerboard_face():
    from rdmesh.surfaces.trilinear import saddle_values

    cell = np.zeros((2, 2, 2))
    cell[0, 0, 0] = cell[0, 1, 1] = 1.0  # the face x = 0 alternates 1, 0, 1, 0
    assert np.any(np.isclose(saddle_values(cell, 0.0, 1.0), 0.5))


def test_body_saddle_is_a_critical_point():
    from rdmesh.surfaces.trilinear import body_saddles

    rng = np.random.default_rng(0)
    cells = rng.normal(size=(2000, 2, 2, 2))
    corners = [cells[:, i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
    # corners in the order v000, v001, v010, v011, v100, v101, v110, v111
    points, values = body_saddles(*corners)
    assert len(points) > 50
    # Which cell each point came from: recompute per cell and compare.
    found = 0
    for cell in cells[:300]:
        c = [cell[i, j, k] for i in (0, 1) for j in (0, 1) for k in (0, 1)]
        pts, vals = body_saddles(*[np.array([x]) for x in c])
        for p, val in zip(pts, vals, strict=True):
            f, g = tensor_spline(np.ascontiguousarray(cell), p[None, :], 1, gradient=True)
            assert np.linalg.norm(g) < 1e-9 * np.ptp(cell)
            assert abs(f[0] - val) < 1e-12 * np.ptp(cell) + 1e-12
            found += 1
    assert found > 5


def test_linear_mask_is_closed_with_the_interpolant_components():
    vol = noise_mask()
    surface = rdmesh.VolumeSurface(vol, interpolation="linear")
    assert surface.requested_isovalue == 0.5
    assert 0.5 < surface.isovalue <= 0.51
    mesh = rdmesh.mesh_surface(surface, radius_bound=1.0)
    rep = mesh.report
    assert rep["closed_manifold"] and mesh.complete and len(mesh.unresolved) == 0
    # The reference: marching cubes of the trilinear interpolant resampled 4x finer.
    want = reference_components(vol, "linear", iso=surface.isovalue)
    assert rep["components"] == want[0]
    assert sum(rep["euler"]) == want[1]


@settings(max_examples=40, deadline=None)
@given(
    seed=st.integers(0, 10_000),
    smooth=st.sampled_from([0.0, 1.0, 3.0]),
    levels=st.sampled_from([2, 4, 256]),
    where=st.floats(0.05, 0.95),
    inside=st.sampled_from(["greater", "less"]),
)
def test_regular_isovalue_is_kept_when_passed_back(seed, smooth, levels, where, inside):
    """The isovalue chosen off the saddle values is its own choice: passed back
    it is kept, so a user can mesh the reported isovalue again. It moves
    towards a smaller inside by less than MAX_SHIFT of the range, and lies
    no nearer a saddle value than the value asked for."""
    from rdmesh.surfaces.trilinear import MAX_SHIFT, SINGULAR_WINDOW, regular_isovalue
    from rdmesh.surfaces.trilinear import saddle_values as saddles
    from scipy.ndimage import gaussian_filter

    rng = np.random.default_rng(seed)
    vol = rng.random((12, 12, 12))
    vol = gaussian_filter(vol, smooth) if smooth else vol
    vol = np.round(vol * (levels - 1)) / (levels - 1)  # quantised, as 8-bit data are
    lo, hi = vol.min(), vol.max()
    if hi == lo:
        return
    iso = lo + where * (hi - lo)
    first = regular_isovalue(vol, iso, inside)
    assert regular_isovalue(vol, first, inside) == first
    shift = (first - iso) * (1.0 if inside == "greater" else -1.0)
    assert 0.0 <= shift < MAX_SHIFT * (hi - lo)
    near = saddles(vol, lo, hi)
    if len(near):
        gap = np.min(np.abs(near - first))
        asked = np.min(np.abs(near - iso))
        assert gap >= min(asked, MAX_SHIFT * (hi - lo)) or asked >= SINGULAR_WINDOW * (hi - lo)


@pytest.mark.slow
def test_linear_mask_at_the_saddle_value_leaves_points_unresolved(monkeypatch):
    # Without the isovalue moved off the interpolant's saddle values, refinement
    # stops at the floor at the singular points (the mesh is closed since the
    # pinched vertices are relabelled).
    import rdmesh.surfaces.volume as volume

    monkeypatch.setattr(volume, "regular_isovalue", lambda v, iso, inside: iso)
    surface = rdmesh.VolumeSurface(noise_mask(), interpolation="linear")
    mesh = rdmesh.mesh_surface(surface, radius_bound=1.0)
    assert not mesh.complete
    assert len(mesh.unresolved) > 0
