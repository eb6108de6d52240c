"""The C++ core rdmesh.core._rdt under threads, faults and extreme inputs."""

from __future__ import annotations

import ast
import math
import os
import subprocess
import textwrap
import threading
from fractions import Fraction
from pathlib import Path

import numpy as np
import pytest
import rdmesh
from child import run_python
from rdmesh.core import _rdt

try:  # not in the test extras (yet): only the property-based test needs it
    from hypothesis import HealthCheck, assume, given, settings
    from hypothesis import strategies as st
except ImportError:  # pragma: no cover
    given = None

FLAG = np.uint8(_rdt.RESTRICTED | _rdt.OUTWARD)


def _sphere(rng, n):
    p = rng.normal(size=(n, 3))
    return p / np.linalg.norm(p, axis=1)[:, None]


def _as_set(tri):
    return {tuple(t) for t in np.sort(tri, axis=1).tolist()}


# -- one core, two threads ----------------------------------------------------------

# Runs in a child process, so a crash shows as a negative return code instead of
# taking pytest down.  A writer drives refinement-like rounds (insert a batch on
# the unit sphere, then changed_facets chunks each answered by update_facets)
# while a reader calls the read-only methods, and changed_facets too, which
# steals chunks: the writer's update then no longer matches the oldest chunk,
# which must be a clean ValueError, after which it restarts the round.  At the
# end one thread finishes the round; the core must still be consistent and
# must have reported every facet exactly as a from-scratch pass lists them.
HAMMER = textwrap.dedent(
    """
    import sys
    import threading

    import numpy as np
    from rdmesh.core import _rdt

    FLAG = np.uint8(_rdt.RESTRICTED | _rdt.OUTWARD)

    def sphere(rng, n):
        p = rng.normal(size=(n, 3))
        return p / np.linalg.norm(p, axis=1)[:, None]

    def drain(rdt, chunk):
        while True:
            tri, seg, *_ = rdt.changed_facets(chunk)
            if len(tri) == 0:
                return
            rdt.update_facets(np.full(len(tri), FLAG), seg[:, 0])

    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(sphere(np.random.default_rng(0), 100))
    done = threading.Event()
    failures = []
    stolen = [0]

    def writer():
        rng = np.random.default_rng(1)
        try:
            for _ in range(ROUNDS):
                rdt.insert(sphere(rng, 150))
                for _ in range(20):
                    try:
                        drain(rdt, 200)
                        break
                    except ValueError as e:  # the reader took a chunk
                        if "oldest chunk" not in str(e):
                            raise
                        stolen[0] += 1
                        rdt.restart_round()
        except BaseException as e:
            failures.append(e)
        finally:
            done.set()

    def reader():
        rng = np.random.default_rng(2)
        try:
            for i in range(100000):
                if done.is_set():
                    break
                tri, centre, flags = rdt.facets(0)
                assert tri.shape == centre.shape and len(flags) == len(tri)
                n = rdt.number_of_samples
                x = rdt.samples()
                assert len(x) >= n and np.isfinite(x).all()
                if n > 2:
                    ids = rng.integers(0, n, 3)
                    edges = rdt.delaunay_edges(ids)
                    try:
                        rdt.voronoi_facets(edges[:5])
                    except ValueError as e:  # an insert came in between
                        if "not a Delaunay edge" not in str(e):
                            raise
                    rdt.neighbours(ids)
                    rdt.is_facet(np.sort(ids)[None])
                rdt.number_of_cells
                if i % 7 == 0:
                    rdt.changed_facets(50)
                if i % 11 == 0:
                    rdt.facets(_rdt.BAD)
        except BaseException as e:
            failures.append(e)

    threads = [threading.Thread(target=writer), threading.Thread(target=reader)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    if failures:
        raise failures[0]
    rdt.restart_round()
    drain(rdt, 0)
    rdt.check()
    got = {tuple(t) for t in np.sort(rdt.facets(0)[0], axis=1).tolist()}
    want = {tuple(t) for t in rdt.all_facets()[0].tolist()}
    assert got == want, (len(got), len(want))
    sys.stdout.write(f"ok {rdt.number_of_samples} {len(got)} {stolen[0]}\\n")
    """
)


def _run(script: str, **names) -> subprocess.CompletedProcess:
    for k, v in names.items():
        script = script.replace(k, repr(v))
    return run_python(script)


