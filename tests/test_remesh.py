"""Remeshing triangle meshes: rdmesh.MeshSurface and ``rdmesh remesh``.

Inputs are what a user would have: marching-cubes meshes of the built-in
surfaces (scikit-image), a decimated (vertex-clustered) and a noisy version,
meshes with a hole, overlapping parts, a cube. Each test checks properties
against values computed independently (exact distances, meshcheck).
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest
import rdmesh
import trimesh
from meshcheck import assert_good_mesh, closed_manifold_problems, euler_per_component
from rdmesh import MeshInputError, MeshSurface, cli
from rdmesh.surfaces import SURFACES
from rdmesh.topology.complex import component_topology

skimage_measure = pytest.importorskip("skimage.measure")


# -- inputs ---------------------------------------------------------------------------


def marching_cubes(name: str, n: int = 40) -> tuple[np.ndarray, np.ndarray]:
    """A built-in surface sampled on an n^3 grid over its bounding box, as a user would."""
    s = SURFACES[name].make()
    ax = np.linspace(-s.radius, s.radius, n)
    grid = np.stack(np.meshgrid(ax, ax, ax, indexing="ij"), -1).reshape(-1, 3) + s.centre
    v, f, _, _ = skimage_measure.marching_cubes(
        s(grid).reshape(n, n, n), 0.0, spacing=(ax[1] - ax[0],) * 3
    )
    return v + (s.centre - s.radius), f.astype(np.int64)


def decimate(v: np.ndarray, f: np.ndarray, cell: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertex clustering: one vertex (the mean) per grid cell, collapsed faces dropped."""
    _, label = np.unique(np.floor(v / cell).astype(np.int64), axis=0, return_inverse=True)
    label = label.reshape(-1)
    counts = np.bincount(label)
    nv = np.stack([np.bincount(label, weights=v[:, k]) for k in range(3)], axis=1)
    nf = label[f]
    keep = (nf[:, 0] != nf[:, 1]) & (nf[:, 1] != nf[:, 2]) & (nf[:, 0] != nf[:, 2])
    return nv / counts[:, None], nf[keep]


def mean_edge(v: np.ndarray, f: np.ndarray) -> float:
    return float(np.linalg.norm(v[f[:, 0]] - v[f[:, 1]], axis=1).mean())


def variant(name: str, kind: str) -> tuple[np.ndarray, np.ndarray]:
    v, f = marching_cubes(name)
    if kind == "decimated":
        return decimate(v, f, 2.5 * mean_edge(v, f))
    if kind == "noisy":
        # Displacement along the vertex normals: random directions would flip the
        # slivers marching cubes makes, a self-intersecting input (see the docs).
        normals = trimesh.Trimesh(v, f, process=False).vertex_normals
        rng = np.random.default_rng(7)
        return v + rng.normal(scale=0.1 * mean_edge(v, f), size=(len(v), 1)) * normals, f
    return v, f


def surface_samples(v: np.ndarray, f: np.ndarray, n: int, seed: int = 0) -> np.ndarray:
    """n area-weighted random points on the mesh, plus its vertices."""
    rng = np.random.default_rng(seed)
    a = np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    pick = rng.choice(len(f), n, p=a / a.sum())
    r = rng.random((n, 2))
    flip = r.sum(axis=1) > 1
    r[flip] = 1 - r[flip]
    t = v[f[pick]]
    return np.vstack(
        [t[:, 0] + r[:, :1] * (t[:, 1] - t[:, 0]) + r[:, 1:] * (t[:, 2] - t[:, 0]), v]
    )


def hausdorff(a: tuple, b: tuple, n: int = 20_000) -> tuple[float, float]:
    """(max distance from a to b, from b to a), on samples, through exact point-mesh distances."""
    sa, sb = MeshSurface(a), MeshSurface(b)
    ab = np.abs(sb.signed_distance(surface_samples(*a, n))).max()
    ba = np.abs(sa.signed_distance(surface_samples(*b, n))).max()
    return float(ab), float(ba)


