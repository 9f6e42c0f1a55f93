"""Inverse FORM, the performance-measure approach (PMA): the allowable as the largest cycle
extreme on the sphere of radius β_t = Φ⁻¹(R_t).

FORM approximates P(Y ≥ a) by Φ(−β(a)), β(a) the distance from the origin of the standard
normal space u to the surface Y(u) = a. Asking for the a with β(a) = β_t is asking for the
largest Y on the sphere ‖u‖ = β_t (Tu, Choi & Park 1999, "A new study on reliability-based
design optimization", J. Mech. Des. 121(4)): its maximiser u* (the most probable target
point) satisfies u* = β_t ∇Y(u*)/‖∇Y(u*)‖, and a = Y(u*). The search is the hybrid mean
value method (Youn, Choi & Park 2003, "Hybrid analysis method for reliability-based design
optimization", J. Mech. Des. 125(2)): from the origin, the advanced mean value step
u_(k+1) = β_t n_k (n_k = ∇Y(u_k)/‖∇Y(u_k)‖), replaced by the conjugate mean value step
u_(k+1) = β_t (n_k + n_(k−1) + n_(k−2))/‖·‖ where the sign of
ζ = (n_k − n_(k−1))·(n_(k−1) − n_(k−2)) says Y is concave there (where the plain step
oscillates). Converged when u_k is parallel to its gradient, ‖u_k − β_t n_k‖ ≤ tol_direction
β_t, and Y changed by at most tol |Y| in the last step. The value is what is reported, and it
is stationary in the direction at the maximum: a direction off by ε moves it by about
½ β_t ‖∇Y‖ ε² ≤ ½ ε² |Y − Y(0)|, so ``tol_direction`` defaults to √tol (the value then within
about tol/2 of its own), looser than FORM's default: on a simulated mechanism the noise of the
finite-difference gradient keeps the direction from settling below about 1e-2 (the lubricated
slider-crank at rtol 1e-5 and step 0.05: 0.01–0.07 from iteration to iteration, the value
steady to 3e-4). Gradients by finite differences in u
(:func:`mechrel.uq.estimators.form.gradient`: 2d + 1 points per iteration, one executor call).

Where it is valid: as FORM, when one design point dominates and Y is nearly linear in u near
it; then a is exact for Y linear in normal inputs. It gives no interval. It fails silently
where the event has several design points, which a cycle extreme often has: the two signs of
a two-sided error, peaks at different crank angles, several quantities. Hence two checks, each
a warning with the first-order probability it adds at the allowable found
(Φ(−(β_t + (a − Y(v))/‖∇Y(v)‖)) for another point v, the surface Y = a linearised there):
(1) a second search from −u*, which finds the opposite sign's point of a two-sided error;
(2) for the whole cycle, the quantities other than the one that sets the common factor
(k = max_q a_q/s_q), each at its own design point. FORM's allowable then lies below the true
one (unconservative); subset simulation or Monte Carlo answer it.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
import pandas as pd
from scipy import special

from ..estimators._problem import Problem
from ..estimators.form import FORMConvergenceError, check_positive, gradient
from ..problem.limit_state import LimitState
from .extremes import WHOLE_CYCLE
from .quantile import InverseEstimate

__all__ = ["inverse_form", "most_probable_target_point", "SECOND_POINT"]

SECOND_POINT = 0.1
"""A second design point (or another quantity) whose first-order probability at the allowable
found exceeds this fraction of 1 − R_t is warned about: it raises the true P_f by more than
10 % over FORM's, which then overstates the allowable's reliability."""


def _scalar(extremes, j: int, Y: np.ndarray) -> np.ndarray:
    return extremes.values(Y)[:, j]


def most_probable_target_point(problem: Problem, *, beta: float, u0: np.ndarray, step: float,
                               scheme: str, tol: float, tol_direction: float, max_iter: int
                               ) -> tuple[np.ndarray, float, np.ndarray, pd.DataFrame]:
    """The largest value of the problem's scalar (its ``g``) on the sphere ‖u‖ = |β| by the
    hybrid mean value method (module docstring), from ``u0``.

    Parameters
    ----------
    problem : mechrel.uq.estimators._problem.Problem
        Its limit state's margin is the scalar Y(u).
    beta : float
        β_t = Φ⁻¹(R_t) (negative: the smallest value on the sphere).
    u0 : ndarray
        The starting point (the origin: the first step is the mean value method's).
    step, scheme, tol, tol_direction, max_iter
        As FORM's (:func:`~mechrel.uq.form`).

    Returns
    -------
    u_star : ndarray
        The most probable target point.
    value : float
        Y(u*).
    grad : ndarray
        ∇Y(u*).
    history : pandas.DataFrame
        One row per iteration.

    Raises
    ------
    FORMConvergenceError
        A zero gradient, or no convergence within ``max_iter`` (with the iterates).

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"a": Normal(0.0, 1.0), "b": Normal(0.0, 1.0)})
    >>> model = FunctionModel(lambda X: X @ np.array([[3.0], [4.0]]), ["a", "b"], ["y"],
    ...                       vectorized=True)
    >>> p = Problem(model=model, inputs=inputs, limit_state=None, n_jobs=1, backend="loky",
    ...             cache=None, progress=False, chunk_size=None, what="pma")
    >>> u, y, g, h = most_probable_target_point(p, beta=2.0, u0=np.zeros(2), step=1e-4,
    ...                                         scheme="central", tol=1e-8, tol_direction=1e-8,
    ...                                         max_iter=20)
    >>> np.round(u, 8).tolist(), round(y, 8)       # β (3, 4)/5, 5 β
    ([1.2, 1.6], 10.0)
    """
    u = np.array(u0, dtype=float)
    rows: list[tuple] = []
    normals: list[np.ndarray] = []
    prev: float | None = None

    def hist() -> pd.DataFrame:
        return pd.DataFrame(rows, columns=["iteration", "value", "direction_criterion",
                                           "value_change", "step", "n_evaluations"]
                            ).set_index("iteration")

    for k in range(max_iter + 1):
        y, dy = gradient(problem.g, u, step=step, scheme=scheme, what=problem.what)
        norm = float(np.linalg.norm(dy))
        if not norm > 0:
            rows.append((k, y, math.nan, math.nan, "", problem.n_evaluations))
            raise FORMConvergenceError(
                f"{problem.what}: the gradient of the extreme is zero at iteration {k} "
                f"(u = {np.round(u, 4).tolist()}); it does not depend on the inputs there, or "
                "u is at a kink (e.g. |error| at zero error); allowed: a sampling method "
                "(mc, subset)", hist())
        n = dy / norm
        crit_u = float(np.linalg.norm(u - beta * n)) / abs(beta)
        change = abs(y - prev) / max(abs(y), 1e-300) if prev is not None else math.inf
        if (crit_u <= tol_direction and change <= tol) or k == max_iter:
            rows.append((k, y, crit_u, change, "", problem.n_evaluations))
            if crit_u <= tol_direction and change <= tol:
                return u, y, dy, hist()
            raise FORMConvergenceError(
                f"{problem.what}: no most probable target point in max_iter = {max_iter} "
                f"iterations (last: direction criterion {crit_u:.3g}, value change "
                f"{change:.3g}, tol = {tol:g}, tol_direction = {tol_direction:g}); allowed: a "
                "larger max_iter or tol, a larger step for a noisy model, or a sampling method "
                "(mc, subset); the iterates are in .history", hist())
        normals.append(n)
        kind = "AMV"
        d = n
        if len(normals) >= 3:
            zeta = float((normals[-1] - normals[-2]) @ (normals[-2] - normals[-3]))
            if zeta < 0:
                kind, d = "CMV", normals[-1] + normals[-2] + normals[-3]
        rows.append((k, y, crit_u, change, kind, problem.n_evaluations))
        dn = float(np.linalg.norm(d))
        u = beta * (d / dn if dn > 0 else n)
        prev = y
    raise AssertionError("unreachable")  # pragma: no cover


def _first_order_pf(beta: float, a: float, value: float, grad: np.ndarray) -> float:
    """Φ(−β') with β' = β_t + (a − Y(v))/‖∇Y(v)‖: the surface Y = a linearised at a point v of
    the sphere of radius β_t."""
    return float(special.ndtr(-(beta + (a - value) / float(np.linalg.norm(grad)))))


def inverse_form(*, model: Any, inputs: Any, extremes: Any, scalars: tuple[str, ...],
                 target: float, seed: Any, confidence_level: float, failures: str,
                 max_failure_fraction: float, executor: dict, step: float = 1e-4,
                 scheme: str = "central", tol: float = 1e-6, tol_direction: float | None = None,
                 max_iter: int = 100) -> InverseEstimate:
    """The quantiles of the scalars by inverse FORM (PMA, module docstring).

    The inverse method ``"form"`` of :func:`~mechrel.uq.inverse_reliability` (the contract
    of :mod:`mechrel.uq.inverse`): one search per quantity from the origin and one from the
    opposite of its point; the whole cycle's factor is the largest of the quantities',
    max_q a_q/s_q. No interval (``lo``, ``hi`` NaN); ``seed``, ``failures`` and
    ``max_failure_fraction`` are not used (a failed stencil point is an error).

    Parameters
    ----------
    model, inputs, extremes, scalars, target, seed, confidence_level, failures, max_failure_fraction, executor
        As passed by :func:`~mechrel.uq.inverse_reliability`.
    step, scheme, tol, tol_direction, max_iter
        As FORM's (:func:`~mechrel.uq.form`), but ``tol_direction=None`` is √tol here: the
        value is stationary in the direction at the maximum (module docstring).

    Returns
    -------
    InverseEstimate
        ``details["design_points"]``: per quantity and input, ``u``, ``x`` (physical),
        ``alpha`` (u*/β_t) and ``importance`` (α²) of the most probable target point;
        ``details["searches"]``: per quantity and start (``"origin"``, ``"opposite"``) the
        value reached, its first-order P at the allowable, the iterations and evaluations.

    Raises
    ------
    FORMConvergenceError
        A search that does not converge from the origin (the one from the opposite point is
        reported in ``details`` instead).

    Examples
    --------
    A linear extreme 1 + 3 x1 + 4 x2 (one-sided): exactly 1 + 5 Φ⁻¹(R_t):

    >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> model = linear_model([1.0], [[3.0, 4.0]], ["x1", "x2"])
    >>> r = inverse_reliability(model=model, inputs=inputs, target=0.99, method="form",
    ...                         event="one-sided", allowable=1.0, progress=False)
    >>> round(float(r.table.loc[("all", "all"), "allowable"]), 8), round(1 + 5 * 2.32634787, 6)
    (12.63173937, 12.631739)
    """
    step = check_positive("step", step)
    tol = check_positive("tol", tol)
    tol_direction = (math.sqrt(tol) if tol_direction is None
                     else check_positive("tol_direction", tol_direction))
    max_iter = check_positive("max_iter", max_iter, integer=True, minimum=0)
    beta = float(special.ndtri(target))
    p_t = 1.0 - target
    groups = [s for s in scalars if s in extremes.groups]
    calls, found, points, searches, notes = [], {}, [], [], []
    for g in groups:
        j = extremes.names.index(g)
        ls = LimitState.from_function(functools.partial(_scalar, extremes, j), name=g)
        problem = Problem(model=model, inputs=inputs, limit_state=ls, what="inverse_form",
                          **executor)
        search = functools.partial(most_probable_target_point, problem, beta=beta, step=step,
                                   scheme=scheme, tol=tol, tol_direction=tol_direction,
                                   max_iter=max_iter)
        u, y, dy, h = search(u0=np.zeros(problem.d))
        n_first = problem.n_evaluations
        searches.append((g, "origin", y, p_t, len(h), n_first, ""))
        try:
            v, yv, dv, hv = search(u0=-u)
        except FORMConvergenceError as exc:
            searches.append((g, "opposite", math.nan, math.nan, len(exc.history),
                             problem.n_evaluations - n_first, "did not converge"))
        else:
            distinct = float(np.linalg.norm(v - u)) > 0.1 * abs(beta)
            if distinct and yv > y:  # the larger extreme on the sphere is the answer
                notes.append(f"inverse (form): {g}: the search from the opposite point found a "
                             f"larger extreme ({yv:.4g} against {y:.4g}), which is kept")
                (u, y, dy), (v, yv, dv) = (v, yv, dv), (u, y, dy)
            pf2 = _first_order_pf(beta, y, yv, dv) if distinct else 0.0
            searches.append((g, "opposite", yv, pf2, len(hv), problem.n_evaluations - n_first,
                             "" if distinct else "the same point"))
            if pf2 > SECOND_POINT * p_t:
                notes.append(
                    f"inverse (form): {g}: a second design point (u = "
                    f"{np.round(v, 3).tolist()}) adds a first-order P = {pf2:.3g} "
                    f"({pf2 / p_t:.0%} of 1 − R_t) at the allowable found: FORM's single-point "
                    "allowable is too small (unconservative); use subset or mc")
        calls += problem.evaluations
        found[g] = (y, dy)
        x = problem.to_x(u)[0]
        points.append(pd.DataFrame({"u": u, "x": x, "alpha": u / beta, "importance": (u / beta) ** 2},
                                   index=pd.MultiIndex.from_product([[g], problem.names],
                                                                    names=["scalar", "input"])))
    values = {g: found[g][0] for g in groups}
    if WHOLE_CYCLE in scalars and WHOLE_CYCLE not in extremes.groups:
        ref = dict(zip(extremes.groups, extremes.reference))
        factors = {g: values[g] / ref[g] for g in groups}
        top = max(factors, key=lambda g: factors[g])
        k = factors[top]
        values[WHOLE_CYCLE] = k
        others = {g: _first_order_pf(beta, k * ref[g], *found[g]) for g in groups if g != top}
        extra = sum(others.values())
        if extra > SECOND_POINT * p_t:
            notes.append(
                f"inverse (form): the whole cycle's factor {k:.4g} is set by {top}; at it "
                + ", ".join(f"{g} adds a first-order P = {p:.3g}" for g, p in others.items())
                + f" ({extra / p_t:.0%} of 1 − R_t): FORM's single-point factor is too small "
                "(unconservative); use subset or mc")
    quantiles = pd.DataFrame({"value": [values[s] for s in scalars], "lo": math.nan,
                              "hi": math.nan}, index=pd.Index(scalars, name="scalar"))
    details = {"design_points": pd.concat(points),
               "searches": pd.DataFrame(searches, columns=["scalar", "start", "value",
                                                           "first_order_pf", "iterations",
                                                           "n_evaluations", "note"]
                                        ).set_index(["scalar", "start"])}
    settings = {"step": step, "scheme": scheme, "tol": tol, "tol_direction": tol_direction,
                "max_iter": max_iter, "beta_target": beta, "seed": None,
                "algorithm": "PMA, hybrid mean value (Youn, Choi & Park 2003)"}
    return InverseEstimate(quantiles, tuple(calls), details, tuple(notes), settings)
