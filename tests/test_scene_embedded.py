"""The embedded scenes: each loads, has the documented content, round-trips through its raw
mapping, and its initial guess is consistent (checked by an independent position solver)."""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType

import numpy as np
import pytest

from mechrel.scene import (
    GROUND, Scene, embedded_names, list_scenes, load_scene, scene_hash,
)

EXPECTED = {
    "slider-crank", "slider-crank-dry", "slider-crank-lubricated",
    "nine-bar", "nine-bar-dry", "nine-bar-lubricated", "double-pendulum", "four-bar",
    "whitworth", "inverted-slider-crank",
}


# --------------------------------------------------------------------------- a tiny position solver
# Independent of mechrel.mechanics: Newton–Raphson with a finite-difference Jacobian on the
# ideal joints and constant-speed drivers of a scene.

def _point(scene, q, index, ref):
    if ref.body == GROUND:
        return np.asarray(scene.ground[ref.point], dtype=float)
    i = index[ref.body]
    x, y, th = q[3 * i: 3 * i + 3]
    sx, sy = scene.bodies[ref.body].points[ref.point]
    c, s = math.cos(th), math.sin(th)
    return np.array([x + c * sx - s * sy, y + s * sx + c * sy])


def _angle(q, index, body):
    return 0.0 if body == GROUND else q[3 * index[body] + 2]


def _residual(scene, q, t, index):
    r = []
    for j in scene.joints.values():
        if j.type == "revolute":
            r.extend(_point(scene, q, index, j.points[1]) - _point(scene, q, index, j.points[0]))
        elif j.type in ("translational", "pin-in-slot"):
            # points[0] on the line through points[1]; the direction is written like the line
            # body's points (ground axes at t = 0 for a body written by global_points)
            line = j.points[1].body
            d = _point(scene, q, index, j.points[0]) - _point(scene, q, index, j.points[1])
            ux, uy = j.direction
            if line != GROUND:
                placed = scene.bodies[line].global_points is not None
                th = _angle(q, index, line) - (scene.bodies[line].angle if placed else 0.0)
                ux, uy = (math.cos(th) * ux - math.sin(th) * uy,
                          math.sin(th) * ux + math.cos(th) * uy)
            r.append(-uy * d[0] + ux * d[1])
            if j.type == "translational":
                r.append(_angle(q, index, j.points[0].body) - _angle(q, index, line) - j.angle)
        else:
            r.append(q[3 * index[j.points[0].body] + 2] - j.angle)
    for d in scene.drivers.values():
        assert d.law == "constant-speed"
        r.append(q[3 * index[d.body] + 2] - (d.angle0 + d.speed * t))
    return np.array(r)


def _initial_q(scene):
    return np.array([v for b in scene.bodies.values() for v in (*b.position, b.angle)])


def _solve(scene, q0, t, tol=1e-12):
    index = {n: k for k, n in enumerate(scene.bodies)}
    q = np.array(q0, dtype=float)
    for _ in range(30):
        r = _residual(scene, q, t, index)
        if np.max(np.abs(r)) < tol:
            return q
        J = np.empty((len(r), len(q)))
        for k in range(len(q)):
            dq = q.copy()
            dq[k] += 1e-7
            J[:, k] = (_residual(scene, dq, t, index) - r) / 1e-7
        q = q - np.linalg.solve(J, r)
    raise AssertionError(f"no convergence at t = {t}")


# --------------------------------------------------------------------------- loading

def test_embedded_names_and_list():
    assert set(embedded_names()) == EXPECTED
    scenes = list_scenes()
    assert set(scenes) == EXPECTED
    assert all(isinstance(d, str) and d for d in scenes.values())


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_every_embedded_scene_loads(name):
    s = load_scene(name)
    assert isinstance(s, Scene)
    assert s.name == name
    assert s.source == f"embedded:{name}"
    assert isinstance(s.bodies, MappingProxyType) and isinstance(s.joints, MappingProxyType)
    assert all(isinstance(b.points, MappingProxyType) for b in s.bodies.values())
    assert all(isinstance(j.points, tuple) for j in s.joints.values())
    assert s.analysis_duration > 0 and 0 < s.analysis_sample_step <= s.analysis_duration


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_raw_round_trip(name):
    s = load_scene(name)
    again = load_scene(s.raw)
    assert again.source is None  # a mapping has no file
    assert dataclasses.replace(again, source=s.source) == s
    assert scene_hash(again) == scene_hash(s)
    assert "extends" not in s.raw