def test_two_threads_share_one_core():
    res = _run(HAMMER, ROUNDS=25)
    assert res.returncode == 0, res.stderr[-3000:]
    ok, samples, facets, _ = res.stdout.split()
    assert ok == "ok"
    assert int(samples) == 100 + 25 * 150 and int(facets) > 0


def test_interpreter_exits_cleanly_after_use():
    """The module keeps no Python object alive past the interpreter (CGALError)."""
    script = textwrap.dedent(
        """
        import numpy as np
        import rdmesh
        from rdmesh.core import _rdt

        rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
        rdt.insert(np.random.default_rng(0).normal(size=(50, 3)) * 0.3)
        rdt.changed_facets()
        """
    )
    res = _run(script)
    assert res.returncode == 0 and res.stderr == "", res.stderr[-3000:]


# -- work spread over threads -----------------------------------------------------------

# Runs in a child process: an exception escaping a worker thread would end it
# through std::terminate (a negative return code) instead of reaching Python.
WORKER_FAULT = textwrap.dedent(
    """
    import sys

    import numpy as np
    from rdmesh.core import _rdt
    from rdmesh.surfaces.expressions import parse_expression
    from rdmesh.surfaces.interval_program import compile_program

    ops, consts = compile_program(parse_expression("x**2 + y**2 + z**2 - 1")._root)
    rng = np.random.default_rng(0)
    lo = rng.uniform(-1, 1, (50_000, 3))
    hi = lo + 0.01
    first = np.array([0, 500])  # one group of boxes, around every segment
    calls = {
        "evaluate_intervals": lambda: _rdt.evaluate_intervals(ops, consts, lo, hi, True, True),
        "isolate_segment_roots": lambda: _rdt.isolate_segment_roots(ops, consts, lo, hi, 1e-6),
        "segment_pieces": lambda: _rdt.segment_pieces(
            lo, hi, np.zeros(len(lo), np.int64), first, lo[:500], hi[:500] + 1.0, 0.0),
    }
    for name, call in calls.items():
        want = call()
        _rdt._fail_worker_for_testing(3)
        try:
            call()
        except RuntimeError as exc:
            assert "worker thread failed" in str(exc), exc
        else:
            raise AssertionError(name + ": no exception")
        assert _rdt._fail_worker_for_testing(0) == 0
        # Nothing is left half-done: the next call gives the same result.
        got = call()
        for a, b in zip(want, got):
            assert np.array_equal(a, b), name
        sys.stdout.write(name + " ")
    """
)


def test_an_exception_in_a_worker_thread_reaches_python():
    if _rdt.usable_cores() < 2:
        pytest.skip("one usable CPU: the core starts no worker thread")
    res = _run(WORKER_FAULT)
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.split() == ["evaluate_intervals", "isolate_segment_roots", "segment_pieces"]


def test_threads_follow_the_cpus_this_process_may_use():
    assert _rdt.usable_cores() == len(os.sched_getaffinity(0))
    one = min(os.sched_getaffinity(0))
    script = textwrap.dedent(
        f"""
        import os
        os.sched_setaffinity(0, {{{one}}})
        from rdmesh.core import _rdt
        print(_rdt.usable_cores())
        """
    )
    res = _run(script)
    assert res.returncode == 0, res.stderr[-3000:]
    assert res.stdout.split() == ["1"]


# -- flag bits ----------------------------------------------------------------------