def cube(subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """The cube [-1, 1]^3, each face split into small triangles."""
    box = trimesh.creation.box(extents=(2, 2, 2))
    v, f = box.vertices, box.faces
    for _ in range(subdivisions):
        v, f = trimesh.remesh.subdivide(v, f)
    return np.asarray(v), np.asarray(f)


def check_remesh(
    name: str, v: np.ndarray, f: np.ndarray, radius_fraction: float = 20
) -> rdmesh.SurfaceMesh:
    """Remesh (v, f) and check every property: manifold, topology, angles, Hausdorff."""
    ms = MeshSurface((v, f))
    rb = ms.radius / radius_fraction
    db = rb / 10
    mesh = rdmesh.mesh_surface(ms, angle_bound=30, radius_bound=rb, distance_bound=db)
    if len(ms.self_intersections):
        # Noise can fold faces through each other: the input then intersects itself,
        # which the report names and which marks the mesh incomplete (issue 30); the
        # remesh of the union it encloses is still checked below.
        assert not mesh.complete
        assert "intersects itself" in mesh.stats["stop_reason"]
        assert mesh.report["input"]["self_intersections"]["pairs"] == len(ms.self_intersections)
        mesh.complete = True
    refused = not mesh.complete and not len(ms.self_intersections)
    if refused:
        # Noise can bring two sheets closer than the spacing floor (a fold's tip):
        # the points refused there must be the ones the report names. The facets
        # next to them are not proven (their centres are sampled), so only the
        # whole-mesh properties are checked below.
        close = mesh.report["input"].get("close_sheets") or {}
        assert len(mesh.unresolved) > 0
        assert close.get("points") == len(mesh.unresolved)
        assert "nearly touch" in mesh.report["input"]["statement"]
    # The input's topology when it is a closed manifold (marching cubes may already
    # have joined parts closer than its grid), else the surface's.
    if closed_manifold_problems(ms.faces, len(ms.vertices)) == []:
        expected = euler_per_component(ms.faces, len(ms.vertices))
    else:
        info = SURFACES[name]
        expected = [2] * info.components if info.components > 1 else [info.euler]
    if refused:
        assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
        assert euler_per_component(mesh.faces, len(mesh.vertices)) == expected
    else:
        # Closed manifold, angle bound, size and distance bounds, vertices on the
        # input, orientation: the independent checks of the smooth-surface tests.
        assert_good_mesh(
            mesh, ms, ms.grad, ms.radius, angle_bound=30, sizing=rb, euler=expected,
            distance_bound=db,
        )  # fmt: skip
    # Each output triangle lies in its surface Delaunay ball (radius <= rb) centred on
    # the input: output -> input <= rb. Input -> output is a sampling property.
    to_input, to_output = hausdorff((mesh.vertices, mesh.faces), (ms.vertices, ms.faces))
    assert to_input <= rb
    assert to_output <= rb
    return mesh


# -- remeshing ------------------------------------------------------------------------


@pytest.mark.parametrize("kind", ["plain", "decimated", "noisy"])
def test_torus_remesh_keeps_topology_and_bounds(kind):
    v, f = variant("torus", kind)
    check_remesh("torus", v, f)


def test_sphere_remesh():
    check_remesh("sphere", *marching_cubes("sphere"))


# Not here: the decimated and noisy double torus. Vertex clustering breaks its thin
# parts (the input is not closed), and at R/40 the noise's folds there are resolved
# and refinement ends at the spacing floor (benchmarks/remesh.py shows both).
@pytest.mark.slow
@pytest.mark.parametrize(
    ("name", "kind"),
    [("double_torus", "plain")]
    + [(n, k) for n in ("two_spheres", "tanglecube") for k in ("plain", "decimated", "noisy")],
)
def test_more_remeshes(name, kind):
    v, f = variant(name, kind)
    check_remesh(name, v, f, radius_fraction=40)


def test_small_hole_is_closed_by_the_winding_number():
    v, f = marching_cubes("torus")
    centroid = v[f].mean(axis=1)
    hole = np.linalg.norm(centroid - [1.4, 0.0, 0.0], axis=1) < 0.15
    assert 5 < hole.sum() < 0.02 * len(f)
    ms = MeshSurface((v, f[~hole]), holes="fill")
    assert ms.sign_method == "winding"
    # Across the hole the zero set is a patch where w = 0.5: f is continuous there.
    mesh = rdmesh.mesh_surface(ms, radius_bound=ms.radius / 20)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert euler_per_component(mesh.faces, len(mesh.vertices)) == [0]
    assert mesh.min_angle >= 30 - 1e-9


def test_half_sphere_becomes_a_closed_half_ball():
    # On the half sphere's base disc the winding number is exactly 0.5 (the half
    # sphere is seen under 2 pi), so the disc closes it.
    ico = trimesh.creation.icosphere(subdivisions=3)
    top = ico.faces[ico.vertices[ico.faces].mean(axis=1)[:, 2] > 0]
    ms = MeshSurface((ico.vertices, top), holes="fill")
    assert ms.sign_method == "winding" and 0 < ms.ambiguous_share < 0.2
    rb = ms.radius / 20
    mesh = rdmesh.mesh_surface(ms, radius_bound=rb)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert euler_per_component(mesh.faces, len(mesh.vertices)) == [2]
    z = mesh.vertices[:, 2]
    assert -rb < z.min() < rb and z.max() > 0.99


def test_overlapping_parts_give_their_union():
    a = trimesh.creation.icosphere(subdivisions=3)
    b = a.copy()
    b.apply_translation([1.0, 0, 0])
    v = np.vstack([a.vertices, b.vertices])
    f = np.vstack([a.faces, b.faces + len(a.vertices)])
    ms = MeshSurface((v, f))
    assert ms.sign_method == "winding"
    inside = np.array([[0.5, 0, 0], [-0.3, 0, 0], [1.3, 0, 0]])  # both, one, the other
    assert np.all(ms(inside) < 0)
    mesh = rdmesh.mesh_surface(ms, radius_bound=ms.radius / 15)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert euler_per_component(mesh.faces, len(mesh.vertices)) == [2]


def test_cube_creases_are_kept_by_default():
    v, f = cube()
    ms = MeshSurface((v, f))
    assert len(ms.sharp_curves) == 12
    mesh = rdmesh.mesh_surface(ms, radius_bound=ms.radius / 20, distance_bound=ms.radius / 200)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert mesh.features.held
    # Corners and edges are on the output: no chamfer.
    out = MeshSurface((mesh.vertices, mesh.faces), feature_angle=None)
    corners = np.array([[1, 1, 1], [-1, -1, -1], [1, -1, 1]], float)
    edges = np.array([[1, 1, 0.1], [0.2, -1, 1], [-1, 0.3, -1]], float)
    for d in (out.signed_distance(corners), out.signed_distance(edges)):
        assert np.abs(d).max() <= 1e-12


def test_cube_creases_are_cut_within_the_bounds_without_features():
    v, f = cube()
    ms = MeshSurface((v, f), feature_angle=None)
    rb = ms.radius / 20
    db = rb / 10
    mesh = rdmesh.mesh_surface(ms, radius_bound=rb, distance_bound=db)
    assert closed_manifold_problems(mesh.faces, len(mesh.vertices)) == []
    assert euler_per_component(mesh.faces, len(mesh.vertices)) == [2]
    assert np.abs(ms.signed_distance(mesh.vertices)).max() <= 1e-8
    # Corners and edges are cut, not kept: never inside the output, and
    # outside by less than the size bound; the corners, which stand out the
    # most, within the distance bound (the distance check inserts them).
    out = MeshSurface((mesh.vertices, mesh.faces), feature_angle=None)
    corners = np.array([[1, 1, 1], [-1, -1, -1], [1, -1, 1]], float)
    edges = np.array([[1, 1, 0.1], [0.2, -1, 1], [-1, 0.3, -1]], float)
    for d in (out.signed_distance(corners), out.signed_distance(edges)):
        assert np.all(d >= 0) and np.all(d <= rb)
    assert np.all(out.signed_distance(corners) <= db)
    s = np.linspace(-1, 1, 401)
    along = np.stack([s, np.ones_like(s), np.ones_like(s)], axis=1)
    assert out.signed_distance(along).max() > 0  # an edge is still cut somewhere
    # Face centres stay on the output.
    assert np.abs(out.signed_distance(np.eye(3))).max() <= 1e-9


# -- the oracle -----------------------------------------------------------------------


def test_signed_distance_to_a_cube_is_exact():
    ms = MeshSurface(cube())
    assert ms.sign_method == "side"
    p = np.array(
        [
            [0.3, 0.2, 1.5],  # above the top face
            [0.3, 0.2, 0.9],  # inside, 0.1 below it
            [2.0, 2.0, 0.0],  # nearest an edge
            [2.0, 3.0, 4.0],  # nearest a corner
            [0.0, 0.0, 0.0],  # centre
        ]
    )
    exact = np.array([0.5, -0.1, np.sqrt(2), np.sqrt(1 + 4 + 9), -1.0])
    assert np.allclose(ms.signed_distance(p), exact, rtol=0, atol=1e-12)
    # f is the same, clamped to +- cap.
    assert np.allclose(ms(p), np.clip(exact, -ms.cap, ms.cap), rtol=0, atol=1e-12)
    g = ms.grad(p[:4])
    expect = np.array([[0, 0, 1], [0, 0, 1], [1, 1, 0], [1, 2, 3]], float)
    expect /= np.linalg.norm(expect, axis=1)[:, None]
    assert np.allclose(g, expect, atol=1e-12)
    closest, _ = ms.closest_points(p[:1])
    assert np.allclose(closest, [[0.3, 0.2, 1.0]], atol=1e-12)


def test_sphere_mesh_inside_outside_and_orientation():
    ico = trimesh.creation.icosphere(subdivisions=4)
    rng = np.random.default_rng(1)
    d = rng.normal(size=(2000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    r = rng.uniform(0.05, 2.0, size=(2000, 1))
    p = d * r
    for faces in (ico.faces, ico.faces[:, ::-1]):  # inward-oriented input is flipped
        ms = MeshSurface((ico.vertices, faces))
        s = ms.signed_distance(p)
        inside = r[:, 0] < 0.98  # the icosphere lies between radii 0.99 and 1
        outside = r[:, 0] > 1.0
        assert np.all(s[inside] < 0) and np.all(s[outside] > 0)
        # |s| is the distance to the polyhedron: within 0.01 of | |p| - 1 |.
        assert np.allclose(np.abs(s), np.abs(r[:, 0] - 1), atol=0.011)
        # The winding number agrees with Side_of_triangle_mesh away from the surface.
        w = ms.winding_number(p)
        far = np.abs(s) > 1e-3
        assert np.array_equal(w[far] > 0.5, s[far] < 0)


def test_gradient_on_the_mesh_points_out_even_for_a_part_oriented_inwards():
    a = trimesh.creation.icosphere(subdivisions=2)
    v = np.vstack([a.vertices, a.vertices + [3.0, 0, 0]])
    f = np.vstack([a.faces, a.faces[:, ::-1] + len(a.vertices)])  # second part inward
    ms = MeshSurface((v, f))
    assert ms.sign_method == "side"
    centre = np.where(v[:, :1] > 1.5, [3.0, 0, 0], [0.0, 0, 0])
    g = ms.grad(v)  # on the mesh: the normals of the closest faces
    assert np.all(np.einsum("ij,ij->i", g, v - centre) > 0)
    assert np.all(ms(centre[[0, -1]] + 0.0) < 0)


def test_gradient_matches_differences_outside_a_convex_mesh():
    # Outside a convex polyhedron the distance is continuously differentiable.
    ico = trimesh.creation.icosphere(subdivisions=2)
    ms = MeshSurface((ico.vertices, ico.faces))
    rng = np.random.default_rng(2)
    d = rng.normal(size=(500, 3))
    p = d / np.linalg.norm(d, axis=1)[:, None] * rng.uniform(1.05, 1.3, size=(500, 1))
    h = 1e-6
    fd = np.stack(
        [
            (ms.signed_distance(p + h * e) - ms.signed_distance(p - h * e)) / (2 * h)
            for e in np.eye(3)
        ],
        axis=1,
    )
    g = ms.grad(p)
    assert np.allclose(np.linalg.norm(g, axis=1), 1.0)
    assert np.abs(g - fd).max() < 1e-5


def test_clamped_oracle_equals_the_clamped_distance():
    # f skips the exact query far from the mesh (k-d tree bound): check it never differs.
    ms = MeshSurface(marching_cubes("torus", n=24))
    p = np.random.default_rng(3).uniform(-ms.radius, ms.radius, size=(20_000, 3))
    exact = ms.signed_distance(p)
    assert np.array_equal(ms(p), np.clip(exact, -ms.cap, ms.cap))
    assert (np.abs(exact) > ms.cap).mean() > 0.3  # the shortcut was taken


def test_two_threads_get_the_same_answers_as_one():
    ms = MeshSurface(marching_cubes("torus", n=32))
    rng = np.random.default_rng(4)
    sets = [rng.uniform(-ms.radius, ms.radius, size=(30_000, 3)) for _ in range(4)]

    def answers(p):
        return ms(p), ms.grad(p), ms.signed_distance(p), ms.winding_number(p)

    serial = [answers(p) for p in sets]
    with ThreadPoolExecutor(max_workers=2) as pool:
        parallel = list(pool.map(lambda i: answers(sets[i % 4]), range(8)))
    for i, got in enumerate(parallel):
        for a, b in zip(got, serial[i % 4], strict=True):
            assert np.array_equal(a, b)


def test_usable_from_two_threads_in_mesh_surface():
    ms = MeshSurface(marching_cubes("sphere", n=24))
    one = rdmesh.mesh_surface(ms, radius_bound=ms.radius / 10, seed=5)
    two = rdmesh.mesh_surface(ms, radius_bound=ms.radius / 10, seed=5, workers=2)
    assert np.array_equal(one.vertices, two.vertices)
    assert np.array_equal(one.faces, two.faces)


# -- bad input ------------------------------------------------------------------------

_TRI = (np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]]), np.array([[0, 1, 2]]))


