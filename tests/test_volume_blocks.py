"""rdmesh.mesh_volume_blocks on a 2-process Dask LocalCluster: seams, topology, determinism.

Volumes are 41^3 (2 x 2 x 2 blocks of 20 cells unless said); the shapes
cross the block faces, and their topology is known beforehand.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import rdmesh
from rdmesh.blocks.field import Field, Params, raw_range
from rdmesh.blocks.layout import Layout, others
from rdmesh.blocks.trace import trace_face

distributed = pytest.importorskip("distributed")
from dask_cluster import local_cluster  # noqa: E402

dask = pytest.importorskip("dask")
da = pytest.importorskip("dask.array")

N = 41
GRID = np.mgrid[0:N, 0:N, 0:N].astype(np.float64)


def torus_and_ball() -> np.ndarray:
    """A torus (chi 0) and a separate ball (chi 2), both cut by the planes at 20."""
    p = GRID - np.array([20.3, 19.6, 20.4])[:, None, None, None]
    torus = 3.5 - np.sqrt((np.hypot(p[0], p[1]) - 12.0) ** 2 + p[2] ** 2)
    q = GRID - np.array([21.0, 20.5, 19.2])[:, None, None, None]
    ball = 5.0 - np.sqrt((q**2).sum(0))
    return np.maximum(torus, ball)


def cylinder() -> np.ndarray:
    """A cylinder of radius 9 along the third axis, through the whole box."""
    return 9.0 - np.hypot(GRID[0] - 20.3, GRID[1] - 19.8)


def digest(mesh: rdmesh.SurfaceMesh) -> str:
    h = hashlib.sha256()
    h.update(np.ascontiguousarray(mesh.vertices).tobytes())
    h.update(np.ascontiguousarray(mesh.faces, dtype=np.int64).tobytes())
    return h.hexdigest()


OPTIONS = {"isovalue": 0.0, "radius_bound": 2.0, "distance_bound": 0.2}


@pytest.fixture(scope="module")
def client():
    """A LocalCluster of 2 worker processes, 1 thread each."""
    cluster = local_cluster()
    with cluster, distributed.Client(cluster) as c:
        yield c


@pytest.fixture(scope="module")
def blocks_mesh(client):
    return rdmesh.mesh_volume_blocks(torus_and_ball(), 20, client=client, **OPTIONS)


# -- the whole ------------------------------------------------------------------------


def test_welded_mesh_is_closed_with_the_whole_volume_topology(blocks_mesh):
    whole = rdmesh.mesh_surface(
        rdmesh.VolumeSurface(torus_and_ball(), isovalue=0.0), radius_bound=2.0, distance_bound=0.2
    )
    m = blocks_mesh
    assert m.complete, m.stats.get("stop_reason")
    assert m.is_closed_manifold()
    assert sorted(m.topology()["euler"]) == sorted(whole.topology()["euler"]) == [0, 2]
    # The two meshes approximate one surface within the distance bound: the
    # vertices of each (on the surface) lie near it from the other's triangles
    # (1.5 times: the bound is met at the Delaunay balls' centres, not at every
    # point; here both ways reach 0.23), the triangles' centroids within twice that.
    bound = 1.5 * OPTIONS["distance_bound"]
    for a, b in ((m, whole), (whole, m)):
        assert _distance(a.vertices, b) <= bound
        assert _distance(a.vertices[a.faces].mean(axis=1), b) <= 2.0 * bound
    assert m.report["components"] == 2 and m.report["closed_manifold"]
    # What mesh_surface reports, for the whole.
    assert set(whole.report) <= set(m.report)
    assert m.report["complete"] and m.report["seeding"]["blocks"] == {"sampled": 8}
    assert m.report["probes"]["count"] > 0
    assert m.report["blocks_layout"]["counts"] == [2, 2, 2]
    seams = m.report["seams"]
    assert seams["held"] and seams["open_edges"] == 0 and seams["nonmanifold_edges"] == 0
    assert seams["curves"] > 0 and seams["corners"] > 0
    # The angle bound away from the seams; Mesh_3's 20-degree floor at them.
    assert seams["min_angle_elsewhere"] >= 30.0 - 1e-9
    assert seams["min_angle_at_seams"] >= 20.0 - 1e-9


def _distance(points: np.ndarray, mesh: rdmesh.SurfaceMesh) -> float:
    """Largest distance from the points to the mesh's triangles."""
    from benchmarks.metrics import surface_to_mesh

    return float(surface_to_mesh(points, mesh.vertices, mesh.faces).max())


