"""The shared shape of the per-output results: the per-angle and cycle-extreme views.

A mechanism model labels its outputs by ``(quantity, crank_angle)`` (docs/uq.md, "Outputs of
the mechanism model"): the analysis angles are floats (degrees), and the cycle extremes share
the ``crank_angle`` level as strings (``"max"``, ``"min"``, ``"max_abs"``, and with
``sectors=True`` the sector extremes ``"max[lo,hi]"``/``"min[lo,hi]"``). Every per-output
result (:class:`~mechrel.uq.estimators.fosm.FOSMResult`,
:class:`~mechrel.uq.estimators.monte_carlo.MonteCarloResult`,
:class:`~mechrel.uq.surrogates.pce.PCEResult`, :class:`~mechrel.uq.estimators.sobol.SobolResult`,
:class:`~mechrel.uq.estimators.normality.NormalityResult`) has the two views of
:class:`OutputViews`, and :func:`per_angle` / :func:`cycle_extremes` give them for any table
indexed by a model's outputs (a gradient, ``Evaluations.to_frame()``), so that no user needs
the labels' internals:

``per_angle()``
    The rows at the analysis angles, the ``crank_angle`` level as floats (ready to plot
    against the angle).
``cycle_extremes()``
    The rows of the cycle extremes, the level renamed ``statistic`` (its values are the
    statistics' labels).

The two views partition the table. They are not named ``whole_cycle``: a Monte Carlo result's
``whole_cycle`` is its table of the whole-cycle *events* (per quantity and for all quantities
jointly), which the cycle-extreme rows are not (a row per statistic and quantity, and FOSM's are
NaN where it gives no estimate).
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .problem.allowables import parse_sector, per_angle_mask

__all__ = ["OutputViews", "per_angle", "cycle_extremes"]


def _check(frame, what: str):
    if not isinstance(frame, (pd.DataFrame, pd.Series)):
        raise StudyError(f"{what}: got {type(frame).__name__}; allowed: a pandas DataFrame or "
                         "Series indexed by a model's outputs")
    return frame


def _angle_level(index: pd.Index) -> int | None:
    if isinstance(index, pd.MultiIndex) and "crank_angle" in index.names:
        return list(index.names).index("crank_angle")
    return None


def per_angle(frame):
    """The rows of ``frame`` at the analysis angles, the crank angles as floats.

    Parameters
    ----------
    frame : pandas.DataFrame or Series
        A table indexed by a model's outputs (a result's ``to_frame()``, a gradient, …).

    Returns
    -------
    pandas.DataFrame or Series
        A new table with the rows whose ``crank_angle`` label is an angle, in their order, the
        level as floats (degrees); ``frame`` unchanged (a copy) when its index has no
        ``crank_angle`` level.

    Raises
    ------
    StudyError
        If ``frame`` is not a DataFrame or Series.

    Examples
    --------
    >>> import pandas as pd
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0), ("velocity", 90), ("velocity", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> t = per_angle(pd.DataFrame({"mean": [0.1, 0.2, 0.3]}, index=idx))
    >>> t.index.tolist(), t.index.get_level_values("crank_angle").dtype
    ([('velocity', 0.0), ('velocity', 90.0)], dtype('float64'))
    """
    _check(frame, "per_angle")
    k = _angle_level(frame.index)
    if k is None:
        return frame.copy()
    out = frame.iloc[np.flatnonzero(per_angle_mask(frame.index))].copy()
    idx = out.index
    arrays = [idx.get_level_values(i) for i in range(idx.nlevels)]
    arrays[k] = pd.Index(np.asarray(arrays[k], dtype=float), name="crank_angle")
    out.index = pd.MultiIndex.from_arrays(arrays, names=idx.names)
    return out


def cycle_extremes(frame, *, sectors: bool = True):
    """The rows of ``frame`` at the cycle extremes, the ``crank_angle`` level renamed ``statistic``.

    Parameters
    ----------
    frame : pandas.DataFrame or Series
        A table indexed by a model's outputs (a result's ``to_frame()``, a gradient, …).
    sectors : bool, default True
        Keep the sector extremes (``"max[lo,hi]"``, ``"min[lo,hi]"``, the members of the whole
        cycle's series system); False keeps the whole cycle's statistics only (``"max"``,
        ``"min"``, ``"max_abs"``).

    Returns
    -------
    pandas.DataFrame or Series
        A new table with the rows whose ``crank_angle`` label is a statistic, in their order;
        empty when the index has no ``crank_angle`` level. With ``sectors=True`` it and
        :func:`per_angle` partition ``frame``.

    Raises
    ------
    StudyError
        If ``frame`` is not a DataFrame or Series.

    Examples
    --------
    >>> import pandas as pd
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", "max_abs"),
    ...                                  ("velocity", "max[0,18]")], names=["quantity", "crank_angle"])
    >>> s = pd.Series([0.1, 0.3, 0.2], index=idx)
    >>> cycle_extremes(s).index.tolist()
    [('velocity', 'max_abs'), ('velocity', 'max[0,18]')]
    >>> cycle_extremes(s, sectors=False).index.names
    FrozenList(['quantity', 'statistic'])
    """
    _check(frame, "cycle_extremes")
    k = _angle_level(frame.index)
    if k is None:
        return frame.iloc[:0].copy()
    keep = ~per_angle_mask(frame.index)
    if not sectors:
        labels = frame.index.get_level_values(k)
        keep &= np.array([parse_sector(a) is None for a in labels], dtype=bool)
    out = frame.iloc[np.flatnonzero(keep)].copy()
    out.index = out.index.set_names("statistic", level=k)
    return out


class OutputViews:
    """The per-angle and cycle-extreme views of a per-output result (a mixin).

    A result class that mixes it in has a ``to_frame()`` indexed by the model's outputs (for
    Sobol' indices, by the outputs and the input); the views select its rows by the
    ``crank_angle`` level (module docstring).

    Examples
    --------
    >>> import numpy as np
    >>> import pandas as pd
    >>> from mechrel.uq import Allowable, FunctionModel, Normal, UncertainInputs, monte_carlo
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 90.0), ("velocity", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> model = FunctionModel(lambda x: np.array([x[0], 2 * x[0], 2 * abs(x[0])]), ["x"], idx)
    >>> r = monte_carlo(model=model, inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
    ...                 n=64, seed=1, allowable=Allowable(1.0), progress=False)
    >>> isinstance(r, OutputViews), len(r.per_angle()), len(r.cycle_extremes())
    (True, 2, 1)
    """

    __slots__ = ()

    def per_angle(self):
        """The rows of ``to_frame()`` at the analysis angles, the crank angles as floats.

        Returns
        -------
        pandas.DataFrame
            :func:`per_angle` of ``to_frame()``.

        Examples
        --------
        >>> import numpy as np
        >>> import pandas as pd
        >>> from mechrel.uq import Allowable, FunctionModel, Normal, UncertainInputs, fosm
        >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 90.0),
        ...                                  ("velocity", "max_abs")], names=["quantity", "crank_angle"])
        >>> model = FunctionModel(lambda x: np.array([x[0], 2 * x[0], 2 * abs(x[0])]), ["x"], idx)
        >>> r = fosm(model=model, inputs=UncertainInputs.from_specs({"x": Normal(1.0, 0.1)}),
        ...          allowable=Allowable(3.0), progress=False)
        >>> r.per_angle().xs("velocity")["sigma_i"].round(12).tolist()   # |df/dx| σ
        [0.1, 0.2]
        """
        return per_angle(self.to_frame())  # type: ignore[attr-defined]

    def cycle_extremes(self, *, sectors: bool = True):
        """The rows of ``to_frame()`` at the cycle extremes (level ``statistic``).

        Parameters
        ----------
        sectors : bool, default True
            Keep the sector extremes (:func:`cycle_extremes`).

        Returns
        -------
        pandas.DataFrame
            :func:`cycle_extremes` of ``to_frame()``.

        Examples
        --------
        >>> import numpy as np
        >>> import pandas as pd
        >>> from mechrel.uq import Allowable, FunctionModel, Normal, UncertainInputs, monte_carlo
        >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", "max_abs")],
        ...                                 names=["quantity", "crank_angle"])
        >>> model = FunctionModel(lambda x: np.array([x[0], abs(x[0])]), ["x"], idx)
        >>> r = monte_carlo(model=model, inputs=UncertainInputs.from_specs({"x": Normal(0.0, 0.1)}),
        ...                 n=256, seed=1, allowable=Allowable(0.2), progress=False)
        >>> row = r.cycle_extremes().loc[("velocity", "max_abs")]
        >>> float(row["reliability"]) == float(r.whole_cycle.loc["velocity", "reliability"])
        True
        """
        return cycle_extremes(self.to_frame(), sectors=sectors)  # type: ignore[attr-defined]
