"""The one-off compilation of a cold kernel cache is announced, with its progress."""

from __future__ import annotations

import io
import json

import pytest

import mechrel.warmup as kc
from mechrel.scene import load_scene


def test_compiled_kernels_are_recognised_as_warm():
    from mechrel.simulation import simulate

    scene = load_scene("slider-crank-dry", overrides={"analysis.cycles": 0.01})
    simulate(scene)  # compiled (or loaded from the cache) in this process now
    assert kc.is_compiled("dopri5") and kc.is_compiled("kinematics")
    assert kc.cold_entries(scene) == []
    out = io.StringIO()
    assert kc.warm_up(scene, file=out) == 0.0 and out.getvalue() == ""  # silent when warm


def test_a_cold_cache_is_announced_and_its_time_recorded(monkeypatch, tmp_path):
    # a cold cache simulated by the check (a real cold compile takes minutes): warm_up says
    # what it does and how long it takes, shows the elapsed time, and records the time taken
    times = tmp_path / "kernel-compile-seconds.json"
    monkeypatch.setattr(kc, "is_compiled", lambda entry, formulation=None: False)
    monkeypatch.setattr(kc, "_times_file", lambda: times)
    scene = load_scene("slider-crank-lubricated")
    assert kc.cold_entries(scene) == ["kinematics", "radau"]
    out = io.StringIO()
    spent = kc.warm_up(scene, file=out)
    text = out.getvalue()
    expected = kc.DEFAULT_COMPILE_SECONDS["kinematics"] + kc.DEFAULT_COMPILE_SECONDS["radau"]
    assert f"compiling simulation kernels, once — about {expected:.0f} s" in text
    assert f"/{expected:.0f} s" in text  # the bar's total: the expected seconds
    recorded = json.loads(times.read_text())
    assert set(recorded) == {"kinematics", "radau"}
    assert abs(sum(recorded.values()) - spent) < 0.2  # shared out, rounded to 0.1 s each
    # the next announcement uses this machine's measured time
    out = io.StringIO()
    kc.warm_up(scene, progress=False, file=out)
    assert out.getvalue().startswith(
        f"compiling simulation kernels, once — about {sum(recorded.values()):.0f} s")


def test_a_compilation_past_its_estimate_says_so_and_keeps_counting(monkeypatch, tmp_path):
    # the estimate is this machine's last time; under load the compilation takes longer, and
    # the bar stood at N/N for minutes: past N it says so and its total follows the elapsed time
    import time

    import mechrel.simulation

    times = tmp_path / "kernel-compile-seconds.json"
    times.write_text(json.dumps({"kinematics": 0.6, "radau": 0.6}))
    monkeypatch.setattr(kc, "is_compiled", lambda entry, formulation=None: False)
    monkeypatch.setattr(kc, "_times_file", lambda: times)
    monkeypatch.setattr(mechrel.simulation, "simulate", lambda scene: time.sleep(2.2))
    monkeypatch.setattr(kc, "split_compile", lambda scene: set())  # the rest of the work
    out = io.StringIO()
    spent = kc.warm_up(load_scene("slider-crank-lubricated"), file=out)
    text = out.getvalue()
    assert spent >= 2.2
    assert "compiling simulation kernels, once — about 1 s, taking longer (a busy machine?)" \
        in text
    assert "/3 s" in text  # the total follows the elapsed time (2.2 s, rounded up)


def test_the_stiff_kernels_callees_compile_in_a_helper_process():
    # on a warm cache the helper loads each job's kernel from the cache and reports it; on a
    # cold one it compiles them while this process compiles its own share (the time it saves
    # is measured in benchmarks/bench_cold_start.py, not here)
    scene = load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.01})
    done = kc.split_compile(scene)
    shares = kc._shares(scene)
    assert shares == kc.SHARES["reduced"]  # the scene's Radau integrates the reduced equations
    assert set(shares.wait_for) <= done <= set(shares.helper)
    with pytest.raises(ValueError, match="unknown compile job 'nope'"):
        kc._compile_job("nope", scene)


