"""Where a main-study sample's Python goes, timed where it runs (issue 35).

Each named function is wrapped, in the module that calls it, by a timer that adds its wall time
per call; ``evaluate_batch`` of the main study's model (``load_study("nine-bar-lubricated")``,
16 Sobol samples) then runs ``--rounds`` times after one untimed batch, and the median per
sample of each function is printed with its calls per sample. A function nested in another is
counted in both. Timed in place, a function after the 30 ms Radau kernel costs two to four
times what a warm loop of it gives (the kernel has evicted the interpreter's code and data from
the caches): this is the cost a sample pays. The wrapper adds about 1 µs per call.

Usage::

    python tools/profile_sample.py                 # the default list below
    python tools/profile_sample.py --rounds 5 \\
        mechrel.simulation.run:_window_values mechrel.integrate.radau:radau5_kernel

A name is ``module:attribute`` (``Class.method`` allowed), the module being the one whose
global the caller looks up (``mechrel.simulation.run:assemble_positions``, not
``mechrel.mechanics.kinematics:...``, for the call in ``run``).
"""

from __future__ import annotations

import argparse
import importlib
import os
import statistics
import time

DEFAULT = (
    "mechrel.uq.problem.mechanism:MechanismModel._in_steps",
    "mechrel.simulation.prepared:PreparedScene.at",
    "mechrel.scene._values:SceneValues.validate",
    "mechrel.integrate.base:Integrator._run",
    "mechrel.integrate.radau:Radau._before",
    "mechrel.integrate.radau:Radau._after",
    "mechrel.integrate.radau:radau5_kernel",
    "mechrel.integrate.radau:reduced_system",
    "mechrel.integrate.radau:_finish_reduced",
    "mechrel.simulation.run:assemble_positions",
    "mechrel.simulation.run:assemble",
    "mechrel.simulation.run:kinematic_analysis",
    "mechrel.simulation.reference:kinematic_analysis",
    "mechrel.mechanics.kinematics:_construct",
    "mechrel.simulation.run:values",
    "mechrel.simulation.reference:values",
    "mechrel.simulation.run:_extremes_of",
    "mechrel.simulation.run:_window_points",
    "mechrel.simulation.run:_window_values",
    "mechrel.simulation.run:_orbits_and_energy",
)


def _wrap(spec: str, spent: dict, calls: dict) -> None:
    module, name = spec.split(":")
    owner = importlib.import_module(module)
    parts = name.split(".")
    for p in parts[:-1]:
        owner = getattr(owner, p)
    fn = getattr(owner, parts[-1])

    def timed(*a, **kw):
        t0 = time.perf_counter()
        try:
            return fn(*a, **kw)
        finally:
            spent[spec] = spent.get(spec, 0.0) + time.perf_counter() - t0
            calls[spec] = calls.get(spec, 0) + 1

    setattr(owner, parts[-1], timed)


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("names", nargs="*", default=list(DEFAULT))
    ap.add_argument("--rounds", type=int, default=5)
    a = ap.parse_args(argv)
    for v in ("OMP_NUM_THREADS", "NUMBA_NUM_THREADS"):
        os.environ.setdefault(v, "1")
    from mechrel.study.study import load_study

    spent: dict = {}
    calls: dict = {}
    for spec in a.names:
        _wrap(spec, spent, calls)
    study = load_study("nine-bar-lubricated")
    model = study.model()
    X = study.uncertain_inputs().sample(16, "sobol", 20221014)
    model.evaluate_batch(X)  # compiled and warm
    per: dict = {spec: [] for spec in a.names}
    for _ in range(a.rounds):
        spent.clear()
        calls.clear()
        model.evaluate_batch(X)
        for spec in a.names:
            per[spec].append(spent.get(spec, 0.0) / len(X) * 1e6)
    for spec in a.names:
        print(f"{statistics.median(per[spec]):10.1f} µs  x{calls.get(spec, 0) / len(X):4.1f}  "
              f"{spec}")


if __name__ == "__main__":
    main()
