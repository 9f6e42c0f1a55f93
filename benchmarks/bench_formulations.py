"""Radau on the reduced equations against Radau on the absolute ones, at equal accuracy
(issue 14 §3).

For each scene (embedded names or TOML files; by default the two lubricated embedded scenes),
one process, warm numba cache, runs interleaved (one repeat of every setting of both
formulations of ``radau`` per round, ``--repeats`` rounds):

* the **reference**: the reduced formulation at rtol 1e-11, atol 1e-14, whose own error on
  the slider's errors is ≤ 1e-7 of their peaks (tests/test_reduced_integration.py);
* for each formulation and each rtol of the grid (atol = 1e-3 rtol, the scenes' ratio), the
  **peak deviation** (|peak − peak_ref| / peak_ref of the acceleration error of the output
  ``slider``, or of the scene's first output where it has none, or of that output itself in a
  scene without clearance joints; the first sample, fixed by
  the initial state, left out: the 1 % peak criterion of ``bench_lubricated_ninebar.py``),
  the **curve deviation** (max over the run of |e − e_ref| / peak_ref, acceleration), the
  median wall time of the whole ``simulate`` per cycle (per run for a scene without
  cycles), and the integrator's counts;
* per formulation, the **loosest setting that meets** each criterion (peak and curve within
  1 %), and the speed-up of the reduced formulation over the absolute one at that accuracy,
  side by side in the same run.

Run (≈ 2 min warm; the undriven pendulum with a lubricated hinge, ≈ 1 min more)::

    python benchmarks/bench_formulations.py --repeats 7 --json /tmp/bench_formulations.json
    python benchmarks/bench_formulations.py --repeats 7 \
        --scenes tests/data/scenes/double-pendulum-lubricated.toml double-pendulum
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

RTOLS = (3e-2, 1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 1e-6, 1e-7)
CRITERION = 0.01


def deviations(res, ref):
    """(peak deviation, curve deviation) of the acceleration error (module docstring)."""
    output = "slider" if "slider" in ref.outputs else next(iter(ref.outputs))
    if ref.scene.clearance_joints:
        e = res.error(output, "acceleration")[1:]
        er = ref.error(output, "acceleration")[1:]
    else:  # an ideal scene (the undriven double pendulum): the output itself
        e = res.outputs[output]["acceleration"][1:]
        er = ref.outputs[output]["acceleration"][1:]
    peak = float(np.max(np.abs(er)))
    return abs(float(np.max(np.abs(e))) - peak) / peak, float(np.max(np.abs(e - er))) / peak


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--scenes", nargs="+",
                    default=["nine-bar-lubricated", "slider-crank-lubricated"])
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    out = {"git": git_state(), "python": platform.python_version(),
           "load_before": os.getloadavg()[0], "repeats": args.repeats, "scenes": {}}
    for name in args.scenes:
        scene = load_scene(name)
        cycles = scene.analysis.cycles or 1  # per run where the scene has no cycles
        ref = simulate(scene, integrator="radau", rtol=1e-11, atol=1e-14,
                       formulation="reduced")
        settings = [(f, r) for r in RTOLS for f in ("absolute", "reduced")]
        rows = {}
        for f, r in settings:  # warm-up, and the accuracy of each setting
            try:
                res = simulate(scene, integrator="radau", rtol=r, atol=r * 1e-3,
                               formulation=f)
            except Exception as exc:  # noqa: BLE001 - a setting too loose to finish
                rows[f, r] = {"formulation": f, "rtol": r, "failed": str(exc)[:200]}
                continue
            pd, cd = deviations(res, ref)
            st = res.stats
            rows[f, r] = {"formulation": f, "rtol": r, "peak_dev": pd, "curve_dev": cd,
                          "steps": st["n_steps"], "rejected": st["n_rejected"],
                          "rhs": st["n_rhs"], "jacobians": st["n_jacobians"], "walls": []}
        for _ in range(args.repeats):  # interleaved rounds
            for key in settings:
                row = rows[key]
                if "failed" in row:
                    continue
                t = time.perf_counter()
                simulate(scene, integrator="radau", rtol=key[1], atol=key[1] * 1e-3,
                         formulation=key[0])
                row["walls"].append((time.perf_counter() - t) / cycles)
        for row in rows.values():
            if "walls" in row:
                row["ms_per_cycle"] = 1e3 * statistics.median(row["walls"])
        best = {}
        for crit in ("peak_dev", "curve_dev"):
            for f in ("absolute", "reduced"):
                ok = [row for (ff, _), row in rows.items()
                      if ff == f and "failed" not in row and row[crit] <= CRITERION]
                if ok:
                    best[crit, f] = min(ok, key=lambda r: r["ms_per_cycle"])
        summary = {}
        for crit in ("peak_dev", "curve_dev"):
            if (crit, "absolute") in best and (crit, "reduced") in best:
                a, r = best[crit, "absolute"], best[crit, "reduced"]
                summary[crit] = {"absolute_rtol": a["rtol"], "absolute_ms": a["ms_per_cycle"],
                                 "reduced_rtol": r["rtol"], "reduced_ms": r["ms_per_cycle"],
                                 "speedup": a["ms_per_cycle"] / r["ms_per_cycle"]}
        out["scenes"][name] = {"rows": list(rows.values()), "fastest_within_1pc": summary}
        unit = "ms per cycle" if scene.analysis.cycles else "ms per run"
        print(f"\n{scene.name} (git {out['git']}, medians of {args.repeats}, {unit})")
        print(f"| rtol | formulation | {unit} | steps (rejected) | rhs | Jacobians "
              "| peak dev | curve dev |")
        print("|---:|---|---:|---:|---:|---:|---:|---:|")
        for row in rows.values():
            if "failed" in row:
                print(f"| {row['rtol']:.0e} | {row['formulation']} | failed: "
                      f"{row['failed'][:60]} | | | | | |")
                continue
            print(f"| {row['rtol']:.0e} | {row['formulation']} | {row['ms_per_cycle']:.2f} | "
                  f"{row['steps']} ({row['rejected']}) | {row['rhs']} | {row['jacobians']} | "
                  f"{row['peak_dev']:.1e} | {row['curve_dev']:.1e} |")
        for crit, s in summary.items():
            print(f"fastest within 1 % ({crit}): absolute rtol {s['absolute_rtol']:.0e} "
                  f"{s['absolute_ms']:.2f} ms, reduced rtol {s['reduced_rtol']:.0e} "
                  f"{s['reduced_ms']:.2f} ms: {s['speedup']:.2f}x")
    out["load_after"] = os.getloadavg()[0]
    if args.json:
        for sc in out["scenes"].values():
            for row in sc["rows"]:
                row.pop("walls", None)
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
