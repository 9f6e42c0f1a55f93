"""Issue 14 §2: the one-off compilation of the main job's kernels on a cold cache.

What is measured
----------------
Each run is a fresh Python process with an empty ``NUMBA_CACHE_DIR`` that compiles what the
main job (``mechrel reliability``: the default study ``nine-bar-lubricated``) compiles before
its first sample, and then evaluates one sample of the study's model (which must then compile
nothing more):

* ``one process``: ``simulate`` of the short run :func:`mechrel.warmup.warm_up` makes,
  on one core: every kernel compiled one after another (the warm-up before this change);
* ``two processes``: :func:`mechrel.warmup.warm_up` itself, which hands part of the
  Radau kernel's callees and the post-processing to a helper process
  (:func:`mechrel.warmup.split_compile`), compiles the rest and then the kernel here;
* ``two processes, previous shares`` (``--modes two-previous``): the same with the absolute
  formulation's shares of the helper and this process before they were balanced (the helper
  also compiled the kinematic analysis, and this process waited for it; the clearance
  Jacobian did not wait for the helper's right-hand side), set in the run's process before
  the warm-up. Since the default study's Radau integrates the reduced equations (which have
  their own shares, ``mechrel.warmup.SHARES``), this mode no longer changes its run.

The runs alternate (``--rounds`` rounds of ``--modes``), one at a time; each reports its
wall time, the CPU time of the process and its children, the load average before it, the
compile time of the first sample after it (0 when nothing was left), the CPU time of this
process and of the helper during the compilation (with two free cores the wall time is about
the larger of the two, plus what this process waits for the helper; on a loaded machine the
wall time says how busy it was), and the functions numba compiled for more than one type
signature (a cache file ``NAME-LINE.py311.2.nbc``). The machine's other jobs are stated by
the load average; medians over rounds.

Run::

    python benchmarks/bench_cold_start.py --rounds 2 --json /tmp/cold.json
    python benchmarks/bench_cold_start.py --rounds 3 --modes two-previous two
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from _common import git_state  # noqa: E402  (benchmarks/ is sys.path[0])

CODE = r"""
import json, resource, sys, time
t0 = time.perf_counter()
from mechrel.study.study import load_study
from mechrel.scene import with_overrides
import mechrel.warmup as kc
study = load_study("nine-bar-lubricated")
model = study.model()
scene = model.scene
t1 = time.perf_counter()
r0 = resource.getrusage(resource.RUSAGE_SELF)
if sys.argv[1] == "one":
    from mechrel.simulation import simulate
    a = scene.analysis
    step = a.sample_step_angle / abs(scene.drivers[a.cycle_driver].speed)
    simulate(with_overrides(scene, {"analysis.duration": step}))
else:
    if sys.argv[1] == "two-previous":
        kc.SHARES["absolute"] = kc.Shares(("rhs", "newton", "kinematics", "post_process"),
                                          ("fd_jacobian", "clearance_jacobian"), {},
                                          ("rhs", "newton", "kinematics"))
    kc.warm_up(scene, progress=False, file=open("/dev/null", "w"))
t2 = time.perf_counter()
r1 = resource.getrusage(resource.RUSAGE_SELF)
import psutil
psutil.wait_procs(psutil.Process().children(recursive=True), timeout=600)  # the helper's rest
rc = resource.getrusage(resource.RUSAGE_CHILDREN)
x = study.uncertain_inputs().sample(2, "sobol", 1)[0]
model.evaluate(x)
t3 = time.perf_counter()
model.evaluate(x)
t4 = time.perf_counter()
print(json.dumps({"import_and_load": t1 - t0, "compile": t2 - t1,
                  "cpu_own": r1.ru_utime + r1.ru_stime - r0.ru_utime - r0.ru_stime,
                  "cpu_helper": rc.ru_utime + rc.ru_stime,
                  "first_sample_extra": (t3 - t2) - (t4 - t3)}))
"""


LABELS = {"one": "one process", "two": "two processes",
          "two-previous": "two processes, previous shares"}


def one_run(mode: str) -> dict:
    with tempfile.TemporaryDirectory(prefix="mechrel-cold-") as cache:
        env = dict(os.environ, NUMBA_CACHE_DIR=cache)
        load = os.getloadavg()
        t0 = time.perf_counter()
        out = subprocess.run([sys.executable, "-c", CODE, mode], env=env, check=True,
                             capture_output=True, text=True)
        wall = time.perf_counter() - t0
        d = json.loads(out.stdout.strip().splitlines()[-1])
        dup = sorted(p.name for p in Path(cache).rglob("*.2.nbc"))
    d.update(mode=mode, wall=wall, load_before=load[0], duplicate_signatures=dup)
    return d


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=2)
    ap.add_argument("--json", default=None)
    ap.add_argument("--modes", nargs="+", choices=list(LABELS), default=["one", "two"])
    args = ap.parse_args(argv)
    runs = []
    for _ in range(args.rounds):
        for mode in args.modes:
            d = one_run(mode)
            runs.append(d)
            print(json.dumps({k: (round(v, 2) if isinstance(v, float) else v)
                              for k, v in d.items()}), flush=True)
    print("\n| warm-up | compile, wall (s) | CPU s, this process | CPU s, helper | first sample, "
          "compile left (s) | load before |")
    print("|---|---|---|---|---|---|")
    for mode in args.modes:
        label = LABELS[mode]
        rs = [d for d in runs if d["mode"] == mode]

        def med(key, rs=rs):
            return statistics.median(d[key] for d in rs)

        each = ", ".join(f"{d['compile']:.1f}" for d in rs)
        loads = ", ".join(f"{d['load_before']:.1f}" for d in rs)
        print(f"| {label} | {med('compile'):.1f} ({each}) | {med('cpu_own'):.1f} | "
              f"{med('cpu_helper'):.1f} | {med('first_sample_extra'):.2f} | {loads} |")
    print(f"{git_state()}; {os.cpu_count()} cores")
    if args.json:
        Path(args.json).write_text(json.dumps({"runs": runs, "git": git_state()}, indent=1))


if __name__ == "__main__":
    main()
