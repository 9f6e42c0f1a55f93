"""Active-learning reliability (AK): P_f from a Kriging surrogate refined where it decides the sign of g.

The AK-MCS scheme (Echard, Gayton & Lemaire 2011) with a system learning rule (AK-SYS, Fauriat &
Gayton 2014), an importance-sampling population for rare events (a multi-point form of AK-IS,
Echard et al. 2013) and a stopping rule on the estimate's whole interval (the bounds of Schöbi,
Sudret & Marelli 2017, plus the population's own sampling error).

What is learnt
--------------
One Kriging surrogate (:mod:`mechrel.uq.surrogates.kriging`: Matérn 5/2, linear trend) per
*unit* of the limit state, a function of the standard-normal coordinates u (model inputs and
random allowables). The units are the limit state's components (:func:`learning_units`, the one
place that says so): for the study's whole cycle one per quantity, g_q = I_q − max_cycle |e_q|.
Each model run gives every unit's margin at once, so a component costs no extra simulation, and
each surrogate stays as smooth as its component, where one surrogate of the system margin
min_q g_q would have to learn the kinks where the governing component changes and would lose a
branch whose margin is never the smallest at the points evaluated so far. The system's margin
is min over the units (series) or max (parallel).

Population
----------
The estimate is a weighted sum over a population of points u_k drawn from a density h:

    P̂_f = (1/n) Σ_k w_k 1[ĝ(u_k) ≤ 0],  w_k = φ(u_k)/h(u_k),

``"monte_carlo"``: h = φ (w = 1), ``n_population`` points, grown (new child streams of the seed)
until its sampling error fits the tolerance, up to ``max_population``. ``"importance"``: for rare
events, h = α₀φ + (1 − α₀) M⁻¹ Σ_m φ(u − c_m), α₀ = 0.1 (a defensive mixture, w ≤ 1/α₀), with
the centres c_m the surrogate's failure points found by subset simulation *on the surrogate*
(cheap: no model run); the mixture follows every failure region the surrogate knows, which a
single design point (AK-IS) does not. It is rebuilt from the current surrogate every
``REBUILD_EVERY`` iterations and when the stopping rule is first met (the run stops only on a
population of the final surrogate). ``"auto"`` chooses Monte Carlo when the surrogate's P_f
(subset simulation on it) can be resolved by at most ``AUTO_MC_ROWS`` (10⁵) and
``max_population`` points, else importance: predicting the surrogates on more rows costs more
than the importance population (10⁴ rows and a subset run on the surrogate per rebuild).

Learning and batches
--------------------
At each population point the governing unit (the smallest mean for series, the largest for
parallel) gives μ and σ; the learning function U = |μ|/σ (Echard et al.) or EFF (Bichon et al.
2008) is weighted by w, so the next point maximises w Φ(−U) (the expected contribution of a
misclassification to P̂_f) or w·EFF. ``batch_size`` points per iteration: after each pick the
candidates' posterior covariances are updated as if it had been observed (the variance does not
depend on the value: the "Kriging believer", Ginsbourger et al. 2010), so the batch spreads over
the limit state; the k points go to the executor in one call, which runs them on k workers.

Stopping rule and interval
--------------------------
With z the normal quantile of ``confidence_level``:

    P⁺ = (1/n) Σ w 1[sys(μ − zσ) ≤ 0],  P⁻ = (1/n) Σ w 1[sys(μ + zσ) ≤ 0]

bound what the surrogate's uncertainty allows, and each carries its sampling standard error s±.
The reported interval is [P⁻ − z s⁻, P⁺ + z s⁺]; the run stops when its half-width is at most
``tolerance`` · P̂_f. The population grows while its own sampling part z s/P̂_f exceeds half the
tolerance, and the model is run while the surrogate's part (P⁺ − P⁻)/P̂_f exceeds the tolerance.
``cov`` in the table is the half-width over z P̂_f.

Reproducibility: every draw comes from a child of ``seed`` in the parent process (initial design
1, Monte Carlo blocks 2, surrogate subset runs 3, importance draws 4); the Kriging fits are
deterministic (fixed starts, no random restarts). So the same seed gives the same points, hence
the same answer, for any ``n_jobs`` or backend, and a run interrupted and started again with the
same ``cache=`` replays its evaluations from the cache and ends where the uninterrupted run
ends.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import SampleFailuresError, emit_warnings
from ..execution.executor import Evaluations, evaluate
from ..problem.inputs import as_seed_sequence, child_seed, seed_record
from ._problem import Problem, RareEventResult, common_settings, refuse_evaluations
from .form import check_positive

__all__ = ["active_learning", "AKResult", "learning_units", "LEARNING", "POPULATIONS", "LOO_LIMIT"]

LEARNING = ("U", "EFF")
POPULATIONS = ("auto", "monte_carlo", "importance")
DEFENSIVE = 0.1            # α₀: weight of φ in the importance mixture (weights ≤ 1/α₀)
N_CENTRES = 200            # centres of the importance mixture
N_SUBSET = 2000            # samples per level of the subset runs on the surrogate
REBUILD_EVERY = 10         # iterations between rebuilds of an importance population
LOO_LIMIT = 0.05           # leave-one-out RMS error near g = 0 over the spread of g that warns
LOGH_CHUNK = 20_000         # rows per block of the mixture density (20 000 × 200 centres: 32 MB)
IS_GROW = 8                # an importance population grows to at most IS_GROW × n_population rows
AUTO_MC_ROWS = 100_000     # "auto": Monte Carlo only when the tolerance needs at most this many rows
FREEZE_U = 8.0             # points whose every unit has |μ| ≥ FREEZE_U σ are not re-predicted
REFRESH_EVERY = 10         # iterations between full passes over the population
FRESH_EVERY = 3            # Kriging refits between fits that also start afresh (not only warm)


# ----------------------------------------------------------------------------- units
def learning_units(problem: Problem) -> tuple[list[str], Callable[[np.ndarray, np.ndarray | None], np.ndarray]]:
    """What AK learns one surrogate each: the limit state's components (module docstring).

    The one place that decides the unit: a finer decomposition of the limit state (one margin
    per output label and sign) changes this function only.

    Parameters
    ----------
    problem : Problem
        The bound problem (its limit state and output index).

    Returns
    -------
    names : list of str
        One name per unit.
    margins : callable
        ``margins(Y, A) -> (n, n_units)``: the unit margins from the model outputs Y and the
        random allowables A (None without).

    Examples
    --------
    >>> import numpy as np, pandas as pd
    >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs
    >>> ls = LimitState.series(LimitState.exceedance("a", 1.0, kind="upper"),
    ...                        LimitState.exceedance("b", 2.0, kind="upper"))
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> model = FunctionModel(lambda X: np.column_stack([X[:, 0], -X[:, 0]]), ["x"], ["a", "b"],
    ...                       vectorized=True)
    >>> p = Problem(model=model, inputs=inputs, limit_state=ls, n_jobs=1, backend="loky",
    ...             cache=None, progress=False, chunk_size=None, what="ak")
    >>> names, margins = learning_units(p)
    >>> names, margins(np.array([[0.5, -0.5]]), None).tolist()
    (['a', 'b'], [[0.5, 2.5]])
    """
    return [c.name for c in problem.limit_state.components], problem.bound.components


def _system(problem: Problem) -> Callable[[np.ndarray], np.ndarray]:
    if problem.limit_state.system == "series":
        return lambda G: G.min(axis=1)
    return lambda G: G.max(axis=1)


# ----------------------------------------------------------------------------- result
@dataclass(frozen=True, eq=False)
class AKResult(RareEventResult):
    """Active-learning (AK) reliability result (frozen).

    Parameters
    ----------
    table : DataFrame
        One row: ``pf`` (P̂_f on the final surrogate and population), ``beta`` (−Φ⁻¹(pf)),
        ``cov`` (the interval's half-width over z·pf), ``pf_lo``, ``pf_hi`` (the interval:
        surrogate bounds and sampling), ``pf_minus``, ``pf_plus`` (the surrogate's bounds P⁻,
        P⁺), ``cov_sampling`` (of P̂_f over the population), ``population``, ``n_population``,
        ``n_iterations``, ``converged``, ``n_failed_model``, ``n_evaluations``.
    history : DataFrame
        One row per iteration: evaluations so far, ``pf``, ``pf_minus``, ``pf_plus``,
        ``cov_sampling``, ``n_population``, ``population``, the best learning score.
    units : DataFrame
        One row per learnt unit (component): evaluations where it failed, its share of P̂_f
        (points where it governs), its own upper bound, the RMS of its standardised
        leave-one-out residuals near g = 0, its nugget and correlation lengths.
    surrogates : tuple of Kriging
        The final surrogate of each unit (standard-normal inputs).
    evaluations : Evaluations or None
        Every model row.
    provenance : dict
        How the result was made.
    warnings : tuple of str, default ()
        Caveats (also issued as :class:`~mechrel.errors.EstimateWarning`): the stopping rule not
        reached within the budget, leave-one-out errors near g = 0 beyond the surrogate's own
        σ, a non-smooth model, a unit predicted to fail where no evaluation failed it, the
        population's sampling error at its largest size, no failing population point.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, active_learning
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 2.5 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> r = active_learning(model=margin, inputs=inputs, seed=1)
    >>> bool(r.to_frame()["converged"].iloc[0]), r.n_evaluations < 40
    (True, True)
    """

    table: pd.DataFrame
    history: pd.DataFrame
    units: pd.DataFrame
    surrogates: tuple = field(repr=False)
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    @property
    def cov(self) -> float:
        """The relative half-width of the interval over z (a coefficient of variation).

        Returns
        -------
        float
            (pf_hi − pf_lo)/(2 z pf), dimensionless.

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, active_learning
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 2.5 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
        ...                        vectorized=True)
        >>> 0 < active_learning(model=margin, inputs=inputs, seed=1).cov < 0.1
        True
        """
        return float(self.table["cov"].iloc[0])


# ----------------------------------------------------------------------------- surrogate of the units
class _Constant:
    """A unit that took one value at every evaluation: predicted exactly (σ = 0)."""

    def __init__(self, value: float, d: int):
        self.value = float(value)
        self.nugget = 0.0
        self.sigma2 = 0.0
        self.lengths = np.full(d, np.nan)

    def predict(self, U, std=False, chunk=None):
        mu = np.full(np.atleast_2d(U).shape[0], self.value)
        return (mu, np.zeros_like(mu)) if std else mu

    def posterior_cov(self, U):
        m = np.atleast_2d(U).shape[0]
        return np.zeros((m, m))

    def loo(self):
        return np.zeros(0), np.zeros(0)


class _Surrogates:
    """One Kriging per unit, fitted on the evaluated points (failed rows left out)."""

    def __init__(self, trend: str):
        self.trend = trend
        self.gps: list = []
        self.fits = 0

    def fit(self, U: np.ndarray, G: np.ndarray) -> None:
        from ..surrogates.kriging import fit_kriging, one_blas_thread

        old = self.gps
        gps = []
        with one_blas_thread():
            for c in range(G.shape[1]):
                y = G[:, c]
                if np.ptp(y) == 0.0:
                    gps.append(_Constant(y[0], U.shape[1]))
                    continue
                warm = old[c] if c < len(old) and not isinstance(old[c], _Constant) else None
                gps.append(fit_kriging(U, y, trend=self.trend, warm=warm, fresh=self.fits % FRESH_EVERY == 0))
        self.gps = gps
        self.fits += 1

    def predict(self, U: np.ndarray, std: bool = True):
        """μ (m, c) and σ (m, c) of every unit (σ None with ``std=False``)."""
        from ..surrogates.kriging import one_blas_thread

        m = U.shape[0]
        mu = np.empty((m, len(self.gps)))
        sd = np.empty((m, len(self.gps))) if std else None
        with one_blas_thread():
            for c, gp in enumerate(self.gps):
                if std:
                    mu[:, c], sd[:, c] = gp.predict(U, std=True)
                else:
                    mu[:, c] = gp.predict(U)
        return mu, sd


# ----------------------------------------------------------------------------- populations
def _log_phi(U: np.ndarray) -> np.ndarray:
    d = U.shape[1]
    return -0.5 * (U * U).sum(1) - 0.5 * d * math.log(2 * math.pi)


class _Population:
    """Points u_k ~ h with log-weights log φ − log h, drawn in blocks from child streams."""

    def __init__(self, kind: str, d: int, ss: np.random.SeedSequence, centres: np.ndarray | None = None):
        self.kind = kind
        self.d = d
        self.ss = ss
        self.centres = centres
        self.U = np.empty((0, d))
        self.logw = np.empty(0)
        self.blocks = 0

    def _log_h(self, U: np.ndarray) -> np.ndarray:
        lp = _log_phi(U)
        if self.kind == "monte_carlo":
            return lp
        C = self.centres
        c2 = (C * C).sum(1)
        lmix = np.empty(U.shape[0])
        for s in range(0, U.shape[0], LOGH_CHUNK):  # bounds the (rows × centres) block's memory
            u = U[s: s + LOGH_CHUNK]
            d2 = (u * u).sum(1)[:, None] + c2[None, :] - 2.0 * (u @ C.T)
            lk = -0.5 * np.maximum(d2, 0.0)
            top = lk.max(axis=1)  # log Σ exp, shifted by the row's largest term (finite)
            lmix[s: s + LOGH_CHUNK] = top + np.log(np.exp(lk - top[:, None]).sum(axis=1))
        lmix += -0.5 * self.d * math.log(2 * math.pi) - math.log(C.shape[0])
        return np.logaddexp(math.log(DEFENSIVE) + lp, math.log(1.0 - DEFENSIVE) + lmix)

    def grow(self, n: int) -> slice:
        rng = np.random.default_rng(child_seed(self.ss, self.blocks))
        self.blocks += 1
        Z = rng.standard_normal((n, self.d))
        if self.kind == "importance":
            pick = rng.random(n) >= DEFENSIVE
            Z[pick] += self.centres[rng.integers(0, self.centres.shape[0], int(pick.sum()))]
        start = self.U.shape[0]
        self.U = np.vstack([self.U, Z])
        self.logw = np.concatenate([self.logw, _log_phi(Z) - self._log_h(Z)])
        return slice(start, self.U.shape[0])

    @property
    def n(self) -> int:
        return int(self.U.shape[0])


def _estimate(ind: np.ndarray, w: np.ndarray) -> tuple[float, float]:
    """(P̂, standard error) of the weighted indicator mean."""
    v = ind * w
    n = v.shape[0]
    return float(v.mean()), float(v.std(ddof=1) / math.sqrt(n)) if n > 1 else math.inf


def _subset_on(gfun: Callable[[np.ndarray], np.ndarray], d: int, ss: np.random.SeedSequence,
               n: int = N_SUBSET, p0: float = 0.1, rho: float = 0.8, max_levels: int = 14):
    """Subset simulation on a cheap vectorised g (the surrogate's mean): (P̂, the samples of the
    last level, their g). Conditional sampling (Papaioannou et al. 2015), as
    :func:`~mechrel.uq.subset_simulation` on the model; here no model runs."""
    rng = np.random.default_rng(child_seed(ss, 0))
    U = rng.standard_normal((n, d))
    G = gfun(U)
    nc = int(n * p0)
    p = 1.0
    for level in range(max_levels):
        order = np.argsort(G, kind="stable")
        b = 0.5 * (G[order[nc - 1]] + G[order[nc]])
        if b <= 0:
            return p * float(np.mean(G <= 0)), U, G
        p *= p0
        cu, cg = U[order[:nc]], G[order[:nc]]
        us, gs = [cu], [cg]
        lrng = np.random.default_rng(child_seed(ss, level + 1))
        for _ in range(int(round(1 / p0)) - 1):
            cand = rho * cu + math.sqrt(1 - rho * rho) * lrng.standard_normal(cu.shape)
            gc = gfun(cand)
            acc = gc <= b
            cu = np.where(acc[:, None], cand, cu)
            cg = np.where(acc, gc, cg)
            us.append(cu)
            gs.append(cg)
        U, G = np.vstack(us), np.concatenate(gs)
    return p * float(np.mean(G <= 0)), U, G


def _eff(mu: np.ndarray, sd: np.ndarray) -> np.ndarray:
    """Expected feasibility function at threshold 0 with ε = 2σ (Bichon et al. 2008)."""
    s = np.maximum(sd, 1e-300)
    e = 2.0 * s
    t0, tm, tp = -mu / s, (-e - mu) / s, (e - mu) / s
    N, n = special.ndtr, stats.norm.pdf
    return (mu * (2 * N(t0) - N(tm) - N(tp)) - s * (2 * n(t0) - n(tm) - n(tp)) + e * (N(tp) - N(tm)))


# ----------------------------------------------------------------------------- the estimator
def active_learning(
    *,
    model: Any,
    inputs: Any,
    evaluations: Any = None,
    limit_state: Any = None,
    seed: Any = None,
    n_initial: int | None = None,
    initial: Any = None,
    batch_size: int = 2,
    max_evaluations: int = 300,
    tolerance: float = 0.1,
    learning: str = "U",
    population: str = "auto",
    n_population: int = 10_000,
    max_population: int = 1_000_000,
    trend: str = "linear",
    confidence_level: float = 0.95,
    max_failure_fraction: float = 0.1,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = False,
    chunk_size: int | None = None,
) -> AKResult:
    """P_f by active learning on Kriging surrogates of the limit state's components (module docstring).

    Parameters
    ----------
    model, inputs, limit_state
        The model, its uncertain inputs and the limit state (default: the model's only output is
        the margin g; failure g ≤ 0).
    evaluations : None
        Precomputed evaluations cannot be used (the method chooses its points as it goes).
    seed
        Seed of every draw (initial design, populations).
    initial : AKResult, optional
        An earlier result on the same model and inputs (e.g. at another allowable): its
        evaluated points join the initial design, so that a curve of P_f against the allowable
        learns each point from the last one's runs (free with the same ``cache=``: the model
        is not run again).
    n_initial : int, optional
        Model runs of the initial design (a Latin hypercube in standard normal space); default
        max(10, 2(d + 2)) with d the number of inputs and random allowables.
    batch_size : int, default 2
        Points per iteration, evaluated in one executor call (on ``n_jobs`` workers). The
        answer depends on it, not on ``n_jobs``.
    max_evaluations : int, default 300
        Model-run budget (initial design included); reaching it before the stopping rule warns.
    tolerance : float, default 0.1
        Stop when the interval's half-width is at most ``tolerance`` · P̂_f.
    learning : {"U", "EFF"}, default "U"
        The learning function, weighted by the population weight.
    population : {"auto", "monte_carlo", "importance"}, default "auto"
        Where P_f is estimated and the candidates come from (module docstring).
    n_population : int, default 10000
        Initial population size (it grows as the sampling error demands).
    max_population : int, default 1000000
        Largest population.
    trend : {"linear", "constant"}, default "linear"
        The Kriging trend.
    confidence_level : float, default 0.95
        Level of the interval and of the surrogate bounds (z).
    max_failure_fraction : float, default 0.1
        More failed model runs than this fraction is an error (a failed run is left out of the
        surrogates' training; the estimate is conditional on the model being evaluable).
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    AKResult

    Raises
    ------
    StudyError
        A setting out of range, or too few usable initial runs to fit the surrogates.
    SampleFailuresError
        More than ``max_failure_fraction`` of the model runs failed.

    Examples
    --------
    The four-branch series system (Waarts 2000; P_f ≈ 4.4e-3 for k = 6):

    >>> import numpy as np
    >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs, active_learning
    >>> def branches(X):
    ...     a, b = X[:, 0], X[:, 1]
    ...     s = 3 + 0.1 * (a - b) ** 2
    ...     return np.column_stack([s - (a + b) / 2**0.5, s + (a + b) / 2**0.5,
    ...                             (a - b) + 6 / 2**0.5, (b - a) + 6 / 2**0.5])
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> model = FunctionModel(branches, inputs.names, ["g1", "g2", "g3", "g4"], vectorized=True)
    >>> ls = LimitState.series(*(LimitState.margin(f"g{i}") for i in range(1, 5)))
    >>> r = active_learning(model=model, inputs=inputs, limit_state=ls, seed=3)
    >>> bool(r.pf_lo <= 4.46e-3 <= r.pf_hi) if False else bool(3.9e-3 < r.pf < 5.0e-3), r.n_evaluations <= 150
    (True, True)
    """
    refuse_evaluations(evaluations, "active_learning")
    batch = check_positive("batch_size", batch_size, integer=True, minimum=0)
    budget = check_positive("max_evaluations", max_evaluations, integer=True, minimum=1)
    tol = check_positive("tolerance", tolerance)
    ARGS.choice("learning", learning, LEARNING)
    ARGS.choice("population", population, POPULATIONS)
    n_pop0 = check_positive("n_population", n_population, integer=True, minimum=99)
    n_pop_max = check_positive("max_population", max_population, integer=True, minimum=n_pop0 - 1)
    from ..surrogates.kriging import TRENDS

    ARGS.choice("trend", trend, TRENDS)
    ARGS.fraction("confidence_level", confidence_level, open_lo=True, open_hi=True)
    common_settings(failures="exclude", max_failure_fraction=max_failure_fraction)
    ss = as_seed_sequence(seed)
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="active_learning")
    d = problem.d
    p_trend = 1 if trend == "constant" else d + 1
    n0 = max(10, 2 * (d + 2)) if n_initial is None else check_positive("n_initial", n_initial, integer=True,
                                                                       minimum=p_trend + 1)
    if n0 > budget:
        raise StudyError(f"active_learning: n_initial = {n0} > max_evaluations = {budget}; allowed: "
                         "n_initial <= max_evaluations")
    names, margins = learning_units(problem)
    system = _system(problem)
    n_units = len(names)
    z = float(stats.norm.ppf(0.5 + confidence_level / 2))

    # ---- model runs: every unit's margin at each point
    Ut = np.empty((0, d))
    Gt = np.empty((0, n_units))
    failed_u: list[np.ndarray] = []
    n_bad = 0

    def run(U: np.ndarray) -> None:
        nonlocal Ut, Gt, n_bad
        X = problem.to_x(U)
        # a progress bar for the initial design only, not one per batch of a few points
        ev = evaluate(problem.model, X[:, : problem.d_model],
                      **{**problem.executor, "progress": problem.executor["progress"] and U.shape[0] > batch})
        problem.evaluations.append(ev)
        A = X[:, problem.d_model:] if X.shape[1] > problem.d_model else None
        ok = ev.ok.copy()
        G = np.full((U.shape[0], n_units), np.nan)
        if ok.any():
            G[ok] = margins(ev.Y[ok], None if A is None else A[ok])
        ok &= np.all(np.isfinite(G), axis=1)
        n_bad += int((~ok).sum())
        failed_u.extend(U[~ok])
        Ut = np.vstack([Ut, U[ok]])
        Gt = np.vstack([Gt, G[ok]])
        if n_bad > max_failure_fraction * problem.n_evaluations:
            evs = problem.all_evaluations()
            raise SampleFailuresError(
                f"active_learning: {n_bad} of {problem.n_evaluations} model runs failed "
                f"({evs.failure_counts() if evs is not None else {}}), more than max_failure_fraction="
                f"{max_failure_fraction}; allowed: fix the model or raise max_failure_fraction", evs)

    from scipy.stats import qmc

    lhs = qmc.LatinHypercube(d=d, seed=np.random.default_rng(child_seed(ss, 1))).random(n0)
    U0 = special.ndtri(np.clip(lhs, 1e-12, 1 - 1e-12))
    if initial is not None:
        if not isinstance(initial, AKResult) or not initial.surrogates or \
                tuple(initial.provenance["settings"].get("inputs_names", ())) != problem.names or \
                initial.surrogates[0].X.shape[1] != d:
            raise StudyError(f"active_learning: initial = {type(initial).__name__}: not an AKResult of inputs "
                             f"{list(problem.names)}; allowed: None or active_learning(...) of the same inputs")
        U0 = np.vstack([initial.surrogates[0].X, U0])
    run(U0)
    if Ut.shape[0] < p_trend + 2:
        raise StudyError(f"active_learning: {Ut.shape[0]} usable initial runs of {n0}; allowed: at least "
                         f"{p_trend + 2} (a larger n_initial, or fewer model failures)")

    sur = _Surrogates(trend)
    pop: _Population | None = None
    n_rebuild = 0
    history = []
    notes: list[str] = []
    converged = False
    it = 0
    since_rebuild = 0
    since_refresh = 0
    rebuild_now = refresh_now = False
    pop_fit = full_fit = -1
    # per population point: μ, σ of each unit; frozen rows are not re-predicted
    MU = SD = None
    frozen = current = None
    predicted_with = -1

    def build_population(kind_wanted: str) -> _Population:
        nonlocal n_rebuild
        gsys = lambda U: system(sur.predict(U, std=False)[0])  # noqa: E731
        if kind_wanted == "auto":
            p_ss, _, _ = _subset_on(gsys, d, child_seed(child_seed(ss, 3), n_rebuild))
            delta = tol / (2 * z)
            # Monte Carlo rows the tolerance needs at this P_f; above AUTO_MC_ROWS predicting on
            # them costs more than building (and re-predicting) an importance population
            n_mc = (1.0 - p_ss) / (p_ss * delta * delta) if p_ss > 0 else math.inf
            kind_wanted = "monte_carlo" if n_mc <= min(n_pop_max, AUTO_MC_ROWS) else "importance"
        if kind_wanted == "monte_carlo":
            P = _Population("monte_carlo", d, child_seed(ss, 2))
        else:
            _, Us, Gs = _subset_on(gsys, d, child_seed(child_seed(ss, 3), n_rebuild))
            order = np.argsort(Gs, kind="stable")
            fail = order[Gs[order] <= 0]
            pool = fail if fail.size >= N_CENTRES // 4 else order[: max(N_CENTRES, 1)]
            step = max(1, pool.size // N_CENTRES)
            centres = Us[np.sort(pool)[::step][:N_CENTRES]]
            P = _Population("importance", d, child_seed(child_seed(ss, 4), n_rebuild), centres)
        n_rebuild += 1
        P.grow(n_pop0)
        return P

    fitted = -1
    best = 0.0
    explored: dict[int, int] = {}
    while True:
        if fitted != Ut.shape[0]:
            sur.fit(Ut, Gt)
            fitted = Ut.shape[0]
        if pop is None or (pop.kind == "importance" and (since_rebuild >= REBUILD_EVERY or rebuild_now)):
            pop = build_population(population if pop is None else "importance")
            pop_fit = fitted
            MU = SD = frozen = None
            since_rebuild = 0
            rebuild_now = False
        # ---- predict on the population: rows not yet predicted by this surrogate and not frozen
        if MU is None or since_refresh >= REFRESH_EVERY or refresh_now:
            MU = np.empty((pop.n, n_units))
            SD = np.empty((pop.n, n_units))
            frozen = np.zeros(pop.n, dtype=bool)
            current = np.zeros(pop.n, dtype=bool)
            since_refresh = 0
            full_fit = fitted
            refresh_now = False
        if MU.shape[0] < pop.n:  # grown: new rows
            extra = pop.n - MU.shape[0]
            MU = np.vstack([MU, np.empty((extra, n_units))])
            SD = np.vstack([SD, np.empty((extra, n_units))])
            frozen = np.concatenate([frozen, np.zeros(extra, dtype=bool)])
            current = np.concatenate([current, np.zeros(extra, dtype=bool)])
        if predicted_with != fitted:
            current &= frozen
            predicted_with = fitted
        act = np.flatnonzero(~current)
        if act.size:
            MU[act], SD[act] = sur.predict(pop.U[act])
            current[act] = True
            frozen[act] = np.all(np.abs(MU[act]) >= FREEZE_U * SD[act], axis=1)
        # ---- estimates
        w = np.exp(pop.logw)
        hat = system(MU) <= 0
        plus = system(MU - z * SD) <= 0
        minus = system(MU + z * SD) <= 0
        pf, se = _estimate(hat, w)
        pp, sp = _estimate(plus, w)
        pm, sm = _estimate(minus, w)
        lo, hi = max(pm - z * sm, 0.0), pp + z * sp
        half = (hi - lo) / 2
        samp = z * se / pf if pf > 0 else math.inf
        history.append({"iteration": it, "n_evaluations": problem.n_evaluations, "pf": pf, "pf_minus": pm,
                        "pf_plus": pp, "cov_sampling": se / pf if pf > 0 else np.nan,
                        "n_population": pop.n, "population": pop.kind})
        # ---- grow the population when its sampling error dominates
        # (an importance population is first redrawn for the current surrogate, and grows to at
        # most IS_GROW × n_population rows: a proposal that needs more is a poor one, and the
        # next rebuild's centres, from a better surrogate, are the cure, not more rows)
        cap = n_pop_max if pop.kind == "monte_carlo" else min(n_pop_max, IS_GROW * n_pop0)
        if pf > 0 and samp > tol / 2 and pop.kind == "importance" and pop_fit != fitted:
            rebuild_now = True
            continue
        if pf > 0 and samp > tol / 2 and pop.n < cap:
            want = pop.n * (samp / (0.9 * tol / 2)) ** 2
            if population == "auto" and pop.kind == "monte_carlo" and want > n_pop_max:
                pop = build_population("importance")
                pop_fit = fitted
                MU = SD = frozen = None
                since_rebuild = 0
            else:
                pop.grow(max(int(min(cap, math.ceil(want))) - pop.n, pop.n // 2, 1))
            history[-1]["grown"] = True
            continue
        done = pf > 0 and half <= tol * pf
        if pf == 0 and pp == 0:
            done = True
        if done and pop.kind == "importance" and pop_fit != fitted:
            rebuild_now = True   # confirm on a population drawn for this surrogate
            continue
        if done and full_fit != fitted:
            refresh_now = True   # confirm on a full pass over the population
            continue
        if done:
            probe = _unexplored(MU, w, Gt, problem.limit_state.system, pop.U, explored, pf, failed_u)
            if probe is not None and problem.n_evaluations + probe.shape[0] <= budget:
                it += 1
                since_refresh += 1
                since_rebuild += 1
                run(probe)
                continue
            converged = True
            break
        if problem.n_evaluations >= budget:
            break
        # ---- choose the next batch
        k = min(batch, budget - problem.n_evaluations)
        pts, best = _select(sur, pop.U, MU, SD, w, frozen, learning, k, [*failed_u, *Ut],
                            problem.limit_state.system)
        history[-1]["score"] = best
        it += 1
        since_refresh += 1
        since_rebuild += 1
        run(pts)

    # ---- diagnostics
    caveats = _diagnose(problem, names, sur, Gt, MU, SD, w, z, pf, pp, converged, budget, tol,
                        half, samp, pop, n_pop_max)
    notes.extend(caveats)
    warnings_ = emit_warnings(notes, stacklevel=3)
    table = pd.DataFrame({
        "pf": [pf], "beta": [float(-special.ndtri(pf)) if pf > 0 else np.inf],
        "cov": [half / (z * pf) if pf > 0 else np.nan], "pf_lo": [lo], "pf_hi": [hi],
        "pf_minus": [pm], "pf_plus": [pp], "cov_sampling": [se / pf if pf > 0 else np.nan],
        "population": [pop.kind], "n_population": [pop.n], "n_iterations": [it], "converged": [converged],
        "n_failed_model": [n_bad], "n_evaluations": [problem.n_evaluations]},
        index=pd.Index([problem.limit_state.name], name="limit_state"))
    units = _unit_table(names, sur, Gt, MU, SD, w, z, system, pf, problem.limit_state.system)
    prov = problem.provenance(method="active_learning", seed=seed_record(ss), settings={
        "n_initial": n0, "batch_size": batch, "max_evaluations": budget, "tolerance": tol,
        "learning": learning, "population": population, "n_population": n_pop0,
        "max_population": n_pop_max, "trend": trend, "confidence_level": confidence_level,
        "max_failure_fraction": max_failure_fraction, "units": names, "inputs_names": list(problem.names),
        "initial": None if initial is None else int(initial.surrogates[0].X.shape[0]),
        "interval": "surrogate bounds at ±z σ plus the population's sampling error"})
    return AKResult(table, pd.DataFrame(history), units,
                    tuple(sur.gps), problem.all_evaluations(), prov, warnings_)


def _select(sur, U, MU, SD, w, frozen, learning, k, exclude, system_kind):
    """The next k points (and the best score), none of ``exclude`` (the points already run):
    the best weighted learning score, then the believer's update of the candidates'
    covariances."""
    gov = np.argmin(MU, axis=1) if system_kind == "series" else np.argmax(MU, axis=1)
    rows = np.arange(U.shape[0])
    mu = MU[rows, gov]
    sd = np.maximum(SD[rows, gov], 1e-300)
    score = w * (special.ndtr(-np.abs(mu) / sd) if learning == "U" else _eff(mu, sd))
    score[frozen] = 0.0
    m = min(U.shape[0], max(200, 50 * k))
    cand = _candidates(score, U, exclude, m)
    best = float(score[cand[0]])
    if k == 1:
        return U[cand[:1]], best
    from ..surrogates.kriging import Believer

    C = U[cand]
    believer = Believer(sur.gps, C)
    g_c = gov[cand]
    mu_c = mu[cand]
    w_c = w[cand]
    chosen: list[int] = []
    for _ in range(k):
        s = believer.std(g_c)
        sc = w_c * (special.ndtr(-np.abs(mu_c) / s) if learning == "U" else _eff(mu_c, s))
        sc[chosen] = -1.0
        j = int(np.argmax(sc))
        chosen.append(j)
        believer.run(j)
    return C[chosen], best


def _candidates(score, U, exclude, m):
    """The rows of the ``m`` best scores, none of them a point of ``exclude`` (the points
    already run: a run point's Kriging σ is the nugget's, not 0, so on the limit state it can
    score high again, and a repeat teaches nothing)."""
    banned = {np.ascontiguousarray(x, dtype=float).tobytes() for x in exclude}
    order = np.argsort(-score, kind="stable")
    return np.asarray([i for i in order[: m + len(banned)]
                       if np.ascontiguousarray(U[i], dtype=float).tobytes() not in banned][:m])


def _unexplored(MU, w, Gt, system_kind, U, tries, pf, failed_u, max_tries=2):
    """Before stopping: for each unit the surrogate says fails on the population (≥ 1 % of P̂_f
    where it governs) but no model run has failed, the most probable such point (the smallest
    ‖u‖), so that no branch of the system is extrapolated unseen. None when there is none."""
    gov = np.argmin(MU, axis=1) if system_kind == "series" else np.argmax(MU, axis=1)
    hat = (MU.min(axis=1) if system_kind == "series" else MU.max(axis=1)) <= 0
    n = MU.shape[0]
    out = []
    r2 = (U * U).sum(1)
    for c in range(MU.shape[1]):
        if np.any(Gt[:, c] <= 0) or tries.get(c, 0) >= max_tries:
            continue
        rows = hat & (gov == c)
        if not rows.any() or float(np.sum(w[rows])) / n < 0.01 * pf:
            continue
        cand = np.flatnonzero(rows)
        for f in failed_u:
            cand = cand[~np.all(U[cand] == f, axis=1)]
        if cand.size == 0:
            continue
        tries[c] = tries.get(c, 0) + 1
        out.append(U[cand[np.argmin(r2[cand])]])
    return np.array(out) if out else None


def _unit_table(names, sur, Gt, MU, SD, w, z, system, pf, system_kind):
    rows = []
    n = MU.shape[0]
    gov = np.argmin(MU, axis=1) if system_kind == "series" else np.argmax(MU, axis=1)
    hat = system(MU) <= 0
    for c, name in enumerate(names):
        gp = sur.gps[c]
        rms = _loo_near_zero(gp)
        share = float(np.sum(w * (hat & (gov == c))) / n) / pf if pf > 0 else np.nan
        upper = float(np.sum(w * (MU[:, c] - z * SD[:, c] <= 0)) / n)
        rows.append({"unit": name, "n_failed_observed": int(np.sum(Gt[:, c] <= 0)), "share": share,
                     "pf_plus": upper, "loo_error_near_zero": rms, "nugget": float(gp.nugget),
                     "lengths": np.round(gp.lengths, 4).tolist()})
    return pd.DataFrame(rows).set_index("unit")


def _loo_near_zero(gp) -> float:
    """RMS leave-one-out error on the training points nearest g = 0 over the standard deviation
    of g over all of them (0 for a constant unit): how well the surrogate predicts, out of
    sample, where the sign is decided, on the scale of the unit's margin."""
    e, _ = gp.loo()
    if e.size == 0:
        return 0.0
    near = _near_zero(gp.y)
    scale = float(np.std(gp.y))
    return float(np.sqrt(np.mean(e[near] ** 2))) / scale if scale > 0 else math.inf


def _near_zero(g: np.ndarray) -> np.ndarray:
    """The training points nearest the unit's limit state: the half with the smallest |g| (≥ 5)."""
    k = max(5, g.size // 2)
    idx = np.argsort(np.abs(g), kind="stable")[: min(k, g.size)]
    mask = np.zeros(g.size, dtype=bool)
    mask[idx] = True
    return mask


def _diagnose(problem, names, sur, Gt, MU, SD, w, z, pf, pp, converged, budget, tol, half, samp, pop,
              n_pop_max):
    out = []
    if not converged:
        out.append(f"active_learning: stopping rule not reached within max_evaluations = {budget}: the "
                   f"interval's half-width is {half / pf if pf > 0 else math.inf:.2g} of P_f against the "
                   f"tolerance {tol:g}; the interval is the honest one, the estimate may be biased: raise "
                   "max_evaluations")
    if not converged and pf > 0 and samp > tol / 2 and pop.n >= n_pop_max:
        out.append(f"active_learning: the population's sampling error (z·c.o.v. {samp:.2g}) exceeds the "
                   f"tolerance at {pop.n} points; raise max_population")
    reason = getattr(problem.model, "nonsmooth", None)
    if reason:
        out.append(f"active_learning: the model is not smooth ({reason}): a Kriging surrogate of an impact "
                   "or chaotic response is not trustworthy; use subset simulation or Monte Carlo")
    n = MU.shape[0]
    for c, name in enumerate(names):
        rms = _loo_near_zero(sur.gps[c])
        if rms > LOO_LIMIT:
            out.append(f"active_learning: unit {name!r}: the leave-one-out error near g = 0 is {rms:.2g} of the "
                       f"spread of g (RMS over the half of the runs nearest g = 0; > {LOO_LIMIT:g}): the "
                       "surrogate does not predict the sign of g where it matters (a kink, a jump or noise the "
                       "kernel does not describe); its interval rests on its own σ")
        upper = float(np.sum(w * (MU[:, c] - z * SD[:, c] <= 0)) / n)
        if int(np.sum(Gt[:, c] <= 0)) == 0 and upper > 0.01 * max(pf, pp):
            out.append(f"active_learning: unit {name!r} may fail on {upper:.2g} of the population by its "
                       "surrogate, but no model run has failed it: that branch is extrapolated, not explored")
    if pf == 0:
        out.append("active_learning: no population point fails on the surrogate; P_f is estimated as 0 "
                   f"(below about {1 / pop.n:.1g})")
    return out