@pytest.mark.parametrize("name", sorted(EXPECTED))
def test_initial_guess_satisfies_joints(name):
    """Bodies are placed where the joints are at t = 0 (nine-bar: to the 1 µm rounding of the
    listed joint positions)."""
    s = load_scene(name)
    index = {n: k for k, n in enumerate(s.bodies)}
    r = _residual(s, _initial_q(s), 0.0, index) if s.drivers else None
    if r is None:  # undriven: only the joints
        r = np.array([v for j in s.joints.values()
                      for v in _point(s, _initial_q(s), index, j.points[1])
                      - _point(s, _initial_q(s), index, j.points[0])])
    assert np.max(np.abs(r)) < 2e-6


# --------------------------------------------------------------------------- slider-crank

def test_slider_crank_content():
    s = load_scene("slider-crank")
    assert [s.bodies[n].mass for n in ("crank", "rod", "slider")] == [0.30, 0.21, 0.14]
    assert [s.bodies[n].inertia for n in ("crank", "rod", "slider")] == [1e-4, 2.5e-4, 1e-4]
    crank, rod = s.bodies["crank"], s.bodies["rod"]
    assert math.dist(crank.points["O"], crank.points["A"]) == pytest.approx(0.05)
    assert math.dist(rod.points["A"], rod.points["B"]) == pytest.approx(0.12)
    assert s.gravity == (0.0, -9.81)
    d = s.drivers["crank"]
    assert d.law == "constant-speed" and d.angle0 == 0.0
    assert d.speed == pytest.approx(5000 * 2 * math.pi / 60)
    c = s.joints["C"]
    assert c.model == "ideal" and not c.is_clearance and s.clearance_joints == ()
    assert [str(p) for p in c.points] == ["rod.B", "slider.B"]  # bearing on the rod
    assert (c.clearance, c.bearing_radius, c.length) == (0.5e-3, 10e-3, 40e-3)
    assert c.contact.youngs_modulus_bearing == 206e9 and c.contact.restitution == 0.9
    assert c.friction.coefficient == 0.01
    assert c.lubricant.viscosity == 0.4
    g = s.joints["G"]
    assert g.type == "translational" and g.direction == (1.0, 0.0) and g.angle == 0.0
    assert s.analysis.cycles == 1 and s.analysis.cycle_driver == "crank"
    assert s.analysis.sample_step_angle == pytest.approx(math.radians(1))
    assert s.outputs["slider"].axis == (1.0, 0.0) and str(s.outputs["slider"].point) == "slider.B"


@pytest.mark.parametrize("name, model", [("slider-crank-dry", "dry"),
                                         ("slider-crank-lubricated", "lubricated")])
def test_slider_crank_variants(name, model):
    s = load_scene(name)
    c = s.joints["C"]
    assert c.model == model and s.clearance_joints == (c,)
    assert c.bearing_radius - c.clearance == pytest.approx(9.5e-3)
    assert s.analysis.cycles == 2
    base = load_scene("slider-crank")
    assert s.bodies == base.bodies and s.drivers == base.drivers


# --------------------------------------------------------------------------- nine-bar

NINE_BAR_BODIES = {
    "crank1": ({"O", "A"}, 0.148, 2.382e-4, 0.045),
    "crank2": ({"O", "B"}, 0.265, 1.210e-3, 0.090),
    "rod3": ({"A", "P"}, 0.805, 8.001e-3, 0.326),
    "rod4": ({"B", "P"}, 0.603, 1.337e-2, 0.497),
    "rod5": ({"H", "Q"}, 0.581, 1.212e-2, 0.230),
    "plate": ({"P", "Q", "R"}, 4.334, 3.802e-3, None),
    "rod7": ({"R", "S"}, 0.827, 8.663e-3, 0.335),
    "slider": ({"S"}, 0.801, 3.944e-4, None),
}


