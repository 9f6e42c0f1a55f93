"""Where a cold compilation of the main job's kernels goes: numba's compile time per function.

A fresh process with an empty ``NUMBA_CACHE_DIR`` simulates the short run of the default
study's scene (the lubricated nine-bar) that :func:`mechrel.warmup.warm_up` makes, in
one process, recording numba's ``numba:compile`` events; each compiled function's *self* time
(its compile time minus that of the functions compiled while it was being compiled) is
printed, largest first, with the wall time and the total. The load average moves these times
by a factor of two or more; compare trees one after the other.

Run::

    python tools/profile_compile.py [--top 25]
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile

CODE = r"""
import collections, json, sys, time
from numba.core import event
with event.install_recorder("numba:compile") as rec:
    from mechrel.scene import with_overrides
    from mechrel.simulation import simulate
    from mechrel.study.study import load_study
    scene = load_study("nine-bar-lubricated").model().scene
    a = scene.analysis
    step = a.sample_step_angle / abs(scene.drivers[a.cycle_driver].speed)
    t0 = time.perf_counter()
    simulate(with_overrides(scene, {"analysis.duration": step}))
    wall = time.perf_counter() - t0
stack, own = [], collections.Counter()
for ts, ev in rec.buffer:
    d = ev.data.get("dispatcher")
    name = f"{d.py_func.__module__}.{d.py_func.__qualname__}" if d is not None else "?"
    if ev.is_start:
        stack.append([name, ts, 0.0])
    else:
        name, start, children = stack.pop()
        own[name] += ts - start - children
        if stack:
            stack[-1][2] += ts - start
print(json.dumps({"wall": wall, "self": own.most_common()}))
"""


def main(argv=None) -> int:
    import json

    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--top", type=int, default=25)
    args = ap.parse_args(argv)
    load = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="mechrel-cold-") as cache:
        out = subprocess.run([sys.executable, "-c", CODE], check=True, capture_output=True,
                             text=True, env=dict(os.environ, NUMBA_CACHE_DIR=cache))
    d = json.loads(out.stdout.strip().splitlines()[-1])
    total = sum(t for _, t in d["self"])
    print(f"wall {d['wall']:.1f} s, compile self times {total:.1f} s in all, load before "
          f"{load:.2f}")
    for name, t in d["self"][:args.top]:
        print(f"{t:7.1f}  {name}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
