"""Fault injection, interrupts: Ctrl-C (SIGINT) and SIGTERM sent to a ``mechrel`` subprocess stop
it promptly with one line and the exit code of the signal, keep the finished samples, and leave
no worker process running — also when only the parent is killed with SIGKILL.

Timeouts are generous (the machine may be loaded), but bounded: a stop that waits for the end
of the integration (as before: up to ~20 s) or workers that linger for minutes fail them."""

from __future__ import annotations

import io
import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pytest

from mechrel.warmup import warm_up
from mechrel.cli.main import main
from mechrel.scene import load_scene

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(),
                                reason="reads process trees from /proc (Linux)")

CLI = [sys.executable, "-c", "import sys; from mechrel.cli.main import main; sys.exit(main())"]
# an interrupt must end the process within this many seconds (the kernel stops at its next
# step, in microseconds; the rest is the interpreter's exit, about 1-4 s on a loaded machine)
PROMPT = 12.0
# DOPRI5 at rtol 1e-11 on the stiff lubricated slider-crank, 400 cycles: about 30 s of CPU,
# longer than the test waits before it interrupts (4 s of CPU; the imports take about 1.5 s)
LONG_SIMULATION = ["simulate", "slider-crank-lubricated", "--no-progress",
                   "--set", "analysis.cycles=400", "--set", "solver.integrator=dopri5",
                   "--set", "solver.rtol=1e-11", "--set", "solver.atol=1e-14"]
STUDY = """\
scene = "slider-crank-lubricated"
cycles = 1
[scene_overrides]
"solver.rtol" = 1e-5
"solver.atol" = 1e-8
[inputs.clearance]
paths = ["joints.C.clearance"]
distribution = "normal"
mean = 0.2e-3
std = 0.01e-3
[reliability]
methods = ["mc"]
n = 4096
seed = 3
"""


@pytest.fixture(scope="module", autouse=True)
def _kernels_compiled(tmp_path_factory):
    """Compile (or load from numba's cache) everything the subprocesses below run, so that
    their interrupts reach a running computation and not the one-off compilation, which
    announces itself on stderr ("compiling simulation kernels, once") before the one line these
    tests expect (an interrupt during the compilation is tested on its own, below). On a cold
    cache, what is compiled before these tests depends on which tests ran before them; here it
    does not."""
    short = [a if a != "analysis.cycles=400" else "analysis.cycles=1" for a in LONG_SIMULATION]
    subprocess.run(CLI + short, capture_output=True, check=True,
                   cwd=tmp_path_factory.mktemp("warm"))
    warm_up(load_scene("slider-crank-lubricated",
                       overrides=["solver.rtol=1e-5", "solver.atol=1e-8"]),
            progress=False, file=io.StringIO())  # the study's scene


def _popen(argv, **kwargs):
    """``subprocess.Popen`` of ``argv`` with SIGINT at its default disposition in the child.

    A process started in the background by a non-interactive shell (``cmd &``, as CI scripts
    and job runners start test suites) has SIGINT *ignored*, and its children inherit that:
    Python then installs no ``KeyboardInterrupt`` handler and a SIGINT does nothing (a run of
    this suite in such a background job saw ``mechrel simulate`` finish normally after its
    Ctrl-C). A terminal's Ctrl-C goes to foreground processes, whose SIGINT is not ignored:
    that is what these tests model, whatever the disposition pytest itself inherited."""
    return subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                            **kwargs)


def _children(pid: int) -> set[int]:
    """Process ids whose parent is ``pid`` (from /proc)."""
    out = set()
    for entry in Path("/proc").iterdir():
        if entry.name.isdigit():
            try:
                stat = (entry / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.add(int(entry.name))
    return out


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def _rows(db: Path) -> int:
    try:
        with sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5) as con:
            return con.execute("SELECT COUNT(*) FROM evaluations").fetchone()[0]
    except sqlite3.Error:
        return 0


def _wait(cond, timeout, what):
    deadline = time.monotonic() + timeout
    while not cond():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out after {timeout} s waiting for {what}")
        time.sleep(0.05)


