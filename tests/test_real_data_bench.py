"""benchmarks/real_data.py's look-alike inputs and measures (issue 30)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
pytest.importorskip("skimage")

import rdmesh  # noqa: E402
import real_data  # noqa: E402


def test_topology_of_a_tetrahedron_and_an_open_fan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    assert real_data.topology(v, f) == {"components": 1, "euler": [2], "closed": True}
    assert real_data.topology(v, f[:3])["closed"] is False
    assert real_data.min_angle(v, f) == pytest.approx(45.0)


def test_genus2_thin_is_a_closed_genus_2_solid():
    v, f = real_data.genus2_thin(h=0.03)
    assert real_data.topology(v, f) == {"components": 1, "euler": [-2], "closed": True}


def test_folded_is_a_closed_sphere():
    v, f = real_data.folded(h=0.03)
    assert real_data.topology(v, f) == {"components": 1, "euler": [2], "closed": True}


def test_hausdorff_of_a_mesh_with_itself_is_zero_and_grows_with_a_shift():
    v, f = real_data.folded(h=0.05)
    ref = rdmesh.MeshSurface((v, f))
    assert real_data.hausdorff(ref.vertices, ref.faces, ref, n=2000) < 1e-9
    shifted = real_data.hausdorff(ref.vertices + [0.01, 0, 0], ref.faces, ref, n=2000)
    assert 0.005 < shifted <= 0.0100001


def test_specks_volume_has_six_interpolant_components():
    vol = real_data.specks()
    surface = rdmesh.VolumeSurface(vol, isovalue=0.5)
    assert real_data._reference(surface)["components"] == 6
    assert real_data._reference(surface, 3)["components"] == 6


def test_reference_factor_must_be_positive(capsys):
    with pytest.raises(SystemExit):
        real_data.main(["--only", "volume", "--reference-factor", "0"])
    assert "--reference-factor must be at least 1" in capsys.readouterr().err


def test_edge_size_must_be_positive(capsys):
    with pytest.raises(SystemExit):
        real_data.main(["--only", "remesh", "--edge-size", "0"])
    assert "--edge-size must be positive" in capsys.readouterr().err


def test_edge_size_reaches_rdmesh_as_a_fraction_of_the_radius_bound(monkeypatch):
    seen = {}

    def fake(surface, **kw):
        seen.update(kw)
        raise RuntimeError("stop")

    monkeypatch.setattr(rdmesh, "mesh_surface", fake)
    with pytest.raises(RuntimeError, match="stop"):
        real_data.run_rdmesh_remesh(None, 0.02, 0.3)
    assert seen["edge_size"] == pytest.approx(0.006) and seen["radius_bound"] == 0.02


def test_alternating_runs_change_which_goes_first():
    calls = []
    runs = [lambda: calls.append("a") or len(calls), lambda: calls.append("b") or len(calls)]
    out = real_data._alternating(runs, 3)
    assert calls == ["a", "b", "b", "a", "a", "b"]
    assert out == [[1, 4, 5], [2, 3, 6]]
    assert real_data._median_seconds([{"s": 3.0}, {"s": 1.0}, {"s": 2.0}], lambda x: x["s"]) == (
        2.0,
        [3.0, 1.0, 2.0],
    )


class _Ramp:
    """A stand-in volume surface: f = x - 3.5 on an 8^3 grid, so every sample
    of the factor-2 grid at x = 3.5 lies exactly on the isovalue."""

    shape, origin, spacing, isovalue, _sign = (8, 8, 8), np.zeros(3), np.ones(3), 0.0, 1.0

    def values(self, p):
        return p[:, 0] - 3.5


def test_reference_skips_a_factor_with_samples_on_the_isovalue():
    ref = real_data._reference(_Ramp(), 2)
    assert ref["factor"] == 3 and ref["samples_at_isovalue"] == 0
    assert ref["components"] == 1 and ref["euler"] == [2] and ref["closed"]
    # Kept when none lies there.
    assert real_data._reference(_Ramp(), 3)["factor"] == 3
