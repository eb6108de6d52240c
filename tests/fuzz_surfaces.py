"""Random smooth surfaces with an independently known topology, for fuzzing.

A helper module, not a test file: ``tests/test_fuzz.py`` draws from the
hypothesis strategies at the bottom, ``benchmarks/fuzz.py`` from the same
families through a numpy generator. Both then call :func:`run_method` and
:func:`classify`, so the two agree on what counts as correct.

Families (each a function ``family(sampler, profile) -> FuzzSurface``):

``metaball_chain``
    ``T - sum_i w_i exp(-|p - c - t_i u|^2 / s^2)``: blobs of one width on a
    line. Then ``f = T - exp(-rho^2/s^2) g(x)`` with ``x`` along the line and
    ``rho`` the distance to it, so ``{f < 0} = {rho^2 < q(x)}`` with
    ``q = s^2 ln(g / T)``: a solid of revolution. Each interval where
    ``q > 0`` (with simple roots at its ends) is one sphere. The topology
    follows from the 1-D function ``g`` whether the blobs are separated,
    clearly merged or joined by a neck: construction.
``metaball_cloud``
    Blobs of several widths: at random, on a ring (a torus when neighbours
    merge), or with a weak "satellite" blob apart (a small component). When
    they are separated enough for :func:`_separated_metaballs` to prove that
    every blob is a radial graph (one sphere each), construction; otherwise
    marching cubes.
``primitives``
    Randomly placed and oriented ellipsoids and ring tori, at least a gap
    apart, combined by product or by min (see :func:`primitives`): one
    component per part, chi 2 per ellipsoid and 0 per torus; now and then one
    part is a small ellipsoid. Construction.
``perturbed_sphere``
    ``|p - c| - rho(u)``, ``rho = R0 (1 + trig modes + bumps)`` on the
    direction ``u``, with amplitudes summing to at most 1/2 so ``rho > 0``:
    a radial graph, hence a sphere. Construction.
``dumbbell``
    A solid of revolution ``rho^2 < q(x)`` with ``q = (L^2 - x^2) beta
    ((x - m)^2 + e)``: two blobs joined by a neck of prescribed radius
    (``e > 0``). Construction.
``near_touching``
    Two blobs a prescribed gap apart: the dumbbell with ``e < 0`` (the roots
    ``m +- gap/2`` split it), or the product of two sphere functions.
    Construction.

Necks and gaps are drawn log-uniformly down to the profile's minimum. One
surface in three gets a bounding sphere up to 3 times too large
(:func:`loosen`): the seeding grid has a fixed number of cells across it.

Reference topology. Construction where it is certain (each family says why);
otherwise skimage's marching cubes at two dense resolutions, whose components
and Euler characteristics (computed here with numpy) must agree, and must be
closed manifolds; a disagreement makes the case *ambiguous*: it is still
meshed, but its topology is not compared.

Every surface carries ``spec``, a Python expression of this module that
rebuilds it exactly (``fz.dumbbell(...)``), so a failing case can be pasted
into a regression list.
"""

from __future__ import annotations

import hashlib
import math
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from meshcheck import closed_manifold_problems
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

ArrayFunction = Callable[[np.ndarray], np.ndarray]

#: Threshold of every metaball sum.
THRESHOLD = 0.5

# -- profiles ---------------------------------------------------------------------


@dataclass(frozen=True)
class Profile:
    """Sizes of one fuzzing run.

    Lengths are in the families' own units: blobs, parts and spheres are
    about 1 across.
    """

    name: str
    #: Vertex budget and time limit of every run (hang guards).
    max_vertices: int
    time_limit: float
    #: Boissonnat-Oudot: radius bound = feature / 10, but not below the size
    #: that would give about this many vertices (so thin cases stay
    #: affordable; such runs are flagged ``radius_clipped``).
    target_vertices: int
    #: Thinnest neck radius and narrowest gap drawn.
    min_neck: float
    min_gap: float
    #: Most blobs of a metaball sum, most parts of a union.
    max_blobs: int
    max_parts: int
    #: Small components: the weakest satellite blob (w = T (1 + this)) and the
    #: smallest part's largest semi-axis.
    min_satellite: float
    min_part: float
    #: Marching cubes resolutions (points per axis of the bounding cube).
    mc_resolutions: tuple[int, int]


FAST = Profile(
    "fast",
    max_vertices=20_000,
    time_limit=30.0,
    target_vertices=6_000,
    min_neck=0.15,
    min_gap=0.1,
    max_blobs=4,
    max_parts=3,
    min_satellite=0.1,
    min_part=0.15,
    mc_resolutions=(112, 160),
)
LARGE = Profile(
    "large",
    max_vertices=60_000,
    time_limit=60.0,
    target_vertices=25_000,
    min_neck=0.005,
    min_gap=0.002,
    max_blobs=6,
    max_parts=4,
    min_satellite=0.005,
    min_part=0.04,
    mc_resolutions=(128, 192),
)
PROFILES = {p.name: p for p in (FAST, LARGE)}


# -- samplers: one interface for hypothesis and numpy ----------------------------------


class Sampler:
    """Draws numbers; subclasses wrap hypothesis's ``draw`` or a numpy generator.

    Floats are rounded to 4 decimals so that a case's ``spec`` stays short and
    still rebuilds it exactly.
    """

    def _uniform(self, lo: float, hi: float) -> float:
        raise NotImplementedError

    def _integer(self, lo: int, hi: int) -> int:
        raise NotImplementedError

    def uniform(self, lo: float, hi: float) -> float:
        return round(min(max(self._uniform(lo, hi), lo), hi), 4)

    def integer(self, lo: int, hi: int) -> int:
        """An integer in ``[lo, hi]`` (both included)."""
        return int(self._integer(lo, hi))

    def log_uniform(self, lo: float, hi: float) -> float:
        """Log-uniform in ``[lo, hi]``: thin necks and narrow gaps as often as wide."""
        return round(min(max(math.exp(self._uniform(math.log(lo), math.log(hi))), lo), hi), 4)

    def choice(self, options: Sequence[Any]) -> Any:
        return options[self.integer(0, len(options) - 1)]

    def unit_vector(self) -> tuple[float, float, float]:
        z = self.uniform(-1.0, 1.0)
        phi = self.uniform(0.0, 2 * math.pi)
        s = math.sqrt(max(0.0, 1.0 - z * z))
        return (round(s * math.cos(phi), 4), round(s * math.sin(phi), 4), z)

    def rotation(self) -> tuple[float, float, float]:
        """An axis-angle vector (axis times angle in radians)."""
        axis = self.unit_vector()
        angle = self.uniform(0.0, math.pi)
        return tuple(round(a * angle, 4) for a in axis)


class RngSampler(Sampler):
    """Draws from a :class:`numpy.random.Generator`."""

    def __init__(self, rng: np.random.Generator) -> None:
        self.rng = rng

    def _uniform(self, lo: float, hi: float) -> float:
        return float(self.rng.uniform(lo, hi))

    def _integer(self, lo: int, hi: int) -> int:
        return int(self.rng.integers(lo, hi + 1))


class HypothesisSampler(Sampler):
    """Draws through hypothesis (inside ``st.composite``)."""

    def __init__(self, draw: Callable) -> None:
        from hypothesis import strategies as st

        self.draw = draw
        self.st = st

    def _uniform(self, lo: float, hi: float) -> float:
        return self.draw(self.st.floats(lo, hi, allow_nan=False, allow_infinity=False))

    def _integer(self, lo: int, hi: int) -> int:
        return self.draw(self.st.integers(lo, hi))


# -- the surface record -------------------------------------------------------------------