def _stop(proc, sig):
    proc.send_signal(sig)
    t0 = time.monotonic()
    try:
        _, err = proc.communicate(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()
        proc.communicate()
        raise AssertionError(f"{sig!r} did not stop the process within 60 s") from None
    return time.monotonic() - t0, err


@pytest.mark.parametrize("sig, code, name", [
    (signal.SIGINT, 130, "Ctrl-C"),
    pytest.param(signal.SIGTERM, 143, "SIGTERM", marks=pytest.mark.slow)])
def test_simulate_stops_promptly_with_one_line(sig, code, name, tmp_path):
    # the simulation starts after the imports: wait until the process has used some CPU time
    proc = _popen(CLI + LONG_SIMULATION)
    time.sleep(0.5)
    _wait(lambda: _cpu_seconds(proc.pid) > 4.0 or proc.poll() is not None, 300,
          "the simulation to run")
    assert proc.poll() is None, "the simulation ended before it could be interrupted"
    took, err = _stop(proc, sig)
    assert proc.returncode == code, f"took {took:.1f} s; stderr: {err!r}"
    assert err == f"mechrel: interrupted ({name})\n"
    assert took < PROMPT, f"took {took:.1f} s to stop"


def test_ctrl_c_during_the_one_off_compilation_stops_it_and_its_helper(tmp_path):
    # a cold kernel cache (an empty NUMBA_CACHE_DIR): the run announces the compilation and a
    # helper process compiles part of it (mechrel.warmup.split_compile); Ctrl-C to the
    # parent alone (as a job runner's SIGINT) stops the parent at once, and the helper, which
    # nobody reads any more, ends itself within its watch interval (0.5 s) instead of
    # compiling on for up to a minute
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    proc = _popen(CLI + ["simulate", "slider-crank-lubricated", "--no-progress"], env=env,
                  cwd=tmp_path)
    _wait(lambda: _children(proc.pid) or proc.poll() is not None, 120,
          "the compile helper to start")
    assert proc.poll() is None, "the run ended before it could be interrupted"
    helpers = {c for c in _children(proc.pid) if _alive(c)}
    time.sleep(1.0)  # into the compilation
    took, err = _stop(proc, signal.SIGINT)
    assert proc.returncode == 130, f"took {took:.1f} s; stderr: {err!r}"
    assert err.startswith("compiling simulation kernels, once")
    assert err.endswith("mechrel: interrupted (Ctrl-C)\n")
    assert took < PROMPT, f"took {took:.1f} s to stop"
    try:
        _wait(lambda: not any(_alive(h) for h in helpers), 10, f"helper {helpers} to end")
    finally:
        for h in helpers:
            if _alive(h):
                os.kill(h, signal.SIGKILL)


def _cpu_seconds(pid: int) -> float:
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except OSError:
        return 0.0
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


@pytest.mark.parametrize("sig, code, name", [
    pytest.param(signal.SIGINT, 130, "Ctrl-C", marks=pytest.mark.slow),
    (signal.SIGTERM, 143, "SIGTERM")])
def test_in_process_reliability_keeps_finished_samples_and_resumes(sig, code, name, tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    db = out / "evaluations.sqlite"
    argv = CLI + ["reliability", str(study), "--jobs", "1", "--no-progress", "--out", str(out)]
    proc = _popen(argv)
    _wait(lambda: _rows(db) >= 1 or proc.poll() is not None, 300, "a first cached chunk")
    assert proc.poll() is None
    took, err = _stop(proc, sig)
    assert proc.returncode == code, err
    assert err == (f"mechrel: interrupted ({name}); the finished model evaluations are kept in "
                   f"{db}: the same command resumes from them\n")
    assert took < PROMPT, f"took {took:.1f} s to stop"
    kept = _rows(db)
    assert 1 <= kept < 4096
    assert not (out / "reliability.csv").exists()


def _start_parallel(tmp_path):
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    argv = CLI + ["reliability", str(study), "--jobs", "2", "--no-progress", "--out", str(out)]
    proc = _popen(argv, start_new_session=True)
    db = out / "evaluations.sqlite"
    _wait(lambda: _rows(db) >= 1 or proc.poll() is not None, 300, "a first cached chunk")
    assert proc.poll() is None
    workers = {c for c in _children(proc.pid) if _alive(c)}
    assert workers, "no worker processes found"
    return proc, workers


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGKILL])
def test_no_worker_outlives_its_parent(sig, tmp_path):
    """SIGTERM to the parent only: it stops its workers itself. SIGKILL to the parent only
    (no cleanup possible): each worker notices within a second and ends itself."""
    proc, workers = _start_parallel(tmp_path)
    try:
        os.kill(proc.pid, sig)
        proc.communicate(timeout=60)
        _wait(lambda: not any(_alive(w) for w in workers), 20, f"workers {workers} to end")
    finally:
        for w in workers:
            if _alive(w):
                os.kill(w, signal.SIGKILL)


