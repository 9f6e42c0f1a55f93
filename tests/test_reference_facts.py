"""The facts docs/reference.md restates from the paper hold in the embedded nine-bar scene.

docs/reference.md is the repository's own statement of what mechrel takes from Chen, Wang &
Gao (2022) and of its reconstruction of the nine-bar's unpublished geometry. These tests read
that page (not a copy of its numbers) and check the scene files and the assembled mechanism
against it, so the page and the code cannot drift apart.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import pytest

from mechrel.mechanics.kinematics import assemble
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene

DOC = Path(__file__).resolve().parents[1] / "docs" / "reference.md"
TEXT = DOC.read_text(encoding="utf-8").replace("\u2212", "-")  # typographic minus signs
NUM = r"(-?\d+(?:\.\d+)?(?:e-?\d+)?)"


def _section(title: str) -> str:
    start = TEXT.index(title)
    nxt = TEXT.find("\n## ", start + len(title))
    return TEXT[start: nxt if nxt >= 0 else len(TEXT)]


def _table1() -> dict[str, tuple[str, str, str]]:
    """Body number → (length, mass, J) cells of the restated Table 1."""
    rows = {}
    for line in _section("### Published").splitlines():
        m = re.match(r"\| (\d) [^|]*\| ([^|]*) \| ([^|]*) \| ([^|]*) \|", line)
        if m:
            rows[m.group(1)] = tuple(c.strip() for c in m.group(2, 3, 4))
    return rows


def _pairs(label: str, text: str) -> dict[str, tuple[float, float]]:
    """``NAME (x, y)`` or ``NAME = (x, y)`` pairs (mm) on the bullet line that starts with label."""
    line = next(ln for ln in text.splitlines() if ln.strip().startswith(label))
    i = text.index(line)
    block = text[i: text.find("\n* ", i + 1)]
    return {m.group(1): (float(m.group(2)), float(m.group(3))) for m in re.finditer(
        r"\b([A-Z])\s*=?\s*\(" + NUM + r",\s*" + NUM + r"\)", block)}


RECON = _section("### Not published")
SCENE = load_scene("nine-bar")
BODY = {"1": "crank1", "2": "crank2", "3": "rod3", "4": "rod4", "5": "rod5", "6": "plate",
        "7": "rod7", "8": "slider"}


def test_restated_table1_masses_and_inertias_are_the_scenes():
    rows = _table1()
    assert set(rows) == set("123456789")
    for k, name in BODY.items():
        _, mass, inertia = rows[k]
        body = SCENE.bodies[name]
        # printed values, transcribed exactly: equal to the last printed digit
        assert body.mass == float(mass), name
        assert body.inertia == float(inertia), name


def test_restated_bar_lengths_are_the_distances_between_the_scenes_points():
    rows = _table1()
    ends = {"crank1": "OA", "crank2": "OB", "rod3": "AP", "rod4": "BP", "rod5": "HQ",
            "rod7": "RS"}
    for k, name in BODY.items():
        if name not in ends:
            continue
        a, b = (SCENE.bodies[name].points[p] for p in ends[name])
        # lengths printed in whole mm; the scene holds them exactly (1e-12 m: round-off)
        assert math.dist(a, b) == pytest.approx(float(rows[k][0]) * 1e-3, abs=1e-12), name
        # bars are centred at mid-length (eq. 21)
        assert a[0] + b[0] == pytest.approx(0.0, abs=1e-15) and a[1] == b[1] == 0.0, name
    # O1–O2: the frame's 430 mm
    o1, o2 = SCENE.ground["O1"], SCENE.ground["O2"]
    assert math.dist(o1, o2) == pytest.approx(float(rows["9"][0]) * 1e-3, abs=1e-15)


def test_plate_sides_follow_eq21_index_convention():
    # restated: |QR| = 250 mm forced by eq. (21), |PQ| = 386 mm, |PR| = 325 mm
    sides = {m.group(1): float(m.group(2)) for m in re.finditer(
        r"\|([PQR]{2})\| = (\d+) mm", RECON)}
    assert sides == {"QR": 250.0, "PQ": 386.0, "PR": 325.0}
    pts = SCENE.bodies["plate"].points
    for pair, mm in sides.items():
        # the scene file writes the vertices with 12 decimals (0.5e-12 m per coordinate): the
        # distance of two such points is off by at most 2·√2·0.5e-12 < 2e-12 m
        assert math.dist(pts[pair[0]], pts[pair[1]]) == pytest.approx(mm * 1e-3, abs=2e-12)
    # the printed side list of Table 1 is the same set of lengths
    assert sorted(map(float, _table1()["6"][0].replace("sides", "").split("/"))) == \
        sorted(sides.values())


def test_reconstructed_ground_pivot_guide_and_plate_vertices():
    h = re.search(r"H = \(" + NUM + r", " + NUM + r"\) mm; slider guide on the vertical line "
                  r"x = " + NUM + " mm", RECON)
    hx, hy, guide = (float(g) * 1e-3 for g in h.groups())
    assert SCENE.ground["H"] == pytest.approx((hx, hy), abs=1e-15)
    guide_joint = SCENE.joints["guide"]
    gp = SCENE.ground[guide_joint.points[0].point if guide_joint.points[0].body == "ground"
                      else guide_joint.points[1].point]
    assert gp[0] == pytest.approx(guide, abs=1e-15)
    verts = _pairs("* Plate vertices", RECON)
    assert set(verts) == {"P", "Q", "R"}
    for name, (x, y) in verts.items():
        sx, sy = SCENE.bodies["plate"].points[name]
        # printed rounded to 1 µm (3 decimals in mm): round-off 0.5e-6 m
        assert abs(sx - x * 1e-3) <= 0.5e-6 and abs(sy - y * 1e-3) <= 0.5e-6, name


def test_assembled_positions_at_t0_and_eq21_rows_15_16():
    compiled = compile_scene(SCENE)
    q, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)

    def world(body, point):
        k = compiled.body_index[body]
        sx, sy = SCENE.bodies[body].points[point]
        th = q[3 * k + 2]
        return (q[3 * k] + math.cos(th) * sx - math.sin(th) * sy,
                q[3 * k + 1] + math.sin(th) * sx + math.cos(th) * sy)

    where = {"A": ("crank1", "A"), "B": ("crank2", "B"), "P": ("plate", "P"),
             "Q": ("plate", "Q"), "R": ("plate", "R"), "S": ("slider", "S")}
    listed = _pairs("* Joint positions at t = 0", RECON)
    assert set(listed) == set(where)
    for name, (x, y) in listed.items():
        px, py = world(*where[name])
        # printed to 1 µm; assembly converges to 1e-12 m: 1e-6 m covers the rounding
        assert abs(px - x * 1e-3) <= 1e-6 and abs(py - y * 1e-3) <= 1e-6, (name, px, py)
    # Correction 12: rows 15–16 of eq. (21) walk H → Q → R → S with the FULL rod 7 (L_7), not
    # its half L_s7. The assembled slider pin is a whole rod 7 (335 mm) from the plate's R.
    l7 = float(_table1()["7"][0]) * 1e-3
    r, s = world("plate", "R"), world("slider", "S")
    assert math.dist(r, s) == pytest.approx(l7, abs=1e-11)
    assert math.dist(r, s) - l7 / 2 > 0.1  # L_s7 would put S 167.5 mm short
    # and S lies on the guide x = H_x (row 17)
    assert s[0] == pytest.approx(SCENE.ground["H"][0], abs=1e-11)
