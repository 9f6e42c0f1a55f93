""":func:`design_for_reliability`: the cheapest design whose whole-cycle reliability meets its
targets, verified by an independent run, with the trade-off curve of cost against reliability.

The problem
-----------
Minimise (or maximise) a cost c(d) of the design variables d within their bounds, subject to
R_c(d) ≥ R_t,c for each reliability constraint c, written in the performance-measure form
k_c(d) ≤ 1 (:mod:`mechrel.uq.design.constraints`). A design method (``method=``, the registry
:data:`mechrel.uq.design.DESIGN_METHODS`) estimates k_c(d) from common random numbers
(:mod:`mechrel.uq.design.space`): ``"ak"``, a Kriging surrogate of the cycle extremes in the
model's input space, learnt where the current optimum's constraint is decided
(:mod:`mechrel.uq.design.augmented`); ``"mc"``, the model itself on one Monte Carlo sample
mapped through each design (:mod:`mechrel.uq.design.crn`). This module optimises on the
method's estimate (COBYQA, a derivative-free trust-region method with bounds and nonlinear
constraints: k is continuous but only piecewise smooth), then

1. draws the **trade-off curve**: the optimum cost at targets 1 − f (1 − R_t), f from 0.1 to
   10, on the method's final estimate (no new simulation for ``"ak"``);
2. **verifies** the optimum by an independent forward run of the model at it (Monte Carlo or
   subset simulation, another seed), each constraint's P_f with its interval;
3. names the **active constraints** (k_c ≥ 1 − :data:`ACTIVE`) and warns when the optimum lies
   on a bound, no design within the bounds meets the targets, the verification's interval
   excludes a target, or the method did not converge.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import optimize

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import CountedByProvenance, check_inputs, emit_warnings, make_provenance
from ..estimators._problem import concat_evaluations
from ..execution.executor import EvaluationCount, Evaluations
from ..problem.allowables import DEFAULT_ALLOWABLES, Allowable, check_event
from ..problem.inputs import as_seed_sequence, child_seed, seed_record
from ..problem.model import check_model, describe_model
from .constraints import ConstraintScalars
from .expression import CostExpression, check_finite
from .space import SENSES, AtDesign, DesignSpace, as_constraints, as_variables

__all__ = ["design_for_reliability", "design_space", "DesignResult", "DesignProblem",
           "DesignEstimate", "optimise", "ACTIVE", "VERIFY_METHODS", "TRADEOFF_RANGE"]

ACTIVE = 0.01
"""A constraint is *active* at the optimum when its factor k ≥ 1 − ACTIVE: within 1 % of its
allowables, it is what stops the cost from falling further."""

FEASIBLE = 1e-6
"""A design meets a constraint on the method's estimate when k ≤ 1 + FEASIBLE (the optimiser's
last digits)."""

ON_BOUND = 1e-6
"""A variable within this fraction of its bounds' span (in the optimiser's coordinates) lies on
the bound."""

VERIFY_METHODS = ("auto", "mc", "subset", "none")
"""How the optimum is verified: Monte Carlo, subset simulation, ``auto`` (Monte Carlo when its
``n`` resolves every target, n (1 − R_t) ≥ 10, and for per-angle constraints; else subset
simulation), or not at all."""

TRADEOFF_RANGE = (0.1, 10.0)
"""The trade-off curve spans targets 1 − f (1 − R_t) for f in this range (log-spaced)."""

_SEED_VERIFY = 7  # child stream of the seed for the verification (the methods use 0 to 6)


# ----------------------------------------------------------------------------- the problem
@dataclass(frozen=True, eq=False)
class DesignProblem:
    """A reliability-based design problem, checked (made by :func:`design_for_reliability`).

    Parameters
    ----------
    model : Model
        The model of the uncertain inputs and the scene design variables.
    inputs : UncertainInputs
        The uncertain inputs at the base design (in the model's order).
    space : DesignSpace
        The design variables and their map to the model's inputs.
    cost : CostExpression
        The cost.
    sense : {"minimize", "maximize"}
        Of the cost.
    scalars : ConstraintScalars
        The constraints' ratios from the model's outputs.
    event : {"two-sided", "one-sided"}
        The event.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> from mechrel.uq.design.space import DesignVariable, ReliabilityConstraint
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> space = DesignSpace([DesignVariable("t", "std", "x", 0.1, 10.0)], inputs, ["x"])
    >>> model = FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True)
    >>> p = DesignProblem(model, inputs, space, CostExpression("1/t", space.names), "minimize",
    ...                   ConstraintScalars(model.output_index, "two-sided", {"all": 1.0},
    ...                                     [ReliabilityConstraint(0.99)]), "two-sided")
    >>> p.cost_at([0.5]), p.reliabilities.tolist()
    (2.0, [0.99])
    """

    model: Any
    inputs: Any
    space: DesignSpace
    cost: CostExpression
    sense: str
    scalars: ConstraintScalars
    event: str

    @property
    def constraints(self) -> tuple:
        """The reliability constraints.

        Returns
        -------
        tuple of ReliabilityConstraint

        Examples
        --------
        >>> p = _demo_problem()   # the class's example: x ~ N(0, 1) scaled by t, cost 1/t
        >>> p.constraints[0].label
        'all (whole-cycle) R >= 0.99'
        """
        return self.scalars.constraints

    @property
    def reliabilities(self) -> np.ndarray:
        """The constraints' target reliabilities.

        Returns
        -------
        ndarray, shape (n_constraints,)

        Examples
        --------
        >>> p = _demo_problem()   # the class's example: x ~ N(0, 1) scaled by t, cost 1/t
        >>> p.reliabilities.tolist()
        [0.99]
        """
        return np.array([c.reliability for c in self.constraints])

    def cost_at(self, d) -> float:
        """The cost at design ``d`` (NaN or inf where the expression is not finite).

        Parameters
        ----------
        d : sequence of float
            The design, in the order of the design space's names.

        Returns
        -------
        float

        Examples
        --------
        >>> p = _demo_problem()   # the class's example: x ~ N(0, 1) scaled by t, cost 1/t
        >>> p.cost_at([0.25])
        4.0
        """
        return float(self.cost(self.space.as_dict(d)))

    def model_at(self, d) -> AtDesign:
        """The model at design ``d`` (:class:`~mechrel.uq.design.space.AtDesign`).

        Parameters
        ----------
        d : sequence of float
            The design.

        Returns
        -------
        AtDesign
            A model of the base inputs: evaluated after the design's map.

        Examples
        --------
        >>> p = _demo_problem()   # the class's example: x ~ N(0, 1) scaled by t, cost 1/t
        >>> p.model_at([3.0]).evaluate(np.array([0.5])).tolist()   # x = 3 × 0.5
        [1.5]
        """
        return AtDesign(self.model, self.space, d)


def _demo_problem() -> DesignProblem:
    """The problem of :class:`DesignProblem`'s example (for the examples of its members): one
    standard normal input x scaled by the design variable t (its std), the output x itself,
    cost 1/t, whole-cycle R ≥ 0.99, two-sided."""
    from ..problem.inputs import Normal, UncertainInputs
    from ..problem.model import FunctionModel
    from .space import DesignVariable, ReliabilityConstraint

    inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    space = DesignSpace([DesignVariable("t", "std", "x", 0.1, 10.0)], inputs, ["x"])
    model = FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True)
    return DesignProblem(model, inputs, space, CostExpression("1/t", space.names), "minimize",
                         ConstraintScalars(model.output_index, "two-sided", {"all": 1.0},
                                           [ReliabilityConstraint(0.99)]), "two-sided")


@dataclass(frozen=True)
class DesignEstimate:
    """What a design method returns to :func:`design_for_reliability` (the registry's
    contract, :mod:`mechrel.uq.design`).

    Parameters
    ----------
    design : ndarray
        The optimum the method found (on its estimate of the constraints).
    estimator : object
        Its final estimate of the constraints: ``factors(d, reliabilities) -> ndarray`` (k per
        constraint), ``summary(d, reliabilities) -> DataFrame`` (per constraint ``factor``,
        ``pf``, ``pf_lo``, ``pf_hi``, ``interval``) and ``resolves(reliabilities) -> bool``
        (whether its samples resolve those targets).
    evaluations : tuple of Evaluations
        The model rows the method keeps (the method may keep fewer than it ran).
    counts : mapping
        ``n_evaluations``, ``n_computed``, ``n_cached``, ``n_failed`` of every model row it
        ran, kept up to date when its estimator runs the model again (the trade-off curve of
        ``"mc"``): the provenance's count of the method's runs. Rows reused from an earlier
        result are not among them.
    history : pandas.DataFrame
        One row per iteration.
    details : mapping, optional
        Named diagnostic tables.
    notes : tuple of str, optional
        Caveats (become warnings).
    settings : mapping, optional
        The method's settings, for provenance.
    converged : bool, optional
        Whether its stopping rule was met (None: it has none).

    Examples
    --------
    A method's return value (here an empty one, as a method would fill it):

    >>> e = DesignEstimate(np.array([0.5]), None, (), {"n_evaluations": 0}, pd.DataFrame())
    >>> e.converged is None, e.notes
    (True, ())
    """

    design: np.ndarray
    estimator: Any
    evaluations: tuple
    counts: Mapping[str, int]
    history: pd.DataFrame
    details: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    settings: Mapping[str, Any] = field(default_factory=dict)
    converged: bool | None = None


# ----------------------------------------------------------------------------- the optimiser
def optimise(problem: DesignProblem, factors, reliabilities, start, *, radius: float = 0.25,
             max_evaluations: int | None = None, confirm=None) -> tuple[np.ndarray, dict]:
    """The design of least cost (greatest, for ``sense="maximize"``) with every factor
    k_c(d) ≤ 1, by COBYQA (Ragonneau & Zhang 2023, scipy's ``method="COBYQA"``) in the
    design space's unit coordinates (:meth:`DesignSpace.to_unit`).

    COBYQA is derivative-free (k is continuous but only piecewise smooth: a quantile of many
    smooth functions) and handles the bounds and the constraints; every design it tries is
    evaluated once (a memory keyed on the point). Of the designs tried, the one of least cost
    with every k ≤ 1 + :data:`FEASIBLE` is returned; when none meets them, the one of smallest
    largest k (``info["feasible"]`` False).

    Parameters
    ----------
    problem : DesignProblem
    factors : callable
        ``factors(d, reliabilities) -> ndarray`` of k per constraint.
    reliabilities : sequence of float
        The targets.
    start : ndarray
        The starting design.
    radius : float, default 0.25
        COBYQA's initial trust-region radius (unit coordinates).
    max_evaluations : int, optional
        Designs tried at most (default 100 + 100 m).
    confirm : callable, optional
        ``confirm(d, reliabilities) -> bool``: whether ``factors`` was exact at the design
        found (an estimate on part of a population); if not, the optimisation starts again
        from it (at most four times).

    Returns
    -------
    design : ndarray
    info : dict
        ``feasible``, ``factors`` (k at the design), ``cost``, ``n_designs`` (designs tried),
        ``message``.

    Examples
    --------
    Σ 1/t_i subject to a linear "factor" Σ t_i ≤ 1 (optimum t_i = 1/2, cost 4):

    >>> from mechrel.uq import Normal, UncertainInputs, linear_model
    >>> from mechrel.uq.design.space import DesignVariable, ReliabilityConstraint
    >>> inputs = UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)})
    >>> space = DesignSpace([DesignVariable("ta", "std", "a", 0.01, 10.0),
    ...                      DesignVariable("tb", "std", "b", 0.01, 10.0)], inputs, ["a", "b"])
    >>> model = linear_model([0.0], [[1.0, 1.0]], ["a", "b"])
    >>> p = DesignProblem(model, inputs, space, CostExpression("1/ta + 1/tb", space.names),
    ...                   "minimize", ConstraintScalars(model.output_index, "two-sided",
    ...                   {"all": 1.0}, [ReliabilityConstraint(0.9)]), "two-sided")
    >>> d, info = optimise(p, lambda d, r: np.array([d.sum()]), [0.9], space.start)
    >>> np.round(d, 3).tolist(), round(info["cost"], 5)
    ([0.5, 0.5], 4.0)
    """
    for _ in range(4):
        d, info = _optimise_once(problem, factors, reliabilities, start, radius,
                                 max_evaluations)
        if confirm is None or confirm(d, reliabilities):
            break
        start, radius = d, 0.1
    return d, info


def _optimise_once(problem, factors, reliabilities, start, radius, max_evaluations):
    space = problem.space
    sign = 1.0 if problem.sense == "minimize" else -1.0
    reliabilities = np.asarray(reliabilities, dtype=float)
    start = np.clip(np.asarray(start, dtype=float), space.lower, space.upper)
    scale = abs(problem.cost_at(start))
    scale = scale if math.isfinite(scale) and scale > 0 else 1.0
    memo: dict[bytes, tuple[float, np.ndarray, np.ndarray]] = {}

    def at(eta):
        key = np.asarray(eta, dtype=float).tobytes()
        if key not in memo:
            d = space.from_unit(eta)
            c = problem.cost_at(d)
            k = np.asarray(factors(d, reliabilities), dtype=float)
            memo[key] = (sign * c / scale if math.isfinite(c) else 1e30, k, d)
        return memo[key]

    def cons(eta):
        k = at(eta)[1]
        return np.where(np.isfinite(k), 1.0 - k, -1e3)

    m = space.m
    budget = max_evaluations or (100 + 100 * m)
    eta0 = space.to_unit(start)
    res = optimize.minimize(
        lambda e: at(e)[0], eta0, method="COBYQA", bounds=optimize.Bounds(0.0, 1.0),
        constraints=[{"type": "ineq", "fun": cons}],
        options={"initial_tr_radius": radius, "final_tr_radius": 1e-5, "maxfev": budget,
                 "disp": False})
    at(res.x)  # the returned point is among the candidates
    rows = list(memo.values())
    worst = np.array([np.max(np.where(np.isfinite(k), k, np.inf)) for _, k, _ in rows])
    ok = worst <= 1.0 + FEASIBLE
    if ok.any():
        i = min(np.flatnonzero(ok), key=lambda j: rows[j][0])
    else:
        i = int(np.argmin(worst))
    f, k, d = rows[i]
    return d, {"feasible": bool(ok.any()), "factors": k, "cost": problem.cost_at(d),
               "n_designs": len(memo), "message": str(res.message)}


# ----------------------------------------------------------------------------- the result
@dataclass(frozen=True, eq=False)
class DesignResult(CountedByProvenance):
    """The optimum design under reliability constraints (frozen), made by
    :func:`design_for_reliability`.

    Parameters
    ----------
    table : pandas.DataFrame
        One row per design variable: ``kind``, ``input``, ``value`` (the optimum), ``lower``,
        ``upper``, ``start``, ``on_bound`` (``"lower"``, ``"upper"`` or ``""``).
    cost : float
        The cost at the optimum.
    start_cost : float
        The cost at the start design.
    constraints : pandas.DataFrame
        One row per constraint (its label): ``quantity``, ``basis``, ``reliability`` (target),
        ``pf_target`` (1 − target), ``factor`` (k at the optimum on the method's estimate),
        ``active``, ``pf``/``pf_lo``/``pf_hi`` (the method's estimate and interval),
        ``verify_method``, ``verify_pf``/``verify_pf_lo``/``verify_pf_hi`` (the independent run:
        for a per-angle constraint, at its governing output), ``whole_cycle_pf`` with
        ``_lo``/``_hi`` (the whole cycle's P_f of the constraint's quantities at the optimum,
        by the verification's Monte Carlo: what a per-angle constraint lets through),
        ``verified``, ``verify_n`` (model runs of the verification).
    tradeoff : pandas.DataFrame
        The trade-off curve: one row per scale f of the targets' P_f: ``f``, ``reliability``
        (of the first constraint), ``pf_target``, ``cost``, the design variables, ``pf``
        (the method's estimate at that design, first constraint), ``pf_lo``, ``pf_hi``,
        ``feasible``.
    history : pandas.DataFrame
        The method's iterations.
    method : str
        The design method's key.
    sense : str
        ``"minimize"`` or ``"maximize"``.
    cost_expression : str
        The cost as written.
    converged : bool or None
        Whether the method's stopping rule was met (None: it has none).
    feasible : bool
        Whether the optimum meets every constraint on the method's estimate.
    details : mapping
        The method's diagnostic tables (e.g. the surrogate's units).
    evaluations : Evaluations or None
        The model rows the method kept.
    verification : mapping
        The verification's results (``"mc"`` or ``"subset[i]"``), for their tables and
        provenance.
    provenance : dict
        Seed, settings, model (scene hash), counts (every model run, the verification's
        included), versions, wall time.
    warnings : tuple of str
        The caveats, each also issued as an :class:`~mechrel.errors.EstimateWarning`.

    Examples
    --------
    See :func:`design_for_reliability`.
    """

    table: pd.DataFrame
    cost: float
    start_cost: float
    constraints: pd.DataFrame
    tradeoff: pd.DataFrame
    history: pd.DataFrame
    method: str
    sense: str
    cost_expression: str
    converged: bool | None
    feasible: bool
    details: Mapping[str, pd.DataFrame]
    evaluations: Evaluations | None
    verification: Mapping[str, Any] = field(repr=False)
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The optimum: one row per design variable (a copy of ``table``).

        Returns
        -------
        pandas.DataFrame

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> r = design_for_reliability(
        ...     model=FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True),
        ...     inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
        ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
        ...     cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=4000, seed=3,
        ...     tradeoff=0, verify="none", progress=False)
        >>> r.to_frame().loc["t", ["kind", "on_bound"]].tolist()
        ['std', '']
        """
        return self.table.copy()

    @property
    def design(self) -> dict[str, float]:
        """``{variable: value}`` at the optimum.

        Returns
        -------
        dict

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> r = design_for_reliability(
        ...     model=FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True),
        ...     inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
        ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
        ...     cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=4000, seed=3,
        ...     tradeoff=0, verify="none", progress=False)
        >>> abs(r.design["t"] / 0.38823 - 1) < 0.05     # 1/Φ⁻¹(0.995)
        True
        """
        return {str(k): float(v) for k, v in self.table["value"].items()}

    @property
    def active(self) -> list[str]:
        """The active constraints' labels (k ≥ 1 − :data:`ACTIVE` at the optimum).

        Returns
        -------
        list of str

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> r = design_for_reliability(
        ...     model=FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True),
        ...     inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
        ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
        ...     cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=4000, seed=3,
        ...     tradeoff=0, verify="none", progress=False)
        >>> r.active
        ['all (whole-cycle) R >= 0.99']
        """
        return [str(k) for k, v in self.constraints["active"].items() if v]


# ----------------------------------------------------------------------------- trade-off curve
def _tradeoff(problem: DesignProblem, estimator, d_star: np.ndarray, points: int
              ) -> pd.DataFrame:
    """The optimum cost at targets 1 − f (1 − R_t) on the method's final estimate, from the
    optimum outward (each point starts from its neighbour's design)."""
    cols = ["f", "reliability", "pf_target", "cost", *problem.space.names, "pf", "pf_lo",
            "pf_hi", "factor", "feasible"]
    if points <= 0:
        return pd.DataFrame(columns=cols)
    fs = np.geomspace(*TRADEOFF_RANGE, points) if points > 1 else np.array([1.0])
    fs = np.unique(np.append(fs, 1.0))
    base = 1.0 - problem.reliabilities
    rows = {}
    one = int(np.argmin(np.abs(fs - 1.0)))
    for order in (fs[one:], fs[:one][::-1]):
        d_prev = d_star
        for f in order:
            pf_t = f * base
            if np.any(pf_t >= 0.5):
                continue
            rel = 1.0 - pf_t
            if not estimator.resolves(rel):
                continue
            if f == 1.0:
                d, info = d_star, {"feasible": True}
                k = estimator.factors(d, rel)
                info["feasible"] = bool(np.all(k <= 1 + FEASIBLE))
            else:
                d, info = optimise(problem, estimator.factors, rel, d_prev, radius=0.1,
                                   confirm=getattr(estimator, "confirm", None))
            s = estimator.summary(d, rel).iloc[0]
            rows[float(f)] = [float(f), float(rel[0]), float(pf_t[0]), problem.cost_at(d),
                              *map(float, d), float(s["pf"]), float(s["pf_lo"]),
                              float(s["pf_hi"]), float(s["factor"]), bool(info["feasible"])]
            d_prev = d
    table = pd.DataFrame([rows[f] for f in sorted(rows)], columns=cols)
    return table


# ----------------------------------------------------------------------------- verification
def _verify_settings(verify: Any, where: str = "verify") -> dict:
    """The verification's settings, checked (``where``: how they are named in messages)."""
    if isinstance(verify, str):
        verify = {"method": verify}
    if not isinstance(verify, Mapping):
        raise StudyError(f"{where} = {verify!r}: allowed: one of {', '.join(VERIFY_METHODS)}, or "
                         "a mapping {method, n, n_per_level, p0}")
    unknown = sorted(set(verify) - {"method", "n", "n_per_level", "p0"})
    if unknown:
        raise StudyError(f"{where}: unknown field {unknown[0]!r}; allowed: fields method, n, "
                         "n_per_level, p0")
    out: dict[str, Any] = {"method": ARGS.choice(f"{where}.method", verify.get("method", "auto"),
                                                 VERIFY_METHODS),
                           "n": ARGS.sample_count(f"{where}.n", verify.get("n", 10_000))}
    from ..estimators import METHODS
    from ..estimators.subset import level_sizes
    sub = METHODS["subset_simulation"].settings
    for key, default in (("n_per_level", 500), ("p0", 0.1)):
        value = verify.get(key, default)
        check = sub[key].check
        out[key] = value if check is None else check(f"{where}.{key}", value)
    level_sizes(out["n_per_level"], out["p0"], f"{where}.p0")  # checked now, not at the end
    return out


def _verify(problem: DesignProblem, d: np.ndarray, settings: dict, ss, *, confidence_level,
            failures, max_failure_fraction, executor) -> tuple[pd.DataFrame, dict, list]:
    """An independent forward run of the model at design ``d`` (another seed): per constraint
    its P_f with the interval, and the whole cycle's P_f of its quantities."""
    from ..estimators.monte_carlo import MonteCarloResult, monte_carlo
    from ..estimators.subset import SubsetSimulationResult, subset_simulation
    from ..inverse import MC_RESOLUTION

    sc = problem.scalars
    method = settings["method"]
    n = settings["n"]
    rel = problem.reliabilities
    if method == "auto":
        resolved = bool(np.all(n * (1.0 - rel) >= MC_RESOLUTION - 1e-9))
        method = "mc" if sc.per_angle or resolved else "subset"
    cols = ["verify_method", "verify_pf", "verify_pf_lo", "verify_pf_hi", "whole_cycle_pf",
            "whole_cycle_pf_lo", "whole_cycle_pf_hi", "verify_n"]
    nan = math.nan
    if method == "none":
        return pd.DataFrame([["none", nan, nan, nan, nan, nan, nan, 0]] * len(rel), columns=cols,
                            index=sc.labels()), {}, []
    if method == "subset" and sc.per_angle:
        raise StudyError("verify = 'subset': a per-angle constraint is many events (one per "
                         "analysis output); allowed: verify 'mc' (or 'auto') for per-angle "
                         "constraints")
    model = problem.model_at(d)
    allowable = ({g: Allowable(a, 0.0) for g, a in sc.allowables.items()}
                 if sc.groups != ("all",) else Allowable(sc.allowables["all"], 0.0))
    rows: list[list] = []
    results: dict[str, MonteCarloResult | SubsetSimulationResult] = {}
    evs: list[Evaluations | None] = []  # a result's rows (None: it kept none)
    if method == "mc":
        r = monte_carlo(model=model, inputs=problem.inputs, n=n, rule="random",
                        seed=child_seed(ss, _SEED_VERIFY), allowable=allowable,
                        event=problem.event, confidence_level=confidence_level,
                        failures="as_violation" if failures == "as_failure" else "exclude",
                        max_failure_fraction=max_failure_fraction, **executor)
        # no limit_state: the per-output result, whose tables are set
        assert isinstance(r, MonteCarloResult) and r.table is not None and r.whole_cycle is not None
        results["mc"] = r
        evs.append(r.evaluations)
        wc = r.whole_cycle
        table = r.table
        for i, c in enumerate(problem.constraints):
            kind, idx = sc.members[i]
            key = c.quantity if c.quantity in wc.index else "all"
            w = wc.loc[key]
            whole = (1 - w["reliability"], 1 - w["reliability_hi"], 1 - w["reliability_lo"])
            if kind == "whole-cycle":
                p = whole
            else:
                t = table.iloc[list(idx)]
                j = int(np.argmax(1 - t["reliability"].to_numpy()))
                p = (1 - t["reliability"].iloc[j], 1 - t["reliability_hi"].iloc[j],
                     1 - t["reliability_lo"].iloc[j])
            rows.append(["mc", *map(float, p), *map(float, whole), int(r.n_evaluations)])
    else:
        for i in range(len(problem.constraints)):
            qs = [sc.groups[j] for j in sc.members[i][1]]
            ls = sc.extremes.limit_state({q: sc.allowables[q] for q in qs})
            ss_r = subset_simulation(model=model, inputs=problem.inputs, limit_state=ls,
                                     seed=child_seed(ss, _SEED_VERIFY + 1 + i),
                                     n_per_level=settings["n_per_level"], p0=settings["p0"],
                                     confidence_level=confidence_level, failures=failures,
                                     max_failure_fraction=max_failure_fraction, **executor)
            results[f"subset[{i}]"] = ss_r
            evs.append(ss_r.evaluations)
            t = ss_r.table.iloc[0]
            p = (float(t["pf"]), float(t["pf_lo"]), float(t["pf_hi"]))
            rows.append(["subset", *p, *p, int(ss_r.n_evaluations)])
    return pd.DataFrame(rows, columns=cols, index=sc.labels()), results, evs


# ----------------------------------------------------------------------------- the entry point
def _allowables(allowable: Any, groups: tuple[str, ...]) -> tuple[dict, list[str]]:
    """The deterministic allowables (means) per quantity, and the stds left out."""
    out, left = {}, []
    for g in groups:
        a: Any  # as given: a number, a (mean, std) pair or an Allowable (checked by the caller)
        if allowable is None:
            a = DEFAULT_ALLOWABLES.get(g)
        elif isinstance(allowable, Mapping):
            a = allowable.get(g)
        else:
            a = allowable
        if a is None:
            raise StudyError(f"allowable: no allowable for quantity {g!r}; allowed: a number, "
                             "an Allowable or {quantity: value} covering every quantity "
                             f"({', '.join(groups)})")
        if isinstance(a, tuple) and len(a) == 2:
            a = Allowable(*a)
        if isinstance(a, Allowable):
            if a.std > 0:
                left.append(f"{g} {a.std:g}")
            a = a.mean
        out[g] = a
    return out, left


def design_space(model: Any, inputs: Any, variables: Any) -> DesignSpace:
    """The design space of ``variables`` on ``model``: the base design is ``inputs`` and, for a
    ``"scene"`` variable without ``start``, the model's nominal value of its input (a
    :class:`~mechrel.uq.MechanismModel`'s: the scene's value at the variable's paths).

    Parameters
    ----------
    model : Model
        Its inputs: the uncertain inputs and one per ``"scene"`` variable.
    inputs : UncertainInputs
        The uncertain inputs at the base design.
    variables : sequence of DesignVariable, or mapping
        As :func:`design_for_reliability` takes them.

    Returns
    -------
    DesignSpace

    Raises
    ------
    StudyError
        A bad variable (naming it), a scene variable with neither ``start`` nor a nominal
        value in the model.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> model = FunctionModel(lambda X: X[:, :1] * X[:, 1:], ["x", "g"], ["e"], vectorized=True)
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> design_space(model, inputs, {"g": {"kind": "scene", "input": "g", "lower": 1.0,
    ...                                    "upper": 3.0, "start": 2.0}}).start.tolist()
    [2.0]
    """
    names, _ = check_model(model)
    if inputs is None or not hasattr(inputs, "names"):
        raise StudyError(f"inputs = {inputs!r}: allowed: an UncertainInputs")
    checked = as_variables(variables)
    random_names = tuple(n for n in names if n in inputs.names)
    inputs = check_inputs(inputs, random_names) if len(random_names) == len(inputs.names) \
        else inputs
    nominal = dict(zip(names, np.asarray(getattr(model, "nominal", []), dtype=float))) \
        if getattr(model, "nominal", None) is not None else {}
    return DesignSpace(checked, inputs, names, nominal)


def design_for_reliability(
    *,
    model: Any,
    inputs: Any,
    variables: Any,
    cost: str,
    constraints: Any,
    allowable: Any = None,
    event: str = "two-sided",
    sense: str = "minimize",
    method: str = "ak",
    seed: Any = None,
    verify: Any = "auto",
    tradeoff: int = 7,
    confidence_level: float = 0.95,
    failures: str = "exclude",
    max_failure_fraction: float = 0.1,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
    **settings: Any,
) -> DesignResult:
    """The design of least cost whose reliability meets its targets (module docstring).

    Parameters
    ----------
    model : Model
        Its inputs are the uncertain inputs and one per design variable of kind ``"scene"``.
        A :class:`~mechrel.uq.MechanismModel` (its cycle extremes judge the whole cycle), or
        any model with labelled outputs.
    inputs : UncertainInputs
        The uncertain inputs at the base design (the study's).
    variables : sequence of DesignVariable, or mapping
        The design variables (:class:`~mechrel.uq.design.space.DesignVariable`;
        ``{name: {kind, input, lower, upper, start}}``).
    cost : str
        The cost, an expression of the variables' names (:mod:`mechrel.uq.design.expression`).
    constraints : float, ReliabilityConstraint, mapping, or sequence of them
        R ≥ target per constraint (:func:`~mechrel.uq.design.space.as_constraints`; a number:
        the whole cycle of every quantity).
    allowable : number, Allowable, or mapping, optional
        The allowables per quantity; only their means count (the allowables are
        deterministic, as a tolerance on a drawing; a std > 0 is left out and said so in the
        warnings). Default: the default allowables' means.
    event : {"two-sided", "one-sided"}, default "two-sided"
        |error| ≤ a, or error ≤ a.
    sense : {"minimize", "maximize"}, default "minimize"
        Of the cost.
    method : {"ak", "mc"}, default "ak"
        The design method (:data:`mechrel.uq.design.DESIGN_METHODS`).
    seed : int >= 0, SeedSequence or None
        The seed: the methods' draws come from its children 0–6, the verification's from 7
        and up (an independent run).
    verify : str or mapping, default "auto"
        One of :data:`VERIFY_METHODS`, or ``{"method", "n" (Monte Carlo, 10000),
        "n_per_level" (subset, 500), "p0" (0.1)}``.
    tradeoff : int >= 0, default 7
        Points of the trade-off curve (0: none).
    confidence_level : float, default 0.95
        Of the intervals.
    failures : {"exclude", "as_failure"}, default "exclude"
        A sample the model cannot evaluate is left out, or counts as beyond every allowable
        (``"mc"`` and the verification; ``"ak"`` learns only from evaluated samples).
    max_failure_fraction : float, default 0.1
        Refuse (:class:`~mechrel.uq.SampleFailuresError`) above this fraction of failed runs.
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.
    **settings
        The method's settings (``DESIGN_METHODS[key].settings``).

    Returns
    -------
    DesignResult

    Raises
    ------
    StudyError
        A bad argument (naming it, its value and what is allowed).
    SampleFailuresError
        More failed model runs than ``max_failure_fraction``.

    Examples
    --------
    A tolerance allocation with a known optimum: the error 2 x₁ + x₂ of two dimensions with
    tolerances (std) t₁, t₂, cost 1/t₁ + 1/t₂, P(|error| ≤ 1) ≥ 0.99. The error is
    N(0, 4t₁² + t₂²), so the constraint is 4t₁² + t₂² ≤ (1/z)², z = Φ⁻¹(0.995) = 2.5758, and
    the Lagrange condition 1/t_i² ∝ s_i² t_i gives t_i ∝ s_i^(−2/3): t₁ = 0.15205,
    t₂ = 0.24136, cost 10.720.

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> model = FunctionModel(lambda X: 2 * X[:, :1] + X[:, 1:], ["x1", "x2"], ["error"],
    ...                       vectorized=True)
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0, 0.1), "x2": Normal(0, 0.1)})
    >>> r = design_for_reliability(
    ...     model=model, inputs=inputs,
    ...     variables={"t1": {"kind": "std", "input": "x1", "lower": 0.01, "upper": 1.0},
    ...                "t2": {"kind": "std", "input": "x2", "lower": 0.01, "upper": 1.0}},
    ...     cost="1/t1 + 1/t2", constraints=0.99, allowable=1.0, method="mc", n=20000,
    ...     seed=1, tradeoff=0, verify={"n": 20000}, progress=False)
    >>> abs(r.cost / 10.720 - 1) < 0.02, r.active, bool(r.constraints["verified"].iloc[0])
    (True, ['all (whole-cycle) R >= 0.99'], True)
    """
    t0 = time.perf_counter()
    from . import DESIGN_METHODS

    ARGS.choice("method", method, tuple(DESIGN_METHODS))
    ARGS.choice("sense", sense, SENSES)
    check_event(event)
    confidence_level = ARGS.fraction("confidence_level", confidence_level, open_lo=True,
                                     open_hi=True)
    ARGS.choice("failures", failures, ("exclude", "as_failure"))
    max_failure_fraction = ARGS.fraction("max_failure_fraction", max_failure_fraction)
    tradeoff = ARGS.integer("tradeoff", tradeoff, ge=0)
    verify_settings = _verify_settings(verify)
    if model is None:
        raise StudyError("design_for_reliability: model = None: required; allowed: a mechrel.uq "
                         "Model (e.g. FunctionModel, MechanismModel)")
    _, index = check_model(model)
    space = design_space(model, inputs, variables)
    inputs = space.inputs
    cost_expr = cost if isinstance(cost, CostExpression) else CostExpression(cost, space.names)
    start_cost = check_finite(cost_expr, space.as_dict(space.start), "the start design")
    from ..problem.allowables import output_groups
    groups = tuple(dict.fromkeys(output_groups(index).tolist()))
    allow, left_out = _allowables(allowable, groups)
    scalars = ConstraintScalars(index, event, allow, as_constraints(constraints))
    problem = DesignProblem(model, inputs, space, cost_expr, sense, scalars, event)
    entry = DESIGN_METHODS[method]
    try:
        chosen = entry.validate(settings)
    except StudyError as exc:
        raise StudyError(f"design_for_reliability (method {method!r}): {exc}") from None
    ss = as_seed_sequence(seed)
    executor = {"n_jobs": n_jobs, "backend": backend, "cache": cache, "progress": progress,
                "chunk_size": chunk_size}
    est: DesignEstimate = entry.function(
        problem=problem, seed=ss, confidence_level=confidence_level, failures=failures,
        max_failure_fraction=max_failure_fraction, executor=executor, **chosen)
    d = np.asarray(est.design, dtype=float)
    rel = problem.reliabilities
    summary = est.estimator.summary(d, rel)
    k = summary["factor"].to_numpy(dtype=float)
    feasible = bool(np.all(k <= 1.0 + FEASIBLE))
    curve = _tradeoff(problem, est.estimator, d, tradeoff)
    ver, ver_results, ver_evs = _verify(
        problem, d, verify_settings, ss, confidence_level=confidence_level, failures=failures,
        max_failure_fraction=max_failure_fraction, executor=executor)
    t_pf = 1.0 - rel
    ctab = pd.DataFrame({
        "quantity": [c.quantity for c in problem.constraints],
        "basis": [c.basis for c in problem.constraints],
        "reliability": rel, "pf_target": t_pf, "factor": k,
        "active": k >= 1.0 - ACTIVE,
        "pf": summary["pf"].to_numpy(float), "pf_lo": summary["pf_lo"].to_numpy(float),
        "pf_hi": summary["pf_hi"].to_numpy(float),
        "interval": summary["interval"].to_numpy()}, index=pd.Index(scalars.labels(),
                                                                    name="constraint"))
    ctab = ctab.join(ver)
    ctab["verified"] = [bool(m != "none" and lo <= t) if np.isfinite(lo) else False
                        for m, lo, t in zip(ctab["verify_method"], ctab["verify_pf_lo"], t_pf)]
    # ---- warnings
    notes = list(est.notes)
    if left_out:
        notes.append("design: deterministic allowables: the std of the allowables ("
                     + ", ".join(left_out) + ") is not part of the constraint (a tolerance on a "
                     "drawing is fixed; a random allowable caps R at Φ(μ/σ))")
    eta = space.to_unit(d)
    on = np.where(eta <= ON_BOUND, "lower", np.where(eta >= 1 - ON_BOUND, "upper", ""))
    for v, o, value in zip(space.variables, on, d):
        if o:
            notes.append(f"design: the optimum lies on the {o} bound of {v.name} ({value:.6g}): "
                         "the cost would fall further beyond it; widen the bound if it is not a "
                         "hard limit, else it is the bound that is active")
    if not feasible:
        bad = [f"{lbl}: k = {kk:.4g}" for lbl, kk in zip(scalars.labels(), k) if kk > 1 + FEASIBLE]
        notes.append("design: infeasible: no design within the bounds meets "
                     + "; ".join(bad) + " (k > 1: its allowables would have to be loosened by "
                     "that factor); the result is the design closest to meeting them")
    for lbl, row in ctab.iterrows():
        if row["verify_method"] == "none":
            continue
        lo, hi, t = row["verify_pf_lo"], row["verify_pf_hi"], row["pf_target"]
        if lo > t:
            notes.append(f"design: constraint not verified: {lbl}: the independent "
                         f"{row['verify_method']} run at the optimum gives P_f = "
                         f"{row['verify_pf']:.3g} [{lo:.3g}, {hi:.3g}], above the target "
                         f"{t:.3g} beyond its interval: the design method's estimate "
                         f"({row['pf']:.3g}) is too low there")
        elif hi < t and row["active"]:
            notes.append(f"design: constraint not verified: {lbl}: the independent "
                         f"{row['verify_method']} run at the optimum gives P_f = "
                         f"{row['verify_pf']:.3g} [{lo:.3g}, {hi:.3g}], below the target "
                         f"{t:.3g} beyond its interval: the constraint holds with margin, the "
                         "design method overestimated P_f there, and a cheaper design may "
                         "meet it")
    warned = emit_warnings(notes, stacklevel=3)
    # ---- the result
    vt = pd.DataFrame({"kind": [v.kind for v in space.variables],
                       "input": [v.input for v in space.variables],
                       "value": d, "lower": space.lower, "upper": space.upper,
                       "start": space.start, "on_bound": on},
                      index=pd.Index(space.names, name="variable"))
    all_evs = list(est.evaluations) + list(ver_evs)
    prov = make_provenance(
        method=f"design_for_reliability ({method})", seed=seed_record(ss), evaluations=all_evs,
        wall_time=time.perf_counter() - t0, inputs=inputs,
        settings={"method": method, "sense": sense, "cost": cost_expr.text, "event": event,
                  "constraints": [c.label for c in problem.constraints],
                  "allowables": dict(scalars.allowables),
                  "variables": space.describe(), "verify": verify_settings,
                  "tradeoff": tradeoff, "confidence_level": confidence_level,
                  "failures": failures, "max_failure_fraction": max_failure_fraction,
                  **{k_: v for k_, v in est.settings.items()}})
    # the totals (n_evaluations, n_computed, n_cached, n_failed): every model run of this
    # call, the method's (its counts: every design it tried, not only the rows it keeps) and
    # the verification's, with the split beside them
    by_method = EvaluationCount(*(int(est.counts[k]) for k in (
        "n_evaluations", "n_computed", "n_cached", "n_failed")))
    by_verification = sum((e.count for e in ver_evs if e is not None), EvaluationCount())
    prov.update((by_method + by_verification).as_dict())
    prov["counts"] = {"design": by_method.as_dict(), "verification": by_verification.as_dict()}
    prov["model"] = describe_model(model)  # the scene and its hash; the designs' maps below
    prov["model_cache_key"] = model.cache_key()
    prov["optimum_model"] = problem.model_at(d).describe()
    return DesignResult(vt, problem.cost_at(d), start_cost, ctab, curve, est.history, method,
                        sense, cost_expr.text, est.converged, feasible, dict(est.details),
                        concat_evaluations([e for e in est.evaluations if e is not None]),
                        ver_results, prov, warned)
