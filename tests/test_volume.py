"""rdmesh.VolumeSurface: isosurfaces of sampled volumes.

Volumes come from sampling built-in surfaces (and a CT-like phantom) on a grid,
so the true topology is known (``tests/volumes.py``). Each mesh is small (about
40 samples per axis, the default radius bound R/20) and takes about a second.
"""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
import trimesh
import volumes
from hypothesis import given, settings
from hypothesis import strategies as st
from meshcheck import assert_good_mesh, closed_manifold_problems, euler_per_component
from rdmesh import surfaces
from rdmesh.core import VolumeSampler
from rdmesh.surfaces.volume import tensor_spline
from scipy import ndimage
from scipy.spatial import cKDTree
from test_cli import load, run

#: name -> (surface, box low corner, box high corner, samples per axis, Euler
#: characteristic per component). The two spheres are 0.1 apart: 41 samples
#: over 4.4 put a plane of samples in the gap, so the linear interpolant (whose
#: samples are 0.11 apart) keeps them apart too.
SAMPLED = {
    "sphere": (surfaces.sphere, (-1.3,) * 3, (1.3,) * 3, 40, [2]),
    "torus": (surfaces.torus, (-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), 40, [0]),
    "two_spheres": (surfaces.two_spheres, (-2.2, -1.2, -1.2), (2.2, 1.2, 1.2), 41, [2, 2]),
    "double_torus": (surfaces.double_torus, (-0.3, -1.0, -0.15), (2.3, 1.0, 0.15), 40, [-2]),
}
TORUS_BOX = SAMPLED["torus"][1:3]


def sampled(name: str, n: int | None = None, **kwargs) -> rdmesh.VolumeSurface:
    make, lo, hi, n_default, _ = SAMPLED[name]
    vol, spacing, origin = volumes.sample(make(), lo, hi, n or n_default)
    return rdmesh.VolumeSurface(vol, spacing=spacing, origin=origin, isovalue=0.0, **kwargs)


def check_on_interpolant(surface: rdmesh.VolumeSurface, mesh) -> None:
    """Every vertex lies on the interpolant's zero set or on the box."""
    fv = np.abs(surface.f_volume(mesh.vertices))
    fb = np.abs(surface.box_distance(mesh.vertices))
    assert np.minimum(fv, fb).max() <= 1e-6 * surface.radius


# -- the interpolant --------------------------------------------------------------------


@pytest.mark.parametrize("degree", [1, 3])
def test_sampler_matches_numpy_and_scipy(degree):
    rng = np.random.default_rng(1)
    vol = ndimage.gaussian_filter(rng.normal(size=(9, 7, 8)), 1.0)
    coef = ndimage.spline_filter(vol, order=3, mode="mirror") if degree == 3 else vol
    origin, spacing = np.array([1.0, -2.0, 0.5]), np.array([0.5, 1.0, 2.0])
    x = rng.uniform(0, np.array(vol.shape) - 1, size=(3000, 3))
    x[:9] = [[0, 0, 0], [8, 6, 7], [8, 0, 3.5], [4.5, 6, 0], [0, 3, 7], [1, 1, 1], *x[6:9]]
    v_np, g_np = tensor_spline(coef, x, degree, gradient=True)
    v_mc = ndimage.map_coordinates(coef, x.T, order=degree, mode="mirror", prefilter=False)
    v_cpp, g_cpp = VolumeSampler(coef, degree, origin, spacing).sample(
        origin + x * spacing, gradient=True
    )
    assert np.abs(v_np - v_mc).max() < 1e-12
    assert np.abs(v_cpp - v_np).max() < 1e-12
    assert np.abs(g_cpp - g_np / spacing).max() < 1e-12
    # The interpolant passes through the samples.
    idx = np.indices(vol.shape).reshape(3, -1).T.astype(float)
    assert np.abs(tensor_spline(coef, idx, degree)[0] - vol.ravel()).max() < 1e-12
    # The gradient is the derivative (inside cells, where the linear one is smooth).
    inner = np.all(np.abs(x - np.round(x)) > 1e-3, axis=1)
    h = 1e-6
    fd = np.stack(
        [
            (tensor_spline(coef, x + h * e, degree)[0] - tensor_spline(coef, x - h * e, degree)[0])
            / (2 * h)
            for e in np.eye(3)
        ],
        axis=1,
    )
    assert np.abs(g_np - fd)[inner].max() < 1e-6


