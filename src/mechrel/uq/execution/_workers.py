"""How the executor starts and ends its loky worker processes.

* **No import from the current folder.** loky starts a worker as ``python -m
  loky.backend.popen_loky_posix``, and ``-m`` puts the current folder first on the worker's
  import path while it starts: a file named like a standard module (``pickle.py``,
  ``signal.py``) in the folder where a user runs ``mechrel reliability`` was executed in every
  worker. Workers are started with ``PYTHONSAFEPATH=1`` (Python >= 3.11: no folder is
  prepended to the path), after which loky sets their path to the parent's. (A parent that
  itself has the current folder on its path — ``python -m``, ``python -c``, a notebook — passes
  it on, as Python itself does for that parent.)
* **No orphaned workers.** A worker watches the process that started it (its id is passed as
  ``MECHREL_PARENT_PID``) and ends itself within :data:`WATCH_INTERVAL` s of that process's end
  — also after a ``kill -9`` of the parent, which gives the parent no chance to stop them.
  On Ctrl-C or SIGTERM the parent stops them itself (joblib aborts the pool). The compile
  helper of :func:`mechrel._kernel_cache.split_compile` watches its parent the same way.

The backend is registered with joblib as ``"mechrel-loky"``: joblib's loky backend with the
environment above added to the one joblib gives its workers (thread limits).
"""

from __future__ import annotations

import contextlib
import os
import threading
import time

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
    """``PYTHONSAFEPATH=1`` in this process's environment for the ``with`` block, for the
    helper processes loky starts itself from it (its resource tracker, ``python -c``, which
    would otherwise import from the current folder too); restored afterwards, so that the
    caller's later subprocesses keep Python's usual path."""
    old = os.environ.get("PYTHONSAFEPATH")
    os.environ["PYTHONSAFEPATH"] = "1"
    try:
        yield
    finally:
        if old is None:
            os.environ.pop("PYTHONSAFEPATH", None)
        else:
            os.environ["PYTHONSAFEPATH"] = old


def _watch(parent: int) -> None:
    while True:
        time.sleep(WATCH_INTERVAL)
        if os.getppid() != parent:
            os._exit(1)  # the parent is gone: no one reads our results


def watch_parent() -> None:
    """In a worker started by :func:`register_backend`'s backend, or a compile helper of
    :func:`mechrel._kernel_cache.split_compile` (both pass this process's parent id as
    ``MECHREL_PARENT_PID``): start (once per process) a daemon thread that ends the process
    when its parent ends. Elsewhere: nothing."""
    global _watching
    if _watching is not False:  # watching, or not a worker (decided once per process)
        return
    parent = os.environ.get(PARENT_ENV, "")
    if not parent.isdigit() or int(parent) == os.getpid() or os.getppid() != int(parent):
        _watching = None  # not a worker of this backend (e.g. a process a worker started)
        return
    _watching = True
    threading.Thread(target=_watch, args=(int(parent),), name="mechrel-watch-parent",
                     daemon=True).start()
