"""The Newton-aware step cap of ``bench_floor.py`` on the reduced equations, against a fresh
copy of the shipped Radau (issue 14 §1, "step-size control that does not throw away 40 % of
its steps").

``bench_floor.py`` times its θ-cap variant (after an accepted step with contraction θ the next
step is at most ``h · 0.2/θ``; the cap doubles after a step that converged at once) against the
*shipped* kernel, which is loaded from numba's cache; a fresh copy of the same kernel runs
5–7 % faster than the cached one (docs/performance.md), so that comparison favours any variant.
Here both are compiled from the shipped source the same way (the variant by
``bench_floor._CONTROLLER_EDITS``, asserted edits), and timed interleaved, the order alternating
from round to round, on the lubricated nine-bar (whose radau runs the reduced equations): one
cycle at rtol 3e-2 (the 1 % peak criterion), 1e-3, 1e-5, 1e-7 (atol = 1e-3 rtol), and the
default study's run (two cycles at rtol 1e-5 with the cycle extremes). Time is the integrator's
wall time (median of 5 runs per round, median over the rounds); the error is the largest
deviation of the slider's three error curves from a radau rtol 1e-11 run, over that curve's
range (one cycle only).

Run (≈ 3 min, of which ≈ 1.5 compiling the two copies)::

    python benchmarks/bench_theta_cap.py --rounds 7
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state, radau_copy  # noqa: E402
from bench_floor import _CONTROLLER_EDITS  # noqa: E402
from bench_radau_controls import curve_error  # noqa: E402

import mechrel.integrate.radau as radau  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    args = ap.parse_args(argv)
    kernels = {"copy of the shipped kernel": radau_copy([], "radau_copy_theta").Radau._advance,
               "θ cap 0.2": radau_copy(_CONTROLLER_EDITS, "radau_theta_cap_only").Radau._advance}
    scene = load_scene("nine-bar-lubricated")
    study = load_scene("nine-bar-lubricated", overrides={"analysis.cycles": 2})
    ref = simulate(scene, rtol=1e-11, atol=1e-14)

    cases = [(f"one cycle, rtol {t:g}", scene, {"rtol": t, "atol": t * 1e-3})
             for t in (3e-2, 1e-3, 1e-5, 1e-7)]
    cases.append(("the study's run (2 cycles, rtol 1e-5, extremes)", study,
                  {"rtol": 1e-5, "atol": 1e-8, "extremes": True}))
    saved = radau.Radau._advance
    counts, times = {}, {(k, c[0]): [] for k in kernels for c in cases}
    try:
        for label, advance in kernels.items():  # compile, count, score
            radau.Radau._advance = advance
            for case, sc, kw in cases:
                r = simulate(sc, **kw)
                s = r.stats
                counts[label, case] = (s["n_steps"], s["n_rejected"], s["n_rhs"],
                                       curve_error(r, ref) if sc is scene else None)
        for rnd in range(args.rounds):
            order = list(kernels.items())
            if rnd % 2:
                order.reverse()
            for label, advance in order:
                radau.Radau._advance = advance
                for case, sc, kw in cases:
                    walls = [simulate(sc, **kw).stats["wall_time"] for _ in range(5)]
                    times[label, case].append(float(np.median(walls)))
    finally:
        radau.Radau._advance = saved
    names = list(kernels)
    print(f"| run | {names[0]} (ms) | {names[1]} (ms) | ratio | steps (rejected), evaluations: "
          f"copy | θ cap | error: copy / θ cap |\n|---|---:|---:|---:|---|---|---|")
    for case, _, _ in cases:
        a, b = (float(np.median(times[n, case])) * 1e3 for n in names)
        ca, cb = counts[names[0], case], counts[names[1], case]
        err = "–" if ca[3] is None else f"{ca[3]:.1e} / {cb[3]:.1e}"
        print(f"| {case} | {a:.2f} | {b:.2f} | {b / a:.3f} | {ca[0]} ({ca[1]}), {ca[2]} | "
              f"{cb[0]} ({cb[1]}), {cb[2]} | {err} |")
    print(f"git {git_state()}, load average {os.getloadavg()[0]:.2f}, {args.rounds} rounds")


if __name__ == "__main__":
    main()
