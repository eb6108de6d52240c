"""rdmesh.core.scan_samples: the sign scan behind the crossing search, against
the rules written out in numpy (sign changes, dips, valleys; algorithm.md 5.2)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rdmesh import core

DIP = 0.25


def reference(offsets, s, values):
    """The three lists by the rules, one segment at a time."""
    sign, dips, valleys = [], [], []
    for k in range(len(offsets) - 1):
        x = s[offsets[k] : offsets[k + 1]]
        v = values[offsets[k] : offsets[k + 1]]
        a, inside, n = np.abs(v), v < 0, len(v)
        sign += [
            (k, x[i], x[i + 1], inside[i], v[i], v[i + 1])
            for i in range(n - 1)
            if inside[i] != inside[i + 1]
        ]
        dip = np.zeros(n, bool)
        for m in range(1, n - 1):
            if (
                a[m] < DIP * max(a[m - 1], a[m + 1])
                and a[m] < min(a[m - 1], a[m + 1])
                and inside[m - 1] == inside[m] == inside[m + 1]
            ):
                dip[m] = True
                dips.append((k, x[m - 1], x[m], x[m + 1], -1.0 if inside[m] else 1.0))
        for j in range(n - 1):
            outer = max(a[j - 1] if j >= 1 else 0.0, a[j + 2] if j + 2 < n else 0.0)
            if (
                max(a[j], a[j + 1]) < DIP * outer
                and inside[j] == inside[j + 1]
                and not (dip[j] or dip[j + 1])
            ):
                valleys.append((k, x[j], x[j + 1], inside[j], a[j], a[j + 1]))
    return sign, dips, valleys


def rows(arrays):
    return [tuple(a[i].item() for a in arrays) for i in range(len(arrays[0]))]


def _case(lengths, values):
    offsets = np.zeros(len(lengths) + 1, np.int64)
    np.cumsum(lengths, out=offsets[1:])
    s = np.concatenate([np.arange(n, dtype=float) * 0.5 for n in lengths])
    return offsets, s, np.asarray(values, float)


@settings(max_examples=200, deadline=None)
@given(st.data())
def test_scan_matches_the_rules(data):
    lengths = data.draw(st.lists(st.integers(2, 9), min_size=1, max_size=8))
    # Few distinct magnitudes, so that ties, dips and valleys are common.
    values = data.draw(
        st.lists(st.sampled_from([-3.0, -1.0, -0.1, -0.01, 0.0, 0.01, 0.1, 1.0, 3.0]),
                 min_size=sum(lengths), max_size=sum(lengths))
    )  # fmt: skip
    offsets, s, v = _case(lengths, values)
    sign, dips, valleys = core.scan_samples(offsets, s, v, None, DIP)
    want = reference(offsets, s, v)
    assert rows(sign) == [(k, lo, hi, int(r), a, b) for k, lo, hi, r, a, b in want[0]]
    assert rows(dips) == want[1]
    assert rows(valleys) == [(k, lo, hi, int(i), a, b) for k, lo, hi, i, a, b in want[2]]


@settings(max_examples=50, deadline=None)
@given(st.data())
def test_interior_values_with_ends_give_the_same_scan(data):
    lengths = data.draw(st.lists(st.integers(2, 7), min_size=1, max_size=6))
    v = np.array(
        data.draw(st.lists(st.floats(-2, 2), min_size=sum(lengths), max_size=sum(lengths)))
    )
    offsets, s, v = _case(lengths, v)
    first, last = offsets[:-1], offsets[1:] - 1
    interior = np.ones(len(v), bool)
    interior[first] = interior[last] = False
    ends = np.column_stack([v[first], v[last]])
    a = core.scan_samples(offsets, s, v, None, DIP)
    b = core.scan_samples(offsets, s, v[interior], ends, DIP)
    for x, y in zip(a, b, strict=True):
        for p, q in zip(x, y, strict=True):
            np.testing.assert_array_equal(p, q)


@pytest.mark.parametrize(
    "offsets, s, values, ends, match",
    [
        ([0, 1], [0.0], [1.0], None, "at least its two ends"),
        ([0, 3], [0.0, 1.0], [1.0, 2.0], None, "from 0 to len"),
        ([0, 2], [0.0, 1.0], [1.0], None, "one entry per sample"),
        ([0, 3], [0.0, 0.5, 1.0], [1.0], [[1.0, 2.0, 3.0]], "ends must have shape"),
        ([1, 3], [0.0, 0.5, 1.0], [1.0, 2.0, 3.0], None, "from 0 to len"),
    ],
)
def test_bad_layouts_raise(offsets, s, values, ends, match):
    with pytest.raises(ValueError, match=match):
        core.scan_samples(np.array(offsets), np.array(s), np.array(values), ends, DIP)