def test_seams_match_exactly(blocks_mesh):
    m = blocks_mesh
    assert m.features is not None and m.features.held
    on_curves = np.unique(np.concatenate(m.features.curves + [m.features.corners]))
    assert on_curves.min() >= 0  # every seam ball centre is a vertex of the whole
    # The vertices on the inner planes (coordinate 20 exactly) are exactly the
    # seam ball centres: the blocks added no vertex of their own there.
    on_plane = np.flatnonzero((m.vertices == 20.0).any(axis=1))
    assert set(on_plane.tolist()) == set(on_curves.tolist())
    # A centre on k inner planes was in 2^k blocks: the weld merged exactly
    # those copies and nothing else.
    k = (m.vertices[on_plane] == 20.0).sum(axis=1)
    assert m.stats["duplicates_merged"] == int(np.sum(2**k - 1))
    # No boundary edge is left.
    e = np.sort(np.concatenate([m.faces[:, [0, 1]], m.faces[:, [1, 2]], m.faces[:, [2, 0]]]), 1)
    _, counts = np.unique(e, axis=0, return_counts=True)
    assert (counts == 2).all()


def test_same_output_for_one_and_two_workers(blocks_mesh):
    one = rdmesh.mesh_volume_blocks(torus_and_ball(), 20, workers=1, **OPTIONS)
    assert digest(one) == digest(blocks_mesh)


class _ArrayLike:
    """What dask.array.from_array takes: a shape, a dtype and slicing (as zarr, h5py)."""

    def __init__(self, a: np.ndarray) -> None:
        self._a, self.shape, self.dtype, self.ndim = a, a.shape, a.dtype, a.ndim

    def __getitem__(self, key):
        return self._a[key]


def test_dask_arrays_and_array_likes_give_the_same_mesh(client, blocks_mesh):
    lazy = da.from_array(torus_and_ball(), chunks=(13, 41, 20))
    a = rdmesh.mesh_volume_blocks(lazy, 20, client=client, **OPTIONS)
    b = rdmesh.mesh_volume_blocks(_ArrayLike(torus_and_ball()), 20, client=client, **OPTIONS)
    assert digest(a) == digest(b) == digest(blocks_mesh)


def test_spacing_origin_and_inside_less(client):
    spacing, origin = (0.5, 1.0, 0.75), (1.0, -2.0, 3.0)
    m = rdmesh.mesh_volume_blocks(
        -torus_and_ball(), 20, client=client, isovalue=0.0, inside="less", spacing=spacing,
        origin=origin, radius_bound=1.5, distance_bound=0.15,
    )  # fmt: skip
    assert m.complete and m.is_closed_manifold(), m.stats.get("stop_reason")
    assert sorted(m.topology()["euler"]) == [0, 2]
    # The seams lie on the physical planes of sample 20.
    planes = np.asarray(origin) + 20.0 * np.asarray(spacing)
    on = m.vertices == planes
    assert on.any(axis=0).all()
    assert m.stats["duplicates_merged"] == int(np.sum(2 ** on[on.any(axis=1)].sum(axis=1) - 1))


def test_a_volume_in_one_block_has_no_seams(client):
    ball = 6.0 - np.sqrt(((GRID[:, :21, :21, :21] - 10.2) ** 2).sum(0))
    m = rdmesh.mesh_volume_blocks(ball, 256, client=client, **OPTIONS)
    assert m.report["blocks_layout"]["counts"] == [1, 1, 1]
    assert m.complete and m.is_closed_manifold() and m.topology()["euler"] == [2]
    assert m.report["seams"]["curves"] == 0 and m.stats["duplicates_merged"] == 0


