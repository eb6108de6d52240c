"""Property-based fuzzing of mesh_surface on random surfaces of known topology.

Each generated surface (tests/fuzz_surfaces.py) is meshed with both methods:
Boissonnat-Oudot with a radius bound of about a tenth of its smallest feature
(clipped so that a case stays near the profile's target size), and the
topological-ball method with no size bound. Every run has a vertex budget
and a time limit as hang guards, and must:

- not crash (only rdmesh errors and ValueError are clear exceptions) and not
  hang (a watchdog at several times the time limit);
- raise BudgetExceeded only with its partial mesh, flagged incomplete;
- when it returns, return a complete closed manifold whose vertices lie on the
  surface, whose smallest angle meets the angle bound and (Boissonnat-Oudot)
  whose surface Delaunay balls meet the radius bound;
- when it certifies its topology, have the reference topology (components,
  and Euler characteristics as a sorted list), and the two methods may not
  certify different topologies (this needs no reference).

Generation is derandomized, so every run draws the same surfaces. The default
run uses the small profile (a few examples per family) and the regressions:
about three minutes on a 2-core machine. The larger profile is marked slow
and, as it takes several times longer, runs only when asked for:
``pytest -m slow tests/test_fuzz.py`` or ``RDMESH_FUZZ_LARGE=1``. Cases that
fuzzing found failing are kept in ``REGRESSIONS`` below, marked
xfail(strict) until the library is fixed.
"""

from __future__ import annotations

import fuzz_surfaces as fz
import numpy as np
import pytest
import rdmesh

pytest.importorskip("hypothesis")
pytest.importorskip("skimage")

from hypothesis import HealthCheck, Phase, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

#: Examples per family: the default run and the slow one.
FAST_EXAMPLES = 3
SLOW_EXAMPLES = 12

_SETTINGS = dict(
    deadline=None,
    derandomize=True,
    database=None,
    # No shrinking: every shrink step meshes again (seconds each), and the
    # failing surface is printed with its spec anyway.
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)


def _explain(surf: fz.FuzzSurface, out: fz.Outcome) -> str:
    return (
        f"{out.method} on {surf.name}: {out.failures()}\n"
        f"  status {out.status} {out.exception}\n"
        f"  reference {out.reference} ({surf.reference.source}), got {out.topology}, "
        f"certified {out.certified}, {out.vertices} vertices\n"
        f"  reproduce: import fuzz_surfaces as fz; s = {surf.spec}\n"
        f"  rdmesh.mesh_surface(s.surface(), method={out.method!r}, "
        f"radius_bound={out.radius_bound!r}, seed={surf.seed}, "
        f"max_vertices={out.max_vertices}, time_limit={out.time_limit})"
    )


def check_surface(surf: fz.FuzzSurface, profile: fz.Profile) -> list[fz.Outcome]:
    """Mesh ``surf`` with both methods and assert every fuzzed property."""
    outcomes = []
    for method in fz.METHODS:
        out = fz.run_method(surf, method, profile)
        assert out.failures() == [], _explain(surf, out)
        # What failures() checks, spelled out where it matters most.
        assert out.status in ("ok", "budget", "error"), _explain(surf, out)
        if out.status == "ok":
            assert out.complete and out.closed_manifold, _explain(surf, out)
            if out.certified and out.reference is not None:
                assert out.topology == out.reference, _explain(surf, out)
        outcomes.append(out)
    # Two certificates of different topologies cannot both hold.
    assert not fz.certified_disagreement(outcomes), "\n".join(_explain(surf, o) for o in outcomes)
    return outcomes


#: skipif condition of the large profile (pytest evaluates it with ``os`` and
#: ``config``): it runs under ``-m slow`` (not ``not slow``) or RDMESH_FUZZ_LARGE=1.
LARGE_NOT_REQUESTED = (
    "os.environ.get('RDMESH_FUZZ_LARGE') != '1' and ("
    "'slow' not in (config.getoption('markexpr') or '') "
    "or 'not slow' in config.getoption('markexpr'))"
)


# -- the fuzz tests ------------------------------------------------------------------


