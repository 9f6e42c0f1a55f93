"""Every script in examples/ runs as documented and writes its figure.

The convention (docs/api.md, README): ``python examples/NAME.py --out DIR`` exits 0 and writes
at least one PNG into DIR. Each script checks its own numbers where it makes a claim (the Dask
example stops with an error if the cluster's results differ from the in-process ones).
The scripts run against the mechrel the tests import (installed or checkout), so they share
its compiled-kernel cache.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

import mechrel

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted((ROOT / "examples").glob("*.py"))


def test_the_examples_are_there():
    names = {p.stem for p in SCRIPTS}
    assert {"four_bar", "generic_model", "dask_cluster", "four_bar_tolerances"} <= names


# The examples that run a study (a rare-event study on the mechanism, a tolerance study, a local
# Dask cluster) take 15-40 s each on two idle cores: they run under -m slow; the others (a
# simulation, a generic model, a custom clearance model) stay in the default suite.
SLOW_EXAMPLES = {"rare_events", "four_bar_tolerances", "dask_cluster"}


@pytest.mark.parametrize("script", [pytest.param(p, marks=pytest.mark.slow)
                                    if p.stem in SLOW_EXAMPLES else p for p in SCRIPTS],
                         ids=[p.stem for p in SCRIPTS])
def test_example_runs_and_writes_a_figure(script, tmp_path):
    src = str(Path(mechrel.__file__).resolve().parents[1])
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PYTHONPATH": os.pathsep.join([src, *filter(None, [os.environ.get("PYTHONPATH")])])}
    proc = subprocess.run([sys.executable, str(script), "--out", str(tmp_path)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-4000:]
    pngs = list(tmp_path.glob("*.png"))
    assert pngs and all(p.stat().st_size > 10_000 for p in pngs), proc.stdout
    assert proc.stdout.strip(), "an example prints what it computed"