def test_small_seam_balls_are_reported_as_holding_the_angle_bound(client, blocks_mesh):
    """The welded mesh says what its blocks' runs did: with edge_size at most
    0.3 times the radius bound the angle bound was held next to the seams'
    balls, with the default spacing relaxed as in Mesh_3."""
    m = rdmesh.mesh_volume_blocks(torus_and_ball(), 20, client=client, edge_size=0.6, **OPTIONS)
    assert m.report["seams"]["curves"] > 0 and m.features.angle_held
    assert not blocks_mesh.features.angle_held


def test_zarr_and_hdf5_volumes_are_read_by_the_tasks(client, blocks_mesh, tmp_path):
    zarr = pytest.importorskip("zarr")
    h5py = pytest.importorskip("h5py")
    vol = torus_and_ball()
    z = zarr.open_array(str(tmp_path / "v.zarr"), mode="w", shape=vol.shape, dtype=vol.dtype,
                        chunks=(20, 20, 20))  # fmt: skip
    z[:] = vol
    with h5py.File(tmp_path / "v.h5", "w") as fh:
        fh["volume"] = vol
    a = rdmesh.mesh_volume_blocks(zarr.open_array(str(tmp_path / "v.zarr"), mode="r"), 20,
                                  client=client, **OPTIONS)  # fmt: skip
    with h5py.File(tmp_path / "v.h5", "r") as fh:  # h5py's datasets do not pickle
        b = rdmesh.mesh_volume_blocks(fh["volume"], 20, client=client, **OPTIONS)
    assert digest(a) == digest(b) == digest(blocks_mesh)


def test_clipped_border_has_its_boundary_on_the_box_only(client):
    surface = rdmesh.VolumeSurface(cylinder(), border="clipped", isovalue=0.0)
    whole = rdmesh.mesh_surface(surface, radius_bound=2.0, distance_bound=0.2)
    m = rdmesh.mesh_volume_blocks(cylinder(), 20, client=client, border="clipped", **OPTIONS)
    assert m.complete and m.is_manifold_with_boundary()
    assert m.topology()["euler"] == whole.topology()["euler"] == [0]
    assert m.topology()["boundary_loops"] == whole.topology()["boundary_loops"] == [2]
    seams = m.report["seams"]
    assert seams["open_edges"] == 0 and seams["boundary_edges_on_box"] > 0
    assert m.features.held
    boundary = np.unique(m.features.curves[0])
    assert np.isin(m.vertices[boundary][:, 2], (0.0, 40.0)).all()


def test_closed_border_refuses_a_surface_that_reaches_the_box(client):
    with pytest.raises(ValueError, match="border='clipped'"):
        rdmesh.mesh_volume_blocks(cylinder(), 20, client=client, **OPTIONS)


def _touching_ball() -> np.ndarray:
    """A ball that crosses the plane x = 20 by 0.001 only: a loop of radius 0.13."""
    return 8.0 - np.sqrt(
        ((GRID - np.array([12.001, 19.7, 20.6])[:, None, None, None]) ** 2).sum(0)
    )


def _integer_ball() -> np.ndarray:
    """Integer samples whose isovalue 3 is met exactly at samples on the block planes."""
    return np.round(10.0 - np.sqrt(((GRID - 20.0) ** 2).sum(0))).astype(np.int32)


def test_almost_tangent_block_face_closes_up(client):
    m = rdmesh.mesh_volume_blocks(_touching_ball(), 20, client=client, **OPTIONS)
    assert m.complete and m.is_closed_manifold(), m.stats.get("stop_reason")
    assert m.topology()["euler"] == [2]


@pytest.mark.slow
def test_isovalue_at_samples_on_the_block_planes_closes_up(client):
    m = rdmesh.mesh_volume_blocks(
        _integer_ball(), 20, client=client, **{**OPTIONS, "isovalue": 3, "interpolation": "linear"}
    )
    assert m.complete and m.is_closed_manifold(), m.stats.get("stop_reason")
    assert m.topology()["euler"] == [2]


def test_blocks_stopped_by_a_budget_make_the_whole_incomplete(client):
    m = rdmesh.mesh_volume_blocks(torus_and_ball(), 20, client=client, max_vertices=40, **OPTIONS)
    assert not m.complete
    assert "blocks incomplete" in m.stats["stop_reason"]
    stopped = [b for b in m.report["blocks"] if not b["complete"]]
    assert stopped and all("max_vertices" in b["stop_reason"] for b in stopped)
    # A stopped block's thin triangles are not repaired (its run ended early).
    assert m.report["seams"]["repairs"] == 0


