#!/usr/bin/env python
"""Active learning on the main study against a 10⁴-sample Monte Carlo, through the command line.

The default study (nine-bar-lubricated: clearances, viscosity and crank speed uncertain; the
whole-cycle event: any of its three quantities beyond its allowable anywhere in the cycle)
with fixed allowables (``--fixed``, default 1.5 mm, 0.083 m/s, 12.5 m/s², where the whole-cycle
P_f is about 3e-3: each near its quantity's 0.998 quantile), or the paper's random allowables
N(μ, (μ/3)²) scaled by ``--scale`` (their spread then dominates: P_f stays above about
3Φ(−3) ≈ 4e-3 however large the scale). Two runs of ``mechrel reliability``:

1. ``--method mc --n 10000`` in ``OUT/mc`` (its evaluations cached there: run once, then every
   other ``--scale`` costs nothing);
2. ``--method ak`` in ``OUT/ak-<scale>-<seed>`` (``--seeds`` seeds; default settings of the
   study's ``[ak]`` table over the registry's).

Printed and written to ``OUT/ninebar_ak.csv``: Monte Carlo's whole-cycle P_f and Wilson 95 %
interval, and per AK run its P_f, interval, simulations and wall time, and whether its P_f lies
inside Monte Carlo's interval.

    python benchmarks/bench_ak_ninebar.py --seeds 3 --out results/ak_ninebar
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd


FIXED = {"displacement": 1.5e-3, "velocity": 0.083, "acceleration": 12.5}


def overrides(scale: float | None) -> list[str]:
    from mechrel.study.study import load_study

    study = load_study("nine-bar-lubricated")
    out = []
    for q, (mean, std) in study.allowable.items():
        m, s = (FIXED[q], 0.0) if scale is None else (mean * scale, std * scale)
        out += ["--set", f"allowable.{q}.mean={m!r}", "--set", f"allowable.{q}.std={s!r}"]
    return out


def cli(args: list[str]) -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-m", "mechrel", "reliability", *args], check=True,
                   stdout=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main(argv=None):
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--scale", type=float, nargs="+", default=None,
                   help="the paper's random allowables times these factors (default: fixed)")
    p.add_argument("--skip-mc", action="store_true", help="only the AK runs")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--n-mc", type=int, default=10_000)
    p.add_argument("--jobs", type=int, default=2)
    p.add_argument("--out", default="results/ak_ninebar")
    p.add_argument("--mc-out", default=None, help="Monte Carlo's folder (default OUT/mc)")
    a = p.parse_args(argv)
    out = Path(a.out)
    rows = []
    for scale in a.scale or [None]:
        ov = overrides(scale)
        mc_dir = Path(a.mc_out) if a.mc_out else out / "mc"
        pf_mc = lo_mc = hi_mc = t_mc = float("nan")
        if not a.skip_mc:
            t_mc = cli(["--method", "mc", "--n", str(a.n_mc), "--jobs", str(a.jobs),
                        "--no-progress", "--out", str(mc_dir), *ov])
            wc = pd.read_csv(mc_dir / "whole_cycle.csv").set_index("quantity").loc["all"]
            pf_mc = 1 - wc["reliability"]
            lo_mc, hi_mc = 1 - wc["reliability_hi"], 1 - wc["reliability_lo"]
        for seed in range(a.seeds):
            ak_dir = out / f"ak-{'fixed' if scale is None else f'{scale:g}'}-{seed}"
            t_ak = cli(["--method", "ak", "--jobs", str(a.jobs), "--no-progress", "--seed",
                        str(20221014 + seed), "--out", str(ak_dir), *ov])
            r = pd.read_csv(ak_dir / "rare_events.csv").set_index("method").loc["ak"]
            rows.append({"scale": scale, "seed": seed, "pf_mc": pf_mc, "pf_mc_lo": lo_mc,
                         "pf_mc_hi": hi_mc, "mc_wall_s": t_mc, "pf_ak": r["pf"],
                         "pf_ak_lo": r["pf_lo"],
                         "pf_ak_hi": r["pf_hi"], "simulations_ak": int(r["n_evaluations"]),
                         "ak_wall_s": t_ak, "ak_estimator_s": r["wall_time"],
                         "inside_mc_interval": bool(lo_mc <= r["pf"] <= hi_mc)})
            print(pd.Series(rows[-1]).to_string(), flush=True)
            pd.DataFrame(rows).to_csv(out / "ninebar_ak.csv", index=False)
    print(pd.DataFrame(rows).to_string())


if __name__ == "__main__":
    main()
