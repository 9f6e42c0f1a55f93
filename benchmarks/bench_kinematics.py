"""The kinematic analysis of a fully driven mechanism: in closed form, by Newton–Raphson, and
by Newton–Raphson as an earlier revision did it, side by side in one process.

The ideal mechanism's kinematic analysis runs at every output instant and, for the cycle
extremes, at every logged instant of the integration: about 860 instants per sample of the
default study. :func:`mechrel.mechanics.kinematics.kinematic_analysis` places the bodies of a
mechanism built of class-II groups in closed form (``_construct``,
:mod:`mechrel.mechanics.construction`), and solves any other by Newton–Raphson (``_kinematics``:
positions by Newton, velocities and accelerations by two more solves with the same factors).
Until git 7cb42ec the Newton analysis built the dense Φ_q, Φ and Φ_t with ``constraints()``
(a new array each call, a sine and cosine per joint end) and γ with ``gamma()``; it now takes
them from the right-hand side's allocation-free ``constraint_terms()``.

What is measured, on the embedded driven scenes (two cycles on a 1/4° grid):

* µs per instant of the closed form (``_construct``), of the shipped Newton analysis
  (``_kinematics``) and of the Newton analysis at ``--before`` (the module as it was at that
  git revision, with the ``constraints`` module of that revision, compiled in this process
  from ``git show``), interleaved over ``--repeats`` rounds, medians;
* the largest difference of Q, V, A between them, relative to the largest entry (the Newton
  analyses converge the same iterates to |Φ| ≤ 1e-12; the closed form is exact to round-off);
* the default study's instants per sample (the output grid and the logged instants of one
  sample at the nominal inputs) times the saving per instant: the saving per sample.

Run (≈ 1 min, most of it compiling the earlier version)::

    python benchmarks/bench_kinematics.py --before 7cb42ec
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import git_state, module_from_source  # noqa: E402

import mechrel.simulation.reference as reference  # noqa: E402
import mechrel.simulation.run as run  # noqa: E402
from mechrel.mechanics.constraints import constraints  # noqa: E402
from mechrel.mechanics.construction import _construct, construction  # noqa: E402
from mechrel.mechanics.kinematics import _kinematics, assemble  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.study.study import load_study  # noqa: E402

SCENES = ("nine-bar", "slider-crank", "four-bar")
ROOT = Path(__file__).resolve().parent.parent


def _module_at(rev: str, path: str, name: str, edits):
    """The module ``path`` as it was at git ``rev``, its relative imports rewritten by
    ``edits``, imported under ``name`` (:func:`_common.module_from_source`)."""
    src = subprocess.run(["git", "show", f"{rev}:{path}"], cwd=ROOT, capture_output=True,
                         text=True, check=True).stdout
    return module_from_source(src, edits, name, f"{path} at {rev}")


def earlier_kinematics(rev: str):
    """``_kinematics`` of git ``rev`` with that revision's ``constraints`` module."""
    _module_at(rev, "src/mechrel/mechanics/constraints.py", "_kin_before_constraints",
               [("from .borrow", "from mechrel.mechanics.borrow"),
                ("from .drivers", "from mechrel.mechanics.drivers"),
                ("from .joints", "from mechrel.mechanics.joints")])
    mod = _module_at(rev, "src/mechrel/mechanics/kinematics.py", "_kin_before",
                     [("from ..errors", "from mechrel.errors"),
                      ("from .constraints", "from _kin_before_constraints")])
    return mod._kinematics


def max_violation(Q, times, system) -> float:
    """Max |Φ| over the instants (m or rad), by the dense ``constraints()``."""
    return max(float(np.max(np.abs(constraints(q, t, system)[0]))) for q, t in zip(Q, times))


def per_instant(fn, args, n_instants: int) -> float:
    """µs per instant of one call of ``fn(*args)``."""
    t = time.perf_counter()
    fn(*args)
    return (time.perf_counter() - t) / n_instants * 1e6


def study_instants() -> int:
    """Instants at which one sample of the default study (nominal inputs) runs the kinematic
    analysis."""
    seen = []
    shipped = run.kinematic_analysis  # called by the run and by the reference design

    def counting(system, q0, times, **kw):
        seen.append(len(times))
        return shipped(system, q0, times, **kw)

    study = load_study("nine-bar-lubricated")
    model = study.model()
    run.kinematic_analysis = reference.kinematic_analysis = counting
    try:
        model.evaluate(np.asarray([model.nominal], dtype=float))
    finally:
        run.kinematic_analysis = reference.kinematic_analysis = shipped
    return sum(seen)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", default="7cb42ec", help="git revision to compare with")
    ap.add_argument("--repeats", type=int, default=9)
    ap.add_argument("--json", default=None)
    args = ap.parse_args(argv)
    before = earlier_kinematics(args.before)
    rows = []
    for name in SCENES:
        c = compile_scene(load_scene(name))
        system = c.ideal
        q0, _ = assemble(system, c.q_guess, 0.0)
        times = np.linspace(0.0, 2 * c.period, 2 * 1440 + 1)
        call = (q0, times, system, 1e-12, 50)
        closed = (q0, times, system, construction(system))
        new, old, con = _kinematics(*call), before(*call), _construct(*closed)  # compiles all
        assert new[4] == old[4] == con[3] == times.size  # every instant done

        def rel(x, y):
            return {lab: float(np.max(np.abs(a - b)) / np.max(np.abs(b)))
                    for lab, a, b in zip("QVA", x[:3], y[:3])}

        t_new, t_old, t_con = [], [], []
        for _ in range(args.repeats):
            t_con.append(per_instant(_construct, closed, times.size))
            t_new.append(per_instant(_kinematics, call, times.size))
            t_old.append(per_instant(before, call, times.size))
        row = {"scene": name, "instants": int(times.size),
               "us_closed_form": float(np.median(t_con)), "us_newton": float(np.median(t_new)),
               "us_before": float(np.median(t_old)), "newton_vs_before": rel(new, old),
               "closed_form_vs_newton": rel(con, new),
               "max_violation": {"closed_form": max_violation(con[0], times, system),
                                 "newton": float(new[3])}}
        rows.append(row)
        print(json.dumps(row), flush=True)
    n_study = study_instants()
    nine = rows[0]
    saving_ms = n_study * (nine["us_newton"] - nine["us_closed_form"]) / 1e3
    print(f"\n| scene | Newton at {args.before} (µs per instant) | Newton (µs) | closed form "
          "(µs) | closed form against Newton | largest difference, closed form − Newton "
          "(Q, V, A; relative) | max |Φ| closed form, Newton |")
    print("|---|---:|---:|---:|---:|---|---|")
    for r in rows:
        d = ", ".join(f"{v:.1e}" for v in r["closed_form_vs_newton"].values())
        mv = r["max_violation"]
        print(f"| {r['scene']} | {r['us_before']:.2f} | {r['us_newton']:.2f} "
              f"| {r['us_closed_form']:.2f} | {r['us_newton'] / r['us_closed_form']:.2f}× "
              f"| {d} | {mv['closed_form']:.1e}, {mv['newton']:.1e} |")
    print(f"\ndefault study: {n_study} instants per sample (nominal inputs) × "
          f"{nine['us_newton'] - nine['us_closed_form']:.2f} µs = {saving_ms:.2f} ms saved per "
          "sample by the closed form")
    print(git_state())
    if args.json:
        Path(args.json).write_text(json.dumps({"rows": rows, "study_instants": n_study,
                                               "saving_ms_per_sample": saving_ms,
                                               "before": args.before, "git": git_state()},
                                              indent=1))


if __name__ == "__main__":
    main()
