"""Is FOSM's normal error model good enough? Compare it with Monte Carlo, output by output.

For each output, using the successful Monte Carlo samples y of the error i:

* ``ks_stat``/``ks_pvalue``: Kolmogorov–Smirnov test of y against FOSM's own N(μ_i, σ_i²)
  (the fully specified distribution FOSM's reliability integrates: tests shape *and* FOSM's
  first-order moments);
* ``ad_stat``/``ad_pvalue``: Anderson–Darling test of normality with estimated parameters
  (shape only; statistic from ``scipy.stats.anderson``, p-value from D'Agostino & Stephens'
  (1986) formula, not clipped like scipy's interpolated table);
* ``skewness``, ``excess_kurtosis`` of y;
* ``R_fosm`` (FOSM's reliability, same ``event`` and allowable) and ``R_mc`` with its interval,
  ``diff = R_fosm − R_mc`` with ``diff_lo``/``diff_hi`` = R_fosm − (R_mc interval);
* ``flag``: True when either test rejects at ``alpha`` or R_fosm lies outside the Monte Carlo
  interval; ``flag_reason`` says which.

Both tests assume independent samples: use ``rule="random"`` Monte Carlo for this check (with
LHS/Sobol designs the p-values are not calibrated). With very many samples the tests reject
small, practically irrelevant departures; read ``diff`` to judge the practical consequence.
:meth:`NormalityResult.qq` gives QQ-plot data.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import (CountedByProvenance, _labels, emit_warnings, make_provenance,
                       resolve_outputs_safe)
from .fosm import FOSMResult
from .monte_carlo import MonteCarloResult, reliability_from_samples
from ..problem.allowables import per_angle_mask
from ..results import OutputViews, ResultTable

__all__ = ["normality_check", "NormalityResult"]


def _ad_normal_pvalue(a2: float, n: int) -> float:
    """p-value of the Anderson–Darling normality test with estimated mean and variance
    (D'Agostino & Stephens 1986, Table 4.9): A*² = A²(1 + 0.75/n + 2.25/n²) and a piecewise
    exponential fit. Unlike scipy's table interpolation it is not clipped to [0.01, 0.15]."""
    a = a2 * (1.0 + 0.75 / n + 2.25 / n**2)
    if a >= 10.0:  # beyond the fit's range its quadratic term turns upward: continue log-linearly
        p = np.exp(1.2937 - 5.709 * 10.0 + 0.0186 * 100.0 - (5.709 - 0.372) * (a - 10.0))
    elif a >= 0.6:
        p = np.exp(1.2937 - 5.709 * a + 0.0186 * a * a)
    elif a >= 0.34:
        p = np.exp(0.9177 - 4.279 * a - 1.38 * a * a)
    elif a >= 0.2:
        p = 1.0 - np.exp(-8.318 + 42.796 * a - 59.938 * a * a)
    else:
        p = 1.0 - np.exp(-13.436 + 101.14 * a - 223.73 * a * a)
    return float(min(max(p, 0.0), 1.0))


@dataclass(frozen=True, eq=False)
class NormalityResult(OutputViews, CountedByProvenance):
    """Per-output normality diagnostics of FOSM against Monte Carlo (frozen).

    Parameters
    ----------
    table : DataFrame
        Per output (a :class:`~mechrel.uq.results.ResultTable`): FOSM's ``fosm_mean``,
        ``fosm_std`` against Monte Carlo's ``mc_mean``, ``mc_std``,
        ``skewness``, ``excess_kurtosis``; the Kolmogorov–Smirnov and Anderson–Darling
        statistics and p-values (``ks_*``, ``ad_*``); ``R_fosm``, ``R_mc`` with its interval,
        their difference ``diff`` with its interval, and ``flag``/``flag_reason``.
    alpha : float
        The tests' significance level.
    event : {"two-sided", "one-sided"}
        FOSM's event (Monte Carlo's reliability is recomputed with it).
    fosm : FOSMResult
        The FOSM result checked.
    monte_carlo : MonteCarloResult
        The Monte Carlo result it is checked against.
    provenance : dict
        How the result was made.
    warnings : tuple of str
        Analysis angles where FOSM's mean μ_i or its reliability lies outside the Monte Carlo
        confidence interval (also issued as :class:`~mechrel.errors.EstimateWarning`); the cycle
        extremes' rows are in ``table`` but not in the warnings.

    Examples
    --------
    >>> from mechrel.uq import Allowable, Normal, UncertainInputs, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
    >>> from mechrel.uq import fosm, monte_carlo, normality_check
    >>> f = fosm(model=model, inputs=inputs, allowable=allow, progress=False)
    >>> mc = monte_carlo(model=model, inputs=inputs, n=1024, seed=1, allowable=allow,
    ...                  progress=False)
    >>> normality_check(fosm=f, monte_carlo=mc).warnings
    ()
    """

    table: pd.DataFrame
    alpha: float
    event: str
    fosm: FOSMResult
    monte_carlo: MonteCarloResult
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The per-output table (a copy of ``table``).

        Returns
        -------
        pandas.DataFrame
            One row per output: the moments, the test statistics and ``flag``.

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, fosm, linear_model, monte_carlo
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
        >>> f = fosm(model=model, inputs=inputs, allowable=allow, progress=False)
        >>> mc = monte_carlo(model=model, inputs=inputs, n=256, seed=1, allowable=allow,
        ...                  progress=False)
        >>> "flag" in normality_check(fosm=f, monte_carlo=mc).to_frame().columns
        True
        """
        return self.table.copy()

    @property
    def flagged(self) -> pd.DataFrame:
        """The rows of ``table`` whose output is flagged as not normal.

        Returns
        -------
        pandas.DataFrame
            The flagged outputs (empty when FOSM's normality assumption holds).

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, fosm, linear_model, monte_carlo
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
        >>> f = fosm(model=model, inputs=inputs, allowable=allow, progress=False)
        >>> mc = monte_carlo(model=model, inputs=inputs, n=1024, seed=1, allowable=allow,
        ...                  progress=False)
        >>> len(normality_check(fosm=f, monte_carlo=mc).flagged)
        0
        """
        return self.table[self.table["flag"]]

    def qq(self, output: Any) -> pd.DataFrame:
        """The QQ data of one output.

        The sorted Monte Carlo errors against the quantiles of FOSM's N(μ_i, σ_i²) at the plotting
        positions (k − 0.5)/n, and the standard-normal quantile (for a shape-only plot).

        Parameters
        ----------
        output : hashable or int
            An output label or position.

        Returns
        -------
        pandas.DataFrame
            Columns ``probability``, ``standard_normal``, ``fosm_quantile`` and ``mc_quantile`` (the
            last two in the output's unit).

        Examples
        --------
        >>> from mechrel.uq import Allowable, Normal, UncertainInputs, fosm, linear_model, monte_carlo
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
        >>> model, allow = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
        >>> f = fosm(model=model, inputs=inputs, allowable=allow, progress=False)
        >>> mc = monte_carlo(model=model, inputs=inputs, n=256, seed=1, allowable=allow,
        ...                  progress=False)
        >>> qq = normality_check(fosm=f, monte_carlo=mc).qq(0)
        >>> len(qq), float(qq["probability"].iloc[0]) == 0.5 / 256
        (256, True)
        """
        idx = self.table.index
        pos = resolve_outputs_safe(idx, output)
        ev = self.monte_carlo.evaluations
        assert ev is not None  # normality_check takes per-output results only
        y = np.sort(ev.Y[ev.ok, pos])
        n = y.shape[0]
        p = (np.arange(1, n + 1) - 0.5) / n
        z = stats.norm.ppf(p)
        mu, sd = self.table["fosm_mean"].iloc[pos], self.table["fosm_std"].iloc[pos]
        return pd.DataFrame({"probability": p, "standard_normal": z, "fosm_quantile": mu + sd * z, "mc_quantile": y})


def normality_check(
    *,
    fosm: FOSMResult,
    monte_carlo: MonteCarloResult,
    alpha: float = 0.01,
) -> NormalityResult:
    """Compare FOSM's N(μ_i, σ_i²) with the Monte Carlo error distribution, output by output.

    ``monte_carlo`` must be of the same model (same output index). Its reliability is
    recomputed with FOSM's ``event`` and allowable (``allowable_mode="sampled"``, so that both
    estimate the same probability), with the Monte Carlo result's seed, confidence level,
    interval method and failure mode.

    Parameters
    ----------
    fosm : FOSMResult
        The first-order result.
    monte_carlo : MonteCarloResult
        A Monte Carlo result of the same model.
    alpha : float in (0, 1), default 0.01
        Significance level of the normality tests.

    Returns
    -------
    NormalityResult
        Per output: test statistics and p-values, skewness, kurtosis, and the difference of
        the two reliabilities with its interval; ``.to_frame()``.

    Raises
    ------
    StudyError
        Results of different models, or a bad ``alpha``.

    Examples
    --------
    >>> from mechrel.uq import (Allowable, Normal, UncertainInputs, fosm, linear_model,
    ...                         monte_carlo, normality_check)
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 0.1)})
    >>> m, a = linear_model([0.0], [[1.0]], ["x"]), Allowable(0.2, 0.0)
    >>> f = fosm(model=m, inputs=inputs, allowable=a, progress=False)
    >>> mc = monte_carlo(model=m, inputs=inputs, n=1024, seed=1, allowable=a, progress=False)
    >>> r = normality_check(fosm=f, monte_carlo=mc)
    >>> len(r.to_frame())
    1
    """
    t0 = time.perf_counter()
    if not isinstance(fosm, FOSMResult):
        raise StudyError(f"normality_check: fosm= must be a FOSMResult, got {type(fosm).__name__}")
    if not isinstance(monte_carlo, MonteCarloResult):
        raise StudyError(f"normality_check: monte_carlo= must be a MonteCarloResult, got {type(monte_carlo).__name__}")
    for name, r in (("fosm", fosm), ("monte_carlo", monte_carlo)):
        if r.table is None:
            raise StudyError(f"normality_check: {name}= was run with limit_state= (one P_f, no "
                             "per-output table); allowed: a result run with allowable=")
    assert fosm.table is not None and fosm.evaluations is not None and fosm.event is not None
    assert monte_carlo.table is not None and monte_carlo.evaluations is not None
    alpha = ARGS.fraction("alpha", alpha, open_lo=True, open_hi=True)
    ev = monte_carlo.evaluations
    if not ev.output_index.equals(fosm.table.index):
        raise StudyError("normality_check: FOSM and Monte Carlo results have different outputs")
    if fosm.provenance.get("model_cache_key") != monte_carlo.provenance.get("model_cache_key"):
        warnings.warn("normality_check: FOSM and Monte Carlo come from models with different cache keys",
                      stacklevel=2)
    ss = monte_carlo.seed
    from ..problem.inputs import child_seed

    point, _ = reliability_from_samples(
        ev, allowable=fosm.allowable, event=fosm.event, allowable_mode="sampled", seed=child_seed(ss, 1),
        confidence_level=monte_carlo.confidence_level, ci_method=monte_carlo.ci_method, failures=monte_carlo.failures,
    )
    Y = ev.Y[ev.ok]
    mu_i = fosm.table["mean"].to_numpy()
    sd_i = fosm.table["std"].to_numpy()
    rows = []
    for k in range(Y.shape[1]):
        y = Y[:, k]
        if sd_i[k] > 0:
            ks = stats.kstest(y, "norm", args=(mu_i[k], sd_i[k]))
            ks_stat, ks_p = float(ks.statistic), float(ks.pvalue)
        else:  # FOSM predicts a point mass
            ks_stat, ks_p = (0.0, 1.0) if np.all(y == mu_i[k]) else (1.0, 0.0)
        if np.ptp(y) > 0 and y.shape[0] >= 8:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                ad = stats.anderson(y, "norm", method="interpolate")
            ad_stat = float(ad.statistic)
            ad_p = _ad_normal_pvalue(ad_stat, y.shape[0])
        else:
            ad_stat, ad_p = np.nan, np.nan
        rows.append((ks_stat, ks_p, ad_stat, ad_p))
    arr = np.array(rows, dtype=float).reshape(-1, 4)
    r_fosm = fosm.table["reliability"].to_numpy()
    r_mc = point["reliability"].to_numpy()
    lo, hi = point["reliability_lo"].to_numpy(), point["reliability_hi"].to_numpy()
    with np.errstate(invalid="ignore"):
        skew = stats.skew(Y, axis=0, bias=False)
        kurt = stats.kurtosis(Y, axis=0, fisher=True, bias=False)
    ks_rej = arr[:, 1] < alpha
    ad_rej = arr[:, 3] < alpha
    outside = (r_fosm < lo) | (r_fosm > hi)
    reasons = []
    for a, b, c in zip(ks_rej, ad_rej, outside):
        parts = [s for s, f in (("KS rejects FOSM's normal", a), ("AD rejects normality", b),
                                ("R_fosm outside MC interval", c)) if f]
        reasons.append("; ".join(parts))
    table = ResultTable(
        {"fosm_mean": mu_i, "fosm_std": sd_i, "mc_mean": Y.mean(axis=0), "mc_std": Y.std(axis=0, ddof=1),
         "skewness": skew, "excess_kurtosis": kurt,
         "ks_stat": arr[:, 0], "ks_pvalue": arr[:, 1], "ad_stat": arr[:, 2], "ad_pvalue": arr[:, 3],
         "R_fosm": r_fosm, "R_mc": r_mc, "R_mc_lo": lo, "R_mc_hi": hi,
         "diff": r_fosm - r_mc, "diff_lo": r_fosm - hi, "diff_hi": r_fosm - lo,
         "flag": ks_rej | ad_rej | outside, "flag_reason": reasons},
        index=ev.output_index,
    )
    prov = make_provenance(
        method="normality_check", seed=monte_carlo.provenance.get("seed"), evaluations=[fosm.evaluations, ev],
        wall_time=time.perf_counter() - t0,
        settings={"alpha": alpha, "event": fosm.event, "tests": "KS vs FOSM normal; Anderson-Darling (interpolated p)",
                  "monte_carlo_rule": monte_carlo.rule},
    )
    notes = []
    level = f"{monte_carlo.confidence_level:.0%}"
    mt = monte_carlo.table
    # the warnings compare FOSM with Monte Carlo where FOSM estimates something: at the analysis
    # angles (a cycle extreme is a maximum over the cycle, not a normal first-order response,
    # and only Monte Carlo estimates the whole cycle)
    angle = per_angle_mask(ev.output_index)
    if {"mean_lo", "mean_hi"} <= set(mt.columns):
        mean_out = ((mu_i < mt["mean_lo"].to_numpy()) | (mu_i > mt["mean_hi"].to_numpy())) & angle
        if mean_out.any():
            notes.append(f"fosm vs Monte Carlo: FOSM's mean μ_i lies outside the {level} Monte "
                         f"Carlo interval of the mean at {int(mean_out.sum())} of "
                         f"{int(angle.sum())} outputs, e.g. {_labels(ev.output_index, mean_out)}: "
                         "the response is not linear over the inputs' spread there; trust "
                         "Monte Carlo")
    if (outside & angle).any():
        notes.append(f"fosm vs Monte Carlo: FOSM's reliability lies outside the {level} Monte "
                     f"Carlo interval at {int((outside & angle).sum())} of {int(angle.sum())} "
                     f"outputs, e.g. {_labels(ev.output_index, outside & angle)}: FOSM's normal, "
                     "first-order model of the error does not hold there; trust Monte Carlo")
    return NormalityResult(table, alpha, fosm.event, fosm, monte_carlo, prov,
                           emit_warnings(notes))
