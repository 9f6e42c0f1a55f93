"""Runners behind ``mechrel reliability`` and ``mechrel sensitivity``: evaluate a study with
the estimators of :mod:`mechrel.uq`, write tables and figures, return a printable summary."""

from __future__ import annotations

import functools
import os
import tempfile
import time
from pathlib import Path

import pandas as pd

from ..errors import OutputError, StudyError
from ..io import save_figure, write_json, write_table
from ..io.lock import hold_folder
from ..outputs import QUANTITY_INFO
from .._checks import ARGS
from ..uq._common import SampleFailuresError, failure_message
from .study import METHODS, RARE_EVENT_METHODS

UNITS = {name: q.unit for name, q in QUANTITY_INFO.items()}  # SI, from the output kinds
# What a finished run writes beside its summary; a refused run removes an earlier run's.
RELIABILITY_RESULTS = ("reliability.csv", "whole_cycle.csv", "reliability.png",
                       "rare_events.csv", "design_point.csv")
SENSITIVITY_RESULTS = ("sensitivity.csv", "sensitivity.png")


def _output_folder(out, names=()):
    """``out`` as a created, writable folder (None: no output), in which none of the files
    ``names`` is a folder; checked before anything runs."""
    if not out:
        return None
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise StudyError(f"out = {str(out)!r}: an existing file, not a folder; allowed: a "
                         "folder (created if missing)")
    for name in names:
        if (out / name).is_dir():
            raise OutputError(f"out = {str(out)!r}: {name} is a folder, where this run writes "
                              f"a file; allowed: a folder without a folder named {name} "
                              "(remove or rename it)")
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd, probe = tempfile.mkstemp(prefix=".mechrel-probe-", dir=out)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        raise OutputError(f"out = {str(out)!r}: cannot create the folder or a file in it "
                          f"({exc.strerror}); allowed: a writable folder (created if "
                          "missing)") from None
    return out


def _holds_output_folder(names):
    """Decorator: ``run(study, out=..., ...)`` with ``out`` checked (a writable folder in which
    none of the files ``names`` that the run writes is a folder, before anything runs) and
    locked for the whole run (:func:`mechrel.io.lock.hold_folder`): a second run on the same
    folder is refused at once instead of evaluating everything again."""
    def decorate(run):
        @functools.wraps(run)
        def wrapper(study, *, out=None, **kwargs):
            folder = _output_folder(out, names)
            if folder is None:
                return run(study, out=None, **kwargs)
            with hold_folder(folder):
                return run(study, out=folder, **kwargs)
        return wrapper
    return decorate


def _remove_stale(out, names) -> None:
    """Remove earlier runs' result files ``names`` from ``out``, so that no table or figure
    of another run is left beside this run's summary."""
    for name in names:
        try:
            (out / name).unlink(missing_ok=True)
        except OSError as exc:
            raise OutputError(f"out = {str(out)!r}: cannot remove the earlier run's {name} "
                              f"({exc.strerror}); allowed: a writable folder") from None


def _check_run(*, n, seed, n_jobs, backend, max_failure_fraction, model, inputs, rows_per_n):
    """Every argument of a run, checked before anything is evaluated (a wrong seed must not
    be found only after the first estimator has run): ``n`` (>= 2, and within the memory its
    ``rows_per_n * n`` model runs need), ``seed``, ``n_jobs``, ``backend`` and
    ``max_failure_fraction``."""
    from ..uq._common import check_memory
    from ..uq.execution.executor import _check_backend
    from ..uq.problem.inputs import as_seed_sequence
    from ..uq.problem.model import check_model

    ARGS.sample_count("n", n)
    as_seed_sequence(seed)
    _check_backend(backend, n_jobs)
    ARGS.fraction("max_failure_fraction", max_failure_fraction)
    if rows_per_n:
        names, index = check_model(model)
        check_memory(rows_per_n * n, len(names) + len(index), "n", n)


def _estimate(method, evaluations, estimator, **kwargs):
    """``estimator(**kwargs)``; records the evaluations it analysed, or refused to analyse
    (:class:`~mechrel.uq.SampleFailuresError`), as ``evaluations[method]``."""
    try:
        result = estimator(**kwargs)
    except SampleFailuresError as exc:
        evaluations[method] = exc.evaluations
        raise
    evaluations[method] = result.evaluations
    return result


def _failure_counts(evaluations) -> dict:
    return {m: {"n_samples": ev.n, "n_failed": ev.n_failed, "reasons": ev.failure_counts()}
            for m, ev in evaluations.items()}


