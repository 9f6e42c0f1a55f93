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
REFERENCE = ROOT / "docs" / "reference.md"


def _module():
    spec = importlib.util.spec_from_file_location("response_errors", STUDY)
    mod = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = mod  # dataclasses look their module up there
    spec.loader.exec_module(mod)
    return mod


def test_transcribed_ranges_are_the_ones_docs_reference_restates():
    # docs/reference.md restates the 30 ranges of the paper's §4.1–4.3 (the paper's text is not
    # in the repository): the study compares against exactly those numbers, in that order.
    mod = _module()
    rows = mod.documented_ranges(REFERENCE.read_text(encoding="utf-8"))
    assert len(rows) == len(mod.PAPER_RANGES) == 30
    units = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s²"}
    for (s, c, q, lo, hi), (ds, dc, dq, dlo, dhi, du) in zip(mod.PAPER_RANGES, rows):
        # the same decimal literals: equal as floats
        assert (s, c, q, lo, hi, units[q]) == (ds, dc, dq, dlo, dhi, du)


def test_paper_text_check_reads_the_latex_ranges_and_names_a_difference(tmp_path):
    # check_paper_ranges parses the paper's LaTeX-like text ("[-4.047 \\times 10^{-3} \\text{m},
    # ...]"); fed the documented ranges in that form it passes, and one changed digit stops it.
    mod = _module()
    units = {"displacement": "m", "velocity": "m/s", "acceleration": "m/s^2"}

    def latex(x):
        m, e = f"{x:.6e}".split("e")
        return f"{float(m):g} \\times 10^{{{int(e)}}}"

    def text(ranges):
        body = " ".join(f"[{latex(lo)} \\text{{{units[q].removesuffix('^2')}}}"
                        f"{'^2' if q == 'acceleration' else ''}, {latex(hi)} "
                        f"\\text{{{units[q].removesuffix('^2')}}}"
                        f"{'^2' if q == 'acceleration' else ''}]" for _, _, q, lo, hi in ranges)
        return f"4.1 Impacts of dry contact {body} Fig. 17 Acceleration error of slider"

    good = tmp_path / "good.txt"
    good.write_text(text(mod.PAPER_RANGES), encoding="utf-8")
    mod.check_paper_ranges(good)
    bad = list(mod.PAPER_RANGES)
    bad[4] = bad[4][:3] + (-366.0, bad[4][4])
    (tmp_path / "bad.txt").write_text(text(bad), encoding="utf-8")
    with pytest.raises(SystemExit, match="transcription differs for §4.1 \\(3π\\) dry-3pi "
                                         "acceleration"):
        mod.check_paper_ranges(tmp_path / "bad.txt")


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
