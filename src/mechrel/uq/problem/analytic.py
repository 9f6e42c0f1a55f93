"""Analytic test models with known answers (module-level, hence picklable).

Used by the test-suite and the examples in ``docs/uq.md``; handy for checking a study set-up
before spending hours of mechanism simulation.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from .inputs import UncertainInputs, Uniform
from .model import FunctionModel

__all__ = ["LinearFunction", "linear_model", "ishigami", "ishigami_model", "ishigami_inputs", "ishigami_indices"]


@dataclass(frozen=True)
class LinearFunction:
    """The affine map y = a + B x, a picklable callable (the function of :func:`linear_model`).

    Parameters
    ----------
    a : tuple of float
        The intercepts, one per output.
    B : tuple of tuple of float
        The coefficients, one row per output and one column per input.

    Examples
    --------
    >>> LinearFunction((1.0,), ((2.0, -1.0),))(np.array([3.0, 4.0])).tolist()
    [3.0]
    """

    a: tuple[float, ...]
    B: tuple[tuple[float, ...], ...]

    def __call__(self, x: np.ndarray) -> np.ndarray:
        return np.asarray(self.a) + np.asarray(self.B) @ x


def linear_model(a, B, input_names, output_index=None, key: str = "linear") -> FunctionModel:
    """A :class:`FunctionModel` computing y = a + B x.

    Parameters
    ----------
    a : array_like, shape (m,)
        Intercepts, one per output (units of the outputs).
    B : array_like, shape (m, d)
        Coefficients, one row per output and one column per input.
    input_names : sequence of str
        The d input names, in the order of the columns of ``B``.
    output_index : pandas.Index, optional
        Labels of the m outputs (default ``RangeIndex(m, name="output")``).
    key : str, default "linear"
        Prefix of the model's cache key (the coefficients are appended).

    Returns
    -------
    FunctionModel
        A picklable model; FOSM is exact for it, and its output is normal for normal inputs.

    Examples
    --------
    >>> m = linear_model([1.0], [[2.0, -1.0]], ("x1", "x2"))
    >>> m.evaluate(np.array([3.0, 4.0]))   # 1 + 2·3 − 4
    array([3.])
    """
    a = tuple(float(v) for v in np.atleast_1d(a))
    B = tuple(tuple(float(v) for v in row) for row in np.atleast_2d(B))
    if output_index is None:
        output_index = pd.RangeIndex(len(a), name="output")
    return FunctionModel(LinearFunction(a, B), input_names, output_index, key=f"{key}:{a}:{B}")


def ishigami(x: np.ndarray, a: float = 7.0, b: float = 0.1) -> np.ndarray:
    """Ishigami function sin x₁ + a sin² x₂ + b x₃⁴ sin x₁, x ~ U(−π, π)³.

    Source: T. Ishigami & T. Homma (1990), "An importance quantification technique in
    uncertainty analysis for computer models", ISUMA '90, 398–403.

    Parameters
    ----------
    x : numpy.ndarray, shape (3,)
        The inputs x₁, x₂, x₃ (rad).
    a, b : float
        The coefficients (7 and 0.1 are the usual choice).

    Returns
    -------
    numpy.ndarray, shape (1,)
        The function value.

    Examples
    --------
    >>> ishigami(np.array([np.pi / 2, np.pi / 2, 0.0]))   # 1 + 7
    array([8.])
    """
    return np.array([math.sin(x[0]) + a * math.sin(x[1]) ** 2 + b * x[2] ** 4 * math.sin(x[0])])


def ishigami_model() -> FunctionModel:
    """The Ishigami function (a = 7, b = 0.1) as a :class:`FunctionModel` with output ``y``.

    Returns
    -------
    FunctionModel
        Inputs ``x1``, ``x2``, ``x3``; one output ``y``.

    Examples
    --------
    >>> ishigami_model().evaluate(np.array([np.pi / 2, 0.0, 1.0]))   # 1 + 0.1
    array([1.1])
    """
    return FunctionModel(ishigami, ("x1", "x2", "x3"), pd.Index(["y"], name="output"), key="ishigami a=7 b=0.1")


def ishigami_inputs() -> UncertainInputs:
    """Independent inputs x1, x2, x3 ~ U(−π, π) of the Ishigami function.

    Returns
    -------
    UncertainInputs
        The three independent uniform inputs.

    Examples
    --------
    >>> ishigami_inputs().sample(4, seed=1).shape
    (4, 3)
    """
    return UncertainInputs.from_specs({f"x{i}": Uniform(-math.pi, math.pi) for i in (1, 2, 3)})


def ishigami_indices(a: float = 7.0, b: float = 0.1) -> dict[str, np.ndarray]:
    """Analytic first- and total-order Sobol indices of the Ishigami function.

    V₁ = ½(1 + bπ⁴/5)², V₂ = a²/8, V₁₃ = b²π⁸(1/18 − 1/50), V = V₁ + V₂ + V₁₃; V₃ = 0.
    Derived from the ANOVA decomposition of :func:`ishigami` over (−π, π)³.

    Parameters
    ----------
    a, b : float
        The coefficients of :func:`ishigami`.

    Returns
    -------
    dict
        ``first`` and ``total`` (arrays of the 3 first- and total-order indices), ``mean``
        (a/2) and ``variance`` (V).

    Examples
    --------
    >>> d = ishigami_indices()
    >>> d["first"].round(4), d["total"].round(4)
    (array([0.3139, 0.4424, 0.    ]), array([0.5576, 0.4424, 0.2437]))
    >>> d["mean"], round(d["variance"], 4)
    (3.5, 13.8446)
    """
    pi = math.pi
    v1 = 0.5 * (1 + b * pi**4 / 5) ** 2
    v2 = a**2 / 8
    v13 = b**2 * pi**8 * (1 / 18 - 1 / 50)
    v = v1 + v2 + v13
    return {
        "first": np.array([v1 / v, v2 / v, 0.0]),
        "total": np.array([(v1 + v13) / v, v2 / v, v13 / v]),
        "mean": a / 2,
        "variance": v,
    }


QUANTITIES = ("displacement", "velocity", "acceleration")


def slider_position(theta, crank, rod, offset):
    """The slider of an offset slider-crank: position and its first two crank-angle derivatives.

    s(θ) = r cos θ + √(l² − q²), q = r sin θ − e (the slider's line at distance e from the crank
    pivot, the slider on the side of positive x; Norton, *Design of Machinery*, §4.6):

        s′ = −r sin θ − q q′/D,  s″ = −r cos θ − (q′² + q q″)/D − (q q′)²/D³,

    with D = √(l² − q²), q′ = r cos θ, q″ = −r sin θ.

    Parameters
    ----------
    theta : array_like
        Crank angle, rad.
    crank, rod, offset : array_like
        r, l and e, m (broadcast against ``theta``).

    Returns
    -------
    (ndarray, ndarray, ndarray)
        s (m), ds/dθ (m/rad), d²s/dθ² (m/rad²).

    Examples
    --------
    At θ = 0 an in-line slider-crank is stretched out, s = r + l:

    >>> [round(float(v), 12) + 0.0 for v in slider_position(0.0, 0.05, 0.12, 0.0)]
    [0.17, 0.0, -0.070833333333]
    """
    t = np.asarray(theta, dtype=float)
    r, l, e = (np.asarray(v, dtype=float) for v in (crank, rod, offset))
    st, ct = np.sin(t), np.cos(t)
    q = r * st - e
    dq, ddq = r * ct, -r * st
    D = np.sqrt(l * l - q * q)
    s = r * ct + D
    ds = -r * st - q * dq / D
    dds = -r * ct - (dq * dq + q * ddq) / D - (q * dq) ** 2 / D**3
    return s, ds, dds


@dataclass(frozen=True)
class SliderCrankErrors:
    """The slider's kinematic error of an offset slider-crank with tolerances (the function of
    :func:`slider_crank_tolerance_model`), a picklable callable on rows (crank, rod, offset)."""

    crank: float
    rod: float
    offset: float
    speed: float
    angles: tuple
    quantities: tuple
    extremes: bool
    sectors: bool
    points_per_sector: int

    def grid(self) -> np.ndarray:
        """The fine crank-angle grid of the cycle extremes (degrees): every sector's ends and
        ``points_per_sector − 1`` points inside."""
        a = np.asarray(self.angles)
        k = self.points_per_sector
        return np.concatenate([np.linspace(lo, hi, k + 1)[:-1] for lo, hi in zip(a[:-1], a[1:])] + [a[-1:]])

    def __call__(self, X: np.ndarray) -> np.ndarray:
        X = np.atleast_2d(np.asarray(X, dtype=float))
        a = np.deg2rad(np.asarray(self.angles))
        fine = np.deg2rad(self.grid())
        theta = np.concatenate([a, fine])
        nominal = slider_position(theta, self.crank, self.rod, self.offset)
        actual = slider_position(theta[None, :], X[:, :1], X[:, 1:2], X[:, 2:3])
        w = self.speed
        errs = {"displacement": actual[0] - nominal[0], "velocity": w * (actual[1] - nominal[1]),
                "acceleration": w * w * (actual[2] - nominal[2])}
        na = a.size
        k = self.points_per_sector
        parts = [errs[q][:, :na] for q in self.quantities]
        if self.extremes:
            for q in self.quantities:
                f = errs[q][:, na:]
                parts.append(np.column_stack([f.max(axis=1), f.min(axis=1), np.abs(f).max(axis=1)]))
        if self.sectors:
            for q in self.quantities:
                f = errs[q][:, na:]
                # sector j: fine points j k ... (j + 1) k (both ends: the boundary belongs to both)
                blocks = [f[:, j * k: (j + 1) * k + 1] for j in range(na - 1)]
                parts.append(np.column_stack([b.max(axis=1) for b in blocks]
                                             + [b.min(axis=1) for b in blocks]))
        return np.concatenate(parts, axis=1)


def slider_crank_tolerance_model(*, crank: float = 0.05, rod: float = 0.12, offset: float = 0.0,
                                 speed: float = 523.5987755982989, angle_step: float = 18.0,
                                 quantities=QUANTITIES, extremes: bool = True, sectors: bool = True,
                                 points_per_sector: int = 32) -> FunctionModel:
    """The kinematic error of an offset slider-crank whose crank, rod and offset are uncertain.

    A mechanism in closed form (:func:`slider_position`) with the outputs of a
    :class:`~mechrel.uq.MechanismModel` of geometric tolerances: the error (actual − nominal) of
    the slider's displacement (m), velocity (m/s) and acceleration (m/s²) at constant crank speed
    ω, at the analysis angles, then per quantity the cycle extremes (``max``, ``min``,
    ``max_abs``) and the sector extremes (``max[lo,hi]``, ``min[lo,hi]``,
    :func:`~mechrel.uq.problem.allowables.sector_label`), all over a fine grid of
    ``points_per_sector`` intervals per sector. Its error peaks at several crank angles with
    either sign (a rod-length tolerance shifts the whole curve, a crank-length one scales
    cos θ), so its whole-cycle failure event is a series system with several design points: the
    test problem of the rare-event methods (``tests/test_uq_system.py``). Its per-angle errors
    agree with the simulator's on the embedded ``slider-crank`` scene (the same test).

    Parameters
    ----------
    crank, rod, offset : float
        The nominal r, l, e (m).
    speed : float
        Crank speed ω (rad/s); default 5000 rpm, the embedded scene's.
    angle_step : float
        The analysis angles' step (degrees), a divisor of 360.
    quantities : sequence of str
        Subset of ``("displacement", "velocity", "acceleration")``.
    extremes, sectors : bool
        Append the cycle extremes, the sector extremes.
    points_per_sector : int
        Intervals of the fine grid per sector.

    Returns
    -------
    FunctionModel
        Vectorised, inputs ``("crank", "rod", "offset")`` in m.

    Examples
    --------
    >>> m = slider_crank_tolerance_model(quantities=["displacement"], angle_step=90.0)
    >>> y = m.evaluate(np.array([0.0501, 0.12, 0.0]))   # a 0.1 mm longer crank
    >>> round(float(y[0]), 9), list(m.output_index)[5]   # + 0.1 mm at θ = 0; the first extreme
    (0.0001, ('displacement', 'max'))
    """
    from .allowables import sector_label

    angles = tuple(float(a) for a in np.arange(0.0, 360.0 + 0.5 * angle_step, angle_step))
    fn = SliderCrankErrors(float(crank), float(rod), float(offset), float(speed), angles, tuple(quantities),
                           bool(extremes), bool(sectors), int(points_per_sector))
    labels = [(q, a) for q in fn.quantities for a in angles]
    if extremes:
        labels += [(q, s) for q in fn.quantities for s in ("max", "min", "max_abs")]
    if sectors:
        for q in fn.quantities:
            labels += [(q, sector_label("max", lo, hi)) for lo, hi in zip(angles[:-1], angles[1:])]
            labels += [(q, sector_label("min", lo, hi)) for lo, hi in zip(angles[:-1], angles[1:])]
    index = pd.MultiIndex.from_tuples(labels, names=["quantity", "crank_angle"])
    return FunctionModel(fn, ("crank", "rod", "offset"), index, vectorized=True,
                         key=f"slider-crank-tolerances:{fn}")
