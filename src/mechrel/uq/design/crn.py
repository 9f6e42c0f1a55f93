"""The design method ``"mc"``: the model itself on one Monte Carlo sample, mapped through
each design (common random numbers), and the optimiser on its order statistics.

One sample x₀₁, ..., x₀ₙ of the uncertain inputs at the base design (``rule``, from the seed's
child 0: the design of :func:`~mechrel.uq.monte_carlo` with the same seed, so that the start
design's runs are a forward Monte Carlo run's and share its cache) is mapped through every
design the optimiser tries (:meth:`~mechrel.uq.design.space.DesignSpace.physical`), the model
is run on it (through the cache: a design tried twice costs nothing), and each constraint's
factor k is the R_t-quantile of its ratios (:mod:`mechrel.uq.design.constraints`). With the
same draws at every design, k(d) is a continuous function of the design, and the optimiser
sees the designs' differences, not the sampling's.

It needs n (1 − R_t) ≥ 10 samples (:data:`mechrel.uq.inverse.MC_RESOLUTION`) and n runs per
design tried (a few hundred designs for three variables): the reference on a cheap model (a
closed form, a kinematic model) and the method for per-angle constraints; on a simulated
mechanism the ``"ak"`` method needs a hundredth of the runs. The estimate at a design has the
order-statistic interval of the inverse question (distribution-free) for k and a Wilson
interval for P_f; the sample is one for every design, so its error moves the optimum as a
whole (the verification's independent run measures it).
"""

from __future__ import annotations

import math
import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .._common import SampleFailuresError, failure_message
from ..execution.executor import Evaluations, evaluate
from ..inverse import MC_RESOLUTION
from ..inverse.order_statistics import quantile_interval
from ..problem.allowables import binomial_interval
from ..problem.inputs import child_seed, sobol_balance_note
from .core import DesignEstimate, optimise

__all__ = ["design_monte_carlo"]


class CRNConstraints:
    """The constraints' factors at any design from one sample mapped through it (module
    docstring); the estimator of a :class:`~mechrel.uq.design.core.DesignEstimate`.

    Parameters
    ----------
    problem : DesignProblem
    X0 : ndarray, shape (n, r)
        The sample of the uncertain inputs at the base design.
    executor : dict
        Passed to :func:`mechrel.uq.evaluate`.
    failures : {"exclude", "as_failure"}
    max_failure_fraction : float
    confidence_level : float
    """

    def __init__(self, problem, X0: np.ndarray, executor: dict, failures: str,
                 max_failure_fraction: float, confidence_level: float):
        self.problem = problem
        self.X0 = X0
        self.executor = dict(executor)
        self.failures = failures
        self.max_failure_fraction = max_failure_fraction
        self.confidence_level = confidence_level
        self._memo: dict[bytes, list[np.ndarray]] = {}
        self._last: tuple[bytes, Evaluations] | None = None  # the last design run, its rows
        self.counts = {"n_evaluations": 0, "n_computed": 0, "n_cached": 0, "n_failed": 0}
        self.n_designs = 0

    def values(self, d: np.ndarray) -> list[np.ndarray]:
        """The constraints' ratios of the sample at design ``d`` (the model run, or the
        memory of a design run before)."""
        d = np.asarray(d, dtype=float)
        key = d.tobytes()
        if key not in self._memo:
            Z = self.problem.space.physical(d, self.X0)
            first = self.n_designs == 0
            ev = evaluate(self.problem.model, Z, **{**self.executor,
                                                    "progress": self.executor["progress"] and first})
            self.n_designs += 1
            self.count(ev)
            if ev.n_failed > self.max_failure_fraction * ev.n:
                raise SampleFailuresError(
                    f"design (mc): at design {self.problem.space.as_dict(d)}, {ev.n_failed} of "
                    f"{ev.n} samples failed ({failure_message(ev)}), more than "
                    f"max_failure_fraction={self.max_failure_fraction}; allowed: bounds that "
                    "keep the model evaluable, or a larger max_failure_fraction", ev)
            self._memo[key] = self.problem.scalars.values(ev.Y)
            self._last = (key, ev)
        return self._memo[key]

    def count(self, ev: Evaluations) -> None:
        """Add the rows of a model run to :attr:`counts` (every run the method makes, the
        trade-off curve's included)."""
        for k in self.counts:
            self.counts[k] += {"n_evaluations": ev.n, "n_computed": ev.n_model_calls,
                               "n_cached": ev.n_cached, "n_failed": ev.n_failed}[k]

    def evaluations_at(self, d: np.ndarray):
        """The model rows at design ``d`` if it was the last design run, else None."""
        key = np.asarray(d, dtype=float).tobytes()
        return self._last[1] if self._last is not None and self._last[0] == key else None

    def factors(self, d: np.ndarray, reliabilities) -> np.ndarray:
        """The factor k per constraint at design ``d``."""
        return self.problem.scalars.factors(self.values(d), reliabilities, self.failures)

    def resolves(self, reliabilities) -> bool:
        """Whether n (1 − R) ≥ 10 for every target."""
        n = self.X0.shape[0]
        return bool(np.all(n * (1.0 - np.asarray(reliabilities)) >= MC_RESOLUTION - 1e-9))

    def summary(self, d: np.ndarray, reliabilities) -> pd.DataFrame:
        """Per constraint at design ``d``: ``factor`` with its order-statistic interval,
        ``pf`` (the fraction of samples beyond) with its Wilson interval."""
        rows = []
        for V, r in zip(self.values(d), reliabilities):
            if self.failures == "as_failure":
                V = np.where(np.isnan(V), np.inf, V)
            j = self.problem.scalars.governing(V, r)
            col = V[:, j]
            col = col[~np.isnan(col)]
            k, k_lo, k_hi = quantile_interval(col, r, self.confidence_level)
            # P_f of the constraint: per angle, at its governing output
            n_out = int(np.sum(col > 1.0))
            lo, hi = binomial_interval(np.array([n_out]), np.array([col.size]),
                                       confidence_level=self.confidence_level)
            rows.append({"factor": k, "factor_lo": k_lo, "factor_hi": k_hi,
                         "pf": n_out / col.size, "pf_lo": float(lo[0]),
                         "pf_hi": float(hi[0]), "n": col.size,
                         "interval": "Monte Carlo: order statistics (factor), Wilson (P_f)"})
        return pd.DataFrame(rows, index=pd.Index(self.problem.scalars.labels(),
                                                 name="constraint"))