@pytest.mark.parametrize("family", list(fz.FAMILIES))
@settings(max_examples=FAST_EXAMPLES, **_SETTINGS)
@given(data=st.data())
def test_fuzz(family, data):
    surf = data.draw(fz.strategy(family, fz.FAST), label="surface")
    check_surface(surf, fz.FAST)


@pytest.mark.slow
@pytest.mark.skipif(
    LARGE_NOT_REQUESTED, reason="large fuzz profile: -m slow or RDMESH_FUZZ_LARGE=1"
)
@pytest.mark.parametrize("family", list(fz.FAMILIES))
@settings(max_examples=SLOW_EXAMPLES, **_SETTINGS)
@given(data=st.data())
def test_fuzz_large(family, data):
    surf = data.draw(fz.strategy(family, fz.LARGE), label="surface")
    check_surface(surf, fz.LARGE)


# -- the generators themselves ---------------------------------------------------------

CONSTRUCTION_FAMILIES = ["metaball_chain", "primitives", "perturbed_sphere", "dumbbell"]


@pytest.mark.parametrize("family", CONSTRUCTION_FAMILIES + ["near_touching"])
@settings(max_examples=2, **_SETTINGS)
@given(data=st.data())
def test_construction_agrees_with_marching_cubes(family, data):
    """The topology each family claims by construction is what marching cubes
    sees; at the small profile's sizes marching cubes is never ambiguous."""
    surf = data.draw(fz.strategy(family, fz.FAST), label="surface")
    claimed = surf.reference
    assert claimed.source == "construction" and claimed.topology is not None
    seen = fz.marching_cubes_reference(surf.mc_mesh, surf.mc_resolutions)
    assert seen.topology == claimed.topology, (surf.spec, seen.detail)


def test_spec_rebuilds_the_surface():
    """A case's spec (what a regression example pastes) rebuilds it exactly."""
    rng = np.random.default_rng(3)
    pts = rng.uniform(-2, 2, size=(500, 3))
    for family in fz.FAMILIES:
        surf = fz.generate(family, np.random.default_rng([5, len(family)]))
        again = eval(surf.spec, {"fz": fz})  # noqa: S307 - our own generated text
        assert again.spec == surf.spec
        assert again.bounding_sphere == surf.bounding_sphere
        assert again.seed == surf.seed
        assert np.array_equal(again.f(pts), surf.f(pts))
        # The same draws give the same surface.
        assert fz.generate(family, np.random.default_rng([5, len(family)])).spec == surf.spec


def test_generated_surfaces_are_valid():
    """f is positive on the bounding sphere, its zero set is not empty, and the
    feature size is positive and below the bounding radius: valid input."""
    rng = np.random.default_rng(0)
    d = rng.normal(size=(4000, 3))
    d /= np.linalg.norm(d, axis=1)[:, None]
    for family in fz.FAMILIES:
        for i in range(3):
            surf = fz.generate(family, np.random.default_rng([9, i, len(family)]))
            c, R = np.asarray(surf.bounding_sphere[0]), surf.bounding_sphere[1]
            assert np.all(surf.f(c + R * d) > 0), surf.spec
            V, _ = surf.mc_mesh(64)
            assert len(V) > 0, surf.spec
            assert 0 < surf.feature < R, surf.spec


def test_revolution_analysis_on_a_sphere_and_two():
    """q = 1 - x^2 is the unit sphere (curvature 1); q = (1 - x^2)(x^2 - 0.04)
    is two blobs 0.4 apart."""
    ana = fz.analyse_revolution(lambda x: (1 - x * x, -2 * x, -2 + 0 * x), -1.5, 1.5, 1.0)
    assert len(ana.intervals) == 1 and not ana.degenerate
    assert ana.feature == pytest.approx(1.0, rel=1e-6)
    assert ana.max_radius == pytest.approx(1.0, rel=1e-6)
    p = np.polynomial.Polynomial([-0.04, 0, 1.04, 0, -1])
    d1, d2 = p.deriv(1), p.deriv(2)
    ana = fz.analyse_revolution(lambda x: (p(x), d1(x), d2(x)), -1.5, 1.5, 1.0)
    assert len(ana.intervals) == 2
    assert ana.feature <= 0.2 + 1e-3  # half the gap
    assert ana.intervals[1][0] - ana.intervals[0][1] == pytest.approx(0.4, abs=1e-3)


