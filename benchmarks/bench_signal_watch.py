"""What watching for signals during a kernel call costs (so that Ctrl-C and SIGTERM stop the
kernel at its next step, docs/architecture.md): interleaved A/B in one process, medians.

A: ``Integrator._run`` on the main thread without a progress bar (the kernel under
``_SignalWatcher``: two ``signal.set_wakeup_fd`` calls around it);
B: the same ``_advance`` call directly (what ``_run`` did before without a progress bar).
Both return bitwise the same arrays, which the script checks. (Running the kernel in a worker
thread instead cost 5-15 ms per call on a loaded machine: the thread hand-overs.)

    python benchmarks/bench_signal_watch.py [--scene slider-crank-lubricated] [--reps 30]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from _common import git_state


def main(argv=None) -> None:
    from mechrel.scene import load_scene
    from mechrel.simulation import make_integrator, simulate

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scene", default="slider-crank-lubricated")
    ap.add_argument("--cycles", type=int, default=1)
    ap.add_argument("--reps", type=int, default=30)
    args = ap.parse_args(argv)

    scene = load_scene(args.scene, overrides={"analysis.cycles": args.cycles})
    simulate(scene)  # compile / load the kernels
    captured = {}
    solver = make_integrator(scene)
    real = type(solver)._run

    def capture(self, system, t, y, hist, t_out, progress, log_from, n_dense, ctl, prep):
        captured["args"] = (system, t, y.copy(), hist.copy(), t_out, log_from, n_dense, prep)
        return real(self, system, t, y, hist, t_out, progress, log_from, n_dense, ctl, prep)

    type(solver)._run = capture
    try:
        simulate(scene)
    finally:
        type(solver)._run = real
    system, t, y, hist, t_out, log_from, n_dense, prep = captured["args"]
    extra = {} if prep is None else {"prep": prep}  # what _run passes (_before's result)
    ctl = np.zeros(2, dtype=np.int64)
    a_times, b_times = [], []
    for _ in range(args.reps):
        t0 = time.perf_counter()
        ra = solver._run(system, t, y.copy(), hist.copy(), t_out, None, log_from, n_dense,
                         ctl.copy(), prep)
        a_times.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        rb = solver._advance(system, t, y.copy(), hist.copy(), t_out, ctl.copy(), log_from,
                             n_dense, **extra)
        b_times.append(time.perf_counter() - t0)
        assert all(np.array_equal(p, q) for p, q in zip(ra[:3], rb[:3]))
    ma, mb = statistics.median(a_times), statistics.median(b_times)
    print(f"{args.scene}, {args.cycles} cycle(s), {solver.name}, {args.reps} interleaved reps "
          f"({git_state()}):")
    print(f"  under the signal watcher (A): median {ma * 1e3:.3f} ms")
    print(f"  direct call (B): median {mb * 1e3:.3f} ms")
    print(f"  A / B = {ma / mb:.4f}; results bitwise equal")


if __name__ == "__main__":
    main()
