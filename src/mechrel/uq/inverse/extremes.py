"""The scalars of the inverse question: each quantity's cycle extreme and the whole cycle's
common factor.

For a quantity q the whole-cycle event with a deterministic allowable a is {Y_q ≤ a}, with
Y_q the cycle's largest |error| (two-sided event) or largest error (one-sided), read at the
model's cycle-extreme output (``max_abs`` or ``max``, found on the integrator's solution) or,
for a model without extremes, as the largest over the analysis angles. The allowable with
P(Y_q ≤ a) = R_t is the R_t-quantile of Y_q.

For several quantities the whole-cycle event is {Y_q ≤ a_q for every q}: a target reliability
fixes a surface in the space of the allowables (a_1, ..., a_m), not a point. mechrel answers
along the ray through the reference allowables s_q (the study's allowable means): a_q = k s_q,
one dimensionless factor k for all quantities, the R_t-quantile of

    Z = max_q Y_q / s_q,

so the whole specification, in the proportions it was written, can be scaled by k (k < 1: it
can be tightened; k > 1: it must be loosened) for the whole cycle to hold with probability
R_t. It is one number with one interval, it does not depend on the units, and every method of
the single-quantity answer applies to it unchanged. Each quantity's own answer (the others
unconstrained) is its marginal quantile; the whole-cycle allowable of each quantity is never
smaller, k s_q >= a_q, since Z >= Y_q/s_q in every sample.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from ..problem.allowables import (DEFAULT_ALLOWABLES, Allowable, check_event, output_groups,
                                  per_angle_mask, whole_cycle_column)
from ..problem.limit_state import LimitState

__all__ = ["Extremes", "WHOLE_CYCLE"]

#: The name of the whole cycle's common factor among the scalars (as Monte Carlo's
#: ``whole_cycle`` row of all quantities together).
WHOLE_CYCLE = "all"


def _reference(allowable: Any, group: str) -> float:
    """The reference allowable (its mean) of ``group`` from ``allowable=``, NaN when none."""
    if allowable is None:
        a = DEFAULT_ALLOWABLES.get(group)
    elif isinstance(allowable, Mapping):
        a = allowable.get(group)
    else:
        a = allowable
    if a is None:
        return float("nan")
    if isinstance(a, tuple) and len(a) == 2:
        a = Allowable(*a)
    if isinstance(a, Allowable):
        return a.mean
    if isinstance(a, (bool, np.bool_)) or not isinstance(a, (int, float, np.integer, np.floating)):
        raise StudyError(f"allowable[{group}] = {a!r}: not an allowable; allowed: an "
                         "Allowable(mean, std), a (mean, std) pair or a number > 0, alone or "
                         "in a mapping {quantity: ...}")
    return Allowable(float(a)).mean


@dataclass(frozen=True)
class Extremes:
    """The scalars whose quantiles answer the inverse question, from a model's outputs.

    Built by :meth:`of`. ``names`` are the quantities and, for a model with a ``quantity``
    level, ``"all"``: the whole cycle's common factor Z = max_q Y_q/s_q (module docstring).

    Parameters
    ----------
    output_index : pandas.Index
        The model's output labels.
    event : {"two-sided", "one-sided"}
        Y_q = max over the cycle of |error| (two-sided) or of the error (one-sided).
    groups : tuple of str
        The quantities (``("all",)`` for a model without a ``quantity`` level).
    positions : tuple of tuple of int
        Per quantity, the outputs whose largest value is Y_q.
    basis : tuple of str
        Per quantity, ``"cycle extreme"`` or ``"analysis angles"``.
    reference : tuple of float
        Per quantity, the reference allowable s_q (the mean of the allowable given; NaN
        where none was given and there is no default).

    Examples
    --------
    >>> idx = pd.MultiIndex.from_tuples([("velocity", 0.0), ("velocity", "max_abs"),
    ...                                  ("acceleration", 0.0), ("acceleration", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> e = Extremes.of(idx)
    >>> e.names, e.reference                  # the default allowables' means are the scale
    (('velocity', 'acceleration', 'all'), (0.3, 18.0))
    >>> e.values(np.array([[0.1, -0.15, 2.0, 3.6]])).tolist()   # Y_v, Y_a, max(Y_q/s_q)
    [[0.15, 3.6, 0.5]]
    """

    output_index: pd.Index
    event: str
    groups: tuple[str, ...]
    positions: tuple[tuple[int, ...], ...]
    basis: tuple[str, ...]
    reference: tuple[float, ...]

    @classmethod
    def of(cls, output_index: pd.Index, *, event: str = "two-sided",
           allowable: Any = None) -> Extremes:
        """The scalars of a model's outputs.

        Parameters
        ----------
        output_index : pandas.Index
            The model's output labels.
        event : {"two-sided", "one-sided"}, default "two-sided"
            The event whose allowable is asked for.
        allowable : None, Allowable, (mean, std), number or mapping, optional
            The reference allowables s_q (only their means count): None for the default
            allowables by quantity, one value for every quantity, or ``{quantity: value}``.
            Needed for the whole cycle of several quantities.

        Returns
        -------
        Extremes

        Raises
        ------
        StudyError
            A bad event or allowable, or no reference allowable for a quantity of a model
            with several.

        Examples
        --------
        >>> Extremes.of(pd.Index(["y"]), allowable=2.0).names   # no quantity level
        ('all',)
        """
        check_event(event)
        groups_of = output_groups(output_index)
        angle = per_angle_mask(output_index)
        groups = tuple(dict.fromkeys(groups_of.tolist()))
        positions: list[tuple[int, ...]] = []
        basis: list[str] = []
        for g in groups:
            col = whole_cycle_column(output_index, g, event)
            if col is not None:
                positions.append((col,))
                basis.append("cycle extreme")
            else:
                positions.append(tuple(np.flatnonzero((groups_of == g) & angle).tolist()))
                basis.append("analysis angles")
        reference = tuple(_reference(allowable, g) for g in groups)
        missing = [g for g, s in zip(groups, reference) if np.isnan(s)]
        if len(groups) > 1 and missing:
            raise StudyError(
                f"allowable: no reference allowable for quantity {missing}: the whole cycle's "
                "allowable scales the allowables of all quantities by one factor; allowed: "
                "allowable={quantity: Allowable(mean)} for every quantity of the model")
        return cls(output_index, event, groups, tuple(positions), tuple(basis), reference)

    @property
    def names(self) -> tuple[str, ...]:
        """The scalars: the quantities, then ``"all"`` for a model with a quantity level.

        Returns
        -------
        tuple of str
            The names, in the order of the columns of :meth:`values`.

        Examples
        --------
        >>> Extremes.of(pd.Index(["y"]), allowable=2.0).names
        ('all',)
        """
        if self.groups == (WHOLE_CYCLE,):
            return self.groups
        return self.groups + (WHOLE_CYCLE,)

    def values(self, Y: np.ndarray) -> np.ndarray:
        """The scalars of each row of outputs.

        Parameters
        ----------
        Y : ndarray, shape (n, n_out)
            Model outputs (NaN rows for failed samples stay NaN).

        Returns
        -------
        ndarray, shape (n, len(names))
            Y_q per quantity (the outputs' unit), then Z = max_q Y_q/s_q (dimensionless).

        Examples
        --------
        >>> e = Extremes.of(pd.Index(["a", "b"]), event="one-sided", allowable=1.0)
        >>> e.values(np.array([[0.5, -2.0]])).tolist()   # the largest signed error
        [[0.5]]
        """
        Y = np.atleast_2d(np.asarray(Y, dtype=float))
        cols = []
        for pos in self.positions:
            sub = Y[:, list(pos)]
            cols.append((np.abs(sub) if self.event == "two-sided" else sub).max(axis=1))
        V = np.column_stack(cols)
        if len(self.names) > len(self.groups):
            V = np.column_stack([V, (V / np.asarray(self.reference)).max(axis=1)])
        return V

    def labels(self, group: str) -> list:
        """The output labels of a quantity's extreme (its cycle-extreme output, or its angles).

        Parameters
        ----------
        group : str
            A quantity (one of ``groups``).

        Returns
        -------
        list
            Output labels of ``output_index``.

        Examples
        --------
        >>> Extremes.of(pd.Index(["a", "b"]), allowable=1.0).labels("all")
        ['a', 'b']
        """
        return [self.output_index[i] for i in self.positions[self.groups.index(group)]]

    def limit_state(self, allowables: Mapping[str, float], *, name: str = "whole cycle"
                    ) -> LimitState:
        """The forward event at fixed allowables: failure when a quantity's extreme exceeds its
        allowable (a series system of the quantities given).

        One quantity: g = a − Y_q (its unit). Several: each component in units of its
        reference allowable, g_q = (a_q − Y_q)/s_q, so that the system's margin
        g = min_q g_q = k − Z at a_q = k s_q orders the samples as Z does (subset simulation
        on it then walks the chains of the inverse run with the same seed).

        Parameters
        ----------
        allowables : mapping
            ``{quantity: a}`` (the outputs' units) for some or all of ``groups``.
        name : str, default "whole cycle"
            The name of a system of several quantities (one quantity keeps its own).

        Returns
        -------
        LimitState
            Failure g ≤ 0.

        Examples
        --------
        >>> ls = Extremes.of(pd.Index(["y"]), allowable=1.0).limit_state({"all": 0.5})
        >>> ls.bind(pd.Index(["y"]))(np.array([[-0.75]])).tolist()
        [-0.25]
        """
        kind = "abs" if self.event == "two-sided" else "upper"
        if len(allowables) == 1:
            (q, a), = allowables.items()
            return LimitState.exceedance(self.labels(q), float(a), kind=kind, name=q)
        parts = []
        for q, a in allowables.items():
            i = self.groups.index(q)
            func = functools.partial(_normalised_margin, self.positions[i], self.event,
                                     float(a), self.reference[i])
            parts.append(LimitState.from_function(func, name=q))
        return LimitState.series(*parts, name=name)


def _normalised_margin(positions: tuple, event: str, a: float, s: float, Y: np.ndarray
                       ) -> np.ndarray:
    """(a − Y_q)/s: a quantity's margin in units of its reference allowable."""
    sub = Y[:, list(positions)]
    y = (np.abs(sub) if event == "two-sided" else sub).max(axis=1)
    return (a - y) / s