def tilted_half_space(n: int = 30, **kwargs) -> rdmesh.VolumeSurface:
    """Inside is below a tilted plane that cuts the box: the surface meets the border."""
    p = volumes.grid((n, n, n), (1.0, 1.0, 1.0), (0.0, 0.0, 0.0))
    vol = p[..., 2] + 0.2 * p[..., 0] - 0.1 * p[..., 1]
    return rdmesh.VolumeSurface(vol, isovalue=0.6 * (n - 1), inside="less", **kwargs)


@settings(max_examples=60, deadline=None)
@given(
    degree=st.sampled_from([1, 3]),
    shape=st.tuples(*[st.integers(2, 7)] * 3),
    seed=st.integers(0, 2**32 - 1),
)
def test_compiled_sampler_equals_the_numpy_reference_anywhere(degree, shape, seed):
    # Any shape, spacing and origin, points inside and outside the grid.
    shape = tuple(max(n, degree + 1) for n in shape)
    rng = np.random.default_rng(seed)
    coef = rng.normal(size=shape)
    origin = rng.uniform(-5, 5, 3)
    spacing = rng.uniform(0.1, 3, 3)
    x = rng.uniform(-2, np.array(shape) + 1, size=(500, 3))
    x[:50] = np.round(x[:50])  # on grid nodes and faces
    p = origin + x * spacing
    v, g = VolumeSampler(coef, degree, origin, spacing).sample(p, True)
    x = (p - origin) / spacing  # as the sampler computes it (nodes may move by an ulp)
    v_ref, g_ref = tensor_spline(coef, x, degree, gradient=True)
    g_ref[(x < 0) | (x > np.array(shape) - 1)] = 0.0
    assert np.allclose(v, v_ref, rtol=0, atol=1e-11)
    assert np.allclose(g, g_ref / spacing, rtol=0, atol=1e-10)


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_oracle_is_positive_outside_the_box_and_its_gradient_is_exact(interpolation):
    s = tilted_half_space(12, interpolation=interpolation)
    rng = np.random.default_rng(2)
    # On and outside the bounding sphere (and everywhere outside the box): f > 0.
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    far = s.centre + s.radius * d * rng.uniform(1.0, 3.0, size=(2000, 1))
    assert s(far).min() > 0
    out = s.centre + rng.normal(size=(5000, 3)) * s.radius
    out = out[s.box_distance(out) > 0]
    assert len(out) > 100 and s(out).min() > 0
    # Inside the box, away from the max's kink and the box's own ridges, the
    # gradient is the derivative of f.
    lo, hi = s.box
    p = rng.uniform(lo, hi, size=(4000, 3))
    fv, d = s.f_volume(p), s.box_distance(p)
    gaps = np.sort(np.minimum(p - lo, hi - p), axis=1)
    smooth = (np.abs(fv - d) > 1e-3) & (gaps[:, 1] - gaps[:, 0] > 1e-3)
    h = 1e-6
    fd = np.stack([(s(p + h * e) - s(p - h * e)) / (2 * h) for e in np.eye(3)], axis=1)
    assert smooth.mean() > 0.9
    assert np.abs(s.grad(p) - fd)[smooth].max() < 1e-5


def test_default_isovalue_is_the_midpoint_and_f_is_scaled_data():
    vol, _, _ = volumes.sample(surfaces.sphere(), (-1.3,) * 3, (1.3,) * 3, 12)
    s = rdmesh.VolumeSurface(vol)
    assert s.isovalue == pytest.approx(0.5 * (vol.min() + vol.max()), rel=1e-15)
    idx = np.indices(vol.shape).reshape(3, -1).T.astype(float)
    expected = (s.isovalue - vol.ravel()) / s.value_scale
    assert np.abs(s.f_volume(idx) - expected).max() < 1e-12
    less = rdmesh.VolumeSurface(vol, inside="less")
    assert np.abs(less.f_volume(idx) + expected).max() < 1e-12
    # A boolean mask is 0/1, so its default isovalue is 0.5.
    assert rdmesh.VolumeSurface(vol > 0).isovalue == 0.5


# -- meshes of known topology --------------------------------------------------------------


@pytest.mark.parametrize("name", ["sphere", "torus", "two_spheres"])
@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
def test_sampled_surfaces_keep_their_topology(name, interpolation):
    s = sampled(name, interpolation=interpolation)
    mesh = rdmesh.mesh_surface(s)
    assert_good_mesh(mesh, s, s.grad, s.radius, euler=SAMPLED[name][4])
    check_on_interpolant(s, mesh)
    topo = mesh.topology()
    assert topo["closed_manifold"]
    assert topo["genus"] == [(2 - e) / 2 for e in SAMPLED[name][4]]
    # Nowhere near the box: the border did not take part.
    assert np.abs(s.f_volume(mesh.vertices)).max() <= 1e-6 * s.radius


