"""The rare-event methods of a study (``mechrel reliability --method form|sorm|is|subset``).

Every registered method of kind ``"rare_event"`` (:data:`mechrel.uq.estimators.METHODS`) runs
the same way: on the study's model and inputs, for one limit state built from the study's
allowables, with the settings of its table in the study file (``[form]``, ``[subset]``, ...)
over the registry's defaults. Nothing here names a method: a new one is its module and its
registry entry.

The limit state is the whole cycle: failure when any of the study's quantities leaves its
allowable anywhere in the cycle, a series system of one component per quantity,
``g_q = I_q − max_cycle |error_q|`` (two-sided event; ``I_q − max_cycle error_q`` one-sided),
on the cycle extremes the model reports (found on the integrator's solution, not only at the
analysis angles). ``I_q`` is the study's allowable: ``Normal(mean, std)``, an extra
standard-normal coordinate of the search, or the fixed ``mean`` when ``std = 0``. This is the
event whose probability Monte Carlo's ``whole_cycle.csv`` row ``all`` reports (1 − reliability).
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd

from ..errors import StudyError
from ..uq._common import SampleFailuresError
from .study import rare_event_methods

TABLE_COLUMNS = ("pf", "beta", "cov", "pf_lo", "pf_hi", "n_evaluations", "wall_time")
"""The columns of ``rare_events.csv`` (NaN where a method does not estimate one: FORM and
SORM give no sampling c.o.v. or interval)."""


def _demo(allowable: float = 10.0):
    """The analytic study of the examples: a velocity cycle extreme 6 + x1 + x2 (m/s) of two
    standard-normal inputs against a fixed allowable, so that β = (allowable − 6)/√2
    exactly. Returns ``(study, model)``."""
    from ..uq import FunctionModel
    from .study import load_study

    labels = pd.MultiIndex.from_tuples(
        [("velocity", 0.0), ("velocity", "max_abs"), ("velocity", "max")],
        names=["quantity", "crank_angle"])

    def extremes(X):
        v = 6.0 + X[:, 0] + X[:, 1]
        return np.column_stack([v, v, v])

    model = FunctionModel(extremes, ["x1", "x2"], labels, key="rare-demo", vectorized=True)
    study = load_study({
        "scene": "nine-bar-lubricated", "quantities": ["velocity"],
        "inputs": {k: {"distribution": "normal", "mean": 0.0, "std": 1.0} for k in ("x1", "x2")},
        "allowable": {"velocity": {"mean": allowable, "std": 0.0}}, "reliability": {"seed": 7}})
    return study, model


def whole_cycle_limit_state(study, model):
    """The series system of the study's quantities at their cycle extremes (module docstring).

    Parameters
    ----------
    study : mechrel.studies.study.Study
        The study (its quantities, allowables and ``reliability.event``).
    model : mechrel.uq.Model
        The model; its outputs must include the cycle extremes of the study's quantities.

    Returns
    -------
    mechrel.uq.estimators.LimitState
        One component per quantity, or their series system.

    Raises
    ------
    mechrel.errors.StudyError
        The model reports no cycle extreme of a quantity.

    Examples
    --------
    >>> study, model = _demo()   # velocity extreme 6 + x1 + x2 against 10 m/s
    >>> whole_cycle_limit_state(study, model).name
    'velocity'
    """
    from ..uq import LimitState
    from ..uq.problem.inputs import Normal
    from ..uq.problem.allowables import whole_cycle_column

    event = study.reliability["event"]
    kind = "abs" if event == "two-sided" else "upper"
    parts = []
    for q in study.quantities:
        col = whole_cycle_column(model.output_index, q, event)
        if col is None:
            raise StudyError(f"{study.source}: quantities = {q!r}: the model reports no cycle "
                             f"extreme of it; allowed: quantities with cycle extremes")
        mean, std = study.allowable[q]
        allowable = Normal(mean, std) if std > 0 else mean
        parts.append(LimitState.exceedance([model.output_index[col]], allowable, kind=kind,
                                           name=q))
    return parts[0] if len(parts) == 1 else LimitState.series(*parts, name="whole cycle")


def estimate_one(ctx, method):
    """Run the rare-event ``method`` (a registry entry) on the study of ``ctx`` (a
    :class:`~mechrel.studies.presenters.Context`): its settings from the study file's table
    (:meth:`~mechrel.studies.presenters.Context.settings`), the whole-cycle limit state, and,
    for a method with a ``design_point`` setting, an earlier FORM result of this run (same
    model, inputs and limit state) instead of a new search. The result goes to
    ``ctx.results[method.key]``; the warnings the estimator raised (a limit state never or
    always violated on the samples, a c.o.v. above its target, ...) to ``ctx.notes``, each
    prefixed with the method's key.

    Parameters
    ----------
    ctx : mechrel.studies.presenters.Context
        The run: study, model, inputs, seed, the estimators' common arguments, the results
        so far (``ctx.results``) and the notes (``ctx.notes``).
    method : mechrel.uq.estimators.Method
        The registry entry of a method of kind ``"rare_event"``.

    Returns
    -------
    result
        The method's frozen result (also stored in ``ctx.results[method.key]``).

    Raises
    ------
    mechrel.errors.StudyError
        The method refuses its settings or arguments (the message names the method).

    Examples
    --------
    :func:`estimate` is this function on a fresh context; the whole-cycle FORM index of the
    linear demo study is exact:

    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> round(results["form"].beta, 6)
    2.828427
    """
    from ..uq import FORMResult

    key = method.key
    if "limit_state" not in ctx.shared:
        ctx.shared["limit_state"] = whole_cycle_limit_state(ctx.study, ctx.model)
    settings = ctx.settings(method)
    if "design_point" in settings and settings["design_point"] is None:
        found = [r for r in ctx.results.values() if isinstance(r, FORMResult)]
        if found:
            settings["design_point"] = found[0]
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            r = ctx.estimate(key, method.function, model=ctx.model, inputs=ctx.inputs,
                             limit_state=ctx.shared["limit_state"], seed=ctx.seed, **settings,
                             **ctx.common)
        except StudyError as exc:
            if isinstance(exc, SampleFailuresError):
                raise
            raise StudyError(f"{ctx.study.source}: {key} ({method.name}): {exc}") from exc
    for w in caught:  # those the result carries are in the summary through its .warnings
        text = f"{key}: {w.message}"
        if str(w.message) not in r.warnings and text not in ctx.notes:
            ctx.notes.append(text)
    if r.pf == 0.0 or r.pf == 1.0:
        ctx.notes.append(f"{key}: P_f = {r.pf:g}: the limit state is "
                         f"{'never' if r.pf == 0 else 'always'} violated on this method's "
                         "samples; tighten or loosen the allowables, or add samples")
    return r


def estimate(study, model, inputs, keys, *, seed, common, max_failure_fraction=None):
    """Run the rare-event methods ``keys`` (study-file names) in order, outside the runner
    (:func:`estimate_one` each, sharing one limit state and the FORM design point).

    Parameters
    ----------
    study : mechrel.studies.study.Study
        The study: allowables, quantities, the methods' settings tables.
    model : mechrel.uq.Model
        The model; its outputs must include the cycle extremes of the study's quantities.
    inputs : mechrel.uq.UncertainInputs
        The uncertain inputs (``study.uncertain_inputs()``).
    keys : sequence of str
        Study-file names of the methods (``"form"``, ``"sorm"``, ``"is"``, ``"subset"``).
    seed : int
        The study's seed.
    common : dict
        Arguments every estimator takes (``n_jobs``, ``backend``, ``cache``, ``progress``).
    max_failure_fraction : float, optional
        The command line's ``--max-failure-fraction``, over the study's.

    Returns
    -------
    results : dict
        ``{key: result}``.
    notes : list of str
        The warnings of the estimates (their ``.warnings`` and any other the estimators
        raised), each prefixed with the method.

    Raises
    ------
    mechrel.errors.StudyError
        A method's settings are invalid, or it refuses its arguments.

    Examples
    --------
    The margin 10 − 6 − x1 − x2 is linear in standard normal inputs: FORM is exact,
    β = 4/√2:

    >>> study, model = _demo()
    >>> results, notes = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                           common={"n_jobs": 1, "cache": None, "progress": False})
    >>> round(results["form"].beta, 6), notes
    (2.828427, [])
    """
    from .presenters import Context

    ctx = Context(study=study, model=model, inputs=inputs, allowables=study.allowables(),
                  event=study.reliability["event"], seed=seed, n=study.reliability["n"],
                  max_failure_fraction=(study.reliability["max_failure_fraction"]
                                        if max_failure_fraction is None
                                        else max_failure_fraction),
                  max_failure_fraction_given=max_failure_fraction is not None,
                  common=dict(common))
    methods = rare_event_methods()
    for key in keys:
        estimate_one(ctx, methods[key])
    carried = [f"{k}: {w}" for k, r in ctx.results.items() for w in r.warnings]
    return ctx.results, carried + ctx.notes


def table(results) -> pd.DataFrame:
    """``rare_events.csv``: one row per method (:data:`TABLE_COLUMNS`).

    Parameters
    ----------
    results : dict
        ``{key: result}`` from :func:`estimate`.

    Returns
    -------
    pandas.DataFrame
        Indexed by method key.

    Examples
    --------
    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> t = table(results)
    >>> round(float(t.loc["form", "pf"]), 6), bool(np.isnan(t.loc["form", "cov"]))   # Φ(−2√2)
    (0.002339, True)
    """
    rows = []
    for key, r in results.items():
        t = r.to_frame().iloc[0]
        row = {c: float(t[c]) if c in t.index else np.nan for c in TABLE_COLUMNS}
        row["n_evaluations"] = int(t["n_evaluations"])
        row["wall_time"] = float(r.provenance.get("wall_time", np.nan))
        rows.append(pd.Series(row, name=key))
    out = pd.DataFrame(rows)
    out.index.name = "method"
    return out


def _form_of(result):
    """The FORM result behind ``result`` (itself, or the one SORM/IS start from), or None."""
    from ..uq import FORMResult

    if isinstance(result, FORMResult):
        return result
    fr = getattr(result, "form", None)
    return fr if isinstance(fr, FORMResult) else None


def design_points(results) -> pd.DataFrame | None:
    """``design_point.csv``: per method with a design point (FORM, and SORM and importance
    sampling through theirs), per input: ``u`` (standard normal), ``x`` (physical, SI: the
    inputs' own units; an allowable in its quantity's unit), ``alpha`` and ``importance``
    (α², summing to 1).

    Parameters
    ----------
    results : dict
        ``{key: result}`` from :func:`estimate`.

    Returns
    -------
    pandas.DataFrame or None
        Indexed by (method, input); None when no method has a design point.

    Examples
    --------
    Both inputs count equally: the design point is x1 = x2 = 2, α² = ½ each:

    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> design_points(results).loc["form"].round(6)[["x", "importance"]].values.tolist()
    [[2.0, 0.5], [2.0, 0.5]]
    """
    frames, keys = [], []
    for key, r in results.items():
        fr = _form_of(r)
        if fr is not None:
            frames.append(fr.design_point[["u", "x", "alpha", "importance"]])
            keys.append(key)
    if not frames:
        return None
    return pd.concat(frames, keys=keys, names=["method", "input"])


def evaluation_counts(results, evaluations):
    """The one count of model evaluations of a run: per method, the rows its estimate rests on
    (:class:`~mechrel.uq.EvaluationCount`) and the method of this run whose rows it includes
    (SORM and importance sampling started from FORM's design point include FORM's search), and
    the run's count, each row counted once.

    Parameters
    ----------
    results : dict
        ``{key: result}``.
    evaluations : dict
        ``{key: Evaluations}`` of the methods (a refusing method has evaluations, no result).

    Returns
    -------
    per_method : dict
        ``{key: (EvaluationCount, key of the method whose rows it includes, or None)}``.
    total : EvaluationCount
        The run's.

    Examples
    --------
    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form", "sorm"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> per, total = evaluation_counts(results, {k: r.evaluations for k, r in results.items()})
    >>> per["sorm"][1], total.evaluations == per["sorm"][0].evaluations
    ('form', True)
    """
    from ..uq import EvaluationCount

    per, total = {}, EvaluationCount()
    for key, ev in evaluations.items():
        count, shared = ev.count, None
        result = results.get(key)
        fr = _form_of(result) if result is not None else None
        if fr is not None and fr is not result:
            shared = next((k for k, r in results.items() if r is fr and k in evaluations), None)
        per[key] = (count, shared)
        total += count - (evaluations[shared].count if shared else EvaluationCount())
    return per, total


def summary_lines(results) -> list[str]:
    """One line per method: P_f, β, the c.o.v. and interval where there is one, the cost, and
    for a design point its largest importance factors.

    Parameters
    ----------
    results : dict
        ``{key: result}`` from :func:`estimate`.

    Returns
    -------
    list of str
        The lines of the console summary.

    Examples
    --------
    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> summary_lines(results)[0][:51]
    '  form (form): whole-cycle P_f = 0.00234, β = 2.828'
    """
    lines = []
    t = table(results)
    per, _ = evaluation_counts(results, {k: r.evaluations for k, r in results.items()
                                         if r.evaluations is not None})
    for key, row in t.iterrows():
        name = rare_event_methods()[key].name
        text = (f"  {key} ({name}): whole-cycle P_f = {row['pf']:.3g}, β = {row['beta']:.3f}")
        if np.isfinite(row["cov"]):
            text += (f", c.o.v. {row['cov']:.2f}, interval [{row['pf_lo']:.3g}, "
                     f"{row['pf_hi']:.3g}]")
        if key in per:
            count, shared = per[key]
            text += f"; {count.text()}" + (f", {per[shared][0].evaluations} of them {shared}'s"
                                           if shared else "")
        else:
            text += f"; {int(row['n_evaluations'])} model evaluations"
        text += f", {row['wall_time']:.1f} s"
        fr = _form_of(results[key])
        if fr is not None and fr is results[key]:
            imp = fr.importance.sort_values(ascending=False)
            text += "; α² " + ", ".join(f"{k} {v:.2f}" for k, v in imp.iloc[:3].items())
        lines.append(text)
    return lines
