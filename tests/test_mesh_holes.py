"""Open meshes remeshed with their holes kept (MeshSurface(holes="keep"))."""

import numpy as np
import pytest
import rdmesh
import trimesh
from rdmesh.surfaces import _mesh_holes, _mesh_tents
from rdmesh.topology.complex import component_topology


def _open_sphere(cut_z=(0.6,), subdivisions=3):
    """An icosphere without the faces above each plane z = c (or below -c for
    negative c): a sphere with holes."""
    s = trimesh.creation.icosphere(subdivisions=subdivisions)
    z = s.triangles_center[:, 2]
    keep = np.ones(len(s.faces), bool)
    for c in cut_z:
        keep &= z < c if c > 0 else z > c
    return np.asarray(s.vertices), np.asarray(s.faces)[keep]


def _rim_points(v, f):
    half = _mesh_holes.rim_half_edges(f)
    return v[half[:, 0]], v[half[:, 1]]


def _distance_to_segments(p, a, b):
    d = b - a
    t = np.clip(np.einsum("kij,ij->ki", p[:, None] - a[None], d) / np.einsum("ij,ij->i", d, d),
                0, 1)  # fmt: skip
    q = a[None] + t[..., None] * d[None]
    return np.linalg.norm(p[:, None] - q, axis=2).min(axis=1)


def _boundary_vertices(faces):
    half = _mesh_holes.rim_half_edges(faces)
    return np.unique(half[:, :2])


@pytest.mark.parametrize("cuts, loops", [((0.6,), 1), ((0.6, -0.6), 2)])
def test_holes_kept_give_the_inputs_topology(cuts, loops):
    v, f = _open_sphere(cuts)
    surface = rdmesh.MeshSurface((v, f))
    assert surface.holes is not None and len(surface.holes.rims) == loops
    assert len(surface.faces) > surface.input_face_count  # capped while meshing
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.15, distance_bound=0.01)
    assert mesh.complete
    chi, bl = component_topology(mesh.faces, len(mesh.vertices))
    in_chi, in_bl = component_topology(f, len(v))
    assert list(chi) == list(in_chi) == [2 - loops]
    assert list(bl) == list(in_bl) == [loops]
    assert mesh.report["holes"]["rims"] == loops
    assert mesh.report["holes"]["closed_by"] == "caps"
    assert mesh.report["holes"]["mixed_regions"] == 0
    assert f"holes: {loops} kept" in mesh.summary()
    # Nothing of the caps is left: every output vertex lies on the input's
    # faces, and every facet's centroid is nearest to one of them, within the
    # size bound (the triangle lies in a surface Delaunay ball on the input).
    inp = rdmesh.MeshSurface((v, f), holes="fill")
    dv = np.abs(inp.signed_distance(mesh.vertices))
    assert dv.max() < 1e-9
    cent = mesh.vertices[mesh.faces].mean(axis=1)
    closest, face = surface.closest_points(cent)
    assert np.all(face < surface.input_face_count)
    assert np.linalg.norm(cent - closest, axis=1).max() <= 0.15
    # The output's boundary lies on the input's rims.
    a, b = _rim_points(surface.vertices, surface.faces[: surface.input_face_count])
    rim_out = mesh.vertices[_boundary_vertices(mesh.faces)]
    assert _distance_to_segments(rim_out, a, b).max() < 1e-9


def test_holes_fill_closes_them():
    v, f = _open_sphere((0.6,))
    surface = rdmesh.MeshSurface((v, f), holes="fill")
    assert surface.holes is None and len(surface.faces) == surface.input_face_count
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.15, distance_bound=0.01)
    assert mesh.is_closed_manifold()
    assert "holes" not in mesh.report


def test_holes_kept_with_the_winding_numbers_patches(monkeypatch):
    """Where no cap can be made, the winding number closes the holes, and the
    cut tells its patches apart from the faces."""

    def no_cap(points, third=None):
        return np.zeros((0, 3), np.int64)

    monkeypatch.setattr(_mesh_holes.core, "fill_hole", no_cap)
    monkeypatch.setattr(_mesh_holes, "TENT_HEIGHTS", ())
    v, f = _open_sphere((0.6,))
    surface = rdmesh.MeshSurface((v, f))
    assert len(surface.faces) == surface.input_face_count
    assert surface.sign_method == "winding"
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.15, distance_bound=0.01)
    chi, bl = component_topology(mesh.faces, len(mesh.vertices))
    assert list(chi) == [1] and list(bl) == [1]
    assert mesh.report["holes"]["closed_by"] == "winding number"
    assert np.abs(surface.signed_distance(mesh.vertices)).max() < 1e-6


