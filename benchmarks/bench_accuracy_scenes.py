"""What accuracy costs in time on the embedded scenes: ``mechrel accuracy`` run on each.

For every scene this calls :func:`mechrel.studies.accuracy.accuracy_report` (the code behind
``mechrel accuracy SCENE``) with a bounded candidate list (each scene a few minutes on one
core), writes the figure to ``docs/figures/performance/accuracy_<scene>.png``, the table to
``<out>/accuracy_<scene>.csv`` and a Markdown summary (tables, recommendation, the default of
``mechrel.simulation.DEFAULT_SOLVERS`` and its measured error) to ``<out>/accuracy_<scene>.md`` (``--replot`` redraws the figures from the saved tables).

Error measures and reference: see ``mechrel.studies.accuracy`` (pointwise max error / range
for ideal and lubricated scenes, relative change of the error curves' statistics for dry
scenes, whose trajectories are chaotic). Wall times are the minimum of ``--repeats`` warm runs.

Run::

    python benchmarks/bench_accuracy_scenes.py --out results/accuracy_scenes
    python benchmarks/bench_accuracy_scenes.py --scenes slider-crank-dry --repeats 2
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import DEFAULT_SOLVERS, compile_scene, scene_kind, simulate  # noqa: E402
from mechrel.studies.accuracy import accuracy_report  # noqa: E402

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
        # dopri5 at 1e-10 and 1e-12 straddle the 1e-11 reference: how far two equally
        # converged runs of a chaotic scene are apart (the "chaos floor" of the measure)
        return (tol("dopri5", [1e-4, 1e-5, 1e-6, 1e-7, 1e-8, 1e-9, 1e-10, 1e-12])
                + rk4([4e3, 16e3, 64e3]) + tol("radau", [1e-5, 1e-7]))
    # ideal: forward dynamics of the ideal mechanism
    return (tol("dopri5", [1e-4, 1e-6, 1e-8, 1e-9, 1e-10]) + rk4([250, 1e3, 4e3])
            + tol("radau", [1e-6, 1e-8]))


def default_label(kind):
    name, s = DEFAULT_SOLVERS[kind]
    return name, ", ".join(f"{k}={v:.3g}" for k, v in s.items())


def figure(rep, kind, path):
    """The report's own plot, plus the default setting, a labelled time axis and, for dry
    scenes, the chaos floor (the measure of dopri5 1e-10 / 1e-12 against the 1e-11 reference)."""
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
    if kind == "dry":
        fl = t[(t["integrator"] == "dopri5") & t["setting"].str.contains("rtol=1e-1[02]")]
        if len(fl):
            ax.axhspan(fl["measure"].min(), fl["measure"].max(), color="grey", alpha=0.2,
                       label="chaos floor: dopri5 1e-10, 1e-12 vs 1e-11 ref.")
    ax.xaxis.set_minor_formatter(LogFormatterSciNotation(labelOnlyBase=False,
                                                         minor_thresholds=(2, 0.5)))
    ax.tick_params(axis="x", which="minor", labelsize=7)
    ax.set_title(f"{rep.scene} ({kind}): error against wall time per run\n"
                 f"(min of {2} warm runs, shared 2-core machine: times ±2×)", fontsize=10)
    ax.legend(fontsize=8, loc="best")
    fig.savefig(path, dpi=130)
    plt.close(fig)


def replot(out, figdir):
    """Redraw the figures from the saved tables (no simulation)."""
    from mechrel.studies.accuracy import AccuracyReport
    summary = json.loads((out / "accuracy_scenes.json").read_text())
    for name, info in summary.items():
        import pandas as pd
        table = pd.read_csv(out / f"accuracy_{name}.csv", keep_default_na=False,
                            na_values=[""])
        table["failed"] = table["failed"].fillna("").astype(str)
        kind = info["kind"]
        rep = AccuracyReport(scene=name, kind=kind, measure=info.get("measure", "error"),
                             target=0.01, reference={}, table=table,
                             recommended=info["recommended"])
        figure(rep, kind, figdir / f"accuracy_{name}.png")


def markdown(rep, kind, elapsed):
    t = rep.table
    dname, dlabel = default_label(kind)
    qcols = [c for c in t.columns if c.startswith("error_")]
    head = ["integrator", "setting", "wall (s)", "steps", "rhs evals"] + \
        [c[6:] for c in qcols] + ["measure"]
    lines = [f"### {rep.scene} ({kind}; {rep.measure})", "",
             f"Reference: {rep.reference}; target {rep.target:g}; run took {elapsed:.0f} s.", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * 2 + "---:|" * (len(head) - 2)]
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
        vals = [f"{r['wall_time']:.3g}", f"{int(r['n_steps'])}", f"{int(r['n_rhs'])}"] + \
            [f"{r[c]:.2g}" for c in qcols] + [f"{r['measure']:.2g}"]
        lines.append(f"| {r['integrator']}{mark} | {r['setting']} | " + " | ".join(vals) + " |")
    lines.append("")
    if rep.recommended:
        r = rep.recommended
        lines.append(f"Recommended: `{r['integrator']}` {r['setting']} (measure {r['measure']:.2g},"
                     f" {r['wall_time']:.3g} s). Default: `{dname}` {dlabel}.")
    else:
        lines.append(f"No candidate met the target. Default: `{dname}` {dlabel}.")
    lines.append("")
    return "\n".join(lines)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=list(SCENES))
    ap.add_argument("--repeats", type=int, default=2)
    ap.add_argument("--target", type=float, default=0.01)
    ap.add_argument("--out", default="results/accuracy_scenes")
    ap.add_argument("--figdir", default=str(FIGDIR))
    ap.add_argument("--replot", action="store_true", help="redraw the figures from --out")
    a = ap.parse_args(argv)
    out, figdir = Path(a.out), Path(a.figdir)
    if a.replot:
        return replot(out, figdir)
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
        t0 = time.perf_counter()
        # also time the default itself so it appears in the table even if not a candidate
        cands = candidates(scene, kind)
        dn, ds = DEFAULT_SOLVERS[kind]
        dl = default_label(kind)
        if not any((n, ", ".join(f"{k}={v:.3g}" for k, v in c.items())) == dl for n, c in cands):
            cands.append((dn, dict(ds)))
        rep = accuracy_report(scene, candidates=cands, target=a.target, repeats=a.repeats)
        elapsed = time.perf_counter() - t0
        rep.table.to_csv(out / f"accuracy_{name}.csv", index=False)
        figure(rep, kind, figdir / f"accuracy_{name}.png")
        md.append(markdown(rep, kind, elapsed))
        summary[name] = {"kind": kind, "recommended": rep.recommended, "measure": rep.measure,
                         "default": [dn, ds], "elapsed": elapsed}
        print(md[-1], flush=True)
        (out / f"accuracy_{name}.md").write_text(md[-1])
        (out / "accuracy_scenes.json").write_text(json.dumps(summary, indent=1, default=str))


if __name__ == "__main__":
    main()
