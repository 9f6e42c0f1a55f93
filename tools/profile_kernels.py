"""Profile mechrel's compiled kernels with Linux ``perf``: simulate a scene repeatedly after
describing the process's JIT code to ``perf`` in ``/tmp/perf-<pid>.map``.

Numba's machine code has no symbols ``perf`` can read. A process may list its own JIT code in
``/tmp/perf-<pid>.map`` (one ``start size name`` line per function, hexadecimal); this script
writes one entry per compiled overload of mechrel's kernel modules (its start address from
``library.get_pointer_to_function``; its size up to the next entry) plus Numba's
``NRT_incref``/``NRT_decref``, then runs the simulations. With ``--nocache`` every kernel
function is compiled in this process, so every function, the inlined-into-caller ones aside,
has its own entry; from numba's disk cache only the entry points resolve.

Run::

    perf record -o /tmp/perf.data python tools/profile_kernels.py nine-bar-lubricated \\
        --nocache --runs 1000
    perf report -i /tmp/perf.data --time 70%-100% --no-children --sort dso,sym

(``--time`` keeps the steady state: with ``--nocache`` the first part is compilation.) This is
how the reference-count traffic that ``mechrel.mechanics.borrow`` removes was found
(docs/dev/performance-log.md, "Where the targets stand").
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")

import argparse  # noqa: E402
import importlib  # noqa: E402
import math  # noqa: E402
import time  # noqa: E402

KERNEL_MODULES = ("mechrel.forces.contact", "mechrel.forces.film", "mechrel.forces.friction",
                  "mechrel.forces.joint", "mechrel.mechanics.drivers",
                  "mechrel.mechanics.joints", "mechrel.mechanics.constraints",
                  "mechrel.mechanics.applied", "mechrel.mechanics.dynamics",
                  "mechrel.mechanics.jacobian", "mechrel.mechanics.post",
                  "mechrel.mechanics.kinematics", "mechrel.integrate.events",
                  "mechrel.integrate.explicit", "mechrel.integrate.radau")


def dispatchers(modules):
    for mod in modules:
        for name in dir(mod):
            d = getattr(mod, name)
            if hasattr(d, "overloads") and getattr(d, "__module__", None) == mod.__name__:
                yield mod, name, d


def write_perf_map(modules) -> int:
    """``/tmp/perf-<pid>.map`` for every compiled overload; returns the number of entries."""
    entries = {}
    for mod, name, d in dispatchers(modules):
        for cres in d.overloads.values():
            lib = cres.library
            for symbol, label in ((cres.fndesc.mangled_name, f"{mod.__name__}.{name}"),
                                  ("NRT_incref", "NRT_incref"), ("NRT_decref", "NRT_decref")):
                try:
                    address = lib.get_pointer_to_function(symbol)
                except Exception:  # not in this library (inlined, or cached code)
                    address = 0
                if address:
                    entries[address] = label
    starts = sorted(entries)
    with open(f"/tmp/perf-{os.getpid()}.map", "w") as f:
        for i, a in enumerate(starts):
            size = starts[i + 1] - a if i + 1 < len(starts) and starts[i + 1] - a < 1 << 20 \
                else 0x4000
            f.write(f"{a:x} {size:x} {entries[a]}\n")
    return len(starts)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("scene")
    ap.add_argument("--integrator", default=None, help="default: the scene type's")
    ap.add_argument("--steps-per-degree", type=int, default=3,
                    help="rk4: h = (1 degree of the crank) / k")
    ap.add_argument("--runs", type=int, default=200)
    ap.add_argument("--nocache", action="store_true",
                    help="compile every kernel in this process (complete symbol map)")
    a = ap.parse_args(argv)
    modules = [importlib.import_module(m) for m in KERNEL_MODULES]
    if a.nocache:
        from numba.core.caching import NullCache
        for _, _, d in dispatchers(modules):
            d._cache = NullCache()
    from mechrel.scene import load_scene
    from mechrel.simulation import simulate
    scene = load_scene(a.scene)
    kw = {}
    if a.integrator == "rk4":
        speed = abs(scene.drivers[scene.analysis.cycle_driver].speed)
        kw["step"] = math.radians(1.0) / speed / a.steps_per_degree
    simulate(scene, integrator=a.integrator, **kw)  # compile or load every kernel used
    print(f"{write_perf_map(modules)} functions in /tmp/perf-{os.getpid()}.map", flush=True)
    t0 = time.perf_counter()
    integration = 0.0
    for _ in range(a.runs):
        r = simulate(scene, integrator=a.integrator, **kw)
        integration += r.stats["wall_time"]
    wall = time.perf_counter() - t0
    print(f"{a.runs} runs: {wall / a.runs:.5f} s per simulate, {integration / a.runs:.5f} s "
          f"integration; {r.stats['n_steps']} steps, {r.stats['n_rhs']} rhs evaluations")


if __name__ == "__main__":
    main()