def test_flag_bits_are_exported_and_used_by_the_core():
    bits = [_rdt.RESTRICTED, _rdt.BAD, _rdt.OUTWARD, _rdt.TOPO]
    assert all(isinstance(b, int) for b in bits)
    assert all(b > 0 and b & (b - 1) == 0 for b in bits)  # single bits
    assert len(set(bits)) == 4
    # The core files facets under these bits: facets(mask) selects them, and
    # a facet without RESTRICTED is not in the complex whatever else is set.
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(np.random.default_rng(3).uniform(-1, 1, (300, 3)))
    tri, seg, *_ = rdt.changed_facets()
    k = len(tri)
    rng = np.random.default_rng(4)
    restricted, bad, topo, outward = rng.random((4, k)) < 0.5
    flags = (
        restricted * _rdt.RESTRICTED | bad * _rdt.BAD | topo * _rdt.TOPO | outward * _rdt.OUTWARD
    ).astype(np.uint8)
    rdt.update_facets(flags, seg.mean(axis=1))
    rdt.check()
    for mask, want in [
        (0, restricted),
        (_rdt.RESTRICTED, restricted),
        (_rdt.BAD, restricted & bad),
        (_rdt.TOPO, restricted & topo),
        (_rdt.BAD | _rdt.TOPO, restricted & (bad | topo)),
    ]:
        got_tri, got_centre, got_flags = rdt.facets(mask)
        assert _as_set(got_tri) == _as_set(tri[want])
        # Flags come back as set, less OUTWARD (which orients the facet).
        key = {t: i for i, t in enumerate(map(tuple, tri.tolist()))}
        idx = [key[t] for t in map(tuple, np.sort(got_tri, axis=1).tolist())]
        assert np.array_equal(got_flags, flags[idx] & ~np.uint8(_rdt.OUTWARD))
        assert np.array_equal(got_centre, seg.mean(axis=1)[idx])
    # OUTWARD: the reported normal points along the dual segment iff it was set.
    got_tri = rdt.facets(0)[0]
    idx = [key[t] for t in map(tuple, np.sort(got_tri, axis=1).tolist())]
    x = rdt.samples()[got_tri]
    normal = np.cross(x[:, 1] - x[:, 0], x[:, 2] - x[:, 0])
    along = np.einsum("ij,ij->i", normal, seg[idx, 1] - seg[idx, 0]) > 0
    assert np.array_equal(along, outward[idx])


# -- exceptions in the middle of a round ----------------------------------------------


def _drain_retrying(rdt, max_facets):
    """Every chunk of the round, each updated as restricted; calls that fail
    with MemoryError are simply made again.  Returns the number of failures."""
    failures = 0
    while True:
        try:
            tri, seg, *_ = rdt.changed_facets(max_facets)
        except MemoryError:
            failures += 1
            continue
        if len(tri) == 0:
            return failures
        while True:
            try:
                rdt.update_facets(np.full(len(tri), FLAG), seg[:, 0])
                break
            except MemoryError:
                failures += 1


def _second_round(batch):
    """A core whose first round is done and whose second is about to start."""
    rng = np.random.default_rng(5)
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(_sphere(rng, 300))
    assert _drain_retrying(rdt, 0) == 0
    rdt.insert(_sphere(rng, batch))
    return rdt


# Few new samples: the round gathers the stars of the new vertices; many: it
# scans all cells.
@pytest.mark.parametrize("batch", [4, 150], ids=["stars", "scan"])
def test_failure_anywhere_in_a_round_loses_no_facet(batch):
    """Whichever fault point of a round raises MemoryError (gathering a cell,
    adding a facet to a chunk, converting a chunk for Python, updating it),
    once the failed call is made again every facet is reported."""
    rdt = _second_round(batch)
    _rdt._fail_allocation_for_testing(10**9)
    _drain_retrying(rdt, 40)
    points = 10**9 - _rdt._fail_allocation_for_testing(0)
    assert points > 100  # several chunks, each with its own conversion and update
    want = _as_set(rdt.facets(0)[0])
    assert want == _as_set(rdt.all_facets()[0])
    step = 1 if batch == 4 else 37
    for fail_at in [*range(1, points + 1, step), points]:
        rdt = _second_round(batch)
        _rdt._fail_allocation_for_testing(fail_at)
        try:
            failures = _drain_retrying(rdt, 40)
        finally:
            _rdt._fail_allocation_for_testing(0)
        assert failures == 1, fail_at
        assert _as_set(rdt.facets(0)[0]) == want, fail_at
        rdt.check()


def test_failed_update_keeps_its_chunk():
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(_sphere(np.random.default_rng(6), 300))
    tri, seg, *_ = rdt.changed_facets(100)
    _rdt._fail_allocation_for_testing(1)
    try:
        with pytest.raises(MemoryError):
            rdt.update_facets(np.full(len(tri), FLAG), seg[:, 0])
    finally:
        _rdt._fail_allocation_for_testing(0)
    assert len(rdt.facets(0)[0]) == 0  # nothing written
    rdt.update_facets(np.full(len(tri), FLAG), seg[:, 0])
    assert _as_set(rdt.facets(0)[0]) == _as_set(tri)


# -- voronoi_facets between chunks --------------------------------------------------