def test_mesh_topology_counts():
    """Independent Euler counts on known meshes: a tetrahedron (chi 2), two of
    them (two components), and a torus from marching cubes (chi 0)."""
    tet = np.array([[0, 1, 2], [0, 3, 1], [1, 3, 2], [0, 2, 3]])
    assert fz.mesh_topology(tet, 4) == fz.Topology(1, (2,))
    assert fz.mesh_topology(np.vstack([tet, tet + 4]), 8) == fz.Topology(2, (2, 2))
    torus = fz.primitives((("torus", (0.0, 0.0, 0.0), 1.0, 0.4, (0.3, 0.1, 0.0)),))
    ref = fz.marching_cubes_reference(torus.mc_mesh, (64, 96))
    assert ref.topology == fz.Topology(1, (0,))


def test_checks_can_fail():
    """Break a good mesh in the ways the fuzz suite looks for; each is caught."""
    surf = fz.perturbed_sphere(
        (0.0, 0.0, 0.0), 1.0, (0.0, 0.0, 0.0), modes=(((1, 2, 0), 0.1, 0.3),)
    )
    mesh = rdmesh.mesh_surface(surf.surface(), radius_bound=0.15, seed=1)

    sphere = fz.Topology(1, (2,))

    def outcome(m, reference=sphere, radius_bound=0.15):
        out = fz.Outcome(
            surface=surf.name,
            spec=surf.spec,
            method="boissonnat-oudot",
            radius_bound=radius_bound,
            radius_clipped=False,
            max_vertices=0,
            time_limit=0.0,
            status="ok",
            seconds=0.0,
            reference=reference,
        )
        fz._measure(out, surf, m)
        return out

    good = outcome(mesh)
    assert good.failures() == [] and fz.classify(good) == "correct"
    assert mesh.report["tbp_holds"] and not mesh.topology_certified
    # A wrong reference with a mesh that claims a certificate: "certified but wrong".
    claimed = rdmesh.SurfaceMesh(mesh.vertices, mesh.faces, mesh.facet_centres)
    claimed.report = {**mesh.report, "certified": True}
    wrong = outcome(claimed, reference=fz.Topology(1, (0,)))
    assert fz.classify(wrong) == "wrong-certified"
    assert any("certified but wrong" in s for s in wrong.failures())
    # Vertices moved off the surface.
    moved = rdmesh.SurfaceMesh(mesh.vertices * 1.001, mesh.faces, mesh.facet_centres)
    moved.report = mesh.report
    assert any("off the surface" in s for s in outcome(moved).failures())
    # A missing face: not a closed manifold.
    holed = rdmesh.SurfaceMesh(mesh.vertices, mesh.faces[1:], mesh.facet_centres[1:])
    holed.report = mesh.report
    assert any("closed manifold" in s for s in outcome(holed).failures())
    # Incomplete with nothing unresolved: not a documented outcome.
    unexplained = rdmesh.SurfaceMesh(mesh.vertices, mesh.faces, mesh.facet_centres)
    unexplained.complete = False
    assert any("incomplete" in s for s in outcome(unexplained).failures())
    # A radius bound the mesh does not meet.
    assert any("ball" in s for s in outcome(mesh, radius_bound=0.05).failures())
    # An angle bound the mesh does not meet: squash it flat along z.
    flat = rdmesh.SurfaceMesh(mesh.vertices * [1, 1, 0.2], mesh.faces, mesh.facet_centres)
    assert any("min angle" in s for s in outcome(flat).failures())


def test_budget_is_a_documented_stop():
    """A tiny vertex budget raises BudgetExceeded with a partial mesh, and the
    fuzz runner counts it as a budget stop, not a failure."""
    surf = fz.dumbbell((0.0, 0.0, 0.0), (0.0, 0.0, 1.0), 1.2, 1.0, 0.1, neck=0.3)
    tiny = fz.Profile(**{**fz.FAST.__dict__, "name": "tiny", "max_vertices": 50})
    out = fz.run_method(surf, "boissonnat-oudot", tiny)
    assert out.status == "budget" and out.budget_mesh_ok
    assert not out.complete and out.failures() == []
    assert fz.classify(out) == "budget"