def design_monte_carlo(*, problem, seed, confidence_level: float, failures: str,
                       max_failure_fraction: float, executor: dict, n: int = 10_000,
                       rule: str = "random", max_designs: int | None = None) -> DesignEstimate:
    """The design method ``"mc"`` (module docstring; the contract of
    :mod:`mechrel.uq.design`).

    Parameters
    ----------
    problem, seed, confidence_level, failures, max_failure_fraction, executor
        As passed by :func:`~mechrel.uq.design_for_reliability`.
    n : int, default 10000
        Samples per design.
    rule : {"random", "latin_hypercube", "sobol"}, default "random"
        Their sampling rule.
    max_designs : int, optional
        Designs the optimiser may try (default 100 + 100 m).

    Returns
    -------
    DesignEstimate

    Raises
    ------
    StudyError
        Every sample failed at every design tried.
    SampleFailuresError
        More failed runs at a design than ``max_failure_fraction``.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs, design_for_reliability, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = design_for_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
    ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
    ...     cost="1/t", constraints=0.99, allowable=1.0, method="mc", n=20000, seed=2,
    ...     tradeoff=0, verify="none", progress=False)
    >>> abs(r.design["t"] / 0.38823 - 1) < 0.02   # 1/Φ⁻¹(0.995), within the sample's error
    True
    """
    from ..problem.inputs import SAMPLING_RULES
    from ..._checks import ARGS

    ARGS.choice("rule", rule, SAMPLING_RULES)
    notes = []
    rel = problem.reliabilities
    if np.any(n * (1.0 - rel) < MC_RESOLUTION - 1e-9):
        need = math.ceil(MC_RESOLUTION / float(np.min(1.0 - rel)))
        notes.append(f"design (mc): n = {n} samples per design resolve targets down to "
                     f"1 − R = {MC_RESOLUTION / n:.2g}; the factor at R = {np.max(rel):g} rests on "
                     f"the few largest samples: n >= {need} needed")
    if rule == "sobol":
        note = sobol_balance_note(n)
        if note:
            notes.append(note)
    X0 = problem.inputs.sample(n, rule, seed=child_seed(seed, 0))
    est = CRNConstraints(problem, X0, executor, failures, max_failure_fraction, confidence_level)
    d, info = optimise(problem, est.factors, rel, problem.space.start,
                       max_evaluations=max_designs)
    est.values(d)
    ev = est.evaluations_at(d)  # the optimum's rows, if it was the last design run
    if ev is None:  # an earlier design: its rows again (from the cache, if there is one)
        ev = evaluate(problem.model, problem.space.physical(d, X0),
                      **{**executor, "progress": False})
        est.count(ev)
    history = pd.DataFrame([{"iteration": 0, "n_designs": est.n_designs,
                             "n_evaluations": est.counts["n_evaluations"],
                             "cost": info["cost"], **problem.space.as_dict(d),
                             "feasible": info["feasible"], "optimiser": info["message"]}]
                           ).set_index("iteration")
    if not info["feasible"] and not np.all(np.isfinite(info["factors"])):
        raise StudyError("design (mc): every sample failed at the designs tried; allowed: "
                         "bounds that keep the model evaluable")
    # est.counts itself: the trade-off curve's designs, run on the same sample, add to it
    return DesignEstimate(d, est, (ev,), est.counts, history, {}, tuple(notes),
                          {"n": n, "rule": rule, "n_designs": est.n_designs,
                           "population": "common random numbers: one sample of the base "
                                         "inputs mapped through every design"},
                          None)

