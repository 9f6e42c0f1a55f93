"""The reliability constraints of a design as numbers: each constraint's *factor* k.

For a constraint R ≥ R_t over the quantities Q (its ``quantity``, or every quantity for
``"all"``) with the deterministic allowables a_q, the sample's ratio is

* whole cycle: h = max_(q ∈ Q) Y_q / a_q, Y_q the cycle extreme (max |error| over the cycle,
  two-sided; max error, one-sided; :mod:`mechrel.uq.inverse.extremes`), so that the sample stays
  within every allowable over the whole cycle iff h ≤ 1;
* per angle: one ratio per analysis output of Q, |e_j| / a_q (two-sided) or e_j / a_q.

The factor k is the R_t-quantile of h (per angle: the largest of the outputs' R_t-quantiles),
and the constraint is k ≤ 1: the performance-measure form (PMA, Tu, Choi & Park 1999) of
P(h > 1) ≤ 1 − R_t, with the same feasible set, but continuous in the design where the count
P(h > 1) of a finite sample is a staircase; k is also the factor by which the allowables could
be tightened (k < 1) or must be loosened (k > 1) for the design to meet R_t exactly (§1's
inverse question, docs/uq.md).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from ..inverse.extremes import WHOLE_CYCLE, Extremes
from ..problem.allowables import output_groups, per_angle_mask
from .space import ReliabilityConstraint

__all__ = ["upper_quantile"]


def _cycle_column(index: pd.Index, group: str, stat: str) -> int | None:
    """The position of a quantity's cycle-extreme output ``stat`` (``"max"``, ``"min"``)."""
    if not (isinstance(index, pd.MultiIndex) and "crank_angle" in index.names
            and "quantity" in index.names):
        return None
    q = index.get_level_values("quantity").astype(str)
    a = index.get_level_values("crank_angle")
    hits = [i for i in range(len(index)) if q[i] == group and isinstance(a[i], str)
            and a[i] == stat]
    return hits[0] if hits else None


def upper_quantile(values: np.ndarray, reliability: float) -> float:
    """The empirical ``reliability``-quantile of samples (NaN rows left out), Y_(⌈n R⌉).

    The same order statistic as the inverse question's Monte Carlo estimate
    (:func:`mechrel.uq.inverse.order_statistics.quantile_interval`).

    Parameters
    ----------
    values : ndarray, shape (n,)
        Samples (+inf for a sample counted beyond every allowable; NaN left out).
    reliability : float
        In (0, 1).

    Returns
    -------
    float
        NaN when no sample is left.

    Examples
    --------
    >>> upper_quantile(np.arange(1.0, 1001.0), 0.99)
    990.0
    """
    v = np.asarray(values, dtype=float)
    v = v[~np.isnan(v)]
    n = v.size
    if n == 0:
        return math.nan
    k = min(max(math.ceil(n * reliability - 1e-9 * n), 1), n)
    return float(np.partition(v, k - 1)[k - 1])