# ---------------------------------------------------------------- an interrupt inside numba
def test_an_interrupt_raised_inside_a_numba_callback_is_an_interrupt(tmp_path):
    """A signal handler that raises inside numba's Python callback (its constant unpickling on
    a function's first call) reaches the caller as ``SystemError`` caused by the interrupt. The
    evaluation loop treats it as the interrupt: the rows finished before it are cached."""
    import numpy as np

    from mechrel.errors import Interrupted, interrupt_of
    from mechrel.uq import FunctionModel, evaluate

    def callback_interrupted():
        try:
            raise Interrupted(signal.SIGTERM)
        except Interrupted as exc:
            raise SystemError("<function _numba_unpickle> returned a result with an exception "
                              "set") from exc

    try:
        callback_interrupted()
    except SystemError as exc:
        assert isinstance(interrupt_of(exc), Interrupted)
    assert interrupt_of(SystemError("another")) is None and interrupt_of(ValueError()) is None

    def f(x):
        if x[0] >= 3:
            callback_interrupted()
        return [2.0 * x[0]]

    model = FunctionModel(f, ["a"], ["y"])
    X = np.arange(6.0)[:, None]
    with pytest.raises(Interrupted):
        evaluate(model, X, cache=tmp_path, progress=False, chunk_size=6)
    with sqlite3.connect(tmp_path / "evaluations.sqlite") as con:
        assert con.execute("SELECT COUNT(*) FROM evaluations").fetchone() == (3,)


# ---------------------------------------------------------------- at the ordinary moments
# A driver that runs the command line as the ``mechrel`` script does, and stops at a named
# moment until the test has sent its signal: it creates MARKER, then waits (sleeping 10 ms at
# a time) for MARKER.sent, which the test creates right after its kill(). By then the signal's
# C-level handler has run, so the Python handler acts at the driver's next bytecode: within
# the wait (a handler that raises), or after it (a signal held by the code around the
# moment). No timing is guessed.
DRIVER = r"""
import os, sys, time
marker, moment, *argv = sys.argv[1:]

def wait_here():
    open(marker, "w").close()
    deadline = time.monotonic() + 120
    while not os.path.exists(marker + ".sent") and time.monotonic() < deadline:
        time.sleep(0.01)

if moment.startswith("import:"):  # inside the first import of a module
    name = moment[len("import:"):]

    class Stop:
        @classmethod
        def find_spec(cls, fullname, path=None, target=None):
            if fullname == name:
                sys.meta_path.remove(cls)
                wait_here()
            return None

    sys.meta_path.insert(0, Stop)
elif moment == "parse":  # inside argparse's parsing of the command line
    import argparse
    parse = argparse.ArgumentParser.parse_known_args

    def parse_known_args(self, *args, **kwargs):
        if self.prog == "mechrel":
            wait_here()
        return parse(self, *args, **kwargs)

    argparse.ArgumentParser.parse_known_args = parse_known_args
elif moment.startswith("call:"):  # at the start of module.function
    import importlib
    where, name = moment[len("call:"):].rsplit(".", 1)
    module = importlib.import_module(where)
    function = getattr(module, name)

    def wrapped(*args, **kwargs):
        wait_here()
        return function(*args, **kwargs)

    setattr(module, name, wrapped)
sys.argv = ["mechrel", *argv]
from mechrel.cli.main import main
code = main()
if moment == "exit":  # main() has returned: the interpreter's exit is next
    wait_here()
sys.exit(code)
"""
FOSM_STUDY = STUDY.replace('methods = ["mc"]', 'methods = ["fosm"]')
NAMES = {signal.SIGINT: (130, "Ctrl-C"), signal.SIGTERM: (143, "SIGTERM")}