def test_anisotropic_double_torus():
    # Thin in z: 40 samples over 0.3 against 2.6 in x (spacing ratio about 9).
    s = sampled("double_torus")
    mesh = rdmesh.mesh_surface(s, radius_bound=s.radius / 40)
    assert_good_mesh(mesh, s, s.grad, s.radius, euler=[-2])
    check_on_interpolant(s, mesh)


def test_phantom_bones_have_the_known_topology():
    vol, spacing = volumes.phantom()
    s = rdmesh.VolumeSurface(vol, spacing=spacing, isovalue=volumes.BONE_ISOVALUE)
    mesh = rdmesh.mesh_surface(s)
    assert_good_mesh(mesh, s, s.grad, s.radius)
    assert sorted(euler_per_component(mesh.faces, len(mesh.vertices))) == sorted(
        volumes.PHANTOM_EULER
    )
    check_on_interpolant(s, mesh)


def test_two_threads_give_the_same_mesh():
    s = sampled("torus")
    one = rdmesh.mesh_surface(s, workers=1)
    two = rdmesh.mesh_surface(s, workers=2)
    assert np.array_equal(one.vertices, two.vertices)
    assert np.array_equal(one.faces, two.faces)


# -- conventions ----------------------------------------------------------------------


def test_same_place_as_marching_cubes_with_spacing_and_origin():
    measure = pytest.importorskip("skimage.measure")
    # An ellipsoid off-centre, sampled with anisotropic spacing; marching
    # cubes' vertices are index * spacing, so add the origin to them.
    n = (36, 30, 24)
    spacing = np.array([0.05, 0.08, 0.1])
    origin = np.array([-0.7, 1.3, 0.2])
    p = volumes.grid(n, spacing, origin)
    centre = origin + (np.array(n) - 1) * spacing * [0.45, 0.5, 0.55]
    q = (p - centre) / [0.6, 0.75, 0.7]
    vol = 1.0 - np.einsum("...i,...i->...", q, q)
    s = rdmesh.VolumeSurface(vol, spacing=spacing, origin=origin, isovalue=0.0)
    mesh = rdmesh.mesh_surface(s)
    verts, faces, _, _ = measure.marching_cubes(vol, 0.0, spacing=tuple(spacing))
    verts = verts + origin
    step = spacing.max()
    assert np.abs(mesh.vertices.min(0) - verts.min(0)).max() < 0.5 * step
    assert np.abs(mesh.vertices.max(0) - verts.max(0)).max() < 0.5 * step
    # Symmetric distance between the vertex sets (each about a radius bound apart).
    r = mesh.ball_radii.max()
    a = cKDTree(verts).query(mesh.vertices)[0].max()
    b = cKDTree(mesh.vertices).query(verts)[0].max()
    assert max(a, b) < r + step
    # And both approximate the true ellipsoid: the mesh much better than a voxel.
    q = (mesh.vertices - centre) / [0.6, 0.75, 0.7]
    assert np.abs(np.sqrt(np.einsum("ij,ij->i", q, q)) - 1).max() < 0.05 * step / 0.6


def test_inside_less_on_negated_data_is_the_same_surface():
    vol, spacing, origin = volumes.sample(
        surfaces.torus(), (-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), 40
    )
    greater = rdmesh.VolumeSurface(vol, spacing=spacing, origin=origin, isovalue=0.0)
    less = rdmesh.VolumeSurface(-vol, spacing=spacing, origin=origin, isovalue=0.0, inside="less")
    p = np.random.default_rng(3).uniform(-1.6, 1.6, size=(1000, 3))
    assert np.array_equal(greater(p), less(p))
    a, b = rdmesh.mesh_surface(greater), rdmesh.mesh_surface(less)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)


# -- the border -------------------------------------------------------------------------


def test_a_surface_crossing_the_border_is_closed_by_the_box():
    s = tilted_half_space()
    mesh = rdmesh.mesh_surface(s)
    assert_good_mesh(mesh, s, s.grad, s.radius, euler=[2])
    tm = mesh.to_trimesh()
    assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0
    check_on_interpolant(s, mesh)
    # Part of the mesh lies on the faces of the box, part on the plane.
    on_box = np.abs(s.box_distance(mesh.vertices)) <= 1e-6 * s.radius
    on_plane = np.abs(s.f_volume(mesh.vertices)) <= 1e-6 * s.radius
    assert on_box.mean() > 0.3 and on_plane.mean() > 0.1
    # The enclosed volume is that of the solid (the plane is linear, so the
    # interpolant is exact): within the error of the faceted crease.
    lo, hi = s.box
    g = volumes.grid((60, 60, 60), (hi - lo) / 59, lo)
    solid = (g[..., 2] + 0.2 * g[..., 0] - 0.1 * g[..., 1] < s.isovalue).mean() * np.prod(hi - lo)
    assert tm.volume == pytest.approx(solid, rel=0.03)


