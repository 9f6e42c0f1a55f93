"""The design method ``"ak"``: Kriging of the cycle extremes in the model's input space, learnt
where the current optimum's constraints are decided.

What is learnt, and where
-------------------------
A design changes the *distribution* of the model's inputs (a mean moves it, a tolerance scales
it, a scene value sets an input: :mod:`mechrel.uq.design.space`), never the model. So one
surrogate of the model's response over its inputs z (the uncertain inputs and the scene
design variables) serves every design: the augmented reliability space of Au (2005) and
Taflanidis & Beck (2008), the surrogate-based form of Dubourg, Sudret & Bourinet (2011),
"Reliability-based design optimization using kriging surrogates and subset simulation",
Struct. Multidisc. Optim. 44(5), and the modular framework of Moustapha & Sudret (2019),
"Surrogate-assisted reliability-based design optimization: a survey and a unified modular
framework", Struct. Multidisc. Optim. 60(5). One Kriging model per quantity (the unit of the
active-learning estimator, :func:`mechrel.uq.estimators.ak.learning_units`) of the margin
g_q(z) = 1 − Y_q(z)/a_q, Y_q the cycle extreme, in standardised coordinates ((x − μ₀)/σ₀ for an
uncertain input, the bounds scaled to [−1, 1] for a scene value); a constraint over the
quantities Q fails where min_(q ∈ Q) g_q ≤ 0.

The loop (every model run is kept and refits the surrogates):

1. an initial Latin hypercube over (standard-normal draws, design) mapped to z, so that the
   training points cover the inputs of every design within the bounds;
2. the optimum *on the surrogate*: the cost minimised subject to k_c(d) ≤ 1, k_c the
   R_t-quantile of the predicted ratio 1 − min_q μ_q over a population of N standard-normal
   draws mapped through the design (**common random numbers**: the same N draws at every
   design, so that k_c is continuous in the design; N ≥ 200/(1 − R_t));
3. at that optimum, the surrogate's bounds P⁻ ≤ P̂ ≤ P⁺ of each constraint's P_f
   (a point counted failed where μ ∓ zσ says so) and the stopping rule: every constraint
   either surely met (P⁺ ≤ 1 − R_t) or resolved (P⁺ − P⁻ ≤ ``tolerance`` (1 − R_t)), the
   optimum moved less than ``tol_design`` (relative) since the last iteration, and every
   surrogate's leave-one-out error near its limit state is at most
   :data:`~mechrel.uq.estimators.ak.LOO_LIMIT` of its margin's spread (a Kriging model whose
   σ has collapsed where it is wrong would pass the bounds' rule alone);
4. else ``batch_size`` new runs: the population points of the optimum where a
   misclassification is most likely, Φ(−|μ|/σ) of the governing quantity (the U function of
   AK-MCS, Echard, Gayton & Lemaire 2011), spread by the Kriging believer's covariance update
   (Ginsbourger et al. 2010), as the active-learning estimator does.

Where the optimiser looks, the surrogate is therefore learnt: near the optimum's limit state,
the only place that decides the constraint. Elsewhere it may be coarse; the trade-off curve
reports its bounds at every point, and the optimum is verified by an independent run of the
model (:func:`~mechrel.uq.design_for_reliability`).

Speed: a factor k needs the population's upper tail only. The optimiser evaluates k on an
*active set*, the top 5 % (at least 20 × the tail) of the population ranked at the last
optimum, and the result is confirmed on the whole population; when the active set misses a
point of the tail there, it is rebuilt at the new optimum and the optimisation repeated.

Reproducibility: draws from the seed's children (initial design 1, population 2), Kriging fits
deterministic: the same answer for any ``n_jobs``, and a rerun with the same ``cache=`` runs
nothing.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError

from .._common import SampleFailuresError, failure_message
from ..estimators._problem import concat_evaluations
from ..estimators.ak import LOO_LIMIT, _candidates, _loo_near_zero, _Surrogates
from ..execution.executor import evaluate
from ..problem.inputs import child_seed
from ..surrogates.kriging import Believer, one_blas_thread
from .core import DesignEstimate, optimise

__all__ = ["design_active_learning", "N_TAIL"]

N_TAIL = 200
"""The population holds at least this many points beyond the allowables at the target,
N ≥ N_TAIL/(1 − R_t): P̂_f's sampling c.o.v. ≤ 7 % there (and 22 % at the trade-off curve's
rarest point, a tenth of it)."""

ACTIVE_FRACTION = 0.05

class SurrogateConstraints:
    """The constraints' factors at any design from Kriging surrogates of the units' margins
    over a common population (module docstring); the estimator of a
    :class:`~mechrel.uq.design.core.DesignEstimate`.

    Parameters
    ----------
    problem : DesignProblem
    surrogates : sequence
        One fitted Kriging model per unit (``problem.scalars.units``), of the margin
        1 − Y_q/a_q over the standardised model inputs.
    centre, width : ndarray
        The standardisation of the model's inputs, ζ = (z − centre)/width.
    X0 : ndarray, shape (N, r)
        The population of the uncertain inputs at the base design.
    confidence_level : float
        Of the bounds (z).
    """

    def __init__(self, problem, surrogates, centre, width, X0, confidence_level):
        self.problem = problem
        self.gps = list(surrogates)
        self.centre = centre
        self.width = width
        self.X0 = X0
        self.z = float(stats.norm.ppf(0.5 + confidence_level / 2))
        self.members = list(problem.scalars.unit_members)
        self._active: np.ndarray | None = None
        self._last_full: tuple | None = None
        self._last_mean: tuple | None = None
        self._memo: dict[bytes, np.ndarray] = {}

    @property
    def n(self) -> int:
        return int(self.X0.shape[0])

    def _zeta(self, d, rows) -> np.ndarray:
        X = self.X0 if rows is None else self.X0[rows]
        return (self.problem.space.physical(d, X) - self.centre) / self.width

    def predict(self, d, rows=None, std=False):
        """μ (and σ) of every unit's margin at the population rows ``rows`` mapped through
        design ``d``: arrays (m, units)."""
        Zs = self._zeta(np.asarray(d, dtype=float), rows)
        return self._predict(Zs, std)

    def _predict(self, Zs, std):
        m = Zs.shape[0]
        mu = np.empty((m, len(self.gps)))
        sd = np.empty((m, len(self.gps))) if std else None
        with one_blas_thread():
            for c, gp in enumerate(self.gps):
                if std:
                    mu[:, c], sd[:, c] = gp.predict(Zs, std=True)
                else:
                    mu[:, c] = gp.predict(Zs)
        return mu, sd

    # ---------------------------------------------------------------- factors
    def _tail(self, r: float) -> int:
        """How many points of the population lie above the R-quantile: N − ⌈N R⌉ + 1."""
        return self.n - min(max(math.ceil(self.n * r - 1e-9 * self.n), 1), self.n) + 1

    def _factor_of(self, MU, rel, total: int) -> np.ndarray:
        out = []
        for idx, r in zip(self.members, rel):
            h = 1.0 - MU[:, list(idx)].min(axis=1)
            t = total - min(max(math.ceil(total * r - 1e-9 * total), 1), total) + 1
            t = min(t, h.size)
            out.append(float(np.partition(h, h.size - t)[h.size - t]))
        return np.asarray(out)

    def _mean(self, d) -> np.ndarray:
        """μ over the whole population at ``d`` (the last full pass's, when it was at ``d``: a
        failed confirmation rebuilds the active set from the pass that confirmed)."""
        key = np.asarray(d, dtype=float).tobytes()
        if self._last_full is not None and self._last_full[0] == key:
            return self._last_full[1]
        if self._last_mean is None or self._last_mean[0] != key:
            self._last_mean = (key, self.predict(d)[0])
        return self._last_mean[1]

    def _build_active(self, d, rel) -> None:
        MU = self._mean(d)
        keep = np.zeros(self.n, dtype=bool)
        for idx, r in zip(self.members, rel):
            h = 1.0 - MU[:, list(idx)].min(axis=1)
            size = min(self.n, max(int(ACTIVE_FRACTION * self.n), 20 * self._tail(r)))
            keep[np.argpartition(-h, size - 1)[:size]] = True
        self._active = np.flatnonzero(keep)
        self._memo.clear()

    def factors(self, d, rel) -> np.ndarray:
        """The factor k per constraint at design ``d`` on the active set (exact when it holds the tail:
        :meth:`confirm`)."""
        d = np.asarray(d, dtype=float)
        rel = np.asarray(rel, dtype=float)
        need = max(self._tail(r) for r in rel)
        if self._active is None or 2 * need > self._active.size:
            self._build_active(d, rel)
        key = d.tobytes() + rel.tobytes()
        if key not in self._memo:
            MU, _ = self.predict(d, self._active)
            self._memo[key] = self._factor_of(MU, rel, self.n)
        return self._memo[key]

    def full(self, d, rel):
        """μ, σ over the whole population at ``d`` (kept for the learning step) and the exact
        factors."""
        d = np.asarray(d, dtype=float)
        if self._last_full is not None and self._last_full[0] == d.tobytes():
            MU, SD = self._last_full[1:]
        else:
            MU, SD = self.predict(d, std=True)
            self._last_full = (d.tobytes(), MU, SD)
        return MU, SD, self._factor_of(MU, np.asarray(rel, dtype=float), self.n)

    def confirm(self, d, rel) -> bool:
        """Whether the active set's factors at ``d`` are the whole population's; if not, the
        active set is rebuilt at ``d`` (and the optimiser should start again from there)."""
        exact = self.full(d, rel)[2]   # with σ: the iteration's bounds and learning step at an
        approx = self.factors(d, rel)  # optimum read this same pass

        if np.allclose(exact, approx, rtol=0, atol=0):
            return True
        self._build_active(d, rel)
        return False

    def resolves(self, rel) -> bool:
        """Whether the population holds ≥ 10 points beyond every target."""
        return bool(np.all(self.n * (1.0 - np.asarray(rel)) >= 10.0 - 1e-9))

    def bounds(self, MU, SD, rel):
        """Per constraint: (P̂, its sampling s.e., P⁻, s⁻, P⁺, s⁺)."""
        out = []
        n = MU.shape[0]
        for idx in self.members:
            cols = list(idx)
            est = []
            for M in (MU[:, cols], MU[:, cols] + self.z * SD[:, cols],
                      MU[:, cols] - self.z * SD[:, cols]):
                p = float(np.mean(M.min(axis=1) <= 0.0))
                est += [p, math.sqrt(max(p * (1 - p), 0.0) / n)]
            out.append(est)
        return out

    def summary(self, d, rel) -> pd.DataFrame:
        """Per constraint at ``d``: ``factor`` (exact, the whole population), ``pf`` on the
        surrogate, ``pf_minus``/``pf_plus`` (its bounds at ±zσ) and the interval
        [P⁻ − z s⁻, P⁺ + z s⁺] (bounds and the population's sampling error)."""
        MU, SD, k = self.full(d, rel)
        rows = []
        for kk, (p, s, pm, sm, pp, sp) in zip(k, self.bounds(MU, SD, rel)):
            rows.append({"factor": kk, "pf": p, "pf_lo": max(pm - self.z * sm, 0.0),
                         "pf_hi": pp + self.z * sp, "pf_minus": pm, "pf_plus": pp,
                         "cov_sampling": s / p if p > 0 else math.nan, "n": self.n,
                         "interval": "surrogate bounds at ±zσ plus the population's sampling "
                                     "error"})
        return pd.DataFrame(rows, index=pd.Index(self.problem.scalars.labels(),
                                                 name="constraint"))


def _optimise(problem, est: SurrogateConstraints, rel, start, radius=0.25):
    """The optimum on the surrogate, confirmed on the whole population."""
    return optimise(problem, est.factors, rel, start, radius=radius, confirm=est.confirm)


def _select(est: SurrogateConstraints, d, MU, SD, k: int, exclude: list) -> tuple[np.ndarray, float]:
    """The next ``k`` population points at design ``d`` (model inputs z), none of ``exclude``
    (the points already run), and the best score:
    the largest probability of misclassification Φ(−|μ|/σ) of any constraint's governing
    unit, spread by the Kriging believer's update of the candidates' covariances."""
    sd = np.maximum(SD, 1e-300)
    score = np.zeros(MU.shape[0])
    govs = []
    for idx in est.members:
        cols = np.asarray(idx)
        g = cols[np.argmin(MU[:, cols], axis=1)]
        govs.append(g)
        rows = np.arange(MU.shape[0])
        score = np.maximum(score, special.ndtr(-np.abs(MU[rows, g]) / sd[rows, g]))
    Z = est.problem.space.physical(d, est.X0)
    m = min(MU.shape[0], max(200, 50 * k))
    cand = _candidates(score, Z, exclude, m)
    best = float(score[cand[0]])
    if k == 1:
        return Z[cand[:1]], best
    believer = Believer(est.gps, (Z[cand] - est.centre) / est.width)
    mu_c = MU[cand]
    chosen: list[int] = []
    for _ in range(k):
        sc = np.zeros(m)
        for g in govs:
            gc = g[cand]
            s = believer.std(gc)
            sc = np.maximum(sc, special.ndtr(-np.abs(mu_c[np.arange(m), gc]) / s))
        sc[chosen] = -1.0
        j = int(np.argmax(sc))
        chosen.append(j)
        believer.run(j)
    return Z[cand[chosen]], best


def design_active_learning(*, problem, seed, confidence_level: float, failures: str,
                           max_failure_fraction: float, executor: dict,
                           n_initial: int | None = None, batch_size: int = 2,
                           max_evaluations: int = 200, tolerance: float = 0.1,
                           tol_design: float = 1e-3, n_population: int = 100_000,
                           max_population: int = 1_000_000, trend: str = "linear",
                           initial: Any = None) -> DesignEstimate:
    """The design method ``"ak"`` (module docstring; the contract of :mod:`mechrel.uq.design`).

    Parameters
    ----------
    problem, seed, confidence_level, failures, max_failure_fraction, executor
        As passed by :func:`~mechrel.uq.design_for_reliability` (``failures`` must be
        ``"exclude"``: a failed run has no margin to learn).
    n_initial : int, optional
        Model runs of the initial design; default max(10, 2 (d + m + 2)), d the model's
        inputs and m the design variables.
    batch_size : int, default 2
        Model runs per iteration (one executor call: ``n_jobs`` workers run them at once).
    max_evaluations : int, default 200
        Model-run budget; reaching it before the stopping rule is a warning.
    tolerance : float, default 0.1
        The surrogate's P_f bounds at the optimum within this fraction of 1 − R_t.
    tol_design : float, default 1e-3
        The optimum's largest change in an iteration (relative to the value for a std or
        half-width, to the bounds' span otherwise).
    n_population, max_population : int
        The population: max(n_population, N_TAIL/(1 − R_t)) points, at most max_population.
    trend : {"linear", "constant"}, default "linear"
        The Kriging trend.
    initial : DesignResult, optional
        An earlier result of this method on the same model (another target, bounds or
        inputs' distributions): its runs start the surrogates (no model run).

    Returns
    -------
    DesignEstimate

    Raises
    ------
    StudyError
        ``failures="as_failure"``, a per-angle constraint, an ``initial`` of another model,
        too few usable initial runs.
    SampleFailuresError
        More failed runs than ``max_failure_fraction``.

    Examples
    --------
    The tolerance of one normal dimension whose error must stay within ±1 with R ≥ 0.99: the
    optimum is t = 1/Φ⁻¹(0.995) = 0.388 (a few tens of model runs):

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, design_for_reliability
    >>> r = design_for_reliability(
    ...     model=FunctionModel(lambda X: X, ["x"], ["e"], vectorized=True),
    ...     inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
    ...     variables={"t": {"kind": "std", "input": "x", "lower": 0.01, "upper": 1.0}},
    ...     cost="1/t", constraints=0.99, allowable=1.0, method="ak", n_population=20000,
    ...     seed=4, tradeoff=0, verify="none", progress=False)
    >>> abs(r.design["t"] / 0.38823 - 1) < 0.03, r.provenance["n_evaluations"] < 60
    (True, True)
    """
    if failures != "exclude":
        raise StudyError("design (ak): failures = 'as_failure': a failed run has no margin to "
                         "learn; allowed: failures = 'exclude' (failed runs are left out of the "
                         "surrogates and counted), or method 'mc'")
    if problem.scalars.per_angle:
        raise StudyError("design (ak): a per-angle constraint has one event per analysis "
                         "output, which the surrogates of the cycle extremes do not give; "
                         "allowed: basis 'whole-cycle', or method 'mc' for per-angle constraints")
    space = problem.space
    model = problem.model
    sc = problem.scalars
    rel = problem.reliabilities
    n_units = len(sc.units)
    names = space.model_names
    r = len(space.random_names)
    dim = len(names)
    p_trend = 1 if trend == "constant" else dim + 1
    n0 = max(10, 2 * (dim + space.m + 2)) if n_initial is None else int(n_initial)
    if n0 < p_trend + 2:
        raise StudyError(f"design (ak): n_initial = {n0}: allowed: at least {p_trend + 2} "
                         f"(the {trend} trend of {dim} inputs)")
    if n0 > max_evaluations:
        raise StudyError(f"design (ak): n_initial = {n0} > max_evaluations = {max_evaluations}; "
                         "allowed: n_initial <= max_evaluations")
    # standardisation of the model's inputs
    centre = np.zeros(dim)
    width = np.ones(dim)
    col = {n: i for i, n in enumerate(names)}
    for j, n in enumerate(space.random_names):
        centre[col[n]] = space.mu0[j]
        width[col[n]] = space.sd0[j]
    for v in space.variables:
        if v.kind == "scene":
            centre[col[v.input]] = 0.5 * (v.lower + v.upper)
            width[col[v.input]] = 0.5 * (v.upper - v.lower)
    # ---- model runs
    Zt = np.empty((0, dim))
    Gt = np.empty((0, n_units))
    failed: list[np.ndarray] = []
    evs: list = []
    counts = {"n_evaluations": 0, "n_computed": 0, "n_cached": 0, "n_failed": 0}
    n_bad = 0

    def learn(Z, Y, ok):
        nonlocal Zt, Gt
        G = np.full((Z.shape[0], n_units), np.nan)
        if ok.any():
            G[ok] = 1.0 - sc.unit_ratios(Y[ok])
        good = ok & np.all(np.isfinite(G), axis=1)
        failed.extend(Z[~good])
        Zt = np.vstack([Zt, Z[good]])
        Gt = np.vstack([Gt, G[good]])
        return int((~good).sum())

    def run(Z):
        nonlocal n_bad
        ev = evaluate(model, Z, **{**executor, "progress": executor["progress"] and
                                   Z.shape[0] > batch_size})
        evs.append(ev)
        for k_ in counts:
            counts[k_] += {"n_evaluations": ev.n, "n_computed": ev.n_model_calls,
                           "n_cached": ev.n_cached, "n_failed": ev.n_failed}[k_]
        n_bad += learn(Z, ev.Y, ev.ok.copy())
        if n_bad > max_failure_fraction * counts["n_evaluations"]:
            all_ev = concat_evaluations(evs)
            raise SampleFailuresError(
                f"design (ak): {n_bad} of {counts['n_evaluations']} model runs failed "
                f"({failure_message(all_ev)}), more than max_failure_fraction="
                f"{max_failure_fraction}; allowed: bounds that keep the model evaluable, or a "
                "larger max_failure_fraction", all_ev)

    n_reused = 0
    if initial is not None:
        ev0 = getattr(initial, "evaluations", None)
        if ev0 is None or getattr(initial, "method", None) != "ak" or \
                ev0.cache_key != model.cache_key() or tuple(ev0.input_names) != names:
            raise StudyError(f"design (ak): initial = {type(initial).__name__}: not a "
                             "DesignResult of method 'ak' on this model; allowed: None, or the "
                             "result of an earlier design_for_reliability(method='ak') with the "
                             "same model")
        learn(np.asarray(ev0.X), np.asarray(ev0.Y), np.asarray(ev0.ok).copy())
        n_reused = int(ev0.n)
        kept = [ev0]
    else:
        kept = []
    from scipy.stats import qmc
    lhs = qmc.LatinHypercube(d=r + space.m, seed=np.random.default_rng(child_seed(seed, 1))
                             ).random(n0)
    U0 = special.ndtri(np.clip(lhs[:, :r], 1e-12, 1 - 1e-12))
    X00 = problem.inputs.from_standard_normal(U0)
    Zinit = np.vstack([space.physical(space.from_unit(lhs[i, r:]), X00[i:i + 1])
                       for i in range(n0)])
    run(Zinit)
    if Zt.shape[0] < p_trend + 2:
        raise StudyError(f"design (ak): {Zt.shape[0]} usable initial runs of {n0}; allowed: at "
                         f"least {p_trend + 2} (a larger n_initial, or bounds where the model "
                         "can be evaluated)")
    # ---- the population (common random numbers)
    N = int(min(max_population, max(n_population,
                                     math.ceil(N_TAIL / float(np.min(1.0 - rel))))))
    notes = []
    if N * float(np.min(1.0 - rel)) < N_TAIL:
        notes.append(f"design (ak): the population of {N} points holds "
                     f"{N * float(np.min(1.0 - rel)):.0f} beyond the rarest target (fewer than "
                     f"{N_TAIL}): P_f's sampling error there is larger; raise max_population")
    X0 = problem.inputs.sample(N, "random", seed=child_seed(seed, 2))
    sur = _Surrogates(trend)
    d = space.start.copy()
    d_prev = None
    history = []
    converged = False
    it = 0
    radius = 0.25
    while True:
        sur.fit((Zt - centre) / width, Gt)
        est = SurrogateConstraints(problem, sur.gps, centre, width, X0, confidence_level)
        d, info = _optimise(problem, est, rel, d, radius=radius)
        radius = 0.1
        MU, SD, k = est.full(d, rel)
        b = est.bounds(MU, SD, rel)
        t = 1.0 - rel
        sure = np.array([e[4] <= tt for e, tt in zip(b, t)])
        tight = np.array([e[4] - e[2] <= tolerance * tt for e, tt in zip(b, t)])
        moved = math.inf if d_prev is None else _moved(space, d, d_prev)
        history.append({"iteration": it, "n_evaluations": counts["n_evaluations"],
                        "cost": problem.cost_at(d), **space.as_dict(d),
                        "factor": float(np.max(k)), "pf": b[0][0], "pf_minus": b[0][2],
                        "pf_plus": b[0][4], "moved": moved, "feasible": info["feasible"]})
        loo = max(_loo_near_zero(gp) for gp in sur.gps)
        history[-1]["loo_error"] = loo
        # an overconfident surrogate (σ collapsed while its out-of-sample error near the limit
        # state is large) would satisfy the bounds' rule on its own: it must also predict there
        if np.all(sure | tight) and moved <= tol_design and loo <= LOO_LIMIT:
            converged = True
            break
        if counts["n_evaluations"] >= max_evaluations:
            break
        k_batch = min(batch_size, max_evaluations - counts["n_evaluations"])
        pts, best = _select(est, d, MU, SD, k_batch, [*failed, *Zt])
        history[-1]["score"] = best
        run(pts)
        d_prev = d
        it += 1
    # ---- diagnostics
    if not converged:
        b0 = history[-1]
        notes.append(f"design (ak): surrogate not converged within max_evaluations = "
                     f"{max_evaluations}: at the optimum the surrogate's P_f bounds are "
                     f"[{b0['pf_minus']:.3g}, {b0['pf_plus']:.3g}] against the tolerance "
                     f"{tolerance:g} × {float(1 - rel[0]):.3g}, and the optimum moved by "
                     f"{b0['moved']:.3g} in the last iteration (tol_design {tol_design:g}); the "
                     "optimum rests on a surrogate that may be wrong there: raise "
                     "max_evaluations (the verification's independent run is the check)")
    reason = getattr(model, "nonsmooth", None)
    if reason:
        notes.append(f"design (ak): the model is not smooth ({reason}): a Kriging surrogate of "
                     "an impact or chaotic response is not trustworthy; use method 'mc'")
    units = []
    MU, SD, _ = est.full(d, rel)
    for c, name in enumerate(sc.units):
        gp = sur.gps[c]
        rms = _loo_near_zero(gp)
        failing_runs = int(np.sum(Gt[:, c] <= 0))
        upper = float(np.mean(MU[:, c] - est.z * SD[:, c] <= 0))
        units.append({"unit": name, "n_failed_observed": failing_runs,
                      "pf_plus": upper, "loo_error_near_zero": rms,
                      "nugget": float(getattr(gp, "nugget", 0.0)),
                      "lengths": np.round(getattr(gp, "lengths", np.array([])), 4).tolist()})
        if rms > LOO_LIMIT:
            notes.append(f"design (ak): unit {name!r}: the leave-one-out error near the limit "
                         f"state is {rms:.2g} of the spread of its margin (> {LOO_LIMIT:g}): the "
                         "surrogate does not predict where the constraint is decided (a kink, a "
                         "jump or noise); its bounds rest on its own σ")
        if failing_runs == 0 and upper > 0.01 * float(np.min(1.0 - rel)):
            notes.append(f"design (ak): unit {name!r} may fail on {upper:.2g} of the optimum's "
                         "population by its surrogate, but no model run has failed it: that "
                         "quantity is extrapolated, not explored")
    all_ev = concat_evaluations(kept + evs)  # every row the surrogates learnt from
    settings = {"n_initial": n0, "batch_size": batch_size, "max_evaluations": max_evaluations,
                "tolerance": tolerance, "tol_design": tol_design, "n_population": N,
                "trend": trend, "units": list(sc.units), "n_reused": n_reused,
                "space": "the model's inputs, standardised: (x - mu0)/sd0, scene values to "
                         "[-1, 1]",
                "population": "common random numbers: one sample of the base inputs mapped "
                              "through every design"}
    return DesignEstimate(d, est, (all_ev,), counts,
                          pd.DataFrame(history).set_index("iteration"),
                          {"units": pd.DataFrame(units).set_index("unit")}, tuple(notes),
                          settings, converged)


def _moved(space, d, d_prev) -> float:
    """The largest change of a variable: relative for a std or half-width, over the bounds'
    span otherwise."""
    d, d_prev = np.asarray(d), np.asarray(d_prev)
    rel = np.abs(np.log(d / d_prev))
    lin = np.abs(d - d_prev) / (space.upper - space.lower)
    return float(np.max(np.where(space.log, rel, lin)))