def test_closed_mesh_has_no_holes():
    s = trimesh.creation.icosphere(subdivisions=2)
    surface = rdmesh.MeshSurface(s)
    assert surface.holes is None
    assert len(surface.faces) == surface.input_face_count


def test_cap_is_oriented_against_the_rim():
    v, f = _open_sphere((0.6,))
    holes = _mesh_holes.find_holes(v, f)
    closed = np.concatenate([f, holes.caps])
    e = np.concatenate([closed[:, [0, 1]], closed[:, [1, 2]], closed[:, [2, 0]]])
    # Every directed edge once, and its reverse once: closed and oriented.
    key = e[:, 0] * len(v) + e[:, 1]
    rev = e[:, 1] * len(v) + e[:, 0]
    assert len(np.unique(key)) == len(key)
    assert np.isin(rev, key).all()


def test_bad_holes_choice_and_conflicts():
    v, f = _open_sphere((0.6,))
    with pytest.raises(ValueError, match="holes"):
        rdmesh.MeshSurface((v, f), holes="close")
    with pytest.raises(ValueError, match="features='none'"):
        rdmesh.MeshSurface((v, f), features="none")
    rdmesh.MeshSurface((v, f), features="none", holes="fill")  # allowed
    surface = rdmesh.MeshSurface((v, f))
    with pytest.raises(ValueError, match="holes='fill'"):
        rdmesh.mesh_surface(surface, method="topological-ball", radius_bound=0.2)


def test_fill_hole_binding_refuses_short_rims():
    from rdmesh.core import _rdt

    with pytest.raises(ValueError, match="at least 3"):
        _rdt.fill_hole(np.zeros((2, 3)))
    t = np.linspace(0, 2 * np.pi, 7)[:-1]
    tri = _rdt.fill_hole(np.c_[np.cos(t), np.sin(t), np.zeros(6)])
    assert tri.shape == (4, 3) and set(np.unique(tri)) == set(range(6))


def test_chords_between_balls_stay_near_a_zigzag_polyline():
    """The spacing next to a polyline vertex that turns by t is at most 4 d / t,
    so the chords between consecutive ball centres stay within about d of
    every vertex of the polyline, however short its segments."""
    from rdmesh.features.graph import build_graph, curve_of_polyline
    from rdmesh.features.protect import protect

    x = np.linspace(0.0, 2.0, 41)
    poly = np.c_[x, 0.02 * (np.arange(41) % 2), np.zeros(41)]  # teeth 0.02 high, 50 deg turns
    graph = build_graph([curve_of_polyline(poly, 1.0, "zigzag", "given")], 1.0)
    d = 0.002
    balls = protect(graph, lambda p: np.full(len(p), 0.3), 1.0, distance=d)
    a, b = balls.centres[balls.pairs[:, 0]], balls.centres[balls.pairs[:, 1]]
    far = _distance_to_segments(poly, a, b)
    assert far.max() <= 1.05 * d
    # Without the rule the smooth estimate alone lets the chords skip the teeth.
    assert len(balls.centres) > 2.0 / 0.3 + 1


def test_rims_that_cannot_be_protected_are_filled_instead(monkeypatch):
    from rdmesh.features import FeatureError
    from rdmesh.refine import methods

    def refuse(*args, **kwargs):
        raise FeatureError("no balls here")

    monkeypatch.setattr(methods, "protect", refuse)
    v, f = _open_sphere((0.6,))
    mesh = rdmesh.mesh_surface(rdmesh.MeshSurface((v, f)), radius_bound=0.2)
    holes = mesh.report["holes"]
    assert holes["cut"] is False and holes["filled_again"] and holes["faces_cut"] == 0
    assert holes["closed_by"] == "winding number"
    assert 0 < holes["first_run_seconds"] < mesh.stats["seconds"]  # both runs counted
    assert "could not be kept" in mesh.report["statement"]
    assert mesh.is_closed_manifold() and mesh.complete  # as holes="fill" gives it
    inp = rdmesh.MeshSurface((v, f), holes="fill")
    assert np.abs(inp.signed_distance(mesh.vertices)).max() < 1e-6  # the patch, not caps


