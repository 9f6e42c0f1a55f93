"""How the executor starts and ends its loky worker processes.

* **No import from the current folder.** loky starts a worker as ``python -m
  loky.backend.popen_loky_posix``, and ``-m`` puts the current folder first on the worker's
  import path while it starts: a file named like a standard module (``pickle.py``,
  ``signal.py``) in the folder where a user runs ``mechrel reliability`` was executed in every
  worker. Workers are started with ``PYTHONSAFEPATH=1`` (Python >= 3.11: no folder is
  prepended to the path), after which loky sets their path to the parent's. (A parent that
  itself has the current folder on its path — ``python -m``, ``python -c``, a notebook — passes
  it on, as Python itself does for that parent.)
* **Ctrl-C reaches the parent only.** Workers start with SIGINT blocked
  (:func:`_fork_exec_without_sigint`), so that a terminal's Ctrl-C, which every process of the
  foreground group receives, prints no worker's traceback; the parent stops them.
* **A killed worker is one line.** Each chunk a worker starts is marked in a ledger folder of
  its parent (:func:`starting_chunk`, :func:`chunk_ledger`), and unmarked when its result is
  collected; when a worker dies without a result (out of memory, ``kill -9``), loky's
  ``TerminatedWorkerError`` (a 40-line traceback) becomes one :class:`~mechrel.errors.WorkerError`
  naming the samples that were being evaluated, and that a rerun resumes from the cache.
* **No orphaned workers.** A worker watches the process that started it (its id is passed as
  ``MECHREL_PARENT_PID``) and ends itself within :data:`WATCH_INTERVAL` s of that process's end
  — also after a ``kill -9`` of the parent, which gives the parent no chance to stop them.
  On Ctrl-C or SIGTERM the parent stops them itself (joblib aborts the pool). The compile
  helper of :func:`mechrel.warmup.split_compile` watches its parent the same way.

The backend is registered with joblib as ``"mechrel-loky"``: joblib's loky backend with the
environment above added to the one joblib gives its workers (thread limits).
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import tempfile
import threading
import time
from pathlib import Path

BACKEND_NAME = "mechrel-loky"
PARENT_ENV = "MECHREL_PARENT_PID"
WATCH_INTERVAL = 0.5  # s

_registered = False
_watching = False


def register_backend() -> str:
    """Register (once) and return the name of the joblib backend for loky workers."""
    global _registered
    if not _registered:
        import joblib
        from joblib._parallel_backends import (
            LokyBackend,  # subclassed, as joblib documents
        )

        class MechrelLokyBackend(LokyBackend):
            def _prepare_worker_env(self, n_jobs):
                env = dict(super()._prepare_worker_env(n_jobs))
                env.update(PYTHONSAFEPATH="1", **{PARENT_ENV: str(os.getpid())})
                return env

        joblib.register_parallel_backend(BACKEND_NAME, MechrelLokyBackend)
        _registered = True
    return BACKEND_NAME


@contextlib.contextmanager
def safe_path_environment():
    """For the ``with`` block (a pool's run): ``PYTHONSAFEPATH=1`` in this process's
    environment, for the helper processes loky starts itself from it (its resource tracker,
    ``python -c``, which would otherwise import from the current folder too), and workers
    started with Ctrl-C blocked (:func:`_fork_exec_without_sigint`); both restored afterwards,
    so that the caller's later subprocesses keep Python's usual path and signals."""
    from joblib.externals.loky.backend import fork_exec as loky_fork_exec

    old = os.environ.get("PYTHONSAFEPATH")
    os.environ["PYTHONSAFEPATH"] = "1"
    real = loky_fork_exec.fork_exec
    loky_fork_exec.fork_exec = _fork_exec_without_sigint(real)
    try:
        yield
    finally:
        loky_fork_exec.fork_exec = real
        if old is None:
            os.environ.pop("PYTHONSAFEPATH", None)
        else:
            os.environ["PYTHONSAFEPATH"] = old


def _fork_exec_without_sigint(fork_exec):
    """Loky's ``fork_exec`` (how it starts a worker) with SIGINT blocked in the calling thread
    for the call: the worker inherits the blocked signal through ``exec`` and keeps it blocked
    all its life. A terminal's Ctrl-C goes to every process of its foreground group, workers
    included, which then printed a ``KeyboardInterrupt`` traceback each (7-40 lines, also from
    a worker still importing its modules) around the parent's one line; now only the parent
    acts on it, and stops its workers. A Ctrl-C during the call itself is held, not lost: the
    parent's mask is restored right after, and the signal delivered then."""
    import signal

    def start(*args, **kwargs):
        old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
        try:
            return fork_exec(*args, **kwargs)
        finally:
            signal.pthread_sigmask(signal.SIG_SETMASK, old)

    return start


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:  # it exists (another user's)
        return True
    return True


def _watch(parent: int) -> None:
    while True:
        time.sleep(WATCH_INTERVAL)
        if os.getppid() != parent:
            os._exit(1)  # the parent is gone: no one reads our results


def watch_parent() -> None:
    """In a worker started by :func:`register_backend`'s backend, or a compile helper of
    :func:`mechrel.warmup.split_compile` (both pass this process's parent id as
    ``MECHREL_PARENT_PID``): start (once per process) a daemon thread that ends the process
    when its parent ends. Elsewhere: nothing."""
    global _watching
    if _watching is not False:  # watching, or not a worker (decided once per process)
        return
    parent = os.environ.get(PARENT_ENV, "")
    if not parent.isdigit() or int(parent) == os.getpid():
        _watching = None  # not a worker of this backend
        return
    if os.getppid() != int(parent):
        if not _alive(int(parent)):
            os._exit(1)  # its parent ended before it got here (a loaded machine: seconds)
        _watching = None  # not a worker of this backend (e.g. a process a worker started)
        return
    _watching = True
    threading.Thread(target=_watch, args=(int(parent),), name="mechrel-watch-parent",
                     daemon=True).start()


def _ledger(parent: int | str) -> Path:
    return Path(tempfile.gettempdir()) / f"mechrel-{parent}-chunks"


def starting_chunk(chunk_id: int) -> None:
    """In a worker: :func:`watch_parent`, and mark chunk ``chunk_id`` as started in the
    ledger of the parent's running pool (if it keeps one; :func:`chunk_ledger`). Elsewhere (the
    parent evaluating in-process): nothing more."""
    watch_parent()
    if _watching:
        with contextlib.suppress(OSError):  # no ledger: a pool not run by evaluate
            (_ledger(os.environ[PARENT_ENV]) / str(chunk_id)).touch(exist_ok=True)


class ChunkLedger:
    """The parent's side of the ledger of started chunks (:func:`chunk_ledger`)."""

    def __init__(self, folder: Path):
        self.folder = folder

    def collecting(self, collect):
        """``collect`` that first unmarks the chunk of the result it is given."""
        def wrapped(result):
            with contextlib.suppress(OSError):
                (self.folder / str(result[0])).unlink()
            collect(result)
        return wrapped

    def running(self) -> list[int]:
        """The chunks started and not collected."""
        try:
            return sorted(int(p.name) for p in self.folder.iterdir() if p.name.isdigit())
        except OSError:
            return []


@contextlib.contextmanager
def chunk_ledger():
    """For the ``with`` block (a pool's run in this process): the ledger in which its workers
    mark the chunks they start (a folder in the temporary directory, removed afterwards)."""
    folder = _ledger(os.getpid())
    shutil.rmtree(folder, ignore_errors=True)
    try:
        folder.mkdir(mode=0o700)
    except OSError:
        pass  # not writable: the error of a killed worker then names no samples
    try:
        yield ChunkLedger(folder)
    finally:
        shutil.rmtree(folder, ignore_errors=True)


def worker_died(exc: BaseException, rows: list, cache) -> Exception:
    """The one-line error for loky's ``TerminatedWorkerError`` ``exc``: how the worker ended,
    the samples being evaluated then (``rows``: the design rows of each chunk started and not
    collected), and what of the run is kept."""
    from ...errors import WorkerError

    codes = re.search(r"exit codes of the workers are \{([^}]*)\}", str(exc))
    how = f" (exit code {codes.group(1)})" if codes else ""
    spans = [f"{r[0]}" if len(r) == 1 else f"{r[0]}–{r[-1]}" for r in rows if len(r)]
    where = (f" while evaluating samples {' or '.join(spans)}" if spans else "")
    kept = (f"the finished model evaluations are kept in {cache.path}: the same command "
            "resumes from them" if cache is not None else
            "without a cache (cache=...), a rerun evaluates every sample again")
    return WorkerError(f"a worker process ended without its result{how}{where}: killed by the "
                       "system (out of memory?) or from outside; " + kept)


def end_pool() -> None:
    """End loky's reusable worker pool of this process, if it has one, and remove the
    temporary folders joblib keeps with it. The command line calls it when a command ends:
    otherwise the pool is ended by the interpreter's exit, and a SIGTERM at that moment (the
    default action: the process ends at once) left loky's resource tracker to print
    "leaked semlock/folder objects" warnings."""
    import sys

    module = sys.modules.get("joblib.externals.loky.reusable_executor")
    pool = getattr(module, "_executor", None)
    if pool is not None:
        # a pool left half-started by an interrupt cannot be joined ("cannot join thread
        # before it is started"): the command has ended, nothing is left to save
        with contextlib.suppress(Exception):
            if hasattr(pool, "terminate"):  # joblib's: also its temporary folders
                pool.terminate(kill_workers=True)
            else:
                pool.shutdown(wait=True, kill_workers=True)
