"""Curves given by two equations: projection onto them and tracing along them.

A curve here is ``{g1 = 0, g2 = 0}`` for two smooth functions of space with
gradients that are not parallel on it (a crease: a piece of the surface and
the switch between two pieces; :mod:`rdmesh.creases.search`).
A *system* evaluates, for ``m`` points and the curve each belongs to, the
residuals ``(m, 2)``, the Jacobians ``(m, 2, 3)`` and an *event* per point:
-1, or the decision node whose change of branch ends the curve there (a
corner).

- :func:`newton_project` moves points onto their curves by Gauss-Newton with
  the minimum-norm step ``-J^T (J J^T)^-1 g`` (the nearest point of the
  linearised curve), each equation scaled by its gradient.
- :func:`trace` follows many curves at once by predictor-corrector
  (Allgower-Georg; Bajaj-Hoffmann-Lynch-Hopcroft 1988): a step ``h`` along
  the tangent ``grad g1 x grad g2``, then the minimum-norm corrector; a step
  is accepted when the corrector converges within :data:`CORRECTOR_STEPS`
  iterations, moves at most :data:`CORRECTOR_MOVE` times ``h`` and the
  tangent turns less than :data:`TURN` degrees, otherwise ``h`` is halved.
  Every iteration is one vectorised evaluation of all live traces. A trace
  ends when it comes back to its start (a closed curve), when an event
  occurs (the caller finds the corner), when the step falls below its floor
  (the equations become degenerate, e.g. where the two surfaces touch: the
  trace is *lost* there, never looping without end) or after a number of
  steps.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

#: Evaluates ``(points (m, 3), curve (m,)) -> (g (m, 2), J (m, 2, 3), event (m,))``.
System = Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]

#: Corrector iterations per step at most.
CORRECTOR_STEPS = 4
#: Largest corrector move, times the step.
CORRECTOR_MOVE = 0.1
#: Largest turn of the tangent per step, degrees.
TURN = 15.0
#: Equations with gradients closer to parallel than this (sine) are degenerate.
DEGENERATE = 1e-8
#: Growth of the step after an accepted one.
GROW = 1.5


def _scaled(g: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each equation divided by its gradient's norm; NaN where that norm is
    not finite (a Newton iterate that ran off to huge values), so that such a
    point reads as degenerate and not converged."""
    with np.errstate(over="ignore", invalid="ignore"):
        n = np.sqrt(np.einsum("ijk,ijk->ij", J, J))
    n = np.where(np.isfinite(n), np.where(n > 0, n, 1.0), np.nan)
    with np.errstate(invalid="ignore"):
        return g / n, J / n[:, :, None]