def test_voronoi_facets_between_chunks_keeps_chunk_ends():
    """voronoi_facets numbers cells through the fields changed_facets uses for
    shared segment ends; interleaving them must not mix the two up."""
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 2.0)
    rdt.insert(np.random.default_rng(7).uniform(-1, 1, (1000, 3)))
    seen = []
    while True:
        tri, seg, end_index, ends, *_ = rdt.changed_facets(150)
        if len(tri) == 0:
            break
        assert np.array_equal(ends[end_index], seg)
        off, pts, cell, _ = rdt.voronoi_facets(rdt.delaunay_edges(tri[:20, 0]))
        # Each distinct cell number stands for one circumcentre.
        first = np.unique(cell, return_index=True)[1]
        assert np.array_equal(pts, pts[first][np.searchsorted(np.unique(cell), cell)])
        assert np.array_equal(np.unique(cell), np.arange(len(first)))
        rdt.update_facets(np.full(len(tri), FLAG), seg[:, 0])
        seen.append(tri)
    assert _as_set(np.concatenate(seen)) == _as_set(rdt.all_facets()[0])


# -- inputs copied before the GIL is released --------------------------------------


def test_sample_segments_works_on_a_snapshot_of_its_inputs():
    """Another thread spoils seg (NaN) as soon as the call releases the GIL: the
    result must be that of the clean input, or a ValueError if the spoiling came
    first, never a mixture."""
    rng = np.random.default_rng(8)
    k = 60_000
    a = rng.normal(size=(k, 3))
    seg = np.stack([a, a + rng.normal(size=(k, 3)) * 50], axis=1)
    apex = a + rng.normal(size=(k, 3)) * 0.01
    rho = np.full(k, 0.01)
    want = _rdt.sample_segments(seg, apex, rho)
    for _ in range(4):
        spoilt = seg.copy()
        go = threading.Event()

        def spoil(x=spoilt, go=go):
            go.wait()
            x[:] = np.nan

        t = threading.Thread(target=spoil)
        t.start()
        go.set()
        try:
            got = _rdt.sample_segments(spoilt, apex, rho)
        except ValueError as e:
            assert "non-finite" in str(e)
            continue
        finally:
            t.join()
        for g, w in zip(got, want, strict=True):
            assert np.array_equal(g, w)


def test_sample_segments_huge_per_radius_gives_max_intervals():
    seg = np.array([[[0.0, 0, 0], [1.0, 0, 0]]])
    offsets, s, _ = _rdt.sample_segments(
        seg, np.array([[0.5, 0.1, 0]]), np.array([0.1]), per_radius=1e300, max_intervals=50
    )
    assert np.diff(offsets).tolist() == [51]
    assert np.all(np.diff(s) > 0)


def test_sample_segments_rejects_non_finite_apex():
    seg = np.array([[[0.0, 0, 0], [1.0, 0, 0]]])
    with pytest.raises(ValueError, match="apex has a non-finite"):
        _rdt.sample_segments(seg, np.array([[np.nan, 0, 0]]), np.ones(1))


# -- extreme bounding spheres and points ----------------------------------------------


@pytest.mark.parametrize(
    ("centre", "radius", "match"),
    [
        ((0.0, 0, 0), 1e308, "overflows"),
        ((1.7e308, 0, 0), 1e307, "overflows"),
        ((1.0, 1.0, 1.0), 1e-320, "not distinct"),
    ],
)
def test_constructor_rejects_spheres_beyond_double_range(centre, radius, match):
    with pytest.raises(ValueError, match=match):
        _rdt.RestrictedDelaunay(np.array(centre), radius)


def test_insert_rejects_far_points_without_overflow():
    rdt = _rdt.RestrictedDelaunay(np.zeros(3), 1e200)
    rdt.insert(np.array([[1e200, 0, 0], [0, -1.5e200, 0]]))
    with pytest.raises(ValueError, match="outside twice the bounding radius"):
        rdt.insert(np.array([[3e200, 0, 0]]))
    assert rdt.number_of_samples == 2


# -- select_independent at the ends of the double range ------------------------------


