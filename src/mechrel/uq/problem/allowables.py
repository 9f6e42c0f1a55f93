"""Allowable errors, the interference formulas (one- and two-sided) and binomial intervals.

Notation (the paper's eqs. 25–28): i is the actual (signed) output error at one crank angle,
I the allowable error ("strength"), both normal and independent:
i ~ N(μ_i, σ_i²), I ~ N(μ_I, σ_I²), s = sqrt(σ_I² + σ_i²).

one-sided (the paper)
    R₁ = P(I − i > 0) = Φ(β),  β = (μ_I − μ_i)/s.
two-sided (a tolerance on the magnitude)
    R₂ = P(−I < i < I) = P(α₁ > 0, α₂ > 0) with α₁ = I − i, α₂ = I + i.
    (α₁, α₂) is bivariate normal with means (μ_I − μ_i, μ_I + μ_i), equal variances s² and
    covariance σ_I² − σ_i², hence exactly
    R₂ = Φ₂(β₊, β₋; ρ),  β₊ = (μ_I − μ_i)/s = β,  β₋ = (μ_I + μ_i)/s,  ρ = (σ_I² − σ_i²)/s².
    (The event is empty when I ≤ 0, which the orthant form handles automatically; the often
    quoted Φ(β₊) − Φ(−β₋) = Φ(β₊) + Φ(β₋) − 1 differs from it by P(I ≤ i ≤ −I), which needs I < 0.)
    The generalised reliability index is Φ⁻¹(R₂).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any

import numpy as np
import pandas as pd
from scipy import special, stats

from mechrel.errors import StudyError
from mechrel.outputs import QUANTITY_INFO

__all__ = [
    "Allowable",
    "DEFAULT_ALLOWABLES",
    "EVENTS",
    "resolve_allowables",
    "output_groups",
    "EXTREME_STATS",
    "sector_label",
    "parse_sector",
    "per_angle_mask",
    "whole_cycle_column",
    "reliability_one_sided",
    "reliability_two_sided",
    "bivariate_normal_cdf",
    "binomial_interval",
]

EVENTS = ("one-sided", "two-sided")


@dataclass(frozen=True)
class Allowable:
    """Allowable output error I ~ N(mean, std²) (std = 0: a fixed tolerance).

    Parameters
    ----------
    mean : float
        Mean allowable error, in the unit of its quantity (SI: m, m/s, m/s²), > 0.
    std : float, default 0.0
        Its standard deviation (≥ 0): the paper's "strength" scatter.

    Examples
    --------
    >>> from mechrel.uq import Allowable
    >>> Allowable(0.2, 0.01)
    Allowable(mean=0.2, std=0.01)
    """

    mean: float
    std: float = 0.0

    def __post_init__(self):
        try:
            m, s = float(self.mean), float(self.std)
        except (TypeError, ValueError):
            raise StudyError(f"Allowable: mean and std must be numbers, got {self.mean!r}, {self.std!r}") from None
        if not (math.isfinite(m) and m > 0):
            raise StudyError(f"Allowable.mean: must be finite and > 0, got {self.mean!r}")
        if not (math.isfinite(s) and s >= 0):
            raise StudyError(f"Allowable.std: must be finite and >= 0, got {self.std!r}")
        object.__setattr__(self, "mean", m)
        object.__setattr__(self, "std", s)


#: The default allowable errors by the ``quantity`` level, from the output kinds' table
#: (:data:`mechrel.outputs.OUTPUT_KINDS`): the paper's (§5) for a point's motion, displacement
#: 0.012 ± 0.004 m, velocity 0.3 ± 0.1 m/s, acceleration 18 ± 6 m/s² (mean ± standard
#: deviation); quantities without a default (a body's angle, a joint's film) need one given.
DEFAULT_ALLOWABLES: Mapping[str, Allowable] = MappingProxyType({
    name: Allowable(*q.allowable) for name, q in QUANTITY_INFO.items()
    if q.allowable is not None})


def output_groups(index: pd.Index) -> np.ndarray:
    """The group label of each output: its ``quantity`` level when present, else ``"all"``.

    Parameters
    ----------
    index : pandas.Index
        A model's output labels.

    Returns
    -------
    ndarray of str, shape (n_out,)
        The group (quantity) of each output.

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("acceleration", 0.0)],
    ...                                 names=["quantity", "crank_angle"])
    >>> output_groups(idx).tolist(), output_groups(pd.Index(["y"])).tolist()
    (['velocity', 'acceleration'], ['all'])
    """
    if isinstance(index, pd.MultiIndex) and "quantity" in index.names:
        return np.asarray(index.get_level_values("quantity").astype(str))
    if index.name == "quantity":
        return np.asarray(index.astype(str))
    return np.full(len(index), "all", dtype=object)


#: The labels of the cycle extremes in a model's ``crank_angle`` level (beside the numeric
#: analysis angles): the largest and smallest signed error and the largest |error| over the
#: analysed cycle, found on the integrator's solution (:class:`~mechrel.uq.MechanismModel`).
EXTREME_STATS = ("max", "min", "max_abs")


def sector_label(stat: str, lo: float, hi: float) -> str:
    """The label of a sector extreme: the largest (``"max"``) or smallest (``"min"``) signed
    error over the crank angles [lo, hi] of the analysed cycle (degrees; a closed sector, so
    a peak on a boundary belongs to both neighbours).

    The whole cycle is the union of its sectors, so its event is the series system of the
    sector extremes (per quantity, sector and sign): the members whose design points the
    rare-event methods search (docs/uq.md, "The whole cycle as a series system").

    Parameters
    ----------
    stat : {"max", "min"}
        The statistic.
    lo, hi : float
        The sector's crank angles, degrees.

    Returns
    -------
    str
        ``"max[lo,hi]"`` or ``"min[lo,hi]"``.

    Examples
    --------
    >>> sector_label("max", 0.0, 18.0)
    'max[0,18]'
    """
    return f"{stat}[{lo:g},{hi:g}]"


def parse_sector(label) -> tuple[str, float, float] | None:
    """``(stat, lo, hi)`` of a sector-extreme label (:func:`sector_label`), else None.

    Parameters
    ----------
    label : object
        A ``crank_angle`` label.

    Returns
    -------
    tuple or None
        The statistic and the sector's crank angles (degrees).

    Examples
    --------
    >>> parse_sector("min[18,36]"), parse_sector("max"), parse_sector(18.0)
    (('min', 18.0, 36.0), None, None)
    """
    if not isinstance(label, str) or not label.endswith("]") or "[" not in label:
        return None
    stat, _, rest = label.partition("[")
    lo, _, hi = rest[:-1].partition(",")
    try:
        return stat, float(lo), float(hi)
    except ValueError:
        return None


def per_angle_mask(index: pd.Index) -> np.ndarray:
    """Which outputs are at an analysis angle (not a cycle extreme).

    Parameters
    ----------
    index : pandas.Index
        A model's output labels.

    Returns
    -------
    ndarray of bool, shape (n_out,)
        False for the cycle extremes (:data:`EXTREME_STATS` in the ``crank_angle`` level); all
        True for other indexes.

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> per_angle_mask(idx).tolist()
    [True, False]
    """
    if isinstance(index, pd.MultiIndex) and "crank_angle" in index.names:
        angles = index.get_level_values("crank_angle")
        return np.array([not isinstance(a, str) for a in angles], dtype=bool)
    return np.ones(len(index), dtype=bool)


def whole_cycle_column(index: pd.Index, group: str, event: str) -> int | None:
    """The position of the output whose event is the whole-cycle event of a quantity.

    The cycle's largest |error| (``max_abs``) for the two-sided event, its largest signed error
    (``max``) for the one-sided one: |i| <= I (i <= I) at every instant is max |i| <= I
    (max i <= I).

    Parameters
    ----------
    index : pandas.Index
        A model's output labels.
    group : str
        The quantity.
    event : {"one-sided", "two-sided"}
        The event.

    Returns
    -------
    int or None
        The position; None when the index has no cycle extremes (the analysis angles then stand
        in for the cycle).

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", "max"),
    ...                                  ("velocity", "max_abs")], names=["quantity", "crank_angle"])
    >>> whole_cycle_column(idx, "velocity", "two-sided"), whole_cycle_column(idx, "velocity", "one-sided")
    (2, 1)
    """
    if not (isinstance(index, pd.MultiIndex) and "crank_angle" in index.names
            and "quantity" in index.names):
        return None
    stat = "max_abs" if event == "two-sided" else "max"
    q = index.get_level_values("quantity").astype(str)
    a = index.get_level_values("crank_angle")
    hits = [i for i in range(len(index)) if q[i] == group and isinstance(a[i], str) and a[i] == stat]
    return hits[0] if hits else None


def resolve_allowables(index: pd.Index, allowable: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The allowable's mean and standard deviation, and the group, of each output.

    Parameters
    ----------
    index : pandas.Index
        A model's output labels.
    allowable : None, Allowable, tuple or mapping
        None (the defaults by the ``quantity`` level, :data:`DEFAULT_ALLOWABLES`), one
        :class:`Allowable` (or ``(mean, std)``) for every output, or ``{quantity: Allowable}``;
        in the outputs' units.

    Returns
    -------
    mu_I, sigma_I : ndarray, shape (n_out,)
        The allowable's mean and standard deviation per output.
    group : ndarray of str, shape (n_out,)
        The group (quantity) per output.

    Raises
    ------
    StudyError
        If ``allowable`` is of another type, keyed by quantity for outputs without one, or
        misses a quantity of the outputs.

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0)], names=["quantity", "crank_angle"])
    >>> mu, sd, g = resolve_allowables(idx, None)
    >>> float(mu[0]), float(sd[0]), g.tolist()
    (0.3, 0.1, ['velocity'])
    """
    groups = output_groups(index)
    if isinstance(allowable, tuple) and len(allowable) == 2:
        allowable = Allowable(*allowable)
    if isinstance(allowable, Allowable):
        n = len(index)
        return np.full(n, allowable.mean), np.full(n, allowable.std), groups
    if allowable is None:
        table = DEFAULT_ALLOWABLES
        src = "the default allowables"
    elif isinstance(allowable, Mapping):
        table = {str(k): (v if isinstance(v, Allowable) else Allowable(*v)) for k, v in allowable.items()}
        src = "allowable"
    else:
        raise StudyError(
            f"allowable: expected None, an Allowable(mean, std) or a mapping {{quantity: Allowable}}, "
            f"got {type(allowable).__name__}"
        )
    if set(groups) == {"all"} and "all" not in table:
        raise StudyError(
            f"allowable: the outputs have no 'quantity' level, so {src} keyed by quantity "
            f"({sorted(table)}) cannot be matched; pass one Allowable(mean, std) for all outputs"
        )
    missing = sorted(set(groups) - set(table))
    if missing:
        raise StudyError(
            f"allowable: no allowable error for quantity {missing}; {src} cover {sorted(table)}"
        )
    mu = np.array([table[g].mean for g in groups], dtype=float)
    sd = np.array([table[g].std for g in groups], dtype=float)
    return mu, sd, groups


