"""Named tolerances and fixed numerical settings, in one place.

Lengths are relative to the bounding radius ``R`` unless the name says
otherwise; each comment says what the number guards.
"""

from __future__ import annotations

#: Guard against division by zero in norms and scale factors.
TINY = 1e-300

# -- crossings along segments (roots) ------------------------------------------
#: Root tolerance along dual segments, times R. Fixed per run (not per chunk)
#: so that results do not depend on how facets are grouped.
ROOT_ATOL = 1e-10
#: Root tolerance of the seeding grid and of shots from samples, times R.
SHOT_ATOL = 1e-9
#: A same-sign sample is a dip when |f| there is a local minimum below this
#: fraction of |f| at its larger neighbour.
DIP_FRACTION = 0.25
#: A crossing whose direction makes |cos| below this with the gradient is tangential.
TANGENCY_COS = 1e-3

# -- dual segment sampling ------------------------------------------------------
#: Samples per unit of asinh(distance / circumradius): spacing about r.
SAMPLES_PER_RADIUS = 1.0
#: Bounds on the intervals per dual segment.
MIN_INTERVALS, MAX_INTERVALS = 3, 64

# -- finite differences -----------------------------------------------------------
#: Central-difference step of the gradient, times R.
GRADIENT_STEP = 1e-6
#: Central-difference step of the Hessian (differences of the gradient), times R.
HESSIAN_STEP = 1e-5

# -- spacing floors -----------------------------------------------------------------
#: Refinement points closer than this (times R) are refused.
MIN_SPACING = 1e-7
#: Points driven only by topology are refused below this fraction of the size bound.
TOPOLOGY_FLOOR = 0.01
#: Topological-ball method without a size bound: topology-driven points are
#: refused below this fraction of R (ends refinement at singular points).
TB_FLOOR = 1e-4
#: Topological-ball method without a size bound: grid seeds on large bands
#: are thinned to this fraction of R (small bands keep all).
TB_SEED_SPACING = 0.25

# -- critical points of a height function (seeding) -------------------------
#: Newton has converged when a step is below this, times R.
CRITICAL_STEP_TOL = 1e-10
#: A solution is on the surface when |f| / |grad f| is below this, times R.
ON_SURFACE = 1e-8
#: ... and the gradient is parallel to the height direction to this (sine).
CRITICAL_PARALLEL = 1e-6
#: Critical points closer than this (times R, plus 1e-3 grid spacings) are one.
CRITICAL_MERGE = 1e-6
#: A tangential Hessian determinant below this (relative) is degenerate.
DEGENERATE_HESSIAN = 1e-6

# -- singular points (report) -----------------------------------------------------
#: |f| below this (times R times the median probe gradient) is on the surface.
SINGULAR_F = 1e-6
#: |grad f| below this (times the median probe gradient) vanishes.
SINGULAR_GRADIENT = 1e-4
#: Newton stops at a start whose |grad f| is below this (same unit): a critical
#: point, where a degenerate Hessian would only let rounding move it along.
SINGULAR_SETTLED = 1e-7
#: Levenberg damping of the singular-point Newton step (relative to trace(H^T H)).
SINGULAR_DAMPING = 1e-12
#: Singular points closer than this (times R) are one.
SINGULAR_MERGE = 1e-3

# -- topology tests ---------------------------------------------------------------
#: Shots from an isolated sample start this far (times R) off the sample.
SHOT_OFFSET = 1e-6
#: Slack of the silhouette test's cosine comparison.
SILHOUETTE_SLACK = 1e-12
#: Voronoi-facet loop search: finite-difference step, times the polygon's diameter.
LOOP_STEP = 1e-4
#: ... converged when |f| / |grad f| is below this, times the diameter ...
LOOP_F_TOL = 1e-7
#: ... and the in-plane gradient component along e2 below this (relative).
LOOP_G_TOL = 1e-6
#: ... a 2x2 Jacobian is singular below this relative determinant.
LOOP_SINGULAR = 1e-12
#: Polygon edges and in-plane directions shorter than this (times the diameter) are degenerate.
POLYGON_EPS = 1e-9
#: A direction shorter than this (times the diameter) is degenerate.
DIRECTION_EPS = 1e-12

# -- regions in the report ------------------------------------------------------
#: Points within this (times R) belong to one named region.
REGION_LINK = 0.05

# -- proofs by interval arithmetic (expression surfaces) ---------------------------
#: Pieces of a Voronoi edge are not halved below this, times R: an unsettled
#: piece there (a tangency, a singular point) leaves the edge unresolved.
PROOF_FLOOR = 1e-9
#: Boxes of the proven loop and silhouette tests are not halved below this
#: side, times R, nor below PROOF_BOX_RELATIVE times the facet's or cell's
#: first box: an unsettled box there is a violation (refined, never proven).
PROOF_BOX_FLOOR = 1e-5
PROOF_BOX_RELATIVE = 2.0**-14
