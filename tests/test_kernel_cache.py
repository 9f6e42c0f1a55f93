"""The kernel-cache guard deletes cached kernels when any kernel source changes; the
simulator's digest (the evaluation cache's key) changes with any module of the simulation."""

import shutil
from pathlib import Path

import mechrel
from mechrel._kernel_cache import ensure_fresh_kernel_cache, simulator_digest


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


def test_the_simulator_digest_covers_every_module_of_the_simulation(tmp_path):
    src = Path(mechrel.__file__).parent
    pkg = _fake_package(tmp_path)
    shutil.copytree(src / "simulation", pkg / "simulation",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (pkg / "uq" / "problem").mkdir(parents=True)
    shutil.copy(src / "uq" / "problem" / "mechanism.py", pkg / "uq" / "problem" / "mechanism.py")
    modules = sorted(p.name for p in (pkg / "simulation").glob("*.py"))
    assert {"__init__.py", "run.py", "evaluators.py", "extremes.py"} <= set(modules)
    seen = {simulator_digest(pkg)}
    for name in modules:  # each module's edit moves the digest
        with open(pkg / "simulation" / name, "a") as f:
            f.write("# changed\n")
        seen.add(simulator_digest(pkg))
    with open(pkg / "uq" / "problem" / "mechanism.py", "a") as f:
        f.write("# changed\n")
    seen.add(simulator_digest(pkg))
    (pkg / "forces" / "joint.py").write_text("# changed\n")  # a kernel source
    seen.add(simulator_digest(pkg))
    assert len(seen) == len(modules) + 3
    assert simulator_digest() == simulator_digest(src)
