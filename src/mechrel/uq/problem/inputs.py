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

Correlation
-----------
``correlation`` is the Pearson correlation matrix of the *physical* inputs X (what one measures).
Dependence is modelled by a Gaussian copula (the Nataf transformation): X_j = F_j⁻¹(Φ(Z_j)),
Z ~ N(0, R_z). For two normal marginals R_z = R_x; otherwise each R_z entry is solved from the
Nataf integral equation ρ_x = E[g_i(Z_i) g_j(Z_j)] (g = standardised F⁻¹∘Φ) by 2-D Gauss–Hermite
quadrature and root finding. ``UncertainInputs.gaussian_correlation`` exposes R_z and
``.joint`` is ``chaospy.Nataf(J(marginals), R_z)``.
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
    "Marginal",
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
            If the mean or the standard deviation is not a finite number > 0.

        Examples
        --------
        >>> LogNormal(1, 1).validated("x")
        LogNormal(mean=1.0, std=1.0)
        """
        return LogNormal(
            _finite(name, "mean", self.mean, positive=True), _finite(name, "std", self.std, positive=True)
        )

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


Marginal = Normal | TruncNormal | Uniform | LogNormal
_KINDS: dict[str, tuple[type, tuple[str, ...]]] = {
    "normal": (Normal, ("mean", "std")),
    "truncnormal": (TruncNormal, ("mean", "std", "lower", "upper")),
    "uniform": (Uniform, ("lower", "upper")),
    "lognormal": (LogNormal, ("mean", "std")),
}


def _parse_marginal(name: str, spec: Any) -> Marginal:
    if isinstance(spec, (Normal, TruncNormal, Uniform, LogNormal)):
        return spec.validated(name)
    if not isinstance(spec, Mapping):
        raise StudyError(
            f"inputs.{name}: expected a mapping like {{'distribution': 'normal', 'mean': ..., 'std': ...}} "
            f"or a Normal/TruncNormal/Uniform/LogNormal, got {type(spec).__name__}"
        )
    spec = dict(spec)
    kind = spec.pop("distribution", spec.pop("dist", None))
    if kind is None:
        raise StudyError(f"inputs.{name}.distribution: missing; allowed: {sorted(_KINDS)}")
    kind_key = str(kind).lower().replace("_", "").replace("-", "")
    if kind_key not in _KINDS:
        raise StudyError(f"inputs.{name}.distribution: got {kind!r}; allowed: {sorted(_KINDS)}")
    cls, fields = _KINDS[kind_key]
    missing = [f for f in fields if f not in spec]
    extra = sorted(set(spec) - set(fields))
    if missing or extra:
        raise StudyError(
            f"inputs.{name}: distribution {kind_key!r} takes fields {list(fields)}; "
            f"missing {missing}, unknown {extra}"
        )
    return cls(**{f: spec[f] for f in fields}).validated(name)


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
        One :class:`Normal`, :class:`TruncNormal`, :class:`Uniform` or :class:`LogNormal`
        per input (SI units).
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
            ``LogNormal(mean, std)``) or a mapping such as
            ``{"distribution": "normal", "mean": 1.0, "std": 0.1}``, in SI units.
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
        u = np.clip(np.asarray(u, dtype=float), _U_EPS, 1.0 - _U_EPS)
        if u.ndim != 2 or u.shape[1] != self.d:
            raise StudyError(f"from_unit: expected shape (n, {self.d}), got {u.shape}")
        if self._chol is None:
            out = np.empty_like(u)
            for j, m in enumerate(self.marginals):
                out[:, j] = m.scipy().ppf(u[:, j])
            return out
        return self.from_standard_normal(special.ndtri(u))

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
            if isinstance(m, Normal):
                z[:, j] = (x[:, j] - m.mean) / m.std
            elif isinstance(m, LogNormal):
                mu, s = m.log_params
                z[:, j] = (np.log(x[:, j]) - mu) / s
            else:
                z[:, j] = special.ndtri(np.clip(m.scipy().cdf(x[:, j]), _U_EPS, 1 - _U_EPS))
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
        return self.from_unit(self.unit_sample(n, rule, seed))
