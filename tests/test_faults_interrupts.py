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

from mechrel._kernel_cache import warm_up
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
    # helper process compiles part of it (mechrel._kernel_cache.split_compile); Ctrl-C to the
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
