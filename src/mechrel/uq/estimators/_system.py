"""Probabilities of systems of linearised failure modes (FORM's series and parallel systems).

A design point u*_i with reliability index β_i and unit normal α_i (pointing into its failure
domain) linearises its failure mode as the half-space F_i = {u : α_i·u ≥ β_i} of the standard
normal space. The correlation of two such modes is ρ_ij = α_i·α_j.

Series system (failure when any mode fails), P(∪ F_i):
    computed without a model call by the union estimator of Karp & Luby (1983) for half-spaces
    (the "multiple hyperplane" estimator): draw a mode i with probability P_i/ΣP_j,
    P_i = Φ(−β_i), then u from φ conditioned on F_i (the coordinate along α_i from the normal
    tail beyond β_i, the rest standard normal), and average 1/N(u), N(u) the number of
    half-spaces containing u:  P(∪ F_i) = (Σ P_i) · E[1/N(u)].  Unbiased, with 1/N ∈ [1/m, 1],
    so its c.o.v. at n draws is below √(m/n) whatever P is (at n = 2·10⁴ and m ≤ 8 under 2 %,
    and typically under 0.5 %). It equals 1 − Φ_m(β; R) (Hohenbichler & Rackwitz 1983)
    without the cancellation that formula suffers at small P. Ditlevsen's (1979) bounds,
    from the bivariate probabilities P(F_i ∩ F_j) = Φ₂(−β_i, −β_j; ρ_ij), bracket it.

Parallel system (failure when every mode fails), P(∩ F_i) = Φ_m(−β; R) with R_ij = ρ_ij, the
multinormal integral (bivariate: Owen's T; more modes: Genz's algorithm in SciPy).
"""

from __future__ import annotations

import numpy as np
from scipy import special, stats

from ..problem.allowables import bivariate_normal_cdf

UNION_DRAWS = 20_000
"""Draws of the union estimator (its c.o.v. is below √(m/n); module docstring)."""


def union_probability(beta, alpha, *, n: int = UNION_DRAWS, seed: int = 0) -> tuple[float, float]:
    """P(∪ {α_i·u ≥ β_i}) of standard normal u, and its c.o.v. (module docstring).

    Parameters
    ----------
    beta : array_like, shape (m,)
        The modes' indices (may be negative).
    alpha : array_like, shape (m, d)
        Their unit normals.
    n : int
        Draws (no model is called).
    seed : int
        Seed of the draws (fixed, so that the same design points give the same number).

    Returns
    -------
    (float, float)
        The probability and the c.o.v. of its estimate (0 for one mode: Φ(−β) exactly).
    """
    beta = np.asarray(beta, dtype=float).reshape(-1)
    A = np.atleast_2d(np.asarray(alpha, dtype=float))
    m, d = A.shape
    P = special.ndtr(-beta)
    if m == 1:
        return float(P[0]), 0.0
    total = float(P.sum())
    if total == 0.0:
        return 0.0, 0.0
    rng = np.random.default_rng(seed)
    pick = rng.choice(m, size=n, p=P / total)
    # the coordinate along α_i beyond β_i: t = −Φ⁻¹(w Φ(−β_i)), w uniform in (0, 1)
    w = rng.random(n)
    t = -special.ndtri(w * P[pick])
    xi = rng.standard_normal((n, d))
    a = A[pick]
    U = xi - np.sum(xi * a, axis=1)[:, None] * a + t[:, None] * a
    N = np.sum(U @ A.T >= beta[None, :] - 1e-12, axis=1)
    N = np.maximum(N, 1)  # the drawn mode's own half-space holds u (round-off aside)
    inv = 1.0 / N
    pf = total * float(inv.mean())
    cov = float(inv.std(ddof=1) / np.sqrt(n) / inv.mean())
    return pf, cov


def ditlevsen_bounds(beta, alpha) -> tuple[float, float]:
    """Ditlevsen's (1979) bounds on P(∪ F_i) from the modes' bivariate probabilities.

    Parameters
    ----------
    beta : array_like, shape (m,)
        The modes' indices.
    alpha : array_like, shape (m, d)
        Their unit normals.

    Returns
    -------
    (float, float)
        Lower and upper bound (the modes ordered by decreasing P_i, as the bounds are
        tightest then).
    """
    beta = np.asarray(beta, dtype=float).reshape(-1)
    A = np.atleast_2d(np.asarray(alpha, dtype=float))
    order = np.argsort(beta)
    beta, A = beta[order], A[order]
    P = special.ndtr(-beta)
    m = beta.size
    if m == 1:
        return float(P[0]), float(P[0])
    R = np.clip(A @ A.T, -1.0, 1.0)
    P2 = np.zeros((m, m))
    for i in range(m):
        for j in range(i):
            P2[i, j] = float(bivariate_normal_cdf(np.array([-beta[i]]), np.array([-beta[j]]),
                                                  np.array([R[i, j]]))[0])
    lo = P[0] + sum(max(0.0, P[i] - P2[i, :i].sum()) for i in range(1, m))
    hi = P.sum() - sum(P2[i, :i].max() for i in range(1, m))
    return float(min(lo, 1.0)), float(min(hi, 1.0))


def intersection_probability(beta, alpha) -> float:
    """P(∩ {α_i·u ≥ β_i}) = Φ_m(−β; R), R_ij = α_i·α_j (module docstring).

    Parameters
    ----------
    beta : array_like, shape (m,)
        The modes' indices.
    alpha : array_like, shape (m, d)
        Their unit normals.

    Returns
    -------
    float
        The probability.
    """
    beta = np.asarray(beta, dtype=float).reshape(-1)
    A = np.atleast_2d(np.asarray(alpha, dtype=float))
    m = beta.size
    if m == 1:
        return float(special.ndtr(-beta[0]))
    R = np.clip(A @ A.T, -1.0, 1.0)
    if m == 2:
        return float(bivariate_normal_cdf(np.array([-beta[0]]), np.array([-beta[1]]),
                                          np.array([R[0, 1]]))[0])
    # a singular R (parallel modes) is regularised: its zero eigen-directions carry no mass
    R = R + 1e-12 * np.eye(m)
    return float(stats.multivariate_normal.cdf(-beta, mean=np.zeros(m), cov=R, allow_singular=True,
                                               maxpts=200_000 * m, abseps=1e-14, releps=1e-5,
                                               rng=np.random.default_rng(0)))