def test_the_complement_of_a_torus_is_the_box_and_the_torus():
    # inside="less" on the torus volume: the box minus the solid torus, whose
    # boundary is the box (Euler 2) and the torus (0).
    s = sampled("torus", inside="less")
    mesh = rdmesh.mesh_surface(s)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert euler_per_component(mesh.faces, len(mesh.vertices)) == [2, 0]
    check_on_interpolant(s, mesh)


# -- bad input ---------------------------------------------------------------------------

GOOD = np.linspace(0.0, 1.0, 5 * 5 * 5).reshape(5, 5, 5)

BAD_INPUTS = [
    ({"volume": GOOD[0]}, ValueError, r"3-D array, got 2-D"),
    ({"volume": GOOD[None]}, ValueError, r"3-D array, got 4-D"),
    ({"volume": GOOD[:3]}, ValueError, r"at least 4 samples .* cubic"),
    ({"volume": GOOD[:1], "interpolation": "linear"}, ValueError, r"at least 2 samples"),
    ({"volume": np.where(GOOD > 0.5, np.nan, GOOD)}, ValueError, r"finite: \d+ NaN"),
    ({"volume": np.where(GOOD > 0.5, np.inf, GOOD)}, ValueError, r"finite"),
    ({"volume": GOOD.astype(complex)}, ValueError, r"real numbers .* complex"),
    ({"volume": GOOD.astype(str)}, ValueError, r"real numbers"),
    ({"spacing": (1.0, 0.0, 1.0)}, ValueError, r"spacing must be 3 positive"),
    ({"spacing": (1.0, -1.0, 1.0)}, ValueError, r"spacing must be 3 positive"),
    ({"spacing": (1.0, np.nan, 1.0)}, ValueError, r"spacing must be 3 positive"),
    ({"spacing": (1.0, 1.0)}, ValueError, r"spacing must be 3 positive"),
    ({"origin": (0.0, np.inf, 0.0)}, ValueError, r"origin must be 3 finite"),
    ({"isovalue": 2.0}, rdmesh.EmptySurfaceError, r"outside the range"),
    ({"isovalue": -0.5}, rdmesh.EmptySurfaceError, r"outside the range"),
    ({"isovalue": 1.0}, rdmesh.EmptySurfaceError, r"outside the range"),
    ({"isovalue": np.nan}, ValueError, r"isovalue must be finite"),
    ({"isovalue": "high"}, ValueError, r"isovalue must be a number"),
    ({"volume": np.full((5, 5, 5), 3.0)}, rdmesh.EmptySurfaceError, r"constant"),
    ({"inside": "above"}, ValueError, r"unknown inside 'above'"),
    ({"interpolation": "quintic"}, ValueError, r"unknown interpolation"),
    ({"border": "open"}, ValueError, r"unknown border 'open'"),
]


@pytest.mark.parametrize(("kwargs", "error", "match"), BAD_INPUTS)
def test_bad_input_is_refused_with_a_clear_message(kwargs, error, match):
    kwargs = dict(kwargs)
    volume = kwargs.pop("volume", GOOD)
    with pytest.raises(error, match=match):
        rdmesh.VolumeSurface(volume, **kwargs)


def test_any_real_dtype_is_accepted():
    base = rdmesh.VolumeSurface(GOOD * 100)
    idx = np.indices(GOOD.shape).reshape(3, -1).T.astype(float)
    for dtype in (np.uint8, np.int16, np.int64, np.float32):
        s = rdmesh.VolumeSurface((GOOD * 100).astype(dtype))
        assert np.allclose(s.values(idx), (GOOD * 100).astype(dtype).ravel(), atol=1e-9)
        assert s.isovalue == pytest.approx(base.isovalue, abs=1)


# -- command line -----------------------------------------------------------------------