# -- regressions: every failing case fuzzing found ---------------------------------------

#: (label, surface spec, method, profile, xfail reason or None). Keep every case the
#: fuzzer ever found failing; mark it xfail(strict=True) while it fails.
_SATELLITE = (
    "fz.loosen(fz.metaball_cloud(centres=((0.0, 0, 0), (1.5, 0.3, 0.2)), "
    "weights=(1.2, 0.52), widths=(0.5, 0.4), seed=3), 3.0)"
)
_SMALL_SPHERE = (
    "fz.primitives(parts=(('ellipsoid', (0.0, 0.0, 0.0), (0.8, 0.6, 0.5), (0.0, 0.0, 0.0)), "
    "('ellipsoid', (1.3, 0.0, 0.0), (0.02, 0.02, 0.02), (0.0, 0.0, 0.0))), seed=0)"
)
_SMALL_ELLIPSOID = (
    "fz.primitives(parts=(('ellipsoid', (0.0, 0, 0), (0.8, 0.6, 0.5), (0.1, 0.2, 0.3)), "
    "('ellipsoid', (1.3, 0.4, 0.2), (0.03, 0.025, 0.02), (0.5, 0.1, 0.0))), seed=2)"
)
_TOUCHING_SPHERES = (
    "fz.sphere_pair(centre=(0.1, 0.0, 0.0), axis=(0.3, 0.5, 0.8), radii=(0.7, 0.5), "
    "gap=0.0003, seed=1)"
)
_PINCHED_NECK = (
    "fz.dumbbell(centre=(0.1, 0.0, 0.0), axis=(0.3, 0.5, 0.8), length=1.3, bulge=1.0, "
    "middle=0.1, neck=0.0001, seed=1)"
)
# Every case below failed when fuzzing found it (at commit 99771c1): satellite,
# small-sphere and small-ellipsoid: a component smaller than the grid missed while
# topology_certified was True (now no sampled run is certified, and expression
# surfaces are also seeded by interval boxes); touching-spheres and pinched-neck:
# a complete mesh that was not a closed manifold (now points left unresolved make
# the mesh incomplete, as documented); cloud-satellite: a weak satellite blob
# missed while certified (found later at the same commit by the large profile).
# cloud-satellite-a..f and cloud-weak-blob (large profile, benchmarks/fuzz.py
# --families metaball_cloud primitives, and -m slow): weak satellite blobs, thinner
# than the seeding grid, missed while certified; now not certified.
_CLOUD_SATELLITE_A = (
    "fz.loosen(fz.metaball_cloud(centres=((0.366, -0.8686, 0.8986), (0.5027, 0.0182, -0.7591), "
    "(-0.3103, 0.5507, 0.3173), (0.5447, 0.8546, 0.1341), (-0.4815, -0.368, 0.6244), "
    "(0.0195, 0.2773, -0.2358), (-2.2954, 1.0687, 1.4125)), weights=(1.4804, 1.0917, 1.025, "
    "1.3547, 1.1152, 1.4601, 0.5103), widths=(0.3262, 0.5341, 0.5716, 0.4295, 0.5241, "
    "0.5039, 0.4085), seed=550), 2.2204)"
)
_CLOUD_SATELLITE_B = (
    "fz.loosen(fz.metaball_cloud(centres=((0.3449, -0.6323, 0.3771), (-0.0427, 0.0619, "
    "-0.1794), (-0.3684, 0.6382, 0.1326), (0.1268, 0.8319, -0.5301), (-0.2692, 0.4362, "
    "0.7134), (-0.1372, 0.393, 0.8518), (-0.8035, 0.4305, -0.3796), (2.2139, 1.584, "
    "-1.4599)), weights=(1.2318, 0.9306, 1.259, 1.2548, 0.8983, 0.7369, 0.7776, 0.5434), "
    "widths=(0.4714, 0.3804, 0.4607, 0.4104, 0.3742, 0.5374, 0.5676, 0.4018), seed=387), "
    "1.6762)"
)
# Found by ``benchmarks/fuzz.py --cases 60 --seed 505 --families metaball_cloud
# primitives`` (cases 8, 10, 24, 34; 36 and 56 below). Case 24's reference is by
# construction (provably separated blobs), the others' by marching cubes.
_CLOUD_SATELLITE_C = (
    "fz.metaball_cloud(centres=((-0.7333, 0.5262, 0.0772), (-0.3428, -3.0328, -0.3465)), "
    "weights=(1.023, 0.5068), widths=(0.5896, 0.3698), seed=260)"
)
_CLOUD_SATELLITE_D = (
    "fz.metaball_cloud(centres=((0.3249, -0.1134, -0.6548), (0.0924, 0.067, 0.8328), "
    "(0.767, -0.0124, -0.0226), (0.0224, 0.0185, 2.0561)), weights=(1.0126, 1.0541, 1.4016, "
    "0.5053), widths=(0.3338, 0.411, 0.4097, 0.3858), seed=901)"
)
_CLOUD_SATELLITE_E = (
    "fz.metaball_cloud(centres=((0.3449, -0.6323, 0.3771), (-0.0427, 0.0619, -0.1794), "
    "(-0.3684, 0.6382, 0.1326), (0.1268, 0.8319, -0.5301), (-0.2692, 0.4362, 0.7134), "
    "(-0.3109, 2.7446, 0.3985)), weights=(0.7429, 1.2913, 0.9313, 1.1591, 1.3362, 0.5037), "
    "widths=(0.4994, 0.3865, 0.5096, 0.5081, 0.3744, 0.3979), seed=142)"
)
_CLOUD_WEAK_BLOB = (
    "fz.loosen(fz.metaball_cloud(centres=((0.5519, -0.8235, -0.3915), (0.3421, -0.5901, "
    "0.8189), (-0.468, 0.4348, 0.8574), (-0.5071, 0.8876, -0.3045), (0.0921, -0.1703, "
    "-1.052)), weights=(1.1485, 1.2789, 0.8584, 0.817, 0.5056), widths=(0.3245, 0.5859, "
    "0.4685, 0.4415, 0.3408), seed=966), 1.4507)"
)
# Found by ``pytest -m slow tests/test_fuzz.py`` (test_fuzz_large[metaball_cloud]);
# the reference is by construction (provably separated blobs).
_CLOUD_SATELLITE_F = (
    "fz.loosen(fz.metaball_cloud(centres=((-0.0123, -0.0, -0.4588), (-1.2825, 0.777, "
    "1.0422)), weights=(1.5, 0.5097), widths=(0.3, 0.4576), seed=678, "
    "mc_resolutions=(128, 192)), 2.9383)"
)
REGRESSIONS: list[tuple[str, str, str, str, str | None]] = [
    ("satellite", _SATELLITE, "boissonnat-oudot", "fast", None),
    ("satellite", _SATELLITE, "topological-ball", "fast", None),
    ("small-sphere", _SMALL_SPHERE, "boissonnat-oudot", "fast", None),
    ("small-sphere", _SMALL_SPHERE, "topological-ball", "fast", None),
    ("small-ellipsoid", _SMALL_ELLIPSOID, "boissonnat-oudot", "fast", None),
    ("small-ellipsoid", _SMALL_ELLIPSOID, "topological-ball", "fast", None),
    ("touching-spheres", _TOUCHING_SPHERES, "boissonnat-oudot", "fast", None),
    ("touching-spheres", _TOUCHING_SPHERES, "topological-ball", "fast", None),
    ("pinched-neck", _PINCHED_NECK, "boissonnat-oudot", "fast", None),
    ("pinched-neck", _PINCHED_NECK, "topological-ball", "fast", None),
    ("cloud-satellite-a", _CLOUD_SATELLITE_A, "boissonnat-oudot", "large", None),
    ("cloud-satellite-a", _CLOUD_SATELLITE_A, "topological-ball", "large", None),
    ("cloud-satellite-b", _CLOUD_SATELLITE_B, "boissonnat-oudot", "large", None),
    ("cloud-satellite-b", _CLOUD_SATELLITE_B, "topological-ball", "large", None),
    ("cloud-satellite-c", _CLOUD_SATELLITE_C, "boissonnat-oudot", "fast", None),
    ("cloud-satellite-c", _CLOUD_SATELLITE_C, "topological-ball", "fast", None),
    ("cloud-satellite-d", _CLOUD_SATELLITE_D, "boissonnat-oudot", "fast", None),
    ("cloud-satellite-d", _CLOUD_SATELLITE_D, "topological-ball", "fast", None),
    ("cloud-satellite-e", _CLOUD_SATELLITE_E, "boissonnat-oudot", "fast", None),
    ("cloud-satellite-e", _CLOUD_SATELLITE_E, "topological-ball", "fast", None),
    ("cloud-satellite-f", _CLOUD_SATELLITE_F, "boissonnat-oudot", "fast", None),
    ("cloud-satellite-f", _CLOUD_SATELLITE_F, "topological-ball", "fast", None),
    ("cloud-weak-blob", _CLOUD_WEAK_BLOB, "boissonnat-oudot", "fast", None),
    ("cloud-weak-blob", _CLOUD_WEAK_BLOB, "topological-ball", "fast", None),
]