def _failure_lines(evaluations, path) -> list[str]:
    """Per method with failed samples: the counts by reason (inputs and reasons in ``path``)."""
    lines = [f"  failed samples ({m}, left out of its estimate): {failure_message(ev)}"
             for m, ev in evaluations.items() if ev.n_failed]
    if lines and path is not None:
        lines.append(f"  inputs and reason of every failed sample: {path}")
    return lines


def _write_failures(evaluations, path) -> None:
    """One row per failed sample: ``method``, ``sample`` (row of its design), the inputs and
    the ``reason``. Written even when empty, so that no earlier run's file is left behind."""
    frames = [ev.failures().reset_index() for ev in evaluations.values()]
    table = pd.concat(frames, keys=list(evaluations), names=["method", None])
    write_table(table.reset_index(level="method"), path)


def _refusal(exc, evaluations, out, files, record, section, stale=()):
    """The error for an estimator's refusal (a :class:`SampleFailuresError`), after writing
    ``files`` = (failures table, summary) to ``out`` and removing an earlier run's results
    ``stale`` from it: the failed samples are never lost, and no earlier run's table or figure
    is left beside the refusal."""
    method = next(reversed(evaluations))  # the refusing estimator recorded its evaluations last
    msg = str(exc).rstrip(".")
    if out:
        _remove_stale(out, stale)
        _write_failures(evaluations, out / files[0])
        write_json({**record, "refused": {"method": method, "error": str(exc)},
                    "failures": _failure_counts(evaluations)}, out / files[1])
        msg += (f". Wrote {out}/{files[0]} (inputs and reason of each failed sample) and "
                f"{files[1]}")
    return SampleFailuresError(
        f"{msg}. To proceed, fix what makes the samples fail, or raise the threshold knowingly "
        "(an estimate over the successful samples only is biased when failures depend on the "
        f"inputs): --max-failure-fraction F, or max_failure_fraction under [{section}] in the "
        "study file", exc.evaluations)


def _angles(table):
    """The rows of a per-output table at the analysis angles (without the cycle extremes),
    with the crank angles as floats."""
    from ..uq.problem.allowables import per_angle_mask
    t = table[per_angle_mask(table.index)].copy()
    names = list(t.index.names)
    k = names.index("crank_angle")
    t.index = pd.MultiIndex.from_tuples(
        [tuple(float(v) if i == k else v for i, v in enumerate(lbl)) for lbl in t.index],
        names=names)
    return t


def _agg() -> None:
    """Draw without a display (before pyplot is imported; keeps a backend already chosen)."""
    import matplotlib
    matplotlib.use("Agg", force=False)


def _save(fig, path) -> None:
    import matplotlib.pyplot as plt

    save_figure(fig, path, dpi=130)  # atomically: temporary file, then rename
    plt.close(fig)


def _warm_up(model, progress) -> None:
    """On a cold kernel cache, compile here, announced and with a bar of the elapsed time,
    before the workers start (they then load the kernels instead of each compiling them
    behind a progress bar standing at 0)."""
    from .._kernel_cache import warm_up

    warm_up(model.scene, progress=progress)


def _warnings_of(results) -> list[str]:
    """Every estimate's warnings, once each, in the order of the estimates."""
    out = []
    for r in results.values():
        for w in getattr(r, "warnings", ()):
            if w not in out and not any(w.startswith(o) for o in out):
                out.append(w)
    return out


