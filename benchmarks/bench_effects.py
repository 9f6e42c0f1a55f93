"""What each declared effect costs: the nine-bar as ideal (kinematics vs dynamics), with dry
clearance joints with and without friction, lubricated, and transition joints.

    python benchmarks/bench_effects.py [--repeats 5] [--rhs-time 0.5] [--out effects.md]

For each scene, one revolution of crank 1 (2/3 s at 3π rad/s), output every degree:

* ``wall/cycle``: median wall time of ``simulate`` over ``--repeats`` warm runs (every kernel
  compiled and cached by an untimed first run), and the minimum, one process, BLAS and Numba
  threads limited to 1;
* ``steps``, ``rhs``: accepted steps and right-hand-side evaluations of the integrator the
  scene type uses by default (``mechrel.simulation.DEFAULT_SOLVERS``);
* ``µs/rhs``: cost of one evaluation of ``mechrel.mechanics.dynamics.rhs_into`` with one
  workspace, timed directly inside a compiled loop (what the compiled kernels pay; no Python
  dispatch, no allocation), averaged over
  the states of the simulated cycle (so dry scenes mix contact and free-flight states in the
  proportion they occur). ``µs/call (Py)`` is the same called from Python, what SciPy's
  LSODA/Radau/BDF wrappers pay per evaluation (dispatch and unboxing of the System tuple);
  ``of which forces``: ``applied_forces_trig`` alone with the bodies' sin/cos (gravity and the
  clearance-joint force laws)
  at the same states, the part of the rhs that depends on the declared effects (the rest is
  the constraint solve).
  All three are the minimum over ``--rhs-rounds`` interleaved chunks of
  ``--rhs-time / --rhs-rounds`` seconds (the median is printed too).

Each round times every case once (first the simulate rounds, then the rhs rounds), so that a
load change on a shared machine hits all cases alike; minima over the rounds estimate the
intrinsic cost.

The ideal nine-bar's rhs is its constraint solve alone (16 × 16 Schur complement, no clearance
joints); the increments of the other rows are the force laws.
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import platform  # noqa: E402
import statistics  # noqa: E402
import time  # noqa: E402

import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

from mechrel.mechanics.applied import applied_forces_trig  # noqa: E402
from mechrel.mechanics.borrow import borrowed  # noqa: E402
from mechrel.mechanics.dynamics import N_WORK, make_workspace, rhs, rhs_into  # noqa: E402
from mechrel.mechanics.joints import body_trig  # noqa: E402
from mechrel.mechanics.system import compile_scene  # noqa: E402
from mechrel.scene import load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402

BOTH = ("C1", "C2")
CASES = [  # (label, scene, overrides, simulate kwargs)
    ("ideal, kinematics", "nine-bar", {}, {}),
    ("ideal, dynamics", "nine-bar", {}, {"method": "dynamics"}),
    ("dry, c_f = 0.05", "nine-bar-dry", {}, {}),
    ("dry, c_f = 0", "nine-bar-dry", {f"joints.{j}.friction.coefficient": 0.0 for j in BOTH}, {}),
    ("lubricated", "nine-bar-lubricated", {}, {}),
    ("lubricated, LSODA", "nine-bar-lubricated", {}, {"integrator": "lsoda"}),
    ("transition", "nine-bar", {f"joints.{j}.model": "transition" for j in BOTH}, {}),
]


# Not cached: numba's cache of a caller keeps its own copy of the callees' compiled code and is
# not invalidated when they change (numba issue #6845; mechrel's kernel-cache guard covers only
# the package's own kernels), so a cached loop would time an old right-hand side.
@njit(cache=False)
def _rhs_loop(T, Y, hist, sys, reps):
    """Evaluate ``rhs_into`` (the kernels' form: one workspace, no allocation) at every state
    ``reps`` times; returns a checksum (keeps the calls)."""
    s = 0.0
    ws = make_workspace(sys)
    out = np.empty(Y.shape[1])
    for _ in range(reps):
        for k in range(Y.shape[0]):
            rhs_into(T[k], Y[k], hist, sys, ws, out)
            s += out[0]
    return s


@njit(cache=False)
def _forces_loop(T, Y, hist, sys, reps):
    """Gravity + clearance forces (``applied_forces``) at every state ``reps`` times, on the
    borrowed System and Workspace as inside the right-hand side."""
    n = sys.mass.shape[0]
    s = 0.0
    Q = np.zeros(n)
    ws0 = make_workspace(sys)
    sys, ws = borrowed((sys, ws0))
    for _ in range(reps):
        for k in range(Y.shape[0]):
            Q[:] = 0.0
            body_trig(Y[k, :n], ws.cs, ws.sn)  # shared with the constraint terms in the rhs
            p, _ = applied_forces_trig(T[k], Y[k, :n], Y[k, n:2 * n], hist, sys, Q, ws.cs,
                                       ws.sn, ws.gap, ws.gaprate)
            s += p + Q[0]
    s += ws0.cs[0]  # ws0 owns the workspace until here
    return s


class Case:
    """One scene: its warm result, the system its rhs runs on and the states of its cycle."""

    def __init__(self, label, name, overrides, kwargs, chunk):
        self.label, self.kwargs = label, kwargs
        self.scene = load_scene(name, overrides=overrides)
        self.res = simulate(self.scene, **kwargs)  # compile / warm the cache
        self.walls, self.compiled, self.python, self.forces = [], [], [], []
        self.system = None
        if self.res.method == "dynamics":
            cs = compile_scene(self.scene)
            self.system = cs.dynamic if self.scene.clearance_joints else cs.ideal
            self.T = np.ascontiguousarray(self.res.time)
            self.Y = np.ascontiguousarray(np.concatenate(
                [self.res.q, self.res.v, np.zeros((self.T.size, N_WORK))], axis=1))
            assert self.Y.shape[1] == 2 * self.system.mass.size + N_WORK
            self.hist = np.zeros(self.system.n_contacts)
            _rhs_loop(self.T[:2], self.Y[:2], self.hist, self.system, 1)
            _forces_loop(self.T[:2], self.Y[:2], self.hist, self.system, 1)
            self.reps = 1
            while True:  # calibrate a chunk of about ``chunk`` seconds
                t0 = time.perf_counter()
                _rhs_loop(self.T, self.Y, self.hist, self.system, self.reps)
                if time.perf_counter() - t0 > 0.5 * chunk:
                    break
                self.reps *= 2
            self.chunk = chunk

    def round(self):
        """One timed simulate."""
        t0 = time.perf_counter()
        simulate(self.scene, **self.kwargs)
        self.walls.append(time.perf_counter() - t0)

    def rhs_round(self):
        """One compiled chunk, one chunk of applied_forces and one Python chunk of rhs calls."""
        if self.system is None:
            return
        t0 = time.perf_counter()
        _rhs_loop(self.T, self.Y, self.hist, self.system, self.reps)
        self.compiled.append((time.perf_counter() - t0) / (self.reps * self.T.size) * 1e6)
        t0 = time.perf_counter()
        _forces_loop(self.T, self.Y, self.hist, self.system, self.reps)
        self.forces.append((time.perf_counter() - t0) / (self.reps * self.T.size) * 1e6)
        n_py = 0
        t0 = time.perf_counter()
        while time.perf_counter() - t0 < self.chunk:
            for k in range(self.T.size):
                rhs(self.T[k], self.Y[k], self.hist, self.system)
            n_py += self.T.size
        self.python.append((time.perf_counter() - t0) / n_py * 1e6)

    def row(self):
        st = self.res.stats
        cycles = self.scene.analysis.cycles
        wall = (statistics.median(self.walls) / cycles, min(self.walls) / cycles)
        if self.system is None:
            return (self.label, "kinematic analysis", *wall, st["n_steps"], None, None, None,
                    None)
        return (self.label, st["integrator"], *wall, st["n_steps"], st["n_rhs"],
                min(self.compiled), min(self.forces), min(self.python))


def bench(repeats, rhs_seconds, rhs_rounds):
    """Rounds interleave the cases, so that the load of a shared machine hits all alike."""
    cases = [Case(*c, chunk=rhs_seconds / rhs_rounds) for c in CASES]
    for r in range(repeats):
        for case in cases:
            case.round()
        print(f"simulate round {r + 1}/{repeats}", flush=True)
    for _ in range(rhs_rounds):
        for case in cases:
            case.rhs_round()
    for case in cases:
        if case.system is not None:
            print(f"  {case.label}: µs/rhs compiled min {min(case.compiled):.3g} median "
                  f"{statistics.median(case.compiled):.3g}; Python min {min(case.python):.3g} "
                  f"median {statistics.median(case.python):.3g}")
    return [case.row() for case in cases]


def table(rows):
    out = ["| nine-bar, 1 cycle | method | wall/cycle (s), median | min | steps | rhs evals "
           "| µs/rhs (compiled) | of which forces | µs/rhs called from Python |",
           "|---|---|---|---|---|---|---|---|---|"]
    for label, method, med, mn, steps, nrhs, us, us_f, us_py in rows:
        def f(x, fmt):
            return "–" if x is None else format(x, fmt)
        out.append(f"| {label} | {method} | {med:.3g} | {mn:.3g} | {steps} | {f(nrhs, 'd')} "
                   f"| {f(us, '.3g')} | {f(us_f, '.2g')} | {f(us_py, '.3g')} |")
    return "\n".join(out)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=5)
    ap.add_argument("--rhs-time", type=float, default=2.0,
                    help="seconds spent timing rhs per scene and per calling mode (split over "
                         "the rhs rounds)")
    ap.add_argument("--rhs-rounds", type=int, default=60,
                    help="interleaved rounds of rhs timing; short chunks make it likely that "
                         "some run unloaded on a shared machine, and the minimum is reported")
    ap.add_argument("--out", default=None, help="write the markdown table here too")
    args = ap.parse_args(argv)

    import numba
    import scipy

    head = (f"Machine: {platform.processor() or platform.machine()}, {os.cpu_count()} cores "
            f"(NUMBA_NUM_THREADS={os.environ['NUMBA_NUM_THREADS']}); Python "
            f"{platform.python_version()}, NumPy {np.__version__}, SciPy {scipy.__version__}, "
            f"Numba {numba.__version__}; wall time: median and minimum of {args.repeats} "
            f"interleaved warm runs; rhs cost: minimum over {args.rhs_rounds} interleaved "
            "chunks.")
    rows = bench(args.repeats, args.rhs_time, args.rhs_rounds)
    text = head + "\n\n" + table(rows) + "\n"
    print()
    print(text)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            fh.write(text)


if __name__ == "__main__":
    main()