def check_event(event: str) -> str:
    if event not in EVENTS:
        raise StudyError(f"event: got {event!r}; allowed: {list(EVENTS)}")
    return event


def reliability_one_sided(mu_i, sigma_i, mu_I, sigma_I) -> tuple[np.ndarray, np.ndarray]:
    """The paper's eqs. (25)–(28): β = (μ_I − μ_i)/sqrt(σ_I² + σ_i²), R = Φ(β).

    With s = 0 (both deterministic) β = ±inf and R ∈ {0, 1} (R = 0.5 when μ_i = μ_I).

    Parameters
    ----------
    mu_i, sigma_i : array_like
        Mean and standard deviation of the signed error i.
    mu_I, sigma_I : array_like
        Mean and standard deviation of the allowable I (same unit), broadcast against them.

    Returns
    -------
    beta : ndarray
        The reliability index.
    R : ndarray
        The reliability P(I − i > 0) = Φ(β).

    Examples
    --------
    >>> from mechrel.uq import reliability_one_sided
    >>> beta, R = reliability_one_sided(0.0, 0.3, 1.2, 0.4)   # β = 1.2 / 0.5
    >>> round(float(beta), 12), round(float(R), 6)
    (2.4, 0.991802)
    """
    mu_i, sigma_i, mu_I, sigma_I = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (mu_i, sigma_i, mu_I, sigma_I)))
    s = np.hypot(sigma_I, sigma_i)
    num = mu_I - mu_i
    with np.errstate(divide="ignore", invalid="ignore"):
        beta = np.where(s > 0, num / np.where(s > 0, s, 1.0), np.sign(num) * np.inf)
    beta = np.where((s == 0) & (num == 0), 0.0, beta)
    return beta, special.ndtr(beta)