def _regression_params():
    short = {"boissonnat-oudot": "bo", "topological-ball": "tb"}
    for label, spec, method, profile, reason in REGRESSIONS:
        marks = [pytest.mark.xfail(strict=True, reason=reason)] if reason else []
        yield pytest.param(spec, method, profile, marks=marks, id=f"{label}-{short[method]}")


#: (label, surface spec, profile, xfail reason or None): surfaces on which the
#: two methods certified different topologies (the reference was ambiguous:
#: marching cubes cannot see the small blob, though it is there).
_CLOUD_DISAGREE_A = (
    "fz.loosen(fz.metaball_cloud(centres=((0.0914, 0.0992, 0.4418), (0.6129, 0.8661, "
    "-0.7974), (-0.718, -0.5661, -0.6368), (-0.0893, 0.5985, 0.5679), (0.1234, -0.5627, "
    "-0.4431), (1.4741, -2.1783, -2.085)), weights=(1.1891, 0.8347, 1.4073, 0.7676, 1.1835, "
    "0.509), widths=(0.3676, 0.4014, 0.5608, 0.5908, 0.5855, 0.4141), seed=562), 1.5292)"
)
_CLOUD_DISAGREE_B = (
    "fz.loosen(fz.metaball_cloud(centres=((0.2501, 0.6554, -0.5336), (0.1229, 0.5224, "
    "0.0883), (0.0468, -0.0122, 0.2286), (-0.5078, 0.0139, 0.3238), (0.8904, -0.297, "
    "-0.5735), (0.3792, -2.013, 1.7166)), weights=(0.7908, 1.0677, 0.9682, 0.9815, 1.0835, "
    "0.5036), widths=(0.3615, 0.406, 0.3627, 0.5009, 0.4496, 0.4086), seed=872), 1.5417)"
)
AGREEMENT_REGRESSIONS: list[tuple[str, str, str, str | None]] = [
    ("cloud-disagree-a", _CLOUD_DISAGREE_A, "fast", None),
    ("cloud-disagree-b", _CLOUD_DISAGREE_B, "large", None),
]


@pytest.mark.parametrize(
    ("spec", "profile"),
    [
        pytest.param(
            spec,
            profile,
            marks=[pytest.mark.xfail(strict=True, reason=reason)] if reason else [],
            id=label,
        )
        for label, spec, profile, reason in AGREEMENT_REGRESSIONS
    ],
)
def test_regression_methods_agree(spec, profile):
    surf = eval(spec, {"fz": fz})  # noqa: S307 - specs are this module's own text
    outcomes = [fz.run_method(surf, m, fz.PROFILES[profile]) for m in fz.METHODS]
    assert not fz.certified_disagreement(outcomes), [
        (o.method, o.topology, o.certified) for o in outcomes
    ]


@pytest.mark.parametrize(("spec", "method", "profile"), list(_regression_params()))
def test_regression(spec, method, profile):
    surf = eval(spec, {"fz": fz})  # noqa: S307 - specs are this module's own text
    prof = fz.PROFILES[profile]
    out = fz.run_method(surf, method, prof)
    assert out.failures() == [], _explain(surf, out)
