"""rdmesh.sampling.roots.line_crossings: the crossings along many segments at once."""

from __future__ import annotations

import numpy as np
import pytest
import rdmesh
from rdmesh.sampling.roots import SegmentSamples, line_crossings
from rdmesh.surfaces import SURFACES
from scipy.optimize import brentq


class CountingSurface:
    """An ImplicitSurface whose raw f records every call."""

    def __init__(self, name):
        base = SURFACES[name].make()
        self.raw = base.f
        self.calls: list[int] = []

        def f(p):
            self.calls.append(len(p))
            return self.raw(p)

        self.surface = rdmesh.ImplicitSurface(f, base.bounding_sphere, gradient=base.gradient)


def _random_segments(rng, k, spread=1.6):
    o = rng.uniform(-spread, spread, (k, 3))
    d = rng.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    length = rng.uniform(0.3, 3.5, k)
    return o, d, length


def _segments_through_torus(rng, k):
    """Segments passing within 0.1 of the torus (R = 1, r = 0.4)."""
    u, v = rng.uniform(0, 2 * np.pi, (2, k))
    q = np.column_stack(
        [(1 + 0.4 * np.cos(v)) * np.cos(u), (1 + 0.4 * np.cos(v)) * np.sin(u), 0.4 * np.sin(v)]
    ) + rng.uniform(-0.1, 0.1, (k, 3))
    d = rng.normal(size=(k, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    length = rng.uniform(0.3, 3.0, k)
    o = q - (rng.uniform(0, 1, k) * length)[:, None] * d
    return o, d, length


def _crossings(surface, o, d, length, n_intervals, xatol):
    """line_crossings with uniform samples; also each segment's sample positions."""
    samples = SegmentSamples.uniform(length, n_intervals)
    cr = line_crossings(surface, o, d, samples, xatol)
    off = samples.offsets
    return cr, [samples.s[off[i] : off[i + 1]] for i in range(len(length))]


def _scalar_crossings(raw, o, d, s_row, vectorised_scan=False):
    """Scalar loop on one segment: brentq on every sign change between the
    positions ``s_row``; returns [(s, rising)]."""

    def g(s):
        return float(raw((o + s * d)[None, :])[0])

    # For dense scans only the scan itself is vectorised.
    vals = raw(o + s_row[:, None] * d) if vectorised_scan else np.vectorize(g)(s_row)
    inside = vals < 0  # 0 counts as outside
    out = []
    for j in np.flatnonzero(inside[:-1] != inside[1:]):
        lo, hi = s_row[j], s_row[j + 1]
        if vals[j] == 0.0:
            root = lo
        elif vals[j + 1] == 0.0:
            root = hi
        else:
            root = brentq(g, lo, hi, xtol=1e-14, rtol=4 * np.finfo(float).eps)
        out.append((root, bool(inside[j])))
    return out


@pytest.mark.parametrize("seed", range(3))
def test_matches_scalar_brentq_on_torus(seed):
    """Same counts, positions and directions as a scalar loop over the same
    samples; where that loop misses a hidden pair of crossings (found by a
    much denser scalar scan), line_crossings may find more, but only real ones."""
    rng = np.random.default_rng(seed)
    cs = CountingSurface("torus")
    k = 300
    o, d, length = _segments_through_torus(rng, k)
    cr, samples = _crossings(cs.surface, o, d, length, rng.integers(1, 100, k), 1e-13)
    assert np.allclose(cr.point, o[cr.segment] + cr.s[:, None] * d[cr.segment], atol=1e-12)
    n_compared = n_crossings = 0
    for row, s_row in enumerate(samples):
        ref = _scalar_crossings(cs.raw, o[row], d[row], s_row)
        dense = _scalar_crossings(
            cs.raw, o[row], d[row], np.linspace(0, length[row], 4001), vectorised_scan=True
        )
        mine = cr.segment == row
        got_s, got_rising = cr.s[mine], cr.rising[mine]
        if len(dense) == len(ref):  # the samples see every crossing
            n_compared += 1
            n_crossings += len(ref)
            assert len(got_s) == len(ref)
            assert np.allclose(got_s, [x for x, _ in ref], atol=1e-9, rtol=0)
            assert got_rising.tolist() == [r for _, r in ref]
        else:
            # Everything found is a true crossing, including the ones the
            # plain sign test finds.
            assert len(got_s) >= len(ref)
            dense_s = np.array([x for x, _ in dense])
            assert np.all(np.min(np.abs(got_s[:, None] - dense_s[None]), axis=1) < 1e-9)
            for x, _ in ref:
                assert np.min(np.abs(got_s - x)) < 1e-9
    assert n_compared > 250
    assert n_crossings > 200


def test_against_exact_quartic_roots():
    """Along a line the torus function is a quartic: compare with its roots
    wherever they are simple and farther apart than the sample spacing."""
    rng = np.random.default_rng(11)
    cs = CountingSurface("torus")
    k = 400
    o, d, length = _random_segments(rng, k)
    cr, _ = _crossings(cs.surface, o, d, length, np.full(k, 64), 1e-13)
    counts = cr.count(k)
    checked = 0
    for row in range(k):
        t = np.linspace(0, length[row], 9)
        vals = cs.raw(o[row] + t[:, None] * d[row])
        coef = np.polynomial.polynomial.polyfit(t, vals, 4)
        roots = np.polynomial.polynomial.polyroots(coef)
        real = np.sort(roots[np.abs(roots.imag) < 1e-9].real)
        real = real[(real > 0) & (real < length[row])]
        h = length[row] / 64
        if len(real) and (
            np.min(np.r_[real, length[row] - real]) < h or np.any(np.diff(real) < 2 * h)
        ):
            continue  # near an end or a close pair: sampling may legitimately differ
        checked += 1
        assert counts[row] == len(real)
        assert np.allclose(cr.s[cr.segment == row], real, atol=1e-8)
    assert checked > 300


def test_even_number_of_crossings_found():
    s = SURFACES["sphere"].make()
    # A chord: both ends outside, two crossings.
    o = np.array([[-1.5, 0.3, 0.0], [0.0, -1.7, 0.5]])
    d = np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
    length = np.array([3.0, 3.4])
    cr, _ = _crossings(s, o, d, length, np.full(2, 16), 1e-13)
    assert cr.count(2).tolist() == [2, 2]
    x = np.sqrt(1 - 0.09)
    assert np.allclose(cr.point[cr.segment == 0, 0], [-x, x], atol=1e-12)
    y = np.sqrt(1 - 0.25)
    assert np.allclose(cr.point[cr.segment == 1, 1], [-y, y], atol=1e-12)
    # Entering then leaving.
    assert cr.rising.tolist() == [False, True, False, True]

    # Four crossings of the torus along the x axis, both ends outside.
    t = SURFACES["torus"].make()
    cr, _ = _crossings(
        t,
        np.array([[-1.9, 0.0, 0.0]]),
        np.array([[1.0, 0.0, 0.0]]),
        np.array([3.8]),
        np.array([32]),
        1e-13,
    )
    assert np.allclose(cr.point[:, 0], [-1.4, -0.6, 0.6, 1.4], atol=1e-12)
    assert cr.rising.tolist() == [False, True, False, True]


def test_rising_matches_gradient():
    rng = np.random.default_rng(21)
    s = SURFACES["tanglecube"].make()
    k = 500
    o, d, length = _random_segments(rng, k, spread=3.0)
    length *= 2
    cr, _ = _crossings(s, o, d, length, np.full(k, 64), 1e-12)
    assert len(cr.segment) > 200
    g = s.gradient(cr.point)
    slope = np.einsum("ij,ij->i", g, d[cr.segment])
    assert np.array_equal(cr.rising, slope > 0)
    # Points are on the surface.
    assert np.all(np.abs(s.f(cr.point)) / np.linalg.norm(g, axis=1) < 1e-9)
    # Sorted by segment, then by position along it.
    order = np.lexsort((cr.s, cr.segment))
    assert np.array_equal(order, np.arange(len(order)))


def test_derivative_from_the_last_bracket_matches_the_gradient():
    """Each crossing's slope across its search's last bracket is f's derivative
    along the segment there (no extra evaluation); NaN where that bracket is
    wider than a central difference's span (a search that stopped on f == 0)."""
    rng = np.random.default_rng(5)
    s = SURFACES["tanglecube"].make()
    k = 500
    o, d, length = _random_segments(rng, k, spread=3.0)
    cr, _ = _crossings(s, o, d, 2 * length, np.full(k, 64), 1e-10 * s.radius)
    assert len(cr.segment) > 200 and np.isfinite(cr.derivative).all()
    exact = np.einsum("ij,ij->i", s.gradient(cr.point), d[cr.segment])
    scale = np.linalg.norm(s.gradient(cr.point), axis=1)
    assert np.abs(cr.derivative - exact).max() <= 1e-4 * scale.max()
    assert np.array_equal(cr.derivative > 0, cr.rising)
    # A sample exactly on the surface ends a search at once, bracket unshrunk.
    line = rdmesh.ImplicitSurface(lambda p: p[:, 0] - 0.5, ((0, 0, 0), 2.0))
    one = line_crossings(
        line, np.array([[0.0, 0, 0]]), np.array([[1.0, 0, 0]]),
        SegmentSamples.uniform(np.array([1.0]), 3), 1e-10,
    )  # fmt: skip
    assert np.allclose(one.s, 0.5) and np.isnan(one.derivative).all()


def test_no_crossings():
    s = SURFACES["sphere"].make()
    o = np.array([[1.5, 1.5, 0.0], [0.0, 0.0, 0.0]])
    d = np.array([[0.0, 0.0, 1.0], [1.0, 0.0, 0.0]])
    cr, _ = _crossings(s, o, d, np.array([1.0, 0.5]), np.full(2, 8), 1e-12)
    assert cr.segment.shape == (0,) and cr.point.shape == (0, 3)
    assert cr.count(2).tolist() == [0, 0]
    empty = SegmentSamples(np.zeros(1, np.int64), np.zeros(0))
    assert line_crossings(s, o[:0], d[:0], empty, 1e-12).count(2).tolist() == [0, 0]


@pytest.mark.parametrize("k", [10, 3000])
def test_few_calls_of_f(k):
    """One call for all samples, then one per root-finder iteration."""
    rng = np.random.default_rng(k)
    cs = CountingSurface("torus")
    o, d, length = _random_segments(rng, k)
    cr, samples = _crossings(cs.surface, o, d, length, rng.integers(1, 100, k), 1e-12)
    assert len(cr.segment) > 0
    n_samples = sum(len(s_row) for s_row in samples)
    assert cs.calls[0] == n_samples
    assert len(cs.calls) < 40
    # Root-finder calls only touch the brackets, never more points than exist.
    assert max(cs.calls[1:]) <= 2 * len(cr.segment)


def test_uniform_samples_layout():
    rng = np.random.default_rng(3)
    length = rng.uniform(0.1, 2.0, 50)
    want = rng.integers(0, 200, 50)
    samples = SegmentSamples.uniform(length, want)
    off, S = samples.offsets, samples.s
    n = np.maximum(want, 1)
    assert np.array_equal(np.diff(off), n + 1)
    seg = samples.segment_of()
    assert np.array_equal(seg, np.repeat(np.arange(50), n + 1))
    assert np.all(S[off[:-1]] == 0) and np.array_equal(S[off[1:] - 1], length)
    same = seg[1:] == seg[:-1]
    assert np.allclose(np.diff(S)[same], (length / n)[seg[1:][same]])


def test_hidden_pair_between_samples():
    """Two crossings between neighbouring samples (no sign change at any
    sample) are still found, as the docstring promises."""
    s = SURFACES["sphere"].make()
    o = np.array([[-1.2, 0.99, 0.0]])
    d = np.array([[1.0, 0.0, 0.0]])
    cr, (s_row,) = _crossings(s, o, d, np.array([3.0]), np.array([3]), 1e-13)
    values = s.f(o + s_row[:, None] * d)
    assert np.all(values > 0)  # every sample is outside
    x = np.sqrt(1 - 0.99**2)
    assert np.allclose(cr.point[:, 0], [-x, x], atol=1e-10)
    assert cr.rising.tolist() == [False, True]