def bivariate_normal_cdf(h, k, rho) -> np.ndarray:
    """Φ₂(h, k; ρ) = P(Z₁ < h, Z₂ < k) for standard normals with correlation ρ.

    Owen's T representation (exact to double precision, vectorised):
    Φ₂ = ½Φ(h) + ½Φ(k) − T(h, a_h) − T(k, a_k) − δ, a_h = (k − ρh)/(h√(1−ρ²)),
    a_k = (h − ρk)/(k√(1−ρ²)), δ = ½ if hk < 0 or (hk = 0 and h + k < 0), else 0;
    with the limits ρ → ±1 and h or k = 0 handled explicitly.

    Parameters
    ----------
    h, k : array_like
        Upper limits of Z₁ and Z₂.
    rho : array_like
        Their correlation, in [−1, 1]; all three are broadcast together.

    Returns
    -------
    ndarray
        Φ₂(h, k; ρ), of the broadcast shape.

    Examples
    --------
    Sheppard's formula at the origin, Φ₂(0, 0; ρ) = 1/4 + arcsin(ρ)/(2π):

    >>> from mechrel.uq import bivariate_normal_cdf
    >>> round(float(bivariate_normal_cdf(0.0, 0.0, 0.5)), 12)   # 1/4 + 1/12
    0.333333333333
    """
    h, k, rho = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (h, k, rho)))
    out = np.empty(h.shape, dtype=float)
    h = h.ravel(); k = k.ravel(); rho = rho.ravel()
    res = np.empty(h.shape, dtype=float)
    Ph = special.ndtr(h)
    one = rho >= 1 - 1e-15
    mone = rho <= -1 + 1e-15
    res[one] = special.ndtr(np.minimum(h[one], k[one]))
    res[mone] = np.maximum(0.0, Ph[mone] - special.ndtr(-k[mone]))
    gen = ~(one | mone)
    if np.any(gen):
        hh, kk, rr = h[gen], k[gen], rho[gen]
        sq = np.sqrt((1 - rr) * (1 + rr))
        inf_h, inf_k = ~np.isfinite(hh), ~np.isfinite(kk)
        with np.errstate(divide="ignore", invalid="ignore"):
            ah = (kk - rr * hh) / (hh * sq)
            ak = (hh - rr * kk) / (kk * sq)
            # h = 0 (or k = 0): T(0, ±inf) = ±1/4 via a = sign(numerator)·inf
            ah = np.where(hh == 0, np.sign(kk - rr * hh) * np.inf, ah)
            ak = np.where(kk == 0, np.sign(hh - rr * kk) * np.inf, ak)
        ah = np.where(np.isnan(ah), 0.0, ah)
        ak = np.where(np.isnan(ak), 0.0, ak)
        T = _owens_t
        delta = np.where((hh * kk < 0) | ((hh * kk == 0) & (hh + kk < 0)), 0.5, 0.0)
        val = 0.5 * special.ndtr(hh) + 0.5 * special.ndtr(kk) - T(hh, ah) - T(kk, ak) - delta
        # h = k = 0: Sheppard's formula
        val = np.where((hh == 0) & (kk == 0), 0.25 + np.arcsin(rr) / (2 * np.pi), val)
        # infinite arguments: Φ₂(h, +inf) = Φ(h), Φ₂(-inf, .) = 0
        val = np.where(inf_h & (hh > 0), special.ndtr(kk), val)
        val = np.where(inf_k & (kk > 0), special.ndtr(hh), val)
        val = np.where((inf_h & (hh > 0)) & (inf_k & (kk > 0)), 1.0, val)
        val = np.where((inf_h & (hh < 0)) | (inf_k & (kk < 0)), 0.0, val)
        res[gen] = np.clip(val, 0.0, 1.0)
    out[...] = res.reshape(out.shape)
    return out


