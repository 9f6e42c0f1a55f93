"""studies/response_errors.py: the transcribed paper ranges, and a smoke run of ``--quick``."""

from __future__ import annotations

import csv
import importlib.util
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
STUDY = ROOT / "studies" / "response_errors.py"
# shared/ stands beside the checkout (here and in CI)
PAPER = ROOT.parent / "shared" / "reference" / "chen-wang-gao-2022.txt"


def _module():
    spec = importlib.util.spec_from_file_location("response_errors", STUDY)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


@pytest.mark.skipif(not PAPER.exists(), reason="the paper's text is not available")
def test_transcribed_ranges_match_the_paper_text():
    mod = _module()
    found = mod.extract_paper_ranges(PAPER.read_text(encoding="utf-8"))
    assert len(found) == len(mod.PAPER_RANGES) == 30
    mod.check_paper_ranges(PAPER)  # raises SystemExit on any difference


def test_every_compared_case_with_a_paper_section_has_its_ranges():
    mod = _module()
    for comp in mod.COMPARISONS:
        if comp.section is None:
            continue
        for case in comp.cases:
            for q in mod.QTY:
                assert mod.paper_range(comp.section, case, q) is not None, (comp.key, case, q)


@pytest.mark.slow
def test_quick_study_runs(tmp_path):
    subprocess.run([sys.executable, str(STUDY), "--out", str(tmp_path), "--quick"], check=True,
                   cwd=ROOT, capture_output=True)
    rows = list(csv.DictReader(open(tmp_path / "errors.csv", encoding="utf-8")))
    assert {r["case"] for r in rows} == {"dry-3pi", "lub-3pi", "sc-dry", "sc-lub"}
    acc = {r["case"]: max(-float(r["min"]), float(r["max"])) for r in rows
           if r["quantity"] == "acceleration"}
    assert acc["lub-3pi"] < 0.1 * acc["dry-3pi"]
    for name in ("summary.md", "runs.csv", "fig_dry_vs_lubricated_3pi_errors.png",
                 "fig_slider_crank_orbits.png"):
        assert (tmp_path / name).stat().st_size > 0