@dataclass(frozen=True)
class Topology:
    """Components and the Euler characteristic of each, largest first."""

    components: int
    euler: tuple[int, ...]

    @property
    def euler_total(self) -> int:
        return sum(self.euler)


@dataclass
class Reference:
    """The reference topology of a surface and where it comes from.

    ``topology`` is None when the case is ambiguous (marching cubes at the two
    resolutions disagreed, or was not a closed manifold).
    """

    topology: Topology | None
    source: str  # "construction" or "marching-cubes"
    detail: str = ""

    @property
    def ambiguous(self) -> bool:
        return self.topology is None


@dataclass(eq=False)
class FuzzSurface:
    """One generated surface.

    ``as_tuple()`` gives (name, f, bounding sphere, components, Euler
    characteristic per component), reading the reference (which may run
    marching cubes) on first use; components and Euler are None for an
    ambiguous case.
    """

    family: str
    spec: str
    f: ArrayFunction
    bounding_sphere: tuple[tuple[float, float, float], float]
    #: Smallest feature (local feature size estimate); the BO radius bound is a tenth of it.
    feature: float
    #: Topology from construction, or None: marching cubes decides.
    construction: Topology | None = None
    #: Why the construction holds, or why marching cubes is needed.
    reason: str = ""
    #: The mesher's seed.
    seed: int = 0
    mc_resolutions: tuple[int, int] = (112, 160)
    #: The sphere marching cubes samples (a tight one; see :func:`loosen`).
    mc_sphere: tuple | None = None
    #: Why marching cubes cannot decide this case (then it is ambiguous).
    mc_unreliable: str = ""
    _mc: dict = field(default_factory=dict, repr=False)

    def mc_mesh(self, n: int) -> tuple[np.ndarray, np.ndarray]:
        """Marching cubes of f at ``n`` points per axis (cached)."""
        if n not in self._mc:
            sphere = self.mc_sphere or self.bounding_sphere
            self._mc[n] = marching_cubes_mesh(self.f, sphere, n)
        return self._mc[n]

    @property
    def name(self) -> str:
        digest = hashlib.sha1(self.spec.encode()).hexdigest()[:8]
        return f"{self.family}-{digest}"

    @property
    def radius(self) -> float:
        return float(self.bounding_sphere[1])

    @cached_property
    def reference(self) -> Reference:
        if self.construction is not None:
            return Reference(self.construction, "construction", self.reason)
        if self.mc_unreliable:
            return Reference(None, "marching-cubes", self.mc_unreliable)
        return marching_cubes_reference(self.mc_mesh, self.mc_resolutions)

    @cached_property
    def area(self) -> float:
        """Surface area from a coarse marching cubes (sizes the radius bound)."""
        V, F = self.mc_mesh(64)
        if len(F) == 0:
            return 0.0
        p = V[F]
        cross = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
        return float(0.5 * np.linalg.norm(cross, axis=1).sum())

    def as_tuple(self) -> tuple:
        t = self.reference.topology
        return (
            self.name,
            self.f,
            self.bounding_sphere,
            None if t is None else t.components,
            None if t is None else list(t.euler),
        )

    def surface(self):
        """A fresh :class:`rdmesh.ImplicitSurface` (central-difference gradient)."""
        import rdmesh

        return rdmesh.ImplicitSurface(self.f, self.bounding_sphere, name=self.name)

    def __repr__(self) -> str:
        return self.spec


#: Marching cubes resolutions every builder uses unless told otherwise.
DEFAULT_MC = (112, 160)


def _spec(builder: str, **kwargs: Any) -> str:
    """The call that rebuilds a surface (``mc_resolutions`` only when not the default)."""
    if tuple(kwargs.get("mc_resolutions", DEFAULT_MC)) == DEFAULT_MC:
        kwargs.pop("mc_resolutions", None)

    def fmt(v: Any) -> str:
        if isinstance(v, float | np.floating):
            return repr(float(v))
        if isinstance(v, tuple | list):
            inner = ", ".join(fmt(x) for x in v)
            return f"({inner},)" if len(v) == 1 else f"({inner})"
        return repr(v)

    args = ", ".join(f"{k}={fmt(v)}" for k, v in kwargs.items())
    return f"fz.{builder}({args})"


# -- geometry helpers ---------------------------------------------------------------


def rotation_matrix(rotvec: Sequence[float]) -> np.ndarray:
    """Rodrigues: the rotation by ``|rotvec|`` radians about ``rotvec``."""
    v = np.asarray(rotvec, dtype=float)
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(angle) * K + (1 - math.cos(angle)) * (K @ K)


def _unit(v: Sequence[float]) -> np.ndarray:
    a = np.asarray(v, dtype=float)
    n = np.linalg.norm(a)
    return a / n if n > 1e-12 else np.array([0.0, 0.0, 1.0])


# -- solids of revolution: exact topology from a 1-D function -------------------------


@dataclass
class RevolutionAnalysis:
    """``{rho^2 < q(x)}``: one sphere per interval where ``q > 0``.

    ``intervals`` are the x-ranges of the components; ``feature`` is the
    smallest of the radii of curvature (meridian and parallel) and half the
    gaps between components; ``degenerate`` says a critical value of q is so
    close to 0 that the topology is numerically fragile.
    """

    intervals: list[tuple[float, float]]
    feature: float
    max_radius: float
    degenerate: bool