@pytest.mark.parametrize("formulation", ["absolute", "reduced"])
def test_own_jobs_wait_for_the_helper_jobs_they_call(monkeypatch, formulation):
    # numba loads a callee from the on-disk cache only if the helper has put it there: an own
    # job that calls a helper's function (the clearance Jacobian calls rhs_into) must start
    # after the helper reported it, or it compiles it a second time; and split_compile returns
    # only when the jobs the kernel needs are reported. A fake helper reports its jobs 0.3 s
    # apart; the order of events is recorded
    import subprocess
    import threading
    import time

    events = []
    lock = threading.Lock()

    def note(what):
        with lock:
            events.append(what)

    class FakeHelper:
        def __init__(self, args, **kw):
            self.jobs = [a for a in args if a in shares.helper]
            assert tuple(self.jobs) == shares.helper
            self.stdin = io.StringIO()
            self.stdout = self._report()
            self.returncode = None

        def _report(self):
            for name in self.jobs:
                time.sleep(0.3)
                note(f"helper:{name}")
                yield name + "\n"

        def wait(self, timeout=None):
            return 0

    shares = kc.SHARES[formulation]
    monkeypatch.setattr(kc, "_shares", lambda scene: shares)
    monkeypatch.setattr(subprocess, "Popen", FakeHelper)
    monkeypatch.setattr(kc, "_compile_job", lambda name, scene: note(f"own:{name}"))
    kc.split_compile(load_scene("slider-crank-lubricated"))
    done_at = len(events)
    for own, needs in shares.needs.items():
        for need in needs:
            assert events.index(f"helper:{need}") < events.index(f"own:{own}"), events
    for need in shares.wait_for:  # reported before split_compile returned
        assert events.index(f"helper:{need}") < done_at, events
    # jobs without needs do not wait: the first own job starts before the helper's first report
    assert events[0] == f"own:{shares.own[0]}", events
    assert shares.needs["clearance_jacobian"] == ("rhs",)
    # every own job that calls the right-hand side as a function waits for it
    if formulation == "reduced":
        assert all(shares.needs[j] == ("rhs",) for j in ("newton", "fd_jacobian"))


# compiles the Radau kernel's jobs in fresh processes (about a minute on two cores)
@pytest.mark.slow
def test_the_compile_jobs_compile_the_types_the_kernel_passes():
    # a job compiled for other argument types than the Radau kernel passes would be compiled
    # a second time by the kernel (no gain, and twice the work). A kernel loaded from the
    # cache does not look its callees up again, so the kernel is compiled afresh here (an
    # uncached copy, for the signature a simulation called it with): its typing resolves every
    # callee for the types it passes, which must be those the jobs compiled (the test takes
    # about 10 s: the kernel's own body)
    import numba

    from mechrel.integrate import radau
    from mechrel.mechanics.reduced import reduced_fast_jacobian
    from mechrel.simulation import simulate

    # the scene's Radau integrates the reduced equations: the clearance-Jacobian job
    # compiles their fast part (the absolute one's, clearance_jacobian, is not called)
    dispatchers = {"newton": radau._solve_collocation, "fd_jacobian": radau.fd_jacobian,
                   "clearance_jacobian": reduced_fast_jacobian}
    shares = kc.SHARES["reduced"]
    assert set(dispatchers) | {"rhs", "start", "kinematics", "expand", "post_process"} \
        == set(shares.helper) | set(shares.own)
    scene = load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.01})
    simulate(scene)
    # the reduced state before the kernel and the expansion after it: the job compiles the
    # types the simulation passed them (one signature each, not a second one)
    from mechrel.mechanics.reduced import _reduced_state

    around = (_reduced_state, radau._finish_reduced)
    before = [set(d.signatures) for d in around]
    kc._compile_job("expand", scene)
    assert [set(d.signatures) for d in around] == before and all(before)
    for name in dispatchers:
        kc._compile_job(name, scene)
    jobs = {name: set(d.signatures) for name, d in dispatchers.items()}
    # only the reduced formulation's signatures: the jobs are its shares, and an absolute
    # kernel an earlier test loaded from the cache (the undriven double pendulum's radau
    # with formulation="absolute") has callees of other types that no reduced job compiles
    from mechrel.mechanics.reduced import ReducedSystem

    fresh = numba.njit(radau.radau5_kernel.py_func)
    for signature in radau.radau5_kernel.signatures:
        if getattr(signature[0], "instance_class", None) is ReducedSystem:
            fresh.compile(signature)
    assert fresh.signatures
    assert {name: set(d.signatures) for name, d in dispatchers.items()} == jobs
    # and the Newton iteration, the one step helper the kernel calls (the others are inlined),
    # is compiled once per formulation, i.e. per type of its system argument (a flag first
    # typed as a literal True or 0 compiled a called helper a second time, for the literal;
    # the tests before this one may have run the absolute formulation too)
    sigs = radau._solve_collocation.signatures
    assert len(sigs) == len({sig[5] for sig in sigs}), sigs