def _owens_t(h: np.ndarray, a: np.ndarray) -> np.ndarray:
    """Owen's T with a = ±inf allowed: T(h, ±inf) = ±½Φ(−|h|)."""
    h = np.asarray(h, dtype=float); a = np.asarray(a, dtype=float)
    fin = np.isfinite(a) & np.isfinite(h)
    out = np.zeros(np.broadcast(h, a).shape)
    hb, ab = np.broadcast_arrays(h, a)
    out[fin] = special.owens_t(hb[fin], ab[fin])
    inf_a = ~np.isfinite(ab) & np.isfinite(hb)
    out[inf_a] = np.sign(ab[inf_a]) * 0.5 * special.ndtr(-np.abs(hb[inf_a]))
    return out


def reliability_two_sided(mu_i, sigma_i, mu_I, sigma_I) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """P(−I < i < I) under the normal assumptions (module docstring: the bivariate orthant form).

    Parameters
    ----------
    mu_i, sigma_i : array_like
        Mean and standard deviation of the signed error i.
    mu_I, sigma_I : array_like
        Mean and standard deviation of the allowable I (same unit), broadcast against them.

    Returns
    -------
    beta_plus, beta_minus : ndarray
        (μ_I − μ_i)/s and (μ_I + μ_i)/s, s = sqrt(σ_I² + σ_i²).
    R : ndarray
        The reliability P(−I < i < I).
    beta_generalized : ndarray
        Φ⁻¹(R).

    Examples
    --------
    A fixed allowable of two standard deviations around a centred error: R = 2Φ(2) − 1.

    >>> from mechrel.uq import reliability_two_sided
    >>> bp, bm, R, bg = reliability_two_sided(0.0, 1.0, 2.0, 0.0)
    >>> round(float(R), 6)
    0.9545
    """
    mu_i, sigma_i, mu_I, sigma_I = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (mu_i, sigma_i, mu_I, sigma_I)))
    s2 = sigma_I**2 + sigma_i**2
    s = np.sqrt(s2)
    bp, _ = reliability_one_sided(mu_i, sigma_i, mu_I, sigma_I)
    bm, _ = reliability_one_sided(-mu_i, sigma_i, mu_I, sigma_I)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho = np.where(s2 > 0, (sigma_I**2 - sigma_i**2) / np.where(s2 > 0, s2, 1.0), 1.0)
    R = bivariate_normal_cdf(bp, bm, rho)
    R = np.where(s == 0, ((mu_I > mu_i) & (mu_I > -mu_i)).astype(float), R)
    return bp, bm, R, special.ndtri(R)


