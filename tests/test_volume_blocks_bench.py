"""benchmarks/volume_blocks.py's volume and measures (issue 29, part 2)."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
pytest.importorskip("skimage")

import volume_blocks  # noqa: E402


def test_the_volume_is_two_linked_tori_and_a_ball_inside_the_box():
    vol = volume_blocks.volume(49)
    assert vol.dtype == np.float32 and vol.shape == (49, 49, 49)
    # Nothing reaches the box (border="closed" works), and the block planes cut the shapes.
    faces = [vol[0], vol[-1], vol[:, 0], vol[:, -1], vol[:, :, 0], vol[:, :, -1]]
    assert all(f.max() < 0 for f in faces)
    assert (vol[24] > 0).any() and (vol[:, 24] > 0).any() and (vol[:, :, 24] > 0).any()


def test_marching_cubes_in_blocks_is_open_concatenated_and_closed_welded():
    res = volume_blocks.marching_cubes_blocks(volume_blocks.volume(49), 24)
    cat, welded = res["concatenated"], res["welded"]
    assert cat["open_edges"] > 0 and cat["components"] > 3
    assert welded["open_edges"] == 0 and welded["nonmanifold_edges"] == 0
    assert welded["components"] == 3 and welded["euler"] == [0, 0, 2]
    assert welded["faces"] == cat["faces"] and welded["vertices"] < cat["vertices"]


def test_mesh_figures_of_a_tetrahedron_and_an_open_fan():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    closed = volume_blocks.mesh_figures(v, f)
    assert closed["open_edges"] == 0 and closed["euler"] == [2] and closed["min_angle"] == 45.0
    fan = volume_blocks.mesh_figures(v, f[:3])
    assert fan["open_edges"] == 3 and fan["boundary_loops"] == 1
