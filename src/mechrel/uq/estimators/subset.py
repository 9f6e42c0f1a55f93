"""Subset simulation (Au & Beck 2001) with conditional sampling or modified Metropolis.

P_f = P(F_1) Π P(F_{i+1} | F_i) with nested events F_i = {g ≤ b_i}, b_1 > b_2 > … > b_m = 0.
Level 0 draws N iid standard normal samples; each level sets b_i to the p₀-quantile of g (mean
of the N·p₀-th and N·p₀+1-th smallest values), keeps the N_c = N·p₀ samples below it as seeds
and grows from each a Markov chain of 1/p₀ states (the seed first) whose stationary law is the
standard normal conditioned on F_i. It stops at the first level whose quantile is ≤ 0:

    P̂_f = p₀^(m−1) · #{g ≤ 0}/N.

Markov chains (all chains advance together, one executor call per step):

``"conditional"`` (Papaioannou et al. 2015)
    candidate v = ρ u + √(1 − ρ²) ξ, ξ ~ N(0, I) (it leaves N(0, I) invariant, so no density
    ratio is needed); accepted when g(v) ≤ b_i, else the chain stays.
``"modified_metropolis"`` (Au & Beck 2001)
    per coordinate, candidate ξ_j ~ N(u_j, σ²) accepted with probability min(1, φ(ξ_j)/φ(u_j));
    the resulting vector is accepted when g ≤ b_i.

Coefficient of variation (Au & Beck 2001, eqs. 24–29): for the level probabilities
δ_i² = (1 − p_i)/(N p_i) · (1 + γ_i), with γ_i = 2 Σ_{k=1}^{N_s−1} (1 − k N_c/N) R_i(k)/R_i(0)
from the correlation R_i(k) of the indicator along the chains (γ₀ = 0). Treating the levels
as uncorrelated, δ² ≈ Σ δ_i² (``cov_au_beck``) understates the spread: level i + 1's samples
grow from level i's seeds, so adjacent levels are positively correlated (Au & Beck bound δ by
Σ δ_i, full correlation between every pair of levels). mechrel reports

    δ² = Σ δ_i² + 2 ρ_adj Σ δ_i δ_{i+1},   ρ_adj = :data:`ADJACENT_CORRELATION` = 0.25,

and the lognormal interval P̂_f · exp(±z s), s² = ln(1 + δ²): P̂_f is a product of the level
probabilities, so its logarithm, a sum, is closer to normal than P̂_f (the normal interval
P̂_f(1 ± zδ) is symmetric and cut at 0). Measured over 200 seeds each at N = 1000 (linear
margins at 1e-3 in 2 inputs and at 1e-6 in 10, two design points at 3.5, the β = 4.5
paraboloid, the four-branch system; ``python benchmarks/bench_system_reliability.py
--subset-coverage --seeds 200``): the observed spread of P̂_f exceeded the uncorrelated δ by
4–9 %, whose normal 95 % interval covered the truth in 90–92.5 % of the runs and the lognormal
one in 92.5–94 %; with ρ_adj = 0.25 the lognormal interval covers 95.5–98 %, and the
full-correlation bound 98.5–100 %.

Randomness: level i uses the i-th child of ``seed`` for all its draws, in the parent process;
the executor only evaluates rows, so the result is identical for any ``n_jobs``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError

from ..._checks import ARGS
from .._common import SampleFailuresError, check_memory, emit_warnings
from ..execution.executor import Evaluations
from ..problem.inputs import as_seed_sequence, child_seed, seed_record
from ._problem import Problem, RareEventResult, common_settings, refuse_evaluations
from .form import check_positive

__all__ = ["subset_simulation", "SubsetSimulationResult", "PROPOSALS"]

PROPOSALS = ("conditional", "modified_metropolis")
ADJACENT_CORRELATION = 0.25
"""The correlation taken between the estimates of adjacent levels in the c.o.v. (module
docstring)."""
MIN_DISTINCT = 0.2
"""A level whose seeds are fewer than this fraction distinct (of N·p₀) is a warning (healthy
chains of conditional sampling at ρ = 0.8 accept about half their candidates, and 40–60 % of a
deep level's seeds are distinct; below a fifth the chains barely move)."""
MIN_MOVED = 0.5
MIN_ACCEPTANCE = 0.05
"""A level where fewer than half the chains moved, or fewer than 5 % of the candidates were
accepted, is a warning: the chains stay at their seeds."""


@dataclass(frozen=True, eq=False)
class SubsetSimulationResult(RareEventResult):
    """Subset-simulation result (frozen).

    Parameters
    ----------
    table : DataFrame
        One row: ``pf``, ``beta`` (−Φ⁻¹(pf)), ``cov`` (δ with adjacent levels correlated),
        ``cov_au_beck`` (the levels treated as uncorrelated), ``pf_lo``, ``pf_hi`` (lognormal),
        ``n_levels``, ``n_failed_model``, ``n_evaluations``.
    levels : DataFrame
        One row per level: ``threshold`` b_i, ``p`` (conditional probability), ``gamma``, ``cov``,
        ``acceptance`` (of the chains grown at that level), ``n_evaluations``,
        ``n_distinct_seeds`` (the distinct seeds its chains grew from; NaN at level 0) and
        ``moved`` (the fraction of its chains that left their seed).
    evaluations : Evaluations or None
        Every model row.
    provenance : dict
        How the result was made.
    warnings : tuple of str, default ()
        Caveats of the estimate, also issued as :class:`~mechrel.errors.EstimateWarning`: a
        level-0 fraction of failures ≥ p0 (not a rare event), no failing sample at the last
        level (P_f = 0), a level grown from few distinct seeds, chains that did not move.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from mechrel.uq import subset_simulation
    >>> r = subset_simulation(model=margin, inputs=inputs, n_per_level=200, seed=2)
    >>> list(r.levels.columns)[:3], r.n_evaluations == int(r.levels["n_evaluations"].sum())
    (['threshold', 'p', 'gamma'], True)
    """

    table: pd.DataFrame
    levels: pd.DataFrame
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    @property
    def cov(self) -> float:
        """The approximate coefficient of variation of the estimate ``pf``.

        Returns
        -------
        float
            √(Σ δ_i² + 2 ρ_adj Σ δ_i δ_{i+1}), δ_i² = (1 − p_i)/(N p_i) (1 + γ_i) with γ_i
            the correlation factor of level i's Markov chains (Au & Beck 2001) and ρ_adj the
            correlation of adjacent levels (module docstring; dimensionless).

        Examples
        --------
        >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
        >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
        >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
        ...                        vectorized=True)
        >>> r = subset_simulation(model=margin, inputs=inputs, n_per_level=200, seed=2)
        >>> 0 < r.cov < 1
        True
        """
        return float(self.table["cov"].iloc[0])


def _gamma(ind: np.ndarray, p: float) -> float:
    """Au–Beck γ from the indicator array (N_c chains, N_s states)."""
    nc, ns = ind.shape
    N = nc * ns
    r0 = p * (1.0 - p)
    if r0 <= 0 or ns < 2:
        return 0.0
    g = 0.0
    for k in range(1, ns):
        rk = float(np.sum(ind[:, : ns - k] * ind[:, k:])) / (N - k * nc) - p * p
        g += (1.0 - k * nc / N) * rk / r0
    return 2.0 * g


def level_sizes(n_per_level: int, p0: float, where: str = "p0") -> tuple[int, int]:
    """The seeds of a level and the length of their chains, n_per_level·p0 and 1/p0, which must
    be integers.

    Parameters
    ----------
    n_per_level : int
        Samples per level.
    p0 : float
        The level probability, in (0, 1).
    where : str, default "p0"
        How ``p0`` is named in the message.

    Returns
    -------
    (int, int)

    Raises
    ------
    StudyError
        Either is not an integer (or no seed).

    Examples
    --------
    >>> level_sizes(500, 0.1)
    (50, 10)
    """
    nc = n_per_level * p0
    ns = 1.0 / p0
    if abs(nc - round(nc)) > 1e-9 or abs(ns - round(ns)) > 1e-9 or round(nc) < 1:
        raise StudyError(f"{where}: got {p0!r} with n_per_level = {n_per_level}; allowed: 1/p0 and n_per_level·p0 integers "
                         "(e.g. p0 = 0.1 with n_per_level a multiple of 10)")
    return int(round(nc)), int(round(ns))


def subset_simulation(
    *,
    model: Any,
    inputs: Any,
    evaluations: Any = None,
    limit_state: Any = None,
    seed: Any = None,
    n_per_level: int = 1000,
    p0: float = 0.1,
    proposal: str = "conditional",
    rho: float = 0.8,
    spread: float = 1.0,
    max_levels: int = 20,
    confidence_level: float = 0.95,
    failures: str = "exclude",
    max_failure_fraction: float = 0.1,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = False,
    chunk_size: int | None = None,
) -> SubsetSimulationResult:
    """P_f by subset simulation (module docstring).

    Parameters
    ----------
    model, inputs, limit_state
        The model, its uncertain inputs and the limit state (default: the model's only output is
        the margin g; failure g ≤ 0).
    evaluations : None
        Precomputed evaluations cannot be used (the method chooses its points as it goes);
        anything but None is an error. Accepted so that every estimator shares one interface.
    seed
        Seed of the samples (each level draws from its own child stream).
    n_per_level : int, default 1000
        Samples per level N (N·p₀ and 1/p₀ must be integers).
    p0 : float, default 0.1
        The conditional probability of each level.
    proposal : {"conditional", "modified_metropolis"}, default "conditional"
        Conditional sampling (correlation ``rho``) or the modified Metropolis algorithm
        (proposal standard deviation ``spread``).
    rho : float, default 0.8
        Correlation of the conditional sampler, in [0, 1).
    spread : float, default 1.0
        Proposal standard deviation of the modified Metropolis algorithm.
    max_levels : int, default 20
        Level limit (P_f ≥ p₀^max_levels is resolvable).
    confidence_level : float, default 0.95
        Level of the interval on P_f (from the Au–Beck c.o.v.).
    failures : {"exclude", "as_failure"}, default "exclude"
        A sample the model cannot evaluate is dropped at level 0 and rejected in a chain (the chain
        stays where it is), or counted as a failure of the limit state.
    max_failure_fraction : float, default 0.1
        More failed samples in total than this fraction is an error.
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.

    Returns
    -------
    SubsetSimulationResult

    Raises
    ------
    StudyError
        If ``p0`` and ``n_per_level`` are inconsistent, a level has too few usable samples,
        ``max_levels`` is reached with the threshold above 0, or the threshold stops decreasing.
    SampleFailuresError
        If more than ``max_failure_fraction`` of the samples fail.

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs
    >>> inputs = UncertainInputs.from_specs({"x1": Normal(0.0, 1.0), "x2": Normal(0.0, 1.0)})
    >>> margin = FunctionModel(lambda X: 3.0 * 2**0.5 - X[:, 0] - X[:, 1], ["x1", "x2"], ["g"],
    ...                        vectorized=True)
    >>> from scipy.special import ndtr
    >>> from mechrel.uq import subset_simulation
    >>> r = subset_simulation(model=margin, inputs=inputs, n_per_level=500, seed=1)
    >>> bool(abs(r.pf - ndtr(-3.0)) <= 3 * r.cov * r.pf), len(r.levels)
    (True, 3)
    """
    refuse_evaluations(evaluations, "subset_simulation")
    N = check_positive("n_per_level", n_per_level, integer=True, minimum=1)
    p0 = ARGS.fraction("p0", p0, open_lo=True, open_hi=True)
    nc, ns = level_sizes(N, p0)
    ARGS.choice("proposal", proposal, PROPOSALS)
    rho = ARGS.fraction("rho", rho, open_lo=False, open_hi=True)
    spread = check_positive("spread", spread)
    max_levels = check_positive("max_levels", max_levels, integer=True, minimum=0)
    ARGS.fraction("confidence_level", confidence_level, open_lo=True, open_hi=True)
    common_settings(failures=failures, max_failure_fraction=max_failure_fraction)
    ss = as_seed_sequence(seed)
    problem = Problem(model=model, inputs=inputs, limit_state=limit_state, n_jobs=n_jobs, backend=backend,
                      cache=cache, progress=progress, chunk_size=chunk_size, what="subset_simulation")
    d = problem.d
    check_memory(N, d + problem.n_out, "n_per_level", N)  # each level holds N model runs
    fail_value = -np.inf if failures == "as_failure" else np.nan
    n_bad = 0

    def g_of(U):
        nonlocal n_bad
        G, ok, _ = problem.g(U)
        n_bad += int((~ok).sum())
        G = np.where(ok, G, fail_value)
        if n_bad > max_failure_fraction * problem.n_evaluations and problem.n_evaluations >= N:
            ev = problem.all_evaluations()
            raise SampleFailuresError(
                f"subset_simulation: {n_bad} of {problem.n_evaluations} samples failed "
                f"({ev.failure_counts() if ev is not None else {}}), more than max_failure_fraction="
                f"{max_failure_fraction}; allowed: fix the model or raise max_failure_fraction", ev)
        return G

    rng = np.random.default_rng(child_seed(ss, 0))
    U = rng.standard_normal((N, d))
    G = g_of(U)
    keep = ~np.isnan(G)
    U, G = U[keep], G[keep]
    levels = []
    pf = None
    delta2 = 0.0
    n_prev = 0
    gamma = 0.0
    acc = np.nan
    n_distinct = -1     # level 0: iid samples, no seeds
    moved = np.nan
    for level in range(max_levels + 1):
        n_here = G.shape[0]
        order = np.argsort(G, kind="stable")
        k_fail = int(np.sum(G <= 0))
        m_seeds = int(round(n_here * p0))
        if m_seeds < 1:
            raise StudyError(f"subset_simulation: only {n_here} usable samples at level {level}; "
                             "allowed: a larger n_per_level or fewer model failures")
        b = 0.5 * (G[order[m_seeds - 1]] + G[order[m_seeds]]) if m_seeds < n_here else G[order[-1]]
        if b <= 0 or k_fail >= m_seeds:  # last level: count failures directly
            p = k_fail / n_here
            pf = p0**level * p
            d2 = (1 - p) / (n_here * p) * (1 + gamma) if p > 0 else np.inf
            delta2 += d2
            levels.append((level, 0.0, p, gamma, math.sqrt(d2), acc, problem.n_evaluations - n_prev,
                           n_distinct, moved))
            break
        if level == max_levels:
            raise StudyError(
                f"subset_simulation: level {level} reached max_levels = {max_levels} with threshold b = {b:.6g} > 0 "
                f"(P_f < p0^max_levels = {p0**max_levels:.3g}, or the limit state is never violated); "
                "allowed: a larger max_levels, or check the limit state")
        if level > 0 and not b < levels[-1][1]:
            raise StudyError(
                f"subset_simulation: the threshold stopped decreasing at level {level} (b = {b:.6g}); g is flat "
                "above 0 on a set of positive probability, so the failure domain cannot be reached "
                "(never violated?); allowed: a limit state whose margin varies continuously")
        d2 = (1 - p0) / (n_here * p0) * (1 + gamma)
        delta2 += d2
        # grow the chains of the next level from the seeds
        seeds = order[:m_seeds]
        n_seeds_distinct = int(np.unique(U[seeds], axis=0).shape[0])
        levels.append((level, float(b), p0, gamma, math.sqrt(d2), acc, problem.n_evaluations - n_prev,
                       n_distinct, moved))
        n_prev = problem.n_evaluations
        n_distinct = n_seeds_distinct
        cu = U[seeds].copy()
        cg = G[seeds].copy()
        moved_chain = np.zeros(m_seeds, dtype=bool)
        chains_u = [cu.copy()]
        chains_g = [cg.copy()]
        lrng = np.random.default_rng(child_seed(ss, level + 1))
        n_acc = 0
        for _ in range(ns - 1):
            if proposal == "conditional":
                cand = rho * cu + math.sqrt(1 - rho * rho) * lrng.standard_normal(cu.shape)
            else:
                xi = cu + spread * lrng.standard_normal(cu.shape)
                ratio = np.exp(-0.5 * (xi**2 - cu**2))
                take = lrng.random(cu.shape) < np.minimum(1.0, ratio)
                cand = np.where(take, xi, cu)
            gc = g_of(cand)
            accept = gc <= b  # NaN (excluded failure) compares False: rejected
            n_acc += int(accept.sum())
            moved_chain |= accept & np.any(cand != cu, axis=1)
            cu = np.where(accept[:, None], cand, cu)
            cg = np.where(accept, gc, cg)
            chains_u.append(cu.copy())
            chains_g.append(cg.copy())
        acc = n_acc / (m_seeds * (ns - 1))
        moved = float(moved_chain.mean())
        CU = np.stack(chains_u, axis=1)  # (chains, states, d)
        CG = np.stack(chains_g, axis=1)  # (chains, states)
        U = CU.reshape(-1, d)
        G = CG.reshape(-1)
        # γ for the next level's probability uses the indicator of its own threshold, known once
        # that threshold is set: compute it lazily at the top of the next iteration
        nxt = np.sort(G, kind="stable")
        m2 = int(round(G.shape[0] * p0))
        b2 = 0.5 * (nxt[m2 - 1] + nxt[m2]) if m2 < G.shape[0] else nxt[-1]
        p_next = float(np.mean(CG <= max(b2, 0.0))) if b2 > 0 else float(np.mean(CG <= 0))
        gamma = _gamma((CG <= max(b2, 0.0)).astype(float), p_next)
    tab = pd.DataFrame(levels, columns=["level", "threshold", "p", "gamma", "cov", "acceptance", "n_evaluations",
                                        "n_distinct_seeds", "moved"]).set_index("level")
    tab.loc[tab["n_distinct_seeds"] < 0, "n_distinct_seeds"] = np.nan
    notes = []
    if len(levels) == 1:
        notes.append(f"subset_simulation: {pf:.3g} of the level-0 samples fail (≥ p0 = {p0}): not a rare event, "
                     "the result is crude Monte Carlo on n_per_level samples")
    if pf == 0:
        notes.append("subset_simulation: no sample of the last level failed; P_f is estimated as 0 "
                     "(below the resolution of this run): increase n_per_level")
    chained = tab.iloc[1:]
    few = chained[chained["n_distinct_seeds"] < MIN_DISTINCT * nc]
    if len(few):
        lv = int(few.index[0])
        notes.append(f"subset_simulation: level {lv} grew its chains from only "
                     f"{int(few['n_distinct_seeds'].iloc[0])} distinct seeds of {nc} (fewer than "
                     f"{MIN_DISTINCT:.0%}): the chains repeat each other, so the levels are strongly correlated and "
                     "the c.o.v. is optimistic; raise n_per_level, or lower rho")
    stuck = chained[(chained["moved"] < MIN_MOVED) | (chained["acceptance"] < MIN_ACCEPTANCE)]
    if len(stuck):
        lv = int(stuck.index[0])
        notes.append(f"subset_simulation: at level {lv} only {stuck['moved'].iloc[0]:.0%} of the chains moved "
                     f"(acceptance {stuck['acceptance'].iloc[0]:.2f}): the conditional samples stay at their seeds, "
                     "so the estimate and its c.o.v. are unreliable; lower rho (conditional sampling) or spread "
                     "(modified Metropolis), or raise n_per_level")
    caveats = emit_warnings(notes, stacklevel=3)
    d_lv = tab["cov"].to_numpy(dtype=float)
    delta_ab = math.sqrt(delta2)
    delta = math.sqrt(delta2 + 2.0 * ADJACENT_CORRELATION * float(np.sum(d_lv[:-1] * d_lv[1:])))
    z = float(stats.norm.ppf(0.5 + confidence_level / 2))
    spread = math.sqrt(math.log1p(delta * delta)) if np.isfinite(delta) else np.inf
    table = pd.DataFrame({"pf": [pf], "beta": [float(-special.ndtri(pf)) if pf > 0 else np.inf], "cov": [delta],
                          "cov_au_beck": [delta_ab],
                          "pf_lo": [pf * math.exp(-z * spread)], "pf_hi": [pf * math.exp(z * spread)],
                          "n_levels": [len(levels)], "n_failed_model": [n_bad],
                          "n_evaluations": [problem.n_evaluations]},
                         index=pd.Index([problem.limit_state.name], name="limit_state"))
    prov = problem.provenance(method="subset_simulation", seed=seed_record(ss),
                              settings={"n_per_level": N, "p0": p0, "proposal": proposal, "rho": rho,
                                        "spread": spread, "max_levels": max_levels,
                                        "confidence_level": confidence_level, "failures": failures,
                                        "max_failure_fraction": max_failure_fraction,
                                        "cov": "Au & Beck (2001), adjacent levels correlated with "
                                               f"rho = {ADJACENT_CORRELATION}",
                                        "interval": "lognormal"})
    return SubsetSimulationResult(table, tab, problem.all_evaluations(), prov, caveats)
