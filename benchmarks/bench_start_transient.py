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
  1e-8) on the second cycle: max |e₂(study) − e₂(tight)| / range(e₃);
* the **decay angle from a warm start**: the same as the decay angle, for a first cycle that
  starts from the nominal inputs' periodic state instead of centred journals at rest (each
  journal's eccentricity and its rate at the start of the nominal's third cycle, scaled by the
  case's clearance and speed over the nominal ones, set as the scene's
  ``initial_eccentricity`` and ``initial_eccentricity_rate``; rates by central differences on
  the 1° grid). Whether a better start would let a warm-up shorter than one cycle do.

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
from mechrel.study.study import load_study  # noqa: E402

QUANTITIES = ("displacement", "velocity", "acceleration")
P_LOW = float(special.ndtr(-3.0))  # 0.00135
TIGHT = {"solver.rtol": 1e-9, "solver.atol": 1e-12}
DECAY_LEVEL = 1e-3
ONE_DEGREE = math.pi / 180.0  # rad: the scene's analysis grid, in SI units


def periodic_start(res) -> dict:
    """Each journal's eccentricity (m) and its rate (m/s) at the start of the third cycle of
    the three-cycle run ``res`` on the 1° grid (rates by central differences)."""
    per = (res.time.size - 1) // 3
    i = 2 * per
    dt = float(res.time[i + 1] - res.time[i - 1])
    return {j: (np.array([o["ex"][i], o["ey"][i]]),
                np.array([o["ex"][i + 1] - o["ex"][i - 1], o["ey"][i + 1] - o["ey"][i - 1]]) / dt)
            for j, o in res.orbits.items()}


def warm_overrides(scene, values, nominal_values, start) -> dict:
    """``initial_eccentricity`` and ``initial_eccentricity_rate`` of every clearance joint from
    the nominal's periodic ``start``, scaled by the case's clearance and cycle-driver speed
    over the nominal ones (the orbit in units of the clearance, its rate per radian of the
    crank)."""
    drv = f"drivers.{scene.analysis.cycle_driver}.speed"
    speed = values.get(drv, scene.drivers[scene.analysis.cycle_driver].speed) \
        / nominal_values.get(drv, scene.drivers[scene.analysis.cycle_driver].speed)
    out = {}
    for j, (e, rate) in start.items():
        key = f"joints.{j}.clearance"
        c = values.get(key, scene.joints[j].clearance) / nominal_values.get(
            key, scene.joints[j].clearance)
        out[f"joints.{j}.initial_eccentricity"] = [float(v) for v in c * e]
        out[f"joints.{j}.initial_eccentricity_rate"] = [float(v) for v in c * speed * rate]
    return out


def decay_angle(c1, c3, span, angles) -> float:
    """The last crank angle of ``c1`` at which it is more than DECAY_LEVEL × ``span`` from
    ``c3``."""
    late = np.nonzero(np.abs(c1 - c3) / span > DECAY_LEVEL)[0]
    return float(angles[late[-1]]) if late.size else 0.0


GRID = {"analysis.sample_step_angle": ONE_DEGREE}


def tight_run(model, x):
    """Three cycles at inputs ``x`` at the tight tolerance, on the 1° grid."""
    return simulate(with_overrides(model.scene, {**model.scene_values(x), **TIGHT,
                                                 "analysis.cycles": 3, **GRID}))


def measure(model, x, tight, study_solver, nominal_values, start) -> dict:
    """Residual, decay angles and integration error (module docstring) at inputs ``x``, whose
    :func:`tight_run` is ``tight``."""
    values = model.scene_values(x)
    study = simulate(with_overrides(model.scene, {**values, **study_solver,
                                                  "analysis.cycles": 2, **GRID}))
    warm = simulate(with_overrides(model.scene, {
        **values, **TIGHT, "analysis.cycles": 1, **GRID,
        **warm_overrides(model.scene, values, nominal_values, start)}))
    out = {"residual": {}, "decay_angle": {}, "integration_error": {}, "decay_angle_warm": {}}
    per = (tight.time.size - 1) // 3
    angles = np.arange(per + 1) * 360.0 / per
    for q in QUANTITIES:
        e = tight.error("slider", q)
        c1, c2, c3 = e[:per + 1], e[per:2 * per + 1], e[2 * per:]
        span = float(c3.max() - c3.min())
        out["residual"][q] = float(np.max(np.abs(c2 - c3)) / span)
        out["decay_angle"][q] = decay_angle(c1, c3, span, angles)
        s2 = study.error("slider", q)[per:]
        out["integration_error"][q] = float(np.max(np.abs(s2 - c2)) / span)
        out["decay_angle_warm"][q] = decay_angle(warm.error("slider", q), c3, span, angles)
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
    nominal_values = model.scene_values(cases[0][1])
    start = None
    for label, x in cases:  # the nominal first: its periodic state is the warm start
        tight = tight_run(model, x)
        start = start or periodic_start(tight)
        m = measure(model, x, tight, study_solver, nominal_values, start)
        rows.append({"case": label, "inputs": dict(zip(names, map(float, x))), **m})
        print(label, json.dumps({k: {q: round(v, 8) for q, v in d.items()}
                                 for k, d in m.items()}), flush=True)
    print("\n| inputs | " + " | ".join(names) + " | residual in the analysed cycle (d, v, a) "
          "| decay to 1e-3 in cycle 1 (d, v, a) | integration error at the study's setting "
          "(d, v, a) | decay to 1e-3 from the nominal's periodic state (d, v, a) |")
    print("|---|" + "---:|" * len(names) + "---|---|---|---|")
    for r in rows:
        vals = " | ".join(f"{v:.4g}" for v in r["inputs"].values())
        res = ", ".join(f"{r['residual'][q]:.1e}" for q in QUANTITIES)
        dec = ", ".join(f"{r['decay_angle'][q]:.0f}°" for q in QUANTITIES)
        ie = ", ".join(f"{r['integration_error'][q]:.1e}" for q in QUANTITIES)
        warm = ", ".join(f"{r['decay_angle_warm'][q]:.0f}°" for q in QUANTITIES)
        print(f"| {r['case']} | {vals} | {res} | {dec} | {ie} | {warm} |")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "git": git_state()}, indent=1))


if __name__ == "__main__":
    main()
