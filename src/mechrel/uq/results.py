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

The two views partition the table.

The tables speak one vocabulary: ``mean`` and ``std`` for the moments of an output (FOSM's
first-order ones, Monte Carlo's sample ones, PCE's from the coefficients), ``allowable_mean``
and ``allowable_std`` for the allowable I ~ N(mean, std²), and an interval as two columns
``<column>_lo`` / ``<column>_hi`` (``mean_lo``, ``reliability_hi``, ``pf_lo``). The names of
release 0.1 (:data:`DEPRECATED_COLUMNS`: FOSM's ``mu_i``/``sigma_i``, ``mu_I``/``sigma_I``,
``mu_g``/``sigma_g``) still read, with a :class:`FutureWarning` naming the new column, from a
result's table (:class:`ResultTable`) for one more release. They are not named ``whole_cycle``: a Monte Carlo result's
``whole_cycle`` is its table of the whole-cycle *events* (per quantity and for all quantities
jointly), which the cycle-extreme rows are not (a row per statistic and quantity, and FOSM's are
NaN where it gives no estimate).
"""

from __future__ import annotations

import warnings
from types import MappingProxyType

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from .problem.allowables import parse_sector, per_angle_mask

__all__ = ["OutputViews", "per_angle", "cycle_extremes", "ResultTable", "DEPRECATED_COLUMNS",
           "limit_state_value"]

#: The column names of release 0.1 that a result's table still reads for one more release
#: (with a :class:`FutureWarning`): old name → the new names it stands for, the first one the
#: table has (FOSM's ``mu_i`` is ``mean`` in its own table, ``fosm_mean`` in the normality
#: check's).
DEPRECATED_COLUMNS = MappingProxyType({
    "mu_i": ("mean", "fosm_mean"), "sigma_i": ("std", "fosm_std"),
    "mu_I": ("allowable_mean",), "sigma_I": ("allowable_std",),
    "mu_g": ("mean",), "sigma_g": ("std",),
})


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


def _demo(method: str):
    """A result of ``method`` ("fosm" or "monte_carlo") for the examples: a velocity error x,
    2x at 0° and 90° and its cycle extreme 2|x|, x ~ N(1, 0.1²), allowable 3 (fixed)."""
    from mechrel.uq import Allowable, FunctionModel, Normal, UncertainInputs, fosm, monte_carlo

    idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 90.0), ("velocity", "max_abs")],
                                    names=["quantity", "crank_angle"])
    model = FunctionModel(lambda x: np.array([x[0], 2 * x[0], 2 * abs(x[0])]), ["x"], idx)
    kw = {"model": model, "inputs": UncertainInputs.from_specs({"x": Normal(1.0, 0.1)}),
          "allowable": Allowable(3.0), "progress": False}
    return fosm(**kw) if method == "fosm" else monte_carlo(n=256, seed=1, **kw)


class OutputViews:
    """The per-angle and cycle-extreme views of a per-output result (a mixin).

    A result class that mixes it in has a ``to_frame()`` indexed by the model's outputs (for
    Sobol' indices, by the outputs and the input); the views select its rows by the
    ``crank_angle`` level (module docstring).

    Examples
    --------
    A made-up velocity error x, 2x at 0° and 90° and its cycle extreme 2|x| (``_demo``):

    >>> r = _demo("monte_carlo")
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
        >>> r = _demo("fosm")   # x ~ N(1, 0.1²): x and 2x at 0° and 90°, 2|x| over the cycle
        >>> r.per_angle().xs("velocity")["std"].round(12).tolist()   # |df/dx| σ
        [0.1, 0.2]
        """
        return per_angle(self._views_frame())

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
        For the two-sided event, Monte Carlo's ``max_abs`` row is the quantity's whole-cycle
        estimate:

        >>> r = _demo("monte_carlo")
        >>> row = r.cycle_extremes().loc[("velocity", "max_abs")]
        >>> float(row["reliability"]) == float(r.whole_cycle.loc["velocity", "reliability"])
        True
        """
        return cycle_extremes(self._views_frame(), sectors=sectors)

    def _views_frame(self):
        """``to_frame()``, or an error for a result run on a limit state (no per-output table)."""
        if getattr(self, "table", True) is None:
            raise StudyError(f"{type(self).__name__}: run with limit_state=, it has no per-output "
                             "table to view; its probability of failure is pf_table (and .pf)")
        return self.to_frame()  # type: ignore[attr-defined]


