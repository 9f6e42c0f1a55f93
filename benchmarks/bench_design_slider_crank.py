"""Tolerance allocation on the embedded slider-crank: the whole-cycle reliability constraint
against the per-angle one (the tolerance-allocation literature's), side by side.

Model: :func:`mechrel.uq.problem.analytic.slider_crank_tolerance_model` (the embedded
``slider-crank`` scene's kinematics in closed form: crank 50 mm, rod 120 mm, 5000 rpm; it
agrees with the simulator to 1e-13), the slider's displacement error at 18° analysis angles
and its cycle extremes on a fine grid. Design variables: the crank's and the rod's tolerance
(std of a normal length), cost 1/t_crank + 1/t_rod, allowable |error| ≤ ``--allowable`` (m).
Constraint: R ≥ ``--target`` over the whole cycle, or at every analysis angle on its own.
Method ``mc`` (common random numbers, ``--n`` samples per design); each optimum is verified by
an independent Monte Carlo run of ``--n-verify`` samples, which also gives the per-angle
optimum's whole-cycle P_f.

Run: ``python benchmarks/bench_design_slider_crank.py`` (the table and the figure
docs/figures/design_slider_crank.png of docs/validation.md, "Design for reliability").
"""

from __future__ import annotations

import argparse
from pathlib import Path
import os
import time
import warnings

import pandas as pd

from mechrel.errors import EstimateWarning
from mechrel.uq import Normal, UncertainInputs, design_for_reliability
from mechrel.uq.design.figure import plot_tradeoff
from mechrel.uq.problem.analytic import slider_crank_tolerance_model


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--target", type=float, default=0.999)
    ap.add_argument("--allowable", type=float, default=1e-4)
    ap.add_argument("--n", type=int, default=40_000)
    ap.add_argument("--n-verify", type=int, default=200_000)
    ap.add_argument("--tradeoff", type=int, default=4)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--figure", default="docs/figures/design_slider_crank.png")
    args = ap.parse_args()
    model = slider_crank_tolerance_model(quantities=["displacement"], points_per_sector=16,
                                         sectors=False)
    inputs = UncertainInputs.from_specs({"crank": Normal(0.05, 20e-6),
                                         "rod": Normal(0.12, 20e-6),
                                         "offset": Normal(0.0, 1e-9)})
    variables = {"t_crank": {"kind": "std", "input": "crank", "lower": 2e-6, "upper": 2e-4},
                 "t_rod": {"kind": "std", "input": "rod", "lower": 2e-6, "upper": 2e-4}}
    common = dict(model=model, inputs=inputs, variables=variables,
                  cost="1/t_crank + 1/t_rod", allowable={"displacement": args.allowable},
                  method="mc", n=args.n, seed=args.seed, tradeoff=args.tradeoff,
                  verify={"method": "mc", "n": args.n_verify}, progress=False)
    results, rows = {}, []
    for basis in ("whole-cycle", "per-angle"):
        t0 = time.perf_counter()
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", EstimateWarning)
            r = design_for_reliability(constraints={"reliability": args.target,
                                                    "basis": basis}, **common)
        wall = time.perf_counter() - t0
        results[basis] = r
        c = r.constraints.iloc[0]
        rows.append({"constraint": basis, "t_crank_um": 1e6 * r.design["t_crank"],
                     "t_rod_um": 1e6 * r.design["t_rod"], "cost": r.cost,
                     "pf_method": c["pf"],
                     "pf_verified": f"{c['verify_pf']:.2e} [{c['verify_pf_lo']:.2e}, "
                                    f"{c['verify_pf_hi']:.2e}]",
                     "whole_cycle_pf": f"{c['whole_cycle_pf']:.2e} "
                                       f"[{c['whole_cycle_pf_lo']:.2e}, "
                                       f"{c['whole_cycle_pf_hi']:.2e}]",
                     "model_rows": r.provenance["n_evaluations"],
                     "designs": r.provenance["settings"].get("n_designs"),
                     "wall_s": round(wall, 1), "warnings": len(caught)})
        for w in caught:
            print(f"  [{basis}] warning: {w.message}")
    table = pd.DataFrame(rows).set_index("constraint")
    with pd.option_context("display.width", 200, "display.max_columns", 20):
        print(table)
    print(f"target R = {args.target}, allowable {args.allowable} m, n = {args.n} per design, "
          f"verification n = {args.n_verify}, seed {args.seed}; load {os.getloadavg()}")
    import matplotlib
    matplotlib.use("Agg")
    fig = plot_tradeoff(results["whole-cycle"], results["per-angle"],
                        labels=["whole-cycle constraint", "per-angle constraint"],
                        title="slider-crank tolerance allocation: cost against reliability")
    Path(args.figure).parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=130)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