def test_nine_bar_content():
    s = load_scene("nine-bar")
    assert "reconstruction" in s.description.lower()
    assert set(s.bodies) == set(NINE_BAR_BODIES)
    for name, (points, mass, inertia, length) in NINE_BAR_BODIES.items():
        b = s.bodies[name]
        assert set(b.points) == points and b.mass == mass and b.inertia == inertia
        if length is not None:
            p1, p2 = b.points.values()
            assert math.dist(p1, p2) == pytest.approx(length, abs=1e-12)
            assert p1[0] == pytest.approx(-p2[0]) and p1[1] == p2[1] == 0.0  # centred bar
    plate = s.bodies["plate"].points
    assert math.dist(plate["P"], plate["Q"]) == pytest.approx(0.386, abs=1e-6)
    assert math.dist(plate["Q"], plate["R"]) == pytest.approx(0.250, abs=1e-6)
    assert math.dist(plate["P"], plate["R"]) == pytest.approx(0.325, abs=1e-6)
    assert np.allclose(np.mean(list(plate.values()), axis=0), 0.0, atol=1e-6)  # centroid origin
    assert dict(s.ground) == {"O1": (0.0, 0.0), "O2": (0.0, -0.430), "H": (0.670, 0.210),
                              "G": (0.670, 0.0)}
    d1, d2 = s.drivers["crank1"], s.drivers["crank2"]
    assert d1.angle0 == pytest.approx(math.radians(60.28))
    assert d1.speed == pytest.approx(-3 * math.pi)
    assert d2.angle0 == pytest.approx(math.radians(-52.86))
    assert d2.speed == pytest.approx(3 * math.pi)
    for name, bearing, journal in (("C1", "rod3.A", "crank1.A"), ("C2", "rod4.B", "crank2.B")):
        j = s.joints[name]
        assert [str(p) for p in j.points] == [bearing, journal]
        assert j.model == "ideal"
        assert (j.clearance, j.bearing_radius, j.length) == (0.5e-3, 15e-3, 40e-3)
        assert j.contact.youngs_modulus_journal == 206e9 and j.contact.poisson_bearing == 0.3
        assert j.contact.restitution == 0.9 and j.friction.coefficient == 0.05
        assert j.lubricant.viscosity == 0.1
    guide = s.joints["guide"]
    assert guide.direction == (0.0, 1.0) and guide.angle == pytest.approx(math.pi / 2)
    assert [str(p) for p in guide.points] == ["slider.S", "ground.G"]
    assert s.analysis.cycle_driver == "crank1" and s.analysis.cycles == 1
    assert s.analysis_duration == pytest.approx(2 / 3)
    assert s.analysis.sample_step_angle == pytest.approx(math.radians(1))
    assert s.outputs["slider"].axis == (0.0, 1.0) and str(s.outputs["slider"].point) == "slider.S"


@pytest.mark.parametrize("name, model", [("nine-bar-dry", "dry"),
                                         ("nine-bar-lubricated", "lubricated")])
def test_nine_bar_variants(name, model):
    s = load_scene(name)
    assert {j.name for j in s.clearance_joints} == {"C1", "C2"}
    assert all(j.model == model for j in s.clearance_joints)
    base = load_scene("nine-bar")
    assert s.bodies == base.bodies and s.analysis == base.analysis


def test_nine_bar_assembles_over_a_cycle():
    """The reconstruction of docs/reference.md: one branch over the whole cycle, stroke ≈ 68.6 mm,
    top dead centre near t ≈ 0.244 s (checked every 3° of crank 1)."""
    s = load_scene("nine-bar")
    idx = list(s.bodies).index("slider")
    q = _initial_q(s)
    ts = np.linspace(0.0, s.analysis_duration, 121)
    ys, prev = [], q
    for t in ts:
        q = _solve(s, q, t)
        assert np.max(np.abs(q - prev)) < 0.1  # no branch jump (cranks turn 0.052 rad a step)
        prev = q
        ys.append(q[3 * idx + 1])
    ys = np.array(ys)
    assert ys.max() - ys.min() == pytest.approx(0.0686, abs=0.5e-3)
    assert ts[ys.argmax()] == pytest.approx(0.244, abs=0.01)
    dq = q - _solve(s, _initial_q(s), 0.0)
    dq[2::3] = (dq[2::3] + math.pi) % (2 * math.pi) - math.pi  # angles modulo 2π
    assert np.allclose(dq, 0.0, atol=1e-9)  # back where it started after one cycle


