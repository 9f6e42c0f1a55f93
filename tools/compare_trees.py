"""Two source trees side by side: bitwise equality of their simulations, and warm speed.

For a refactor of the simulator (a change that must not change a number): extract the code
before it, e.g. ``git archive main | tar -x -C /tmp/before``, and compare it with a checkout.

``bitwise``: each tree, in a process of its own (``PYTHONPATH=TREE/src``), simulates the same
cases (every embedded scene with its default solver; radau, dopri5, rk4 and scipy-radau on the
lubricated, dry and transition scenes; radau in fixed-step mode and at a loose and a tight
tolerance; with and without cycle extremes) and saves every array of each result and every
solver count (``np.savez``); then every saved array of the cases both trees ran is compared
with ``np.array_equal`` (NaN equal to NaN); an embedded scene only one tree has (a scene added
since) is listed and not compared. Wall times are left out. Any difference is printed and
makes the exit status 1.

``timing``: one ``simulate`` of a scene (default the lubricated nine-bar at its own settings;
``--settings`` adds keyword arguments as JSON, e.g. the default study's tolerances and the
cycle extremes), warm, in alternating processes on the trees (the order reversed every
round), each process the median of ``--reps`` runs after one warm-up run; prints each
process's median, the load average, and the median over ``--rounds`` rounds with its ratio to
the first tree; then the ratio of the two processes of each round (median and quartiles over
the rounds) and the ratio of the two trees' fastest runs. On a VM whose speed jumps between
processes the paired ratio and the fastest runs are steadier than the medians.

Run::

    python tools/compare_trees.py bitwise /tmp/before .
    python tools/compare_trees.py timing /tmp/before . --rounds 7 --reps 15
    python tools/compare_trees.py timing /tmp/before . --rounds 7 --reps 15 \
        --settings '{"rtol": 1e-5, "atol": 1e-8, "extremes": true}'

A cold tree compiles its kernels in its first process (minutes); run ``timing`` once with
``--rounds 1`` to warm both caches first.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

SNAPSHOT = r"""
import sys
import numpy as np
from mechrel.scene import embedded_names, load_scene
from mechrel.simulation import simulate

TRANSITION = {"joints.C1.model": "transition", "joints.C2.model": "lubricated"}
CASES = [(name, None, {}, False) for name in embedded_names()] + [
    ("nine-bar-lubricated", None, {"integrator": "radau"}, True),
    ("nine-bar-lubricated", None, {"integrator": "radau", "rtol": 3e-4}, True),
    ("nine-bar-lubricated", None, {"integrator": "radau", "rtol": 1e-9, "atol": 1e-12}, False),
    ("slider-crank-lubricated", None, {"integrator": "radau"}, True),
    ("slider-crank-lubricated", None, {"integrator": "radau", "step": 2e-5,
                                       "fixed_step": True}, False),
    ("slider-crank-lubricated", None, {"integrator": "scipy-radau"}, False),
    ("nine-bar-dry", None, {"integrator": "dopri5"}, True),
    ("nine-bar-dry", None, {"integrator": "rk4", "step": 2e-6}, False),
    ("nine-bar-dry", None, {"integrator": "radau", "rtol": 1e-4}, True),
    ("slider-crank-dry", None, {"integrator": "dopri5"}, True),
    ("slider-crank-dry", None, {"integrator": "rk4", "step": 2e-6}, True),
    ("slider-crank-dry", None, {"integrator": "radau"}, True),
    ("nine-bar", TRANSITION, {}, True),
    ("nine-bar", TRANSITION, {"integrator": "radau", "rtol": 1e-5}, False),
    ("double-pendulum", None, {"integrator": "radau"}, False),
]


def flat(prefix, obj, out):
    if hasattr(obj, "items"):
        for k, v in obj.items():
            flat(f"{prefix}/{k}", v, out)
    elif obj is None or isinstance(obj, (str, bytes)):
        out[prefix] = np.array(str(obj))
    else:
        out[prefix] = np.asarray(obj)


out = {}
for i, (name, overrides, settings, extremes) in enumerate(CASES):
    r = simulate(load_scene(name, overrides=overrides), extremes=extremes, **settings)
    p = f"{name} {settings} {'transition' if overrides else ''}"
    for f in ("time", "crank_angle", "q", "v", "a", "method", "outputs", "ideal", "orbits",
              "energy", "extremes"):
        flat(f"{p}/{f}", getattr(r, f), out)
    flat(f"{p}/stats", {k: v for k, v in r.stats.items() if "wall" not in k}, out)
    print(i, name, settings, r.stats.get("n_steps"), flush=True, file=sys.stderr)
