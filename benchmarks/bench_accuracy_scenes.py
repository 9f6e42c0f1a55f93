"""What accuracy costs in time on the embedded scenes: ``mechrel accuracy`` run on each.

For every scene this calls :func:`mechrel.study.accuracy.accuracy_report` (the code behind
``mechrel accuracy SCENE``) with a bounded candidate list (each scene a few minutes on one
core), writes the figure to ``docs/figures/performance/accuracy_<scene>.png``, the table to
``<out>/accuracy_<scene>.csv`` and a Markdown summary (tables, recommendation, the default of
``mechrel.simulation.DEFAULT_SOLVERS`` and its measured error) to
``<out>/accuracy_<scene>.md`` (``--replot`` redraws the figures from the saved tables).

Error measures and reference: see ``mechrel.study.accuracy`` (pointwise max error / range
for ideal and lubricated scenes; for dry scenes, whose trajectories are chaotic, the difference
of the ensemble means of the error curves' statistics over ``--ensemble`` R perturbed initial
states, with its standard error as the floor). Wall times: pointwise, the minimum of
``--repeats`` warm runs; ensembles, the median member run (and the ensemble's total).

Run::

    python benchmarks/bench_accuracy_scenes.py --out results/accuracy_scenes
    python benchmarks/bench_accuracy_scenes.py --scenes slider-crank-dry nine-bar-dry --ensemble 8
    # how the floor scales with R, without touching the docs figures:
    python benchmarks/bench_accuracy_scenes.py --scenes slider-crank-dry --ensemble 32 \
        --out results/accuracy_scenes_R32 --figdir results/accuracy_scenes_R32
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from _common import git_state  # noqa: E402  (benchmarks/ is sys.path[0])
from mechrel.scene import load_scene  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.simulation import DEFAULT_SOLVERS, scene_kind, simulate  # noqa: E402
from mechrel.study.accuracy import CHAOTIC_KINDS, accuracy_report  # noqa: E402

SCENES = ("nine-bar-lubricated", "slider-crank-lubricated", "nine-bar-dry", "slider-crank-dry",
          "nine-bar")
FIGDIR = Path(__file__).resolve().parents[1] / "docs" / "figures" / "performance"


def tol(name, tols):
    return [(name, {"rtol": t, "atol": t * 1e-3}) for t in tols]


def candidates(scene, kind):
    period = compile_scene(scene).period or scene.analysis_duration
    rk4 = lambda divs: [("rk4", {"step": period / d}) for d in divs]  # noqa: E731
    if kind == "lubricated":
        return (tol("radau", [1e-3, 1e-4, 1e-5, 1e-6, 1e-7, 1e-8]) + tol("lsoda", [1e-5, 1e-7])
                + tol("dopri5", [1e-6]))
    if kind == "dry":
        # dopri5 at 1e-10 and 1e-12 straddle the 1e-11 reference: equally converged, so the
        # ensemble measure must find them within its floor (one trajectory each did not: they
        # differed by 1-75 %, the old "chaos floor")
        return (tol("dopri5", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-12])
                + rk4([4e3, 16e3, 64e3]) + tol("radau", [1e-5, 1e-7]))
    # ideal: forward dynamics of the ideal mechanism
    return (tol("dopri5", [1e-4, 1e-6, 1e-8, 1e-9, 1e-10]) + rk4([250, 1e3, 4e3])
            + tol("radau", [1e-6, 1e-8]))


def default_label(kind):
    name, s = DEFAULT_SOLVERS[kind]
    return name, ", ".join(f"{k}={v:.3g}" for k, v in s.items())


def figure(rep, kind, path, repeats=2, load=None):
    """The report's own plot (for dry scenes with each point's upper confidence bound and the
    floor of the reference against itself as a grey band), plus the default setting and a
    labelled time axis."""
    import matplotlib.pyplot as plt
    from matplotlib.ticker import LogFormatterSciNotation

    fig = rep.plot()
    ax = fig.axes[0]
    dname, dlabel = default_label(kind)
    t = rep.table[rep.table["failed"] == ""]
    d = t[(t["integrator"] == dname) & (t["setting"] == dlabel)]
    if len(d):
        ax.plot(d["wall_time"].iloc[:1], d["measure"].iloc[:1], "o", ms=15, mfc="none",
                mec="red", mew=2, label=f"default ({dname})")
    ax.xaxis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False,
                                                         minor_thresholds=(2, 0.5)))
    ax.tick_params(axis="x", which="minor", labelsize=7)
    timing = (f"median of the R = {rep.ensemble} member runs" if rep.ensemble > 1
              else f"min of {repeats} warm runs")
    where = (f"load average {load:.1f} at the start" if load is not None
             else "machine load not recorded")
    ax.set_title(f"{rep.scene} ({kind}): error against wall time per run\n"
                 f"({timing}, 2-core VM, {where})", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=130)
    plt.close(fig)


def replot(out, figdir, scenes=SCENES):
    """Redraw the figures of ``scenes`` from the saved tables (no simulation)."""
    from mechrel.study.accuracy import AccuracyReport
    summary = json.loads((out / "accuracy_scenes.json").read_text())
    for name, info in summary.items():
        if name not in scenes:
            continue
        import pandas as pd
        table = pd.read_csv(out / f"accuracy_{name}.csv", keep_default_na=False,
                            na_values=[""])
        table["failed"] = ["" if pd.isna(v) else str(v) for v in table["failed"]]
        kind = info["kind"]
        rep = AccuracyReport(scene=name, kind=kind, measure=info.get("measure", "error"),
                             target=info.get("target", 0.01), reference={}, table=table,
                             recommended=info["recommended"],
                             ensemble=info.get("ensemble", 1),
                             floor=info.get("floor", float("nan")))
        figure(rep, kind, figdir / f"accuracy_{name}.png", info.get("repeats", 2),
               info.get("load"))


def markdown(rep, kind, elapsed):
    t = rep.table
    dname, dlabel = default_label(kind)
    qcols = [c for c in t.columns if c.startswith("error_")]
    ens = rep.ensemble > 1
    extra = ["floor", "bound", "verdict"] if ens else []
    head = ["integrator", "setting", "wall (s)", "steps", "rhs evals"] + \
        [c[6:] for c in qcols] + ["measure"] + extra
    lines = [f"### {rep.scene} ({kind}; {rep.measure})", "",
             f"Reference: {rep.reference}; target {rep.target:g}; run took {elapsed:.0f} s.", ""]
    if ens:
        lines += [f"Ensemble: R = {rep.ensemble}, seed {rep.seed}, initial eccentricity "
                  f"perturbed by {rep.perturbation:g} x clearance; floor of the reference "
                  f"against itself {rep.floor:.2g}; wall = median member run, ensemble total "
                  f"{t['wall_total'].sum():.0f} s. Columns per quantity: largest |difference "
                  "of ensemble means| / reference over peak, RMS and p95; floor = largest "
                  "standard error; bound = largest |difference| + t x floor.", ""]
    lines += ["| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
    for _, r in t.iterrows():
        mark = ""
        if rep.recommended and (r["integrator"], r["setting"]) == (
                rep.recommended["integrator"], rep.recommended["setting"]):
            mark = " **(recommended)**"
        if (r["integrator"], r["setting"]) == (dname, dlabel):
            mark += " *(default)*"
        if r["failed"]:
            lines.append(f"| {r['integrator']} | {r['setting']} | failed: {r['failed'][:80]} |")
            continue
        vals = [f"{r['wall_time']:.3g}", f"{r['n_steps']:.0f}", f"{r['n_rhs']:.0f}"] + \
            [f"{r[c]:.2g}" for c in qcols] + [f"{r['measure']:.2g}"]
        if ens:
            vals += [f"{r['floor']:.2g}", f"{r['bound']:.2g}", r["verdict"]]
        lines.append(f"| {r['integrator']}{mark} | {r['setting']} | " + " | ".join(vals) + " |")
    lines.append("")
    if rep.recommended:
        r = rep.recommended
        lines.append(f"Recommended: `{r['integrator']}` {r['setting']} (measure {r['measure']:.2g},"
                     f" {r['wall_time']:.3g} s). Default: `{dname}` {dlabel}.")
    else:
        lines.append(f"{rep.conclusion[0].upper()}{rep.conclusion[1:]}. "
                     f"Default: `{dname}` {dlabel}.")
    lines.append("")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--target", type=float, default=0.01)
    ap.add_argument("--ensemble", type=int, default=8,
                    help="members per setting for dry scenes (default 8)")
    ap.add_argument("--seed", type=int, default=0, help="seed of the ensemble (default 0)")
    ap.add_argument("--out", default="results/accuracy_scenes")
    ap.add_argument("--figdir", default=str(FIGDIR))
    ap.add_argument("--replot", action="store_true", help="redraw the figures from --out")
    a = ap.parse_args(argv)
    out, figdir = Path(a.out), Path(a.figdir)
    if a.replot:
        return replot(out, figdir, a.scenes)
    out.mkdir(parents=True, exist_ok=True)
    figdir.mkdir(parents=True, exist_ok=True)
    md, summary = [], {}
    if (out / "accuracy_scenes.json").exists():  # keep the scenes not rerun
        summary = json.loads((out / "accuracy_scenes.json").read_text())
        summary = {k: v for k, v in summary.items() if k not in a.scenes}
    for name in a.scenes:
        scene = load_scene(name)
        kind = scene_kind(scene)
        if kind == "ideal":
            scene = load_scene(name, overrides={"solver.integrator": "dopri5"})
        simulate(scene, method="dynamics")  # warm the kernels (numba disk cache)
        load = os.getloadavg()[0]
        t0 = time.perf_counter()
        # also time the default itself so it appears in the table even if not a candidate
        cands = candidates(scene, kind)
        dn, ds = DEFAULT_SOLVERS[kind]
        dl = default_label(kind)
        if not any((n, ", ".join(f"{k}={v:.3g}" for k, v in c.items())) == dl for n, c in cands):
            cands.append((dn, dict(ds)))
        chaotic = kind in CHAOTIC_KINDS
        rep = accuracy_report(scene, candidates=cands, target=a.target, repeats=a.repeats,
                              ensemble=a.ensemble if chaotic else None, seed=a.seed)
        elapsed = time.perf_counter() - t0
        rep.table.to_csv(out / f"accuracy_{name}.csv", index=False)
        figure(rep, kind, figdir / f"accuracy_{name}.png", a.repeats, load)
        md.append(markdown(rep, kind, elapsed))
        summary[name] = {"kind": kind, "recommended": rep.recommended, "measure": rep.measure,
                         "default": [dn, ds], "elapsed": elapsed, "target": rep.target,
                         "repeats": a.repeats, "ensemble": rep.ensemble, "seed": rep.seed,
                         "floor": rep.floor, "ensemble_needed": rep.ensemble_needed,
                         "conclusion": rep.conclusion, "load": load, "git": git_state()}
        print(md[-1], flush=True)
        (out / f"accuracy_{name}.md").write_text(md[-1])
        (out / "accuracy_scenes.json").write_text(json.dumps(summary, indent=1, default=str))


if __name__ == "__main__":
    main()
