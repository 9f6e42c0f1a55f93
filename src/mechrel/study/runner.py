"""Runners behind ``mechrel reliability`` and ``mechrel sensitivity``: evaluate a study with
the estimators of :mod:`mechrel.uq`, write tables and figures, return a printable summary."""

from __future__ import annotations

import functools
import time

import pandas as pd

from ..io import write_json, write_table
from ..io.lock import hold_folder
from ..io.results import check_folder, removed_if_left_empty, result_set
from ..outputs import QUANTITY_INFO
from .._checks import ARGS
from ..uq._common import SampleFailuresError, failure_message

UNITS = {name: q.unit for name, q in QUANTITY_INFO.items()}  # SI, from the output kinds
# What a finished run writes beside its summary. A run's files are one set (io.results): a
# refused or a later run leaves none of an earlier run's beside its own.
RELIABILITY_FILES = ("reliability.csv", "reliability.png")
"""The per-angle table and figure of ``mechrel reliability`` (the methods' presenters add
their own files, :func:`reliability_results`)."""
SENSITIVITY_RESULTS = ("sensitivity.csv", "sensitivity.png")


def reliability_results() -> tuple[str, ...]:
    """Every result file a reliability run may write beside its summary.

    The per-angle table and figure, and the files of every registered method's presenter (a run
    removes those it does not write, so that no earlier run's file is left beside its summary).

    Returns
    -------
    tuple of str
        The file names.

    Examples
    --------
    >>> {"reliability.csv", "whole_cycle.csv", "rare_events.csv"} <= set(reliability_results())
    True
    """
    from .presenters import COMBINED, files_of
    from .study import study_methods

    combined = tuple(f for cls in COMBINED for f in cls.files)
    return RELIABILITY_FILES + files_of(study_methods().values()) + combined


def _holds_output_folder(names):
    """Decorator: ``run(study, out=..., ...)`` with ``out`` checked (a writable folder in which
    none of the files ``names`` that the run writes is a folder, before anything runs; a
    callable ``names`` is asked at each run, for the methods registered by then) and
    locked for the whole run (:func:`mechrel.io.lock.hold_folder`): a second run on the same
    folder is refused at once instead of evaluating everything again. A folder this run
    created is removed again if the run leaves nothing in it (an argument refused after the
    folder was made)."""
    def decorate(run):
        @functools.wraps(run)
        def wrapper(study, *, out=None, **kwargs):
            with removed_if_left_empty(out):
                folder = check_folder(out, names() if callable(names) else names)
                if folder is None:
                    return run(study, out=None, **kwargs)
                with hold_folder(folder):
                    return run(study, out=folder, **kwargs)
        return wrapper
    return decorate


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


def _refusal(exc, evaluations, out, files, record, section, known=()):
    """The error for an estimator's refusal (a :class:`SampleFailuresError`), after writing
    ``files`` = (failures table, summary) to ``out`` as the run's set of results
    (:func:`mechrel.io.results.result_set`, the set named ``section``, as a finished run's;
    ``known``: the other files of the set): the failed samples are never lost, and no earlier
    run's table or figure is left beside the refusal."""
    method = next(reversed(evaluations))  # the refusing estimator recorded its evaluations last
    msg = str(exc).rstrip(".")
    if out:
        with result_set(out, section, known=known) as stage:
            _write_failures(evaluations, stage / files[0])
            write_json({**record, "refused": {"method": method, "error": str(exc)},
                        "failures": _failure_counts(evaluations)}, stage / files[1],
                       relative_to=out)
        msg += (f". Wrote {out}/{files[0]} (inputs and reason of each failed sample) and "
                f"{files[1]}")
    return SampleFailuresError(
        f"{msg}. To proceed, fix what makes the samples fail, or raise the threshold knowingly "
        "(an estimate over the successful samples only is biased when failures depend on the "
        f"inputs): --max-failure-fraction F, or max_failure_fraction under [{section}] in the "
        "study file", exc.evaluations)


