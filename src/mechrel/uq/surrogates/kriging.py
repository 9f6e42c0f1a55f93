"""Kriging (Gaussian-process regression) with an anisotropic Matérn-5/2 kernel, on numpy and scipy.

The model of a scalar function y(x), x ∈ ℝ^d (Santner, Williams & Notz 2003, ch. 3; Rasmussen &
Williams 2006, ch. 2 and 5):

    Y(x) = f(x)ᵀβ + Z(x),  Z a zero-mean Gaussian process, Cov[Z(x), Z(x')] = σ² k(x, x'),

with the trend f(x) = 1 (ordinary kriging) or (1, x) (universal kriging, ``trend="linear"``:
it extrapolates a margin that grows linearly away from the data, as a limit state in standard
normal space does), and the Matérn-5/2 correlation with one length ℓ_j per input

    k(x, x') = (1 + √5 r + 5r²/3) exp(−√5 r),  r² = Σ_j ((x_j − x'_j)/ℓ_j)²,

twice differentiable, so it fits smooth responses without the Gaussian kernel's
ill-conditioning. Observations carry a *nugget* τ (noise variance τσ²: the integration noise of a
simulated response; τ ≥ 1e-10 for round-off).

Hyperparameters
---------------
β and σ² in closed form (generalised least squares), ψ = (log ℓ, log τ) by maximising the
profile likelihood, −2 log L/n = log σ̂²(ψ) + log|R(ψ)|/n, with its analytic gradient
∂/∂ψ_j = (tr(R⁻¹ D_j) − αᵀD_jα/σ̂²)/n, α = R⁻¹(y − Fβ̂), D_j = ∂R/∂ψ_j (Rasmussen & Williams
eq. 5.9), by L-BFGS-B from deterministic starts (no random restarts: the same data give the
same fit). A warm start (the previous fit's ψ) makes a refit after one more point cheap.

Prediction (the posterior of the latent function, not of a new noisy observation)
---------------------------------------------------------------------------------
μ(x) = f(x)ᵀβ̂ + r(x)ᵀα,
s²(x) = σ̂² [1 − r(x)ᵀR⁻¹r(x) + u(x)ᵀ(FᵀR⁻¹F)⁻¹u(x)],  u(x) = FᵀR⁻¹r(x) − f(x),

(the last term is the trend's estimation variance). Leave-one-out residuals and variances in
closed form (Dubrule 1983, with the trend): with Q = R⁻¹ − R⁻¹F(FᵀR⁻¹F)⁻¹FᵀR⁻¹,
e_i = (Qy)_i/Q_ii and s²_LOO,i = σ̂²/Q_ii.

Why not a library: ``docs/uq.md`` ("Active learning", the choice of the Kriging library) has the
measurements against scikit-learn, OpenTURNS and SMT.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit, prange
from scipy import linalg, optimize

from mechrel.errors import StudyError

__all__ = ["Believer", "Kriging", "fit_kriging", "matern52", "one_blas_thread", "TRENDS"]

TRENDS = ("constant", "linear")
SQRT5 = math.sqrt(5.0)
LOG_LENGTH_BOUNDS = (math.log(1e-2), math.log(1e3))
LOG_NUGGET_BOUNDS = (math.log(1e-10), math.log(1e-1))


def matern52(A: np.ndarray, B: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """The Matérn-5/2 correlation matrix k(A_i, B_j) with per-input lengths.

    Parameters
    ----------
    A : ndarray, shape (m, d)
    B : ndarray, shape (n, d)
    lengths : ndarray, shape (d,)
        ℓ_j > 0, in the inputs' units.

    Returns
    -------
    ndarray, shape (m, n)
        Correlations in (0, 1], 1 on coincident points.

    Examples
    --------
    >>> import numpy as np
    >>> k = matern52(np.zeros((1, 2)), np.array([[0.0, 0.0], [1.0, 0.0]]), np.array([1.0, 2.0]))
    >>> round(float(k[0, 0]), 12), round(float(k[0, 1]), 6)    # (1 + √5 + 5/3) e^(−√5)
    (1.0, 0.523994)
    """
    a = np.ascontiguousarray(A / lengths, dtype=float)
    b = np.ascontiguousarray(B / lengths, dtype=float)
    out = np.empty((a.shape[0], b.shape[0]))
    _matern52_into(a, b, out)
    return out


@njit(cache=True, parallel=True)
def _matern52_into(a, b, out):
    """``out[i, j] = (1 + ρ + ρ²/3) e^(−ρ)``, ρ = √5 ‖a_i − b_j‖, in one pass (the NumPy form made
    six (m, n) temporaries: 3–4× the time of this loop on one core), rows split over the cores
    (each row alone: the same bits for any thread count). The distance from the differences,
    not ‖a‖² + ‖b‖² − 2a·b: no cancellation at coincident points."""
    m, d = a.shape
    n = b.shape[0]
    for i in prange(m):
        for j in range(n):
            s = 0.0
            for k in range(d):
                t = a[i, k] - b[j, k]
                s += t * t
            rho = math.sqrt(5.0 * s)
            out[i, j] = (1.0 + rho + rho * rho / 3.0) * math.exp(-rho)


def _trend(X: np.ndarray, trend: str) -> np.ndarray:
    one = np.ones((X.shape[0], 1))
    return one if trend == "constant" else np.hstack([one, X])


def _profile(psi: np.ndarray, X: np.ndarray, y: np.ndarray, F: np.ndarray, diff2: np.ndarray,
             grad: bool = True):
    """−2 log L/n (profile) and its gradient in ψ = (log ℓ, log τ)."""
    n, d = X.shape
    lengths = np.exp(psi[:d])
    tau = math.exp(psi[d])
    s2 = (diff2 / (lengths**2)[:, None, None]).sum(0)  # Σ_j (Δ_j/ℓ_j)², (n, n)
    r = np.sqrt(s2)
    e = np.exp(-SQRT5 * r)
    K = (1.0 + SQRT5 * r + (5.0 / 3.0) * s2) * e
    R = K + tau * np.eye(n)
    try:
        c = linalg.cho_factor(R, lower=True, check_finite=False)
    except linalg.LinAlgError:
        return (1e10, np.zeros_like(psi)) if grad else 1e10
    Ri_F = linalg.cho_solve(c, F, check_finite=False)
    FtRiF = F.T @ Ri_F
    try:
        beta = np.linalg.solve(FtRiF, Ri_F.T @ y)
    except np.linalg.LinAlgError:
        return (1e10, np.zeros_like(psi)) if grad else 1e10
    res = y - F @ beta
    alpha = linalg.cho_solve(c, res, check_finite=False)
    sigma2 = max(float(res @ alpha) / n, 1e-300)
    logdet = 2.0 * float(np.log(np.diag(c[0])).sum())
    f = math.log(sigma2) + logdet / n
    if not grad:
        return f
    Ri = linalg.cho_solve(c, np.eye(n), check_finite=False)
    W = Ri - np.outer(alpha, alpha) / sigma2
    common = (5.0 / 3.0) * (1.0 + SQRT5 * r) * e  # ∂k/∂log ℓ_j = common · (Δ_j/ℓ_j)²
    g = np.empty_like(psi)
    for j in range(d):
        g[j] = float(np.sum(W * (common * diff2[j] / lengths[j] ** 2))) / n
    g[d] = tau * float(np.trace(W)) / n
    return f, g


@dataclass(frozen=True, eq=False)
class Kriging:
    """A fitted Kriging model (see the module docstring); made by :func:`fit_kriging`.

    Parameters
    ----------
    X : ndarray, shape (n, d)
        The training inputs.
    y : ndarray, shape (n,)
        The training outputs.
    trend : {"constant", "linear"}
        The trend basis f(x).
    lengths : ndarray, shape (d,)
        The correlation lengths ℓ_j (the inputs' units).
    nugget : float
        τ: the observation noise variance over σ².
    sigma2 : float
        σ̂², the process variance (the outputs' unit squared).
    beta : ndarray
        The trend coefficients.
    chol : ndarray, shape (n, n)
        The lower Cholesky factor of R = K + τI.
    alpha : ndarray, shape (n,)
        R⁻¹(y − Fβ̂).
    G : ndarray
        L⁻¹F (for the trend's variance term).
    FtRiF_chol : ndarray
        The Cholesky factor of FᵀR⁻¹F.
    psi : ndarray
        (log ℓ, log τ), for a warm start.
    neg2loglik : float
        The profile −2 log L/n at the optimum.
    n_fun : int
        Likelihood evaluations the fit took.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.linspace(-2.0, 2.0, 9)[:, None]
    >>> gp = fit_kriging(X, np.sin(X[:, 0]))
    >>> mu, sd = gp.predict(np.array([[0.25]]), std=True)
    >>> bool(abs(mu[0] - np.sin(0.25)) < 1e-3), bool(sd[0] < 1e-2)
    (True, True)
    """

    X: np.ndarray
    y: np.ndarray
    trend: str
    lengths: np.ndarray
    nugget: float
    sigma2: float
    beta: np.ndarray
    chol: np.ndarray
    alpha: np.ndarray
    G: np.ndarray
    FtRiF_chol: np.ndarray
    psi: np.ndarray
    neg2loglik: float
    n_fun: int

    @property
    def n(self) -> int:
        """The number of training points.

        Returns
        -------
        int
            Rows of ``X``.

        Examples
        --------
        >>> import numpy as np
        >>> fit_kriging(np.linspace(0.0, 1.0, 6)[:, None], np.arange(6.0) ** 2).n
        6
        """
        return int(self.X.shape[0])

    def predict(self, X: np.ndarray, std: bool = False, chunk: int = 4096):
        """The posterior mean (and standard deviation) of the latent function at ``X``.

        Parameters
        ----------
        X : ndarray, shape (m, d)
            Where to predict.
        std : bool, default False
            Also return the posterior standard deviation (costs O(n²) per point against O(n)
            for the mean).
        chunk : int, default 4096
            Rows per block (bounds the memory: ``chunk × n`` doubles).

        Returns
        -------
        mu : ndarray, shape (m,)
        sd : ndarray, shape (m,)
            Only with ``std=True``.

        Examples
        --------
        >>> import numpy as np
        >>> X = np.array([[0.0], [1.0], [2.0], [3.0]])
        >>> gp = fit_kriging(X, 2.0 * X[:, 0] + 1.0)          # linear: the trend is exact
        >>> [round(float(v), 6) for v in gp.predict(np.array([[10.0]]))]
        [21.0]
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        m = X.shape[0]
        mu = np.empty(m)
        sd = np.empty(m) if std else None
        for s in range(0, m, chunk):
            xs = X[s: s + chunk]
            r = matern52(xs, self.X, self.lengths)
            f = _trend(xs, self.trend)
            mu[s: s + chunk] = f @ self.beta + r @ self.alpha
            if std:
                v = linalg.solve_triangular(self.chol, r.T, lower=True, check_finite=False)
                u = self.G.T @ v - f.T
                w = linalg.solve_triangular(self.FtRiF_chol, u, lower=True, check_finite=False)
                var = 1.0 - (v * v).sum(0) + (w * w).sum(0)
                sd[s: s + chunk] = np.sqrt(np.maximum(var, 0.0) * self.sigma2)
        return (mu, sd) if std else mu

    def posterior_cov(self, X: np.ndarray) -> np.ndarray:
        """The posterior covariance matrix of the latent function at the rows of ``X``.

        Parameters
        ----------
        X : ndarray, shape (m, d)

        Returns
        -------
        ndarray, shape (m, m)
            Its diagonal is ``predict(X, std=True)[1] ** 2``.

        Examples
        --------
        >>> import numpy as np
        >>> X = np.linspace(-2.0, 2.0, 7)[:, None]
        >>> gp = fit_kriging(X, np.cos(X[:, 0]))
        >>> P = np.array([[0.3], [5.0]])
        >>> bool(np.allclose(np.sqrt(np.diag(gp.posterior_cov(P))), gp.predict(P, std=True)[1]))
        True
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        r = matern52(X, self.X, self.lengths)
        v = linalg.solve_triangular(self.chol, r.T, lower=True, check_finite=False)
        u = self.G.T @ v - _trend(X, self.trend).T
        w = linalg.solve_triangular(self.FtRiF_chol, u, lower=True, check_finite=False)
        return self.sigma2 * (matern52(X, X, self.lengths) - v.T @ v + w.T @ w)

    def loo(self) -> tuple[np.ndarray, np.ndarray]:
        """Leave-one-out residuals and standard deviations, in closed form (module docstring).

        Returns
        -------
        residual : ndarray, shape (n,)
            y_i − μ_(−i)(x_i): the prediction error at each training point of the model fitted
            without it (same hyperparameters).
        sd : ndarray, shape (n,)
            The standard deviation of that prediction (of a new noisy observation).

        Examples
        --------
        >>> import numpy as np
        >>> X = np.linspace(0.0, 1.0, 6)[:, None]
        >>> gp = fit_kriging(X, X[:, 0] ** 2, trend="constant")
        >>> e, s = gp.loo()
        >>> bool(np.all(np.abs(e) < 0.1)), bool(np.all(s > 0))
        (True, True)
        """
        n = self.n
        Ri = linalg.cho_solve((self.chol, True), np.eye(n), check_finite=False)
        F = _trend(self.X, self.trend)
        RiF = Ri @ F
        M = linalg.cho_solve((self.FtRiF_chol, True), RiF.T, check_finite=False)
        Q = Ri - RiF @ M
        q = np.diag(Q).copy()
        return (Q @ self.y) / q, np.sqrt(self.sigma2 / q)


def fit_kriging(X: np.ndarray, y: np.ndarray, *, trend: str = "linear", warm: Kriging | None = None,
                fresh: bool = True, fit_nugget: bool = True, maxiter: int = 200) -> Kriging:
    """Fit a Kriging model by maximum (profile) likelihood (module docstring).

    Parameters
    ----------
    X : ndarray, shape (n, d)
        Training inputs (standardised or of comparable scales: the length bounds are
        1e-2 … 1e3 in the inputs' units).
    y : ndarray, shape (n,)
        Training outputs (finite).
    trend : {"linear", "constant"}, default "linear"
        Universal (1, x) or ordinary (1) kriging; ``"linear"`` needs n > d + 2.
    warm : Kriging, optional
        A previous fit on (a subset of) these points: its hyperparameters are one start.
    fresh : bool, default True
        Also start from isotropic lengths (half and twice the inputs' spread; with a warm start
        only twice): a warm start alone can stay in a poor local optimum of the likelihood
        found on fewer points (on the six-input paraboloid of benchmarks/bench_ak.py, −2 log
        L/n −5.2 against −10.1 from a fresh start, and a 30× larger prediction error).
    fit_nugget : bool, default True
        Estimate the nugget τ ∈ [1e-10, 0.1] (else fix it at 1e-10).
    maxiter : int, default 200
        L-BFGS-B iterations per start.

    Returns
    -------
    Kriging

    Raises
    ------
    StudyError
        If the data are not finite, too few for the trend, or y is constant.

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> X = rng.standard_normal((40, 2))
    >>> gp = fit_kriging(X, X[:, 0] ** 2 + 0.1 * X[:, 1])
    >>> Xt = rng.standard_normal((2000, 2))
    >>> err = gp.predict(Xt) - (Xt[:, 0] ** 2 + 0.1 * Xt[:, 1])
    >>> bool(np.sqrt(np.mean(err**2)) < 0.1)
    True
    """
    X = np.atleast_2d(np.asarray(X, dtype=float))
    y = np.asarray(y, dtype=float).reshape(-1)
    n, d = X.shape
    if trend not in TRENDS:
        raise StudyError(f"fit_kriging: trend = {trend!r}; allowed: {list(TRENDS)}")
    p = 1 if trend == "constant" else d + 1
    if y.shape != (n,) or not (np.all(np.isfinite(X)) and np.all(np.isfinite(y))):
        raise StudyError(f"fit_kriging: X {X.shape} and y {y.shape}: not finite or of different lengths; "
                         "allowed: finite arrays with one y per row of X")
    if n < p + 2:
        raise StudyError(f"fit_kriging: {n} points for a {trend} trend in {d} inputs; allowed: at least {p + 2}")
    if np.ptp(y) == 0.0:
        raise StudyError("fit_kriging: y is constant; allowed: outputs that vary")
    F = _trend(X, trend)
    diff2 = (X.T[:, :, None] - X.T[:, None, :]) ** 2  # (d, n, n)
    bounds = [LOG_LENGTH_BOUNDS] * d + [LOG_NUGGET_BOUNDS if fit_nugget else (LOG_NUGGET_BOUNDS[0],) * 2]
    lo = np.array([b[0] for b in bounds])
    hi = np.array([b[1] for b in bounds])
    starts = []
    if warm is not None and warm.psi.shape == (d + 1,):
        starts.append(np.clip(warm.psi, lo, hi))
    if fresh or not starts:
        spread = np.maximum(X.std(axis=0), 1e-3)
        for f in ((2.0,) if starts else (0.5, 2.0)):
            starts.append(np.clip(np.r_[np.log(f * spread), math.log(1e-8)], lo, hi))
    best = None
    n_fun = 0
    for s in starts:
        r = optimize.minimize(_profile, s, args=(X, y, F, diff2), jac=True, method="L-BFGS-B",
                              bounds=bounds, options={"maxiter": maxiter})
        n_fun += int(r.nfev)
        if best is None or r.fun < best.fun:
            best = r
    psi = np.clip(best.x, lo, hi)
    lengths = np.exp(psi[:d])
    tau = math.exp(psi[d])
    R = matern52(X, X, lengths) + tau * np.eye(n)
    L = np.linalg.cholesky(R)
    G = linalg.solve_triangular(L, F, lower=True)
    A = G.T @ G
    LA = np.linalg.cholesky(A)
    z = linalg.solve_triangular(L, y, lower=True)
    beta = linalg.cho_solve((LA, True), G.T @ z)
    res = y - F @ beta
    alpha = linalg.cho_solve((L, True), res)
    sigma2 = max(float(res @ alpha) / n, 1e-300)
    return Kriging(X, y, trend, lengths, tau, sigma2, beta, L, alpha, G, LA, psi, float(best.fun), n_fun)


_CONTROLLER: list = []


def one_blas_thread():
    """A context of one BLAS thread: Kriging's predictions are then the same for any machine's
    thread count. The libraries are scanned once per process (``threadpool_limits`` scans them
    on every call; that scan cost a sixth of the design method's time).

    Returns
    -------
    context manager
        ``threadpoolctl``'s limit of the BLAS libraries to one thread.

    Examples
    --------
    >>> import numpy as np
    >>> with one_blas_thread():
    ...     y = np.ones((3, 3)) @ np.ones(3)
    >>> y.tolist()
    [3.0, 3.0, 3.0]
    """
    if not _CONTROLLER:
        from threadpoolctl import ThreadpoolController
        _CONTROLLER.append(ThreadpoolController())
    return _CONTROLLER[0].limit(limits=1, user_api="blas")


class Believer:
    """The "Kriging believer" over candidate points (Ginsbourger, Le Riche & Carraro 2010):
    each surrogate's posterior covariance at the candidates, updated as if a chosen candidate
    had been run and had returned the surrogate's own prediction. The means do not change; a
    covariance loses the rank-one part the point explains,
    ``S ← S − S[:, j] S[j, :] / (S[j, j] + τσ²)`` (τσ²: the surrogate's noise variance), so the
    next choice of a batch goes where the surrogates are still uncertain.

    Parameters
    ----------
    gps : sequence of Kriging
        The surrogates (an object without ``nugget``/``sigma2``, e.g. a constant, counts as
        noise-free).
    C : ndarray, shape (m, d)
        The candidates, in the surrogates' inputs.

    Examples
    --------
    >>> import numpy as np
    >>> X = np.linspace(-2.0, 2.0, 7)[:, None]
    >>> b = Believer([fit_kriging(X, np.cos(X[:, 0]))], np.array([[0.3], [0.35], [1.7]]))
    >>> before = b.std(np.zeros(3, dtype=int))
    >>> b.run(0)
    >>> after = b.std(np.zeros(3, dtype=int))

    The run point keeps only the noise's share of its variance, s² τσ²/(s² + τσ²); its
    neighbour at 0.05 loses most of its own, the far point at 1.7 little:

    >>> v, tau = before[0] ** 2, b.noise[0]
    >>> bool(np.isclose(after[0] ** 2, v * tau / (v + tau), rtol=1e-6))
    True
    >>> [round(float(a / s), 2) for a, s in zip(after[1:], before[1:])]
    [0.1, 0.96]
    """

    def __init__(self, gps, C: np.ndarray):
        with one_blas_thread():
            self.covs = [gp.posterior_cov(C) for gp in gps]
        self.noise = [getattr(gp, "nugget", 0.0) * getattr(gp, "sigma2", 0.0) for gp in gps]
        self.m = C.shape[0]

    def std(self, gov: np.ndarray) -> np.ndarray:
        """Each candidate's posterior standard deviation by the surrogate ``gov[i]`` that
        governs it (floored at 1e-150, so that a ratio by it stays finite).

        Parameters
        ----------
        gov : ndarray of int, shape (m,)
            The governing surrogate of each candidate.

        Returns
        -------
        ndarray, shape (m,)

        Examples
        --------
        >>> import numpy as np
        >>> X = np.linspace(-2.0, 2.0, 7)[:, None]
        >>> b = Believer([fit_kriging(X, np.cos(X[:, 0]))], np.array([[-2.0], [0.3]]))
        >>> s = b.std(np.zeros(2, dtype=int))
        >>> bool(s[0] < 0.1 * s[1])  # a training point against a point between two
        True
        """
        var = np.array([self.covs[gov[i]][i, i] for i in range(self.m)])
        return np.sqrt(np.maximum(var, 1e-300))

    def run(self, j: int) -> None:
        """Candidate ``j`` counted as run (the covariances' rank-one update above).

        Parameters
        ----------
        j : int
            The candidate's row.

        Examples
        --------
        >>> import numpy as np
        >>> X = np.linspace(-2.0, 2.0, 7)[:, None]
        >>> b = Believer([fit_kriging(X, np.cos(X[:, 0]))], np.array([[0.3], [0.35]]))
        >>> before = b.std(np.zeros(2, dtype=int))
        >>> b.run(1)
        >>> bool(b.std(np.zeros(2, dtype=int))[0] < 0.2 * before[0])
        True
        """
        for c, S in enumerate(self.covs):
            col = S[:, j].copy()
            denom = S[j, j] + self.noise[c]
            if denom > 0:
                S -= np.outer(col, col) / denom
