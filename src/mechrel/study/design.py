"""Design for reliability of a study (``mechrel design STUDY``, the study file's ``[design]``):
the cheapest design whose whole-cycle reliability meets its targets
(:func:`mechrel.uq.design_for_reliability`).

The study's model gains one input per ``"scene"`` design variable (its ``paths`` set the scene
values, e.g. a lubricant's viscosity); the study's uncertain inputs are the base design, whose
means and spreads the other variables move or scale. The allowables are the study's means
(deterministic: their std is left out and said so). The run writes to ``out``:

``design.csv``
    The optimum: one row per design variable (value, bounds, start, on a bound).
``design_constraints.csv``
    Per constraint: the target, the factor k, active, the method's P_f and the independent
    verification's P_f with their intervals, the whole cycle's P_f at the optimum.
``design_tradeoff.csv``, ``design_tradeoff.png``
    The trade-off curve: the optimum cost against the target's P_f (×0.1 to ×10).
``design_history.csv``
    The method's iterations.
``design.json``
    The summary, the warnings, the settings and the provenance (every model run counted).
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..errors import StudyError
from ..io import write_json, write_table
from ..uq._common import SampleFailuresError
from .presenters import _agg, _save, cycle_closure
from .runner import (_check_run, _failure_counts, _failure_lines, _holds_output_folder,
                     _refusal, _write_failures, warm_up)
from .study import _design_variables

if TYPE_CHECKING:
    from ..uq.design.core import DesignResult
    from ..uq.problem.mechanism import MechanismModel
    from .study import Study

__all__ = ["run_design", "DESIGN_FILES", "design_model"]

DESIGN_FILES = ("design.csv", "design_constraints.csv", "design_tradeoff.csv",
                "design_tradeoff.png", "design_history.csv", "design_failures.csv",
                "design.json")
"""The files a design run writes to its output folder."""


def design_model(study: Study) -> MechanismModel:
    """The study's mechanism model with one input per ``"scene"`` design variable.

    Parameters
    ----------
    study : mechrel.study.study.Study
        A study with a ``[design]`` section.

    Returns
    -------
    mechrel.uq.problem.mechanism.MechanismModel
        Inputs: the study's uncertain inputs, then the scene variables (by their names).

    Raises
    ------
    StudyError
        The study has no ``[design]`` section.

    Examples
    --------
    >>> from mechrel.study.study import load_study
    >>> study = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
    ...     "inputs": {"c": {"paths": ["joints.C.clearance"], "distribution": "normal",
    ...                      "mean": 0.5e-3, "std": 2e-5}},
    ...     "design": {"cost": "-mu", "constraints": 0.99, "variables": {
    ...         "mu": {"kind": "scene", "paths": ["joints.C.lubricant.viscosity"],
    ...                "lower": 0.01, "upper": 0.1, "start": 0.04}}}})
    >>> design_model(study).input_names
    ('c', 'mu')
    """
    from ..uq.problem.mechanism import MechanismModel

    if study.design is None:
        raise StudyError(f"{study.source}: design: the study has no [design] section; allowed: "
                         "a study file with [design] (docs/studies.md, 'Design for "
                         "reliability')")
    paths = dict(study.paths)
    for name, v in study.design["variables"].items():
        if v["kind"] == "scene":
            paths[name] = tuple(v["paths"])
    return MechanismModel(study.scene, paths, output=study.output,
                          quantities=study.quantities, angle_step=study.angle_step,
                          cycles=study.cycles, overrides=dict(study.scene_overrides),
                          reference=study.reference)


@_holds_output_folder(DESIGN_FILES)
def run_design(study: Study, *, method: str | None = None, n_jobs: int = 1,
               seed: Any = None, out: Path | None = None, progress: bool = True,
               cache: bool = True, backend: str = "loky",
               max_failure_fraction: float | None = None,
               settings: Mapping[str, Any] | None = None) -> tuple[list[str], DesignResult]:
    """The study's ``[design]``: the optimum, its verification and the trade-off curve.

    Parameters
    ----------
    study : Study
        From :func:`~mechrel.study.study.load_study`, with a ``[design]`` section.
    method : str, optional
        A key of :data:`mechrel.uq.design.DESIGN_METHODS`; default: the study's
        ``design.method``.
    n_jobs : int, default 1
        Parallel workers (:func:`mechrel.uq.evaluate`).
    seed : int, optional
        The seed; default: the study's ``design.seed``.
    out : path, optional
        Folder for the files of the module docstring.
    progress : bool, default True
        Show progress bars.
    cache : bool, default True
        Cache the model evaluations in ``out/evaluations.sqlite`` (a rerun, or a run with
        other targets or bounds, reuses every simulation it can).
    backend : str, default "loky"
        The executor's backend.
    max_failure_fraction : float, optional
        Default: the study's ``design.max_failure_fraction``.
    settings : mapping, optional
        The method's settings, over the study's ``[design.KEY]`` table.

    Returns
    -------
    lines : list of str
        The printable summary.
    result : DesignResult
        :class:`mechrel.uq.DesignResult`.

    Raises
    ------
    StudyError
        No ``[design]`` section, or a bad field or argument (naming it).
    SampleFailuresError
        Too many failed simulations; ``design_failures.csv`` and ``design.json`` are written
        first.

    Examples
    --------
    The largest nominal clearance of a lubricated slider-crank whose velocity error stays
    within 0.3 m/s with R ≥ 0.9, at a toy budget (one cycle, four angles, the Monte Carlo
    method on 10 samples per design and at most 2 designs, no verification: far too few for an
    answer, which the warnings say):

    >>> from mechrel.study.study import load_study
    >>> study = load_study({"scene": "slider-crank-lubricated", "quantities": ["velocity"],
    ...     "angle_step": 90.0, "cycles": 1, "allowable": {"velocity": {"mean": 0.3}},
    ...     "inputs": {"c": {"paths": ["joints.C.clearance"], "distribution": "normal",
    ...                      "mean": 0.3e-3, "std": 2e-5}},
    ...     "design": {"cost": "c", "sense": "maximize", "constraints": 0.9, "method": "mc",
    ...                "mc": {"n": 10, "max_designs": 2}, "verify": "none", "tradeoff": 0,
    ...                "seed": 1, "variables": {"c": {"kind": "mean", "input": "c",
    ...                                               "lower": 0.2e-3, "upper": 0.4e-3}}}})
    >>> import warnings
    >>> with warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     lines, result = run_design(study, progress=False)
    >>> lines[0].startswith("study study: design for reliability (mc, ")
    True
    >>> result.provenance["n_evaluations"] <= 30      # 10 per design tried, + the optimum
    True
    """
    from ..uq import design_for_reliability

    start = time.perf_counter()
    if study.design is None:
        raise StudyError(f"{study.source}: design: the study has no [design] section; allowed: "
                         "a study file with [design] (docs/studies.md, 'Design for "
                         "reliability')")
    cfg = study.design
    method = cfg["method"] if method is None else method
    seed = cfg["seed"] if seed is None else seed
    max_failure_fraction = (cfg["max_failure_fraction"] if max_failure_fraction is None
                            else max_failure_fraction)
    chosen = {**cfg["settings"].get(method, {}), **dict(settings or {})}
    model = design_model(study)
    inputs = study.uncertain_inputs()
    _check_run(n=2, seed=seed, n_jobs=n_jobs, backend=backend,
               max_failure_fraction=max_failure_fraction, model=model, inputs=inputs,
               rows_per_n=0)
    warm_up(model, progress=progress)
    record = {"study": study.name, "source": study.source, "method": method, "seed": seed,
              "max_failure_fraction": max_failure_fraction, "design": {
                  k: v for k, v in cfg.items() if k != "settings"}, "settings": chosen}
    try:
        res = design_for_reliability(
            model=model, inputs=inputs, variables=_design_variables(cfg), cost=cfg["cost"],
            constraints=list(cfg["constraints"]), allowable=study.allowables(),
            event=study.reliability["event"], sense=cfg["sense"], method=method, seed=seed,
            verify=dict(cfg["verify"]), tradeoff=cfg["tradeoff"],
            max_failure_fraction=max_failure_fraction, n_jobs=n_jobs, backend=backend,
            progress=progress, cache=(out / "evaluations.sqlite") if (out and cache) else None,
            **chosen)
    except SampleFailuresError as exc:
        record["wall_time"] = time.perf_counter() - start
        raise _refusal(exc, {"design": exc.evaluations}, out,
                       ("design_failures.csv", "design.json"), record, "design",
                       DESIGN_FILES) from None
    prov = res.provenance
    n_method = prov["counts"]["design"]["n_evaluations"]
    n_verify = prov["counts"]["verification"]["n_evaluations"]
    lines = [f"study {study.name}: design for reliability ({res.method}, "
             f"{prov['n_evaluations']} simulations: {n_method} by the method, "
             f"{n_verify} to verify; "
             f"{prov['n_cached']} from the cache)",
             f"  {res.sense} {res.cost_expression}: {res.cost:.6g} at the optimum "
             f"(start {res.start_cost:.6g})"]
    for name, row in res.table.iterrows():
        bound = f"  [on the {row['on_bound']} bound]" if row["on_bound"] else ""
        lines.append(f"    {name} ({row['kind']} of {row['input']}) = {row['value']:.6g}  "
                     f"(bounds {row['lower']:.4g} .. {row['upper']:.4g}){bound}")
    for label, row in res.constraints.iterrows():
        ver = ("not verified (verify = none)" if row["verify_method"] == "none" else
               f"verified by {row['verify_method']} ({int(row['verify_n'])} runs): P_f = "
               f"{row['verify_pf']:.3g} [{row['verify_pf_lo']:.3g}, {row['verify_pf_hi']:.3g}]"
               + ("" if row["verified"] else "  NOT within the target"))
        lines.append(f"  {label}: k = {row['factor']:.4f}{' (active)' if row['active'] else ''}"
                     f", P_f target {row['pf_target']:.3g}, method's estimate "
                     f"{row['pf']:.3g} [{row['pf_lo']:.3g}, {row['pf_hi']:.3g}]; {ver}")
        if row["basis"] == "per-angle" and row["verify_method"] == "mc":
            lines.append(f"    whole cycle at this optimum: P_f = {row['whole_cycle_pf']:.3g} "
                         f"[{row['whole_cycle_pf_lo']:.3g}, {row['whole_cycle_pf_hi']:.3g}]")
    evaluations = {"design": res.evaluations} if res.evaluations is not None else {}
    lines += _failure_lines(evaluations, out / "design_failures.csv" if out else None)
    # the model's own check, which every design shares: does the analysed cycle close?
    notes = list(res.warnings) + cycle_closure(model, evaluations.values())[1]
    lines += [f"  warning: {w}" for w in notes]
    wall = time.perf_counter() - start
    lines.append(f"  wall time {wall:.1f} s (n_jobs = {n_jobs})")
    if out:
        from ..io.results import result_set
        from ..uq.design.figure import plot_tradeoff

        # one set: everything written into the staging folder, moved into out together
        with result_set(out, "design", known=DESIGN_FILES) as stage:
            write_table(res.table.reset_index(), stage / "design.csv")
            write_table(res.constraints.reset_index(), stage / "design_constraints.csv")
            write_table(res.tradeoff, stage / "design_tradeoff.csv")
            write_table(res.history.reset_index(), stage / "design_history.csv")
            _agg()
            _save(plot_tradeoff(res, title=f"{study.name}: cost against reliability"),
                  stage / "design_tradeoff.png")
            if evaluations:
                _write_failures(evaluations, stage / "design_failures.csv")
            write_json({**record, "wall_time": wall, "failures": _failure_counts(evaluations),
                        "cost": res.cost, "optimum": res.design, "active": res.active,
                        "provenance": dict(prov), "warnings": notes,
                        "summary": lines}, stage / "design.json", relative_to=out)
        lines.append(f"  wrote {out}/design.csv, design_constraints.csv, design_tradeoff.csv, "
                     "design_tradeoff.png, design_history.csv, design.json")
    return lines, res