def _at(moment, argv, sig, tmp_path, *, group=False):
    """Run ``mechrel ARGV`` through DRIVER, send ``sig`` at ``moment`` (to the process group
    when ``group``: a terminal's Ctrl-C reaches every process of the foreground group) and
    return (exit code, stderr)."""
    marker = tmp_path / "at-moment"
    proc = _popen([sys.executable, "-c", DRIVER, str(marker), moment, *argv],
                  start_new_session=True)
    try:
        _wait(lambda: marker.exists() or proc.poll() is not None, 300, f"the moment {moment}")
        assert proc.poll() is None, proc.communicate()
        (os.killpg if group else os.kill)(proc.pid, sig)
        Path(f"{marker}.sent").touch()
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    return proc.returncode, err


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
@pytest.mark.parametrize("moment", ["import:numpy", "parse"])
def test_an_interrupt_while_the_command_starts_is_one_line(moment, sig, tmp_path):
    # the first imports (numpy, pandas, scipy, numba: seconds) and the parsing happen inside
    # main()'s handlers; there was a KeyboardInterrupt traceback, and SIGTERM ended it silently
    code, name = NAMES[sig]
    rc, err = _at(moment, ["simulate", "slider-crank", "--no-progress"], sig, tmp_path)
    assert (rc, err) == (code, f"mechrel: interrupted ({name})\n")


def test_no_cache_is_named_before_there_is_one(tmp_path):
    # the arguments are parsed, the run's modules are being imported: no evaluations.sqlite
    # exists yet, so the line does not send the user to one
    study = tmp_path / "study.toml"
    study.write_text(FOSM_STUDY)
    out = tmp_path / "out"
    rc, err = _at("import:mechrel.study.runner",
                  ["reliability", str(study), "--jobs", "1", "--no-progress", "--out", str(out)],
                  signal.SIGINT, tmp_path)
    assert (rc, err) == (130, "mechrel: interrupted (Ctrl-C)\n")
    assert not (out / "evaluations.sqlite").exists()


@pytest.mark.parametrize("sig", [signal.SIGINT,
                                 pytest.param(signal.SIGTERM, marks=pytest.mark.slow)])
def test_ctrl_c_while_the_workers_start_is_one_line(sig, tmp_path):
    """A terminal's Ctrl-C reaches the whole foreground group: the workers too, while they
    start (import their modules). They start with SIGINT blocked, and the parent ends them:
    one line, no worker traceback, no resource tracker's 'leaked' warning."""
    code, name = NAMES[sig]
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    out = tmp_path / "out"
    proc = _popen(CLI + ["reliability", str(study), "--jobs", "2", "--no-progress", "--out",
                         str(out)], start_new_session=True)
    try:
        # a worker whose interpreter has set up its signal handling (Python's SIGINT handler,
        # in /proc's SigCgt) and now imports its modules, for a second or more: a Ctrl-C then
        # was a KeyboardInterrupt traceback of 26-81 lines per worker
        _wait(lambda: any(_catches_sigint(c) for c in _children(proc.pid)
                          if "popen_loky" in _cmdline(c))
              or proc.poll() is not None, 300, "a worker process to start")
        assert proc.poll() is None, proc.communicate()
        os.killpg(proc.pid, sig)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == code, err
    assert err.startswith(f"mechrel: interrupted ({name})") and err.count("\n") == 1, err