def analyse_revolution(
    q: Callable[[np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
    lo: float,
    hi: float,
    scale: float,
    samples: int = 40_001,
) -> RevolutionAnalysis:
    """Components and feature size of the solid of revolution ``rho^2 < q(x)``.

    ``q`` returns ``(q, q', q'')`` on an array of x. It must be negative at
    ``lo`` and ``hi``. For the level set ``G(x, rho) = rho^2 - q(x) = 0`` the
    meridian curvature is ``|2 q'^2 - 4 q q''| / (q'^2 + 4q)^1.5`` and the
    parallel one ``2 / sqrt(q'^2 + 4q)``; both stay finite at the poles, where
    ``q`` has simple roots.
    """
    x = np.linspace(lo, hi, samples)
    v, d1, d2 = q(x)
    if v[0] >= 0 or v[-1] >= 0:
        raise ValueError("q must be negative at both ends")
    pos = v > 0
    edges = np.flatnonzero(np.diff(pos.astype(np.int8)))
    starts, ends = edges[0::2], edges[1::2]
    intervals = [(float(x[a]), float(x[b + 1])) for a, b in zip(starts, ends, strict=True)]
    # Critical values of q: a sign change of q' between samples.
    crit = np.flatnonzero(np.sign(d1[:-1]) != np.sign(d1[1:]))
    crit_values = np.minimum(np.abs(v[crit]), np.abs(v[crit + 1]))
    # A neck or gap below 1e-5 x scale is numerically fragile.
    degenerate = bool(np.any(crit_values < 1e-10 * scale**2))
    inside = v >= 0
    denom = d1[inside] ** 2 + 4 * v[inside]
    k1 = np.abs(2 * d1[inside] ** 2 - 4 * v[inside] * d2[inside]) / denom**1.5
    k2 = 2 / np.sqrt(denom)
    feature = float(1.0 / max(k1.max(), k2.max()))
    for (_, b), (a, _) in zip(intervals[:-1], intervals[1:], strict=True):
        feature = min(feature, (a - b) / 2)
    max_radius = float(np.sqrt(v[inside].max()))
    return RevolutionAnalysis(intervals, feature, max_radius, degenerate)


def _axial(p: np.ndarray, centre: np.ndarray, axis: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(x along the axis, rho^2 off it) of points ``p``."""
    d = p - centre
    x = d @ axis
    rho2 = np.maximum(np.einsum("ij,ij->i", d, d) - x * x, 0.0)
    return x, rho2


# -- builders (exact, reproducible from their arguments) ------------------------------


def metaball_chain(
    centre: Sequence[float],
    axis: Sequence[float],
    positions: Sequence[float],
    weights: Sequence[float],
    width: float,
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """Blobs of one width on a line: an exact solid of revolution (module docstring)."""
    c, u = np.asarray(centre, float), _unit(axis)
    t = np.asarray(positions, float)
    w = np.asarray(weights, float)
    s2 = width * width

    def f(p: np.ndarray) -> np.ndarray:
        d = p[:, None, :] - (c + t[:, None] * u)[None]
        return THRESHOLD - np.exp(-np.einsum("ijk,ijk->ij", d, d) / s2) @ w

    def q(x: np.ndarray):
        e = w * np.exp(-((x[:, None] - t) ** 2) / s2)
        g = e.sum(axis=1)
        g1 = (e * (-2 * (x[:, None] - t) / s2)).sum(axis=1)
        g2 = (e * (4 * (x[:, None] - t) ** 2 / s2**2 - 2 / s2)).sum(axis=1)
        return s2 * np.log(g / THRESHOLD), s2 * g1 / g, s2 * (g2 / g - (g1 / g) ** 2)

    reach = width * math.sqrt(math.log(max(w.sum(), 1.0) / THRESHOLD)) + width
    lo, hi = float(t.min() - reach), float(t.max() + reach)
    ana = analyse_revolution(q, lo, hi, width)
    spec = _spec(
        "metaball_chain",
        centre=tuple(centre),
        axis=tuple(axis),
        positions=tuple(positions),
        weights=tuple(weights),
        width=width,
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    half = max(abs(lo), abs(hi))
    radius = 1.05 * math.sqrt(half**2 + ana.max_radius**2) + 0.05
    n = len(ana.intervals)
    construction = None if ana.degenerate or n == 0 else Topology(n, (2,) * n)
    return FuzzSurface(
        "metaball_chain",
        spec,
        f,
        (tuple(float(a) for a in c), radius),
        feature=ana.feature,
        construction=construction,
        reason=f"solid of revolution, {n} intervals of g > T"
        + (" (near-critical: marching cubes)" if ana.degenerate else ""),
        seed=seed,
        mc_resolutions=mc_resolutions,
    )


def _separated_metaballs(
    centres: np.ndarray, weights: np.ndarray, widths: np.ndarray
) -> tuple[bool, float]:
    """Whether a metaball sum is provably one sphere per blob; and its feature size.

    For some ``eps`` (0.01, 1e-3 or 1e-4), let ``m_i`` be blob i and ``rho_i``
    the radius where ``m_i = eps T / n``. If the balls ``B(c_i, rho_i)`` are
    disjoint, a point lies in at most one, and the other blobs add less than
    ``eps T`` there, so ``f > 0`` outside every ball. Inside ball k, ``f < 0``
    where ``m_k >= T`` (radius ``r_k``, which needs ``w_k > T``), and the zero
    set lies in the shell where ``m_k`` is in ``(T (1 - eps), T]``. There the
    radial derivative of ``m_k`` (at least ``2 r_k / s_k^2 T (1 - eps)``)
    beats the gradient of the others (at most ``2 rho_j / s_j^2 eps T / n``
    each, as ``d exp(-d^2/s^2)`` decreases beyond ``s / sqrt 2 < rho_j``), so
    every ray from ``c_k`` crosses the zero set once: a radial graph over the
    sphere of directions, hence a sphere.
    """
    n = len(weights)
    T = THRESHOLD
    if np.any(weights <= T):
        return False, 0.0
    r_in = widths * np.sqrt(np.log(weights / T))  # radius where m_k = T
    dist = np.linalg.norm(centres[:, None] - centres[None], axis=2)
    np.fill_diagonal(dist, np.inf)
    for eps in (1e-2, 1e-3, 1e-4):
        rho = widths * np.sqrt(np.log(n * weights / (eps * T)))
        if np.any(dist < rho[:, None] + rho[None, :]) or np.any(rho / widths <= 2**-0.5):
            continue
        others = float(np.sum(2 * rho / widths**2 * eps * T / n))
        if np.any(2 * r_in / widths**2 * T * (1 - eps) <= others):
            continue
        # Each blob is nearly the sphere of radius r_in: curvature about 1 / r_in.
        gap = float(np.min(dist - r_in[:, None] - r_in[None, :])) if n > 1 else math.inf
        return True, float(min(r_in.min(), gap / 2))
    return False, 0.0


def _small_isolated_blob(
    centres: np.ndarray, weights: np.ndarray, widths: np.ndarray, spacing: float
) -> str:
    """Why marching cubes at ``spacing`` cannot be trusted, or "": a blob far
    from the others (centres 2.5 widths apart) whose own sphere has a radius
    below two grid cells could be missed by both resolutions alike."""
    for k in range(len(weights)):
        if weights[k] <= THRESHOLD:
            continue
        r = widths[k] * math.sqrt(math.log(weights[k] / THRESHOLD))
        d = np.linalg.norm(np.delete(centres, k, axis=0) - centres[k], axis=1)
        apart = bool(np.all(d > 2.5 * (np.delete(widths, k) + widths[k])))
        if apart and r < 2 * spacing:
            return f"blob {k} alone has radius {r:.3g}, below two cells ({spacing:.3g})"
    return ""


def metaball_cloud(
    centres: Sequence[Sequence[float]],
    weights: Sequence[float],
    widths: Sequence[float],
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """A sum of Gaussians anywhere; construction when provably separated."""
    C = np.asarray(centres, float).reshape(-1, 3)
    w = np.asarray(weights, float)
    s = np.asarray(widths, float)
    inv = 1.0 / (s * s)

    def f(p: np.ndarray) -> np.ndarray:
        d = p[:, None, :] - C[None]
        return THRESHOLD - np.exp(-np.einsum("ijk,ijk->ij", d, d) * inv) @ w

    centre = C.mean(axis=0)
    reach = s.max() * math.sqrt(math.log(max(w.sum(), 1.0) / THRESHOLD)) + 0.2 * s.max()
    radius = float(np.linalg.norm(C - centre, axis=1).max() + reach)
    spec = _spec(
        "metaball_cloud",
        centres=tuple(tuple(c) for c in centres),
        weights=tuple(weights),
        widths=tuple(widths),
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    separated, feature = _separated_metaballs(C, w, s)
    surf = FuzzSurface(
        "metaball_cloud",
        spec,
        f,
        (tuple(float(a) for a in centre), radius),
        feature=feature,
        construction=Topology(len(w), (2,) * len(w)) if separated else None,
        reason="provably separated blobs" if separated else "blobs interact: marching cubes",
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    if not separated:
        spacing = 2 * radius / (mc_resolutions[-1] - 1)
        surf.mc_unreliable = _small_isolated_blob(C, w, s, spacing)
        if not surf.mc_unreliable:
            surf.feature = _feature_from_reference(surf)
    return surf


def _ellipsoid(centre, axes, rotation) -> tuple[ArrayFunction, float, float, int]:
    c = np.asarray(centre, float)
    Rt = rotation_matrix(rotation).T
    inv = 1.0 / np.asarray(axes, float)
    a_min, a_max = min(axes), max(axes)

    def f(p: np.ndarray) -> np.ndarray:
        q = ((p - c) @ Rt.T) * inv
        return 0.5 * a_min * (np.einsum("ij,ij->i", q, q) - 1.0)

    # Smallest radius of curvature c^2 / a (semi-axes a >= b >= c).
    return f, a_max, a_min * a_min / a_max, 2


def _torus(centre, major, minor, rotation) -> tuple[ArrayFunction, float, float, int]:
    c = np.asarray(centre, float)
    Rt = rotation_matrix(rotation).T
    R2, r2 = major * major, minor * minor
    scale = 1.0 / (8 * R2 * minor)

    def f(p: np.ndarray) -> np.ndarray:
        q = (p - c) @ Rt.T
        rho2 = q[:, 0] ** 2 + q[:, 1] ** 2
        s = rho2 + q[:, 2] ** 2 + R2 - r2
        return scale * (s * s - 4 * R2 * rho2)

    # The medial axis is the core circle (distance r) and the axis (R - r).
    return f, major + minor, min(minor, major - minor), 0


def primitives(
    parts: Sequence[tuple],
    combine: str = "product",
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """A union of separated ellipsoids and ring tori.

    ``parts`` holds ``("ellipsoid", centre, axes, rotation)`` and
    ``("torus", centre, major, minor, rotation)`` (rotation: an axis-angle
    vector). The parts' bounding spheres must be disjoint.

    Combination:

    - ``"product"``: ``prod_i f_i`` is smooth everywhere and zero exactly on
      the union of the zero sets. Outside every part all factors are positive;
      inside part k only ``f_k`` is negative (the parts are disjoint and none
      holds another, as their bounding spheres are disjoint), so the sign is
      right. The gradient on surface k is ``grad f_k prod_{j != k} f_j``, not
      zero.
    - ``"min"``: ``min_i f_i`` is only C0 where two parts tie. On surface k,
      every other ``f_j`` is positive (the surface lies outside body j), so
      ``f_j > f_k = 0``, and by continuity the crease ``f_j = f_k`` keeps a
      positive distance from the zero set: near it, ``f = f_k`` is smooth.
      Each ``f_i`` is normalised to unit gradient scale on its surface so the
      crease runs near the middle of the gaps, and min is only used when the
      gaps are at least half the parts' size, so the crease lies well away
      from the zero set (the crossing search and the Newton probes near the
      surface never straddle it). A min of smooth functions only has ridges
      (concave kinks), never dips, so it cannot fake a sign-preserving dip.

    The topology is exact: one component per part, chi 2 per ellipsoid and 0
    per ring torus (minor < major).
    """
    if combine not in ("product", "min"):
        raise ValueError(f"combine must be 'product' or 'min', got {combine!r}")
    fs, bounds, centres, features, eulers = [], [], [], [], []
    for part in parts:
        kind = part[0]
        if kind == "ellipsoid":
            fn, bound, feat, chi = _ellipsoid(*part[1:])
        elif kind == "torus":
            if not part[3] < part[2]:
                raise ValueError("a ring torus needs minor < major")
            fn, bound, feat, chi = _torus(*part[1:])
        else:
            raise ValueError(f"unknown part {kind!r}")
        fs.append(fn)
        bounds.append(bound)
        centres.append(np.asarray(part[1], float))
        features.append(feat)
        eulers.append(chi)
    C = np.array(centres)
    B = np.array(bounds)
    dist = np.linalg.norm(C[:, None] - C[None], axis=2)
    np.fill_diagonal(dist, np.inf)
    gaps = dist - B[:, None] - B[None, :]
    min_gap = float(gaps.min()) if len(parts) > 1 else math.inf
    if min_gap <= 0:
        raise ValueError("the parts' bounding spheres overlap")
    if combine == "min" and min_gap < 0.5 * B.max():
        raise ValueError("min needs gaps of at least half the parts' size")

    if combine == "product":

        def f(p: np.ndarray) -> np.ndarray:
            out = fs[0](p)
            for fn in fs[1:]:
                out = out * fn(p)
            return out
    else:

        def f(p: np.ndarray) -> np.ndarray:
            return np.min(np.stack([fn(p) for fn in fs]), axis=0)

    centre = C.mean(axis=0)
    radius = float(np.max(np.linalg.norm(C - centre, axis=1) + B)) * 1.05 + 0.1
    spec = _spec(
        "primitives",
        parts=tuple(parts),
        combine=combine,
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    eul = tuple(sorted(eulers, reverse=True))
    return FuzzSurface(
        "primitives",
        spec,
        f,
        (tuple(float(a) for a in centre), radius),
        feature=float(min(min(features), min_gap / 2)),
        construction=Topology(len(parts), eul),
        reason=f"{len(parts)} disjoint parts combined by {combine}",
        seed=seed,
        mc_resolutions=mc_resolutions,
    )


def perturbed_sphere(
    centre: Sequence[float],
    radius: float,
    rotation: Sequence[float],
    modes: Sequence[tuple] = (),
    bumps: Sequence[tuple] = (),
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """``|p - c| - rho(u)``: a star-shaped radial graph, hence a sphere.

    ``rho(u) = R0 (1 + sum a cos(pi k.u + phase) + sum b exp(-|u - d|^2 / w^2))``
    over the rotated direction ``u``; ``modes`` are ``(k (3 ints), a, phase)``
    and ``bumps`` ``(d (unit), b, w)``. ``sum |a| + sum |b| <= 1/2`` keeps
    ``rho`` in ``[R0/2, 3 R0/2]``. ``f`` is smooth except at the centre,
    which is deep inside (``f = -rho < 0``).
    """
    amp = sum(abs(m[1]) for m in modes) + sum(abs(b[1]) for b in bumps)
    if amp > 0.5 + 1e-12:
        raise ValueError("amplitudes must sum to at most 1/2")
    c = np.asarray(centre, float)
    Rt = rotation_matrix(rotation).T
    K = np.array([m[0] for m in modes], float).reshape(-1, 3)
    A = np.array([m[1] for m in modes], float)
    P = np.array([m[2] for m in modes], float)
    D = np.array([_unit(b[0]) for b in bumps], float).reshape(-1, 3)
    Bb = np.array([b[1] for b in bumps], float)
    W = np.array([b[2] for b in bumps], float)

    def f(p: np.ndarray) -> np.ndarray:
        d = (p - c) @ Rt.T
        r = np.linalg.norm(d, axis=1)
        u = d / np.maximum(r, 1e-300)[:, None]
        rho = 1.0 + np.cos(np.pi * (u @ K.T) + P) @ A
        if len(Bb):
            e = u[:, None, :] - D[None]
            rho = rho + np.exp(-np.einsum("ijk,ijk->ij", e, e) / W**2) @ Bb
        return r - radius * rho

    spec = _spec(
        "perturbed_sphere",
        centre=tuple(centre),
        radius=radius,
        rotation=tuple(rotation),
        modes=tuple(modes),
        bumps=tuple(bumps),
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    surf = FuzzSurface(
        "perturbed_sphere",
        spec,
        f,
        (tuple(float(a) for a in c), 1.6 * radius),
        feature=radius,
        construction=Topology(1, (2,)),
        reason="radial graph with rho > 0",
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    # Feature size: the smallest radius of curvature on the surface, sampled
    # on a Fibonacci set of directions (rho is known exactly there).
    n = 4000
    i = np.arange(n) + 0.5
    z = 1 - 2 * i / n
    phi = np.pi * (1 + 5**0.5) * i
    w = np.column_stack([np.sqrt(1 - z * z) * np.cos(phi), np.sqrt(1 - z * z) * np.sin(phi), z])
    # Along a direction w, f(c + t w) = t - R0 rho, so the surface is at
    # t = R0 rho = 1 - f(c + w).
    pts = c + w * (1.0 - f(c + w))[:, None]
    kappa = max_curvature(f, pts, 1e-4 * radius)
    surf.feature = float(min(radius * 0.5, 1.0 / kappa))
    return surf


def dumbbell(
    centre: Sequence[float],
    axis: Sequence[float],
    length: float,
    bulge: float,
    middle: float,
    neck: float | None = None,
    gap: float | None = None,
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """Two blobs on an axis, joined by a neck or split by a gap.

    The solid ``rho^2 < q(x) = (L^2 - x^2) beta ((x - m)^2 + e)`` with
    ``L = length``, ``beta = bulge``, ``m = middle``. With ``neck`` (> 0),
    ``e = neck^2 / ((L^2 - m^2) beta)``: the radius at ``x = m`` is ``neck``,
    q has simple roots at ``+-L`` only, one sphere. With ``gap`` (> 0),
    ``e = -(gap / 2)^2``: q also has simple roots at ``m +- gap/2`` inside
    ``(-L, L)``, so two spheres exactly ``gap`` apart on the axis (the
    nearest points of the two blobs are at the axis there, as ``q`` grows
    from its roots). ``f = rho^2 - q(x)`` is a quartic polynomial: smooth.
    """
    if (neck is None) == (gap is None):
        raise ValueError("give exactly one of neck and gap")
    L, beta, m = float(length), float(bulge), float(middle)
    if gap is not None:
        if not (abs(m) + gap / 2 < L and gap > 0):
            raise ValueError("the gap must lie inside (-L, L)")
        e = -((gap / 2) ** 2)
    else:
        if not (neck > 0 and abs(m) < L):
            raise ValueError("the neck must be positive, inside (-L, L)")
        e = neck**2 / ((L * L - m * m) * beta)
    # q(x) = beta (L^2 - x^2)((x - m)^2 + e) as a polynomial.
    poly = np.polynomial.Polynomial([L * L, 0, -1]) * np.polynomial.Polynomial(
        [m * m + e, -2 * m, 1]
    )
    poly = poly * beta
    d1, d2 = poly.deriv(1), poly.deriv(2)
    c, u = np.asarray(centre, float), _unit(axis)

    def f(p: np.ndarray) -> np.ndarray:
        x, rho2 = _axial(p, c, u)
        return rho2 - poly(x)

    ana = analyse_revolution(lambda x: (poly(x), d1(x), d2(x)), -1.05 * L, 1.05 * L, L)
    n = len(ana.intervals)
    expected = 1 if neck is not None else 2
    if n != expected or ana.degenerate:
        raise ValueError(
            f"dumbbell gives {n} components (expected {expected}), degenerate={ana.degenerate}"
        )
    kind = "near_touching" if gap is not None else "dumbbell"
    spec = _spec(
        "dumbbell",
        centre=tuple(centre),
        axis=tuple(axis),
        length=length,
        bulge=bulge,
        middle=middle,
        **({"neck": neck} if neck is not None else {"gap": gap}),
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    return FuzzSurface(
        kind,
        spec,
        f,
        (tuple(float(a) for a in c), 1.1 * math.sqrt(L * L + ana.max_radius**2)),
        feature=ana.feature,
        construction=Topology(n, (2,) * n),
        reason=f"solid of revolution, q has {2 * n} simple roots",
        seed=seed,
        mc_resolutions=mc_resolutions,
    )


def sphere_pair(
    centre: Sequence[float],
    axis: Sequence[float],
    radii: tuple[float, float],
    gap: float,
    seed: int = 0,
    mc_resolutions: tuple[int, int] = DEFAULT_MC,
) -> FuzzSurface:
    """Two spheres ``gap`` apart, as the product of their functions (like two_spheres)."""
    c, u = np.asarray(centre, float), _unit(axis)
    r1, r2 = radii
    c1 = c - u * (r1 + gap / 2)
    c2 = c + u * (r2 + gap / 2)

    def f(p: np.ndarray) -> np.ndarray:
        a = p - c1
        b = p - c2
        return (np.einsum("ij,ij->i", a, a) - r1 * r1) * (np.einsum("ij,ij->i", b, b) - r2 * r2)

    spec = _spec(
        "sphere_pair",
        centre=tuple(centre),
        axis=tuple(axis),
        radii=tuple(radii),
        gap=gap,
        seed=seed,
        mc_resolutions=mc_resolutions,
    )
    return FuzzSurface(
        "near_touching",
        spec,
        f,
        (tuple(float(a) for a in c), 1.1 * (max(r1, r2) * 2 + gap / 2) + 0.05),
        feature=min(r1, r2, gap / 2),
        construction=Topology(2, (2, 2)),
        reason="two disjoint spheres, product of their functions",
        seed=seed,
        mc_resolutions=mc_resolutions,
    )


def loosen(surface: FuzzSurface, scale: float) -> FuzzSurface:
    """The same surface in a bounding sphere ``scale`` times larger.

    The seeding grid has a fixed number of cells across the bounding ball, so
    a loose sphere makes small components and thin parts thinner than a cell.
    Marching cubes still samples the tight sphere.
    """
    c, R = surface.bounding_sphere
    return FuzzSurface(
        surface.family,
        f"fz.loosen({surface.spec}, {float(scale)!r})",
        surface.f,
        (c, R * scale),
        feature=surface.feature,
        construction=surface.construction,
        reason=surface.reason,
        seed=surface.seed,
        mc_resolutions=surface.mc_resolutions,
        mc_sphere=surface.mc_sphere or surface.bounding_sphere,
        mc_unreliable=surface.mc_unreliable,
    )


# -- families: draw parameters, build -----------------------------------------------------


def gen_metaball_chain(s: Sampler, prof: Profile) -> FuzzSurface:
    n = s.integer(2, prof.max_blobs)
    width = s.uniform(0.35, 0.6)
    positions, t = [], 0.0
    for _ in range(n):
        positions.append(round(t, 4))
        # Spacings from clearly merged (0.6 s) to clearly separated (3.5 s).
        t += s.uniform(0.6, 3.5) * width
    shift = positions[-1] / 2
    positions = [round(p - shift, 4) for p in positions]
    weights = [s.uniform(0.6, 1.5) for _ in range(n)]
    return metaball_chain(
        centre=(s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3)),
        axis=s.unit_vector(),
        positions=tuple(positions),
        weights=tuple(weights),
        width=width,
        seed=s.integer(0, 999),
        mc_resolutions=prof.mc_resolutions,
    )


def gen_metaball_cloud(s: Sampler, prof: Profile) -> FuzzSurface:
    layout = s.choice(("random", "ring", "satellite"))
    if layout == "ring":
        # Blobs on a circle: a torus when neighbours merge, arcs otherwise.
        n = s.integer(4, max(4, prof.max_blobs + 2))
        ring = s.uniform(0.6, 1.1)
        rot = rotation_matrix(s.rotation())
        centres = []
        for k in range(n):
            a = 2 * math.pi * k / n + s.uniform(-0.2, 0.2)
            local = np.array([ring * math.cos(a), ring * math.sin(a), s.uniform(-0.1, 0.1)])
            centres.append(tuple(round(float(v), 4) for v in rot @ local))
    else:
        n = s.integer(2, prof.max_blobs)
        centres = [
            (s.uniform(-0.9, 0.9), s.uniform(-0.9, 0.9), s.uniform(-0.9, 0.9)) for _ in range(n)
        ]
    weights = [s.uniform(0.7, 1.5) for _ in range(n)]
    widths = [s.uniform(0.3, 0.6) for _ in range(n)]
    if layout == "satellite":
        # The last blob is weak and apart: alone, a small sphere of radius
        # about s sqrt(x) for w = T (1 + x), well away from the others.
        weights[-1] = round(THRESHOLD * (1 + s.log_uniform(prof.min_satellite, 0.3)), 4)
        widths[-1] = s.uniform(0.3, 0.5)
        main = np.array(centres[:-1])
        reach = float(np.linalg.norm(main, axis=1).max()) + max(widths[:-1]) * 2.2
        away = np.array(s.unit_vector()) * (reach + s.uniform(0.3, 1.0))
        centres[-1] = tuple(round(float(v), 4) for v in away)
    elif s.integer(0, 2) == 0:
        # A weak blob among the others: a small bump or a thin bridge.
        weights[-1] = round(THRESHOLD * (1 + s.log_uniform(0.01, 0.3)), 4)
    return metaball_cloud(
        centres=tuple(centres),
        weights=tuple(weights),
        widths=tuple(widths),
        seed=s.integer(0, 999),
        mc_resolutions=prof.mc_resolutions,
    )


def gen_primitives(s: Sampler, prof: Profile) -> FuzzSurface:
    combine = s.choice(("product", "min"))
    n = s.integer(1 if combine == "product" else 2, prof.max_parts)
    shapes = []
    small = s.integer(0, n) if s.integer(0, 1) == 0 else -1
    for i in range(n):
        if s.choice(("ellipsoid", "torus")) == "ellipsoid" or i == small:
            # Now and then a part is a small ellipsoid (a small component).
            a = s.log_uniform(prof.min_part, 0.3) if i == small else s.uniform(0.5, 1.0)
            axes = (a, round(a * s.uniform(0.6, 1.0), 4), round(a * s.uniform(0.5, 1.0), 4))
            shapes.append(("ellipsoid", axes, a))
        else:
            major = s.uniform(0.5, 0.9)
            minor = round(major * s.uniform(0.25, 0.5), 4)
            shapes.append(("torus", (major, minor), major + minor))
    min_gap = 0.5 * max(b for *_, b in shapes) if combine == "min" else prof.min_gap
    parts, placed = [], []
    for kind, dims, bound in shapes:
        gap = s.uniform(min_gap, min_gap + 0.6)
        if placed:
            # Next to the previous part, pushed out until it clears all parts.
            direction = np.array(s.unit_vector())
            pc, pb = placed[-1]
            dist = pb + bound + gap
            centre = pc + direction * dist
            while any(np.linalg.norm(centre - q) < qb + bound + gap for q, qb in placed):
                dist *= 1.1
                centre = pc + direction * dist
        else:
            centre = np.zeros(3)
        centre = np.round(centre, 4)
        # Rounding must not close a gap: give it back a margin.
        while any(np.linalg.norm(centre - q) <= qb + bound + 0.99 * gap for q, qb in placed):
            centre = np.round(centre * 1.01, 4)
        placed.append((centre, bound))
        rot = s.rotation()
        c = tuple(float(v) for v in centre)
        if kind == "ellipsoid":
            parts.append(("ellipsoid", c, dims, rot))
        else:
            parts.append(("torus", c, dims[0], dims[1], rot))
    return primitives(
        tuple(parts), combine, seed=s.integer(0, 999), mc_resolutions=prof.mc_resolutions
    )


def gen_perturbed_sphere(s: Sampler, prof: Profile) -> FuzzSurface:
    budget = s.uniform(0.05, 0.35 if prof is FAST else 0.5)
    n_modes = s.integer(0, 3)
    n_bumps = s.integer(0 if n_modes else 1, 3)
    shares = [s.uniform(0.2, 1.0) for _ in range(n_modes + n_bumps)]
    total = sum(shares)
    top = 3 if prof is FAST else 5
    modes, bumps = [], []
    for i in range(n_modes):
        k = (s.integer(-top, top), s.integer(-top, top), s.integer(-top, top))
        if k == (0, 0, 0):
            k = (1, 0, 0)
        # Higher frequencies get smaller amplitudes (curvature ~ a k^2).
        kk = max(1.0, float(np.dot(k, k)))
        a = round(budget * shares[i] / total / math.sqrt(kk), 4)
        modes.append((k, a * s.choice((1, -1)), s.uniform(0.0, 2 * math.pi)))
    for i in range(n_bumps):
        w = s.uniform(0.3, 0.8)
        b = round(budget * shares[n_modes + i] / total * min(1.0, 2 * w), 4)
        bumps.append((s.unit_vector(), b * s.choice((1, -1)), w))
    return perturbed_sphere(
        centre=(s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3)),
        radius=s.uniform(0.7, 1.3),
        rotation=s.rotation(),
        modes=tuple(modes),
        bumps=tuple(bumps),
        seed=s.integer(0, 999),
        mc_resolutions=prof.mc_resolutions,
    )


def _bulge(length: float, blob_radius: float) -> float:
    """beta giving blobs of about ``blob_radius``: max of (L^2 - x^2) x^2 beta
    is beta L^4 / 4."""
    return round((2 * blob_radius / length**2) ** 2, 4)


def gen_dumbbell(s: Sampler, prof: Profile) -> FuzzSurface:
    length = s.uniform(1.0, 1.6)
    bulge = _bulge(length, s.uniform(0.45, 0.9))
    middle = round(length * s.uniform(-0.3, 0.3), 4)
    neck = s.log_uniform(prof.min_neck, 0.4)
    return dumbbell(
        centre=(s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3)),
        axis=s.unit_vector(),
        length=length,
        bulge=bulge,
        middle=middle,
        neck=neck,
        seed=s.integer(0, 999),
        mc_resolutions=prof.mc_resolutions,
    )


def gen_near_touching(s: Sampler, prof: Profile) -> FuzzSurface:
    centre = (s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3), s.uniform(-0.3, 0.3))
    axis = s.unit_vector()
    gap = s.log_uniform(prof.min_gap, 0.3)
    seed = s.integer(0, 999)
    if s.choice(("dumbbell", "spheres")) == "dumbbell":
        length = s.uniform(1.0, 1.6)
        middle = round(length * s.uniform(-0.3, 0.3), 4)
        return dumbbell(
            centre=centre,
            axis=axis,
            length=length,
            bulge=_bulge(length, s.uniform(0.45, 0.9)),
            middle=middle,
            gap=gap,
            seed=seed,
            mc_resolutions=prof.mc_resolutions,
        )
    return sphere_pair(
        centre=centre,
        axis=axis,
        radii=(s.uniform(0.4, 1.0), s.uniform(0.4, 1.0)),
        gap=gap,
        seed=seed,
        mc_resolutions=prof.mc_resolutions,
    )


FAMILIES: dict[str, Callable[[Sampler, Profile], FuzzSurface]] = {
    "metaball_chain": gen_metaball_chain,
    "metaball_cloud": gen_metaball_cloud,
    "primitives": gen_primitives,
    "perturbed_sphere": gen_perturbed_sphere,
    "dumbbell": gen_dumbbell,
    "near_touching": gen_near_touching,
}


def draw_surface(s: Sampler, family: str, profile: Profile) -> FuzzSurface:
    """One surface of ``family``; one in three gets a loose bounding sphere."""
    surf = FAMILIES[family](s, profile)
    if s.integer(0, 2) == 0:
        surf = loosen(surf, s.log_uniform(1.2, 3.0))
    return surf


def generate(family: str, rng: np.random.Generator, profile: Profile = FAST) -> FuzzSurface:
    """One surface of ``family`` drawn with a numpy generator."""
    return draw_surface(RngSampler(rng), family, profile)


def strategy(family: str, profile: Profile = FAST):
    """A hypothesis strategy of surfaces of ``family``."""
    from hypothesis import strategies as st

    @st.composite
    def draw(draw_fn):
        return draw_surface(HypothesisSampler(draw_fn), family, profile)

    return draw()


def surfaces(profile: Profile = FAST):
    """A hypothesis strategy over every family."""
    from hypothesis import strategies as st

    return st.one_of(*(strategy(name, profile) for name in FAMILIES))


# -- reference topology: marching cubes at two resolutions ------------------------------


def _grid_values(
    f: ArrayFunction, bounding_sphere, n: int
) -> tuple[np.ndarray, float, np.ndarray]:
    """f on an n^3 grid over the bounding cube, shifted by an irrational fraction
    of a cell (so f is almost never exactly 0 at a grid point), padded by a
    positive layer (so every surface closes)."""
    c, R = np.asarray(bounding_sphere[0], float), float(bounding_sphere[1])
    h = 2 * R / (n - 1)
    origin = c - R + h * (math.sqrt(2) - 1) * np.array([0.3, 0.5, 0.7])
    axis = np.arange(n) * h
    vol = np.empty((n, n, n))
    yy, zz = np.meshgrid(axis, axis, indexing="ij")
    plane = np.column_stack([np.zeros(n * n), yy.ravel(), zz.ravel()]) + origin
    for i in range(n):
        pts = plane.copy()
        pts[:, 0] += axis[i]
        vol[i] = f(pts).reshape(n, n)
    pad = float(np.abs(vol).max()) + 1.0
    return np.pad(vol, 1, constant_values=pad), h, origin - h


def marching_cubes_mesh(
    f: ArrayFunction, bounding_sphere, n: int
) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of ``f = 0`` by skimage's (Lewiner) marching cubes."""
    from skimage.measure import marching_cubes

    vol, h, origin = _grid_values(f, bounding_sphere, n)
    if vol.min() >= 0:
        return np.zeros((0, 3)), np.zeros((0, 3), np.int64)
    verts, faces, _, _ = marching_cubes(vol, level=0.0, spacing=(h, h, h), allow_degenerate=False)
    return verts + origin, faces.astype(np.int64)


def mesh_topology(faces: np.ndarray, n_vertices: int) -> Topology:
    """Components (faces sharing vertices) and V - E + F of each, largest first."""
    F = np.asarray(faces, dtype=np.int64)
    if len(F) == 0:
        return Topology(0, ())
    nf = len(F)
    rows = np.repeat(np.arange(nf), 3)
    g = coo_matrix((np.ones(3 * nf), (rows, F.ravel() + nf)), shape=(nf + n_vertices,) * 2)
    _, label = connected_components(g, directed=False)
    _, face_label = np.unique(label[:nf], return_inverse=True)
    k = int(face_label.max()) + 1
    # Per component: distinct vertices, distinct edges, faces.
    vlab = np.full(n_vertices, -1)
    vlab[F.ravel()] = np.repeat(face_label, 3)
    V = np.bincount(vlab[vlab >= 0], minlength=k)
    edges = np.unique(
        np.sort(np.concatenate([F[:, [0, 1]], F[:, [1, 2]], F[:, [2, 0]]]), 1), axis=0
    )
    E = np.bincount(vlab[edges[:, 0]], minlength=k)
    Fc = np.bincount(face_label, minlength=k)
    chi = (V - E + Fc).tolist()
    return Topology(k, tuple(sorted((int(c) for c in chi), reverse=True)))


def marching_cubes_reference(
    mc_mesh: Callable[[int], tuple[np.ndarray, np.ndarray]], resolutions: tuple[int, int]
) -> Reference:
    """Topology by marching cubes at two resolutions (``mc_mesh(n)`` gives the
    mesh); None (ambiguous) unless both are closed manifolds and agree."""
    found = []
    for n in resolutions:
        V, F = mc_mesh(n)
        problems = closed_manifold_problems(F, len(V)) if len(F) else ["empty"]
        found.append(None if problems else mesh_topology(F, len(V)))
    detail = f"marching cubes at {resolutions}: {found}"
    if found[0] is None or found[0] != found[1]:
        return Reference(None, "marching-cubes", detail)
    return Reference(found[0], "marching-cubes", detail)


def max_curvature(f: ArrayFunction, points: np.ndarray, h: float) -> float:
    """Largest |principal curvature| of the level set of f through ``points``,
    from central-difference gradient and Hessian."""
    p = np.asarray(points, float)
    E = np.eye(3) * h

    def grad(x: np.ndarray) -> np.ndarray:
        return np.column_stack([(f(x + E[k]) - f(x - E[k])) / (2 * h) for k in range(3)])

    g = grad(p)
    H = np.stack([(grad(p + E[k]) - grad(p - E[k])) / (2 * h) for k in range(3)], axis=1)
    H = 0.5 * (H + np.swapaxes(H, 1, 2))
    gn = np.linalg.norm(g, axis=1)
    ok = gn > 0
    n = g[ok] / gn[ok, None]
    P = np.eye(3)[None] - n[:, :, None] * n[:, None, :]
    S = P @ H[ok] @ P / gn[ok, None, None]
    return float(np.abs(np.linalg.eigvalsh(S)).max())


def _feature_from_reference(surf: FuzzSurface) -> float:
    """Feature size of a marching-cubes case: the smallest radius of curvature
    at the finer grid's vertices, and half the distance between components."""
    n = surf.mc_resolutions[-1]
    V, F = surf.mc_mesh(n)
    if len(F) == 0:
        return surf.radius / 10
    rng = np.random.default_rng(0)
    pick = rng.choice(len(V), size=min(len(V), 4000), replace=False)
    feature = 1.0 / max_curvature(surf.f, V[pick], 1e-4 * surf.radius)
    nf = len(F)
    rows = np.repeat(np.arange(nf), 3)
    g = coo_matrix((np.ones(3 * nf), (rows, F.ravel() + nf)), shape=(nf + len(V),) * 2)
    k, label = connected_components(g, directed=False)
    vl = label[nf:]
    comps = np.unique(label[:nf])
    if len(comps) > 1:
        for a in comps:
            mine = vl == a
            others = np.isin(vl, comps) & ~mine
            d, _ = cKDTree(V[others]).query(V[mine])
            feature = min(feature, float(d.min()) / 2)
    return float(feature)


# -- running the mesher and judging the result -------------------------------------------------

METHODS = ("boissonnat-oudot", "topological-ball")
ANGLE_BOUND = 30.0
#: A vertex is on the surface when |f| / |grad f| is below this, times R.
ON_SURFACE_TOL = 1e-6


class Hang(BaseException):  # noqa: N818 - a BaseException so library code cannot catch it
    """The watchdog fired: the run overshot its time limit by the hang factor."""


@dataclass
class Outcome:
    """What one run of :func:`rdmesh.mesh_surface` did, and what was checked."""

    surface: str
    spec: str
    method: str
    radius_bound: float | None
    radius_clipped: bool
    max_vertices: int
    time_limit: float
    #: "ok", "budget" (BudgetExceeded), "error" (a clear rdmesh error or
    #: ValueError), "crash" (anything else), "hang" (the watchdog fired).
    status: str
    seconds: float
    exception: str = ""
    reference: Topology | None = None
    reference_source: str = ""
    vertices: int = 0
    complete: bool = False
    closed_manifold: bool = False
    manifold_problems: list[str] = field(default_factory=list)
    topology: Topology | None = None
    certified: bool = False
    min_angle: float = float("nan")
    #: max |f| / |grad f| over the vertices, divided by R.
    surface_distance: float = float("nan")
    #: max surface Delaunay ball radius / radius bound (Boissonnat-Oudot).
    ball_ratio: float = float("nan")
    unresolved: int = 0
    budget_mesh_ok: bool = True

    @property
    def topology_correct(self) -> bool | None:
        """None when there is no reference or no mesh to compare."""
        if self.reference is None or self.topology is None:
            return None
        return self.topology == self.reference

    def failures(self) -> list[str]:
        """The properties the fuzz suite asserts that this run violates."""
        out = []
        if self.status == "crash":
            out.append(f"unexpected exception: {self.exception}")
        if self.status == "hang":
            out.append(f"no result after the watchdog ({self.exception})")
        if self.status == "budget" and not self.budget_mesh_ok:
            out.append(
                f"BudgetExceeded without a partial mesh flagged incomplete: {self.exception}"
            )
        if self.status == "ok":
            # Documented: a mesh comes back incomplete (no exception) only with
            # unresolved points, and only a complete mesh promises a closed manifold.
            if not self.complete and self.unresolved == 0:
                out.append("returned a mesh flagged incomplete with nothing unresolved")
            if self.complete and not self.closed_manifold:
                out.append(f"complete but not a closed manifold: {self.manifold_problems}")
            if self.certified and self.topology_correct is False:
                out.append(
                    f"topology certified but wrong: {self.topology} != reference {self.reference}"
                )
            if self.complete and not self.min_angle >= ANGLE_BOUND - 1e-6:
                out.append(f"min angle {self.min_angle:.6f} < {ANGLE_BOUND}")
            if not self.surface_distance <= ON_SURFACE_TOL:
                out.append(
                    f"vertices off the surface: |f|/|grad f| = {self.surface_distance:.3g} R"
                )
            if self.complete and self.radius_bound is not None and not self.ball_ratio <= 1 + 1e-9:
                out.append(f"surface Delaunay ball {self.ball_ratio:.6f} x the radius bound")
        return out

    def as_dict(self) -> dict[str, Any]:
        d = {k: v for k, v in self.__dict__.items() if k not in ("reference", "topology")}
        for k in ("reference", "topology"):
            t = getattr(self, k)
            d[k] = None if t is None else {"components": t.components, "euler": list(t.euler)}
        d["category"] = classify(self)
        return d


def radius_bound_for(surf: FuzzSurface, prof: Profile) -> tuple[float, bool]:
    """Boissonnat-Oudot's radius bound: a tenth of the feature, or the size that
    gives about ``prof.target_vertices`` vertices if that is larger (clipped)."""
    tenth = surf.feature / 10
    # About 1.3 r^2 of area per vertex at 30 degrees (measured on spheres).
    affordable = math.sqrt(max(surf.area, 1e-12) / (1.3 * prof.target_vertices))
    return (tenth, False) if tenth >= affordable else (affordable, True)


def central_gradient(f: ArrayFunction, p: np.ndarray, h: float) -> np.ndarray:
    E = np.eye(3) * h
    return np.column_stack([(f(p + E[k]) - f(p - E[k])) / (2 * h) for k in range(3)])


def _watchdog(seconds: float):
    """Raise :class:`Hang` in the main thread after ``seconds`` (no-op elsewhere)."""

    class Guard:
        def __enter__(self):
            self.armed = threading.current_thread() is threading.main_thread() and hasattr(
                signal, "setitimer"
            )
            if self.armed:

                def fire(signum, frame):
                    raise Hang(f"still running after {seconds:g} s")

                self.old = signal.signal(signal.SIGALRM, fire)
                signal.setitimer(signal.ITIMER_REAL, seconds)
            return self

        def __exit__(self, *exc):
            if self.armed:
                signal.setitimer(signal.ITIMER_REAL, 0)
                signal.signal(signal.SIGALRM, self.old)
            return False

    return Guard()


#: The watchdog fires at this multiple of the time limit (plus a minute).
HANG_FACTOR = 5.0


def run_method(surf: FuzzSurface, method: str, prof: Profile) -> Outcome:
    """Mesh ``surf`` with ``method`` under the profile's budgets, and measure."""
    import rdmesh

    if method == "boissonnat-oudot":
        rb, clipped = radius_bound_for(surf, prof)
    else:
        rb, clipped = None, False
    ref = surf.reference
    out = Outcome(
        surface=surf.name,
        spec=surf.spec,
        method=method,
        radius_bound=rb,
        radius_clipped=clipped,
        max_vertices=prof.max_vertices,
        time_limit=prof.time_limit,
        status="ok",
        seconds=0.0,
        reference=ref.topology,
        reference_source=ref.source,
    )
    mesh = None
    t0 = time.perf_counter()
    try:
        with _watchdog(HANG_FACTOR * prof.time_limit + 60):
            mesh = rdmesh.mesh_surface(
                surf.surface(),
                angle_bound=ANGLE_BOUND,
                radius_bound=rb,
                method=method,
                seed=surf.seed,
                max_vertices=prof.max_vertices,
                time_limit=prof.time_limit,
            )
    except Hang as exc:
        out.status, out.exception = "hang", str(exc)
    except rdmesh.BudgetExceeded as exc:
        out.status, out.exception = "budget", f"{type(exc).__name__}: {exc}"
        out.budget_mesh_ok = isinstance(exc.mesh, rdmesh.SurfaceMesh) and not exc.mesh.complete
        mesh = exc.mesh if isinstance(exc.mesh, rdmesh.SurfaceMesh) else None
    except (rdmesh.RdmeshError, ValueError) as exc:
        out.status, out.exception = "error", f"{type(exc).__name__}: {exc}"
    except Exception as exc:  # noqa: BLE001 - a crash is what the fuzzer looks for
        out.status, out.exception = "crash", f"{type(exc).__name__}: {exc}"
    out.seconds = time.perf_counter() - t0
    if mesh is not None:
        _measure(out, surf, mesh)
    return out


def _measure(out: Outcome, surf: FuzzSurface, mesh) -> None:
    V, F = np.asarray(mesh.vertices), np.asarray(mesh.faces)
    out.vertices = len(V)
    out.complete = bool(mesh.complete)
    out.certified = bool(mesh.topology_certified)
    out.unresolved = len(mesh.unresolved)
    out.manifold_problems = closed_manifold_problems(F, len(V)) if len(F) else ["no faces"]
    out.closed_manifold = not out.manifold_problems
    out.topology = mesh_topology(F, len(V))
    if len(F):
        p = V[F]
        ang = []
        for i in range(3):
            a = p[:, (i + 1) % 3] - p[:, i]
            b = p[:, (i + 2) % 3] - p[:, i]
            cos = np.einsum("ij,ij->i", a, b) / (
                np.linalg.norm(a, axis=1) * np.linalg.norm(b, axis=1)
            )
            ang.append(np.degrees(np.arccos(np.clip(cos, -1, 1))))
        out.min_angle = float(np.min(ang))
        if out.radius_bound is not None:
            r = np.linalg.norm(np.asarray(mesh.facet_centres) - V[F[:, 0]], axis=1)
            out.ball_ratio = float(r.max() / out.radius_bound)
    if len(V):
        R = surf.radius
        g = central_gradient(surf.f, V, 1e-6 * R)
        dist = np.abs(surf.f(V)) / np.maximum(np.linalg.norm(g, axis=1), 1e-300)
        out.surface_distance = float(dist.max() / R)


def certified_disagreement(outcomes: Sequence[Outcome]) -> bool:
    """Two runs on one surface that both certify their topology, yet differ:
    one certificate is false, whatever the reference (even an ambiguous one)."""
    certified = {o.topology for o in outcomes if o.status == "ok" and o.certified}
    return len(certified) > 1


def classify(o: Outcome) -> str:
    """One category per run, in the order the fuzz report lists them.

    ``crash``, ``hang``, ``budget``, ``error`` (a clear exception on a valid
    surface), then for finished meshes ``ambiguous`` (no reference),
    ``correct`` (closed manifold with the reference topology), ``wrong-flagged``
    (wrong, not certified) or ``wrong-certified`` (wrong and certified).
    """
    if o.status in ("crash", "hang", "budget", "error"):
        return o.status
    if o.reference is None:
        return "ambiguous"
    if o.closed_manifold and o.topology == o.reference:
        return "correct"
    return "wrong-certified" if o.certified else "wrong-flagged"
