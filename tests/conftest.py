"""Settings for the whole test session.

Hypothesis draws its examples from a seed derived from each test (``derandomize=True``), so
that the default run, the CI's included, checks the same examples every time: a property
test passes or fails for the code, not for the day's draw. Random exploration, with the
example database, is the ``explore`` profile: ``HYPOTHESIS_PROFILE=explore python -m pytest``
(an example it finds that fails goes into a test as an explicit ``@example``).

With several workers (``-n 2``, the default) and a cold numba cache (a fresh install, or kernel
sources changed), the controller compiles the integrators' kernels once before the workers
start (:func:`pytest_sessionstart`): otherwise the first test of each worker that runs Radau
compiles the same kernel as the other worker's, at the same time.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import time

import pytest
from hypothesis import settings

settings.register_profile("default", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "default"))


# The kernels the suite runs, one (scene, integrator, overrides) per compiled overload, longest
# first: Radau on the absolute and on the reduced equations (each also compiles the kinematic
# analysis and the assembly), DOPRI5, RK4. Compiled from a cold cache on two idle cores
# (2026-11-29): 102, 128, 24 and 23 s one after the other, 240 s two at a time.
_KERNELS = (
    ("slider-crank-lubricated", None, {"solver.formulation": "absolute"}),
    ("nine-bar-lubricated", None, {}),
    ("slider-crank-dry", "dopri5", {}),
    ("slider-crank-dry", "rk4", {"solver.step": 1e-5}),
)
_COMPILE = ("import json, sys; from mechrel.scene import load_scene; "
            "from mechrel.warmup import warm_up; name, integrator, overrides = "
            "json.loads(sys.argv[1]); warm_up(load_scene(name, overrides=overrides), "
            "integrator=integrator, progress=False, file=sys.stdout)")


@pytest.hookimpl(tryfirst=True)  # before pytest-xdist starts its workers
def pytest_sessionstart(session):
    """On a cold kernel cache with ``-n N`` (N >= 2), compile the kernels of :data:`_KERNELS`
    that are cold, N at a time in processes of their own (``mechrel.warmup.warm_up``), so that
    the workers load them from the cache. The numbers do not depend on it (the same functions
    compiled for the same types); a job that fails is reported and left to the tests."""
    config = session.config
    workers = getattr(config.option, "numprocesses", None)
    if hasattr(config, "workerinput") or not isinstance(workers, int) or workers < 2 \
            or config.option.collectonly:
        return
    from mechrel.scene import load_scene
    from mechrel.warmup import cold_entries

    jobs = [(name, integrator, overrides) for name, integrator, overrides in _KERNELS
            if cold_entries(load_scene(name, overrides={
                **overrides, **({"solver.integrator": integrator} if integrator else {})}))]
    if not jobs:
        return
    report = config.pluginmanager.get_plugin("terminalreporter")
    say = report.write_line if report is not None else print
    say(f"numba cache cold: compiling {len(jobs)} kernel sets, {workers} at a time, before "
        "the workers start")
    env = {**os.environ, "PYTHONSAFEPATH": "1"}
    start, running = time.perf_counter(), []
    try:
        while jobs or running:
            while jobs and len(running) < workers:
                job = jobs.pop(0)
                err = tempfile.TemporaryFile("w+")  # a pipe could fill and stall the job
                running.append((job, err, subprocess.Popen(
                    [sys.executable, "-c", _COMPILE, json.dumps(job)], env=env,
                    stdout=subprocess.DEVNULL, stderr=err, text=True)))
            time.sleep(0.1)
            for job, err, proc in [r for r in running if r[2].poll() is not None]:
                running.remove((job, err, proc))
                err.seek(0)
                lines = err.read().strip().splitlines()
                err.close()
                if proc.returncode:
                    say(f"compiling {job}: failed "
                        f"({lines[-1] if lines else proc.returncode}); the tests compile it")
    finally:  # interrupted: the jobs started here end with it
        for _, err, proc in running:
            proc.kill()
            proc.wait()
            err.close()
    say(f"kernels compiled in {time.perf_counter() - start:.0f} s")
