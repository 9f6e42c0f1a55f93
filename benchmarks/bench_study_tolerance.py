"""The main study's sampling tolerance: how far each setting's outputs are from a tight one,
against the spread the uncertain inputs cause.

The default study (``nine-bar-lubricated``: clearance, viscosity and crank speed uncertain;
slider displacement, velocity and acceleration errors at 21 crank angles of the second cycle)
is evaluated at ``--n`` samples of its inputs (scrambled Sobol' points, seed 1) with its
scene's Radau at each ``rtol`` of the grid (atol = 1e-3 rtol, the study's ratio) and at
rtol 1e-8, atol 1e-11 (the reference). For each quantity the figure is the largest
|output − reference| over samples and angles, divided by the standard deviation of the
reference outputs over the samples at that angle: the integration error as a fraction of the
spread the inputs cause (the criterion the study file states for its setting).
Also: CPU seconds per evaluation (in this process, one worker) and the formulation that ran.

Run (≈ 1–2 min warm)::

    python benchmarks/bench_study_tolerance.py --n 16 --json /tmp/bench_study_tolerance.json
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.study.study import load_study  # noqa: E402

RTOLS = (1e-3, 3e-4, 1e-4, 3e-5, 1e-5)


def outputs(rtol, X):
    """The study model's outputs at the samples ``X`` with the scene's Radau at ``rtol``, and
    the CPU seconds per evaluation."""
    study = load_study("nine-bar-lubricated",
                       scene_overrides={"solver.rtol": rtol, "solver.atol": rtol * 1e-3})
    model = study.model()
    model.evaluate(X[0])  # warm
    t = time.process_time()
    Y = np.asarray(model.evaluate_batch(X))
    return Y, (time.process_time() - t) / X.shape[0], model


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=16)
    ap.add_argument("--json")
    args = ap.parse_args(argv)
    study = load_study("nine-bar-lubricated")
    X = study.uncertain_inputs().sample(args.n, rule="sobol", seed=1)
    ref, ref_cpu, model = outputs(1e-8, X)
    index = model.output_index  # (quantity, crank angle or "max"/"min"/"max_abs")
    quantities = list(model.quantities)
    std = ref.std(axis=0, ddof=1)
    out = {"git": git_state(), "n": args.n, "load_before": os.getloadavg()[0],
           "reference_cpu_s": ref_cpu, "rows": []}
    print(f"git {out['git']}, {args.n} samples; reference rtol 1e-8: {ref_cpu * 1e3:.1f} ms "
          "CPU per evaluation")
    print("| rtol | CPU per evaluation (ms) | " + " | ".join(
        f"max error / std, {q}" for q in quantities) + " |")
    print("|---:|---:|" + "---:|" * len(quantities))
    for r in RTOLS:
        Y, cpu, _ = outputs(r, X)
        rel = np.abs(Y - ref) / np.where(std > 0, std, np.inf)
        worst = {}
        for q in quantities:
            cols = [i for i, (qq, _) in enumerate(index) if qq == q]
            worst[q] = float(rel[:, cols].max())
        out["rows"].append({"rtol": r, "cpu_s": cpu, "worst_error_over_std": worst})
        print(f"| {r:.0e} | {cpu * 1e3:.1f} | " + " | ".join(
            f"{100 * worst[q]:.2f} %" for q in quantities) + " |", flush=True)
    if args.json:
        Path(args.json).write_text(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
