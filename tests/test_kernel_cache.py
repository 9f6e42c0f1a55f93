"""The kernel-cache guard deletes cached kernels when any kernel source changes."""

import shutil
from pathlib import Path

import mechrel
from mechrel._kernel_cache import ensure_fresh_kernel_cache


def _fake_package(tmp_path: Path) -> Path:
    pkg = tmp_path / "pkg"
    for sub in ("mechanics", "forces", "integrate"):
        (pkg / sub / "__pycache__").mkdir(parents=True)
        shutil.copy(Path(mechrel.__file__).parent / sub / "__init__.py", pkg / sub / "__init__.py")
    return pkg


def test_cache_is_cleared_only_when_sources_change(tmp_path):
    pkg = _fake_package(tmp_path)
    cached = pkg / "mechanics" / "__pycache__" / "problem.rhs-100.py311.nbi"
    cached.write_text("x")
    assert ensure_fresh_kernel_cache(pkg) is True  # no stamp yet: clear and record
    assert not cached.exists()
    cached.write_text("x")
    assert ensure_fresh_kernel_cache(pkg) is False  # unchanged sources: keep the cache
    assert cached.exists()
    # editing a force law (another module than the cached kernel's) invalidates it
    (pkg / "forces" / "joint.py").write_text("# changed\n")
    assert ensure_fresh_kernel_cache(pkg) is True
    assert not cached.exists()
