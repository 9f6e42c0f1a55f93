"""Monte Carlo order statistics: the quantile of a cycle extreme with its distribution-free
interval.

From n samples of a scalar Y sorted as Y_(1) ≤ ... ≤ Y_(n), the R_t-quantile ξ is estimated
by Y_(k), k = ⌈n R_t⌉ (the empirical quantile: a fraction k/n ≥ R_t of the samples lies at or
below it). The number K of samples at or below ξ is binomial(n, R_t) whatever the distribution
of Y, so

    P(Y_(l) ≤ ξ ≤ Y_(u)) ≥ P(l ≤ K ≤ u − 1) ≥ 1 − α

for l − 1 the largest j with P(K ≤ j) ≤ α/2 and u − 1 the smallest j with P(K ≤ j) ≥ 1 − α/2
(the order-statistic interval of a quantile, e.g. David & Nagaraja, *Order Statistics*, 3rd
ed., §7.1). It is exact for independent samples (``rule="random"``) and needs no assumption on
Y. It exists only when n is large enough: Y_(u) with u ≤ n needs R_t^n ≤ α/2, n ≥
ln(α/2)/ln(R_t) (3688 samples at R_t = 0.999, α = 0.05); with fewer, the interval has no upper
end (+inf), and the estimate rests on the few largest samples (a warning below
n (1 − R_t) = 10, :data:`mechrel.uq.inverse.MC_RESOLUTION`). For Latin hypercube and Sobol'
designs the same ranks are used, as Monte Carlo's binomial intervals are (docs/uq.md).
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

from mechrel.errors import EstimateWarning, StudyError

from ..._checks import ARGS
from .._common import SampleFailuresError, failure_message
from ..execution.executor import Evaluations, evaluate
from ..problem.inputs import SAMPLING_RULES, as_seed_sequence, child_seed, seed_record, sobol_balance_note
from .quantile import InverseEstimate

__all__ = ["inverse_monte_carlo", "order_statistic_ranks", "quantile_interval"]


def order_statistic_ranks(n: int, target: float, confidence_level: float) -> tuple[int, int, int]:
    """The ranks of the estimate and of the interval of a quantile among n sorted samples.

    Parameters
    ----------
    n : int
        The number of samples (>= 1).
    target : float
        The quantile's probability R_t, in (0, 1).
    confidence_level : float
        1 − α, in (0, 1).

    Returns
    -------
    k, l, u : int
        1-based ranks: the estimate Y_(k), k = ⌈n R_t⌉, and the interval [Y_(l), Y_(u)]
        (module docstring); l = 0 when no sample bounds it from below, u = n + 1 when none
        bounds it from above.

    Examples
    --------
    >>> order_statistic_ranks(1000, 0.99, 0.95)   # Y_(990) in [Y_(983), Y_(997)]
    (990, 983, 997)
    >>> order_statistic_ranks(256, 0.999, 0.95)   # no upper end: u = n + 1
    (256, 254, 257)
    """
    alpha = 1.0 - confidence_level
    k = min(max(math.ceil(n * target - 1e-9 * n), 1), n)
    cdf = stats.binom.cdf(np.arange(n + 1), n, target)
    below = np.flatnonzero(cdf <= alpha / 2)
    l = int(below[-1]) + 1 if below.size else 0
    u = int(np.flatnonzero(cdf >= 1.0 - alpha / 2)[0]) + 1
    return k, l, u


def quantile_interval(values: np.ndarray, target: float, confidence_level: float
                      ) -> tuple[float, float, float]:
    """The ``target``-quantile of samples, with its distribution-free interval.

    Parameters
    ----------
    values : ndarray, shape (n,)
        Independent samples of the scalar (+inf for a sample beyond every allowable).
    target : float
        R_t, in (0, 1).
    confidence_level : float
        In (0, 1).

    Returns
    -------
    value, lo, hi : float
        Y_(k), Y_(l), Y_(u) (:func:`order_statistic_ranks`); lo = −inf, hi = +inf where no
        sample bounds the interval.

    Examples
    --------
    >>> y = np.arange(1.0, 1001.0)   # 1, ..., 1000
    >>> quantile_interval(y, 0.99, 0.95)
    (990.0, 983.0, 997.0)
    """
    s = np.sort(np.asarray(values, dtype=float))
    n = s.shape[0]
    k, l, u = order_statistic_ranks(n, target, confidence_level)
    return (float(s[k - 1]), float(s[l - 1]) if l >= 1 else -math.inf,
            float(s[u - 1]) if u <= n else math.inf)


def inverse_monte_carlo(*, model: Any, inputs: Any, extremes: Any, scalars: tuple[str, ...],
                        target: float, seed: Any, confidence_level: float, failures: str,
                        max_failure_fraction: float, executor: dict, n: int = 1000,
                        rule: str = "random", evaluations: Evaluations | None = None
                        ) -> InverseEstimate:
    """The quantiles of the scalars by Monte Carlo order statistics (module docstring).

    The inverse method ``"mc"`` of :func:`~mechrel.uq.inverse_reliability` (the contract of
    :mod:`mechrel.uq.inverse`): ``n`` samples drawn by ``rule`` from ``seed``'s first child
    stream (the design of :func:`~mechrel.uq.monte_carlo` with the same seed, so a cache or
    its ``evaluations`` serve both), or the precomputed ``evaluations``.

    Parameters
    ----------
    model, inputs, extremes, scalars, target, seed, confidence_level, failures, max_failure_fraction, executor
        As passed by :func:`~mechrel.uq.inverse_reliability`.
    n : int, default 1000
        Samples (ignored with ``evaluations``).
    rule : {"random", "latin_hypercube", "sobol"}, default "random"
        Sampling rule (the interval is exact for ``"random"``).
    evaluations : Evaluations, optional
        Precomputed evaluations of the model (e.g. a forward Monte Carlo run's).

    Returns
    -------
    InverseEstimate
        ``details["order_statistics"]``: per scalar the samples used and the ranks k, l, u.

    Raises
    ------
    StudyError
        A bad setting, or evaluations of another model.
    SampleFailuresError
        More failed samples than ``max_failure_fraction``, or fewer than 2 left.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> r = inverse_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
    ...                         target=0.9, method="mc", n=2000, seed=3, event="one-sided",
    ...                         allowable=1.0, progress=False)
    >>> row = r.table.loc[("all", "all")]          # Φ⁻¹(0.9) = 1.2816
    >>> bool(row["allowable_lo"] < 1.2816 < row["allowable_hi"]), r.n_evaluations
    (True, 2000)
    """
    ss = as_seed_sequence(seed)
    notes: list[str] = []
    if evaluations is not None:
        if not isinstance(evaluations, Evaluations):
            raise StudyError(f"evaluations: got {type(evaluations).__name__}; allowed: an "
                             "Evaluations of the model (mechrel.uq.evaluate)")
        if (tuple(evaluations.input_names) != tuple(inputs.names)
                or not evaluations.output_index.equals(extremes.output_index)):
            raise StudyError("evaluations: of another model (input names or outputs differ); "
                             "allowed: evaluations of this model")
        ev, rule = evaluations, "user-supplied"
    else:
        ARGS.choice("rule", rule, SAMPLING_RULES)
        n = ARGS.sample_count("n", n)
        note = sobol_balance_note(n) if rule == "sobol" else None
        if note:
            notes.append(f"inverse (mc): {note}")
        with warnings.catch_warnings():  # the caveat, if any, is the result's
            warnings.simplefilter("ignore", EstimateWarning)
            X = inputs.sample(n, rule, child_seed(ss, 0))
        ev = evaluate(model, X, **executor)
    if ev.n_failed > max_failure_fraction * ev.n:
        raise SampleFailuresError(
            f"inverse_reliability (mc): {failure_message(ev)}, more than max_failure_fraction="
            f"{max_failure_fraction}; inspect evaluations.failures(), fix the model or raise "
            "the threshold", ev)
    V = extremes.values(ev.Y)
    if failures == "exclude":
        V = V[ev.ok]
    else:
        V = np.where(ev.ok[:, None], V, np.inf)
    m = V.shape[0]
    if m < 2:
        raise SampleFailuresError(f"inverse_reliability (mc): {m} usable samples; allowed: at "
                                  "least 2", ev)
    cols = [extremes.names.index(s) for s in scalars]
    k, l, u = order_statistic_ranks(m, target, confidence_level)
    q = pd.DataFrame([quantile_interval(V[:, j], target, confidence_level) for j in cols],
                     index=pd.Index(scalars, name="scalar"), columns=["value", "lo", "hi"])
    details = pd.DataFrame({"n": m, "rank": k, "rank_lo": l, "rank_hi": u},
                           index=pd.Index(scalars, name="scalar"))
    expected = m * (1.0 - target)
    from . import MC_RESOLUTION

    if expected < MC_RESOLUTION:
        notes.append(
            f"inverse (mc): target beyond what {m} samples resolve: n (1 − R_t) = "
            f"{expected:.3g} < {MC_RESOLUTION:g} samples are expected beyond the allowable, so "
            f"it is the sorted extreme of rank {k} of {m}; use n ≥ "
            f"{math.ceil(MC_RESOLUTION / (1 - target))} or subset simulation")
    if u > m:
        need = math.ceil(math.log((1 - confidence_level) / 2) / math.log(target))
        notes.append(f"inverse (mc): the interval has no upper end: {m} samples cannot bound the "
                     f"{target:g}-quantile at {confidence_level:.0%} (that needs n ≥ {need})")
    settings = {"n": ev.n, "rule": rule, "seed": seed_record(ss),
                "ci": "order statistics (distribution-free binomial ranks)"
                + ("; the ranks of independent samples, taken as they are for this design as "
                   "Monte Carlo's binomial intervals are" if rule in ("latin_hypercube", "sobol")
                   else "")}
    return InverseEstimate(q, (ev,), {"order_statistics": details}, tuple(notes), settings)