def min_norm_step(g: np.ndarray, J: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The minimum-norm Gauss-Newton steps ``(m, 3)`` of scaled equations, and
    the sine of the angle between the two gradients ``(m,)`` (0 where the
    system is degenerate; the step is then 0)."""
    g, J = _scaled(g, J)
    a11 = np.einsum("ij,ij->i", J[:, 0], J[:, 0])
    a22 = np.einsum("ij,ij->i", J[:, 1], J[:, 1])
    a12 = np.einsum("ij,ij->i", J[:, 0], J[:, 1])
    det = a11 * a22 - a12 * a12
    ok = np.isfinite(det) & (det > DEGENERATE**2) & np.isfinite(g).all(axis=1)
    safe = np.where(ok, det, 1.0)
    y1 = (a22 * g[:, 0] - a12 * g[:, 1]) / safe
    y2 = (a11 * g[:, 1] - a12 * g[:, 0]) / safe
    step = -(J[:, 0] * y1[:, None] + J[:, 1] * y2[:, None])
    step[~ok] = 0.0
    sine = np.sqrt(np.clip(np.where(ok, det, 0.0), 0.0, None))
    return step, sine


def residual(g: np.ndarray, J: np.ndarray) -> np.ndarray:
    """The larger scaled residual ``|g_i| / |grad g_i|`` per point ``(m,)``
    (a first-order distance to each surface; inf where not finite)."""
    gs, _ = _scaled(g, J)
    r = np.abs(gs).max(axis=1)
    return np.where(np.isfinite(r), r, np.inf)


def newton_project(
    system: System, x: np.ndarray, curve: np.ndarray, tol: float, iterations: int = 12
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points ``(m, 3)`` moved onto their curves (``curve`` ``(m,)``) by
    minimum-norm Gauss-Newton until the scaled residual is below ``tol``
    and the last step below it too (or ``iterations`` ran).

    Returns ``(points, converged (m,), sine (m,))``: the sine of the angle
    between the two gradients at the result (the conditioning).
    """
    x = np.array(x, dtype=np.float64).reshape(-1, 3)
    curve = np.asarray(curve)
    done = np.zeros(len(x), bool)
    sine = np.zeros(len(x))
    live = np.arange(len(x))
    for _ in range(iterations):
        if not len(live):
            break
        g, J, _ = system(x[live], curve[live])
        step, s = min_norm_step(g, J)
        sine[live] = s
        x[live] += step
        small = (residual(g, J) <= tol) & (np.linalg.norm(step, axis=1) <= tol) & (s > 0)
        done[live[small]] = True
        live = live[~small & (s > 0)]
    if len(live):
        g, J, _ = system(x[live], curve[live])
        _, s = min_norm_step(g, J)
        sine[live] = s
        done[live] = (residual(g, J) <= tol) & (s > 0)
    return x, done, sine


@dataclass
class Traces:
    """Where :func:`trace` went: per trace, its accepted points (the start
    first) and how it ended.

    Attributes
    ----------
    points : list of (k, 3) arrays
    end : (m,) str array
        "closed" (back at the start: the points form a loop), "event" (the
        last point is past an event; ``previous`` is the point before it),
        "lost" (the step fell below its floor), "steps" (too many steps),
        "left" (outside the ball of the search).
    event : (m,) int64
        The event (decision node) of each trace that ended with one, else -1.
    """

    points: list[np.ndarray] = field(default_factory=list)
    end: np.ndarray = field(default_factory=lambda: np.zeros(0, "<U6"))
    event: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def trace(
    system: System,
    start: np.ndarray,
    curve: np.ndarray,
    direction: np.ndarray,
    h_max: float,
    h_min: float,
    tol: float,
    ball: tuple[np.ndarray, float],
    max_steps: int,
) -> Traces:
    """Follow curves from points on them, all at once.

    Parameters
    ----------
    system : System
    start : (m, 3) points on the curves (projected).
    curve : (m,) the curve of each trace (passed to ``system``).
    direction : (m,) +1 or -1: along ``grad g1 x grad g2`` or against it.
    h_max, h_min : the largest step, and the floor below which a trace is lost.
    tol : the corrector's residual tolerance.
    ball : (centre, radius): a trace that leaves it ends ("left").
    max_steps : steps per trace at most.
    """
    m = len(start)
    x = np.array(start, dtype=np.float64).reshape(-1, 3)
    first = x.copy()
    g, J, _ = system(x, curve)
    t = _tangent(J) * np.asarray(direction, dtype=np.float64)[:, None]
    h = np.full(m, float(h_max))
    end = np.full(m, "", dtype="<U6")
    event = np.full(m, -1, np.int64)
    steps = np.zeros(m, np.int64)
    travelled = np.zeros(m)
    cos_turn = np.cos(np.radians(TURN))
    # The accepted points, step after step: (trace, point) in order.
    owners, points = [np.arange(m)], [x.copy()]
    live = np.arange(m)
    while len(live):
        xl, hl, tl, cl = x[live], h[live], t[live], curve[live]
        y = xl + hl[:, None] * tl
        pred = y.copy()
        ok = np.ones(len(live), bool)
        for _ in range(CORRECTOR_STEPS):
            g, J, ev = system(y, cl)
            step, s = min_norm_step(g, J)
            y += step
            ok &= s > 0
        g, J, ev = system(y, cl)
        conv = ok & (residual(g, J) <= tol)
        t_new = _tangent(J)
        t_new *= np.where(np.einsum("ij,ij->i", t_new, tl) < 0, -1.0, 1.0)[:, None]
        good = (
            conv
            & (np.linalg.norm(y - pred, axis=1) <= CORRECTOR_MOVE * hl)
            & (np.einsum("ij,ij->i", t_new, tl) >= cos_turn)
            & np.isfinite(y).all(axis=1)
        )
        # Rejected: halve the step; below the floor the trace is lost.
        bad = live[~good]
        h[bad] *= 0.5
        end[bad[h[bad] < h_min]] = "lost"
        acc = np.flatnonzero(good)
        j = live[acc]
        ya, chord = y[acc], y[acc] - x[j]
        # Back at the start: the start lies on the step just taken.
        cc = np.maximum(np.einsum("ij,ij->i", chord, chord), 1e-300)
        w = np.clip(np.einsum("ij,ij->i", first[j] - x[j], chord) / cc, 0.0, 1.0)
        off = np.linalg.norm(x[j] + w[:, None] * chord - first[j], axis=1)
        closed = (steps[j] >= 2) & (travelled[j] > 2.0 * hl[acc]) & (off <= 0.25 * np.sqrt(cc))
        end[j[closed]] = "closed"
        keep = ~closed
        j, ya, acc = j[keep], ya[keep], acc[keep]
        owners.append(j)
        points.append(ya.copy())
        travelled[j] += np.linalg.norm(chord[keep], axis=1)
        steps[j] += 1
        x[j], t[j] = ya, t_new[acc]
        h[j] = np.minimum(h[j] * GROW, h_max)
        hit = ev[acc] >= 0
        end[j[hit]], event[j[hit]] = "event", ev[acc][hit]
        out = ~hit & (np.linalg.norm(ya - ball[0], axis=1) > ball[1])
        end[j[out]] = "left"
        end[j[~hit & ~out & (steps[j] >= max_steps)]] = "steps"
        live = live[end[live] == ""]
    owner, pts = np.concatenate(owners), np.concatenate(points)
    order = np.argsort(owner, kind="stable")
    split = np.cumsum(np.bincount(owner, minlength=m))[:-1]
    return Traces(np.split(pts[order], split), end, event)


def _tangent(J: np.ndarray) -> np.ndarray:
    """Unit tangents ``grad g1 x grad g2`` ``(m, 3)`` (0 where degenerate)."""
    t = np.cross(J[:, 0], J[:, 1])
    n = np.linalg.norm(t, axis=1)
    return np.where(n[:, None] > 0, t / np.where(n > 0, n, 1.0)[:, None], 0.0)
