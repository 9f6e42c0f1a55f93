"""What a compiled call costs from Python: numba's dispatch of the mechanism's arrays.

A sample of a study calls compiled code from Python a few dozen times; each call that takes the
mechanism (:class:`~mechrel.mechanics.system.System`, a named tuple of 41 arrays) pays numba's
dispatch, which types and unboxes every argument before the compiled code runs. This script
times, warm, in one process, interleaved over ``--rounds`` rounds (median of the rounds'
per-call times, each round ``--calls`` calls):

``system``
    A compiled function that does nothing, called with the main study's ``System``.
``plain_tuple``
    The same with the same 41 arrays as a plain tuple.
``one_array``
    The same with one of its arrays.
``violations_at``
    :func:`~mechrel.mechanics.constraints.violations_at` on two rows of a kinematic analysis
    (what a closed-form kinematic analysis computed in a call of its own until 2026-11-29).

Run::

    python benchmarks/bench_dispatch.py              # µs per call, as JSON
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import json  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402


@njit
def _nothing(x):
    return 0


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--calls", type=int, default=20000)
    a = ap.parse_args(argv)

    from mechrel.mechanics.constraints import violations_at
    from mechrel.mechanics.kinematics import assemble_positions, kinematic_analysis
    from mechrel.mechanics.system import compile_scene
    from mechrel.scene import load_scene

    compiled = compile_scene(load_scene("nine-bar-lubricated"))
    system = compiled.ideal
    q0 = assemble_positions(system, compiled.q_guess, 0.0)
    times = np.linspace(0.0, 1.0, 41)
    Q = kinematic_analysis(system, q0, times)[0]
    rows = np.array([0, times.size - 1], dtype=np.int64)
    plain = tuple(system)
    cases = {"system": lambda: _nothing(system), "plain_tuple": lambda: _nothing(plain),
             "one_array": lambda: _nothing(system.mass),
             "violations_at": lambda: violations_at(Q, times, rows, system)}
    for f in cases.values():  # compiled and warm
        f()
    per_call: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(a.rounds):
        for name, f in cases.items():
            t0 = time.perf_counter()
            for _ in range(a.calls):
                f()
            per_call[name].append((time.perf_counter() - t0) / a.calls * 1e6)
    print(json.dumps({"us_per_call": {k: statistics.median(v) for k, v in per_call.items()},
                      "arrays_in_system": len(system), "load": os.getloadavg()[0]}, indent=1))


if __name__ == "__main__":
    main()