def test_cli_remesh_keeps_or_fills_the_holes(tmp_path, capsys):
    from rdmesh import cli

    v, f = _open_sphere((0.6,))
    trimesh.Trimesh(v, f).export(tmp_path / "open.ply")
    for holes, closed in (("keep", False), ("fill", True)):
        out = tmp_path / f"{holes}.ply"
        args = ["remesh", str(tmp_path / "open.ply"), "-o", str(out), "--radius", "0.2"]
        assert cli.main([*args, "--holes", holes, "--quiet"]) == 0
        m = trimesh.load(out)
        assert m.is_watertight == closed
    assert cli.main(["remesh", str(tmp_path / "open.ply"), "-o", str(out), "--holes", "x"]) == 2
    assert "--holes" in capsys.readouterr().err


def test_caps_whose_edges_the_mesh_already_has_are_found():
    """A cap edge that is already an edge of the mesh would be in three faces:
    such caps are dropped (their holes take the winding number's patch)."""
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 1, 3], [1, 2, 4]])
    assert len(_mesh_holes._overfull(f, 2)) == 0
    f = np.array([[0, 1, 2], [0, 2, 3], [0, 2, 4], [0, 1, 3]])  # (0, 2) in three faces
    assert _mesh_holes._overfull(f, 2).tolist() == [0]


def _strip(n=12, width=1.0):
    """A flat strip of 2 n triangles along x: vertices 0..n on y = 0, n+1..2n+1 on y = width."""
    x = np.arange(n + 1, dtype=float)
    zero = np.zeros(n + 1)
    v = np.r_[np.c_[x, zero, zero], np.c_[x, zero + width, zero]]
    f = []
    for i in range(n):
        a, b, c, d = i, i + 1, n + 1 + i, n + 2 + i
        f += [[a, b, d], [a, d, c]]
    return v, np.array(f)


def test_rim_slivers_are_trimmed():
    """A spike (a face whose two rim edges meet at a sliver's angle) is dropped;
    a notch (two rim edges at a sliver's angle with no face) is filled."""
    v, f = _strip()
    spike = np.array(
        [[6.0, -20.0, 0.0]]
    )  # below the strip: a face (5, 6, tip) at ~3 degrees at tip
    v2 = np.r_[v, spike]
    f2 = np.r_[f, [[6, 5, len(v)]]]
    out_v, out_f, dropped, added = _mesh_holes.trim_rims(v2, f2)
    assert dropped == 1 and added == 0
    assert len(out_v) == len(v) and len(out_f) == len(f)  # the tip is gone with its face
    # A notch: a fan about v = 0 leaving a 5.7 degree wedge between p and q open.
    fan_v = np.array(
        [[0, 0, 0], [10, 0.5, 0], [0, 10, 0], [-10, 0, 0], [0, -10, 0], [10, -0.5, 0.0]]
    )
    fan_f = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    out_v, out_f, dropped, added = _mesh_holes.trim_rims(fan_v, fan_f)
    assert dropped == 0 and added == 1
    assert sorted(out_f[-1].tolist()) == [0, 1, 5]
    rim = _mesh_holes.rim_half_edges(out_f)
    assert 0 not in rim[:, :2]  # v is inside now
    loops = _mesh_holes.rim_loops(rim[:, :2])
    assert len(loops) == 1 and len(loops[0]) == 5
    # Nothing to trim on a plain strip.
    assert _mesh_holes.trim_rims(v, f)[2:] == (0, 0)


def test_a_mesh_with_holes_kept_is_sent_to_a_worker_whole():
    """Pickled for a batch worker (its faces with the caps), the surface gives
    the same mesh and report there."""
    import pickle

    from rdmesh.batch.transport import dumps

    v, f = _open_sphere((0.6,))
    here = rdmesh.MeshSurface((v, f))
    there = pickle.loads(dumps(here))
    assert there.input_face_count == here.input_face_count < len(there.faces)
    a = rdmesh.mesh_surface(here, radius_bound=0.2)
    b = rdmesh.mesh_surface(there, radius_bound=0.2)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    assert a.report["holes"] == b.report["holes"]


