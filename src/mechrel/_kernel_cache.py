"""Keep numba's on-disk cache consistent with the sources compiled into the kernels.

Numba invalidates a cached function only when *its own* source file changes, not when a
function it calls (and inlines) changes in another module: after editing a force law, the
cached right-hand side and integrator kernels would silently keep the old one (numba issue
#6845; the proposed fixes were never merged). mechrel's kernels span
``mechanics/``, ``forces/`` and ``integrate/``, so before any of them is imported this module
hashes those sources and, when the hash differs from the one recorded beside the cache, deletes
mechrel's cached kernels so that they recompile. Installed packages never change, so this costs
one hash of ~20 small files per process (< 2 ms) and deletes nothing.

This module is the guard only: it imports nothing of mechrel (``mechrel.mechanics`` calls it
first). Compiling the kernels of a cold cache with an announcement is :mod:`mechrel.warmup`.
"""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

_PACKAGE = Path(__file__).resolve().parent
_KERNEL_DIRS = ("mechanics", "forces", "integrate")
_STAMP = "kernel-sources.sha256"


def _sources_digest(package: Path) -> str:
    h = hashlib.sha256()
    for sub in _KERNEL_DIRS:
        for path in sorted((package / sub).glob("*.py")):
            h.update(path.name.encode())
            h.update(path.read_bytes())
    return h.hexdigest()


def _cache_dirs(package: Path):
    for sub in _KERNEL_DIRS:
        yield package / sub / "__pycache__"
    env = os.environ.get("NUMBA_CACHE_DIR")
    if env:
        yield Path(env)


def ensure_fresh_kernel_cache(package: Path = _PACKAGE) -> bool:
    """Delete mechrel's cached kernels if their sources changed; return True if it did."""
    digest = _sources_digest(package)
    stamp = package / "__pycache__" / _STAMP
    try:
        if stamp.read_text() == digest:
            return False
    except OSError:
        pass
    removed = False
    for d in _cache_dirs(package):
        if not d.is_dir():
            continue
        for f in d.rglob("*"):
            if f.suffix in (".nbi", ".nbc") and ("mechrel" in str(f) or d.parent.parent == package):
                try:
                    f.unlink()
                    removed = True
                except OSError:  # another process removed it, or a read-only install
                    pass
    try:
        stamp.parent.mkdir(exist_ok=True)
        tmp = stamp.with_suffix(f".{os.getpid()}.tmp")
        tmp.write_text(digest)
        tmp.replace(stamp)
    except OSError:  # read-only installation: nothing can be stale there either
        pass
    return removed


# The sources besides the kernels that determine a simulation's numbers: the simulation
# package (driver, output evaluators, extremes, prepared scenes) and the mechanism model.
_SIMULATOR = ("simulation", "uq/problem/mechanism.py")


def simulator_digest(package: Path = _PACKAGE) -> str:
    """Hash of every source that determines a simulation's numbers (the kernels, the
    simulation package and the mechanism model): part of the UQ evaluation-cache key, so that
    cached evaluations are never reused across a change of the simulator's code."""
    h = hashlib.sha256(_sources_digest(package).encode())
    for rel in _SIMULATOR:
        path = package / rel
        for f in (sorted(path.glob("*.py")) if path.is_dir() else [path]):
            h.update(f.relative_to(package).as_posix().encode())
            h.update(f.read_bytes())
    return h.hexdigest()