def test_the_kinematic_analysis_entry_is_the_one_the_scene_compiles(monkeypatch):
    # a mechanism built of class-II groups compiles the closed form, any other driven one the
    # Newton analysis; a scene whose ideal mechanism is not fully driven (the free double
    # pendulum) runs no kinematic analysis at all, so it must not wait for one to be compiled
    monkeypatch.setattr(kc, "is_compiled", lambda entry, formulation=None: False)
    assert kc.cold_entries(load_scene("nine-bar"))[0] == "kinematics"
    assert "kinematics" not in kc.cold_entries(load_scene("double-pendulum"))
    assert "kinematics-newton" not in kc.cold_entries(load_scene("double-pendulum"))
    import mechrel.mechanics.construction as construction

    monkeypatch.setattr(construction, "construction", lambda system: None)
    assert kc.cold_entries(load_scene("nine-bar"))[0] == "kinematics-newton"
    assert kc._ENTRY_POINTS["kinematics-newton"] == ("mechrel.mechanics.kinematics",
                                                     "_kinematics")


def test_a_kernel_compiled_for_one_formulation_is_cold_for_the_other(monkeypatch):
    # radau's absolute and reduced kernels are separate overloads: an index (or a process)
    # holding only the absolute one must not pass the reduced one as compiled, or its
    # first compilation would go unannounced; a stale index (numba returns {}) is cold
    from types import SimpleNamespace

    import numba
    import numpy as np

    from mechrel.integrate import radau
    from mechrel.mechanics.kinematics import assemble
    from mechrel.mechanics.system import compile_scene

    c = compile_scene(load_scene("slider-crank-lubricated"))
    q, v = assemble(c.assembly, c.q_guess, 0.0)
    red = radau.reduced_system(c.dynamic, np.concatenate([q, v, [0.0, 0.0]]))
    absolute = (numba.typeof(c.dynamic), numba.float64)
    reduced = (numba.typeof(red), numba.float64)

    def fake(signatures, cached):
        index = {(sig, ("magic",), ("hash",)): "data" for sig in cached}
        cache_file = SimpleNamespace(_load_index=lambda: index)
        return SimpleNamespace(signatures=signatures, _cache=SimpleNamespace(
            _cache_file=cache_file))

    monkeypatch.setattr(radau, "radau5_kernel", fake([], [absolute]))
    assert kc.is_compiled("radau", "absolute") and kc.is_compiled("radau")
    assert not kc.is_compiled("radau", "reduced")
    monkeypatch.setattr(radau, "radau5_kernel", fake([absolute], []))  # in this process
    assert not kc.is_compiled("radau", "reduced")
    monkeypatch.setattr(radau, "radau5_kernel", fake([], [absolute, reduced]))
    assert kc.is_compiled("radau", "reduced")
    monkeypatch.setattr(radau, "radau5_kernel", fake([], []))  # no index, or a stale one
    assert not kc.is_compiled("radau") and not kc.is_compiled("radau", "absolute")
    # and cold_entries asks for the formulation the scene's Radau integrates
    monkeypatch.setattr(radau, "radau5_kernel", fake([], [absolute]))
    monkeypatch.setattr(kc, "is_compiled", lambda entry, formulation=None:
                        entry != "radau" or formulation == "absolute")
    assert kc.cold_entries(load_scene("slider-crank-lubricated")) == ["radau"]


def test_the_kernel_checked_and_compiled_is_the_one_the_run_uses(monkeypatch, tmp_path):
    # `mechrel simulate --integrator radau` on a scene whose own integrator is DOPRI5: the
    # warm-up must look at (and compile) Radau's kernel, not the scene's DOPRI5
    import mechrel.simulation

    monkeypatch.setattr(kc, "is_compiled", lambda entry, formulation=None: entry != "radau")
    monkeypatch.setattr(kc, "_times_file", lambda: tmp_path / "kernel-compile-seconds.json")
    seen = []
    monkeypatch.setattr(kc, "split_compile", lambda s: seen.append(s.solver.integrator) or set())
    monkeypatch.setattr(mechrel.simulation, "simulate",
                        lambda s: seen.append(("run", s.solver.integrator)))
    scene = load_scene("slider-crank-dry")
    out = io.StringIO()
    assert kc.warm_up(scene, file=out) == 0.0 and out.getvalue() == ""  # its DOPRI5: warm
    kc.warm_up(scene, integrator="radau", progress=False, file=out)
    assert out.getvalue().startswith("compiling simulation kernels, once")
    assert seen == ["radau", ("run", "radau")]
    from mechrel.errors import SimulationError

    with pytest.raises(SimulationError, match=r"solver\.integrator: unknown integrator 'dopri'"):
        kc.warm_up(scene, integrator="dopri", progress=False, file=out)
