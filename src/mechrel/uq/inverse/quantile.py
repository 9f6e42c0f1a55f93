""":func:`inverse_reliability`: the allowable for a target reliability, per quantity and for
the whole cycle, by a registered inverse method (:data:`mechrel.uq.inverse.INVERSE_METHODS`).

The allowable asked for is deterministic: a tolerance as it is written on a drawing. A
study's random allowable I ~ N(μ_I, σ_I²) models the uncertainty of the specification itself;
its σ_I is no part of this question and is not used (its mean μ_I is the reference s_q of the
whole cycle's common factor, :mod:`mechrel.uq.inverse.extremes`). A random allowable caps the
reliability at Φ(μ_I/σ_I) (a mechanism without error): 0.99865 for the paper's allowables
(σ_I = μ_I/3). The forward check of an allowable found here uses ``Allowable(a, 0)``
(:meth:`InverseResult.allowables`).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from mechrel.errors import StudyError

from ..._checks import ARGS
from ...outputs import QUANTITY_INFO
from .._common import CountedByProvenance, check_inputs, emit_warnings, make_provenance
from ..estimators._problem import concat_evaluations
from ..execution.executor import Evaluations
from ..problem.allowables import Allowable
from ..problem.inputs import seed_record
from ..problem.limit_state import LimitState
from ..problem.model import check_model
from .extremes import WHOLE_CYCLE, Extremes

__all__ = ["inverse_reliability", "InverseResult", "InverseEstimate", "FAILURE_MODES", "WIDE"]

FAILURE_MODES = ("exclude", "as_failure")
"""What a sample the model cannot evaluate counts as: left out (the answer is then conditional
on the model working), or a failure, an extreme beyond every allowable (conservative)."""

WIDE = 0.2
"""An interval wider than this fraction of its allowable, (hi − lo)/a > 0.2, is warned about:
the allowable is then not known to better than about ±10 %, too coarse to set a tolerance."""

TABLE_COLUMNS = ("allowable", "allowable_lo", "allowable_hi", "reference", "factor",
                 "factor_lo", "factor_hi", "unit", "basis")
"""The columns of :attr:`InverseResult.table` (and of ``inverse.csv``)."""


@dataclass(frozen=True)
class InverseEstimate:
    """What an inverse method returns to :func:`inverse_reliability` (the registry's contract,
    :mod:`mechrel.uq.inverse`).

    Parameters
    ----------
    quantiles : pandas.DataFrame
        Indexed by the scalars asked for: ``value`` (the target-quantile), ``lo`` and ``hi``
        (its interval at the confidence level; ±inf where the samples do not bound it, NaN for
        a method without one), in the scalar's unit.
    evaluations : tuple of Evaluations
        Every executor call of the method, in order (for provenance and failed samples).
    details : mapping, optional
        Named tables of the method's diagnostics (the subset levels, the FORM design points).
    notes : tuple of str, optional
        The method's caveats (e.g. a target its samples cannot resolve).
    settings : mapping, optional
        The method's settings, for provenance.

    Examples
    --------
    >>> q = pd.DataFrame({"value": [1.0], "lo": [0.9], "hi": [1.2]}, index=["all"])
    >>> float(InverseEstimate(q, ()).quantiles.loc["all", "hi"])
    1.2
    """

    quantiles: pd.DataFrame
    evaluations: tuple
    details: Mapping[str, pd.DataFrame] = field(default_factory=dict)
    notes: tuple[str, ...] = ()
    settings: Mapping[str, Any] = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class InverseResult(CountedByProvenance):
    """The allowables for a target reliability (frozen), made by :func:`inverse_reliability`.

    Parameters
    ----------
    table : pandas.DataFrame
        Indexed by (``group``, ``quantity``): one row per quantity (group = the quantity: its
        allowable with the others unconstrained) and, for a model with a quantity level, one
        row per quantity of the group ``"all"`` (the whole cycle: the common factor k on the
        reference allowables, a_q = k s_q). Columns :data:`TABLE_COLUMNS`: ``allowable``
        with ``allowable_lo``/``allowable_hi`` (the outputs' SI unit, ``unit``), ``reference``
        s_q, ``factor`` = allowable/reference with its interval, ``basis`` (``"cycle
        extreme"`` or ``"analysis angles"``).
    target : float
        The target reliability.
    event : {"two-sided", "one-sided"}
        The event.
    method : str
        The inverse method's key (``"auto"`` resolved).
    confidence_level : float
        Of the intervals.
    extremes : Extremes
        The scalars (to recompute them from ``evaluations.Y``).
    details : mapping
        The method's diagnostic tables (:class:`InverseEstimate`).
    evaluations : Evaluations or None
        Every model row of the method.
    provenance : dict
        How the result was made (target, method, settings, seed, model, counts, versions).
    warnings : tuple of str
        The caveats, each also issued as an :class:`~mechrel.errors.EstimateWarning`.

    Examples
    --------
    >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> r = inverse_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
    ...                         target=0.9, method="form", event="one-sided", allowable=1.0,
    ...                         progress=False)
    >>> round(float(r.table.loc[("all", "all"), "allowable"]), 6)     # Φ⁻¹(0.9)
    1.281552
    """

    table: pd.DataFrame
    target: float
    event: str
    method: str
    confidence_level: float
    extremes: Extremes
    details: Mapping[str, pd.DataFrame]
    evaluations: Evaluations | None
    provenance: dict = field(repr=False)
    warnings: tuple[str, ...] = ()

    def to_frame(self) -> pd.DataFrame:
        """The table of allowables (a copy of ``table``).

        Returns
        -------
        pandas.DataFrame
            Indexed by (group, quantity), columns :data:`TABLE_COLUMNS`.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> r = inverse_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
        ...                         target=0.9, method="form", event="one-sided",
        ...                         allowable=1.0, progress=False)
        >>> r.to_frame().columns[:3].tolist()
        ['allowable', 'allowable_lo', 'allowable_hi']
        """
        return self.table.copy()

    def allowables(self, group: str = WHOLE_CYCLE) -> dict[str, Allowable]:
        """The allowables found, as fixed allowables for a forward run.

        Parameters
        ----------
        group : str, default "all"
            ``"all"`` (every quantity at k s_q, the whole cycle) or one quantity.

        Returns
        -------
        dict
            ``{quantity: Allowable(a, 0)}``, for :func:`~mechrel.uq.monte_carlo`'s
            ``allowable=`` (which needs one for every quantity of the model: for one quantity
            of several, give the others one out of reach, or check with
            :meth:`limit_state`).

        Raises
        ------
        StudyError
            An unknown group, or an allowable found that is not > 0 (one-sided event whose
            error stays negative).

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> r = inverse_reliability(model=linear_model([0.0], [[1.0]], ["x"]), inputs=inputs,
        ...                         target=0.9, method="form", event="one-sided", allowable=1.0,
        ...                         progress=False)
        >>> round(r.allowables()["all"].mean, 6)
        1.281552
        """
        rows = self._rows(group)
        out = {}
        for q, a in rows["allowable"].items():
            if not a > 0:
                raise StudyError(f"allowables: the allowable of {q!r} found is {a!r}, not > 0 "
                                 "(the error stays below it with at least the target "
                                 "probability); allowed: a group whose allowable is > 0")
            out[str(q)] = Allowable(float(a), 0.0)
        return out

    def limit_state(self, group: str = WHOLE_CYCLE) -> LimitState:
        """The forward limit state at the allowables found (failure: an extreme beyond them).

        Parameters
        ----------
        group : str, default "all"
            ``"all"`` (the whole cycle, every quantity at k s_q) or one quantity.

        Returns
        -------
        LimitState
            For :func:`~mechrel.uq.subset_simulation`, :func:`~mechrel.uq.form`, ...: P_f
            there should be 1 − target within the estimates' intervals.

        Examples
        --------
        >>> from mechrel.uq import Normal, UncertainInputs, inverse_reliability, linear_model, form
        >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
        >>> model = linear_model([0.0], [[1.0]], ["x"])
        >>> r = inverse_reliability(model=model, inputs=inputs, target=0.9, method="form",
        ...                         event="one-sided", allowable=1.0, progress=False)
        >>> round(form(model=model, inputs=inputs, limit_state=r.limit_state()).pf, 6)
        0.1
        """
        rows = self._rows(group)
        return self.extremes.limit_state(
            {q: float(a) for q, a in rows["allowable"].items()},
            name="whole cycle" if group == WHOLE_CYCLE else group)

    def _rows(self, group: str) -> pd.Series:
        groups = self.table.index.get_level_values("group")
        if group not in set(groups):
            raise StudyError(f"group: got {group!r}; allowed: one of {list(dict.fromkeys(groups))}")
        return self.table.xs(group, level="group")


def _table(ex: Extremes, q: pd.DataFrame) -> pd.DataFrame:
    """The result table from the quantiles of the scalars (the whole cycle's from the only
    quantity's when there is one)."""
    rows, index = [], []

    def row(a, k, s, quantity, basis):
        """A row from the allowable (value, lo, hi) and the factor (value, lo, hi)."""
        unit = QUANTITY_INFO[quantity].unit if quantity in QUANTITY_INFO else ""
        return {"allowable": a[0], "allowable_lo": a[1], "allowable_hi": a[2], "reference": s,
                "factor": k[0], "factor_lo": k[1], "factor_hi": k[2], "unit": unit,
                "basis": basis}

    own = {}
    for g, s, b in zip(ex.groups, ex.reference, ex.basis):
        a = tuple(float(q.loc[g, c]) for c in ("value", "lo", "hi"))
        own[g] = a
        rows.append(row(a, tuple(v / s for v in a), s, g, b))
        index.append((g, g))
    if WHOLE_CYCLE in ex.names and WHOLE_CYCLE not in ex.groups:
        bases = set(ex.basis)
        basis = bases.pop() if len(bases) == 1 else "mixed"
        for g, s in zip(ex.groups, ex.reference):
            if WHOLE_CYCLE in q.index:
                k = tuple(float(q.loc[WHOLE_CYCLE, c]) for c in ("value", "lo", "hi"))
                a = tuple(v * s for v in k)
            else:  # one quantity: Z = Y_q/s_q, the quantity's own allowable
                a = own[g]
                k = tuple(v / s for v in a)
            rows.append(row(a, k, s, g, basis))
            index.append((WHOLE_CYCLE, g))
    table = pd.DataFrame(rows, index=pd.MultiIndex.from_tuples(index, names=["group", "quantity"]))
    return table[list(TABLE_COLUMNS)]


def _caveats(table: pd.DataFrame, method: str) -> list[str]:
    """The warnings every method shares: an interval wider than :data:`WIDE` of its
    allowable, an allowable that is not > 0."""
    notes = []
    per_group = table.groupby(level="group", sort=False).first()
    if len(per_group) == 2 and WHOLE_CYCLE in per_group.index:  # one quantity: "all" repeats it
        per_group = per_group.drop(WHOLE_CYCLE)
    width = (per_group["allowable_hi"] - per_group["allowable_lo"]) / per_group["allowable"].abs()
    wide = [f"{g} [{r['allowable_lo']:.4g}, {r['allowable_hi']:.4g}] around {r['allowable']:.4g}"
            for g, r in per_group.iterrows()
            if np.isfinite(width[g]) and width[g] > WIDE]
    if wide:
        notes.append(f"inverse ({method}): interval too wide, more than {WIDE:.0%} of the "
                     f"allowable: {'; '.join(wide)}; raise the sample count (the width falls "
                     "as 1/sqrt(n))")
    bad = [str(g) for g, r in per_group.iterrows() if not r["allowable"] > 0]
    if bad:
        notes.append(f"inverse ({method}): the allowable found for {', '.join(bad)} is not > 0: "
                     "the error stays below 0 with at least the target probability (one-sided "
                     "event), so every positive allowable meets the target")
    return notes


def inverse_reliability(
    *,
    model: Any,
    inputs: Any,
    target: float,
    event: str = "two-sided",
    allowable: Any = None,
    method: str = "auto",
    seed: Any = None,
    confidence_level: float = 0.95,
    failures: str = "exclude",
    max_failure_fraction: float = 0.1,
    n_jobs: int = 1,
    backend: str = "loky",
    cache: Any = None,
    progress: bool = True,
    chunk_size: int | None = None,
    **settings: Any,
) -> InverseResult:
    """The deterministic allowable a with whole-cycle reliability R = ``target``, per quantity
    and for the whole cycle, with its interval.

    Per quantity q, a_q is the ``target``-quantile of the cycle extreme Y_q (max |error| over
    the cycle for the two-sided event, max error for the one-sided one); for the whole cycle
    of several quantities, a common factor k on the reference allowables s_q (a_q = k s_q),
    the ``target``-quantile of max_q Y_q/s_q (:mod:`mechrel.uq.inverse.extremes`).

    Parameters
    ----------
    model : Model
        The model; its outputs' cycle extremes (``max_abs``/``max``) are used when it reports
        them, else the largest over its analysis angles.
    inputs : UncertainInputs
        The uncertain inputs.
    target : float
        The target reliability R_t, in (0, 1).
    event : {"two-sided", "one-sided"}, default "two-sided"
        |error| ≤ a, or error ≤ a (the paper's event on the signed error).
    allowable : None, Allowable, number or mapping, optional
        The reference allowables s_q of the whole cycle's factor (their means; None: the
        default allowables by quantity). Their std is not used: the allowable found is
        deterministic (module docstring).
    method : str, default "auto"
        A key of :data:`~mechrel.uq.inverse.INVERSE_METHODS`: ``"mc"`` (Monte Carlo order
        statistics), ``"subset"`` (subset simulation's levels), ``"form"`` (inverse FORM,
        PMA), or ``"auto"`` (:func:`~mechrel.uq.inverse.choose_method`: Monte Carlo when its
        ``n`` samples resolve the target, n (1 − R_t) ≥ 10, else subset simulation).
    seed : int >= 0, SeedSequence or None
        The seed (Monte Carlo draws its inputs from child 0, the design of
        :func:`~mechrel.uq.monte_carlo` with the same seed; subset simulation's level i from
        child i, its chains those of :func:`~mechrel.uq.subset_simulation`). FORM draws nothing.
    confidence_level : float in (0, 1), default 0.95
        Of the intervals.
    failures : {"exclude", "as_failure"}, default "exclude"
        A sample the model cannot evaluate is left out, or counts as beyond every allowable.
    max_failure_fraction : float in [0, 1], default 0.1
        Refuse (:class:`~mechrel.uq.SampleFailuresError`) above this fraction of failed samples.
    n_jobs, backend, cache, progress, chunk_size
        Passed to :func:`mechrel.uq.evaluate`.
    **settings
        The method's settings (``INVERSE_METHODS[key].settings``): Monte Carlo ``n`` (1000),
        ``rule`` (``"random"``) and ``evaluations`` (precomputed, e.g. a forward Monte Carlo
        run's ``.evaluations`` of the same seed); subset simulation's ``n_per_level``,
        ``p0``, ``proposal``, ``rho``, ``spread``, ``max_levels``; FORM's ``step``,
        ``scheme``, ``tol``, ``tol_direction``, ``max_iter``.

    Returns
    -------
    InverseResult
        ``.table`` (``.to_frame()``), ``.allowables(group)`` and ``.limit_state(group)`` for
        a forward check, ``.details``, ``.evaluations``, ``.provenance``, ``.warnings``.

    Raises
    ------
    StudyError
        A bad argument or setting (naming it, its value and what is allowed), a method that
        cannot answer (FORM not converging: :class:`~mechrel.uq.FORMConvergenceError`).
    SampleFailuresError
        More failed samples than ``max_failure_fraction`` allows.

    Examples
    --------
    The velocity error 0.01 x at its cycle extreme, x standard normal: a_q = 0.01 Φ⁻¹((1 +
    R_t)/2) (two-sided), 0.02576 m/s at R_t = 0.99; 4000 samples bound it within 3 %:

    >>> from mechrel.uq import FunctionModel, Normal, UncertainInputs, inverse_reliability
    >>> idx = pd.MultiIndex.from_tuples([("velocity", "max_abs")],
    ...                                 names=["quantity", "crank_angle"])
    >>> model = FunctionModel(lambda X: 0.01 * np.abs(X), ["x"], idx, vectorized=True)
    >>> inputs = UncertainInputs.from_specs({"x": Normal(0.0, 1.0)})
    >>> r = inverse_reliability(model=model, inputs=inputs, target=0.99, n=4000, seed=1,
    ...                         progress=False)
    >>> r.method, bool(r.to_frame().loc[("velocity", "velocity"), "allowable_lo"] < 0.02576)
    ('mc', True)
    """
    t0 = time.perf_counter()
    from . import INVERSE_METHODS, choose_method

    target = ARGS.fraction("target", target, open_lo=True, open_hi=True)
    confidence_level = ARGS.fraction("confidence_level", confidence_level, open_lo=True,
                                     open_hi=True)
    ARGS.choice("failures", failures, FAILURE_MODES)
    max_failure_fraction = ARGS.fraction("max_failure_fraction", max_failure_fraction)
    ARGS.choice("method", method, tuple(INVERSE_METHODS) + ("auto",))
    if model is None:
        raise StudyError("inverse_reliability: model = None: required; allowed: a mechrel.uq "
                         "Model (e.g. FunctionModel, MechanismModel)")
    names, index = check_model(model)
    inputs = check_inputs(inputs, names)
    extremes = Extremes.of(index, event=event, allowable=allowable)
    if method == "auto":
        n = settings.get("n", INVERSE_METHODS["mc"].settings["n"].default)
        ev = settings.get("evaluations")
        method = "mc" if ev is not None else choose_method(target, ARGS.sample_count("n", n))
    entry = INVERSE_METHODS[method]
    try:
        chosen = entry.validate(settings)
    except StudyError as exc:
        raise StudyError(f"inverse_reliability (method {method!r}): {exc}") from None
    scalars = extremes.groups if len(extremes.groups) == 1 else extremes.names
    est = entry.function(model=model, inputs=inputs, extremes=extremes, scalars=scalars,
                         target=target, seed=seed, confidence_level=confidence_level,
                         failures=failures, max_failure_fraction=max_failure_fraction,
                         executor={"n_jobs": n_jobs, "backend": backend, "cache": cache,
                                   "progress": progress, "chunk_size": chunk_size},
                         **chosen)
    table = _table(extremes, est.quantiles)
    warned = emit_warnings(list(est.notes) + _caveats(table, method), stacklevel=3)
    evaluations = concat_evaluations(list(est.evaluations))
    record = {k: v for k, v in est.settings.items() if k != "evaluations"}
    prov = make_provenance(
        method=f"inverse_reliability ({method})", seed=record.pop("seed", seed_record(seed)),
        evaluations=list(est.evaluations), wall_time=time.perf_counter() - t0,
        inputs=inputs,
        settings={"target": target, "event": event, "method": method,
                  "confidence_level": confidence_level, "failures": failures,
                  "max_failure_fraction": max_failure_fraction,
                  "reference": dict(zip(extremes.groups, extremes.reference)),
                  "allowable_std": "not used: the allowable found is deterministic", **record})
    return InverseResult(table, target, event, method, confidence_level, extremes,
                         dict(est.details), evaluations, prov, warned)