def _catches_sigint(pid: int) -> bool:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return False
    caught = next((line.split()[1] for line in status.splitlines()
                   if line.startswith("SigCgt:")), "0")
    return bool(int(caught, 16) & (1 << (signal.SIGINT - 1)))


def _cmdline(pid: int) -> str:
    try:
        return Path(f"/proc/{pid}/cmdline").read_text().replace("\0", " ")
    except OSError:
        return ""


def _files(folder: Path) -> dict:
    return {p.name: p.read_bytes() for p in sorted(folder.iterdir()) if p.is_file()
            and p.name != "evaluations.sqlite"}


def _fosm(tmp_path, std):
    study = tmp_path / "study.toml"
    study.write_text(FOSM_STUDY)
    return ["reliability", str(study), "--jobs", "1", "--no-progress", "--out",
            str(tmp_path / "out"), "--set", f"inputs.clearance.std={std}"]


@pytest.mark.parametrize("sig", [pytest.param(signal.SIGINT, marks=pytest.mark.slow),
                                 signal.SIGTERM])
def test_an_interrupt_while_results_are_written_keeps_the_earlier_set(sig, tmp_path):
    """Interrupted after some of its files are written (the summary is written last): the
    folder holds the earlier run's complete set, not a mix, and no staging folder."""
    code, name = NAMES[sig]
    out = tmp_path / "out"
    assert main(_fosm(tmp_path, 1e-5)) == 0  # the earlier run, in-process
    earlier = _files(out)
    assert {"reliability.csv", "reliability.png", "summary.json"} <= set(earlier)
    rc, err = _at("call:mechrel.study.runner.write_json", _fosm(tmp_path, 2e-5), sig, tmp_path)
    assert rc == code, err
    assert err == (f"mechrel: interrupted ({name}); the finished model evaluations are kept in "
                   f"{out / 'evaluations.sqlite'}: the same command resumes from them\n")
    assert _files(out) == earlier
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == []


def test_an_interrupt_while_the_set_is_moved_into_place_waits_for_it(tmp_path):
    """Interrupted during the renames that put the new set in place (held for their
    milliseconds): the folder holds the new complete set, which its manifest describes, and
    the run then stops with its one line."""
    import hashlib
    import json

    out = tmp_path / "out"
    assert main(_fosm(tmp_path, 1e-5)) == 0  # the earlier run, in-process
    earlier = _files(out)
    rc, err = _at("call:mechrel.io.results._roll_forward", _fosm(tmp_path, 2e-5),
                  signal.SIGTERM, tmp_path)
    assert (rc, err.splitlines()[0]) == (143, "mechrel: interrupted (SIGTERM); the finished "
                                               f"model evaluations are kept in "
                                               f"{out / 'evaluations.sqlite'}: the same command "
                                               "resumes from them")
    now = _files(out)
    manifest = json.loads(now.pop(".mechrel-set-reliability.json"))
    assert {f["name"]: f["sha256"] for f in manifest["files"]} == \
        {k: hashlib.sha256(v).hexdigest() for k, v in now.items()}
    assert now["reliability.csv"] != earlier["reliability.csv"]  # the new run's
    assert sorted(p.name for p in out.iterdir() if p.is_dir()) == []


def test_a_killed_worker_is_one_line_and_the_finished_chunks_are_kept(tmp_path):
    """A worker killed outright (as by the kernel's out-of-memory killer): one line naming the
    samples being evaluated and that the same command resumes; the chunks stored before are
    in the cache."""
    import re

    proc, workers = _start_parallel(tmp_path)
    db = tmp_path / "out" / "evaluations.sqlite"
    try:
        # a worker (not loky's resource tracker, also a child)
        os.kill(min(w for w in workers if "popen_loky" in _cmdline(w)), signal.SIGKILL)
        _, err = proc.communicate(timeout=120)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.communicate()
    assert proc.returncode == 2, err
    assert re.fullmatch(r"mechrel: error: a worker process ended without its result \(exit "
                        r"code SIGKILL\(-9\)\)( while evaluating samples [0-9–]+( or [0-9–]+)*)?: "
                        r"killed by the system \(out of memory\?\) or from outside; the "
                        rf"finished model evaluations are kept in {re.escape(str(db))}: the "
                        r"same command resumes from them\n", err), err
    assert 1 <= _rows(db) < 4096


