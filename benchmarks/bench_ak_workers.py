#!/usr/bin/env python
"""Active learning on the main study with one and two workers: where the wall time goes.

The default study (nine-bar-lubricated; clearances, viscosity and crank speed uncertain) at the
fixed allowables of ``bench_ak_ninebar.py`` (1.5 mm, 0.083 m/s, 12.5 m/s²; whole-cycle
P_f ≈ 2.6e-3), its ``--cycles`` setting (the analysed cycle: 2 by default; more cycles make one
simulation dearer in proportion, standing in for a costlier mechanism). For each worker count
and round, one fresh process runs ``active_learning`` (batch of 2 points per iteration, so each
of two workers gets one) with the estimator's phases timed:

``model_runs``
    wall time inside :func:`mechrel.uq.evaluate` (the simulations, dispatch and collection);
    ``first_call`` is the initial design's call, which with two workers includes starting
    them (loky spawns them on first use and keeps them for the process);
``surrogate``
    the Kriging fits, the predictions on the population, the subset runs on the surrogate,
    the population draws and the choice of the next points (the parent's serial work);

Worker counts alternate within each round (interleaved), and the medians are printed with the
load average before and after. The estimate must be bitwise the same for any worker count
(checked: ``same_pf``).

    python benchmarks/bench_ak_workers.py --rounds 3 --cycles 2 8 --json results/ak_workers.json
    python benchmarks/bench_ak_workers.py --rounds 3 --jobs 1 --before /tmp/before-ak
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
from pathlib import Path

FIXED = {"displacement": 1.5e-3, "velocity": 0.083, "acceleration": 12.5}

CHILD = r"""
import json, sys, time
import mechrel.uq.estimators.ak as ak
from mechrel.study.study import load_study
from mechrel.study.rare import whole_cycle_limit_state

jobs, cycles, seed = int(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
fixed = json.loads(sys.argv[4])
spent = {"model_runs": 0.0, "surrogate": 0.0}
calls = []

def timed(owner, name, key):
    f = getattr(owner, name)
    def w(*a, **k):
        t = time.perf_counter()
        try:
            return f(*a, **k)
        finally:
            dt = time.perf_counter() - t
            spent[key] += dt
            if key == "model_runs":
                calls.append(dt)
    setattr(owner, name, w)

timed(ak, "evaluate", "model_runs")
for owner, name in ((ak._Surrogates, "fit"), (ak._Surrogates, "predict"), (ak._Population, "grow"),
                    (ak, "_select")):
    timed(owner, name, "surrogate")
over = {"cycles": cycles}
for q, a in fixed.items():
    over.update({f"allowable.{q}.mean": a, f"allowable.{q}.std": 0.0})
study = load_study("nine-bar-lubricated", overrides=over)
model = study.model()
inputs = study.uncertain_inputs()
ls = whole_cycle_limit_state(study, model)
t0 = time.perf_counter()
c0 = time.process_time()
r = ak.active_learning(model=model, inputs=inputs, limit_state=ls, seed=seed, n_jobs=jobs,
                       progress=False)
wall = time.perf_counter() - t0
print(json.dumps({"jobs": jobs, "cycles": cycles, "wall_s": wall,
                  "parent_cpu_s": time.process_time() - c0, "pf": float(r.pf),
                  "simulations": int(r.n_evaluations), "model_runs_s": spent["model_runs"],
                  "first_call_s": calls[0] if calls else float("nan"),
                  "surrogate_s": spent["surrogate"]}))
"""


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--rounds", type=int, default=3)
    p.add_argument("--cycles", type=int, nargs="+", default=[2],
                   help="the analysed cycle (the study's `cycles`); larger: dearer simulations")
    p.add_argument("--jobs", type=int, nargs="+", default=[1, 2])
    p.add_argument("--seed", type=int, default=20221014)
    p.add_argument("--before", default=None,
                   help="another source tree (e.g. a worktree of an earlier commit): its runs "
                        "interleave with this tree's, labelled tree=before")
    p.add_argument("--json", default=None, help="write the runs and medians here")
    a = p.parse_args(argv)
    import pandas as pd

    trees = {"after": Path(__file__).resolve().parents[1]}
    if a.before:
        trees = {"before": Path(a.before).resolve(), **trees}
    rows = []
    load0 = os.getloadavg()
    for rnd in range(a.rounds):
        for cycles in a.cycles:
            for jobs in (a.jobs if rnd % 2 == 0 else a.jobs[::-1]):
                for tree, root in (trees.items() if rnd % 2 == 0 else list(trees.items())[::-1]):
                    env = {**os.environ, "PYTHONPATH": str(root / "src")}
                    out = subprocess.run([sys.executable, "-c", CHILD, str(jobs), str(cycles),
                                          str(a.seed), json.dumps(FIXED)], env=env,
                                         capture_output=True, text=True)
                    if out.returncode:
                        sys.exit(f"{tree}: jobs={jobs} cycles={cycles} failed:\n"
                                 f"{out.stderr[-3000:]}")
                    last = out.stdout.strip().splitlines()[-1]
                    row = {"tree": tree, **json.loads(last), "round": rnd}
                    rows.append(row)
                    print(row, flush=True)
    load1 = os.getloadavg()
    df = pd.DataFrame(rows)
    cols = ["wall_s", "model_runs_s", "first_call_s", "surrogate_s", "parent_cpu_s", "simulations"]
    med = df.groupby(["tree", "cycles", "jobs"])[cols].median()
    same = df.groupby(["tree", "cycles"])["pf"].nunique().eq(1)
    base = med.xs(min(a.jobs), level="jobs")["wall_s"]
    med["speedup"] = [base[(t, c)] / w for (t, c, _), w in med["wall_s"].items()]
    print(med.round(3).to_string())
    print("same P_f for every worker count:", {str(k): v for k, v in same.to_dict().items()})
    print(f"load average before {load0[0]:.2f}, after {load1[0]:.2f}")
    if a.json:
        Path(a.json).parent.mkdir(parents=True, exist_ok=True)
        doc = {"runs": rows, "medians": med.reset_index().to_dict("records"),
               "same_pf": {str(k): v for k, v in same.to_dict().items()}, "load": [load0, load1],
               "date": time.strftime("%Y-%m-%d %H:%M")}
        Path(a.json).write_text(json.dumps(doc, indent=1))


if __name__ == "__main__":
    main()
