"""The study scripts in studies/ use mechrel's public API only, and each starts: ``--help``
prints its usage and exits 0.

Public means: no module or name with a leading underscore, and a mechrel module that the API
reference renders (docs/api.md). A script may import what a sibling script defines (the
studies share the paper's cases), under the same rule."""

from __future__ import annotations

import ast
import contextlib
import importlib.util
import io
import re
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
STUDIES = ROOT / "studies"
SCRIPTS = sorted(p.stem for p in STUDIES.glob("*.py"))
DOCUMENTED = set(re.findall(r"\.\. auto(?:module|function|class):: (mechrel[\w.]*)",
                            (ROOT / "docs" / "api.md").read_text(encoding="utf-8")))


def private_uses(source: str, siblings=()) -> list[str]:
    """Each import of ``source`` that is not public API: ``module: name`` and why."""
    found = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            pairs = [(alias.name, None) for alias in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            pairs = [(node.module, alias.name) for alias in node.names]
        else:
            continue
        for module, name in pairs:
            top = module.split(".")[0]
            if top not in ("mechrel", *siblings):
                continue
            label = f"{module}: {name}" if name else module
            if any(part.startswith("_") for part in module.split(".")):
                found.append(f"{label} (a private module)")
            elif name is not None and name.startswith("_"):
                found.append(f"{label} (a private name)")
            elif top == "mechrel" and module not in DOCUMENTED:
                found.append(f"{label} (a module the API reference does not document)")
    return found


def test_the_check_finds_what_the_scripts_used_to_import():
    # the imports issue 33 found in the scripts, and a sibling's private helper
    source = ("from mechrel.uq._common import package_versions\n"
              "from mechrel.uq.estimators.monte_carlo import _draw_allowables\n"
              "import mechrel._kernel_cache\n"
              "def f():\n    from reliability_paper import _md\n"
              "from mechrel.mechanics.problem import rhs\n"
              "from mechrel.uq import monte_carlo\n")
    assert sorted(private_uses(source, siblings=("reliability_paper",))) == sorted([
        "mechrel.uq._common: package_versions (a private module)",
        "mechrel.uq.estimators.monte_carlo: _draw_allowables (a private name)",
        "mechrel._kernel_cache (a private module)",
        "reliability_paper: _md (a private name)",
        "mechrel.mechanics.problem: rhs (a module the API reference does not document)",
    ])


@pytest.mark.parametrize("name", SCRIPTS)
def test_study_script_imports_only_public_api(name):
    source = (STUDIES / f"{name}.py").read_text(encoding="utf-8")
    assert private_uses(source, siblings=tuple(SCRIPTS)) == []


@pytest.mark.parametrize("name", SCRIPTS)
def test_study_script_prints_its_usage(name):
    spec = importlib.util.spec_from_file_location(f"study_script_{name}", STUDIES / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up while it executes
    spec.loader.exec_module(module)
    out = io.StringIO()
    with contextlib.redirect_stdout(out), pytest.raises(SystemExit) as info:
        module.main(["--help"])
    assert info.value.code == 0
    assert out.getvalue().startswith("usage: ") and "--out" in out.getvalue()
