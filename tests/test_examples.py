"""Every script in examples/ runs as ``python examples/NAME.py --out DIR``, exits 0 and writes at
least one figure (.png) into DIR."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import mechrel

EXAMPLES = sorted((Path(__file__).resolve().parents[1] / "examples").glob("*.py"))


@pytest.mark.parametrize("script", EXAMPLES, ids=[p.stem for p in EXAMPLES])
def test_example_runs_and_writes_a_figure(script, tmp_path):
    src = str(Path(mechrel.__file__).resolve().parents[1])
    env = {**os.environ, "PYTHONPATH": src + os.pathsep + os.environ.get("PYTHONPATH", ""),
           "MPLBACKEND": "Agg"}
    proc = subprocess.run([sys.executable, str(script), "--out", str(tmp_path)], env=env,
                          capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stderr[-2000:]
    assert list(tmp_path.glob("*.png")), f"{script.name} wrote no figure"
    assert proc.stdout.strip(), f"{script.name} printed nothing"


def test_there_are_examples():
    assert any(p.stem == "four_bar_tolerances" for p in EXAMPLES)
