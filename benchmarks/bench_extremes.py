"""What the cycle extremes cost: simulate(scene) against simulate(scene, extremes=True) on the
same scene, interleaved in one process (A, B, A, B, ...), medians of the wall time, and the
right-hand-side evaluations of each (deterministic).

    python benchmarks/bench_extremes.py [--repeats 7]
"""

from __future__ import annotations

import argparse
import os
import statistics
import time

from _common import git_state

from mechrel.scene import load_scene
from mechrel.simulation import simulate

CASES = (("four-bar", {}), ("four-bar", {"joints.B.model": "ideal"}),
         ("slider-crank-dry", {}), ("slider-crank-lubricated", {}),
         # the default study's model evaluation (its sampling tolerance; README's quick start)
         ("nine-bar-lubricated", {"solver.rtol": 1e-5, "solver.atol": 1e-8, "analysis.cycles": 2}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--scene", default=None, help="run only the cases of this scene")
    args = parser.parse_args()
    print(f"git {git_state()}, load average {os.getloadavg()[0]:.1f}")
    print("scene | rhs without | rhs with (dense 3) | points logged | wall ratio (median)")
    for name, overrides in CASES:
        if args.scene is not None and name != args.scene:
            continue
        scene = load_scene(name, overrides=overrides)
        simulate(scene)
        simulate(scene, extremes=True)  # compile and warm
        walls = {False: [], True: []}
        for _ in range(args.repeats):
            for flag in (False, True):
                t = time.perf_counter()
                res = simulate(scene, extremes=flag)
                walls[flag].append(time.perf_counter() - t)
                if flag:
                    with_rhs, points = res.stats["n_rhs"], res.stats["n_extreme_points"]
                else:
                    without_rhs = res.stats["n_rhs"]
        ratio = statistics.median(walls[True]) / statistics.median(walls[False])
        label = name + "".join(f" {k}={v}" for k, v in overrides.items())
        print(f"{label} | {without_rhs} | {with_rhs} | {points} | {ratio:.2f} "
              f"({statistics.median(walls[False]) * 1e3:.0f} ms without)")

    if args.scene in (None, "nine-bar-lubricated"):
        study_evaluation(args.repeats)


def study_evaluation(repeats: int) -> None:
    """One model evaluation of the default study (README's quick start), with and without the
    cycle extremes: MechanismModel.evaluate at the inputs' means, interleaved, medians."""
    import numpy as np

    from mechrel.study.study import load_study
    from mechrel.uq.problem.mechanism import MechanismModel

    study = load_study("nine-bar-lubricated")
    model = study.model()
    plain = MechanismModel(study.scene, dict(study.paths), output=study.output,
                           quantities=study.quantities, angle_step=study.angle_step,
                           cycles=study.cycles, overrides=dict(study.scene_overrides),
                           reference=study.reference, extremes=False)
    x = np.asarray(model.nominal, dtype=float)
    walls = {False: [], True: []}
    for m in (plain, model):
        m.evaluate(x)
    for _ in range(repeats):
        for flag, m in ((False, plain), (True, model)):
            t = time.perf_counter()
            m.evaluate(x)
            walls[flag].append(time.perf_counter() - t)
    ratio = statistics.median(walls[True]) / statistics.median(walls[False])
    print(f"default study, MechanismModel.evaluate: {ratio:.2f} with extremes "
          f"({statistics.median(walls[False]) * 1e3:.0f} ms without, "
          f"{statistics.median(walls[True]) * 1e3:.0f} ms with), load average "
          f"{os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
