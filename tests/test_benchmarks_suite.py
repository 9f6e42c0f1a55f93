"""benchmarks/ is the maintained suite behind the docs' figures: every script registered with the
runner (``python -m benchmarks``), its quick settings valid options of the script, and every
benchmark, tool or fixture the docs and tests name present."""

from __future__ import annotations

import importlib.util
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
_spec = importlib.util.spec_from_file_location("benchmarks_runner",
                                               ROOT / "benchmarks" / "__main__.py")
runner = importlib.util.module_from_spec(_spec)
sys.modules[_spec.name] = runner  # the dataclass looks its module up
_spec.loader.exec_module(runner)


def test_every_benchmark_script_is_registered_and_every_registered_script_exists():
    on_disk = {p.name for p in (ROOT / "benchmarks").glob("bench_*.py")}
    registered = {b.script for b in runner.BENCHMARKS.values()}
    assert on_disk == registered, (on_disk - registered, registered - on_disk)


@pytest.mark.parametrize("name", list(runner.BENCHMARKS))
def test_quick_settings_are_options_of_the_script(name):
    b = runner.BENCHMARKS[name]
    source = (ROOT / "benchmarks" / b.script).read_text(encoding="utf-8")
    options = set(re.findall(r'add_argument\(\s*"(--[a-z][a-z0-9-]*)"', source))
    wanted = [a for a in b.quick if a.startswith("--")] + (["--json"] if b.json else [])
    assert set(wanted) <= options, set(wanted) - options
    assert b.measures and b.cited_in


def _named_paths():
    files = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")),
             ROOT / "docs" / "dev" / "retired-benchmarks.md",
             *sorted((ROOT / "tests").glob("*.py")), *sorted((ROOT / "benchmarks").glob("*.py")),
             *sorted((ROOT / "tools").glob("*.py")), *sorted((ROOT / "studies").glob("*.py"))]
    # a path from the repository's root: not inside another path (mechrel/studies/...), no
    # placeholder (benchmarks/NAME.py)
    pattern = re.compile(r"(?<![\w/.-])((?:benchmarks|tools|tests/data)/[a-z0-9_][\w./-]*"
                         r"\.(?:py|toml|json))")
    for f in files:
        for m in pattern.finditer(f.read_text(encoding="utf-8")):
            yield f.relative_to(ROOT), m.group(1)


def test_every_script_and_fixture_the_docs_and_tests_name_exists():
    # docs/dev/performance-log.md is history and names retired scripts (listed, with the commit
    # to read them from, in docs/dev/retired-benchmarks.md); everything else must be present
    named = list(_named_paths())
    assert any(p == "benchmarks/bench_effects.py" for _, p in named)  # the scan finds names
    missing = sorted({(str(f), p) for f, p in named if not (ROOT / p).exists()})
    assert missing == []


def test_runner_lists_every_benchmark_and_refuses_an_unknown_name():
    proc = subprocess.run([sys.executable, "-m", "benchmarks", "--list"], cwd=ROOT,
                          capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    listed = [line.split()[0] for line in proc.stdout.splitlines()[1:]]
    assert listed == list(runner.BENCHMARKS)
    proc = subprocess.run([sys.executable, "-m", "benchmarks", "bogus"], cwd=ROOT,
                          capture_output=True, text=True)
    assert proc.returncode == 2
    assert proc.stderr.strip().endswith("error: unknown benchmark 'bogus'; allowed: "
                                        + ", ".join(runner.BENCHMARKS)
                                        + " (python -m benchmarks --list)")