class ConstraintScalars:
    """The ratios of each constraint from a model's outputs (module docstring).

    Parameters
    ----------
    output_index : pandas.Index
        The model's output labels.
    event : {"two-sided", "one-sided"}
        The event.
    allowables : mapping
        ``{quantity: a}``, the deterministic allowables (the outputs' units); a model without
        a quantity level has the one quantity ``"all"``.
    constraints : sequence of ReliabilityConstraint
        Checked (:func:`~mechrel.uq.design.space.as_constraints`).

    Raises
    ------
    StudyError
        A constraint on a quantity the model does not have, an allowable missing or not > 0.

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", 180.0),
    ...                                  ("velocity", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> cs = ConstraintScalars(idx, "two-sided", {"velocity": 0.5},
    ...                        [ReliabilityConstraint(0.99)])
    >>> cs.values(np.array([[0.1, -0.3, 0.4]]))[0].tolist()     # 0.4 / 0.5
    [[0.8]]
    """

    def __init__(self, output_index: pd.Index, event: str, allowables: Mapping[str, float],
                 constraints: Sequence[ReliabilityConstraint]):
        self.constraints = tuple(constraints)
        self.event = event
        gof = output_groups(output_index)
        groups = tuple(dict.fromkeys(gof.tolist()))
        for g in groups:
            a = allowables.get(g)
            if a is None:
                raise StudyError(f"allowable: no allowable for quantity {g!r}; allowed: "
                                 f"{{quantity: a}} for every quantity ({', '.join(groups)})")
            if isinstance(a, bool) or not isinstance(a, (int, float, np.floating)) or not a > 0:
                raise StudyError(f"allowable[{g}] = {a!r}: not a number > 0; allowed: a "
                                 "deterministic allowable > 0 (the outputs' unit)")
        self.allowables = {g: float(allowables[g]) for g in groups}
        self.extremes = Extremes.of(output_index, event=event, allowable=self.allowables)
        self.groups = groups
        angle = per_angle_mask(output_index)
        self.members: list[tuple[str, tuple[int, ...]]] = []
        for i, c in enumerate(self.constraints):
            if c.quantity == WHOLE_CYCLE:
                qs = groups
            elif c.quantity in groups:
                qs = (c.quantity,)
            else:
                raise StudyError(f"constraints[{i}].quantity = {c.quantity!r}: not a quantity "
                                 f"of the model; allowed: 'all' or one of {', '.join(groups)}")
            if c.basis == "whole-cycle":
                self.members.append(("whole-cycle", tuple(groups.index(q) for q in qs)))
            else:
                cols = tuple(int(j) for j in np.flatnonzero(angle & np.isin(gof, qs)))
                if not cols:
                    raise StudyError(f"constraints[{i}]: basis 'per-angle' but the model has no "
                                     f"analysis-angle outputs of {list(qs)}; allowed: basis "
                                     "'whole-cycle'")
                self.members.append(("per-angle", cols))
        self._col_scale = np.array([self.allowables[g] for g in gof], dtype=float)
        self._gof = gof
        # the learning units: per quantity its largest signed ratio, and for the two-sided
        # event also its largest negated one (max |e| = max(max e, −min e): the same event,
        # without the kink of |e| at e = 0 that a smooth surrogate cannot follow)
        units: list[str] = []
        unit_of: list[int] = []
        # per unit: the output columns, the sign (0: |e|'s own extreme) and the allowable
        self._unit_cols: list[tuple[tuple[int, ...], float, float]] = []
        for j, g in enumerate(groups):
            signs: tuple[float, ...] = (1.0, -1.0) if event == "two-sided" else (1.0,)
            if event == "two-sided" and None in (_cycle_column(output_index, g, "max"),
                                                 _cycle_column(output_index, g, "min")):
                col = _cycle_column(output_index, g, "max_abs")
                if col is not None:  # only |e|'s extreme: one unit, with its kink
                    self._unit_cols.append(((col,), 0.0, self.allowables[g]))
                    units.append(g)
                    unit_of.append(j)
                    continue
            for sign in signs:
                stat = "max" if sign > 0 else "min"
                col = _cycle_column(output_index, g, stat)
                cols = (col,) if col is not None else \
                    tuple(int(i) for i in np.flatnonzero((gof == g) & angle)) or \
                    tuple(int(i) for i in np.flatnonzero(gof == g))
                self._unit_cols.append((cols, sign, self.allowables[g]))
                units.append(g if event == "one-sided" else f"{g} {'+' if sign > 0 else '-'}")
                unit_of.append(j)
        self._units = tuple(units)
        unit_of_a = np.asarray(unit_of)
        self.unit_members: list[tuple[int, ...]] = [
            tuple(int(u) for u in np.flatnonzero(np.isin(unit_of_a, idx))) if kind == "whole-cycle"
            else () for kind, idx in self.members]

    @property
    def units(self) -> tuple[str, ...]:
        """The units a surrogate learns: per quantity its cycle's largest signed ratio
        max e/a_q (``"q +"``) and, for the two-sided event, −min e/a_q (``"q -"``); the
        whole-cycle ratio of the quantity is the larger of the two.

        Returns
        -------
        tuple of str
        """
        return self._units

    @property
    def per_angle(self) -> bool:
        """Whether a constraint holds per analysis angle."""
        return any(kind == "per-angle" for kind, _ in self.members)

    def unit_ratios(self, Y: np.ndarray) -> np.ndarray:
        """The ratio of each unit (:attr:`units`), shape (n, len(units)) (NaN rows stay NaN).

        Examples
        --------
        >>> cs = ConstraintScalars(pd.Index(["y"]), "two-sided", {"all": 2.0},
        ...                        [ReliabilityConstraint(0.9)])
        >>> cs.units, cs.unit_ratios(np.array([[-3.0]])).tolist()
        (('all +', 'all -'), [[-1.5, 1.5]])
        """
        Y = np.atleast_2d(np.asarray(Y, dtype=float))
        return np.column_stack([((sign * Y[:, list(cols)]) if sign else
                                 np.abs(Y[:, list(cols)])).max(axis=1) / a
                                for cols, sign, a in self._unit_cols])

    def values(self, Y: np.ndarray) -> list[np.ndarray]:
        """Per constraint the ratios, shape (n, 1) for the whole cycle and (n, outputs) per
        angle (NaN rows stay NaN)."""
        Y = np.atleast_2d(np.asarray(Y, dtype=float))
        H = self.unit_ratios(Y)
        out = []
        for (kind, idx), units in zip(self.members, self.unit_members):
            if kind == "whole-cycle":
                out.append(H[:, list(units)].max(axis=1)[:, None])
            else:
                sub = Y[:, list(idx)]
                sub = np.abs(sub) if self.event == "two-sided" else sub
                out.append(sub / self._col_scale[list(idx)])
        return out

    def factors(self, values: Sequence[np.ndarray], reliabilities: Sequence[float],
                failures: str = "exclude") -> np.ndarray:
        """Each constraint's factor k: the largest of its columns' R-quantiles.

        Parameters
        ----------
        values : list of ndarray
            From :meth:`values`.
        reliabilities : sequence of float
            The target of each constraint.
        failures : {"exclude", "as_failure"}
            NaN rows left out, or counted beyond every allowable (+inf).

        Returns
        -------
        ndarray, shape (n_constraints,)
        """
        out = []
        for V, r in zip(values, reliabilities):
            if failures == "as_failure":
                V = np.where(np.isnan(V), np.inf, V)
            out.append(max(upper_quantile(V[:, j], r) for j in range(V.shape[1])))
        return np.asarray(out)

    def governing(self, values: np.ndarray, reliability: float) -> int:
        """The column (per-angle output) whose R-quantile is the factor."""
        q = [upper_quantile(values[:, j], reliability) for j in range(values.shape[1])]
        return int(np.nanargmax(q))

    def labels(self) -> list[str]:
        """One label per constraint (:attr:`ReliabilityConstraint.label`)."""
        return [c.label for c in self.constraints]
