"""The documentation builds without warnings, and the docstrings' examples run.

The HTML build is the documented command (docs/api.md) with ``-W``: any warning (a broken
docstring, a missing page, a bad cross-reference) fails it. The doctests are every ``>>>``
example in the docstrings of the package, compiled functions included (their docstrings live
on ``py_func``, which :mod:`doctest` does not look into by itself).
"""

from __future__ import annotations

import doctest
import importlib
import pkgutil
import subprocess
import sys
from pathlib import Path

import numba.core.dispatcher
import pytest

import mechrel

ROOT = Path(__file__).resolve().parents[1]
MODULES = sorted(m.name for m in pkgutil.walk_packages(mechrel.__path__, "mechrel.")
                 if not m.name.endswith("__main__"))
FLAGS = doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE


def _doctests(module):
    finder = doctest.DocTestFinder()
    tests = finder.find(module)
    for name, obj in vars(module).items():
        if (isinstance(obj, numba.core.dispatcher.Dispatcher)
                and obj.py_func.__module__ == module.__name__):
            tests += [t for t in finder.find(obj.py_func, f"{module.__name__}.{name}",
                                             globs=vars(module)) if t.examples]
    # a compiled function's examples are found twice (the dispatcher, without a line number,
    # and py_func): keep one; key on the docstring, not the line, since the argparse types of
    # mechrel.cli.args share one code object (one line) but each has its own docstring
    seen, out = set(), []
    for t in tests:
        key = (t.filename, t.docstring)
        if t.examples and key not in seen:
            seen.add(key)
            out.append(t)
    return out


def test_doctests_are_found():
    # the modules whose examples the project promises: a finder that misses the compiled
    # functions (or a module that lost its examples) would make the doctests vacuous
    found = {t.name for m in ("mechrel.forces.contact", "mechrel.forces.friction",
                              "mechrel.uq.problem.analytic", "mechrel.scene.loader",
                              "mechrel.integrate.explicit", "mechrel.cli.args",
                              "mechrel.uq.problem.inputs", "mechrel.uq.execution.executor",
                              "mechrel.study.presenters", "mechrel.study.runner",
                              "mechrel.cli.studies")
             for t in _doctests(importlib.import_module(m))}
    for name in ("mechrel.forces.contact.ln_normal_force", "mechrel.forces.friction.friction_force",
                 "mechrel.forces.contact.contact_stiffness", "mechrel.uq.problem.analytic.ishigami",
                 "mechrel.scene.loader.load_scene", "mechrel.integrate.explicit.rk4_kernel",
                 "mechrel.cli.args.sample_count",
                 "mechrel.uq.problem.inputs.UncertainInputs.sample",
                 "mechrel.uq.execution.executor.Evaluations.reduce",
                 "mechrel.study.presenters.Presenter.run",
                 "mechrel.study.runner.run_sensitivity", "mechrel.cli.studies.split_overrides"):
        assert name in found


@pytest.mark.parametrize("name", MODULES)
def test_docstring_examples(name):
    module = importlib.import_module(name)
    runner = doctest.DocTestRunner(optionflags=FLAGS)
    for test in _doctests(module):
        runner.run(test)
    result = runner.summarize(verbose=False)
    assert result.failed == 0, f"{result.failed} of {result.attempted} examples failed in {name}"


# the whole Sphinx build (90 s on two cores): a documentation check, run under -m slow
@pytest.mark.slow
def test_sphinx_build_has_no_warnings(tmp_path):
    # the command of docs/api.md, into a temporary folder; -W --keep-going lists every warning
    proc = subprocess.run(
        [sys.executable, "-m", "sphinx", "-W", "--keep-going", "-q", "-b", "html",
         str(ROOT / "docs"), str(tmp_path / "html")], capture_output=True, text=True, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-4000:]
    assert proc.stderr.strip() == ""
    html = (tmp_path / "html" / "api.html").read_text(encoding="utf-8")
    # the API page holds the rendered docstrings (autodoc ran), with their examples
    for text in ("load_scene", "contact_stiffness", "polynomial_chaos", "9.9536e+10",
                 "all_finite", "kinematic_analysis", "hold_folder"):
        assert text in html, text
    assert (tmp_path / "html" / "reference.html").exists()
