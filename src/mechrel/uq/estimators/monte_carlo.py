"""Monte Carlo reliability: point-in-time per output, whole-cycle, moments, with intervals.

Events (per sample, error i, allowable I)
-----------------------------------------
``event="two-sided"``  |i| ≤ I  (the tolerance is on the magnitude of the error);
``event="one-sided"``  i ≤ I    (the paper's P(I − i > 0) on the signed error).

The allowable I
---------------
``allowable_mode="sampled"`` (default): I ~ N(μ_I, σ_I²) is drawn once per sample *and per
quantity* and shared by every crank angle of that quantity: the allowable is a property of the
specification a mechanism is checked against, not of the crank angle. Point-in-time estimates
then estimate exactly the probability FOSM's interference formula computes (same event, no
normality assumption on i), and the binomial intervals are exact for random sampling.
``allowable_mode="fixed"``: I = μ_I (σ_I ignored), the classical fixed tolerance.
An ``Allowable(mean, 0)`` makes the two identical.

Whole-cycle reliability
-----------------------
P(the event holds at every instant of the cycle, jointly, in the same sample), per quantity and
for all quantities together ("all"): the quantity that matters for "stays within accuracy over
the cycle". When the model reports the cycle extremes (the ``max``/``min``/``max_abs`` entries
of :class:`~mechrel.uq.MechanismModel`'s ``crank_angle`` level, found on the integrator's
solution), the event is the one at the extreme: max |i| ≤ I (two-sided) or max i ≤ I
(one-sided); the table's ``basis`` column says "cycle extreme". Otherwise it is the event at
every analysis angle ("analysis angles"), which misses what happens between them (impact
spikes), so it can only overstate the reliability. Either way it is ≤ the smallest
point-in-time reliability of the group. ``n_outputs`` counts the analysis angles.

Intervals
---------
Reliabilities: Wilson score (default) or Clopper–Pearson binomial intervals. For
``rule="latin_hypercube"``/``"sobol"`` samples are negatively correlated / low-discrepancy and the
estimator's variance is smaller than binomial: the intervals are conservative (too wide).
Mean: ± z·s/√n. Standard deviation: asymptotic distribution-free interval for s² from the fourth
central moment, se(s²) = sqrt((m₄ − s⁴(n − 3)/(n − 1))/n), mapped to s.

Failed samples
--------------
``failures="exclude"`` (default): estimates are over the successful samples (i.e. conditional
on the model being evaluable), the failures are counted and listed by reason in the result.
``failures="as_violation"``: a failed sample counts as out of tolerance at every output
(conservative for reliability; moments still use the successful samples). Either way the run
refuses if more than ``max_failure_fraction`` of the samples failed (or fewer than 2 succeeded):
:class:`~mechrel.uq.SampleFailuresError`, a ``StudyError`` that carries the evaluations.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import EstimateWarning, StudyError

from .._docs import fill_doc
from ..._checks import ARGS
from .._common import (
    CountedByProvenance,
    SampleFailuresError,
    check_inputs,
    check_memory,
    emit_warnings,
    exclusive_source,
    executor_kwargs,
    failure_message,
    make_provenance,
    run,
)
from ..execution.executor import Evaluations
from ..problem.inputs import (SAMPLING_RULES, as_seed_sequence, child_seed, seed_record,
                              sobol_balance_note)
from ..problem.model import check_model
from ..results import OutputViews, ResultTable, limit_state_value
from ..problem.allowables import (binomial_interval, check_event, per_angle_mask, resolve_allowables,
                          whole_cycle_column)
from ._moments import column_moments
from ._tally import tally
from ._problem import Problem

__all__ = ["monte_carlo", "monte_carlo_design", "MonteCarloResult", "ALLOWABLE_MODES",
           "FAILURE_MODES"]

ALLOWABLE_MODES = ("sampled", "fixed")
FAILURE_MODES = ("exclude", "as_violation")


def _draw_allowables(n: int, mu_I: np.ndarray, sd_I: np.ndarray, groups: np.ndarray, mode: str,
                     seed: np.random.SeedSequence) -> np.ndarray:
    """(n, n_out) allowable values: one N(0,1) draw per sample and group, scaled per output."""
    if mode == "fixed":
        return np.broadcast_to(mu_I, (n, mu_I.shape[0]))
    xi, col = _standard_draws(n, groups, seed)
    return mu_I[None, :] + sd_I[None, :] * xi[:, col]


def _standard_draws(n: int, groups: np.ndarray, seed: np.random.SeedSequence):
    """The N(0,1) draws of the allowables, (n, n_groups), and each output's column in them."""
    uniq = list(dict.fromkeys(groups.tolist()))
    xi = np.random.default_rng(seed).standard_normal((n, len(uniq)))
    return xi, np.array([uniq.index(g) for g in groups])