def test_cli_meshes_a_volume_file(tmp_path):
    vol, spacing, origin = volumes.sample(
        surfaces.torus(), (-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), 40
    )
    np.save(tmp_path / "torus.npy", vol.astype(np.float32))
    out = run(
        "mesh", "torus.npy", "--isovalue", "0", "--spacing", *map(str, spacing),
        "--origin", *map(str, origin), "-o", "torus.ply", "--quiet", cwd=tmp_path,
    )  # fmt: skip
    assert out.returncode == 0, out.stderr
    mesh = load(tmp_path / "torus.ply")
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.euler_number == 0
    # The mesh is where the torus is: the world coordinates came through.
    assert np.allclose(mesh.bounds, [[-1.4, -1.4, -0.4], [1.4, 1.4, 0.4]], atol=0.05)
    ref = trimesh.load(tmp_path / "torus.ply", process=False)
    assert len(ref.vertices) == len(mesh.vertices)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["flat.npy"], "3-D array"),
        (["vol.npy", "--isovalue", "5"], "outside the range"),
        (["vol.npy", "--spacing", "1", "0", "1"], "must be positive"),
        (["missing.npy"], "no such volume file"),
        (["torus", "--isovalue", "0"], "applies only to volumes"),
        (["vol.npy", "--bound", "3"], "do not apply to a volume"),
    ],
)
def test_cli_bad_volume_input_is_one_line(tmp_path, args, message):
    np.save(tmp_path / "vol.npy", GOOD)
    np.save(tmp_path / "flat.npy", GOOD[0])
    out = run("mesh", *args, "-o", "o.ply", cwd=tmp_path)
    assert out.returncode == 2
    assert message in out.stderr and "Traceback" not in out.stderr
    assert len(out.stderr.strip().splitlines()) == 1


# -- larger ------------------------------------------------------------------------------


def test_noisy_blurred_torus_at_80_samples():
    vol, spacing, origin = volumes.sample(
        surfaces.torus(), (-1.6, -1.6, -0.6), (1.6, 1.6, 0.6), 80
    )
    rng = np.random.default_rng(4)
    vol = ndimage.gaussian_filter(vol + rng.normal(0, 0.02, vol.shape), 1.0)
    s = rdmesh.VolumeSurface(vol, spacing=spacing, origin=origin, isovalue=0.0)
    mesh = rdmesh.mesh_surface(s, radius_bound=s.radius / 60)
    assert_good_mesh(mesh, s, s.grad, s.radius, euler=[0])
    check_on_interpolant(s, mesh)


@pytest.mark.slow
@pytest.mark.parametrize("method", ["boissonnat-oudot", "topological-ball"])
def test_larger_phantom_both_methods(method):
    # 96 x 96 x 64 samples; the bones do not reach the border, so the surface
    # is smooth (no crease) and both methods apply.
    vol, spacing = volumes.phantom((96, 96, 64), spacing=(0.5, 0.5, 0.75))
    s = rdmesh.VolumeSurface(vol, spacing=spacing, isovalue=volumes.BONE_ISOVALUE)
    radius = s.radius / 80 if method == "boissonnat-oudot" else None
    mesh = rdmesh.mesh_surface(s, method=method, radius_bound=radius)
    assert_good_mesh(mesh, s, s.grad, s.radius)
    assert sorted(euler_per_component(mesh.faces, len(mesh.vertices))) == sorted(
        volumes.PHANTOM_EULER
    )
    assert mesh.report["tbp_holds"]


@pytest.mark.parametrize("interpolation", ["cubic", "linear"])
@pytest.mark.parametrize("border", ["closed", "clipped"])
def test_gradient_bound_holds_in_each_box(interpolation, border):
    # Noise is the hard case: steep, changing slopes everywhere. Boxes reach
    # past the volume too (the gradient of the nearest box point holds there).
    rng = np.random.default_rng(7)
    vol = 3.0 * rng.random((13, 17, 11))
    s = rdmesh.VolumeSurface(
        vol, isovalue=1.5, interpolation=interpolation, border=border,
        spacing=(0.5, 1.0, 2.0), origin=(1.0, 2.0, 3.0),
    )  # fmt: skip
    lo, hi = s.box
    centres = rng.uniform(lo - 1.0, hi + 1.0, size=(150, 3))
    radius = 0.7
    bound = s.gradient_bound(centres, radius)
    points = centres[:, None, :] + rng.uniform(-radius, radius, size=(150, 300, 3))
    slopes = np.linalg.norm(s.grad(points.reshape(-1, 3)), axis=1).reshape(150, 300)
    ratio = (slopes / bound[:, None]).max()
    assert ratio <= 1.0
    if border == "closed":
        assert np.all(bound >= 1.0)  # the box's distance is 1-Lipschitz
    if interpolation == "linear":
        assert ratio > 0.5  # not a loose bound: the steepest slope comes close
