"""How much of the start transient is left in the analysed cycle of the default study.

The default study (``nine-bar-lubricated``) simulates two cycles and analyses the second: the
journals start centred and at rest, which is not a state of the periodic response, and the
first cycle carries that start (docs/studies.md, "Which cycle is analysed"). The film damps the
transient, faster with less damping and larger clearance. This measures, at the nominal inputs
and at the eight corners of the study's input box (each input at its 0.135 % or 99.865 %
quantile, ±3σ for a normal input), on three cycles at a tight tolerance (radau rtol 1e-9, atol
1e-12):

* the **residual** in the analysed (second) cycle: max |e₂ − e₃| / range(e₃) of the slider's
  displacement, velocity and acceleration error curves e on the 1° grid of the second and third
  cycles (the third stands for the periodic response);
* the **decay angle**: the last crank angle of the first cycle at which |e₁ − e₃| exceeds 1e-3
  of the range (the warm-up a shorter run would need for that level);
* for comparison, the **integration error** of the study's setting (radau rtol 1e-5, atol
  1e-8) on the second cycle: max |e₂(study) − e₂(tight)| / range(e₃).

A residual well below the integration error means the one-cycle warm-up costs no accuracy; a
decay angle near 360° means it cannot be shortened.

Run (≈ 1 min)::

    python benchmarks/bench_start_transient.py --json bench_start_transient.json
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import itertools  # noqa: E402
import json  # noqa: E402
import math  # noqa: E402
import sys  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy import special  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state  # noqa: E402

from mechrel.scene import with_overrides  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402
from mechrel.studies.study import load_study  # noqa: E402

QUANTITIES = ("displacement", "velocity", "acceleration")
P_LOW = float(special.ndtr(-3.0))  # 0.00135
TIGHT = {"solver.rtol": 1e-9, "solver.atol": 1e-12}
DECAY_LEVEL = 1e-3
ONE_DEGREE = math.pi / 180.0  # rad: the scene's analysis grid, in SI units


def measure(model, x, study_solver) -> dict:
    """Residual, decay angle and integration error (module docstring) at inputs ``x``."""
    values = model.scene_values(x)
    tight = simulate(with_overrides(model.scene, {**values, **TIGHT, "analysis.cycles": 3,
                                                  "analysis.sample_step_angle": ONE_DEGREE}))
    study = simulate(with_overrides(model.scene, {**values, **study_solver,
                                                  "analysis.cycles": 2,
                                                  "analysis.sample_step_angle": ONE_DEGREE}))
    per = (tight.time.size - 1) // 3
    angles = np.arange(per + 1) * 360.0 / per
    out = {"residual": {}, "decay_angle": {}, "integration_error": {}}
    for q in QUANTITIES:
        e = tight.error("slider", q)
        c1, c2, c3 = e[:per + 1], e[per:2 * per + 1], e[2 * per:]
        span = float(c3.max() - c3.min())
        out["residual"][q] = float(np.max(np.abs(c2 - c3)) / span)
        late = np.nonzero(np.abs(c1 - c3) / span > DECAY_LEVEL)[0]
        out["decay_angle"][q] = float(angles[late[-1]]) if late.size else 0.0
        s2 = study.error("slider", q)[per:]
        out["integration_error"][q] = float(np.max(np.abs(s2 - c2)) / span)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    study = load_study("nine-bar-lubricated")
    model = study.model()
    inputs = study.uncertain_inputs()
    names = list(model.input_names)
    study_solver = {k: v for k, v in study.scene_overrides.items() if k.startswith("solver.")}
    cases = [("nominal", np.asarray(model.nominal, dtype=float))]
    for signs in itertools.product((0, 1), repeat=len(names)):
        u = np.array([[P_LOW if s == 0 else 1.0 - P_LOW for s in signs]])
        x = inputs.from_unit(u)[0]
        cases.append((" ".join(f"{n}{'−' if s == 0 else '+'}" for n, s in zip(names, signs)), x))
    rows = []
    for label, x in cases:
        m = measure(model, x, study_solver)
        rows.append({"case": label, "inputs": dict(zip(names, map(float, x))), **m})
        print(label, json.dumps({k: {q: round(v, 8) for q, v in d.items()}
                                 for k, d in m.items()}), flush=True)
    print("\n| inputs | " + " | ".join(names) + " | residual in the analysed cycle (d, v, a) "
          "| decay to 1e-3 in cycle 1 (d, v, a) | integration error at the study's setting "
          "(d, v, a) |")
    print("|---|" + "---:|" * len(names) + "---|---|---|")
    for r in rows:
        vals = " | ".join(f"{v:.4g}" for v in r["inputs"].values())
        res = ", ".join(f"{r['residual'][q]:.1e}" for q in QUANTITIES)
        dec = ", ".join(f"{r['decay_angle'][q]:.0f}°" for q in QUANTITIES)
        ie = ", ".join(f"{r['integration_error'][q]:.1e}" for q in QUANTITIES)
        print(f"| {r['case']} | {vals} | {res} | {dec} | {ie} |")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "git": git_state()}, indent=1))


if __name__ == "__main__":
    main()
