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
