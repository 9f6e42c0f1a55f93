"""The repository's own files: lint clean, license and citation metadata consistent."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LINTED = ["src", "tests", "examples", "benchmarks", "tools", "studies"]


def test_ruff_is_clean():
    # the rules are [tool.ruff] in pyproject.toml; ruff is in the test extra
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache", *LINTED],
                          cwd=ROOT, capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]


def test_ruff_reports_a_violation():
    # the check above is not vacuous: the same configuration flags an unused import
    proc = subprocess.run([sys.executable, "-m", "ruff", "check", "--no-cache",
                           "--stdin-filename", "src/mechrel/_probe.py", "-"],
                          input='"""Probe."""\n\nimport os\n', cwd=ROOT, capture_output=True,
                          text=True)
    assert proc.returncode == 1 and "F401" in proc.stdout


def test_license_citation_and_pyproject_agree():
    project = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))["project"]
    assert project["license"] == {"text": "MIT"}
    license_text = (ROOT / "LICENSE").read_text(encoding="utf-8")
    assert license_text.startswith("MIT License\n\nCopyright (c) 2026 mechrel developers\n")
    cff = (ROOT / "CITATION.cff").read_text(encoding="utf-8")
    fields = dict(line.split(": ", 1) for line in cff.splitlines()
                  if line and not line.startswith((" ", "-", "#")) and ": " in line)
    assert fields["cff-version"] == "1.2.0"
    assert fields["version"] == project["version"]
    assert fields["license"] == "MIT"
    assert "doi: 10.1007/s00419-022-02283-2" in cff
    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    assert "## [Unreleased]" in changelog


def test_no_reference_outside_the_repository():
    # a fresh clone has nothing beside it: no tracked file may point at the project's notes
    # folder next to the checkout
    files = subprocess.run(["git", "ls-files"], cwd=ROOT, capture_output=True, text=True,
                           check=True).stdout.split()
    needle = "shared/" + "reference"
    hits = [f for f in files if (ROOT / f).is_file() and f.endswith((".py", ".md", ".toml", ".cff"))
            and needle in (ROOT / f).read_text(encoding="utf-8", errors="replace")]
    assert hits == []


def _mypy(*files):
    # the configuration is [tool.mypy] in pyproject.toml (the public API modules; files given
    # here replace its list); mypy is in the test extra; its cache (.mypy_cache/, ignored by
    # git) keeps a warm run to seconds
    return subprocess.run([sys.executable, "-m", "mypy", *map(str, files)], cwd=ROOT,
                          capture_output=True, text=True)


def test_mypy_is_clean():
    proc = _mypy()
    assert proc.returncode == 0, proc.stdout[-4000:] + proc.stderr[-2000:]
    assert "Success: no issues found" in proc.stdout


def test_mypy_checks_the_public_types(tmp_path):
    # every estimator result satisfies the Result protocol, every estimator is an Estimator ...
    good = ("from mechrel.uq import fosm, monte_carlo, polynomial_chaos, sobol_indices\n"
            "from mechrel.uq.estimators.fosm import FOSMResult\n"
            "from mechrel.uq.estimators.monte_carlo import MonteCarloResult\n"
            "from mechrel.uq.estimators.normality import NormalityResult\n"
            "from mechrel.uq.surrogates.pce import PCEResult\n"
            "from mechrel.uq.estimators.protocols import Estimator, Result\n"
            "from mechrel.uq.estimators.sobol import SobolResult\n"
            "def f(a: FOSMResult, b: MonteCarloResult, c: PCEResult, d: SobolResult,\n"
            "      e: NormalityResult) -> list[Result]:\n"
            "    return [a, b, c, d, e]\n"
            "E: list[Estimator] = [fosm, monte_carlo, polynomial_chaos, sobol_indices]\n")
    (tmp_path / "good.py").write_text(good, encoding="utf-8")
    proc = _mypy(tmp_path / "good.py")
    assert proc.returncode == 0, proc.stdout[-4000:]
    # ... and the check is not vacuous: a wrong use of the same types is reported
    bad = ("from mechrel.scene import load_scene\n"
           "from mechrel.uq.estimators.protocols import Result\n"
           "def g(r: Result) -> int:\n"
           "    return r.warnings\n"
           "n: int = load_scene('nine-bar-dry').name\n")
    (tmp_path / "bad.py").write_text(bad, encoding="utf-8")
    proc = _mypy(tmp_path / "bad.py")
    assert proc.returncode == 1
    assert proc.stdout.count("error: Incompatible") == 2, proc.stdout