def _tetra() -> tuple[np.ndarray, np.ndarray]:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    return v, np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])


def _with(index, value, faces=False):
    v, f = (a.copy() for a in _tetra())
    if faces:
        f = f.astype(float) if isinstance(value, float) else f
        f[index] = value
    else:
        v[index] = value
    return v, f


# A flat square of 8 x 8 x 2 triangles: nothing to be inside of.
_SQUARE = trimesh.creation.box(extents=(2, 2, 0.0001))
_SQUARE = trimesh.remesh.subdivide(_SQUARE.vertices, _SQUARE.faces)
_SQUARE = (_SQUARE[0], _SQUARE[1][_SQUARE[0][_SQUARE[1]].mean(axis=1)[:, 2] > 0])


def test_a_single_triangle_is_remeshed_as_a_disk():
    """An open sheet (here one triangle) is closed by a tent while meshing: the
    remesh is a disk on the triangle with its three corners."""
    surface = rdmesh.MeshSurface(_TRI)
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.1, distance_bound=0.01)
    chi, loops = component_topology(mesh.faces, len(mesh.vertices))
    assert list(chi) == [1] and list(loops) == [1] and mesh.complete
    assert np.abs(mesh.vertices[:, 2]).max() < 1e-12
    assert np.all(mesh.vertices[:, :2].sum(axis=1) <= 1 + 1e-12)
    corners = _TRI[0][:3]
    assert np.linalg.norm(mesh.vertices[:, None] - corners[None], axis=2).min(axis=0).max() < 1e-12


