"""Helpers shared by the benchmark scripts (run as ``python benchmarks/<script>.py``)."""

from __future__ import annotations

import importlib.util
import subprocess
import sys
import tempfile
from pathlib import Path


def git_state() -> str:
    """``git describe --always --dirty`` of the checkout, or ``"unknown"``."""
    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"],
                              cwd=Path(__file__).resolve().parent, capture_output=True,
                              text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def module_from_source(src: str, edits, name: str, what: str):
    """Import ``src`` with ``edits`` (``(old, new)`` pairs, each matching exactly once) as the
    module ``name``, from a file in a temporary folder (numba compiles it there afresh).
    ``what`` names the source in the error raised when an edit no longer matches it."""
    for old, new in edits:
        n = src.count(old)
        if n != 1:
            raise RuntimeError(f"{what} changed ({n} matches of {old.strip()[:60]!r}); "
                               "update the benchmark's edits")
        src = src.replace(old, new)
    path = Path(tempfile.mkdtemp(prefix="mechrel-bench-")) / f"{name}.py"
    path.write_text(src)
    spec = importlib.util.spec_from_file_location(name, path)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[name] = mod  # so that another such module can import it by name
    spec.loader.exec_module(mod)
    return mod


def radau_copy(edits, name: str):
    """A fresh copy of ``mechrel.integrate.radau`` with ``edits`` applied, imported as the
    module ``name`` (:func:`module_from_source`): its relative imports made absolute first, so
    edits anchor on the absolute ones. numba compiles the copy afresh in this process, which
    makes it the fair baseline for kernel variants (a fresh copy runs a few per cent faster
    than the kernel loaded from numba's cache; docs/dev/performance-log.md)."""
    import inspect

    import mechrel.integrate.radau as radau

    src = inspect.getsource(radau)
    src = src.replace("from ..", "from mechrel.").replace("from .events",
                                                          "from mechrel.integrate.events")
    src = src.replace("from .base import", "from mechrel.integrate.base import")
    return module_from_source(src, edits, name, "the Radau kernel")


def timed(fn, spent: dict, key: str, clock=None):
    """``fn`` wrapped to add the seconds each call takes to ``spent[key]``, by ``clock``
    (default ``time.perf_counter``, the wall clock; ``time.process_time`` for CPU time)."""
    import time

    clock = clock or time.perf_counter

    def run(*a, **kw):
        t0 = clock()
        try:
            return fn(*a, **kw)
        finally:
            spent[key] += clock() - t0
    return run
