"""Uncertain inputs: marginal specs, optional correlation (Nataf / Gaussian copula), sampling.

Plain specs in, a chaospy joint out (``UncertainInputs.joint``), plus seeded sampling that does
not touch numpy's global state: every draw comes from a ``numpy.random.Generator`` built from
the ``seed`` argument, mapped through inverse CDFs.

Marginals
---------
``normal(mean, std)``
    X ~ N(mean, std²).
``truncnormal(mean, std, lower, upper)``
    The *parent* normal N(mean, std²) truncated to [lower, upper] (chaospy's and scipy's
    convention). The moments of the truncated variable differ from (mean, std);
    ``UncertainInputs.mean``/``.std`` report the true moments.
``uniform(lower, upper)``
    X ~ U(lower, upper).
``lognormal(mean, std)``
    Given by the mean m and standard deviation s *of X itself* (what a drawing tolerance gives),
    converted to the parameters of ln X ~ N(μ_ln, σ_ln²) by
    σ_ln² = ln(1 + (s/m)²),  μ_ln = ln m − σ_ln²/2, so that E[X] = m and Std[X] = s exactly.
``gumbel(mean, std)``
    Gumbel for maxima (extreme value type I, largest) with E[X] = mean and Std[X] = std:
    F(x) = exp(−exp(−(x − μ)/β)), β = std √6/π, μ = mean − γ β (γ Euler's constant).
``weibull(shape, scale, lower=0)``
    F(x) = 1 − exp(−((x − lower)/scale)^shape), x >= lower: the Weibull modulus, the scale (the
    63.2 % quantile above ``lower``) and the location (three-parameter Weibull).
``gamma(mean, std)``
    Gamma with E[X] = mean and Std[X] = std: shape k = (mean/std)², scale θ = std²/mean.
``beta(alpha, beta, lower, upper)``
    lower + (upper − lower) B, B ~ Beta(alpha, beta) on [0, 1].
``scipy.NAME(shapes..., loc, scale)``
    Any frozen continuous ``scipy.stats`` distribution (:class:`ScipyMarginal`), given in a
    study file by its scipy name and parameters; it must have a finite mean and variance.

Every marginal maps to and from the standard normal germ z (``from_z``/``to_z``: x = F⁻¹(Φ(z)),
through the nearer tail so that the upper tail keeps its relative accuracy, in closed form
where there is one) and gives its SciPy (``scipy()``) and chaospy (``chaospy()``) distributions.

Correlation
-----------
``correlation`` is the Pearson correlation matrix of the *physical* inputs X (what one measures).
Dependence is modelled by a Gaussian copula (the Nataf transformation): X_j = F_j⁻¹(Φ(Z_j)),
Z ~ N(0, R_z). For two normal marginals R_z = R_x; otherwise each R_z entry is solved from the
Nataf integral equation ρ_x = E[g_i(Z_i) g_j(Z_j)] (g = standardised F⁻¹∘Φ) by 2-D Gauss–Hermite
quadrature and root finding. ``UncertainInputs.gaussian_correlation`` exposes R_z and
``.joint`` is ``chaospy.Nataf(J(marginals), R_z)``.

Limits: a pair of marginals reaches only the Pearson correlations between those of its
countermonotonic and comonotonic couplings (R_z = ∓1; e.g. two identical Gumbels cannot be
correlated below −0.886, two exponentials below 1 − π²/6 = −0.645, two lognormals of
coefficient of variation 1 below −0.5); a request outside is refused with the attainable range. The Pearson correlation needs finite variances, which every marginal
has (a ``ScipyMarginal`` without them is refused).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from scipy import optimize, special, stats
from scipy.stats import qmc

from mechrel._checks import ARGS
from mechrel.errors import EstimateWarning, StudyError

__all__ = [
    "Normal",
    "TruncNormal",
    "Uniform",
    "LogNormal",
    "Gumbel",
    "Weibull",
    "Gamma",
    "Beta",
    "ScipyMarginal",
    "Marginal",
    "MARGINAL_TYPES",
    "UncertainInputs",
    "SAMPLING_RULES",
    "as_seed_sequence",
    "as_generator",
    "child_seed",
    "sobol_balance_note",
]

SAMPLING_RULES = ("random", "latin_hypercube", "sobol")


def sobol_balance_note(n: int) -> str | None:
    """The caveat of ``n`` scrambled Sobol' points when ``n`` is not a power of 2, else None.

    The first ``2**m`` points of a (scrambled) Sobol' sequence form a (t, m, s)-net: every
    elementary box of volume ``2**t / 2**m`` holds exactly ``2**t`` of them. That balance is
    what makes the variance of an average over them fall faster than ``1/n`` for smooth
    integrands (Owen 1997, "Scrambled net variance for integrals of smooth functions",
    Ann. Statist. 25(4)). A count between two powers of 2 is an unbalanced part of the next
    net: the estimate stays unbiased, but that faster decrease is no longer assured.

    Parameters
    ----------
    n : int
        The number of points (>= 1).

    Returns
    -------
    str or None
        The caveat, naming the nearest balanced counts; None for a power of 2.

    Examples
    --------
    >>> sobol_balance_note(8192) is None
    True
    >>> print(sobol_balance_note(10000))
    rule='sobol' with n = 10000 points: not a power of 2, so the points are not a balanced Sobol' net and the estimate may converge no faster than with rule='random'; n = 8192 or 16384 keeps the balance
    """
    if n & (n - 1) == 0:
        return None
    low = 1 << (n.bit_length() - 1)
    return (f"rule='sobol' with n = {n} points: not a power of 2, so the points are not a "
            f"balanced Sobol' net and the estimate may converge no faster than with "
            f"rule='random'; n = {low} or {2 * low} keeps the balance")
_U_EPS = 2.0**-53  # keep unit-cube points strictly inside (0, 1) so inverse CDFs stay finite


def _finite(name: str, field_: str, value: Any, *, positive: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise StudyError(f"inputs.{name}.{field_}: must be a number, got {value!r}") from None
    if not math.isfinite(v):
        raise StudyError(f"inputs.{name}.{field_}: must be finite, got {value!r}")
    if positive and not v > 0:
        raise StudyError(f"inputs.{name}.{field_}: must be > 0, got {value!r}")
    return v


def _representable(name: str, marginal, params, positive: tuple[int, ...]) -> None:
    """Refuse a marginal whose parameters overflow or underflow float64 (``params``: a
    callable giving them, those at the indices ``positive`` > 0; a lognormal's
    ln(1 + (std/mean)²) of std/mean = 1e160, a gamma's (mean/std)² of std/mean = 1e-200):
    SciPy would get an infinite or zero parameter."""
    try:
        values = params()
        ok = all(math.isfinite(p) and (k not in positive or p > 0)
                 for k, p in enumerate(values))
    except (OverflowError, ZeroDivisionError):
        ok = False
    if not ok:
        ratio = marginal.std / marginal.mean
        raise StudyError(f"inputs.{name}: a {marginal.kind} of mean = {marginal.mean!r} and "
                         f"std = {marginal.std!r}: its parameters overflow or underflow float64 "
                         f"(std / mean = {ratio:.3g}); allowed: std / mean between 1e-150 and "
                         "1e150")


@dataclass(frozen=True)
class Normal:
    """X ~ N(mean, std²).

    Parameters
    ----------
    mean : float
        Mean, in the input's unit (SI).
    std : float
        Standard deviation (> 0), same unit.

    Examples
    --------
    >>> UncertainInputs.from_specs({"speed": Normal(9.42, 0.1)}).std.tolist()
    [0.1]
    """

    mean: float
    std: float
    kind = "normal"

    def validated(self, name: str) -> Normal:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Normal
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If the mean is not a finite number or the standard deviation is not > 0.

        Examples
        --------
        >>> Normal(1, 2).validated("x")
        Normal(mean=1.0, std=2.0)
        """
        return Normal(_finite(name, "mean", self.mean), _finite(name, "std", self.std, positive=True))

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.norm(mean, std)``.

        Examples
        --------
        >>> float(Normal(1.0, 2.0).scipy().cdf(1.0))
        0.5
        """
        return stats.norm(self.mean, self.std)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.Normal(mean, std)``.

        Examples
        --------
        >>> float(Normal(1.0, 2.0).chaospy().mom(1))
        1.0
        """
        import chaospy

        return chaospy.Normal(self.mean, self.std)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal (the inverse Rosenblatt transform).

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``mean + std z``, in the input's unit.

        Examples
        --------
        >>> Normal(1.0, 2.0).from_z(np.array([0.0, 1.0])).tolist()
        [1.0, 3.0]
        """
        return self.mean + self.std * z

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``(x − mean)/std``.

        Examples
        --------
        >>> Normal(1.0, 2.0).to_z(np.array([3.0])).tolist()
        [1.0]
        """
        return (x - self.mean) / self.std


@dataclass(frozen=True)
class TruncNormal:
    """Parent N(mean, std²) truncated to [lower, upper] (infinite bounds allowed on one side).

    Parameters
    ----------
    mean, std : float
        Mean and standard deviation (> 0) of the parent normal, in the input's unit (SI).
    lower, upper : float
        Truncation bounds (lower < upper), same unit.

    Examples
    --------
    A clearance of 0.5 mm ± 0.05 mm kept within [0.35, 0.65] mm: the truncation at ±3σ
    shrinks the standard deviation by 1.4 %:

    >>> u = UncertainInputs.from_specs({"c": TruncNormal(0.5e-3, 0.05e-3, 0.35e-3, 0.65e-3)})
    >>> round(float(u.std[0] / 0.05e-3), 4)
    0.9866
    """

    mean: float
    std: float
    lower: float
    upper: float
    kind = "truncnormal"

    def validated(self, name: str) -> TruncNormal:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        TruncNormal
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If a parameter is not a number, ``std`` is not > 0, ``lower < upper`` fails, both bounds
            are infinite, or the interval holds a negligible probability (<= 1e-10) of the parent.

        Examples
        --------
        >>> TruncNormal(0, 1, -1, float("inf")).validated("x").lower
        -1.0
        """
        mean = _finite(name, "mean", self.mean)
        std = _finite(name, "std", self.std, positive=True)
        try:
            lo, hi = float(self.lower), float(self.upper)
        except (TypeError, ValueError):
            raise StudyError(
                f"inputs.{name}.lower/upper: must be numbers, got {self.lower!r}, {self.upper!r}"
            ) from None
        if math.isnan(lo) or math.isnan(hi) or not lo < hi:
            raise StudyError(f"inputs.{name}.lower/upper: need lower < upper, got lower={lo!r}, upper={hi!r}")
        if not (math.isfinite(lo) or math.isfinite(hi)):
            raise StudyError(
                f"inputs.{name}.lower/upper: at least one bound must be finite (use 'normal' otherwise)"
            )
        mass = stats.norm.cdf((hi - mean) / std) - stats.norm.cdf((lo - mean) / std)
        if not mass > 1e-10:
            raise StudyError(
                f"inputs.{name}: [lower, upper] = [{lo}, {hi}] holds probability {mass:.3g} of the "
                f"parent N({mean}, {std}²); allowed: an interval with non-negligible mass (> 1e-10)"
            )
        return TruncNormal(mean, std, lo, hi)

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.truncnorm`` with standardized bounds.

        Examples
        --------
        >>> round(float(TruncNormal(0.0, 1.0, -1.0, 1.0).scipy().cdf(0.0)), 12)
        0.5
        """
        a = (self.lower - self.mean) / self.std
        b = (self.upper - self.mean) / self.std
        return stats.truncnorm(a, b, loc=self.mean, scale=self.std)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.TruncNormal(lower, upper, mean, std)``.

        Examples
        --------
        >>> round(float(TruncNormal(0.0, 1.0, -1.0, 1.0).chaospy().mom(1)), 12)
        0.0
        """
        import chaospy

        return chaospy.TruncNormal(lower=self.lower, upper=self.upper, mu=self.mean, sigma=self.std)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal (through its inverse CDF).

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``F⁻¹(Φ(z))``, within ``[lower, upper]``, in the input's unit.

        Examples
        --------
        >>> TruncNormal(0.0, 1.0, -1.0, 1.0).from_z(np.array([0.0])).tolist()
        [0.0]
        """
        return self.scipy().ppf(np.clip(special.ndtr(z), _U_EPS, 1 - _U_EPS))

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹(F(x))``, F clipped to [2⁻⁵³, 1 − 2⁻⁵³] (|z| <= 8.2).

        Examples
        --------
        >>> TruncNormal(0.0, 1.0, -1.0, 1.0).to_z(np.array([0.0])).round(12).tolist()
        [0.0]
        """
        return special.ndtri(np.clip(self.scipy().cdf(x), _U_EPS, 1 - _U_EPS))


@dataclass(frozen=True)
class Uniform:
    """X ~ U(lower, upper).

    Parameters
    ----------
    lower, upper : float
        Bounds (lower < upper), in the input's unit (SI).

    Examples
    --------
    >>> u = UncertainInputs.from_specs({"x": Uniform(0.0, 1.0)})
    >>> float(u.mean[0]), round(float(u.std[0]) ** 2 * 12, 12)
    (0.5, 1.0)
    """

    lower: float
    upper: float
    kind = "uniform"

    def validated(self, name: str) -> Uniform:
        """The marginal with its bounds checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Uniform
            The same distribution with float bounds.

        Raises
        ------
        StudyError
            If a bound is not a finite number or ``lower < upper`` fails.

        Examples
        --------
        >>> Uniform(0, 1).validated("x")
        Uniform(lower=0.0, upper=1.0)
        """
        lo = _finite(name, "lower", self.lower)
        hi = _finite(name, "upper", self.upper)
        if not lo < hi:
            raise StudyError(f"inputs.{name}.lower/upper: need lower < upper, got lower={lo!r}, upper={hi!r}")
        return Uniform(lo, hi)

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.uniform(lower, upper - lower)``.

        Examples
        --------
        >>> float(Uniform(0.0, 4.0).scipy().mean())
        2.0
        """
        return stats.uniform(self.lower, self.upper - self.lower)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.Uniform(lower, upper)``.

        Examples
        --------
        >>> float(Uniform(0.0, 4.0).chaospy().mom(1))
        2.0
        """
        import chaospy

        return chaospy.Uniform(self.lower, self.upper)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``lower + (upper - lower) Φ(z)``, in the input's unit.

        Examples
        --------
        >>> Uniform(0.0, 4.0).from_z(np.array([0.0])).tolist()
        [2.0]
        """
        return self.lower + (self.upper - self.lower) * special.ndtr(z)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹((x − lower)/(upper − lower))``, the fraction clipped to [2⁻⁵³, 1 − 2⁻⁵³].

        Examples
        --------
        >>> Uniform(0.0, 4.0).to_z(np.array([2.0])).tolist()
        [0.0]
        """
        return special.ndtri(np.clip(self.scipy().cdf(x), _U_EPS, 1 - _U_EPS))


@dataclass(frozen=True)
class LogNormal:
    """X lognormal with E[X] = mean and Std[X] = std (of X itself, not of ln X).

    Parameters
    ----------
    mean : float
        Mean of X (> 0), in the input's unit (SI).
    std : float
        Standard deviation of X (> 0), same unit.

    Examples
    --------
    A viscosity of 0.1 Pa s with a 15 % coefficient of variation:

    >>> u = UncertainInputs.from_specs({"mu": LogNormal(0.1, 0.015)})
    >>> round(float(u.mean[0]), 12), round(float(u.std[0]), 12)
    (0.1, 0.015)
    """

    mean: float
    std: float
    kind = "lognormal"

    def validated(self, name: str) -> LogNormal:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        LogNormal
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If the mean or the standard deviation is not a finite number > 0, or std / mean
            makes the distribution's parameters overflow or underflow float64.

        Examples
        --------
        >>> LogNormal(1, 1).validated("x")
        LogNormal(mean=1.0, std=1.0)
        """
        out = LogNormal(_finite(name, "mean", self.mean, positive=True),
                        _finite(name, "std", self.std, positive=True))
        _representable(name, out, lambda: out.log_params, positive=(1,))
        return out

    @property
    def log_params(self) -> tuple[float, float]:
        """The parameters (μ_ln, σ_ln) of ln X.

        From the mean m and standard deviation s of X: σ_ln² = ln(1 + (s/m)²), μ_ln = ln m − σ_ln²/2
        (the moments of the lognormal distribution).

        Returns
        -------
        tuple of float
            ``(mu_ln, sigma_ln)`` (dimensionless: ln of the input's unit).

        Examples
        --------
        >>> mu, s = LogNormal(1.0, 1.0).log_params
        >>> math.isclose(s**2, math.log(2.0)), math.isclose(mu, -s**2 / 2)
        (True, True)
        """
        s2 = math.log1p((self.std / self.mean) ** 2)
        return math.log(self.mean) - 0.5 * s2, math.sqrt(s2)

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.lognorm(sigma_ln, scale=exp(mu_ln))``.

        Examples
        --------
        >>> round(float(LogNormal(2.0, 0.5).scipy().mean()), 12)
        2.0
        """
        mu, s = self.log_params
        return stats.lognorm(s, scale=math.exp(mu))

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.LogNormal(mu_ln, sigma_ln)``.

        Examples
        --------
        >>> round(float(LogNormal(2.0, 0.5).chaospy().mom(1)), 12)
        2.0
        """
        import chaospy

        mu, s = self.log_params
        return chaospy.LogNormal(mu=mu, sigma=s)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``exp(mu_ln + sigma_ln z)``, in the input's unit.

        Examples
        --------
        The median (z = 0) is m / √(1 + (s/m)²):

        >>> LogNormal(1.0, 1.0).from_z(np.array([0.0])).round(6).tolist()
        [0.707107]
        """
        mu, s = self.log_params
        return np.exp(mu + s * z)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values (> 0), in the input's unit.

        Returns
        -------
        ndarray
            ``(ln x − mu_ln)/sigma_ln``.

        Examples
        --------
        >>> m = LogNormal(1.0, 1.0)
        >>> m.to_z(m.from_z(np.array([1.5]))).round(12).tolist()
        [1.5]
        """
        mu, s = self.log_params
        return (np.log(x) - mu) / s


_P_TAIL = 1e-30
"""Smallest tail probability the SciPy-backed maps between z and x use (|z| <= 11.4): beyond
it, several ``scipy.stats`` inverse CDFs lose their accuracy or return NaN/∞ (e.g. ``beta.isf``
at 1e-200, ``t.ppf`` at 1e-250), so the map is held constant there."""
_Z_MAX = 37.5  # |z| beyond which Φ(-|z|) underflows: the closed-form maps clip there


def _x_of_z(dist, z: np.ndarray) -> np.ndarray:
    """F⁻¹(Φ(z)) through the nearer tail: ``ppf(Φ(z))`` for z <= 0, ``isf(Φ(−z))`` for z > 0.

    The upper tail keeps its relative accuracy (Φ(z) itself rounds to 1 beyond z ≈ 8.3); the
    tail probability is clipped at :data:`_P_TAIL`.
    """
    z = np.asarray(z, dtype=float)
    p = np.maximum(special.ndtr(-np.abs(z)), _P_TAIL)
    out = np.empty_like(p)
    low = z <= 0
    out[low] = dist.ppf(p[low])
    out[~low] = dist.isf(p[~low])
    return out


def _z_of_x(dist, x: np.ndarray) -> np.ndarray:
    """Φ⁻¹(F(x)) through the nearer tail (the inverse of :func:`_x_of_z`): ``Φ⁻¹(cdf(x))``
    below the median, ``−Φ⁻¹(sf(x))`` above it; the tail probability clipped at
    :data:`_P_TAIL`, so that a point outside the support maps to |z| = 11.4, not ∞."""
    x = np.asarray(x, dtype=float)
    p = np.asarray(dist.cdf(x), dtype=float)
    out = np.empty_like(p)
    low = p <= 0.5
    out[low] = special.ndtri(np.maximum(p[low], _P_TAIL))
    out[~low] = -special.ndtri(np.maximum(np.minimum(dist.sf(x[~low]), 0.5), _P_TAIL))
    return out


@dataclass(frozen=True)
class Gumbel:
    """X Gumbel for maxima (extreme value type I, largest), given by its mean and std.

    F(x) = exp(−exp(−(x − μ)/β)), with the scale β = std √6/π and the mode μ = mean − γ β
    (γ = 0.5772… Euler's constant), so that E[X] = mean and Std[X] = std exactly
    (``scipy.stats.gumbel_r(μ, β)``). The law of the largest of many independent loads or
    deviations; its upper tail is exponential, its lower tail double-exponential.

    Parameters
    ----------
    mean : float
        Mean of X, in the input's unit (SI).
    std : float
        Standard deviation of X (> 0), same unit.

    Examples
    --------
    The largest crank speed of a shift, mean 9.6 rad/s, std 0.2 rad/s:

    >>> u = UncertainInputs.from_specs({"w": Gumbel(9.6, 0.2)})
    >>> round(float(u.mean[0]), 12), round(float(u.std[0]), 12)
    (9.6, 0.2)
    """

    mean: float
    std: float
    kind = "gumbel"

    def validated(self, name: str) -> Gumbel:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Gumbel
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If the mean is not a finite number or the standard deviation is not > 0.

        Examples
        --------
        >>> Gumbel(1, 2).validated("x")
        Gumbel(mean=1.0, std=2.0)
        """
        return Gumbel(_finite(name, "mean", self.mean), _finite(name, "std", self.std, positive=True))

    @property
    def params(self) -> tuple[float, float]:
        """The mode μ and the scale β of the Gumbel distribution.

        β = std √6/π (Var X = π² β²/6) and μ = mean − γ β (E[X] = μ + γ β, γ Euler's constant).

        Returns
        -------
        tuple of float
            ``(mu, beta)``, in the input's unit.

        Examples
        --------
        >>> mu, beta = Gumbel(0.0, math.pi / math.sqrt(6)).params
        >>> round(beta, 12), round(mu, 12) == round(-np.euler_gamma, 12)
        (1.0, True)
        """
        beta = self.std * math.sqrt(6.0) / math.pi
        return self.mean - np.euler_gamma * beta, beta

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.gumbel_r(mu, beta)``.

        Examples
        --------
        >>> round(float(Gumbel(2.0, 0.5).scipy().mean()), 12)
        2.0
        """
        mu, beta = self.params
        return stats.gumbel_r(mu, beta)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.LogWeibull(scale=beta, shift=mu)`` (chaospy's name for the Gumbel law).

        Examples
        --------
        >>> round(float(Gumbel(2.0, 0.5).chaospy().mom(1)), 6)
        2.0
        """
        import chaospy

        mu, beta = self.params
        return chaospy.LogWeibull(scale=beta, shift=mu)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``mu − beta ln(−ln Φ(z))``, in the input's unit (ln Φ by ``scipy.special.log_ndtr``,
            accurate in both tails).

        Examples
        --------
        The median, z = 0, is mu − beta ln ln 2:

        >>> g = Gumbel(0.0, 1.0)
        >>> bool(np.isclose(g.from_z(np.array([0.0]))[0], g.scipy().median()))
        True
        """
        mu, beta = self.params
        z = np.clip(np.asarray(z, dtype=float), -_Z_MAX, _Z_MAX)
        return mu - beta * np.log(-special.log_ndtr(z))

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹(exp(−exp(−(x − mu)/beta)))``, by ``scipy.special.ndtri_exp`` (accurate in
            both tails).

        Examples
        --------
        >>> g = Gumbel(0.0, 1.0)
        >>> g.to_z(g.from_z(np.array([-3.0, 0.5, 7.0]))).round(12).tolist()
        [-3.0, 0.5, 7.0]
        """
        mu, beta = self.params
        t = -np.exp(-(np.asarray(x, dtype=float) - mu) / beta)  # ln F(x)
        return np.clip(special.ndtri_exp(t), -_Z_MAX, _Z_MAX)


@dataclass(frozen=True)
class Weibull:
    """X = lower + W, W Weibull (two-parameter, ``shape`` k and ``scale`` λ).

    F(x) = 1 − exp(−((x − lower)/λ)^k) for x >= lower (``scipy.stats.weibull_min(k, lower, λ)``):
    the law of a strength or a life governed by its weakest link; k is the Weibull modulus.
    E[X] = lower + λ Γ(1 + 1/k), Var X = λ² (Γ(1 + 2/k) − Γ(1 + 1/k)²).

    Parameters
    ----------
    shape : float
        The Weibull modulus k (> 0, dimensionless): k = 1 is the exponential law, k ≈ 3.6
        nearly symmetric, large k a narrow spread.
    scale : float
        λ (> 0), in the input's unit (SI): the 63.2 % quantile of X − lower.
    lower : float, default 0.0
        The location, the lower end of the support (the three-parameter Weibull), same unit.

    Examples
    --------
    A fatigue life with modulus 2 and characteristic life 1e6 cycles:

    >>> u = UncertainInputs.from_specs({"N": Weibull(shape=2.0, scale=1e6)})
    >>> round(float(u.mean[0]) / (1e6 * math.gamma(1.5)), 12)
    1.0
    """

    shape: float
    scale: float
    lower: float = 0.0
    kind = "weibull"

    def validated(self, name: str) -> Weibull:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Weibull
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If ``shape`` or ``scale`` is not a finite number > 0, or ``lower`` is not finite.

        Examples
        --------
        >>> Weibull(2, 3).validated("x")
        Weibull(shape=2.0, scale=3.0, lower=0.0)
        """
        return Weibull(_finite(name, "shape", self.shape, positive=True),
                       _finite(name, "scale", self.scale, positive=True),
                       _finite(name, "lower", self.lower))

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.weibull_min(shape, lower, scale)``.

        Examples
        --------
        >>> float(Weibull(1.0, 2.0).scipy().mean())  # k = 1: exponential, mean = scale
        2.0
        """
        return stats.weibull_min(self.shape, self.lower, self.scale)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.Weibull(shape, scale, shift=lower)``.

        Examples
        --------
        >>> round(float(Weibull(1.0, 2.0).chaospy().mom(1)), 6)
        2.0
        """
        import chaospy

        return chaospy.Weibull(self.shape, self.scale, self.lower)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``lower + scale (−ln Φ(−z))^(1/shape)``, in the input's unit (ln Φ by
            ``scipy.special.log_ndtr``, accurate in both tails).

        Examples
        --------
        >>> w = Weibull(1.0, 1.0)
        >>> bool(np.isclose(w.from_z(np.array([0.0]))[0], math.log(2.0)))  # the median
        True
        """
        z = np.clip(np.asarray(z, dtype=float), -_Z_MAX, _Z_MAX)
        return self.lower + self.scale * (-special.log_ndtr(-z)) ** (1.0 / self.shape)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit (below ``lower``: the lower end, z = −37.5).

        Returns
        -------
        ndarray
            ``−Φ⁻¹(exp(−((x − lower)/scale)^shape))`` (by ``scipy.special.ndtri_exp``).

        Examples
        --------
        >>> w = Weibull(1.5, 2.0, 1.0)
        >>> w.to_z(w.from_z(np.array([-4.0, 0.0, 6.0]))).round(12).tolist()
        [-4.0, 0.0, 6.0]
        """
        t = np.maximum((np.asarray(x, dtype=float) - self.lower) / self.scale, 0.0)
        return np.clip(-special.ndtri_exp(-(t**self.shape)), -_Z_MAX, _Z_MAX)


@dataclass(frozen=True)
class Gamma:
    """X gamma with E[X] = mean and Std[X] = std.

    The shape k = (mean/std)² and the scale θ = std²/mean (E[X] = k θ, Var X = k θ²;
    ``scipy.stats.gamma(k, scale=θ)``): a positive quantity given by its mean and coefficient of
    variation, with a lighter upper tail than the lognormal of the same moments.

    Parameters
    ----------
    mean : float
        Mean of X (> 0), in the input's unit (SI).
    std : float
        Standard deviation of X (> 0), same unit.

    Examples
    --------
    >>> u = UncertainInputs.from_specs({"mu": Gamma(0.1, 0.015)})
    >>> round(float(u.mean[0]), 12), round(float(u.std[0]), 12)
    (0.1, 0.015)
    """

    mean: float
    std: float
    kind = "gamma"

    def validated(self, name: str) -> Gamma:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Gamma
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If the mean or the standard deviation is not a finite number > 0, or std / mean
            makes the distribution's parameters overflow or underflow float64.

        Examples
        --------
        >>> Gamma(2, 1).validated("x")
        Gamma(mean=2.0, std=1.0)
        """
        out = Gamma(_finite(name, "mean", self.mean, positive=True),
                    _finite(name, "std", self.std, positive=True))
        _representable(name, out, lambda: out.params, positive=(0, 1))
        return out

    @property
    def params(self) -> tuple[float, float]:
        """The shape k = (mean/std)² and the scale θ = std²/mean.

        Returns
        -------
        tuple of float
            ``(k, theta)``: k dimensionless, θ in the input's unit.

        Examples
        --------
        >>> Gamma(2.0, 1.0).params
        (4.0, 0.5)
        """
        return (self.mean / self.std) ** 2, self.std**2 / self.mean

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.gamma(k, scale=theta)``.

        Examples
        --------
        >>> round(float(Gamma(2.0, 1.0).scipy().std()), 12)
        1.0
        """
        k, theta = self.params
        return stats.gamma(k, scale=theta)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.Gamma(k, scale=theta)``.

        Examples
        --------
        >>> round(float(Gamma(2.0, 1.0).chaospy().mom(1)), 12)
        2.0
        """
        import chaospy

        k, theta = self.params
        return chaospy.Gamma(k, scale=theta)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``F⁻¹(Φ(z))`` through the nearer tail (``ppf`` below the median, ``isf`` above),
            the tail probability clipped at 1e-30 (|z| <= 11.4), in the input's unit.

        Examples
        --------
        >>> g = Gamma(2.0, 2.0)  # k = 1: exponential with mean 2
        >>> bool(np.isclose(g.from_z(np.array([0.0]))[0], 2.0 * math.log(2.0)))
        True
        """
        return _x_of_z(self.scipy(), z)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹(F(x))`` through the nearer tail (|z| <= 11.4).

        Examples
        --------
        >>> g = Gamma(2.0, 0.5)
        >>> g.to_z(g.from_z(np.array([-4.0, 1.0, 6.0]))).round(10).tolist()
        [-4.0, 1.0, 6.0]
        """
        return _z_of_x(self.scipy(), x)


@dataclass(frozen=True)
class Beta:
    """X = lower + (upper − lower) B, B ~ Beta(alpha, beta) on [0, 1].

    f(x) ∝ (x − lower)^(alpha − 1) (upper − x)^(beta − 1) on [lower, upper]
    (``scipy.stats.beta(alpha, beta, lower, upper − lower)``): a bounded quantity whose
    distribution within its tolerance band may be skewed (alpha ≠ beta) or peaked
    (alpha, beta > 1). E[X] = lower + (upper − lower) alpha/(alpha + beta).

    Parameters
    ----------
    alpha, beta : float
        The shape parameters (> 0, dimensionless).
    lower, upper : float
        The bounds of the support (lower < upper), in the input's unit (SI).

    Examples
    --------
    A clearance within [0.45, 0.55] mm, skewed towards the lower end:

    >>> u = UncertainInputs.from_specs({"c": Beta(2.0, 3.0, 0.45e-3, 0.55e-3)})
    >>> round(float(u.mean[0]) * 1e3, 12)
    0.49
    """

    alpha: float
    beta: float
    lower: float
    upper: float
    kind = "beta"

    def validated(self, name: str) -> Beta:
        """The marginal with its parameters checked and converted to float.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        Beta
            The same distribution with float parameters.

        Raises
        ------
        StudyError
            If ``alpha`` or ``beta`` is not a finite number > 0, a bound is not finite, or
            ``lower < upper`` fails.

        Examples
        --------
        >>> Beta(2, 3, 0, 1).validated("x")
        Beta(alpha=2.0, beta=3.0, lower=0.0, upper=1.0)
        """
        a = _finite(name, "alpha", self.alpha, positive=True)
        b = _finite(name, "beta", self.beta, positive=True)
        lo = _finite(name, "lower", self.lower)
        hi = _finite(name, "upper", self.upper)
        if not lo < hi:
            raise StudyError(f"inputs.{name}.lower/upper: need lower < upper, got lower={lo!r}, upper={hi!r}")
        return Beta(a, b, lo, hi)

    def scipy(self):
        """The frozen SciPy distribution of this marginal.

        Returns
        -------
        scipy.stats.rv_continuous
            ``scipy.stats.beta(alpha, beta, lower, upper − lower)``.

        Examples
        --------
        >>> round(float(Beta(1.0, 1.0, 0.0, 4.0).scipy().std() ** 2), 12)  # uniform: 16/12
        1.333333333333
        """
        return stats.beta(self.alpha, self.beta, self.lower, self.upper - self.lower)

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.Beta(alpha, beta, lower, upper)``.

        Examples
        --------
        >>> round(float(Beta(2.0, 3.0, 0.0, 1.0).chaospy().mom(1)), 12)
        0.4
        """
        import chaospy

        return chaospy.Beta(self.alpha, self.beta, self.lower, self.upper)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``F⁻¹(Φ(z))`` through the nearer tail, within ``[lower, upper]`` (|z| <= 11.4).

        Examples
        --------
        >>> Beta(2.0, 2.0, -1.0, 1.0).from_z(np.array([0.0])).round(12).tolist()  # symmetric
        [0.0]
        """
        return _x_of_z(self.scipy(), z)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹(F(x))`` through the nearer tail (|z| <= 11.4; the bounds map to ∓11.4).

        Examples
        --------
        >>> b = Beta(2.0, 5.0, 0.0, 1.0)
        >>> b.to_z(b.from_z(np.array([-3.0, 0.0, 3.0]))).round(10).tolist()
        [-3.0, 0.0, 3.0]
        """
        return _z_of_x(self.scipy(), x)


def _scipy_label(dist) -> str:
    """``scipy.stats.NAME(p=v, ...)`` (or the class's dotted name for a distribution defined
    outside scipy.stats), every shape parameter, ``loc`` and ``scale`` by keyword."""
    gen = dist.dist
    where = getattr(stats, gen.name, None) if isinstance(getattr(gen, "name", None), str) else None
    head = (f"scipy.stats.{gen.name}" if where is not None and type(where) is type(gen)
            else f"{type(gen).__module__}.{type(gen).__qualname__}")
    return f"{head}({', '.join(f'{k}={v!r}' for k, v in _scipy_params(dist).items())})"


def _scipy_params(dist) -> dict:
    """The parameters of a frozen scipy distribution by keyword, shapes first, then loc, scale."""
    shapes = [s.strip() for s in (dist.dist.shapes or "").split(",") if s.strip()]
    names = shapes + ["loc", "scale"]
    params = dict(zip(names, dist.args))
    params.update(dist.kwds)
    params.setdefault("loc", 0.0)
    params.setdefault("scale", 1.0)
    return {k: params[k] for k in names if k in params}


@dataclass(frozen=True, eq=False)
class ScipyMarginal:
    """Any frozen continuous ``scipy.stats`` distribution as a marginal.

    Sampling, the Nataf transform, FORM, SORM, importance and subset sampling go through its
    ``ppf``/``isf``/``cdf``/``sf`` (the nearer tail of each, the tail probability clipped at
    1e-30, |z| <= 11.4), FOSM and the reported moments through its ``mean()``/``std()``, a
    polynomial chaos through Hermite polynomials of its standard-normal image. It must have a
    finite mean and variance: one without (Cauchy, Student's t with df <= 2, Pareto with
    b <= 2) is refused.

    In a study file: ``distribution = "scipy.NAME"`` and the distribution's parameters by
    their scipy names (its shapes, ``loc`` and ``scale``; the last two default to 0 and 1).

    Parameters
    ----------
    distribution : scipy.stats frozen distribution
        E.g. ``scipy.stats.genextreme(c=-0.1, loc=1.0, scale=0.2)``, in the input's unit (SI).

    Examples
    --------
    A generalised extreme value (Fréchet-type, c < 0) load:

    >>> m = ScipyMarginal(stats.genextreme(c=-0.1, loc=1.0, scale=0.2))
    >>> m
    ScipyMarginal(scipy.stats.genextreme(c=-0.1, loc=1.0, scale=0.2))
    >>> u = UncertainInputs.from_specs({"F": m})
    >>> bool(np.isclose(u.mean[0], stats.genextreme(-0.1, 1.0, 0.2).mean()))
    True
    """

    distribution: Any

    def __repr__(self) -> str:
        return f"ScipyMarginal({_scipy_label(self.distribution)})"

    def __eq__(self, other) -> bool:
        return isinstance(other, ScipyMarginal) and repr(self) == repr(other)

    def __hash__(self) -> int:
        return hash(repr(self))

    @property
    def kind(self) -> str:
        """``"scipy.NAME"``: the distribution's name (its class's name outside scipy.stats).

        Returns
        -------
        str

        Examples
        --------
        >>> ScipyMarginal(stats.logistic(0.0, 1.0)).kind
        'scipy.logistic'
        """
        return "scipy." + str(getattr(self.distribution.dist, "name", type(self.distribution.dist).__name__))

    def validated(self, name: str) -> ScipyMarginal:
        """The marginal with its distribution checked: continuous, valid parameters, finite
        mean and variance.

        Parameters
        ----------
        name : str
            The input's name, for the error message.

        Returns
        -------
        ScipyMarginal
            The same distribution, frozen again with float parameters by keyword.

        Raises
        ------
        StudyError
            If ``distribution`` is not a frozen continuous scipy.stats distribution, a parameter
            is not a finite number or outside the distribution's domain, or the mean or the
            variance is not finite.

        Examples
        --------
        >>> ScipyMarginal(stats.t(2)).validated("x")
        Traceback (most recent call last):
        ...
        mechrel.errors.StudyError: inputs.x: scipy.stats.t(df=2.0, loc=0.0, scale=1.0) has no finite variance (variance inf); allowed: a distribution with a finite mean and variance (the reported moments, FOSM and the Nataf correlation need them)
        """
        d = self.distribution
        if not (hasattr(d, "dist") and isinstance(d.dist, stats.rv_continuous)):
            raise StudyError(
                f"inputs.{name}: got {d!r}; allowed: a frozen continuous scipy.stats distribution "
                "(the distribution called with its parameters, e.g. scipy.stats.gamma(2.0, scale=0.1))"
            )
        params = {k: _finite(name, k, v) for k, v in _scipy_params(d).items()}
        try:
            frozen = d.dist(**params)
            lo, hi = (float(v) for v in frozen.support())
            mean, var = (float(v) for v in frozen.stats("mv"))
        except Exception as exc:  # noqa: BLE001 (a third-party distribution's own failure)
            raise StudyError(f"inputs.{name}: {_scipy_label(d)}: {exc}; allowed: parameters "
                             "the distribution accepts") from None
        if math.isnan(lo) or math.isnan(hi):
            shapes = [k for k in params if k not in ("loc", "scale")]
            raise StudyError(
                f"inputs.{name}: {_scipy_label(frozen)}: parameters outside the distribution's "
                f"domain; allowed: scale > 0 and shape parameters {shapes} that scipy.stats."
                f"{d.dist.name} accepts"
            )
        if not (math.isfinite(mean) and math.isfinite(var)):
            raise StudyError(
                f"inputs.{name}: {_scipy_label(frozen)} has no finite "
                f"{'mean' if not math.isfinite(mean) else 'variance'} "
                f"({'mean' if not math.isfinite(mean) else 'variance'} "
                f"{mean if not math.isfinite(mean) else var}); allowed: a distribution with a "
                "finite mean and variance (the reported moments, FOSM and the Nataf correlation "
                "need them)"
            )
        return ScipyMarginal(frozen)

    def scipy(self):
        """The frozen SciPy distribution of this marginal (the one given).

        Returns
        -------
        scipy.stats.rv_continuous
            ``distribution``.

        Examples
        --------
        >>> float(ScipyMarginal(stats.logistic(2.0, 1.0)).scipy().median())
        2.0
        """
        return self.distribution

    def chaospy(self):
        """The chaospy distribution of this marginal.

        Returns
        -------
        chaospy.Distribution
            ``chaospy.ScipyStatsDist(distribution)`` (its recurrence coefficients come from
            chaospy's discretised Stieltjes procedure, not accurate for every distribution:
            :func:`~mechrel.uq.polynomial_chaos` uses the standard-normal image instead).

        Examples
        --------
        >>> round(float(ScipyMarginal(stats.logistic(2.0, 1.0)).chaospy().mom(1)), 12)
        2.0
        """
        import chaospy

        return chaospy.ScipyStatsDist(self.distribution)

    def from_z(self, z: np.ndarray) -> np.ndarray:
        """Map standard-normal germ values to this marginal.

        Parameters
        ----------
        z : ndarray
            Standard-normal values.

        Returns
        -------
        ndarray
            ``F⁻¹(Φ(z))`` through the nearer tail (``ppf`` below the median, ``isf`` above),
            the tail probability clipped at 1e-30 (|z| <= 11.4), in the input's unit.

        Examples
        --------
        >>> ScipyMarginal(stats.logistic(2.0, 1.0)).from_z(np.array([0.0])).tolist()
        [2.0]
        """
        return _x_of_z(self.distribution, z)

    def to_z(self, x: np.ndarray) -> np.ndarray:
        """Map values of this marginal to the standard-normal germ (inverse of :meth:`from_z`).

        Parameters
        ----------
        x : ndarray
            Values, in the input's unit.

        Returns
        -------
        ndarray
            ``Φ⁻¹(F(x))`` through the nearer tail (|z| <= 11.4).

        Examples
        --------
        >>> m = ScipyMarginal(stats.logistic(2.0, 1.0))
        >>> m.to_z(m.from_z(np.array([-5.0, 1.0]))).round(10).tolist()
        [-5.0, 1.0]
        """
        return _z_of_x(self.distribution, x)


Marginal = Normal | TruncNormal | Uniform | LogNormal | Gumbel | Weibull | Gamma | Beta | ScipyMarginal
MARGINAL_TYPES = (Normal, TruncNormal, Uniform, LogNormal, Gumbel, Weibull, Gamma, Beta, ScipyMarginal)
"""The marginal classes: what an input's spec or a random allowable may be."""
_KINDS: dict[str, tuple[type, tuple[str, ...]]] = {
    "normal": (Normal, ("mean", "std")),
    "truncnormal": (TruncNormal, ("mean", "std", "lower", "upper")),
    "uniform": (Uniform, ("lower", "upper")),
    "lognormal": (LogNormal, ("mean", "std")),
    "gumbel": (Gumbel, ("mean", "std")),
    "weibull": (Weibull, ("shape", "scale", "lower")),
    "gamma": (Gamma, ("mean", "std")),
    "beta": (Beta, ("alpha", "beta", "lower", "upper")),
}
_OPTIONAL = {"weibull": ("lower",)}  # fields with a default (the class's)
_SCIPY = "scipy."  # the prefix of a study file's generic scipy.stats distribution


def _allowed_kinds() -> str:
    return (f"{sorted(_KINDS)}, or 'scipy.NAME' with NAME a continuous scipy.stats "
            "distribution (e.g. 'scipy.genextreme')")


def _scipy_spec(name: str, kind: str, spec: dict) -> ScipyMarginal:
    """``{"distribution": "scipy.NAME", shape: …, "loc": …, "scale": …}`` → ScipyMarginal."""
    dist_name = kind[len(_SCIPY):]
    gen = getattr(stats, dist_name, None)
    if not isinstance(gen, stats.rv_continuous):
        what = ("a discrete distribution" if isinstance(gen, stats.rv_discrete)
                else "not a scipy.stats distribution")
        raise StudyError(f"inputs.{name}.distribution: got {kind!r}: {what}; allowed: "
                         f"{_allowed_kinds()}")
    shapes = [s.strip() for s in (gen.shapes or "").split(",") if s.strip()]
    fields = shapes + ["loc", "scale"]
    missing = [f for f in shapes if f not in spec]
    extra = sorted(set(spec) - set(fields))
    if missing or extra:
        raise StudyError(
            f"inputs.{name}: distribution {kind!r} takes fields {fields} (loc and scale optional, "
            f"default 0 and 1); missing {missing}, unknown {extra}"
        )
    params = {f: _finite(name, f, spec[f]) for f in fields if f in spec}
    return ScipyMarginal(gen(**params)).validated(name)


def _parse_marginal(name: str, spec: Any) -> Marginal:
    marginal = _marginal_of(name, spec)
    _within_float64(name, marginal)
    return marginal


def _within_float64(name: str, marginal: Marginal) -> None:
    """Refuse a marginal whose values overflow float64 where the methods reach: at
    z = ±:data:`_Z_MAX` of its standard-normal image (the farthest any map goes), or in its
    mean and standard deviation (FOSM's point and steps): e.g. a normal of mean and std
    1e308, a Gumbel of std 1e308."""
    with np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ends = np.asarray(marginal.from_z(np.array([-_Z_MAX, _Z_MAX])), dtype=float)
        # the declared moments where the kind has them (SciPy's lognormal std overflows
        # for std / mean = 1e150, which is representable)
        if hasattr(marginal, "mean") and hasattr(marginal, "std"):
            moments = np.array([marginal.mean, marginal.std], dtype=float)
        else:
            dist = marginal.scipy()
            moments = np.array([dist.mean(), dist.std()], dtype=float)
    if not np.isfinite(ends).all():
        what = (f"values overflow float64 within {_Z_MAX:g} standard deviations of its "
                f"standard-normal image (x from {ends[0]:.3g} to {ends[1]:.3g}), where sampling "
                "and the reliability methods reach")
    elif not np.isfinite(moments).all():
        what = (f"mean or standard deviation overflows float64 (mean {moments[0]:.3g}, std "
                f"{moments[1]:.3g}), which FOSM and the reported moments use")
    else:
        return
    raise StudyError(f"inputs.{name}: this {marginal.kind} distribution's {what}; allowed: a "
                     "distribution of physical magnitude, finite there")


def _marginal_of(name: str, spec: Any) -> Marginal:
    if isinstance(spec, MARGINAL_TYPES):
        return spec.validated(name)
    if not isinstance(spec, Mapping):
        raise StudyError(
            f"inputs.{name}: expected a mapping like {{'distribution': 'normal', 'mean': ..., 'std': ...}} "
            f"or a marginal ({'/'.join(t.__name__ for t in MARGINAL_TYPES)}), got {type(spec).__name__}"
        )
    spec = dict(spec)
    kind = spec.pop("distribution", spec.pop("dist", None))
    if kind is None:
        raise StudyError(f"inputs.{name}.distribution: missing; allowed: {_allowed_kinds()}")
    if isinstance(kind, str) and kind.lower().startswith(_SCIPY):
        return _scipy_spec(name, _SCIPY + kind[len(_SCIPY):], spec)
    kind_key = str(kind).lower().replace("_", "").replace("-", "")
    if kind_key not in _KINDS:
        raise StudyError(f"inputs.{name}.distribution: got {kind!r}; allowed: {_allowed_kinds()}")
    cls, fields = _KINDS[kind_key]
    optional = _OPTIONAL.get(kind_key, ())
    missing = [f for f in fields if f not in spec and f not in optional]
    extra = sorted(set(spec) - set(fields))
    if missing or extra:
        raise StudyError(
            f"inputs.{name}: distribution {kind_key!r} takes fields {list(fields)}"
            + (f" ({', '.join(optional)} optional)" if optional else "")
            + f"; missing {missing}, unknown {extra}"
        )
    return cls(**{f: spec[f] for f in fields if f in spec}).validated(name)


def as_seed_sequence(seed: Any) -> np.random.SeedSequence:
    """Int / SeedSequence / None → SeedSequence (None draws fresh OS entropy, recorded in
    ``.entropy`` so that the run can be repeated).

    Parameters
    ----------
    seed : int >= 0, numpy.random.SeedSequence or None
        The seed (the rule of :meth:`mechrel._checks.Checker.seed`).

    Returns
    -------
    numpy.random.SeedSequence

    Raises
    ------
    StudyError
        A seed that is not None, a SeedSequence or an integer >= 0.

    Examples
    --------
    >>> as_seed_sequence(7).entropy
    7
    """
    if isinstance(seed, np.random.SeedSequence):
        return seed
    if seed is None:
        return np.random.SeedSequence()
    return np.random.SeedSequence(ARGS.seed("seed", seed))


def child_seed(ss: np.random.SeedSequence, k: int) -> np.random.SeedSequence:
    """The k-th child of ``ss`` without mutating it (``ss.spawn`` is stateful: calling it twice
    gives different children, which would make results depend on call order).

    Parameters
    ----------
    ss : numpy.random.SeedSequence
        The parent.
    k : int
        Which child (0, 1, ...).

    Returns
    -------
    numpy.random.SeedSequence
        The same child for the same ``ss`` and ``k``, however often it is asked for.

    Examples
    --------
    >>> ss = as_seed_sequence(7)
    >>> a, b = child_seed(ss, 1), child_seed(ss, 1)
    >>> a.spawn_key, a.generate_state(2).tolist() == b.generate_state(2).tolist()
    ((1,), True)
    """
    return np.random.SeedSequence(ss.entropy, spawn_key=tuple(ss.spawn_key) + (int(k),),
                                  pool_size=ss.pool_size)


def as_generator(seed: Any) -> np.random.Generator:
    """Generator / int / SeedSequence / None → numpy Generator (never the global state).

    Parameters
    ----------
    seed : numpy.random.Generator, int >= 0, SeedSequence or None
        A generator is returned as it is; anything else goes through :func:`as_seed_sequence`.

    Returns
    -------
    numpy.random.Generator

    Examples
    --------
    >>> a, b = as_generator(3), as_generator(3)
    >>> a.integers(0, 100, 3).tolist() == b.integers(0, 100, 3).tolist()
    True
    """
    if isinstance(seed, np.random.Generator):
        return seed
    return np.random.default_rng(as_seed_sequence(seed))


def seed_record(seed: Any) -> Any:
    """What provenance records for ``seed``: the entropy of a SeedSequence, the int, or a note."""
    if isinstance(seed, np.random.SeedSequence):
        return {"entropy": int(seed.entropy) if isinstance(seed.entropy, int) else seed.entropy,
                "spawn_key": list(seed.spawn_key)}
    if isinstance(seed, np.random.Generator):
        return "numpy Generator supplied by caller (state not recorded)"
    return seed


def _gh_nodes(n: int = 48) -> tuple[np.ndarray, np.ndarray]:
    z, w = np.polynomial.hermite_e.hermegauss(n)
    return z, w / math.sqrt(2 * math.pi)


@dataclass(frozen=True, eq=False)
class UncertainInputs:
    """Named uncertain inputs (frozen): marginals and an optional Pearson correlation matrix.

    Build with :meth:`from_specs`. ``names`` follow the model's ``input_names``.

    Parameters
    ----------
    names : tuple of str
        The inputs' names.
    marginals : tuple
        One marginal per input (:class:`Normal`, :class:`TruncNormal`, :class:`Uniform`,
        :class:`LogNormal`, :class:`Gumbel`, :class:`Weibull`, :class:`Gamma`, :class:`Beta`,
        :class:`ScipyMarginal`; SI units).
    correlation : ndarray, shape (d, d)
        Pearson correlation of the physical inputs (the identity when independent).

    Examples
    --------
    >>> u = UncertainInputs.from_specs({"c": Normal(0.5e-3, 0.05e-3), "w": Normal(9.42, 0.1)},
    ...                                correlation={("c", "w"): 0.5})
    >>> u.names, u.d
    (('c', 'w'), 2)
    >>> X = u.sample(4096, "sobol", seed=1)
    >>> X.shape, bool(abs(np.corrcoef(X.T)[0, 1] - 0.5) < 0.05)
    ((4096, 2), True)
    """

    names: tuple[str, ...]
    marginals: tuple[Marginal, ...]
    correlation: np.ndarray | None = None
    gaussian_correlation: np.ndarray | None = field(default=None, init=False, repr=False)
    _chol: np.ndarray | None = field(default=None, init=False, repr=False)

    # ----------------------------------------------------------------- construction
    def __post_init__(self):
        names = tuple(str(n) for n in self.names)
        if len(names) == 0:
            raise StudyError("inputs: at least one uncertain input is required, got none")
        if len(set(names)) != len(names):
            raise StudyError(f"inputs: names must be unique, got {list(names)}")
        if len(self.marginals) != len(names):
            raise StudyError(
                f"inputs: {len(names)} names but {len(self.marginals)} marginals"
            )
        margs = tuple(_parse_marginal(n, m) for n, m in zip(names, self.marginals))
        object.__setattr__(self, "names", names)
        object.__setattr__(self, "marginals", margs)
        corr = self.correlation
        if corr is not None:
            corr = self._validate_correlation(corr)
            if np.allclose(corr, np.eye(len(names)), rtol=0, atol=0):
                corr = None
        if corr is None:
            object.__setattr__(self, "correlation", None)
            return
        corr.setflags(write=False)
        object.__setattr__(self, "correlation", corr)
        rz = self._nataf_matrix(corr)
        try:
            chol = np.linalg.cholesky(rz)
        except np.linalg.LinAlgError:
            raise StudyError(
                "inputs.correlation: the Gaussian-copula (Nataf) matrix implied by this Pearson "
                "correlation is not positive definite; allowed: a correlation the marginals can "
                f"jointly attain. Implied matrix:\n{np.array2string(rz, precision=4)}"
            ) from None
        rz.setflags(write=False)
        chol.setflags(write=False)
        object.__setattr__(self, "gaussian_correlation", rz)
        object.__setattr__(self, "_chol", chol)

    @classmethod
    def from_specs(
        cls,
        specs: Mapping[str, Any],
        correlation: Any = None,
    ) -> UncertainInputs:
        """Build the inputs from ``{name: spec}``.

        Parameters
        ----------
        specs : mapping of str to marginal or mapping
            ``{name: spec}``; a spec is a marginal object (``Normal(mean, std)``,
            ``TruncNormal(mean, std, lower, upper)``, ``Uniform(lower, upper)``,
            ``LogNormal(mean, std)``, ``Gumbel(mean, std)``, ``Weibull(shape, scale, lower=0)``,
            ``Gamma(mean, std)``, ``Beta(alpha, beta, lower, upper)``,
            ``ScipyMarginal(scipy.stats.NAME(...))``) or a mapping such as
            ``{"distribution": "normal", "mean": 1.0, "std": 0.1}`` or
            ``{"distribution": "scipy.genextreme", "c": -0.1, "loc": 1.0, "scale": 0.2}``,
            in SI units.
        correlation : None, array_like or mapping, optional
            Pearson correlation of the physical inputs: ``None`` (independent), a d×d matrix in the
            order of ``specs``, or ``{(name_a, name_b): rho}`` (unlisted pairs 0).

        Returns
        -------
        UncertainInputs
            The validated inputs.

        Raises
        ------
        StudyError
            If ``specs`` is empty or not a mapping, a spec or a correlation entry is invalid (unknown
            name, |rho| > 1, not positive definite after the Nataf transform).

        Examples
        --------
        >>> u = UncertainInputs.from_specs({"a": {"distribution": "uniform", "lower": 0, "upper": 2},
        ...                                 "b": Normal(0.0, 1.0)}, correlation={("a", "b"): 0.3})
        >>> u.names, u.independent
        (('a', 'b'), False)
        """
        if not isinstance(specs, Mapping) or len(specs) == 0:
            raise StudyError(
                f"inputs: expected a non-empty mapping {{name: spec}}, got {type(specs).__name__}"
                + (" (empty)" if isinstance(specs, Mapping) else "")
            )
        names = tuple(str(k) for k in specs)
        margs = tuple(specs.values())
        if isinstance(correlation, Mapping):
            idx = {n: i for i, n in enumerate(names)}
            mat = np.eye(len(names))
            for pair, rho in correlation.items():
                if not (isinstance(pair, tuple) and len(pair) == 2):
                    raise StudyError(
                        f"inputs.correlation: keys must be (name_a, name_b) pairs, got {pair!r}"
                    )
                a, b = pair
                for n in (a, b):
                    if n not in idx:
                        raise StudyError(
                            f"inputs.correlation: unknown input {n!r}; allowed: {list(names)}"
                        )
                if a == b:
                    raise StudyError(f"inputs.correlation[{pair!r}]: a pair needs two different inputs")
                mat[idx[a], idx[b]] = mat[idx[b], idx[a]] = rho
            correlation = mat
        return cls(names, margs, correlation)

    def _validate_correlation(self, corr: Any) -> np.ndarray:
        d = len(self.names)
        try:
            c = np.array(corr, dtype=float)
        except (TypeError, ValueError):
            raise StudyError(f"inputs.correlation: must be a {d}x{d} numeric matrix, got {corr!r}") from None
        if c.shape != (d, d):
            raise StudyError(f"inputs.correlation: must be {d}x{d} (one row per input), got shape {c.shape}")
        if not np.all(np.isfinite(c)):
            raise StudyError("inputs.correlation: entries must be finite")
        if not np.allclose(c, c.T, rtol=0, atol=1e-12):
            raise StudyError("inputs.correlation: must be symmetric")
        if not np.allclose(np.diag(c), 1.0, rtol=0, atol=1e-12):
            raise StudyError(f"inputs.correlation: diagonal must be 1, got {np.diag(c).tolist()}")
        off = c[~np.eye(d, dtype=bool)]
        if off.size and np.max(np.abs(off)) >= 1:
            i, j = np.argwhere((np.abs(c) >= 1) & ~np.eye(d, dtype=bool))[0]
            raise StudyError(
                f"inputs.correlation[{self.names[i]!r}, {self.names[j]!r}]: got {float(c[i, j])!r}; "
                "allowed: -1 < rho < 1"
            )
        if np.linalg.eigvalsh(c).min() <= 0:
            raise StudyError(
                f"inputs.correlation: must be positive definite, smallest eigenvalue "
                f"{np.linalg.eigvalsh(c).min():.3g}"
            )
        np.fill_diagonal(c, 1.0)
        return c

    # ----------------------------------------------------------------- Nataf
    def _std_transform(self, j: int, z: np.ndarray) -> np.ndarray:
        m = self.marginals[j]
        d = m.scipy()
        return (m.from_z(z) - d.mean()) / d.std()

    def _pearson_from_gaussian(self, i: int, j: int, r: float, z: np.ndarray, w: np.ndarray) -> float:
        za = z[:, None]
        zb = r * za + math.sqrt(max(0.0, 1.0 - r * r)) * z[None, :]
        gi = self._std_transform(i, za)
        gj = self._std_transform(j, zb)
        ww = w[:, None] * w[None, :]
        mi, mj = np.sum(ww * gi), np.sum(ww * gj)
        cov = np.sum(ww * (gi - mi) * (gj - mj))
        vi = np.sum(w * (self._std_transform(i, z) - mi) ** 2)
        vj = np.sum(w * (self._std_transform(j, z) - mj) ** 2)
        return float(cov / math.sqrt(vi * vj))

    def _nataf_matrix(self, corr: np.ndarray) -> np.ndarray:
        d = len(self.names)
        rz = np.eye(d)
        z, w = _gh_nodes()
        for i in range(d):
            for j in range(i + 1, d):
                rho = corr[i, j]
                if rho == 0.0:
                    continue
                if self.marginals[i].kind == "normal" and self.marginals[j].kind == "normal":
                    rz[i, j] = rz[j, i] = rho
                    continue
                f = lambda r: self._pearson_from_gaussian(i, j, r, z, w) - rho  # noqa: E731
                lo, hi = -0.999999, 0.999999
                flo, fhi = f(lo), f(hi)
                if flo > 0 or fhi < 0:
                    raise StudyError(
                        f"inputs.correlation[{self.names[i]!r}, {self.names[j]!r}]: got {rho}; "
                        f"these marginals ({self.marginals[i].kind}, {self.marginals[j].kind}) can only "
                        f"reach Pearson correlations in [{flo + rho:.4f}, {fhi + rho:.4f}]"
                    )
                rz[i, j] = rz[j, i] = optimize.brentq(f, lo, hi, xtol=1e-12)
        return rz

    # ----------------------------------------------------------------- properties
    @property
    def d(self) -> int:
        """The number of inputs.

        Returns
        -------
        int
            ``len(names)``.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)}).d
        2
        """
        return len(self.names)

    @property
    def independent(self) -> bool:
        """Whether the inputs are independent (no correlation given, or the identity).

        Returns
        -------
        bool
            True without a correlation.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 1)}).independent
        True
        """
        return self.correlation is None

    @property
    def mean(self) -> np.ndarray:
        """The true means of the inputs (for a truncated normal: of the truncated variable).

        Returns
        -------
        ndarray, shape (d,)
            The means, in the inputs' units.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Uniform(0, 2), "b": Normal(5, 1)}).mean.tolist()
        [1.0, 5.0]
        """
        return np.array([m.scipy().mean() for m in self.marginals])

    @property
    def std(self) -> np.ndarray:
        """The true standard deviations of the inputs.

        Returns
        -------
        ndarray, shape (d,)
            The standard deviations, in the inputs' units.

        Examples
        --------
        >>> UncertainInputs.from_specs({"b": Normal(5, 3)}).std.tolist()
        [3.0]
        """
        return np.array([m.scipy().std() for m in self.marginals])

    @property
    def pearson_correlation(self) -> np.ndarray:
        """The Pearson correlation matrix of the physical inputs (the identity when independent).

        Returns
        -------
        ndarray, shape (d, d)
            The correlation matrix.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 1)},
        ...                            {("a", "b"): 0.5}).pearson_correlation.tolist()
        [[1.0, 0.5], [0.5, 1.0]]
        """
        return np.eye(self.d) if self.correlation is None else np.array(self.correlation)

    @property
    def covariance(self) -> np.ndarray:
        """The covariance matrix of the physical inputs, ``R_ij σ_i σ_j``.

        Returns
        -------
        ndarray, shape (d, d)
            The covariance, in the products of the inputs' units.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 2), "b": Normal(0, 3)},
        ...                            {("a", "b"): 0.5}).covariance.tolist()
        [[4.0, 3.0], [3.0, 9.0]]
        """
        s = self.std
        return self.pearson_correlation * np.outer(s, s)

    @property
    def joint(self):
        """The chaospy joint distribution of the inputs.

        Returns
        -------
        chaospy.Distribution
            ``J(marginals)``, or ``Nataf(J(marginals), R_z)`` when correlated.

        Examples
        --------
        >>> j = UncertainInputs.from_specs({"a": Normal(1, 1), "b": Uniform(0, 2)}).joint
        >>> j.mom([[1, 0], [0, 1]]).round(12).tolist()
        [1.0, 1.0]
        """
        import chaospy

        j = chaospy.J(*[m.chaospy() for m in self.marginals])
        if self.gaussian_correlation is None:
            return j
        return chaospy.Nataf(j, self.gaussian_correlation)

    def to_frame(self) -> pd.DataFrame:
        """One row per input: its distribution, parameters, mean and standard deviation.

        Returns
        -------
        pandas.DataFrame
            Indexed by the input's name; columns ``distribution``, ``parameters``, ``mean``, ``std``.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(1, 2)}).to_frame()["std"].tolist()
        [2.0]
        """
        rows = []
        for n, m in zip(self.names, self.marginals):
            d = m.scipy()
            rows.append({"name": n, "distribution": m.kind, "parameters": repr(m),
                         "mean": d.mean(), "std": d.std()})
        return pd.DataFrame(rows).set_index("name")

    def describe(self) -> dict:
        """A JSON-friendly description of the inputs, for provenance.

        Returns
        -------
        dict
            ``names``, ``marginals`` (their reprs) and ``correlation`` (a nested list or None).

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(1, 2)}).describe()
        {'names': ['a'], 'marginals': ['Normal(mean=1.0, std=2.0)'], 'correlation': None}
        """
        return {
            "names": list(self.names),
            "marginals": [repr(m) for m in self.marginals],
            "correlation": None if self.correlation is None else self.correlation.tolist(),
        }

    def reordered(self, names: Sequence[str]) -> UncertainInputs:
        """The same inputs in the order ``names``.

        Parameters
        ----------
        names : sequence of str
            The same set of names, in the wanted order (usually a model's ``input_names``).

        Returns
        -------
        UncertainInputs
            The reordered inputs (``self`` when the order is already that one).

        Raises
        ------
        StudyError
            If ``names`` is not the same set as :attr:`names`.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 1), "b": Normal(0, 2)}).reordered(["b", "a"]).names
        ('b', 'a')
        """
        names = tuple(names)
        if names == self.names:
            return self
        if set(names) != set(self.names) or len(names) != len(self.names):
            missing = sorted(set(names) - set(self.names))
            extra = sorted(set(self.names) - set(names))
            raise StudyError(
                f"inputs: names must match the model's input_names; missing {missing}, "
                f"not inputs of the model {extra}"
            )
        perm = [self.names.index(n) for n in names]
        corr = None if self.correlation is None else self.correlation[np.ix_(perm, perm)]
        return UncertainInputs(names, tuple(self.marginals[p] for p in perm), corr)

    # ----------------------------------------------------------------- transforms
    def from_unit(self, u: np.ndarray) -> np.ndarray:
        """Map points of the unit hypercube (independent uniforms) to inputs.

        Parameters
        ----------
        u : array_like, shape (n, d)
            Points in (0, 1)^d (clipped to stay strictly inside).

        Returns
        -------
        ndarray, shape (n, d)
            The input points (through the marginals' inverse CDFs, and the Nataf transform when
            correlated), in the inputs' units.

        Raises
        ------
        StudyError
            If ``u`` is not of shape (n, d).

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Uniform(0, 2)}).from_unit([[0.25]]).tolist()
        [[0.5]]
        """
        u = np.asarray(u, dtype=float)
        if u.ndim != 2 or u.shape[1] != self.d:
            raise StudyError(f"from_unit: expected shape (n, {self.d}), got {u.shape}")
        return self._from_own_unit(np.clip(u, _U_EPS, 1.0 - _U_EPS))

    def _from_own_unit(self, u: np.ndarray) -> np.ndarray:
        """:meth:`from_unit` of points this object owns (an (n, d) float array, changed in
        place): clipped, then mapped column by column into ``u`` itself, so that a sample of
        10⁶ points allocates its own array and no temporaries of its size."""
        np.clip(u, _U_EPS, 1.0 - _U_EPS, out=u)
        if self._chol is not None:
            return self.from_standard_normal(special.ndtri(u, out=u))
        for j, m in enumerate(self.marginals):
            col = u[:, j]
            if type(m) is Normal:
                # SciPy's norm.ppf is ndtri(u)·std + mean, the same bits as from_z(ndtri(u))
                # (mean + std·z: IEEE sums and products commute) without its argument checks
                special.ndtri(col, out=col)
                np.multiply(col, m.std, out=col)
                np.add(col, m.mean, out=col)
            else:
                col[...] = m.scipy().ppf(col)
        return u

    def from_standard_normal(self, z: np.ndarray) -> np.ndarray:
        """Map iid standard-normal germ points to inputs (through R_z's Cholesky factor when correlated).

        Parameters
        ----------
        z : array_like, shape (n, d)
            Independent standard-normal points.

        Returns
        -------
        ndarray, shape (n, d)
            The input points, in the inputs' units.

        Raises
        ------
        StudyError
            If ``z`` is not of shape (n, d).

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(1, 2)}).from_standard_normal([[1.0]]).tolist()
        [[3.0]]
        """
        z = np.asarray(z, dtype=float)
        if z.ndim != 2 or z.shape[1] != self.d:
            raise StudyError(f"from_standard_normal: expected shape (n, {self.d}), got {z.shape}")
        if self._chol is not None:
            z = z @ self._chol.T
        out = np.empty_like(z)
        for j, m in enumerate(self.marginals):
            out[:, j] = m.from_z(z[:, j])
        return out

    def to_standard_normal(self, x: np.ndarray) -> np.ndarray:
        """Map input points to the independent standard-normal space (inverse of :meth:`from_standard_normal`).

        Parameters
        ----------
        x : array_like, shape (n, d)
            Input points, in the inputs' units.

        Returns
        -------
        ndarray, shape (n, d)
            The independent standard-normal points.

        Raises
        ------
        StudyError
            If ``x`` is not of shape (n, d).

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(1, 2)}).to_standard_normal([[3.0]]).tolist()
        [[1.0]]
        """
        x = np.asarray(x, dtype=float)
        if x.ndim != 2 or x.shape[1] != self.d:
            raise StudyError(f"to_standard_normal: expected shape (n, {self.d}), got {x.shape}")
        z = np.empty_like(x)
        for j, m in enumerate(self.marginals):
            z[:, j] = m.to_z(x[:, j])
        if self._chol is not None:
            z = np.linalg.solve(self._chol, z.T).T
        return z

    # ----------------------------------------------------------------- sampling
    def unit_sample(self, n: int, rule: str = "random", seed: Any = None) -> np.ndarray:
        """Draw ``n`` points in the unit hypercube by ``rule`` (see :meth:`sample`).

        Parameters
        ----------
        n : int
            The number of points (>= 1).
        rule : {"random", "latin_hypercube", "sobol"}, optional
            The sampling rule.
        seed : int, SeedSequence, Generator or None, optional
            The seed (None: fresh OS entropy).

        Returns
        -------
        ndarray, shape (n, d)
            Points in [0, 1)^d.

        Raises
        ------
        StudyError
            If ``n`` is not an integer >= 1 or ``rule`` is unknown.

        Examples
        --------
        >>> UncertainInputs.from_specs({"a": Normal(0, 1)}).unit_sample(8, "latin_hypercube", seed=0).shape
        (8, 1)
        """
        n = ARGS.integer("n", n, ge=1, what="a number of draws")
        ARGS.choice("rule", rule, SAMPLING_RULES)
        rng = as_generator(seed)
        if rule == "random":
            return rng.random((n, self.d))
        if rule == "latin_hypercube":
            return qmc.LatinHypercube(self.d, rng=rng).random(n)
        note = sobol_balance_note(n)
        with warnings.catch_warnings():
            # SciPy's own warning names no remedy a caller of mechrel can act on: ours does
            warnings.filterwarnings("ignore", message="The balance properties of Sobol",
                                    category=UserWarning)
            points = qmc.Sobol(self.d, scramble=True, rng=rng).random(n)
        if note is not None:
            warnings.warn(note, EstimateWarning, stacklevel=3)
        return points

    def sample(self, n: int, rule: str = "random", seed: Any = None) -> np.ndarray:
        """Draw ``n`` input vectors.

        Unit-cube points are mapped through the marginal inverse CDFs (and the Nataf transform when
        correlated). The same seed and rule give the same bytes.

        Parameters
        ----------
        n : int
            The number of draws (>= 1; a power of 2 for ``"sobol"``).
        rule : {"random", "latin_hypercube", "sobol"}, optional
            ``"random"`` (iid), ``"latin_hypercube"`` (``scipy.stats.qmc.LatinHypercube``) or
            ``"sobol"`` (scrambled ``scipy.stats.qmc.Sobol``).
        seed : int, SeedSequence, Generator or None, optional
            The seed (None: fresh OS entropy).

        Returns
        -------
        ndarray, shape (n, d)
            The draws, in the inputs' units.

        Raises
        ------
        StudyError
            If ``n`` is not an integer >= 1 or ``rule`` is unknown.

        Examples
        --------
        >>> u = UncertainInputs.from_specs({"a": Normal(0, 1)})
        >>> bool((u.sample(16, "sobol", seed=3) == u.sample(16, "sobol", seed=3)).all())
        True
        """
        return self._from_own_unit(self.unit_sample(n, rule, seed))