np.savez(sys.argv[1], **out)
"""

TIMING = r"""
import json, sys, time
from mechrel.scene import load_scene
from mechrel.simulation import simulate
scene = load_scene(sys.argv[1])
settings = json.loads(sys.argv[3])
simulate(scene, **settings)
times = []
for _ in range(int(sys.argv[2])):
    t0 = time.perf_counter()
    r = simulate(scene, **settings)
    times.append(time.perf_counter() - t0)
print(json.dumps({"t": sorted(times)[len(times) // 2], "min": min(times),
                  "steps": int(r.stats["n_steps"]),
                  "rhs": int(r.stats["n_rhs"])}))
"""


def _run(tree: Path, code: str, *args: str) -> str:
    env = dict(os.environ, PYTHONPATH=str(tree / "src"))
    proc = subprocess.run([sys.executable, "-c", code, *args], env=env, capture_output=True,
                          text=True, cwd=tempfile.gettempdir())
    if proc.returncode:
        sys.exit(f"{tree}: {proc.stderr[-3000:]}")
    return proc.stdout


def bitwise(trees) -> int:
    import numpy as np

    with tempfile.TemporaryDirectory() as tmp:
        files = []
        for k, tree in enumerate(trees):
            files.append(Path(tmp) / f"{k}.npz")
            _run(tree, SNAPSHOT, str(files[-1]))
        a, b = np.load(files[0]), np.load(files[1])
        cases = [{k.split("/")[0] for k in f.files} for f in (a, b)]
        common = cases[0] & cases[1]
        keys = sorted(k for k in set(a.files) | set(b.files) if k.split("/")[0] in common)
        differ = [k for k in keys if k not in a.files or k not in b.files
                  or a[k].shape != b[k].shape
                  or not np.array_equal(a[k], b[k], equal_nan=a[k].dtype.kind in "fc")]
        values = sum(a[k].size for k in keys if k in a.files)
    for k, tree in enumerate(trees):  # an embedded scene one tree does not have
        for case in sorted(cases[k] - common):
            print(f"only in {tree}: {case} (not compared)")
    for k in differ:
        print("differs:", k)
    print(f"{len(keys)} arrays ({values} values) of {len(common)} cases compared, "
          f"{len(differ)} differ")
    return 1 if differ else 0


def timing(trees, scene: str, rounds: int, reps: int, settings: str = "{}") -> int:
    medians = {str(t): [] for t in trees}
    minima = {str(t): [] for t in trees}
    for r in range(rounds):
        for tree in (trees if r % 2 == 0 else trees[::-1]):
            d = json.loads(_run(tree, TIMING, scene, str(reps), settings)
                           .strip().splitlines()[-1])
            medians[str(tree)].append(d["t"])
            minima[str(tree)].append(d["min"])
            print(f"round {r}: {tree}: {d['t'] * 1e3:.2f} ms ({d['steps']} steps, {d['rhs']} "
                  f"right-hand sides), load {os.getloadavg()[0]:.2f}", flush=True)
    first, second = (str(t) for t in trees)
    base = statistics.median(medians[first])
    for tree, ts in medians.items():
        m = statistics.median(ts)
        print(f"{tree}: median {m * 1e3:.2f} ms over {len(ts)} rounds, {m / base:.3f}x the first")
    # The VM's speed drifts and jumps between processes; the two processes of one round run
    # back to back, so their ratio cancels what is slow to change, and the fastest run of
    # each tree is what the code can do when the machine lets it.
    paired = [b / a for a, b in zip(medians[first], medians[second])]
    if len(paired) >= 2:
        q1, _, q3 = statistics.quantiles(paired, n=4, method="inclusive")
        print(f"second / first, paired by round: median {statistics.median(paired):.3f} "
              f"(quartiles {q1:.3f}-{q3:.3f}); fastest run {min(minima[second]) * 1e3:.2f} "
              f"against {min(minima[first]) * 1e3:.2f} ms, "
              f"{min(minima[second]) / min(minima[first]):.3f}")
    return 0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("mode", choices=["bitwise", "timing"])
    ap.add_argument("trees", nargs=2, type=Path, help="two source trees (each with src/mechrel)")
    ap.add_argument("--scene", default="nine-bar-lubricated", help="timing: the scene")
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--reps", type=int, default=15)
    ap.add_argument("--settings", default="{}",
                    help='timing: keyword arguments of simulate, as JSON ({"rtol": 1e-5})')
    args = ap.parse_args(argv)
    trees = [t.resolve() for t in args.trees]
    if args.mode == "bitwise":
        return bitwise(trees)
    return timing(trees, args.scene, args.rounds, args.reps, args.settings)


if __name__ == "__main__":
    sys.exit(main())