def test_rim_steps_are_skipped_by_the_rim_curves():
    # A rim with a step a hundredth of its edges: the curve skips the step's
    # vertex, so no two corners lie a step apart.
    v, f = _open_sphere((0.6,), subdivisions=3)
    half = _mesh_holes.rim_half_edges(f)
    a, b = half[0, 0], half[0, 1]
    step = v[a] + 0.01 * (v[b] - v[a])
    v2 = np.vstack([v, step])
    s_id = len(v)
    face = half[0, 3]
    tri = f[face]
    c = tri[(np.flatnonzero(tri == a)[0] + 2) % 3]  # the third vertex
    f2 = np.vstack([np.delete(f, face, axis=0), [[a, s_id, c], [s_id, b, c]]])
    holes = _mesh_holes.find_holes(v2, f2)
    pts = np.concatenate(holes.curves)
    assert not np.any(np.all(np.isclose(pts, step, atol=0.0, rtol=0.0), axis=1))
    # The cap still covers the whole rim, the step's vertex included.
    assert s_id in np.concatenate(holes.rims)
    # ... and the curves stray from the rim by less than the step.
    lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    assert lengths.min() > 0.5 * np.linalg.norm(v[b] - v[a]) * 0.01


@pytest.mark.slow
def test_a_marching_cubes_rim_is_protected_and_its_holes_kept():
    # The thin-handled genus-2 solid of the real-data benchmark with three
    # holes cut: its cut rims have steps and corners at small angles, whose
    # balls used to shrink to the floor (the holes were then filled instead).
    from skimage import measure

    def g(p):
        x, y, z = p.T
        a = np.hypot(np.hypot(x - 1.05, y) - 1.0, z) - 0.12
        b = np.hypot(np.hypot(x + 1.05, y) - 1.0, z) - 0.12
        return np.minimum(a, b)

    h = 0.015
    lo, hi = np.array([-2.3, -1.25, -0.25]), np.array([2.3, 1.25, 0.25])
    n = np.ceil((hi - lo) / h).astype(int) + 1
    axes = [lo[i] + h * np.arange(n[i]) for i in range(3)]
    pts = np.stack(np.meshgrid(*axes, indexing="ij"), -1).reshape(-1, 3)
    v, f, _, _ = measure.marching_cubes(g(pts).reshape(*n), 0.0, spacing=(h, h, h))
    v, f = v + lo, f.astype(np.int64)
    diag = np.linalg.norm(np.ptp(v, axis=0))
    centres = v[f].mean(axis=1)
    keep = np.ones(len(f), bool)
    for i in np.linspace(0, len(v) - 1, 5)[1:-1].astype(int):
        keep &= np.linalg.norm(centres - v[i], axis=1) > 0.03 * diag
    f = f[keep]
    m = rdmesh.mesh_surface(
        rdmesh.MeshSurface((v, f)), radius_bound=0.01 * diag, distance_bound=0.001 * diag
    )
    assert m.report["holes"]["cut"] and not m.report["holes"].get("filled_again")
    assert component_topology(m.faces, len(m.vertices)) == component_topology(f, len(v))


def _sheet(n=30, kind="flat"):
    """A square sheet [-1, 1]^2 on a grid of n x n vertices: flat (z = 0), or wavy
    with its sides tilted opposite ways (z = 0.15 sin 3x cos 2y)."""
    u, w = np.meshgrid(np.linspace(-1, 1, n), np.linspace(-1, 1, n), indexing="ij")
    z = 0 * u if kind == "flat" else 0.15 * np.sin(3 * u) * np.cos(2 * w)
    v = np.c_[u.ravel(), w.ravel(), z.ravel()]
    i = np.arange(n * n).reshape(n, n)
    a, b, c, d = i[:-1, :-1].ravel(), i[1:, :-1].ravel(), i[1:, 1:].ravel(), i[:-1, 1:].ravel()
    return v, np.r_[np.c_[a, b, c], np.c_[a, c, d]]


def _closed_and_oriented(faces, n):
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    key, rev = e[:, 0] * n + e[:, 1], e[:, 1] * n + e[:, 0]
    return len(np.unique(key)) == len(key) and np.array_equal(np.sort(key), np.sort(rev))


def test_a_tent_closes_a_rim_square_to_its_faces():
    v, f = _sheet(12)
    holes = _mesh_holes.find_holes(v, f)
    loop, third = holes.rims[0], holes.thirds[0]
    new, tri = _mesh_tents.tent(v, loop, third, len(v), -0.5)
    k = len(loop)
    assert len(new) == (_mesh_tents.TENT_RINGS - 1) * k + 1
    assert _closed_and_oriented(np.concatenate([f, tri]), len(v) + len(new))
    # A dome behind the flat sheet, half a rim radius tall at its top ...
    _, _, _, radius = _mesh_tents.rim_frame(v, loop)
    assert np.all(new[:, 2] < 0) and abs(new[-1, 2] + 0.5 * radius) < 1e-9 * radius
    assert np.allclose(new[-1, :2], 0, atol=1e-9)
    # ... that leaves the rim square to the sheet: its first ring mostly rises.
    step = new[:k] - v[loop]
    assert np.median(np.abs(step[:, 2]) / np.linalg.norm(step[:, :2], axis=1)) > 3