def _verdict(results, quantities, model) -> list[str]:
    """Which estimate to trust for each quantity, and why (the summary's last lines)."""
    from ..uq.surrogates.pce import LOO_THRESHOLD

    lines = ["  verdict:"]
    fosm, mc, pce = results.get("fosm"), results.get("mc"), results.get("pce")
    nc = results.get("normality")
    nonsmooth = getattr(model, "nonsmooth", None)
    for q in quantities:
        why = []
        if mc is not None:
            level = f"{mc.confidence_level:.0%}"
            n_ok = mc.evaluations.n_ok
            if fosm is not None and nc is not None:
                t = _angles(nc.table).xs(q, level="quantity")
                m = _angles(mc.table).xs(q, level="quantity")
                r_out = int(((t["R_fosm"] < t["R_mc_lo"]) | (t["R_fosm"] > t["R_mc_hi"])).sum())
                mu_out = int(((t["mu_i"] < m["mean_lo"]) | (t["mu_i"] > m["mean_hi"])).sum())
                if nonsmooth:
                    why.append(f"FOSM is not applicable ({nonsmooth})")
                elif r_out or mu_out:
                    why.append(f"FOSM's R is outside MC's {level} interval at {r_out} and its "
                               f"mean at {mu_out} of {len(t)} angles")
                else:
                    why.append(f"FOSM agrees (its R and mean inside MC's {level} interval at "
                               "every angle), so FOSM's 2d + 1 runs suffice for this design")
            if pce is not None:
                loo = pce.loo_error.xs(q, level="quantity") if pce.loo_error is not None else None
                worst = float(loo.max()) if loo is not None and loo.notna().any() else float("nan")
                if not worst <= LOO_THRESHOLD:
                    why.append(f"PCE is not (leave-one-out error {worst:.3g} > "
                               f"{LOO_THRESHOLD:g})")
                else:
                    why.append(f"PCE fits (leave-one-out error ≤ {worst:.3g})")
            m = mc.table.xs(q, level="quantity")
            width = float((m["reliability_hi"] - m["reliability_lo"]).max())
            if width > 0.1:
                why.append(f"MC's intervals are up to {width:.2f} wide: raise n to narrow them "
                           "(the width falls as 1/sqrt(n))")
            lines.append(f"    {q}: trust Monte Carlo ({n_ok} successful samples, {level} "
                         "intervals that hold whatever the error's distribution)"
                         + ("; " + "; ".join(why) if why else ""))
        elif pce is not None:
            loo = pce.loo_error.xs(q, level="quantity") if pce.loo_error is not None else None
            worst = float(loo.max()) if loo is not None and loo.notna().any() else float("nan")
            if worst <= LOO_THRESHOLD:
                lines.append(f"    {q}: the PCE surrogate (leave-one-out error ≤ {worst:.3g}); "
                             "not checked against Monte Carlo")
            else:
                lines.append(f"    {q}: no estimate to trust: the PCE's leave-one-out error is "
                             f"{worst:.3g} > {LOO_THRESHOLD:g} and there is no Monte Carlo run")
        elif fosm is not None:
            lines.append(f"    {q}: FOSM only, unchecked (no Monte Carlo run): "
                         + (f"not applicable ({nonsmooth}); run Monte Carlo" if nonsmooth else
                            "a first-order, normal model of the error; run --method mc to "
                            "check it"))
    rare = [k for k in results if k in RARE_EVENT_METHODS]
    if rare:
        who = ", ".join(rare) + (" and Monte Carlo" if mc else "")
        verb = "estimates" if who == rare[0] else "estimate"
        lines.append(f"    whole cycle: {who} {verb} it (FOSM and PCE give per-angle "
                     "reliabilities); FORM and SORM are approximations, the sampling methods "
                     "carry an interval")
    elif mc is not None:
        lines.append("    whole cycle: only Monte Carlo estimates it (FOSM and PCE give "
                     "per-angle reliabilities)")
    return lines


@_holds_output_folder(RELIABILITY_RESULTS + ("failures.csv", "summary.json",
                                            "evaluations.sqlite"))