def _greedy_exact(c, r):
    """The greedy rule by brute force, in exact rational arithmetic: by
    decreasing radius (ties: lexicographic centre), keep a ball unless its
    centre lies in the closed ball of a kept one."""
    n = len(r)
    order = sorted(range(n), key=lambda k: (-r[k], c[k, 0], c[k, 1], c[k, 2]))
    cf = [[Fraction(float(x)) for x in row] for row in c]
    r2 = [Fraction(float(x)) ** 2 for x in r]
    kept = []
    for k in order:
        if all(sum((cf[k][i] - cf[a][i]) ** 2 for i in range(3)) > r2[a] for a in kept):
            kept.append(k)
    return kept


def _assert_greedy(c, r):
    c, r = np.asarray(c, float).reshape(-1, 3), np.asarray(r, float)
    got = _rdt.select_independent(c, r)
    ref = _greedy_exact(c, r)
    # Same balls in the same order (exactly repeated balls are interchangeable).
    assert np.array_equal(c[got], c[ref]) and np.array_equal(r[got], r[ref])
    return got


TINY = 5e-324  # the smallest subnormal


@pytest.mark.parametrize(
    ("centres", "radii", "kept"),
    [
        # Tiny balls far out: x / cell size is far beyond int64.
        ([[1e300, 1e300, 1e300], [1e300, 1e300, 1e300], [-1e300, 0, 1e300]], [1e-300] * 3, 2),
        # Neighbouring doubles at 1e300 are 1.5e284 apart: more than 1e-300.
        (
            [[1e300, 0, 0], [np.nextafter(1e300, 2e300), 0, 0], [1e300, 0, 0]],
            [1e-300, 1e-300, 1e-300],
            2,
        ),
        # Huge balls: squared distances overflow (2e300 > 1e300, but inf <= inf).
        ([[1e300, 0, 0], [-1e300, 0, 0]], [1e300, 1e300], 2),
        # Neighbouring grid cells, distance 1.2e300 > 1e300 (but inf <= inf).
        ([[0.5e300, 0, 0], [-0.7e300, 0, 0]], [1e300, 1e300], 2),
        # ... and here the distance equals the larger radius: closed ball.
        ([[1e300, 0, 0], [-1e300, 0, 0]], [2e300, 1e300], 1),
        # Centres at the ends of the range: the difference itself overflows.
        ([[1.7e308, 0, 0], [-1.7e308, 0, 0]], [1.7e308, 1.0], 2),
        # Subnormal radii: squares underflow to 0 (0 <= 0, yet 2 TINY > TINY).
        ([[0.0, 0, 0], [2 * TINY, 0, 0], [TINY, 0, 0]], [TINY, TINY, TINY], 2),
        ([[0.0, 0, 0], [3 * TINY, 0, 0]], [2 * TINY, 2 * TINY], 2),
        # Every scale at once: one level per power of two from 1e-300 to 1e300.
        (
            np.column_stack([np.logspace(-300, 300, 61), np.zeros(61), np.zeros(61)]),
            np.logspace(-300, 300, 61) * 0.999,
            None,
        ),
    ],
    ids=[
        "tiny_far",
        "tiny_neighbours",
        "huge",
        "huge_neighbours",
        "huge_touching",
        "range_ends",
        "subnormal",
        "subnormal_apart",
        "all_scales",
    ],
)
def test_select_independent_extreme_values(centres, radii, kept):
    got = _assert_greedy(centres, radii)
    if kept is not None:
        assert len(got) == kept


def test_select_independent_near_ties_are_exact():
    """Distances within an ulp or two of the radius: decided exactly."""
    rng = np.random.default_rng(9)
    c = rng.normal(size=(200, 3))
    a = c[rng.integers(0, 200, 200)]
    r = np.linalg.norm(c - a, axis=1)
    r = r * (1 + rng.integers(-2, 3, 200) * 2.0**-52)  # a few ulps either way
    keep = r > 0
    _assert_greedy(c[keep], r[keep])


@pytest.mark.parametrize(
    ("centre", "radius", "match"),
    [
        ([np.nan, 0, 0], 1.0, r"ball 1 has a non-finite centre"),
        ([0, -np.inf, 0], 1.0, r"ball 1 has a non-finite centre"),
        ([0, 0, 0], np.nan, r"ball 1 has a non-finite radius \(nan\)"),
        ([0, 0, 0], np.inf, r"ball 1 has a non-finite radius \(inf\)"),
        ([0, 0, 0], -1e-300, r"ball 1 has a negative radius \(-1e-300\)"),
        ([0, 0, 0], -0.0, r"ball 1 has radius 0"),
    ],
)
def test_select_independent_rejects_bad_balls(centre, radius, match):
    c = np.array([[1.0, 2, 3], centre])
    with pytest.raises(ValueError, match=match):
        _rdt.select_independent(c, np.array([0.5, radius]))