def _holed_sheet(n=40, kind="flat"):
    """:func:`_sheet` without the faces in the middle ninth: a sheet with an inner hole."""
    v, f = _sheet(n, kind)
    c = v[f].mean(axis=1)
    return v, f[(np.abs(c[:, 0]) > 1 / 3) | (np.abs(c[:, 1]) > 1 / 3)]


def test_a_tent_over_an_inner_rim_stands_on_the_side_asked():
    """An inner hole's rim runs against its faces' normals: its tent still goes
    behind the faces for a negative height."""
    v, f = _holed_sheet(13)
    holes = _mesh_holes.find_holes(v, f)
    assert len(holes.rims) == 2
    for loop, third in zip(holes.rims, holes.thirds, strict=True):
        assert _mesh_tents.faces_along_normal(v, loop, third)
        new, _ = _mesh_tents.tent(v, loop, third, len(v), -0.5)
        assert np.all(new[:, 2] < 0)


@pytest.mark.parametrize("kind", ["flat", "wavy"])
def test_an_open_sheet_is_remeshed_with_its_boundary(kind):
    """A sheet's flat cap lies on it: it is closed by a tent instead, and the
    remesh is a disk on the sheet whose boundary follows the sheet's."""
    v, f = _sheet(40, kind)
    surface = rdmesh.MeshSurface((v, f))
    assert len(surface.holes.apexes) and surface.sign_method == "side"
    assert np.abs(surface.holes.apexes[:, 2]).max() > 0.3  # it stands off the sheet
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.1, distance_bound=0.01)
    assert mesh.complete
    chi, bl = component_topology(mesh.faces, len(mesh.vertices))
    assert list(chi) == [1] and list(bl) == [1]
    assert mesh.report["holes"]["closed_by"] == "tents"
    closest, face = surface.closest_points(mesh.vertices)
    assert np.linalg.norm(closest - mesh.vertices, axis=1).max() < 1e-9
    on_sheet = face < surface.input_face_count
    rim = np.zeros(len(mesh.vertices), bool)
    rim[_boundary_vertices(mesh.faces)] = True
    assert np.all(on_sheet | rim)  # none on the tent (the rim is on both)
    a, b = _rim_points(v, f)
    rim_out = mesh.vertices[_boundary_vertices(mesh.faces)]
    assert _distance_to_segments(rim_out, a, b).max() < 1e-9
    # The rim is covered: its corners are output vertices.
    corners = np.array([[x, y] for x in (-1, 1) for y in (-1, 1)])
    gap = np.linalg.norm(rim_out[:, None, :2] - corners[None], axis=2).min(axis=0)
    assert gap.max() < 1e-9
    assert mesh.angles.min() >= 20.0


def test_of_two_caps_that_cross_the_smaller_rims_is_dropped():
    holes = _mesh_holes.Holes(
        [np.arange(3), np.arange(3, 6)], [], np.zeros((4, 3), np.int64), np.array([0, 0, 1, 1])
    )
    size = np.array([1.0, 5.0])
    # Cap triangles 1 (rim 0) and 2 (rim 1) cross; cap 3 (rim 1) crosses input face -4.
    assert _mesh_holes._crossing_rims(holes, np.array([[1, 2]]), size).tolist() == [0]
    assert _mesh_holes._crossing_rims(holes, np.array([[-4, 3]]), size).tolist() == [1]
    assert _mesh_holes._crossing_rims(holes, np.array([[-4, -2]]), size).tolist() == []