BAD_INPUTS = [
    (42, "trimesh.Trimesh or a \\(vertices, faces\\) pair"),
    ((np.zeros((4, 2)), np.array([[0, 1, 2]])), "vertices must have shape \\(n, 3\\)"),
    ((_tetra()[0], np.array([[0, 1, 2, 3]])), "faces must have shape \\(m, 3\\)"),
    ((np.zeros((0, 3)), np.zeros((0, 3), int)), "the mesh is empty"),
    ((_tetra()[0], np.zeros((0, 3), int)), "the mesh is empty"),
    (_with((1, 2), np.nan), "vertex 1 is not finite"),
    (_with((3, 0), np.inf), "vertex 3 is not finite"),
    (_with((2, 1), 7, faces=True), "refers to vertex 7, out of range"),
    (_with((0, 0), -1, faces=True), "refers to vertex -1, out of range"),
    (_with((0, 0), 0.5, faces=True), "must be integer vertex indices"),
    ((np.array([[0, 0, 0], [1, 1, 1], [2, 2, 2.0]]), np.array([[0, 1, 2]])), "zero area"),
    ((np.zeros((3, 3)), np.array([[0, 1, 2]])), "zero area"),
    (_SQUARE, "too open to tell inside from outside"),
    (([[0, 0, 0], [1, "a", 0], [0, 1, 0]], [[0, 1, 2]]), "array of numbers"),
]