def binomial_interval(k, n, *, confidence_level: float = 0.95, method: str = "wilson") -> tuple[np.ndarray, np.ndarray]:
    """Two-sided confidence interval for a binomial proportion k/n (vectorised).

    For Latin hypercube or Sobol designs the samples are not independent and the true sampling
    variance is smaller: these intervals are then conservative (too wide), never too narrow for
    a bounded indicator.

    Parameters
    ----------
    k, n : array_like of int
        Successes and trials.
    confidence_level : float, default 0.95
        Coverage of the interval, in (0, 1).
    method : {"wilson", "clopper-pearson"}, default "wilson"
        ``"wilson"``: the score interval (good coverage down to small n and extreme p);
        ``"clopper-pearson"``: exact and conservative.

    Returns
    -------
    lo, hi : ndarray
        The interval's bounds.

    Raises
    ------
    StudyError
        If ``confidence_level`` is not in (0, 1) or ``method`` is unknown.

    Examples
    --------
    >>> from mechrel.uq import binomial_interval
    >>> lo, hi = binomial_interval(50, 100)
    >>> round(float(lo), 4), round(float(hi), 4)
    (0.4038, 0.5962)
    """
    k = np.asarray(k, dtype=float)
    n = np.asarray(n, dtype=float)
    if not 0 < confidence_level < 1:
        raise StudyError(f"confidence_level: must be in (0, 1), got {confidence_level!r}")
    alpha = 1 - confidence_level
    with np.errstate(divide="ignore", invalid="ignore"):
        if method == "wilson":
            z = stats.norm.ppf(1 - alpha / 2)
            p = k / n
            den = 1 + z**2 / n
            centre = (p + z**2 / (2 * n)) / den
            half = z * np.sqrt(p * (1 - p) / n + z**2 / (4 * n**2)) / den
            lo, hi = centre - half, centre + half
            lo = np.where(k == 0, 0.0, lo)
            hi = np.where(k == n, 1.0, hi)
        elif method in ("clopper-pearson", "clopper_pearson", "exact"):
            lo = np.where(k > 0, stats.beta.ppf(alpha / 2, k, n - k + 1), 0.0)
            hi = np.where(k < n, stats.beta.ppf(1 - alpha / 2, k + 1, n - k), 1.0)
        else:
            raise StudyError(f"ci_method: got {method!r}; allowed: ['wilson', 'clopper-pearson']")
    bad = n <= 0
    lo = np.where(bad, np.nan, np.clip(lo, 0, 1))
    hi = np.where(bad, np.nan, np.clip(hi, 0, 1))
    return lo, hi