def test_seam_check_finds_holes_and_says_where(blocks_mesh):
    from rdmesh.blocks.weld import seam_check

    m = blocks_mesh
    lay = Layout.of((N, N, N), 20, (1, 1, 1), (0, 0, 0))
    net = _network_of(m)
    # Drop one triangle with a vertex on the seam plane x = 20: three holes' edges.
    hit = np.flatnonzero((m.vertices[m.faces][:, :, 0] == 20.0).any(axis=1))[0]
    cut = rdmesh.SurfaceMesh(m.vertices, np.delete(m.faces, hit, axis=0), m.facet_centres)
    seams = seam_check(cut, net, lay)
    assert seams["open_edges"] == 3 and not seams["held"]
    where = np.array(seams["open_where"])
    tri = m.vertices[m.faces[hit]]
    assert np.allclose(np.sort(where, axis=0), np.sort(0.5 * (tri + np.roll(tri, 1, 0)), axis=0))
    assert seam_check(m, net, lay)["held"]


def _network_of(m):
    """A stand-in for the run's network: no balls (only the edge checks run)."""
    from rdmesh.blocks.network import Network, _no_balls
    from rdmesh.features import FeatureGraph

    return Network(FeatureGraph(), _no_balls(), [], np.zeros(0, np.int64))


# -- bad input ------------------------------------------------------------------------


@pytest.mark.parametrize(
    "volume, block, options, match",
    [
        (np.zeros((5, 5)), 20, {}, "3-D"),
        (np.zeros((8, 8, 8), complex), 20, {}, "real numbers"),
        (np.zeros((3, 8, 8)), 20, {}, "at least 4 samples"),
        (torus_and_ball(), 4, {}, "block must be"),
        (torus_and_ball(), 20.5, {}, "block must be"),
        (torus_and_ball(), 20, {"radius": 1.0}, "unknown option 'radius'"),
        (torus_and_ball(), 20, {"features": []}, "features= is not available"),
        (torus_and_ball(), 20, {"method": "topological-ball"}, "boissonnat-oudot"),
        (torus_and_ball(), 20, {"certify": True}, "certify"),
        (torus_and_ball(), 20, {"border": "clipped", "topology": "manifold"}, "does not match"),
        (torus_and_ball(), 20, {"spacing": (1, -1, 1)}, "spacing must be"),
        (torus_and_ball(), 20, {"inside": "up"}, "unknown inside"),
        (torus_and_ball(), 20, {"isovalue": "low"}, "isovalue must be a number"),
        (torus_and_ball(), 20, {"angle_bound": 40}, "angle_bound"),
    ],
)
def test_bad_input_is_refused_before_anything_runs(volume, block, options, match):
    with pytest.raises(ValueError, match=match):
        rdmesh.mesh_volume_blocks(volume, block, **options)


def test_client_and_workers_together_are_refused(client):
    with pytest.raises(ValueError, match="workers"):
        rdmesh.mesh_volume_blocks(torus_and_ball(), 20, client=client, workers=2)


def test_an_address_instead_of_a_client_is_refused():
    with pytest.raises(TypeError, match=r"Client\('tcp://host:8786'\)"):
        rdmesh.mesh_volume_blocks(torus_and_ball(), 20, client="tcp://127.0.0.1:8786")


@pytest.mark.parametrize(
    "volume, options, error, match",
    [
        (np.where(GRID[0] == 30, np.nan, torus_and_ball()), {}, ValueError, "finite"),
        (np.ones((N, N, N)), {}, rdmesh.EmptySurfaceError, "constant"),
        (torus_and_ball(), {"isovalue": 1e6}, rdmesh.EmptySurfaceError, "outside the range"),
    ],
)
def test_bad_data_is_refused(client, volume, options, error, match):
    with pytest.raises(error, match=match):
        rdmesh.mesh_volume_blocks(volume, 20, client=client, **options)


# -- the pieces -----------------------------------------------------------------------


