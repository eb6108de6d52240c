"""benchmarks/levers.py: the speed levers' measurements run and mean what they say."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

BENCH = Path(__file__).resolve().parents[1] / "benchmarks"
RADIUS = "0.08"


def _rows(*args: str) -> list[dict]:
    cmd = [sys.executable, str(BENCH / "levers.py"), *args]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=900, check=False)
    assert done.returncode == 0, done.stderr
    return [json.loads(line) for line in done.stdout.splitlines()]


def test_a_perfect_seed_leaves_nothing_to_refine():
    first, seeded = _rows("seeds", "torus", RADIUS, "--shares", "1")
    assert first["run"] == "first" and seeded["share"] == 1.0
    assert seeded["extra_seeds"] == first["vertices"]
    # Every output vertex seeded: the same mesh, in one round, no facet evaluated twice.
    assert seeded["vertices"] == first["vertices"]
    assert seeded["rounds"] == 1 < first["rounds"]
    assert seeded["facets_evaluated"] < first["facets_evaluated"]
    assert seeded["closed_manifold"] and seeded["min_angle"] >= 30.0


def test_a_finer_seeding_grid_gives_more_seeds():
    coarse, fine = _rows("resolution", "torus", RADIUS, "--resolutions", "32", "64")
    assert fine["seeds"]["seeds"] > coarse["seeds"]["seeds"]
    assert coarse["closed_manifold"] and fine["closed_manifold"]


def test_bad_arguments_get_a_one_line_error():
    cmd = [sys.executable, str(BENCH / "levers.py"), "seeds", "no_such_surface", RADIUS]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2 and "unknown surface 'no_such_surface'" in done.stderr


@pytest.mark.slow
@pytest.mark.skipif(shutil.which("cmake") is None, reason="needs cmake")
def test_the_insertion_replay_builds_the_run_s_triangulation():
    (row,) = _rows("insertion", "torus", RADIUS, "--repeats", "1")
    replay = row["replay"]
    # The replay inserts exactly the run's samples, in the run's batches; it
    # exits with an error when the ways of inserting give different
    # triangulations.
    assert replay["points"] == row["vertices"] == sum(row["batch_sizes"])
    assert replay["batches"] == len(row["batch_sizes"]) == row["rounds"]
    assert replay["cells"] > 4 * replay["points"]
    assert replay["sequential_s"] > 0 and replay["bulk_s"] > 0


def _levers_module():
    import importlib.util

    spec = importlib.util.spec_from_file_location("levers", BENCH / "levers.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_the_band_grid_finds_crossings_on_the_surface_at_its_finest_spacing():
    import numpy as np
    from rdmesh import surfaces

    levers = _levers_module()
    torus = surfaces.SURFACES["torus"].make()
    coarse, _, coarse_step = levers.band_crossings(torus, np.random.default_rng(3), 16, 1.0)
    fine, evaluations, step = levers.band_crossings(torus, np.random.default_rng(3), 16, 0.03)
    # Halved down to the requested cell: 2 R / 16 = 0.25 -> 0.0156.
    assert coarse_step == 2 * torus.radius / 16 and step <= 0.03 < 2 * step
    # Every crossing on the torus, to the root tolerance.
    f = torus(fine)
    assert np.all(np.abs(f) / np.linalg.norm(torus.grad(fine), axis=1) < 1e-8)
    # Grid edges of the three axes cross a surface of area A about
    # A (|n_x| + |n_y| + |n_z|) / step^2 times, 1 to sqrt(3) A / step^2 (the
    # torus's area is 4 pi^2 R r = 15.8): the band missed no part of it.
    for points, s in ((coarse, coarse_step), (fine, step)):
        assert 1.0 < len(points) * s**2 / 15.8 < 3**0.5
    # Only the band was evaluated, far fewer nodes than the full fine grid.
    assert evaluations < 0.2 * (2 * torus.radius / step) ** 3


def test_the_band_lever_refuses_bad_spacings():
    cmd = [sys.executable, str(BENCH / "levers.py"), "band", "torus", RADIUS, "--spacings", "0"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=False)
    assert done.returncode == 2 and "--spacings and --cell must be positive" in done.stderr