def _allowable_draws(n: int, sd_I: np.ndarray, groups: np.ndarray, mode: str,
                     seed: np.random.SeedSequence):
    """The N(0,1) draws of the allowables and each output's column in them (those of
    :func:`_draw_allowables`), or ``(None, None)`` where no output's allowable has a spread
    (``fixed``, or every ``sigma_I`` 0): the allowable is then its mean, bitwise (μ + 0·ξ = μ
    for a finite ξ), and nothing is drawn (the allowables' stream is a child seed of its own,
    read by nothing else)."""
    if mode == "fixed" or not np.any(sd_I):
        return None, None
    return _standard_draws(n, groups, seed)


def reliability_from_samples(
    ev: Evaluations,
    *,
    allowable: Any,
    event: str,
    allowable_mode: str,
    seed: np.random.SeedSequence,
    confidence_level: float,
    ci_method: str,
    failures: str,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Point-in-time and whole-cycle reliability from evaluations (see module docstring); the
    counts in one compiled pass over the outputs (:func:`~._tally.tally`)."""
    mu_I, sd_I, groups = resolve_allowables(ev.output_index, allowable)
    xi, col = _allowable_draws(ev.n, sd_I, groups, allowable_mode, seed)
    ok = ev.ok
    rows = ok if failures == "exclude" else np.ones(ev.n, dtype=bool)
    n_eff = int(rows.sum())
    # whole cycle: the event at the cycle extreme of each quantity when the model reports its
    # cycle extremes (found on the integrator's solution), else at every analysis angle
    angle = per_angle_mask(ev.output_index)
    labels = list(dict.fromkeys(groups.tolist()))
    member = np.zeros((len(labels), len(groups)), dtype=bool)
    bases = []
    for r, g in enumerate(labels):
        c = whole_cycle_column(ev.output_index, g, event)
        if c is not None:
            member[r, c] = True
            bases.append("cycle extreme")
        else:
            member[r] = (groups == g) & angle
            bases.append("analysis angles")
    k, k_group, k_joint = tally(ev.Y, rows, ok, mu_I, sd_I, xi, col, event == "two-sided",
                                member)
    lo, hi = binomial_interval(k, n_eff, confidence_level=confidence_level, method=ci_method)
    point = pd.DataFrame(
        {"allowable_mean": mu_I, "allowable_std": sd_I, "n": n_eff, "n_inside": k,
         "reliability": k / n_eff if n_eff else np.nan, "reliability_lo": lo, "reliability_hi": hi},
        index=ev.output_index,
    )
    wc_rows = [(g, int(((groups == g) & angle).sum()), int(k_group[r]), bases[r])
               for r, g in enumerate(labels)]
    all_row = ("all", int(angle.sum()), k_joint,
               bases[0] if len(set(bases)) == 1 else "mixed")
    if len(labels) == 1 and labels == ["all"]:
        wc_rows = []
    wc_rows.append(all_row)
    kw = np.array([r[2] for r in wc_rows])
    wlo, whi = binomial_interval(kw, n_eff, confidence_level=confidence_level, method=ci_method)
    whole = pd.DataFrame(
        {"n_outputs": [r[1] for r in wc_rows], "n": n_eff, "n_inside": kw,
         "reliability": kw / n_eff if n_eff else np.nan, "reliability_lo": wlo, "reliability_hi": whi,
         "basis": [r[3] for r in wc_rows]},
        index=pd.Index([r[0] for r in wc_rows], name="group"),
    )
    return point, whole


def sample_moments(Y: np.ndarray, *, confidence_level: float,
                   rows: np.ndarray | None = None) -> pd.DataFrame:
    """mean, std, skewness, excess kurtosis per column of ``Y[rows]``, with intervals for mean
    and std (the moments in one pass: :func:`~mechrel.uq.estimators._moments.column_moments`,
    the same bits as SciPy's ``skew``/``kurtosis`` with ``bias=False``)."""
    n, mean, ss, m4, skew, kurt = column_moments(Y, rows)
    z = stats.norm.ppf(0.5 + confidence_level / 2)
    with np.errstate(invalid="ignore", divide="ignore"):
        s2 = ss / (n - 1) if n > 1 else np.full(mean.shape[0], np.nan)
        s = np.sqrt(s2)
        se_mean = s / np.sqrt(n)
        var_s2 = (m4 - s2**2 * (n - 3) / (n - 1)) / n
        se_s2 = np.sqrt(np.maximum(var_s2, 0.0))
    return pd.DataFrame(
        {"mean": mean, "mean_lo": mean - z * se_mean, "mean_hi": mean + z * se_mean,
         "std": s, "std_lo": np.sqrt(np.maximum(s2 - z * se_s2, 0.0)), "std_hi": np.sqrt(s2 + z * se_s2),
         "skewness": skew, "excess_kurtosis": kurt},
    )


@dataclass(frozen=True, eq=False)
class MonteCarloResult(OutputViews, CountedByProvenance):
    """Monte Carlo reliability and moments, or crude Monte Carlo on a limit state (frozen).

    What :func:`monte_carlo` returns, whatever its arguments: with ``allowable=`` the
    per-output ``table`` and ``whole_cycle`` (``pf_table`` is None), with ``limit_state=`` the
    limit state's ``pf_table`` (``table``, ``whole_cycle``, ``event``, ``allowable_mode`` are
    None).

    Parameters
    ----------
    table : DataFrame or None
        Per output (a :class:`~mechrel.uq.results.ResultTable`): the sample moments ``mean``
        with ``mean_lo``/``mean_hi``, ``std`` with ``std_lo``/``std_hi``, ``skewness``,
        ``excess_kurtosis``; the allowable's ``allowable_mean``, ``allowable_std``; ``n``,
        ``n_inside``, ``reliability`` with ``reliability_lo``/``reliability_hi``.
    whole_cycle : DataFrame or None
        Per quantity and ``"all"``: the joint event over the cycle.
    event : {"two-sided", "one-sided"} or None
        The event counted as inside.
    allowable, allowable_mode
        The allowables as given, and whether they were ``"sampled"`` or ``"fixed"`` at their mean
        (None on a limit state).
    rule : str
        The sampling rule (``"user-supplied"`` for precomputed evaluations).
    confidence_level, ci_method
        Level and method of the binomial intervals.
    failures : {"exclude", "as_violation"}
        What a failed sample counted as.
    n_failed : int
        Failed samples.
    failure_counts : dict
        ``{reason: count}`` of the failed samples.
    evaluations : Evaluations
        The model runs.
    seed
        The seed record.
    provenance : dict
        How the result was made.
    warnings : tuple of str
        Caveats of the estimate: a Sobol' design of a size that is not a power of 2
        (:func:`~mechrel.uq.problem.inputs.sobol_balance_note`); for a run on a PCE surrogate,
        the surrogate's.
    pf_table : DataFrame or None, default None
        With ``limit_state=`` (a :class:`~mechrel.uq.results.ResultTable`): one row (index: the
        limit state's name), ``pf`` = k/n, ``beta`` = −Φ⁻¹(pf), ``cov`` = sqrt((1 − pf)/(n pf)),
        ``pf_lo``/``pf_hi`` (the binomial interval of ``ci_method``), ``n_samples``,
        ``n_failed_domain`` (k, samples with g ≤ 0), ``n_failed_model`` and ``n_evaluations``.

    Examples
    --------
    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
    >>> from mechrel.uq import monte_carlo
    >>> r = monte_carlo(model=model, inputs=inputs, n=256, seed=3, allowable=allow,
    ...                 progress=False)
    >>> r.provenance["seed"]["entropy"], r.n_evaluations, int(r.to_frame()["n"].iloc[0])
    (3, 256, 256)
    """

    table: pd.DataFrame | None
    whole_cycle: pd.DataFrame | None
    event: str | None
    allowable: Any
    allowable_mode: str | None
    rule: str
    confidence_level: float
    ci_method: str
    failures: str
    n_failed: int
    failure_counts: dict
    evaluations: Evaluations | None
    seed: Any
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()
    pf_table: pd.DataFrame | None = None

    def to_frame(self) -> pd.DataFrame:
        """The result's table: a copy of ``table`` (or of ``pf_table`` on a limit state).

        Returns
        -------
        pandas.DataFrame
            One row per output: the sample statistics, the reliability and its confidence
            interval; or the limit state's row.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = monte_carlo(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs, n=64, seed=1,
        ...                 allowable=Allowable(10.0, 0.0), progress=False)
        >>> float(r.to_frame()["reliability"].iloc[0])
        1.0
        """
        table = self.table if self.table is not None else self.pf_table
        assert table is not None  # one of the two, by construction
        return table.copy()

    @property
    def reliability(self) -> pd.Series:
        """The estimated reliability of the selected event per output.

        Returns
        -------
        pandas.Series
            The ``reliability`` column of ``table`` (a probability).

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = monte_carlo(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs, n=4096,
        ...                 seed=1, allowable=Allowable(0.2, 0.0), progress=False)
        >>> bool(abs(float(r.reliability.iloc[0]) - 0.9545) < 0.01)   # 2 Φ(2) − 1, 3 s.e. ≈ 0.01
        True
        """
        return self._views_frame()["reliability"]

    @property
    def pf(self) -> float:
        """The estimated probability of failure P(g ≤ 0) (a result of ``limit_state=``).

        Returns
        -------
        float
            ``pf_table["pf"]``, k/n.

        Raises
        ------
        StudyError
            If the result was run with ``allowable=`` (then ``1 - reliability`` per output and
            ``whole_cycle``).

        Examples
        --------
        >>> from mechrel.uq import LimitState, Uniform, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"u": Uniform(0.0, 1.0)})
        >>> r = monte_carlo(model=linear_model([0.0], [[1.0]], ["u"]), inputs=inputs, n=1000,
        ...                 seed=2, limit_state=LimitState.exceedance([0], 0.9, kind="upper"),
        ...                 progress=False)
        >>> bool(r.pf == r.pf_table["n_failed_domain"].iloc[0] / 1000), bool(0.07 < r.pf < 0.13)
        (True, True)
        """
        return limit_state_value(self, "pf")

    @property
    def beta(self) -> float:
        """The generalised reliability index −Φ⁻¹(pf) (a result of ``limit_state=``).

        Returns
        -------
        float
            ``pf_table["beta"]``.

        Raises
        ------
        StudyError
            If the result was run with ``allowable=``.

        Examples
        --------
        g = 2 − x of a standard normal x, so β = 2:

        >>> from mechrel.uq import LimitState, Normal, UncertainInputs, linear_model
        >>> r = monte_carlo(model=linear_model([2.0], [[-1.0]], ["x"]), n=4096, seed=2,
        ...                 inputs=UncertainInputs.from_specs({"x": Normal(0.0, 1.0)}),
        ...                 limit_state=LimitState.margin(), progress=False)
        >>> bool(abs(r.beta - 2.0) < 0.15)   # the c.o.v. of pf is ≈ 0.1 at n p ≈ 90
        True
        """
        return limit_state_value(self, "beta")

    @property
    def cov(self) -> float:
        """The coefficient of variation of the estimate ``pf`` (a result of ``limit_state=``).

        Returns
        -------
        float
            √((1 − p)/(n p)) for the plain estimator (dimensionless).

        Raises
        ------
        StudyError
            If the result was run with ``allowable=``.

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> model = FunctionModel(lambda X: X[:, 0], ["x"], ["y"], vectorized=True)
        >>> r = monte_carlo(model=model, inputs=inputs, n=1024, seed=2, progress=False,
        ...                 limit_state=LimitState.exceedance(["y"], 1.0, kind="upper"))
        >>> bool(np.isclose(r.cov, ((1 - r.pf) / (1024 * r.pf)) ** 0.5))
        True
        """
        return limit_state_value(self, "cov")

    def allowable_draws(self) -> np.ndarray:
        """The allowable each sample was compared with: one draw per sample and quantity from
        the seed's allowable stream, scaled per output (the mean where ``allowable_mode`` is
        ``"fixed"``), the same numbers the result counted.

        For paired comparisons on the same samples and the same allowables, e.g. a model
        against its linearisation (``studies/fosm_vs_mc.py``).

        Returns
        -------
        numpy.ndarray, shape (n, n_out)
            The allowable of each sample (row, failed samples included) and output (column),
            in the outputs' units.

        Examples
        --------
        >>> import numpy as np
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> r = monte_carlo(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs, n=64,
        ...                 seed=5, allowable=Allowable(0.2, 0.05), progress=False)
        >>> draws = r.allowable_draws()
        >>> draws.shape
        (64, 1)
        >>> inside = np.abs(r.evaluations.Y) <= draws        # the two-sided event it counted
        >>> int(inside.sum()) == int(r.table["n_inside"].iloc[0])
        True
        """
        self._views_frame()  # a limit-state result drew no allowables
        assert self.evaluations is not None and self.allowable_mode is not None
        mu_I, sd_I, groups = resolve_allowables(self.evaluations.output_index, self.allowable)
        return _draw_allowables(self.evaluations.n, mu_I, sd_I, groups, self.allowable_mode,
                                child_seed(as_seed_sequence(self.seed), 1))


def _check_common(event, allowable_mode, confidence_level, ci_method, failures, max_failure_fraction):
    check_event(event)
    ARGS.choice("allowable_mode", allowable_mode, ALLOWABLE_MODES)
    ARGS.fraction("confidence_level", confidence_level, open_lo=True, open_hi=True)
    ARGS.choice("ci_method", ci_method, ("wilson", "clopper-pearson"))
    ARGS.choice("failures", failures, FAILURE_MODES)
    ARGS.fraction("max_failure_fraction", max_failure_fraction)


@fill_doc
def monte_carlo(
    *,
    model: Any = None,
    inputs: Any = None,
    n: int | None = None,
    rule: str = "random",
    seed: Any = None,
    evaluations: Evaluations | None = None,
    allowable: Any = None,
    event: str = "two-sided",
    limit_state: Any = None,
    allowable_mode: str = "sampled",
    confidence_level: float = 0.95,
    ci_method: str = "wilson",
    failures: str = "exclude",
    max_failure_fraction: float = 0.1,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
) -> MonteCarloResult:
    """Monte Carlo reliability of every output and of the whole cycle.

    Either ``model=`` + ``inputs=`` + ``n=`` (samples drawn by ``rule`` from ``seed``'s first
    child stream) or precomputed ``evaluations=`` (e.g. of ``inputs.sample(...)``; ``inputs`` is
    then optional). Allowable draws use ``seed``'s second child stream, so the same seed gives
    the same numbers for any ``n_jobs``/backend. ``seed=None`` draws fresh entropy and records
    it in ``provenance["seed"]``.

    Parameters
    ----------
    model : Model, optional
        The model evaluated at ``n`` samples (exclusive with ``evaluations``).
    inputs : UncertainInputs
        The uncertain inputs (required with ``model``).
    n : int
        Number of samples: an integer >= 2 (with ``model``).
    rule : {"random", "latin_hypercube", "sobol"}, default "random"
        Sampling rule (:meth:`~mechrel.uq.problem.inputs.UncertainInputs.sample`).
    seed : int >= 0, SeedSequence or None
        The study's seed; its child streams draw the inputs and the allowables.
    evaluations : Evaluations, optional
        Precomputed evaluations to analyse.
    allowable : Allowable or mapping, optional
        The allowable error I ~ N(mean, std²) in the outputs' units: None (the default
        allowables per quantity, :data:`mechrel.uq.problem.allowables.DEFAULT_ALLOWABLES`), one
        :class:`~mechrel.uq.problem.allowables.Allowable` for every output, or
        ``{quantity: Allowable}``.
    event : {"two-sided", "one-sided"}, default "two-sided"
        The safe event: P(|i| < I) (two-sided) or the paper's P(i < I) on the signed error.
    limit_state : LimitState, optional
        In place of ``allowable``/``event``: the probability of failure P(g ≤ 0) of this limit
        state (its random allowables sampled with the inputs by ``rule``), with its binomial
        interval, in the result's ``pf_table``. Needs ``model=`` and ``inputs=``.
    allowable_mode : {"sampled", "fixed"}, default "sampled"
        Draw one allowable per sample from N(mean, std²), or compare with the mean only.
    confidence_level : float in (0, 1), default 0.95
        Of the intervals on the reliability, the mean and the standard deviation.
    ci_method : {"wilson", "clopper-pearson"}, default "wilson"
        Binomial interval of the reliability.
    failures : {"exclude", "as_violation"}, default "exclude"
        Failed samples: left out (and counted) or counted as unsafe.
    max_failure_fraction : float in [0, 1], default 0.1
        Refuse (:class:`~mechrel.uq.SampleFailuresError`) above this fraction of failures.
    %(executor)s

    Returns
    -------
    MonteCarloResult
        Per output and for the whole cycle: reliability with its interval, mean, std,
        skewness, kurtosis; ``.to_frame()``, ``.evaluations``, ``.provenance``; on a limit
        state its ``pf_table`` (``.pf``, ``.beta``, ``.cov``).

    Raises
    ------
    StudyError
        A bad argument (naming it, its value and what is allowed).
    SampleFailuresError
        More failed samples than ``max_failure_fraction`` allows.

    Examples
    --------
    y = x with x ~ N(0, 0.1²) against a fixed allowable 0.2 (exact reliability 0.9545):

    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model, monte_carlo
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> r = monte_carlo(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs, n=1024,
    ...                 seed=1, allowable=Allowable(0.2, 0.0), progress=False)
    >>> row = r.to_frame().iloc[0]
    >>> bool(row["reliability_lo"] < 0.9545 < row["reliability_hi"])
    True

    P(x > 2) for x ~ N(0, 1) is Φ(−2) = 0.0228, in the same result type:

    >>> from mechrel.uq import FunctionModel, LimitState
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> model = FunctionModel(lambda X: X[:, 0], ["x"], ["y"], vectorized=True)
    >>> r = monte_carlo(model=model, inputs=inputs, n=4096, seed=2, progress=False,
    ...                 limit_state=LimitState.exceedance(["y"], 2.0, kind="upper"))
    >>> row = r.to_frame().iloc[0]
    >>> type(r).__name__, bool(row["pf_lo"] < 0.0228 < row["pf_hi"]), r.n_evaluations
    ('MonteCarloResult', True, 4096)
    """
    t0 = time.perf_counter()
    exclusive_source(model, evaluations, what="monte_carlo")
    _check_common(event, allowable_mode, confidence_level, ci_method, failures, max_failure_fraction)
    if limit_state is not None:
        if allowable is not None:
            raise StudyError("monte_carlo: allowable= and limit_state= are both given; allowed: one of them "
                             "(a limit state carries its own allowables)")
        if model is None:
            raise StudyError("monte_carlo: limit_state= with evaluations=: the limit state's random allowables "
                             "and inputs are sampled with the model's; allowed: model= and inputs= with limit_state=")
        return _limit_state_monte_carlo(
            model=model, inputs=inputs, limit_state=limit_state, n=n, rule=rule, seed=seed,
            confidence_level=confidence_level, ci_method=ci_method, failures=failures,
            max_failure_fraction=max_failure_fraction,
            executor=executor_kwargs(n_jobs, backend, cache, progress, chunk_size))
    ss = as_seed_sequence(seed)
    ss_x, ss_I = child_seed(ss, 0), child_seed(ss, 1)
    notes: tuple[str, ...] = ()
    if model is not None:
        ARGS.choice("rule", rule, SAMPLING_RULES)
        if inputs is None:
            raise StudyError("monte_carlo: inputs= is required with model=")
        names, index = check_model(model)
        inputs = check_inputs(inputs, names)
        n = ARGS.sample_count("n", n)
        check_memory(n, len(names) + len(index), "n", n)
        note = sobol_balance_note(n) if rule == "sobol" else None
        with warnings.catch_warnings():  # the caveat, if any, is the result's: emitted below
            warnings.simplefilter("ignore", EstimateWarning)
            X = inputs.sample(n, rule, ss_x)
        X.setflags(write=False)  # the design is ours: the evaluations keep it, not a copy
        notes = emit_warnings([f"monte_carlo: {note}"] if note else [])
        ev = run(model, X, executor_kwargs(n_jobs, backend, cache, progress, chunk_size))
    else:
        assert evaluations is not None  # exclusive_source: exactly one
        ev = evaluations
        rule = "user-supplied"
        if inputs is not None:
            inputs = check_inputs(inputs, ev.input_names)
    if ev.n == 0:
        raise StudyError("monte_carlo: no samples")
    if ev.n_failed > max_failure_fraction * ev.n:
        raise SampleFailuresError(
            f"monte_carlo: {failure_message(ev)}, more than max_failure_fraction="
            f"{max_failure_fraction}; inspect evaluations.failures(), fix the model or raise the threshold",
            ev,
        )
    if ev.n_ok < 2:
        raise SampleFailuresError(f"monte_carlo: need at least 2 successful samples, got {ev.n_ok}"
                                  + (f" ({failure_message(ev)})" if ev.n_failed else ""), ev)
    point, whole = reliability_from_samples(
        ev, allowable=allowable, event=event, allowable_mode=allowable_mode, seed=ss_I,
        confidence_level=confidence_level, ci_method=ci_method, failures=failures,
    )
    mom = sample_moments(ev.Y, rows=ev.ok, confidence_level=confidence_level)
    mom.index = ev.output_index
    table = ResultTable(pd.concat([mom, point], axis=1))
    prov = make_provenance(
        method="monte_carlo", seed=seed_record(ss), evaluations=[ev], inputs=inputs,
        wall_time=time.perf_counter() - t0,
        settings={"n": ev.n, "rule": rule, "event": event, "allowable_mode": allowable_mode,
                  "allowable": repr(allowable) if allowable is not None else "paper defaults",
                  "confidence_level": confidence_level, "ci_method": ci_method,
                  "failures": failures, "max_failure_fraction": max_failure_fraction,
                  "ci_note": ("binomial intervals are conservative for latin_hypercube/sobol designs"
                              if rule in ("latin_hypercube", "sobol") else "binomial intervals")},
    )
    return MonteCarloResult(
        table, whole, event, allowable, allowable_mode, rule, confidence_level, ci_method, failures,
        ev.n_failed, ev.failure_counts(), ev, ss, prov, notes,
    )


def monte_carlo_design(inputs: Any, *, n: int, rule: str = "random", seed: Any = None) -> np.ndarray:
    """The input sample ``monte_carlo(model=..., inputs=inputs, n=n, rule=rule, seed=seed)``
    evaluates (the first child stream of ``seed``), for evaluating elsewhere and passing back
    with ``evaluations=`` and the same ``seed``.

    Parameters
    ----------
    inputs : UncertainInputs
        The uncertain inputs.
    n : int
        Number of samples, an integer >= 2.
    rule : {"random", "latin_hypercube", "sobol"}, default "random"
        Sampling rule.
    seed : int >= 0, SeedSequence or None
        The study's seed (the same one passed to :func:`monte_carlo`).

    Returns
    -------
    ndarray, shape (n, d)
        The samples, in the inputs' units.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs
    >>> u = UncertainInputs.from_specs({"a": Normal(1.0, 0.1), "b": Normal(2.0, 0.2)})
    >>> X = monte_carlo_design(u, n=4, seed=1)
    >>> X.shape, bool((X == monte_carlo_design(u, n=4, seed=1)).all())
    ((4, 2), True)
    """
    ARGS.choice("rule", rule, SAMPLING_RULES)
    inputs = check_inputs(inputs, None)
    return inputs.sample(ARGS.sample_count("n", n), rule, child_seed(as_seed_sequence(seed), 0))


def _limit_state_monte_carlo(*, model, inputs, limit_state, n, rule, seed, confidence_level, ci_method,
                             failures, max_failure_fraction, executor) -> MonteCarloResult:
    """P(g ≤ 0) by crude Monte Carlo: x (and the random allowables) drawn by ``rule`` from
    ``seed``'s first child stream, g through the model; binomial interval."""
    ARGS.choice("rule", rule, SAMPLING_RULES)
    n = ARGS.sample_count("n", n)
    ss = as_seed_sequence(seed)
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, what="monte_carlo",
                      **executor)
    X = problem.inputs.sample(n, rule, child_seed(ss, 0))
    G, ok, reasons = problem.g(problem.inputs.to_standard_normal(X))
    evaluations = problem.all_evaluations()
    assert evaluations is not None  # one executor call
    n_bad = int((~ok).sum())
    if n_bad > max_failure_fraction * n:
        counts = pd.Series([r for r in reasons if r is not None], dtype=object).value_counts().to_dict()
        raise SampleFailuresError(
            f"monte_carlo: {n_bad} of {n} samples failed ({counts}), more than max_failure_fraction="
            f"{max_failure_fraction}; allowed: fix the model or raise max_failure_fraction", evaluations)
    inside = np.where(ok, G <= 0, failures == "as_violation")
    rows = ok if failures == "exclude" else np.ones(n, dtype=bool)
    m = int(rows.sum())
    if m < 2:
        raise SampleFailuresError(f"monte_carlo: {m} usable samples; allowed: at least 2", evaluations)
    k = int(inside[rows].sum())
    pf = k / m
    lo, hi = binomial_interval(np.array([k]), np.array([m]), confidence_level=confidence_level, method=ci_method)
    table = ResultTable({"pf": [pf], "beta": [float(-special.ndtri(pf))],
                         "cov": [math.sqrt((1 - pf) / (m * pf)) if pf > 0 else np.inf],
                         "pf_lo": [float(lo[0])], "pf_hi": [float(hi[0])], "n_samples": [n],
                         "n_failed_domain": [k], "n_failed_model": [n_bad],
                         "n_evaluations": [problem.n_evaluations]},
                        index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method="monte_carlo", seed=seed_record(ss),
                              settings={"n": n, "rule": rule, "confidence_level": confidence_level,
                                        "ci_method": ci_method, "failures": failures,
                                        "max_failure_fraction": max_failure_fraction})
    counts = pd.Series([r for r in reasons if r is not None], dtype=object).value_counts().to_dict()
    return MonteCarloResult(None, None, None, None, None, rule, confidence_level, ci_method, failures,
                            n_bad, counts, evaluations, ss, prov, pf_table=table)