def test_layout_blocks_cover_the_volume_within_the_block_size():
    lay = Layout.of((41, 100, 9), 16, (1, 1, 1), (0, 0, 0))
    for planes, n in zip(lay.planes, (41, 100, 9), strict=True):
        assert planes[0] == 0 and planes[-1] == n - 1
        assert max(np.diff(planes)) <= 16 and min(np.diff(planes)) >= 8
    # Every face of every block is traced by exactly one block.
    owned = lay.all_faces()
    assert len(owned) == len(set(owned))
    assert set(owned) == {f for b in lay.blocks() for f in lay.faces_of(b)}


def _field(volume, lo, hi, params) -> Field:
    a, b = raw_range(np.asarray(lo), np.asarray(hi), params.degree)
    pads = [(max(0, -int(a[k])), max(0, int(b[k]) - (volume.shape[k] - 1))) for k in range(3)]
    sl = tuple(slice(max(0, int(a[k])), min(int(b[k]), volume.shape[k] - 1) + 1) for k in range(3))
    raw = np.pad(volume[sl], pads, mode="reflect")
    return Field(raw, a, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), params)


def test_every_window_evaluates_the_same_bits():
    vol = torus_and_ball()
    params = Params(0.0, 1.0, 1.0, 3)
    small = _field(vol, (18, 18, 18), (22, 22, 22), params)
    large = _field(vol, (0, 3, 10), (40, 25, 30), params)
    rng = np.random.default_rng(1)
    x = rng.uniform(18.0, 22.0, size=(500, 3))
    assert np.array_equal(small.f(x), large.f(x))
    assert np.array_equal(small.gradient(x), large.gradient(x))
    # Near VolumeSurface's interpolant (its prefilter is not truncated).
    ref = rdmesh.VolumeSurface(vol, isovalue=0.0)
    values = ref.values(x)
    assert np.abs((0.0 - values) - large.f(x)).max() <= 1e-6 * np.ptp(vol)


def test_faces_around_a_block_edge_end_their_curves_at_the_same_corners():
    vol = torus_and_ball()
    lay = Layout.of(vol.shape, 20, (1, 1, 1), (0, 0, 0))
    params = Params(0.0, 1.0, 1.0, 3)
    ends = []
    for face in lay.all_faces():
        a, p, (b0, b1), (c0, c1) = lay.rect(face)
        b, c = others(a)
        lo, hi = np.zeros(3, int), np.zeros(3, int)
        lo[a] = hi[a] = p
        lo[b], hi[b], lo[c], hi[c] = b0, b1, c0, c1
        tr = trace_face(_field(vol, lo, hi, params), lay, face, 0.5, 40.0)
        ends += [c[[0, -1]] for c, closed in zip(tr.curves, tr.closed, strict=True) if not closed]
    pts, counts = np.unique(np.concatenate(ends), axis=0, return_counts=True)
    inner = ((pts == 20.0).sum(axis=1) == 2) & ~np.isin(pts, (0.0, 40.0)).any(axis=1)
    assert inner.any()
    # Four faces meet at an inner block edge: each corner ends four curves.
    assert (counts[inner] == 4).all()


def test_a_lazy_volume_is_read_by_the_tasks_window_by_window():
    from rdmesh.blocks.source import Source

    lazy = da.from_array(torus_and_ball(), chunks=(13, 41, 20))
    src = Source(lazy, "cubic")
    piece = src.piece(np.array([20, 0, 0]), np.array([40, 20, 20]), 3)
    # The task gets a graph that reads its window, not the samples: nothing is
    # computed in the caller, and the window is the block and its halo only.
    assert hasattr(piece.data, "dask") and not isinstance(piece.data, np.ndarray)
    assert piece.data.shape == (37, 37, 37)  # samples 4 to 40, 0 to 36, 0 to 36
    assert piece.pads == [(0, 16), (16, 0), (16, 0)]  # mirrored past the volume's ends
    raw = piece.read()
    assert raw.shape == (53, 53, 53)
    assert np.array_equal(raw[:37, 16:, 16:], torus_and_ball()[4:41, 0:37, 0:37])
    assert np.array_equal(raw[37:, 16:, 16:], torus_and_ball()[39:23:-1, 0:37, 0:37])