def test_sigterm_as_a_parallel_run_ends_leaves_no_leaked_resources(tmp_path):
    """SIGTERM just after a parallel run has printed its summary, as the interpreter exits
    (the default action: the process ends at once): the command ended its worker pool
    itself, so loky's resource tracker finds nothing 'leaked' to warn about (it printed four
    lines of leaked semaphores and folders)."""
    study = tmp_path / "study.toml"
    study.write_text(STUDY)
    rc, err = _at("exit", ["reliability", str(study), "--n", "16", "--jobs", "2",
                           "--no-progress", "--out", str(tmp_path / "out")],
                  signal.SIGTERM, tmp_path, group=True)
    assert rc == -signal.SIGTERM, err
    assert "leaked" not in err and "Traceback" not in err, err


# ------------------------------------------------------- the signal watcher over a batch of runs
def _main_thread_handler():
    """SIGINT at Python's own handler for the test (a job runner may start the suite with
    SIGINT ignored), restored after; skipped off the main thread (no handler can be set)."""
    import threading

    if threading.current_thread() is not threading.main_thread():
        pytest.skip("signal handlers are set on the main thread only")
    return signal.signal(signal.SIGINT, signal.default_int_handler)


def _wakeup_fd() -> int:
    fd = signal.set_wakeup_fd(-1)
    signal.set_wakeup_fd(fd)
    return fd


def test_a_signal_session_installs_the_watcher_once_and_restores_what_it_replaced():
    from mechrel.integrate.base import signal_session
    from mechrel.scene import load_scene
    from mechrel.simulation import simulate

    old = _main_thread_handler()
    try:
        fd = _wakeup_fd()
        with signal_session():
            inside = signal.getsignal(signal.SIGINT), _wakeup_fd()
            assert inside[0] is not signal.default_int_handler and inside[1] != fd
            with signal_session():  # re-entrant: nothing installed again
                assert (signal.getsignal(signal.SIGINT), _wakeup_fd()) == inside
            for _ in range(2):  # the runs inside do not install their own
                assert simulate(load_scene("slider-crank-lubricated")).stats["status"] == "ok"
                assert (signal.getsignal(signal.SIGINT), _wakeup_fd()) == inside
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
        assert _wakeup_fd() == fd
    finally:
        signal.signal(signal.SIGINT, old)


def test_in_a_signal_session_a_signal_between_runs_raises_at_once():
    from mechrel.integrate.base import signal_session

    old = _main_thread_handler()
    try:
        start = time.perf_counter()
        with pytest.raises(KeyboardInterrupt), signal_session():
            os.kill(os.getpid(), signal.SIGINT)
            time.sleep(5.0)  # no kernel runs: Python's handler raises during the sleep
        assert time.perf_counter() - start < 2.0
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, old)


def test_in_a_signal_session_a_signal_during_a_run_stops_its_kernel_then_raises():
    import math
    import threading

    from mechrel.integrate.base import signal_session
    from mechrel.scene import load_scene, with_overrides
    from mechrel.simulation import simulate

    old = _main_thread_handler()
    try:
        base = load_scene("slider-crank-lubricated")
        simulate(base)  # compiled before the clock starts
        # ~3 s of kernel here, and few output instants, so that the kinematic analysis before
        # it is over long before the signal comes
        long = with_overrides(base, {"analysis.cycles": 400,
                                     "analysis.sample_step_angle": math.pi / 2})
        timer = threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT))
        start = time.perf_counter()
        with pytest.raises(KeyboardInterrupt) as info, signal_session():
            timer.start()
            simulate(long)
        took = time.perf_counter() - start
        timer.join()
        assert any("integration stopped after" in n for n in getattr(info.value, "__notes__", []))
        assert took < 1.5, took  # stopped at its next step, not run to the end
        assert signal.getsignal(signal.SIGINT) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGINT, old)