@pytest.mark.parametrize(("mesh", "message"), BAD_INPUTS)
def test_bad_input_is_refused_with_a_clear_message(mesh, message):
    with pytest.raises(MeshInputError, match=message) as info:
        MeshSurface(mesh)
    assert isinstance(info.value, ValueError)


def test_non_finite_query_points_are_refused():
    ms = MeshSurface(_tetra())
    bad = np.array([[0.1, 0.1, 0.1], [np.nan, 0.0, 0.0]])
    for query in (ms.signed_distance, ms.winding_number, ms.grad, ms.closest_points):
        with pytest.raises(ValueError, match="query point 1 is not finite"):
            query(bad)
    with pytest.raises(rdmesh.OracleError, match="not finite"):
        ms(bad)


def test_accepts_a_trimesh_and_is_an_implicit_surface():
    ms = MeshSurface(trimesh.Trimesh(*_tetra(), process=False))
    assert isinstance(ms, rdmesh.ImplicitSurface)
    assert ms.sign_method == "side"
    assert ms.radius > np.linalg.norm(ms.vertices - ms.centre, axis=1).max()
    inside, outside = [[0.25, 0.25, 0.25]], [[0.5, 0.5, 0.5]]
    assert ms(inside).item() < 0 < ms(outside).item()
    assert rdmesh.surfaces.MeshSurface is MeshSurface