def test_double_pendulum():
    s = load_scene("double-pendulum")
    assert not s.drivers and s.analysis.duration == 2.0 and s.analysis.sample_step == 1e-3
    assert s.analysis.cycles is None and s.analysis.cycle_driver is None
    assert len(s.bodies) == 2 and all(j.type == "revolute" and not j.is_clearance
                                      for j in s.joints.values())
    for b in s.bodies.values():  # uniform bars: J = m L^2 / 12
        L = math.dist(*b.points.values())
        assert b.inertia == pytest.approx(b.mass * L * L / 12)


def test_docs_example_is_the_embedded_slider_crank():
    """docs/scenes.md's complete example loads and is the embedded scene (up to description)."""
    import re
    import tomllib
    from pathlib import Path

    docs = (Path(__file__).resolve().parents[1] / "docs" / "scenes.md").read_text(encoding="utf-8")
    section = docs.split("## A complete example", 1)[1]
    block = re.search(r"```toml\n(.*?)```", section, re.S).group(1)
    example = load_scene(tomllib.loads(block))
    embedded = load_scene("slider-crank")
    same = load_scene(example.raw, overrides={"description": embedded.description})
    assert scene_hash(same) == scene_hash(embedded)


def test_swapping_bearing_and_journal_by_override():
    s = load_scene("nine-bar", overrides=['joints.C1.connects=["crank1.A", "rod3.A"]'])
    assert [str(p) for p in s.joints["C1"].points] == ["crank1.A", "rod3.A"]


# --------------------------------------------------------------------------- four-bar

def _four_bar_tip(theta):
    """Rocker tip B of the ideal four-bar by circle intersection (crank 0.05, coupler 0.15,
    rocker 0.12 m, pivots O2 = (0, 0), O4 = (0.14, 0); the branch with B above the ground)."""
    ax, ay = 0.05 * np.cos(theta), 0.05 * np.sin(theta)
    dx, dy = 0.14 - ax, -ay
    d = np.hypot(dx, dy)
    a = (0.15 ** 2 - 0.12 ** 2 + d * d) / (2 * d)
    h = np.sqrt(0.15 ** 2 - a * a)
    return ax + a * dx / d - h * dy / d, ay + a * dy / d + h * dx / d


def test_four_bar_ideal_tip_is_the_circle_intersection():
    # the scene with both clearance joints ideal is a Grashof crank-rocker; kinematic analysis
    # (assembled to 1e-12 m) against the closed form, 1e-10 m for rounding in both
    from mechrel.simulation import simulate
    s = load_scene("four-bar", overrides={"joints.A.model": "ideal", "joints.B.model": "ideal",
                                          "analysis.sample_step_angle": math.radians(5.0)})
    assert 0.05 + 0.15 <= 0.12 + 0.14  # Grashof, crank shortest: it turns fully
    res = simulate(s)
    bx, by = _four_bar_tip(np.radians(res.crank_angle))
    assert res.method == "kinematics"
    assert np.max(np.abs(res.outputs["tip"]["displacement"] - bx)) < 1e-10
    assert np.all(by > 0)


def test_four_bar_dry_pin_impacts_and_the_film_carries_the_load():
    # what the scene is for: the dry pin B is in contact (ε > 1) in the last cycle and leaves
    # it again (free flight, ε < 1), while the lubricated pin A stays inside its bearing
    from mechrel.simulation import simulate
    res = simulate(load_scene("four-bar"))
    last = slice(res.time.size - 361, res.time.size)
    eps_b = res.orbits["B"]["eps"][last]
    assert eps_b.max() > 1.0 and eps_b.min() < 1.0
    assert res.orbits["A"]["eps"].max() < 0.99