def run_reliability(study, *, methods=None, n=None, n_jobs=1, seed=None, out=None,
                    progress=True, cache=True, backend="loky", max_failure_fraction=None):
    """Run the study's reliability methods and write their results to ``out``.

    Parameters
    ----------
    study : Study
        From :func:`~mechrel.studies.study.load_study`.
    methods : sequence of {"fosm", "mc", "pce", "form", "sorm", "is", "subset", "all"}, optional
        Default: the study's ``reliability.methods``; ``"all"``: every method. The rare-event
        methods (:data:`~mechrel.studies.study.RARE_EVENT_METHODS`, settings from the study's
        ``[form]``, ``[sorm]``, ``[is]``, ``[subset]``) estimate the whole-cycle failure
        probability (:mod:`mechrel.studies.rare`).
    n, seed, max_failure_fraction : optional
        Monte Carlo samples, seed, and the largest fraction of failed samples Monte Carlo and
        PCE accept; default: the study's.
    n_jobs, backend, progress
        Passed to :func:`mechrel.uq.evaluate`.
    out : path, optional
        Folder for ``reliability.csv``, ``whole_cycle.csv``, ``reliability.png``,
        ``failures.csv`` (every failed sample: method, inputs, reason) and ``summary.json``;
        with a rare-event method ``rare_events.csv`` (one row per method) and, with a design
        point, ``design_point.csv``.
    cache : bool
        Cache the model evaluations in ``out/evaluations.sqlite``.

    Returns
    -------
    lines : list of str
        The printable summary.
    results : dict
        The estimators' results by method.

    Raises
    ------
    SampleFailuresError
        An estimator refused because of failed samples; ``failures.csv`` and ``summary.json``
        (with the counts and the reason) are written first.
    """
    from ..uq import fosm, monte_carlo, polynomial_chaos

    start = time.perf_counter()
    cfg = study.reliability
    methods = tuple(methods or cfg["methods"])
    for m in methods:
        ARGS.choice("methods", m, METHODS + ("all",))
    if "all" in methods:
        methods = METHODS
    n = cfg["n"] if n is None else n
    seed = cfg["seed"] if seed is None else seed
    max_failure_fraction = (cfg["max_failure_fraction"] if max_failure_fraction is None
                            else max_failure_fraction)
    form, rule = cfg["form"], cfg["rule"]
    model = study.model()
    inputs = study.uncertain_inputs()
    _check_run(n=n, seed=seed, n_jobs=n_jobs, backend=backend,
               max_failure_fraction=max_failure_fraction, model=model, inputs=inputs,
               rows_per_n=1 if "mc" in methods else 0)
    allow = study.allowables()
    _warm_up(model, progress)
    cache_path = (out / "evaluations.sqlite") if (out and cache) else None
    common = dict(n_jobs=n_jobs, backend=backend, cache=cache_path, progress=progress)
    record = {"study": study.name, "source": study.source, "methods": list(methods), "n": n,
              "seed": seed, "form": form, "max_failure_fraction": max_failure_fraction}
    results, evaluations, frames = {}, {}, []
    lines = [f"study {study.name}: scene {model.scene.name}, inputs {', '.join(inputs.names)}; "
             f"form {form}"]
    try:
        if "fosm" in methods:
            r = _estimate("fosm", evaluations, fosm, model=model, inputs=inputs,
                          allowable=allow, form=form, **common)
            results["fosm"] = r
            frames.append(r.to_frame().add_prefix("fosm."))
        if "mc" in methods:
            r = _estimate("mc", evaluations, monte_carlo, model=model, inputs=inputs, n=n,
                          rule=rule, seed=seed, allowable=allow, form=form,
                          max_failure_fraction=max_failure_fraction, **common)
            results["mc"] = r
            frames.append(r.to_frame().add_prefix("mc."))
        if "pce" in methods:
            r = _estimate("pce", evaluations, polynomial_chaos, model=model, inputs=inputs,
                          order=cfg["pce_order"], seed=seed,
                          max_failure_fraction=max_failure_fraction, **common)
            results["pce"] = r
            frames.append(r.to_frame().add_prefix("pce."))
            surrogate = _estimate("pce_surrogate", evaluations, r.reliability, n=2**17,
                                  rule="sobol", seed=seed, allowable=allow, form=form)
            results["pce_reliability"] = surrogate
            frames.append(surrogate.to_frame()[["reliability", "reliability_lo",
                                                "reliability_hi"]].add_prefix("pce_surrogate."))
        rare_keys = [m for m in methods if m in RARE_EVENT_METHODS]
        rare_notes = []
        if rare_keys:
            from . import rare
            rare_results, rare_notes = rare.estimate(
                study, model, inputs, rare_keys, seed=seed, common=common,
                max_failure_fraction=max_failure_fraction, evaluations=evaluations)
            results.update(rare_results)
    except SampleFailuresError as exc:
        record.update(wall_time=time.perf_counter() - start, summary=lines,
                      provenance={k: dict(v.provenance) for k, v in results.items()})
        raise _refusal(exc, evaluations, out, ("failures.csv", "summary.json"), record,
                       "reliability", RELIABILITY_RESULTS) from None
    if "fosm" in results and "mc" in results:
        from ..uq import normality_check
        results["normality"] = normality_check(fosm=results["fosm"], monte_carlo=results["mc"])
        frames.append(results["normality"].to_frame().add_prefix("normality."))
    table = pd.concat(frames, axis=1) if frames else None
    if "pce" in results:
        loo = results["pce"].loo_error
        if loo is not None:
            lines.append(f"  PCE order {results['pce'].order} ({results['pce'].evaluations.n} "
                         f"training runs): leave-one-out error median {float(loo.median()):.3g}, "
                         f"max {float(loo.max()):.3g} (relative to each output's variance)")
    if "normality" in results:
        nt = _angles(results["normality"].to_frame())
        flag = [c for c in nt.columns if "flag" in c]
        if flag:
            lines.append(f"  normality check: FOSM's normal assumption flagged at "
                         f"{int(nt[flag[0]].sum())} of {len(nt)} (quantity, angle) points")
    for q in study.quantities:
        parts = []
        if "fosm" in results:
            t = _angles(results["fosm"].table).xs(q, level="quantity")
            k = t["reliability"].idxmin()
            # the index of the R printed: Φ⁻¹(R) of the study's form (the table's ``beta`` is
            # the paper's one-sided index, which is not Φ⁻¹ of a two-sided R)
            parts.append(f"FOSM min R {t['reliability'].min():.4f} at {k:g}° "
                         f"(β = Φ⁻¹(R) = {t['beta_generalized'].loc[k]:.3f}, {form})")
        if "pce_reliability" in results:
            t = _angles(results["pce_reliability"].table).xs(q, level="quantity")
            parts.append(f"PCE min R {t['reliability'].min():.4f} at "
                         f"{t['reliability'].idxmin():g}°")
        if "mc" in results:
            t = _angles(results["mc"].table).xs(q, level="quantity")
            k = t["reliability"].idxmin()
            parts.append(f"MC min R {t['reliability'].min():.4f} "
                         f"[{t['reliability_lo'].loc[k]:.4f}, {t['reliability_hi'].loc[k]:.4f}]"
                         f" at {k:g}°")
        if parts:  # a run with rare-event methods only has no per-angle estimate
            width = max(len(name) for name in study.quantities) + 1
            lines.append(f"  {q + ':':{width}s} " + "; ".join(parts))
    if "mc" in results:
        mc = results["mc"]
        wc = mc.whole_cycle
        for key, row in wc.iterrows():
            lines.append(f"  whole-cycle reliability ({key}): {row['reliability']:.4f} "
                         f"[{row['reliability_lo']:.4f}, {row['reliability_hi']:.4f}] "
                         f"(from the {row['basis']})")
        lines.append(f"  Monte Carlo: {mc.evaluations.n} samples ({rule}), {mc.n_failed} failed")
    if rare_keys:
        lines.append("  whole cycle, any quantity beyond its allowable (rare-event methods):")
        lines += rare.summary_lines({k: results[k] for k in rare_keys})
    lines += _failure_lines(evaluations, out / "failures.csv" if out else None)
    wall = time.perf_counter() - start
    n_calls = sum(ev.n_model_calls for ev in evaluations.values())
    lines.append(f"  {n_calls} model evaluations in {wall:.1f} s (n_jobs = {n_jobs})")
    notes = _warnings_of(results) + rare_notes
    lines += [f"  warning: {w}" for w in notes]
    verdict = _verdict(results, study.quantities, model)
    if out:
        written = ["failures.csv", "summary.json"]
        if table is not None:
            write_table(table.reset_index(), out / "reliability.csv")
            written[:0] = ["reliability.csv", "reliability.png"]
        else:  # rare-event methods only: no per-angle table; none of an earlier run's either
            _remove_stale(out, ["reliability.csv", "reliability.png"])
        if "mc" in results:
            write_table(results["mc"].whole_cycle.reset_index(), out / "whole_cycle.csv")
            written.insert(1, "whole_cycle.csv")
        else:
            _remove_stale(out, ["whole_cycle.csv"])
        if not rare_keys:
            _remove_stale(out, ["rare_events.csv", "design_point.csv"])
        else:
            write_table(rare.table({k: results[k] for k in rare_keys}).reset_index(),
                        out / "rare_events.csv")
            written.insert(-2, "rare_events.csv")
            dp = rare.design_points({k: results[k] for k in rare_keys})
            if dp is not None:
                write_table(dp.reset_index(), out / "design_point.csv")
                written.insert(-2, "design_point.csv")
        if table is not None:
            from ..uq.plots import plot_reliability
            _agg()

            _save(plot_reliability(*(results[k] for k in ("fosm", "mc", "pce_reliability")
                                     if k in results),
                                   title=f"{study.name}: reliability per crank angle ({form})"),
                  out / "reliability.png")
        _write_failures(evaluations, out / "failures.csv")
        write_json({**record, "wall_time": wall, "failures": _failure_counts(evaluations),
                    "provenance": {k: dict(v.provenance) for k, v in results.items()},
                    "warnings": notes, "verdict": [v.strip() for v in verdict[1:]],
                    "summary": lines}, out / "summary.json")
        lines.append(f"  wrote {out}/{', '.join(written)}")
    lines += verdict  # the summary ends with it
    return lines, results