def warm_up(model, *, progress: bool = True) -> float:
    """Compile the simulation kernels a model needs, once, before its samples run.

    On a cold kernel cache (after installing or changing mechrel) this compiles them in this
    process, announced on stderr with the expected time and a bar of the elapsed time, so that
    worker processes load them from numba's on-disk cache instead of each compiling them behind
    a progress bar standing at 0. On a warm cache it returns at once. The numbers of later runs
    do not depend on it. ``mechrel reliability`` and ``mechrel sensitivity`` call it; a study
    script does so before its first estimator.

    Parameters
    ----------
    model : MechanismModel
        The model whose scene (:attr:`~mechrel.uq.problem.mechanism.MechanismModel.scene`)
        decides which kernels are needed.
    progress : bool, optional
        Announce a compilation and show its bar (default True).

    Returns
    -------
    float
        The seconds spent compiling (0.0 on a warm cache).

    Examples
    --------
    >>> from mechrel.uq import MechanismModel
    >>> model = MechanismModel("slider-crank", {"crank": ["bodies.crank.length(O,A)"]},
    ...                        angle_step=90.0)
    >>> seconds = warm_up(model, progress=False)   # compiles here if the cache is cold
    >>> warm_up(model, progress=False)             # then nothing is left to compile
    0.0
    """
    from ..warmup import warm_up as compile_kernels

    return compile_kernels(model.scene, progress=progress)


def _verdict(ctx, by_rank) -> list[str]:
    """Which estimate to trust for each quantity, and why (the summary's last lines): the
    verdict of the most trusted presenter that gives one (``by_rank``: least to most
    trusted), with what the others say about that estimate; then the whole cycle's line."""
    lines = ["  verdict:"]
    for q in ctx.study.quantities:
        for top in reversed(by_rank):
            reasons = [r for p in by_rank if p is not top
                       for r in [p.verdict_reason(ctx, q)] if r]
            line = top.verdict(ctx, q, reasons)
            if line:
                lines.append(line)
                break
    for p in ctx.presenters:
        w = p.whole_cycle_verdict(ctx)
        lines += [w] if isinstance(w, str) else list(w or [])
    return lines


@_holds_output_folder(lambda: reliability_results()
                      + ("failures.csv", "summary.json", "evaluations.sqlite"))