# -- command line ---------------------------------------------------------------------


def test_cli_round_trip(tmp_path, capsys):
    v, f = marching_cubes("torus", n=32)
    src = tmp_path / "torus_mc.ply"
    trimesh.Trimesh(v, f, process=False).export(src)
    out = tmp_path / "out" / "torus.stl"
    status = cli.main(
        ["remesh", str(src), "-o", str(out), "--radius", "0.12", "--distance", "0.012", "-q"]
    )
    assert status == 0
    assert "torus_mc.ply: wrote" in capsys.readouterr().out
    mesh = trimesh.load(out, force="mesh")
    assert mesh.is_watertight and mesh.is_winding_consistent
    assert mesh.euler_number == 0
    hole = np.abs(MeshSurface((v, f)).signed_distance(mesh.vertices)).max()
    assert hole <= 1e-6  # STL stores float32


@pytest.mark.parametrize(
    ("write", "message"),
    [
        (None, "no such file"),
        ("folder", "a folder, not a file"),
        (b"garbage", "cannot read"),
        ("ply ascii empty", "the mesh is empty"),
    ],
)
def test_cli_bad_input_is_one_line(tmp_path, capsys, write, message):
    src = tmp_path / "in.ply"
    if write == "folder":
        src.mkdir()
    elif isinstance(write, bytes):
        src.write_bytes(write)
    elif write is not None:
        trimesh.Trimesh(np.zeros((0, 3)), np.zeros((0, 3), int)).export(src)
    status = cli.main(["remesh", str(src), "-o", str(tmp_path / "out.ply")])
    err = capsys.readouterr().err
    assert status == 2
    assert message in err and len(err.strip().splitlines()) == 1


def test_folds_are_counted_and_logged(caplog):
    flat = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0.3, 0.3, 0.001]])
    faces = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    with caplog.at_level("WARNING", logger="rdmesh"):
        ms = MeshSurface((flat, faces))
    assert ms.folds == 3  # the base against each side, at almost 180 degrees
    assert "3 folds" in caplog.text
    assert MeshSurface(marching_cubes("torus", n=24)).folds == 0


@pytest.mark.slow
def test_folds_finer_than_the_bounds_end_incomplete_near_the_folds():
    # Random noise flips marching cubes' slivers into folds (razor-thin wedges). With
    # bounds fine enough to see them, the run must not claim success: it ends with
    # complete=False (or at the vertex budget) and the unresolved points next to folds.
    v, f = marching_cubes("sphere", n=24)
    rng = np.random.default_rng(7)
    v = v + rng.normal(scale=0.1 * mean_edge(v, f), size=v.shape)
    ms = MeshSurface((v, f))
    assert ms.folds > 0
    rb = ms.radius / 40
    budget = False
    try:
        mesh = rdmesh.mesh_surface(
            ms, radius_bound=rb, distance_bound=rb / 10, max_vertices=25_000
        )
    except rdmesh.BudgetExceeded as exc:  # refinement may creep along a fold instead
        mesh, budget = exc.mesh, True
    assert not mesh.complete
    if len(mesh.unresolved) == 0:
        assert budget
        return
    n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    n /= np.linalg.norm(n, axis=1)[:, None]
    edges = np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1)
    _, inv, counts = np.unique(edges, axis=0, return_inverse=True, return_counts=True)
    order = np.argsort(inv.reshape(-1), kind="stable")
    pairs = np.tile(np.arange(len(f)), 3)[order].reshape(-1, 2)
    assert np.all(counts == 2)
    fold = np.einsum("ij,ij->i", n[pairs[:, 0]], n[pairs[:, 1]]) < np.cos(np.radians(150))
    mids = v[np.unique(edges, axis=0)[fold]].mean(axis=1)
    from scipy.spatial import cKDTree

    gap, _ = cKDTree(mids).query(mesh.unresolved)
    assert np.median(gap) <= 4 * rb
