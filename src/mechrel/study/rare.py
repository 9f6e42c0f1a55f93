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
analysis angles). A run with rare-event methods builds the model with sector extremes
(:class:`~mechrel.uq.MechanismModel` ``sectors=True``), and each component is then written over
the sectors' largest and smallest errors: the same margin, whose members (quantity × sector ×
sign) are the failure modes FORM searches one by one (docs/uq.md, "The whole cycle as a series
system"). ``I_q`` is the study's allowable: ``Normal(mean, std)``, an extra
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
    study : mechrel.study.study.Study
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
    from ..uq.problem.allowables import parse_sector, whole_cycle_column

    event = study.reliability["event"]
    kind = "abs" if event == "two-sided" else "upper"
    index = model.output_index
    parts = []
    for q in study.quantities:
        mean, std = study.allowable[q]
        allowable = Normal(mean, std) if std > 0 else mean
        # the sectors' extremes, when the model reports them: the same margin (the cycle's
        # extreme is the largest sector's), with one member per sector and sign for FORM
        sectors = [lbl for lbl in index if lbl[0] == q and (sec := parse_sector(lbl[1])) is not None
                   and (kind == "abs" or sec[0] == "max")]
        if sectors:
            parts.append(LimitState.exceedance(sectors, allowable, kind=kind, name=q))
            continue
        col = whole_cycle_column(index, q, event)
        if col is None:
            raise StudyError(f"{study.source}: quantities = {q!r}: the model reports no cycle "
                             f"extreme of it; allowed: quantities with cycle extremes")
        parts.append(LimitState.exceedance([index[col]], allowable, kind=kind, name=q))
    return parts[0] if len(parts) == 1 else LimitState.series(*parts, name="whole cycle")


def estimate_one(ctx, method):
    """Run the rare-event ``method`` (a registry entry) on the study of ``ctx`` (a
    :class:`~mechrel.study.context.Context`): its settings from the study file's table
    (:meth:`~mechrel.study.context.Context.settings`), the whole-cycle limit state, and,
    for a method with a ``design_point`` setting, an earlier FORM result of this run (same
    model, inputs and limit state), else FORM run with the study's ``[form]`` settings (the
    FORM settings of the method's own table over them). The result goes to
    ``ctx.results[method.key]``; the warnings the estimator raised (a limit state never or
    always violated on the samples, a c.o.v. above its target, ...) to ``ctx.notes``, each
    prefixed with the method's key.

    Parameters
    ----------
    ctx : mechrel.study.context.Context
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
        elif "form" in rare_event_methods() and key != "form":
            settings["design_point"] = _design_points(ctx, method)
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


def _design_points(ctx, method):
    """FORM's design points for a method that starts from them (``design_point``) when the run
    has no FORM result: with the study's ``[form]`` settings, over which the FORM settings
    written in the method's own table (``[is]``, ``[sorm]``) take precedence."""
    from ..uq.estimators import METHODS

    form_method = rare_event_methods()["form"]
    given = dict(ctx.study.method_settings.get(form_method.key, {}))
    own = ctx.study.method_settings.get(method.key, {})
    given.update({k: v for k, v in own.items() if k in form_method.settings})
    try:
        settings = form_method.validate(given)
    except StudyError as exc:
        raise StudyError(f"{ctx.study.source}: [{form_method.key}] {exc}") from None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            fr = METHODS[form_method.name].function(
                model=ctx.model, inputs=ctx.inputs, limit_state=ctx.shared["limit_state"],
                seed=ctx.seed, **settings, **ctx.common)
        except StudyError as exc:
            if isinstance(exc, SampleFailuresError):
                raise
            raise StudyError(f"{ctx.study.source}: {method.key} ({method.name}): its design points "
                             f"(FORM with the study's [form] settings): {exc}") from exc
    for w in caught:
        text = f"{method.key}: {w.message}"
        if text not in ctx.notes:
            ctx.notes.append(text)
    return fr


def estimate(study, model, inputs, keys, *, seed, common, max_failure_fraction=None):
    """Run the rare-event methods ``keys`` (study-file names) in order, outside the runner
    (:func:`estimate_one` each, sharing one limit state and the FORM design point).

    Parameters
    ----------
    study : mechrel.study.study.Study
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
    from .context import Context

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
    """``design_point.csv``: per method with design points (FORM, and SORM and importance
    sampling through theirs), per design point (``point``, its failure mode in ``member``, its
    ``beta``) and input: ``u`` (standard normal), ``x`` (physical, SI: the inputs' own units; an
    allowable in its quantity's unit), ``alpha`` and ``importance`` (α², summing to 1 per point).

    Parameters
    ----------
    results : dict
        ``{key: result}`` from :func:`estimate`.

    Returns
    -------
    pandas.DataFrame or None
        Indexed by (method, point, input); None when no method has a design point.

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
        if fr is None:
            continue
        if fr.points is not None and fr.system == "series":
            pts = fr.points[["u", "x", "alpha", "importance"]].copy()
            dps = fr.design_points
            pts.insert(0, "beta", [float(dps.loc[k, "beta"]) for k, _i in pts.index])
            pts.insert(0, "member", [str(dps.loc[k, "member"]) for k, _i in pts.index])
        else:
            pts = pd.concat([fr.design_point[["u", "x", "alpha", "importance"]]], keys=[0],
                            names=["point", "input"])
            pts.insert(0, "beta", fr.beta)
            pts.insert(0, "member", "joint design point" if fr.system == "parallel"
                       else fr.to_frame().index[0])
        frames.append(pts)
        keys.append(key)
    if not frames:
        return None
    return pd.concat(frames, keys=keys, names=["method", "point", "input"])


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


MIN_FAILURES = 10
"""Monte Carlo is trusted for the whole cycle when it saw at least this many failures (below,
its interval spans a factor of about 2 or more: e.g. [0.5, 1.8]× at 10 failures)."""

TRUST_ORDER = ("monte_carlo", "sampling", "approximation")


def whole_cycle_estimates(results) -> pd.DataFrame:
    """Every estimate of the whole cycle's failure probability in a run, one row per method and
    group (a quantity, or ``"all"``: any quantity beyond its allowable).

    Monte Carlo gives every group (``whole_cycle``: 1 − reliability, with its binomial
    interval); a rare-event method gives ``"all"`` (its limit state is the series system of the
    quantities), FORM also each quantity (the union of its design points of that quantity).

    Parameters
    ----------
    results : dict
        ``{key: result}`` of a run (``ctx.results``).

    Returns
    -------
    pandas.DataFrame
        Columns ``method``, ``group``, ``pf``, ``pf_lo``, ``pf_hi`` (NaN without an interval),
        ``kind`` (``"monte_carlo"``, ``"sampling"``: an interval from its samples,
        ``"approximation"``: FORM, SORM), ``n_failures`` and ``n_samples`` (Monte Carlo; NaN
        otherwise) and ``n_warnings``.

    Examples
    --------
    >>> study, model = _demo()
    >>> results, _ = estimate(study, model, study.uncertain_inputs(), ["form"], seed=7,
    ...                       common={"n_jobs": 1, "cache": None, "progress": False})
    >>> whole_cycle_estimates(results)[["method", "group", "kind"]].values.tolist()
    [['form', 'all', 'approximation']]
    """
    from ..uq import FORMResult, MonteCarloResult
    from ..uq.estimators._problem import RareEventResult
    from ..uq.estimators._system import union_probability

    rows = []
    for key, r in results.items():
        nw = len(getattr(r, "warnings", ()))
        if isinstance(r, MonteCarloResult) and r.whole_cycle is not None:
            for g, row in r.whole_cycle.iterrows():
                n = float(row["n"])
                rows.append((key, str(g), 1.0 - float(row["reliability"]),
                             1.0 - float(row["reliability_hi"]), 1.0 - float(row["reliability_lo"]),
                             "monte_carlo", n - float(row["n_inside"]), n, nw))
        elif isinstance(r, RareEventResult) or getattr(r, "pf_table", None) is not None:
            # a rare-event result, or FOSM / Monte Carlo run on the limit state (pf_table)
            t = r.to_frame().iloc[0]
            lo, hi = float(t.get("pf_lo", np.nan)), float(t.get("pf_hi", np.nan))
            kind = "sampling" if np.isfinite(lo) and np.isfinite(hi) else "approximation"
            rows.append((key, "all", float(t["pf"]), lo, hi, kind, np.nan, np.nan, nw))
            if isinstance(r, FORMResult) and r.system == "series" and r.design_points is not None:
                comps = r.design_points["component"]
                if comps.nunique() > 1:
                    for q in pd.unique(comps):
                        idx = r.design_points.index[comps == q]
                        betas = r.design_points.loc[idx, "beta"].to_numpy(dtype=float)
                        alphas = np.array([r.points.loc[k]["alpha"].to_numpy() for k in idx])
                        pq = union_probability(betas, alphas)[0]
                        rows.append((key, str(q), pq, np.nan, np.nan, "approximation", np.nan,
                                     np.nan, nw))
    return pd.DataFrame(rows, columns=["method", "group", "pf", "pf_lo", "pf_hi", "kind",
                                       "n_failures",
                                       "n_samples", "n_warnings"])


def per_angle_worst(results, quantities) -> tuple[float, str] | None:
    """The largest single-angle failure probability any per-angle method gives (its lower
    bound where it has an interval), and where: the whole cycle contains every angle, so no
    whole-cycle P_f can be smaller.

    Parameters
    ----------
    results : dict
        ``{key: result}`` of a run.
    quantities : sequence of str
        The study's quantities.

    Returns
    -------
    (float, str) or None
        The probability and a description (``"fosm, velocity at 90°"``), or None without a
        per-angle estimate.

    Examples
    --------
    >>> per_angle_worst({}, ["velocity"]) is None
    True
    """
    from ..uq.problem.allowables import per_angle_mask

    best = None
    for key, r in results.items():
        t = getattr(r, "table", None)
        if not isinstance(t, pd.DataFrame) or "reliability" not in t.columns or len(t) < 2:
            continue
        if not isinstance(t.index, pd.MultiIndex) or "quantity" not in t.index.names:
            continue
        t = t[per_angle_mask(t.index)]
        t = t[t.index.get_level_values("quantity").isin(list(quantities))]
        lower = 1.0 - (t["reliability_hi"] if "reliability_hi" in t.columns else t["reliability"])
        lower = lower.dropna()
        if lower.empty:
            continue
        i = lower.idxmax()
        if best is None or lower[i] > best[0]:
            best = (float(lower[i]), f"{key}, {i[0]} at {float(i[1]):g}°")
    return best


def verdict_lines(est: pd.DataFrame, *, worst=None, names=None) -> list[str]:
    """The verdict on the whole cycle (``"all"``): which estimate to trust and why, whether the
    others agree with it (two intervals that do not overlap, an approximation outside the
    trusted interval), Monte Carlo with too few failures to be trusted, and a whole-cycle
    P_f below the largest single-angle P_f (impossible: a method that misses failure modes).

    Parameters
    ----------
    est : pandas.DataFrame
        :func:`whole_cycle_estimates`.
    worst : (float, str), optional
        :func:`per_angle_worst`.
    names : dict, optional
        Display names of the methods by key (default: the keys, as in the summary).

    Returns
    -------
    list of str
        The verdict's whole-cycle lines (indented for the summary).

    Examples
    --------
    >>> est = pd.DataFrame({"method": ["mc", "form"], "group": ["all", "all"], "pf": [0.02, 0.004],
    ...                     "pf_lo": [0.015, np.nan], "pf_hi": [0.026, np.nan],
    ...                     "kind": ["monte_carlo", "approximation"], "n_failures": [40.0, np.nan],
    ...                     "n_samples": [2000.0, np.nan], "n_warnings": [0, 0]})
    >>> for line in verdict_lines(est):
    ...     print(line[:71])
        whole cycle: trust mc (P_f = 0.02, interval [0.015, 0.026], 40 fail
        whole cycle: form gives 0.2× the trusted P_f, outside its interval:
    """
    names = names or {}
    a = est[est["group"] == "all"].reset_index(drop=True)
    if a.empty:
        return []

    def nm(k):
        return str(names.get(k, k))

    def interval(r):
        return f"[{r['pf_lo']:.3g}, {r['pf_hi']:.3g}]"

    weak = (a["kind"] == "monte_carlo") & (a["n_failures"] < MIN_FAILURES)
    rank = np.where((a["kind"] == "monte_carlo") & ~weak, 0,
                    np.where(a["kind"] == "sampling", np.where(a["n_warnings"] == 0, 1, 2), 9))
    order = np.argsort(rank, kind="stable")
    top = a.iloc[order[0]] if rank[order[0]] < 9 else None
    lines = []
    if top is None:
        parts = []
        if (a["kind"] == "approximation").any():
            parts.append(", ".join(nm(m) for m in a.loc[a["kind"] == "approximation", "method"])
                         + " carry no interval and see only the failure modes their searches reach")
        for _i, r in a[weak].iterrows():
            parts.append(f"{nm(r['method'])} saw {int(r['n_failures'])} failures in "
                         f"{int(r['n_samples'])} samples (fewer than {MIN_FAILURES}), interval "
                         f"{interval(r)}")
        lines.append("    whole cycle: no estimate to trust at this level: " + "; ".join(parts)
                     + "; run subset simulation (--method subset), or Monte Carlo with more "
                     "samples")
        ref = a[weak].iloc[0] if weak.any() else None
        for _i, r in a[a["kind"] == "approximation"].iterrows():
            if ref is not None:
                inside = ref["pf_lo"] <= r["pf"] <= ref["pf_hi"]
                lines.append(f"    whole cycle: {nm(r['method'])}'s P_f = {r['pf']:.3g} is "
                             f"{'inside' if inside else 'outside'} {nm(ref['method'])}'s "
                             f"interval {interval(ref)}"
                             + ("" if inside else ": one of them misses failure modes"))
    else:
        rel = (top["pf_hi"] - top["pf_lo"]) / top["pf"] if top["pf"] > 0 else np.inf
        if top["kind"] == "monte_carlo":
            why = (f"{int(top['n_failures'])} failures in {int(top['n_samples'])} samples: its "
                   "interval holds whatever the response")
        elif top["n_warnings"] == 0:
            why = "a sampling method, unbiased for the whole event, with no warning"
        else:
            why = "a sampling method, but see its warnings"
        lines.append(f"    whole cycle: trust {nm(top['method'])} (P_f = {top['pf']:.3g}, "
                     f"interval {interval(top)}, {why}; relative width {rel:.2f})")
        for _i, r in a.iterrows():
            if r["method"] == top["method"]:
                continue
            if r["kind"] == "monte_carlo" and r["n_failures"] < MIN_FAILURES:
                lines.append(f"    whole cycle: {nm(r['method'])} saw only {int(r['n_failures'])} "
                             f"failures in {int(r['n_samples'])} samples (fewer than "
                             f"{MIN_FAILURES}): its interval {interval(r)} is too wide to check "
                             "the others at this level")
                continue
            if np.isfinite(r["pf_lo"]) and np.isfinite(r["pf_hi"]):
                if r["pf_hi"] < top["pf_lo"] or r["pf_lo"] > top["pf_hi"]:
                    why_not = (" (see its warnings)" if r["n_warnings"] else
                               " (a sampler's interval is too narrow when it misses a failure "
                               "region)")
                    lines.append(f"    whole cycle: {nm(r['method'])} disagrees with "
                                 f"{nm(top['method'])}: their intervals {interval(r)} and "
                                 f"{interval(top)} do not overlap; trust {nm(top['method'])}"
                                 + why_not)
                else:
                    lines.append(f"    whole cycle: {nm(r['method'])} agrees (P_f = {r['pf']:.3g}, "
                                 f"interval {interval(r)})")
            elif top["pf_lo"] <= r["pf"] <= top["pf_hi"]:
                lines.append(f"    whole cycle: {nm(r['method'])} agrees (P_f = {r['pf']:.3g}, "
                             "inside the interval)")
            else:
                ratio = r["pf"] / top["pf"] if top["pf"] > 0 else np.inf
                lines.append(f"    whole cycle: {nm(r['method'])} gives {ratio:.2g}× the trusted "
                             "P_f, outside its interval: a first-order (FORM) or second-order "
                             "(SORM) system of the design points it found, whose error is the "
                             "modes' curvature or a mode it did not reach")
    if worst is not None:
        for _i, r in a.iterrows():
            upper = r["pf_hi"] if np.isfinite(r["pf_hi"]) else r["pf"]
            if upper < worst[0]:
                lines.append(f"    whole cycle: {nm(r['method'])}'s P_f ({r['pf']:.3g}) is below "
                             f"the largest single-angle P_f ({worst[0]:.3g}, {worst[1]}): "
                             "impossible, the cycle contains every angle; it misses failure "
                             "modes")
    return lines
