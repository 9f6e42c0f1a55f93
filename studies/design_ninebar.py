#!/usr/bin/env python
"""The largest nominal clearance of the lubricated nine-bar for a whole-cycle R ≥ 0.999, and how
it moves with the oil's viscosity grade.

The embedded study ``nine-bar-clearance-design`` (the default study's uncertain inputs:
clearance TruncNormal(0.5, 0.05 mm, 0.35–0.65 mm) in C1 and C2, viscosity LogNormal(100 cP,
c.o.v. 15 %), crank speed N(3π, 0.1) rad/s; fixed allowables 1.5 mm, 0.083 m/s, 12.5 m/s² on
the slider over the whole second cycle) asks for the largest mean of the clearance input
(``kind = "mean"``: the distribution moved, its spread and truncation width kept) with
P(every quantity within its allowable at every instant) ≥ 0.999. This script answers it at
three viscosity grades (the viscosity input's mean; its c.o.v. kept at 15 %), by the design
method ``ak`` (Kriging of the cycle extremes over the model's inputs, learnt where the optimum's
constraint is decided: docs/uq.md, "Design for reliability"), each grade learnt from its own
simulations (``--chain`` starts each from the previous grades' simulations,
``initial=``: the model is the same, only the inputs' distribution moves; fewer simulations, but
each prediction over the population then costs in proportion to the reused points), and
verifies each optimum by an independent subset-simulation run (``--verify``); the trade-off
curve of cost against reliability is drawn at the first grade.

Writes into OUT: ``grades.csv`` (per grade: the optimum clearance, the method's P_f and
interval, the verification's P_f and interval, simulations by the method and by the
verification, wall time), ``design_ninebar.png`` (the optimum clearance against viscosity, with
the verified P_f), ``summary.json`` and, per grade, the design run's files in
``OUT/<grade>cP/`` (``mechrel design``'s set).

    python studies/design_ninebar.py --out results/design_ninebar --jobs 2 --max-evaluations 80
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd

from mechrel.cli.args import positive_integer, report_errors

STUDY = "nine-bar-clearance-design"
GRADES_CP = (100.0, 50.0, 200.0)   # the study's own grade first: the others start from it
COV = 0.15


def run(args) -> int:
    import warnings

    if args.replot:  # the figure again from OUT/grades.csv, nothing run
        _figure(pd.read_csv(Path(args.out) / "grades.csv"), Path(args.out) / "design_ninebar.png")
        return 0

    from mechrel.study.design import run_design
    from mechrel.study.study import load_study

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rows, previous, lines_all = [], None, []
    t_all = time.perf_counter()
    for grade in args.grades:
        mu = grade * 1e-3
        over = {"inputs.viscosity.mean": mu, "inputs.viscosity.std": COV * mu,
                "design.verify": {"method": args.verify, "n_per_level": args.n_per_level},
                "design.tradeoff": args.tradeoff if grade == args.grades[0] else 0}
        study = load_study(STUDY, overrides=over)
        settings = {"initial": previous} if (args.chain and previous is not None) else {}
        if args.max_evaluations:
            settings["max_evaluations"] = args.max_evaluations
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            lines, res = run_design(study, n_jobs=args.jobs, out=out / f"{grade:g}cP",
                                    progress=not args.no_progress, settings=settings)
        wall = time.perf_counter() - t0
        print("\n".join(lines), flush=True)
        lines_all += lines
        con = res.constraints.iloc[0]
        counts = res.provenance["counts"]
        c = float(res.table.loc["c", "value"])
        rows.append({
            "viscosity_cP": grade, "clearance_mm": c * 1e3,
            "on_bound": res.table.loc["c", "on_bound"] or "",
            "pf_method": float(con["pf"]), "pf_method_lo": float(con["pf_lo"]),
            "pf_method_hi": float(con["pf_hi"]), "verify_method": con["verify_method"],
            "pf_verified": float(con["verify_pf"]), "pf_verified_lo": float(con["verify_pf_lo"]),
            "pf_verified_hi": float(con["verify_pf_hi"]), "verified": bool(con["verified"]),
            "simulations_method": int(counts["design"]["n_computed"]),
            "simulations_method_cached": int(counts["design"]["n_evaluations"]
                                             - counts["design"]["n_computed"]),
            "simulations_verify": int(counts["verification"]["n_computed"]),
            "wall_s": wall, "warnings": " | ".join(str(w.message) for w in caught)})
        pd.DataFrame(rows).to_csv(out / "grades.csv", index=False)
        previous = res
    df = pd.DataFrame(rows)
    print(df.drop(columns="warnings").to_string(index=False))
    _figure(df, out / "design_ninebar.png")
    summary = {"study": STUDY, "grades_cP": list(args.grades), "cov": COV,
               "simulations_method": int(df["simulations_method"].sum()),
               "simulations_verify": int(df["simulations_verify"].sum()),
               "wall_s": time.perf_counter() - t_all, "jobs": args.jobs,
               "rows": rows, "lines": lines_all}
    (out / "summary.json").write_text(json.dumps(summary, indent=1, default=str))
    print(f"simulations: {summary['simulations_method']} by the design method, "
          f"{summary['simulations_verify']} to verify; {summary['wall_s']:.0f} s")
    return 0


def _figure(df: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from matplotlib.ticker import NullFormatter

    df = df.sort_values("viscosity_cP").reset_index(drop=True)
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(9.5, 3.8), constrained_layout=True)
    a1.plot(df["viscosity_cP"], df["clearance_mm"], "o-", color="C0")
    for _, r in df.iterrows():
        a1.annotate(f"{r['clearance_mm']:.3f} mm", (r["viscosity_cP"], r["clearance_mm"]),
                    textcoords="offset points", xytext=(6, -12), fontsize=8)
    a1.set_xscale("log")
    a1.set_xticks(df["viscosity_cP"], [f"{v:g}" for v in df["viscosity_cP"]])
    a1.xaxis.set_minor_formatter(NullFormatter())
    a1.set_xlabel("viscosity grade (mean), cP")
    a1.set_ylabel("largest nominal clearance C1 = C2, mm")
    a1.set_title("the clearance the target allows")
    x = np.arange(len(df))
    err = [df["pf_verified"] - df["pf_verified_lo"], df["pf_verified_hi"] - df["pf_verified"]]
    a2.errorbar(x, df["pf_verified"], yerr=err, fmt="o", color="C1", capsize=4,
                label="independent run at the optimum (95 %)")
    a2.scatter(x + 0.08, df["pf_method"], marker="x", color="C0", label="design method")
    a2.axhline(1e-3, color="k", lw=0.8, ls="--", label="target 1e-3")
    a2.set_xticks(x, [f"{v:g} cP" for v in df["viscosity_cP"]])
    a2.set_yscale("log")
    a2.set_ylabel("whole-cycle P_f at the optimum")
    a2.set_title("the target, verified")
    a2.legend(fontsize=7, loc="lower right")
    fig.savefig(path, dpi=130)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--out", default="results/design_ninebar")
    ap.add_argument("--grades", type=float, nargs="+", default=list(GRADES_CP),
                    help="viscosity grades (the input's mean), cP")
    ap.add_argument("--max-evaluations", type=positive_integer, default=None,
                    help="the design method's simulation budget per grade (default the "
                         "study's)")
    ap.add_argument("--verify", default="subset", choices=("subset", "mc", "auto"),
                    help="the independent run at each optimum (default subset simulation: "
                         "about 1 500 simulations at 1e-3, against 10 000 for Monte Carlo)")
    ap.add_argument("--n-per-level", type=positive_integer, default=500,
                    help="subset simulation's samples per level")
    ap.add_argument("--tradeoff", type=int, default=5,
                    help="points of the trade-off curve at the first grade (0: none)")
    ap.add_argument("--chain", action="store_true",
                    help="start each grade's surrogates from the previous grades' simulations "
                         "(fewer simulations, but every prediction over the population costs "
                         "with the training points: with 150 reused points, 41 simulations "
                         "took the time 150 took without)")
    ap.add_argument("--replot", action="store_true",
                    help="only redraw OUT/design_ninebar.png from OUT/grades.csv")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--no-progress", action="store_true")
    args = ap.parse_args(argv)
    return report_errors(run, args, ap.prog)


if __name__ == "__main__":
    sys.exit(main())