if given is not None:

    @st.composite
    def _clustered_balls(draw):
        """Balls at one random scale (any power of two the doubles have) near
        one random anchor, so that they overlap, touch and nest."""
        n = draw(st.integers(1, 24))
        scale = math.ldexp(1.0, draw(st.integers(-1074, 1023)))
        anchor = draw(st.floats(allow_nan=False, allow_infinity=False))
        steps = np.array(draw(st.lists(st.integers(-3, 3), min_size=3 * n, max_size=3 * n)))
        mult = np.array(
            draw(st.lists(st.sampled_from([0.5, 1.0, 1.5, 2.0, 3.0]), min_size=n, max_size=n))
        )
        with np.errstate(all="ignore"):
            c = anchor + steps.reshape(n, 3) * scale
            r = mult * scale
        assume(np.isfinite(c).all() and np.isfinite(r).all() and (r > 0).all())
        return c, r

    _any_balls = st.integers(1, 16).flatmap(
        lambda n: st.tuples(
            st.lists(
                st.floats(allow_nan=False, allow_infinity=False), min_size=3 * n, max_size=3 * n
            ).map(lambda v: np.array(v).reshape(-1, 3)),
            st.lists(st.floats(min_value=TINY, max_value=1.7e308), min_size=n, max_size=n).map(
                np.array
            ),
        )
    )

    @settings(
        max_examples=400,
        deadline=None,
        database=None,
        suppress_health_check=[HealthCheck.filter_too_much],
    )
    @given(st.one_of(_clustered_balls(), _any_balls))
    def test_select_independent_matches_exact_greedy(balls):
        _assert_greedy(*balls)

else:  # pragma: no cover

    def test_select_independent_matches_exact_greedy():
        pytest.skip("hypothesis is not installed")


# -- the type stub ------------------------------------------------------------------


def _split_top(text):
    """Split at commas outside brackets."""
    parts, depth, start = [], 0, 0
    for i, ch in enumerate(text):
        if ch in "[(":
            depth += 1
        elif ch in "])":
            depth -= 1
        elif ch == "," and depth == 0:
            parts.append(text[start:i].strip())
            start = i + 1
    if text[start:].strip():
        parts.append(text[start:].strip())
    return parts


def _runtime_signature(func):
    """(parameter names, {name: default}) from pybind11's docstring signature."""
    head = func.__doc__.splitlines()[0]
    inner = head[head.index("(") + 1 : head.rindex(") ->")]
    names, defaults = [], {}
    for part in _split_top(inner):
        name = part.split(":")[0].strip()
        names.append(name)
        if " = " in part:
            defaults[name] = ast.literal_eval(part.rsplit(" = ", 1)[1])
    return names, defaults


def _stub_signature(node):
    args = node.args.args
    names = [a.arg for a in args]
    values = [ast.literal_eval(d) for d in node.args.defaults]
    return names, dict(zip(names[len(names) - len(values) :], values, strict=True))


def test_stub_matches_the_bindings():
    stub = ast.parse(Path(rdmesh.core.__file__).with_name("_rdt.pyi").read_text())
    public = {n for n in dir(_rdt) if not n.startswith("__")}
    seen = set()
    for node in stub.body:
        if isinstance(node, ast.AnnAssign):
            name = node.target.id
            seen.add(name)
            assert name in public and not callable(getattr(_rdt, name))
        elif isinstance(node, ast.FunctionDef):
            seen.add(node.name)
            assert _stub_signature(node) == _runtime_signature(getattr(_rdt, node.name))
        elif isinstance(node, ast.ClassDef):
            seen.add(node.name)
            cls = getattr(_rdt, node.name)
            members = {n for n in dir(cls) if not n.startswith("_")} | {"__init__"}
            stubbed = set()
            for item in node.body:
                stubbed.add(item.name)
                if any(getattr(d, "id", None) == "property" for d in item.decorator_list):
                    assert isinstance(getattr(cls, item.name), property)
                    continue
                names, defaults = _runtime_signature(getattr(cls, item.name))
                assert _stub_signature(item) == (["self", *names[1:]], defaults), item.name
            assert stubbed == members
    assert seen == public