class ResultTable(pd.DataFrame):
    """A result's table: a :class:`pandas.DataFrame` that still reads the deprecated columns.

    ``table["mu_i"]``, ``table[["mu_i", "beta"]]``, ``table.loc[rows, "mu_i"]`` and
    ``table.mu_i`` return the renamed column (:data:`DEPRECATED_COLUMNS`) with a
    :class:`FutureWarning` that names it; everything else is a DataFrame's. Tables derived
    from it (copies, slices, ``to_frame()``) are ResultTables too; the old names are not
    columns (``"mu_i" in table`` is False, CSV files have the new names).

    Parameters
    ----------
    data, index, columns, dtype, copy
        As for :class:`pandas.DataFrame`.

    Examples
    --------
    >>> import warnings
    >>> t = ResultTable({"mean": [1.0], "std": [0.5]})
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     value = float(t["sigma_i"].iloc[0])
    >>> value, str(caught[0].message)
    (0.5, "column 'sigma_i' is renamed 'std'; the old name goes in the release after 0.1")
    """

    _metadata: list[str] = []

    @property
    def _constructor(self):
        return ResultTable

    def _renamed(self, name, stacklevel: int):
        if isinstance(name, str) and name in DEPRECATED_COLUMNS and name not in self.columns:
            for new in DEPRECATED_COLUMNS[name]:
                if new in self.columns:
                    warnings.warn(f"column {name!r} is renamed {new!r}; the old name goes in the "
                                  "release after 0.1", FutureWarning, stacklevel=stacklevel + 1)
                    return new
        return name

    def _columns_key(self, key, stacklevel: int):
        if isinstance(key, list):
            return [self._renamed(k, stacklevel + 1) for k in key]
        return self._renamed(key, stacklevel + 1)

    def __getitem__(self, key):
        return super().__getitem__(self._columns_key(key, 2))

    def __getattr__(self, name):
        if name in DEPRECATED_COLUMNS:
            new = self._renamed(name, 2)
            if new != name:
                return super().__getitem__(new)
        return super().__getattr__(name)

    @property
    def loc(self):
        """``.loc`` that reads a deprecated column name as its new one.

        Returns
        -------
        object
            An indexer like :attr:`pandas.DataFrame.loc`.

        Examples
        --------
        >>> import warnings
        >>> t = ResultTable({"mean": [1.0, 2.0]})
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore", FutureWarning)
        ...     t.loc[1, "mu_i"]
        np.float64(2.0)
        """
        return _Loc(self, super().loc)


class _Loc:
    """``ResultTable.loc``: the column part of a key read through the deprecated names."""

    __slots__ = ("_table", "_loc")

    def __init__(self, table: ResultTable, loc):
        self._table, self._loc = table, loc

    def _key(self, key):
        if isinstance(key, tuple) and len(key) == 2:
            return key[0], self._table._columns_key(key[1], 3)
        return key

    def __getitem__(self, key):
        return self._loc[self._key(key)]

    def __setitem__(self, key, value):
        self._loc[self._key(key)] = value

    def __call__(self, *args, **kwargs):
        return _Loc(self._table, self._loc(*args, **kwargs))

    def __getattr__(self, name):
        return getattr(self._loc, name)


def limit_state_value(result, column: str):
    """``result.pf_table[column]`` of a result run on a limit state, as a float.

    Parameters
    ----------
    result : FOSMResult or MonteCarloResult
        A result with a ``pf_table`` field.
    column : str
        ``"pf"``, ``"beta"``, ``"cov"``.

    Returns
    -------
    float
        The limit state's value.

    Raises
    ------
    StudyError
        If the result was run with ``allowable=`` (no limit state).

    Examples
    --------
    >>> from mechrel.uq import FunctionModel, LimitState, Normal, UncertainInputs, fosm
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> g = FunctionModel(lambda X: 2.0 - X[:, 0], ["x"], ["g"], vectorized=True)
    >>> r = fosm(model=g, inputs=inputs, limit_state=LimitState.margin(), progress=False)
    >>> round(limit_state_value(r, "beta"), 9)
    2.0
    """
    table = result.pf_table
    if table is None:
        raise StudyError(f"{type(result).__name__}.{column}: the result was run with allowable= (a "
                         f"reliability per output); {column} is a limit state's: allowed: "
                         "limit_state= (or the per-output table)")
    return float(table[column].iloc[0])