def run_reliability(study, *, methods=None, n=None, n_jobs=1, seed=None, out=None,
                    progress=True, cache=True, backend="loky", max_failure_fraction=None,
                    target_reliability=None):
    """Run the study's reliability methods and write their results to ``out``.

    The methods are those of the registry (:data:`mechrel.uq.estimators.METHODS`), each run
    and presented by its :class:`~mechrel.study.presenters.Presenter`; nothing here names a
    method.

    Parameters
    ----------
    study : Study
        From :func:`~mechrel.study.study.load_study`.
    methods : sequence of str, optional
        Study-file names of registered methods (:func:`~mechrel.study.study.study_methods`:
        ``"fosm"``, ``"mc"``, ``"pce"``, ``"form"``, ``"sorm"``, ``"is"``, ``"subset"``, ...)
        or ``"all"`` (every one). Default: the study's ``reliability.methods``. The rare-event
        methods (settings from the study's ``[form]``, ``[sorm]``, ``[is]``, ``[subset]``)
        estimate the whole-cycle failure probability (:mod:`mechrel.study.rare`).
    n, seed, max_failure_fraction : optional
        Monte Carlo samples, seed, and the largest fraction of failed samples the sampling
        methods accept; default: the study's.
    n_jobs, backend, progress
        Passed to :func:`mechrel.uq.evaluate`.
    out : path, optional
        Folder for ``reliability.csv`` and ``reliability.png`` (the per-angle methods),
        ``failures.csv`` (every failed sample: method, inputs, reason), ``summary.json``, and
        the methods' own files: ``whole_cycle.csv`` (Monte Carlo), ``rare_events.csv`` (one
        row per rare-event method) and ``design_point.csv`` (with a design point).
    cache : bool
        Cache the model evaluations in ``out/evaluations.sqlite``.
    target_reliability : float or False, optional
        Ask the inverse question too: the allowables at which the whole-cycle reliability is
        this, in (0, 1) (:mod:`mechrel.study.inverse`; ``inverse.csv``, the summary's
        ``allowable for`` lines, ``summary.json``'s ``inverse``). Default (None): the study's
        ``inverse.target``, if it has one; False: not asked.

    Returns
    -------
    lines : list of str
        The printable summary.
    results : dict
        The estimators' results by method (the inverse ones as ``inverse_KEY``).

    Raises
    ------
    SampleFailuresError
        An estimator refused because of failed samples; ``failures.csv`` and ``summary.json``
        (with the counts and the reason) are written first.

    Examples
    --------
    FOSM (three simulations) on a one-cycle slider-crank with an uncertain clearance:

    >>> from mechrel.study.study import load_study
    >>> study = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
    ...                     "angle_step": 90.0, "cycles": 1,
    ...                     "inputs": {"c": {"paths": ["joints.C.clearance"],
    ...                                      "distribution": "normal", "mean": 0.5e-3,
    ...                                      "std": 2e-5}}})
    >>> lines, results = run_reliability(study, methods=["fosm"], progress=False)
    >>> list(results), results["fosm"].n_evaluations
    (['fosm'], 3)
    """
    from .context import Context
    from .presenters import COMBINED, presenter_class, warnings_of
    from .rare import evaluation_counts
    from .study import study_methods

    start = time.perf_counter()
    cfg = study.reliability
    known = study_methods()
    given = tuple(methods or cfg["methods"])
    for m in given:
        ARGS.choice("methods", m, tuple(known) + ("all",))
    # in the registry's order (FORM before the methods that start from its design point)
    keys = tuple(k for k in known if "all" in given or k in given)
    chosen = [known[k] for k in keys]
    n = cfg["n"] if n is None else n
    seed = cfg["seed"] if seed is None else seed
    given_fraction = max_failure_fraction is not None
    max_failure_fraction = (cfg["max_failure_fraction"] if max_failure_fraction is None
                            else max_failure_fraction)
    event = cfg["event"]
    if target_reliability is None:
        target = study.inverse["target"]
    elif target_reliability is False:
        target = None
    else:
        target = ARGS.fraction("target_reliability", target_reliability, open_lo=True,
                               open_hi=True)
    # the rare-event methods search the whole cycle's failure modes sector by sector
    model = study.model(sectors=any(m.kind == "rare_event" for m in chosen))
    inputs = study.uncertain_inputs()
    presenters = {}
    for m in chosen:
        cls = presenter_class(m)
        presenters.setdefault(cls, cls())
    _check_run(n=n, seed=seed, n_jobs=n_jobs, backend=backend,
               max_failure_fraction=max_failure_fraction, model=model, inputs=inputs,
               rows_per_n=max((p.rows_per_n for p in presenters.values()), default=0))
    allow = study.allowables()
    cache_path = (out / "evaluations.sqlite") if (out and cache) else None
    ctx = Context(study=study, model=model, inputs=inputs, allowables=allow, event=event,
                  seed=seed, n=n, max_failure_fraction=max_failure_fraction,
                  max_failure_fraction_given=given_fraction,
                  common=dict(n_jobs=n_jobs, backend=backend, cache=cache_path,
                              progress=progress), target=target)
    ctx.presenters = list(presenters.values()) + [cls() for cls in COMBINED]
    for m in chosen:  # every method's settings and sizes, before the first one runs
        presenters[presenter_class(m)].check(ctx, m)
    warm_up(model, progress=progress)
    record = {"study": study.name, "source": study.source, "methods": list(keys), "n": n,
              "seed": seed, "event": event, "max_failure_fraction": max_failure_fraction}
    lines = [f"study {study.name}: scene {model.scene.name}, inputs {', '.join(inputs.names)}; "
             f"event {event}"]
    lines += [f"  {name}: {m!r}; mean {mu:.6g}, std {sd:.6g}"
              for name, m, mu, sd in zip(inputs.names, inputs.marginals, inputs.mean, inputs.std)]
    if study.correlation:
        lines.append("  correlation (Pearson): "
                     + ", ".join(f"{pair} {rho:g}" for pair, rho in study.correlation.items()))
    try:
        for m in chosen:
            presenters[presenter_class(m)].run(ctx, m)
        for p in ctx.presenters:
            p.finish(ctx)
    except SampleFailuresError as exc:
        record.update(wall_time=time.perf_counter() - start, summary=lines,
                      provenance={k: dict(v.provenance) for k, v in ctx.results.items()})
        raise _refusal(exc, ctx.evaluations, out, ("failures.csv", "summary.json"), record,
                       "reliability", reliability_results()) from None
    frames = [f for p in ctx.presenters for f in p.frames(ctx)]
    table = pd.concat(frames, axis=1) if frames else None
    # the sector extremes are the rare-event methods' members, not rows of the per-angle table
    if table is not None:
        from ..uq.problem.allowables import parse_sector
        keep = [not (isinstance(lbl, tuple) and parse_sector(lbl[-1])) for lbl in table.index]
        table = table[keep]
    for p in ctx.presenters:
        lines += p.head_lines(ctx)
    by_rank = sorted(ctx.presenters, key=lambda p: p.rank)
    width = max(len(name) for name in study.quantities) + 1
    for q in study.quantities:
        parts = [s for s in (p.quantity_part(ctx, q) for p in by_rank) if s]
        if parts:  # a run with rare-event methods only has no per-angle estimate
            lines.append(f"  {q + ':':{width}s} " + "; ".join(parts))
    for p in ctx.presenters:
        lines += p.tail_lines(ctx)
    lines += _failure_lines(ctx.evaluations, out / "failures.csv" if out else None)
    wall = time.perf_counter() - start
    per_method, total = evaluation_counts(ctx.results, ctx.evaluations)
    lines.append(f"  {total.text()} in {wall:.1f} s (n_jobs = {n_jobs})")
    notes = warnings_of(ctx.results) + ctx.notes
    lines += [f"  warning: {w}" for w in notes]
    verdict = _verdict(ctx, by_rank)
    if out:
        # one set: everything written into the staging folder, moved into out together
        with result_set(out, "reliability", known=reliability_results()) as stage:
            written = []
            if table is not None:
                write_table(table.reset_index(), stage / "reliability.csv")
                written.append("reliability.csv")
            plotted = [r for p in ctx.presenters for r in p.plotted(ctx)]
            if plotted:
                from ..uq.plots import plot_reliability
                from .presenters import _agg, _save

                _agg()

                _save(plot_reliability(*plotted, title=f"{study.name}: reliability per crank "
                                                       f"angle ({event})"),
                      stage / "reliability.png")
                written.append("reliability.png")
            for p in ctx.presenters:
                written += p.write(ctx, stage)
            _write_failures(ctx.evaluations, stage / "failures.csv")
            write_json({**record, "wall_time": wall,
                        "failures": _failure_counts(ctx.evaluations),
                        "evaluations": {**{k: {**c.as_dict(), "includes": shared}
                                           for k, (c, shared) in per_method.items()},
                                        "total": total.as_dict()},
                        "provenance": {k: dict(v.provenance) for k, v in ctx.results.items()},
                        "warnings": notes, "verdict": [v.strip() for v in verdict[1:]],
                        "summary": lines, **{k: v for p in ctx.presenters
                                             for k, v in p.record(ctx).items()}},
                       stage / "summary.json", relative_to=out)
            written += ["failures.csv", "summary.json"]
        lines.append(f"  wrote {out}/{', '.join(written)}")
    lines += verdict  # the summary ends with it
    return lines, ctx.results


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

    Parameters
    ----------
    study : Study
        From :func:`~mechrel.study.study.load_study`.
    n : int, optional
        Saltelli base samples (N (d + 2) model runs); default: the study's
        ``sensitivity.n``.
    n_jobs : int, default 1
        Parallel workers (:func:`mechrel.uq.evaluate`).
    seed : int, optional
        The seed; default: the study's ``sensitivity.seed``.
    out : path, optional
        Folder for ``sensitivity.csv`` (ranked), ``sensitivity.png``,
        ``sensitivity_failures.csv`` and ``sensitivity.json``.
    progress : bool, default True
        Show a progress bar.
    cache : bool, default True
        Cache the model evaluations in ``out/evaluations.sqlite``.
    backend : str, default "loky"
        The executor's backend (:func:`mechrel.uq.evaluate`).
    max_failure_fraction : float, optional
        The largest fraction of Saltelli blocks with a failed sample that may be dropped;
        default: the study's.

    Returns
    -------
    lines : list of str
        The printable summary.
    result : SobolResult
        The indices of the peak |error| of each quantity.

    Raises
    ------
    SampleFailuresError
        Too many Saltelli blocks failed; ``sensitivity_failures.csv`` and
        ``sensitivity.json`` (with the counts and the reason) are written first.
    StudyError
        An argument is invalid (naming it, its value and what is allowed).

    Examples
    --------
    N = 8 base samples of one input: 8 (1 + 2) = 24 simulations of a one-cycle slider-crank
    (far too few to rank inputs: the result warns so):

    >>> from mechrel.study.study import load_study
    >>> study = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
    ...                     "angle_step": 90.0, "cycles": 1,
    ...                     "inputs": {"c": {"paths": ["joints.C.clearance"],
    ...                                      "distribution": "normal", "mean": 0.5e-3,
    ...                                      "std": 2e-5}}})
    >>> lines, result = run_sensitivity(study, n=8, progress=False)
    >>> result.evaluations.n, list(result.total.columns)
    (24, ['c'])
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
    warm_up(model, progress=progress)
    record = {"study": study.name, "source": study.source, "n": n, "seed": seed,
              "max_failure_fraction": max_failure_fraction}
    try:
        res = sobol_indices(model=model, inputs=inputs, n=n, seed=seed, reducer=peak_abs,
                            max_failure_fraction=max_failure_fraction, n_jobs=n_jobs,
                            backend=backend, progress=progress,
                            cache=(out / "evaluations.sqlite") if (out and cache) else None)
    except SampleFailuresError as exc:
        evaluations = {"sobol": exc.evaluations}
        record["wall_time"] = time.perf_counter() - start
        raise _refusal(exc, evaluations, out, ("sensitivity_failures.csv", "sensitivity.json"),
                       record, "sensitivity", SENSITIVITY_RESULTS) from None
    evaluations = {"sobol": res.evaluations}
    table = res.to_frame().reset_index()
    table = table.sort_values([table.columns[0], "ST"], ascending=[True, False])
    lines = [f"study {study.name}: Sobol indices of the peak |error| over the cycle "
             f"(N = {n}, {res.n_blocks_dropped} Saltelli blocks dropped for failures)"]
    for out_name, grp in table.groupby(table.columns[0], sort=False):
        ranked = ", ".join(f"{r[table.columns[1]]} ST={r['ST']:.3f}±{r['ST_conf']:.3f} "
                           f"S1={r['S1']:.3f}" for _, r in grp.iterrows())
        lines.append(f"  {out_name}: {ranked}")
    lines += _failure_lines(evaluations, out / "sensitivity_failures.csv" if out else None)
    from .presenters import cycle_closure

    # the model's own check, which the indices share: does the analysed cycle close?
    notes = list(res.warnings) + cycle_closure(model, [res.evaluations])[1]
    lines += [f"  warning: {w}" for w in notes]
    wall = time.perf_counter() - start
    count = res.evaluations.count
    lines.append(f"  {count.text()} in {wall:.1f} s (n_jobs = {n_jobs})")
    if out:
        with result_set(out, "sensitivity", known=SENSITIVITY_RESULTS) as stage:
            write_table(table, stage / "sensitivity.csv")
            from ..uq.plots import plot_sobol

            from .presenters import _agg, _save

            _agg()

            _save(plot_sobol(res, title=f"{study.name}: what drives the error"),
                  stage / "sensitivity.png")
            _write_failures(evaluations, stage / "sensitivity_failures.csv")
            write_json({**record, "wall_time": wall, "failures": _failure_counts(evaluations),
                        "evaluations": {"sobol": count.as_dict(), "total": count.as_dict()},
                        "provenance": dict(res.provenance), "warnings": notes,
                        "summary": lines}, stage / "sensitivity.json", relative_to=out)
        lines.append(f"  wrote {out}/sensitivity.csv, sensitivity.png, "
                     "sensitivity_failures.csv, sensitivity.json")
    return lines, res
