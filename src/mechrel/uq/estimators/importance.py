"""Importance sampling centred on the FORM design point.

Draw u⁽ᵏ⁾ ~ N(u*, I) (the standard normal density shifted to the design point, Melchers 1989;
Ditlevsen & Madsen 1996 §15) and weight each failure by the likelihood ratio

    w(u) = φ_d(u)/φ_d(u − u*) = exp(−u·u* + ½‖u*‖²),

    P̂_f = (1/n) Σ 1[g(u⁽ᵏ⁾) ≤ 0] w(u⁽ᵏ⁾),  Var P̂_f = (1/n) · sample variance of 1[g ≤ 0] w,

c.o.v. = √Var / P̂_f, and the confidence interval P̂_f ± z √Var (the central limit theorem on the
n iid weighted indicators). When the failure domain is dominated by one design point the
c.o.v. at n samples is about that of crude Monte Carlo at P_f ≈ 1/2, whatever P_f is; with several
design points of similar β (series systems) the points the shifted density misses give no
warning in the c.o.v.: use subset simulation there.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import SampleFailuresError, check_memory
from ..execution.executor import Evaluations
from ..problem.inputs import as_seed_sequence, child_seed, seed_record
from ._problem import Problem, RareEventResult, common_settings, concat_evaluations, refuse_evaluations
from .form import FORMResult, _form, check_positive

__all__ = ["importance_sampling", "ImportanceSamplingResult"]


@dataclass(frozen=True, eq=False)
class ImportanceSamplingResult(RareEventResult):
    """Importance-sampling result (frozen).

    Parameters
    ----------
    table : DataFrame
        One row: ``pf``, ``beta`` (−Φ⁻¹(pf)), ``cov``, ``pf_lo``, ``pf_hi``, ``n_samples``,
        ``n_failed_domain`` (samples with g ≤ 0), ``n_failed_model``, ``n_evaluations`` (FORM's
        included).
    form : FORMResult
        The FORM result giving the centre.
    failure_counts : dict
        ``{reason: count}`` of the samples the model could not evaluate.
    evaluations : Evaluations or None
        Every model row (FORM's included).
    provenance : dict
        How the result was made.
    warnings : tuple of str, default ()
        Caveats of the estimate (none are issued today; a run without a failing sample raises).

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from mechrel.uq import importance_sampling
    >>> r = importance_sampling(model=margin, inputs=inputs, n=200, seed=1, progress=False)
    >>> int(r.to_frame()["n_samples"].iloc[0]), r.n_evaluations > 200
    (200, True)
    """

    table: pd.DataFrame
    form: FORMResult
    failure_counts: dict
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    @property
    def cov(self) -> float:
        """The coefficient of variation of the estimate ``pf``.

        Returns
        -------
        float
            The standard error of the weighted mean over ``pf`` (dimensionless).

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
        ...                        vectorized=True)
        >>> r = importance_sampling(model=margin, inputs=inputs, n=200, seed=1, progress=False)
        >>> 0 < r.cov < 0.5
        True
        """
        return float(self.table["cov"].iloc[0])


def importance_sampling(
    *,
    model: Any,
    inputs: Any,
    evaluations: Any = None,
    limit_state: Any = None,
    seed: Any = None,
    n: int = 1000,
    design_point: FORMResult | None = None,
    confidence_level: float = 0.95,
    failures: str = "exclude",
    max_failure_fraction: float = 0.1,
    step: float = 1e-4,
    scheme: str = "central",
    tol: float = 1e-6,
    max_iter: int = 100,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
) -> ImportanceSamplingResult:
    """P_f by importance sampling around the design point (module docstring).

    Parameters
    ----------
    model, inputs, limit_state
        The model, its uncertain inputs and the limit state (default: the model's only output is
        the margin g; failure g ≤ 0).
    evaluations : None
        Precomputed evaluations cannot be used (the method chooses its points as it goes);
        anything but None is an error. Accepted so that every estimator shares one interface.
    seed
        Seed of the samples (drawn from its first child stream).
    n : int, default 1000
        Samples around the design point.
    design_point : FORMResult, optional
        FORM's result for the same problem (else FORM runs first with ``step``, ``scheme``,
        ``tol``, ``max_iter``).
    confidence_level : float, default 0.95
        Level of the interval on P_f (normal approximation).
    failures : {"exclude", "as_failure"}, default "exclude"
        A sample the model cannot evaluate is left out (the estimate is then conditional on the
        model being evaluable) or counted as a failure of the limit state.
    max_failure_fraction : float, default 0.1
        More failed samples than this fraction is an error (:class:`~mechrel.uq.SampleFailuresError`).
    step, scheme, tol, max_iter
        FORM's settings, when FORM runs here (:func:`form`).
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    ImportanceSamplingResult

    Raises
    ------
    StudyError
        If ``design_point`` is not a FORMResult of the same inputs, or no sample fails (P_f not
        estimable).
    SampleFailuresError
        If more than ``max_failure_fraction`` of the samples fail, or fewer than 2 are usable.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from scipy.special import ndtr
    >>> from mechrel.uq import importance_sampling
    >>> r = importance_sampling(model=margin, inputs=inputs, n=500, seed=1, progress=False)
    >>> bool(abs(r.pf - ndtr(-3.0)) <= 3 * r.cov * r.pf)   # within 3 of its c.o.v.
    True
    """
    refuse_evaluations(evaluations, "importance_sampling")
    n = check_positive("n", n, integer=True, minimum=1)
    ARGS.fraction("confidence_level", confidence_level, open_lo=True, open_hi=True)
    common_settings(failures=failures, max_failure_fraction=max_failure_fraction)
    ss = as_seed_sequence(seed)
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="importance_sampling")
    check_memory(n, problem.d + problem.n_out, "n", n)  # before FORM runs, not after it
    extra = []
    if design_point is None:
        fr = _form(problem, seed=None, step=step, scheme=scheme, tol=tol, max_iter=max_iter, start=None)
        n_form = problem.n_evaluations
    else:
        if not isinstance(design_point, FORMResult) or tuple(design_point.design_point.index) != problem.names:
            raise StudyError(f"importance_sampling: design_point = {type(design_point).__name__}: not a FORMResult "
                             f"of inputs {list(problem.names)}; allowed: None or form(...) of the same problem")
        fr = design_point
        n_form = fr.n_evaluations
        if fr.evaluations is not None:
            extra = [fr.evaluations]
    u_star = np.array(fr.u_star)
    U = u_star[None, :] + np.random.default_rng(child_seed(ss, 0)).standard_normal((n, problem.d))
    n_before = problem.n_evaluations
    G, ok, reasons = problem.g(U)
    n_bad = int((~ok).sum())
    if n_bad > max_failure_fraction * n:
        counts = pd.Series([r for r in reasons if r is not None]).value_counts().to_dict()
        raise SampleFailuresError(
            f"importance_sampling: {n_bad} of {n} samples failed ({counts}), more than max_failure_fraction="
            f"{max_failure_fraction}; allowed: fix the model or raise max_failure_fraction", problem.all_evaluations())
    logw = -U @ u_star + 0.5 * float(u_star @ u_star)
    ind = np.where(ok, G <= 0, failures == "as_failure").astype(float)
    rows = ok if failures == "exclude" else np.ones(n, dtype=bool)
    vals = ind[rows] * np.exp(logw[rows])
    m = int(rows.sum())
    if m < 2:
        raise SampleFailuresError(f"importance_sampling: {m} usable samples; allowed: at least 2", problem.all_evaluations())
    pf = float(vals.mean())
    se = float(vals.std(ddof=1) / np.sqrt(m))
    z = float(stats.norm.ppf(0.5 + confidence_level / 2))
    k_fail = int(ind[rows].sum())
    if k_fail == 0:
        raise StudyError(
            f"importance_sampling: none of the {m} samples around the design point failed (g ≤ 0), so P_f and its "
            "c.o.v. are not estimable; the design point is wrong (FORM converged to a local point?) or g is flat "
            "there; allowed: check the FORM result, or use subset_simulation")
    cov = se / pf
    table = pd.DataFrame({"pf": [pf], "beta": [float(-special.ndtri(pf))], "cov": [cov],
                          "pf_lo": [max(pf - z * se, 0.0)], "pf_hi": [pf + z * se],
                          "n_samples": [n], "n_failed_domain": [k_fail], "n_failed_model": [n_bad],
                          "n_evaluations": [n_form + problem.n_evaluations - n_before]},
                         index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method="importance_sampling", seed=seed_record(ss), extra_evaluations=extra,
                              settings={"n": n, "confidence_level": confidence_level, "failures": failures,
                                        "max_failure_fraction": max_failure_fraction,
                                        "centre": u_star.tolist(),
                                        "interval": "normal approximation (central limit theorem)"})
    counts = dict(pd.Series([r for r in reasons if r is not None], dtype=object).value_counts())
    return ImportanceSamplingResult(table, fr, {str(k): int(v) for k, v in counts.items()},
                                    concat_evaluations(extra + problem.evaluations), prov)
