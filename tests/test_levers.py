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