def test_a_tent_is_meshed_coarsely_away_from_the_rim(monkeypatch):
    """The remesh of a tent is cut off, so its facets may grow with their distance
    from the input: far fewer facets are cut than with the input's bounds, and
    the part kept is a disk of about as many vertices."""
    monkeypatch.setenv("RDMESH_CHECK", "0")  # its per-round checks would take minutes here
    v, f = _sheet(40, "wavy")

    def run():
        mesh = rdmesh.mesh_surface(
            rdmesh.MeshSurface((v, f)), radius_bound=0.02, distance_bound=0.002
        )
        return mesh, mesh.report["holes"]["faces_cut"]

    coarse, cut = run()
    monkeypatch.setattr(_mesh_tents, "TENT_GRADE", 0.0)
    monkeypatch.setattr(_mesh_tents, "TENT_DISTANCE_GRADE", 0.0)
    fine, cut_fine = run()
    assert cut < 0.6 * cut_fine
    assert abs(len(coarse.vertices) - len(fine.vertices)) <= 0.05 * len(fine.vertices)
    for mesh in (coarse, fine):
        chi, bl = component_topology(mesh.faces, len(mesh.vertices))
        assert list(chi) == [1] and list(bl) == [1] and mesh.complete


def test_a_sheet_with_an_inner_hole_keeps_both_rims():
    v, f = _holed_sheet(40, "wavy")
    mesh = rdmesh.mesh_surface(rdmesh.MeshSurface((v, f)), radius_bound=0.1, distance_bound=0.01)
    chi, bl = component_topology(mesh.faces, len(mesh.vertices))
    assert list(chi) == [0] and list(bl) == [2] and mesh.complete
    a, b = _rim_points(v, f)
    rim_out = mesh.vertices[_boundary_vertices(mesh.faces)]
    assert _distance_to_segments(rim_out, a, b).max() < 1e-9


def test_filling_again_drops_the_tents_vertices(monkeypatch):
    """Meshed again with its holes filled, a surface closed by a tent keeps only
    its input's vertices (the tent's would widen its bounding sphere)."""
    from rdmesh.surfaces.mesh import filled

    monkeypatch.setattr(
        _mesh_holes.core, "fill_hole", lambda points, third=None: np.zeros((0, 3), np.int64)
    )
    v, f = _open_sphere((0.6,))
    surface = rdmesh.MeshSurface((v, f))
    assert len(surface.holes.apexes) and len(surface.vertices) > surface.holes.base
    again = filled(surface)
    assert again.holes is None and len(again.vertices) == surface.holes.base
    assert again.radius <= surface.radius


def _bowtie(n=30):
    """Two wavy unit squares sharing one corner: the rims touch at a point."""
    v, f = _sheet(n, "wavy")
    v = (v + 1) / 2  # [0, 1]^2
    w = v * [-1, -1, 1] + [2, 2, 0]  # turned half a turn about (1, 1): one corner shared
    return np.r_[v, w], np.r_[f, f + len(v)]


def test_a_pinched_rim_vertex_loses_its_smaller_fan():
    v, f = _bowtie(6)
    v, f = rdmesh.surfaces._mesh_input.clean(v, f)  # the pinch is split in two copies
    assert len(np.unique(v, axis=0)) == len(v) - 1
    v2, f2, dropped = _mesh_holes.drop_pinch_fans(v, f)
    assert dropped == 2  # both squares' corners there have two faces: one copy keeps them
    assert len(np.unique(v2, axis=0)) == len(v2) == len(v) - 1
    assert len(f2) == len(f) - 2
    # Nothing to drop without a pinch.
    v3, f3, none = _mesh_holes.drop_pinch_fans(*_sheet(6))
    assert none == 0 and len(f3) == len(_sheet(6)[1])


def test_two_sheets_touching_at_a_corner_are_meshed_apart():
    """Refused before (too open): the pinch's smaller fan is dropped, and each
    sheet is closed by a tent (each one's cap lies on it)."""
    v, f = _bowtie(30)
    surface = rdmesh.MeshSurface((v, f))
    assert surface.sign_method == "side"
    mesh = rdmesh.mesh_surface(surface, radius_bound=0.04, distance_bound=0.004)
    assert mesh.report["holes"]["closed_by"] == "tents" and mesh.complete
    assert mesh.report["holes"]["slivers_trimmed"]["faces_dropped"] == 2
    chi, bl = component_topology(mesh.faces, len(mesh.vertices))
    assert sorted(chi) == [1, 1] and list(bl) == [1, 1]
    closest, face = surface.closest_points(mesh.vertices)
    assert np.linalg.norm(closest - mesh.vertices, axis=1).max() < 1e-9
    rim = np.zeros(len(mesh.vertices), bool)
    rim[_boundary_vertices(mesh.faces)] = True
    assert np.all((face < surface.input_face_count) | rim)  # none on the tents
    assert mesh.angles.min() >= 20.0