@_holds_output_folder(SENSITIVITY_RESULTS + ("sensitivity_failures.csv", "sensitivity.json",
                                            "evaluations.sqlite"))
def run_sensitivity(study, *, n=None, n_jobs=1, seed=None, out=None, progress=True,
                    cache=True, backend="loky", max_failure_fraction=None):
    """Sobol indices (SALib) of the peak |error| over the cycle per quantity with respect to
    the study's inputs.

    The parameters are those of :func:`run_reliability`, except that ``n`` counts Saltelli base
    samples, ``max_failure_fraction`` is the largest fraction of Saltelli blocks with a failed
    sample that may be dropped, the defaults are the study's ``[sensitivity]``, and ``out``
    receives ``sensitivity.csv`` (ranked), ``sensitivity.png``, ``sensitivity_failures.csv``
    and ``sensitivity.json``.

    Returns
    -------
    lines : list of str
        The printable summary.
    result : SobolResult

    Raises
    ------
    SampleFailuresError
        Too many Saltelli blocks failed; ``sensitivity_failures.csv`` and
        ``sensitivity.json`` (with the counts and the reason) are written first.
    """
    from ..uq import peak_abs, sobol_indices

    start = time.perf_counter()
    cfg = study.sensitivity
    n = cfg["n"] if n is None else n
    seed = cfg["seed"] if seed is None else seed
    max_failure_fraction = (cfg["max_failure_fraction"] if max_failure_fraction is None
                            else max_failure_fraction)
    model = study.model()
    inputs = study.uncertain_inputs()
    _check_run(n=n, seed=seed, n_jobs=n_jobs, backend=backend,
               max_failure_fraction=max_failure_fraction, model=model, inputs=inputs,
               rows_per_n=inputs.d + 2)
    _warm_up(model, progress)
    record = {"study": study.name, "source": study.source, "n": n, "seed": seed,
              "max_failure_fraction": max_failure_fraction}
    evaluations = {}
    try:
        res = _estimate("sobol", evaluations, sobol_indices, model=model, inputs=inputs, n=n,
                        seed=seed, reducer=peak_abs, max_failure_fraction=max_failure_fraction,
                        n_jobs=n_jobs, backend=backend, progress=progress,
                        cache=(out / "evaluations.sqlite") if (out and cache) else None)
    except SampleFailuresError as exc:
        record["wall_time"] = time.perf_counter() - start
        raise _refusal(exc, evaluations, out, ("sensitivity_failures.csv", "sensitivity.json"),
                       record, "sensitivity", SENSITIVITY_RESULTS) from None
    table = res.to_frame().reset_index()
    table = table.sort_values([table.columns[0], "ST"], ascending=[True, False])
    lines = [f"study {study.name}: Sobol indices of the peak |error| over the cycle "
             f"(N = {n}, {res.evaluations.n} model runs, "
             f"{res.n_blocks_dropped} Saltelli blocks dropped for failures)"]
    for out_name, grp in table.groupby(table.columns[0], sort=False):
        ranked = ", ".join(f"{r[table.columns[1]]} ST={r['ST']:.3f}±{r['ST_conf']:.3f} "
                           f"S1={r['S1']:.3f}" for _, r in grp.iterrows())
        lines.append(f"  {out_name}: {ranked}")
    lines += _failure_lines(evaluations, out / "sensitivity_failures.csv" if out else None)
    lines += [f"  warning: {w}" for w in res.warnings]
    wall = time.perf_counter() - start
    lines.append(f"  wall time {wall:.1f} s (n_jobs = {n_jobs})")
    if out:
        write_table(table, out / "sensitivity.csv")
        from ..uq.plots import plot_sobol
        _agg()

        _save(plot_sobol(res, title=f"{study.name}: what drives the error"),
              out / "sensitivity.png")
        _write_failures(evaluations, out / "sensitivity_failures.csv")
        write_json({**record, "wall_time": wall, "failures": _failure_counts(evaluations),
                    "provenance": dict(res.provenance), "warnings": list(res.warnings),
                    "summary": lines}, out / "sensitivity.json")
        lines.append(f"  wrote {out}/sensitivity.csv, sensitivity.png, "
                     "sensitivity_failures.csv, sensitivity.json")
    return lines, res
