"""Restricted-facet evaluation: where a facet's dual Voronoi edge meets the surface.

For every facet the dual segment is searched for *all* crossings. The facet is
restricted when there is at least one; its representative surface centre is the
crossing with the largest surface Delaunay ball (farthest from the facet's
vertices), and the facet is flagged when it has several crossings or a
tangential one (algorithm.md, 1.3 and 5.2).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .. import core
from .._errors import OracleError
from .._tol import (
    GRADIENT_STEP,
    MAX_INTERVALS,
    MIN_INTERVALS,
    ROOT_ATOL,
    SAMPLES_PER_RADIUS,
    TANGENCY_COS,
)
from .._vectors import row_norms, segment_directions
from ..sampling.roots import Crossings, SegmentSamples, line_crossings
from ..sampling.screen import end_slopes, ruled_out
from ..surfaces.oracle import ImplicitSurface

#: What the core's changed_facets and sample_segments take.
SAMPLING = {
    "per_radius": SAMPLES_PER_RADIUS,
    "min_intervals": MIN_INTERVALS,
    "max_intervals": MAX_INTERVALS,
}


@dataclass
class FacetEval:
    """Result of :func:`evaluate_facets` for k facets."""

    n_cross: np.ndarray  # (k,) int
    centre: np.ndarray  # (k, 3), zeros where not restricted
    radius: np.ndarray  # (k,), zeros where not restricted
    outward: np.ndarray  # (k,) bool: outside lies along the segment direction
    tangential: np.ndarray  # (k,) bool
    failed: int = 0  # segments whose root search failed (see Crossings.failed)
    #: (k,) bool: no crossing or one transversal one, and no failed root search
    #: (the core's KNOWN flag).
    clean: np.ndarray | None = None
    #: (k,) the slope of f between each segment's ends (zeros without a
    #: slope bound).
    steep: np.ndarray | None = None

    @property
    def restricted(self) -> np.ndarray:
        return self.n_cross > 0


@dataclass
class DualSamples:
    """Samples of k dual segments, as the core makes them (see
    ``core.sample_segments``): flat positions plus the interior points."""

    offsets: np.ndarray  # (k + 1,)
    s: np.ndarray  # (P,)
    interior: np.ndarray  # (P - 2k, 3)

    @classmethod
    def of(cls, seg: np.ndarray, apex: np.ndarray, rho: np.ndarray) -> DualSamples:
        return cls(*core.sample_segments(seg, apex, rho, **SAMPLING))

    def select(self, rows: np.ndarray) -> DualSamples:
        """The samples of segments ``rows`` (increasing indices)."""
        n = np.diff(self.offsets)
        mask = np.zeros(len(n), bool)
        mask[rows] = True
        return DualSamples(
            np.r_[0, np.cumsum(n[rows])].astype(np.int64),
            self.s[np.repeat(mask, n)],
            self.interior[np.repeat(mask, n - 2)],
        )

    def take(self, sl: slice) -> DualSamples:
        """The samples of segments ``sl`` (a contiguous slice)."""
        a, b, _ = sl.indices(len(self.offsets) - 1)
        off = self.offsets
        # Interior points: all samples but two per segment.
        return DualSamples(
            off[a : b + 1] - off[a],
            self.s[off[a] : off[b]],
            self.interior[off[a] - 2 * a : off[b] - 2 * b],
        )


def evaluate_facets(
    surface: ImplicitSurface,
    apex: np.ndarray,
    seg: np.ndarray,
    rho: np.ndarray,
    end_values: np.ndarray | None = None,
    samples: DualSamples | None = None,
    apex_weight: np.ndarray | None = None,
    slope: np.ndarray | None = None,
) -> FacetEval:
    """Find the crossings of each facet's dual segment.

    Parameters
    ----------
    surface : ImplicitSurface
    apex : (k, 3) the vertex with the smallest id of each facet.
    seg : (k, 2, 3) dual segments (clipped to the bounding sphere).
    rho : (k,) facet circumradii.
    end_values : (k, 2) float, optional
        ``f`` at both ends of each segment, when known (the core reports
        shared Voronoi vertices once, so ``f`` is evaluated once per vertex).
    samples : DualSamples, optional
        The segments' samples, when the core made them already.
    apex_weight : (k,) float, optional
        The apex's weight (a protecting ball's radius squared): the ball
        radius is then the power radius ``sqrt(|x - apex|^2 - w)``.
    slope : (k,) float, optional
        A bound on ``|grad f|`` along each segment: intervals between samples
        that it rules out are not sampled (:mod:`rdmesh.sampling.screen`).

    Returns
    -------
    FacetEval
    """
    k = len(seg)
    out = FacetEval(
        np.zeros(k, np.int64),
        np.zeros((k, 3)),
        np.zeros(k),
        np.zeros(k, bool),
        np.zeros(k, bool),
        clean=np.ones(k, bool),
        steep=np.zeros(k),
    )
    if k == 0:
        return out
    start = seg[:, 0]
    length, u = segment_directions(seg[:, 1] - start)
    exact = getattr(surface, "exact_crossings", None)
    if exact is None:
        cr, out.steep = _sampled_crossings(
            surface, seg, apex, rho, u, end_values, samples, slope, length
        )
        cos = np.full(len(cr.segment), np.nan)
    else:
        *found, cos, unsure = exact(seg)
        cr = Crossings(*found)
        # Degenerate hits (through an edge, say): those segments are sampled.
        again = np.flatnonzero(unsure)
        if len(again):
            more, out.steep[again] = _sampled_crossings(
                surface, seg[again], apex[again], rho[again], u[again],
                slope=None if slope is None else slope[again], length=length[again],
            )  # fmt: skip
            more.segment, more.failed = again[more.segment], again[more.failed]
            order = np.argsort(np.r_[cr.segment, more.segment], kind="stable")
            cos = np.r_[cos, np.full(len(more.segment), np.nan)][order]
            known = np.full(len(cr.segment), np.nan)
            cr = Crossings(
                np.r_[cr.segment, more.segment][order],
                np.r_[cr.s, more.s][order],
                np.r_[cr.point, more.point][order],
                np.r_[cr.rising, more.rising][order],
                more.failed,
                np.r_[known, _derivatives(more)][order],
            )
    out.clean = np.ones(k, bool)
    out.clean[cr.failed] = False
    if cr.segment.size == 0:
        out.failed = len(cr.failed)
        return out
    segment = cr.segment
    out.n_cross = np.bincount(segment, minlength=k)
    # Representative crossing: the largest ball, i.e. the largest distance from
    # the facet's circumcentre along the line.
    sigma0 = np.einsum("ij,ij->i", u[segment], start[segment] - apex[segment])
    far = np.abs(sigma0 + cr.s)
    pick_order = np.lexsort((far, segment))
    last = np.r_[segment[pick_order][1:] != segment[pick_order][:-1], True]
    pick = pick_order[last]
    rows = segment[pick]
    out.centre[rows] = cr.point[pick]
    if apex_weight is None:
        out.radius[rows] = np.linalg.norm(cr.point[pick] - apex[rows], axis=1)
    else:
        d = cr.point[pick] - apex[rows]
        r2 = np.einsum("ij,ij->i", d, d) - apex_weight[rows]
        out.radius[rows] = np.sqrt(np.maximum(r2, 0.0))
    out.outward[rows] = cr.rising[pick]
    cos = cos[pick]
    trusted = np.ones(len(pick), bool)
    if surface.gradient is None and slope is not None:
        # Central differences of f cost six evaluations; the derivative along
        # the segment (from the root search's last bracket, else two) shows
        # most crossings transversal.
        idx = np.flatnonzero(np.isnan(cos))
        if len(idx):
            cos[idx] = _cos_by_slope(
                surface, cr.point[pick[idx]], u[rows[idx]], slope[rows[idx]],
                _derivatives(cr)[pick[idx]],
            )  # fmt: skip
    ask = np.flatnonzero(np.isnan(cos))
    if len(ask):
        g = surface.grad(cr.point[pick[ask]])
        # hypot: squaring underflows below 1e-154 and overflows above 1e154,
        # which made every crossing of a scaled f look tangential.
        gn = row_norms(g)
        trusted[ask] = np.isfinite(gn) & (gn > 0)
        _check_gradients(trusted[ask], cr.point[pick[ask]])
        with np.errstate(invalid="ignore", over="ignore"):
            cos[ask] = np.abs(np.einsum("ij,ij->i", g, u[rows[ask]])) / np.where(
                trusted[ask], gn, 1.0
            )
    out.tangential[rows] = ~trusted | (cos < TANGENCY_COS)
    # A sign change whose root search failed: refine there (a Voronoi-edge
    # violation), never use the bracket as a surface point.
    out.tangential[cr.failed] |= out.n_cross[cr.failed] > 0
    out.failed = len(cr.failed)
    out.clean &= (out.n_cross <= 1) & ~out.tangential
    return out


def _sampled_crossings(
    surface, seg, apex, rho, u, end_values=None, samples=None, slope=None, length=None
):
    """Every crossing of the segments ``seg`` (unit directions ``u``) from
    samples of ``f`` and root searches (``Crossings.failed``: segments whose
    search failed), and the slope of ``f`` between each segment's ends; ``f``
    at the ends and the samples when known. With ``slope`` bounds (one per
    segment) the segments they clear are not sampled
    (:mod:`rdmesh.sampling.screen`); the others are sampled here, unless
    ``samples`` has them all."""
    k = len(seg)
    if slope is None:
        if samples is None:
            samples = DualSamples.of(seg, apex, rho)
        return _all_samples(surface, seg, u, end_values, samples), np.zeros(k)
    if end_values is None:
        end_values = surface(np.concatenate([seg[:, 0], seg[:, 1]])).reshape(2, k).T
    if length is None:  # the caller's segment lengths, when it has them
        length = segment_directions(seg[:, 1] - seg[:, 0])[0]
    steep = end_slopes(end_values, length, surface.radius)
    rows = np.flatnonzero(~ruled_out(end_values, length, slope))
    if len(rows) == 0:
        return Crossings(
            np.zeros(0, np.int64), np.zeros(0), np.zeros((0, 3)), np.zeros(0, bool)
        ), steep
    if samples is not None:
        samples = samples.select(rows) if len(rows) < k else samples
    else:
        samples = DualSamples.of(seg[rows], apex[rows], rho[rows])
    cr = _all_samples(surface, seg[rows], u[rows], end_values[rows], samples)
    cr.segment, cr.failed = rows[cr.segment], rows[cr.failed]
    return cr, steep


def _all_samples(surface, seg, u, end_values, samples):
    """The crossings from every sample of each segment (``f`` at the ends when known).

    The core places the interior samples as the root search places its points
    (start + s u, with ``u`` from :func:`segment_directions`, bit for bit), so
    ``f`` there is what the search would find, and it takes those values
    instead of evaluating again."""
    flat = SegmentSamples(samples.offsets, samples.s)
    if end_values is None:
        v = surface(np.concatenate([samples.interior, seg[:, 0], seg[:, 1]]))
        interior_values = v[: len(samples.interior)]
        end_values = v[len(samples.interior) :].reshape(2, len(seg)).T
    else:
        interior_values = surface(samples.interior)
    xatol = ROOT_ATOL * surface.radius
    return line_crossings(surface, seg[:, 0], u, flat, xatol, interior_values, end_values)


def _derivatives(cr: Crossings) -> np.ndarray:
    """``cr.derivative``, NaN throughout where it is not known."""
    return np.full(len(cr.segment), np.nan) if cr.derivative is None else cr.derivative


def _cos_by_slope(surface, points, u, bound, known):
    """At crossings ``points`` of segments along ``u``: ``|f'(x; u)| / L``, a
    lower bound on ``|cos|`` between ``u`` and the gradient wherever
    ``|grad f| <= L`` (``bound``); NaN where that does not show the crossing
    transversal (then the gradient decides). ``f'`` is ``known`` (the slope
    across the root search's last bracket) where not NaN, else a central
    difference (two evaluations). Either is ``f'`` at a point within
    ``GRADIENT_STEP R`` of the crossing (mean value theorem). A known slope
    above ``L`` is not trusted: across a bracket some 1e-10 R wide, rounding
    in ``f`` (one computed in float32, say) shows as a steep slope."""
    ok = np.isfinite(bound) & (bound > 0)
    d = np.array(known, dtype=float)
    with np.errstate(invalid="ignore"):
        d[~(np.abs(d) <= bound)] = np.nan
    ask = np.flatnonzero(np.isnan(d) & ok)
    if len(ask):
        h = GRADIENT_STEP * surface.radius
        p, v = points[ask], u[ask]
        f = surface(np.concatenate([p + h * v, p - h * v])).reshape(2, -1)
        d[ask] = (f[0] - f[1]) / (2.0 * h)
    cos = np.full(len(points), np.nan)
    cos[ok] = np.abs(d[ok]) / bound[ok]
    return np.where(cos >= TANGENCY_COS, cos, np.nan)


#: Crossings with a zero or non-finite gradient: a few are singular points of
#: the surface (refined, then left unresolved at the floor); this many, and at
#: least this share of a chunk's crossings, mean the gradient is broken.
UNTRUSTED_MIN, UNTRUSTED_SHARE = 8, 0.5


def _check_gradients(trusted: np.ndarray, points: np.ndarray) -> None:
    bad = np.flatnonzero(~trusted)
    if len(bad) >= max(UNTRUSTED_MIN, UNTRUSTED_SHARE * len(trusted)):
        raise OracleError(
            f"the gradient is zero or not finite at {len(bad)} of {len(trusted)} crossings "
            f"(e.g. at {np.round(points[bad[0]], 6).tolist()}): the surface's normals cannot "
            "be trusted (a gradient function that returns zeros, or f constant in steps so "
            "that central differences vanish); give a correct gradient or a smooth f"
        )
