"""Kinematic analysis against closed forms and the nine-bar reference positions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechrel.errors import AssemblyError
from mechrel.mechanics.kinematics import assemble
from mechrel.mechanics.system import compile_scene
from mechrel.scene import load_scene
from mechrel.simulation import simulate

R, L = 0.05, 0.12
OMEGA = 5000 * 2 * math.pi / 60


def slider_closed_form(theta, omega):
    """x(θ) = r cos θ + sqrt(l² − r² sin² θ) and its time derivatives at constant ω."""
    s, c = np.sin(theta), np.cos(theta)
    S = np.sqrt(L**2 - R**2 * s**2)
    x = R * c + S
    dx = -R * s - R**2 * s * c / S
    ddx = -R * c - R**2 * np.cos(2 * theta) / S - R**4 * s**2 * c**2 / S**3
    return x, omega * dx, omega**2 * ddx


def test_slider_crank_kinematics_matches_closed_form():
    # 1° sampling over one revolution: 361 crank angles (≥ 50 required).
    res = simulate(load_scene("slider-crank"))
    assert res.method == "kinematics"
    assert res.time.size >= 50
    theta = OMEGA * res.time
    x, v, a = slider_closed_form(theta, OMEGA)
    out = res.outputs["slider"]
    # Newton converges to |Φ| ≤ 1e-12 m (assembly_tolerance) and the velocity/acceleration
    # solves are exact up to round-off (cond(Φ_q) ~ 10): 1e-9 relative is far above both.
    # Velocity and acceleration pass through zero, so they are compared relative to their
    # amplitude over the cycle.
    assert np.max(np.abs(out["displacement"] - x) / np.abs(x)) <= 1e-9
    assert np.max(np.abs(out["velocity"] - v)) / np.max(np.abs(v)) <= 1e-9
    assert np.max(np.abs(out["acceleration"] - a)) / np.max(np.abs(a)) <= 1e-9
    assert res.stats["max_position_violation"] <= 1e-12
    # crank angle column: rotation of the cycle driver in degrees
    assert np.allclose(res.crank_angle, np.degrees(theta), atol=1e-9)


NINE_BAR_JOINTS_MM = {  # nine-bar.md, joint positions at t = 0
    ("crank1", "A"): (22.309, 39.081), ("crank2", "B"): (54.339, -501.745),
    ("plate", "P"): (324.059, -84.300), ("plate", "Q"): (704.225, -17.439),
    ("plate", "R"): (605.366, -247.063), ("slider", "S"): (670.000, -575.769),
}


def _point(scene, compiled, q, body, point):
    k = compiled.body_index[body]
    sx, sy = scene.bodies[body].points[point]
    th = q[3 * k + 2]
    return (q[3 * k] + math.cos(th) * sx - math.sin(th) * sy,
            q[3 * k + 1] + math.sin(th) * sx + math.cos(th) * sy)


def test_nine_bar_assembly_matches_reference_positions():
    scene = load_scene("nine-bar")
    compiled = compile_scene(scene)
    q, _ = assemble(compiled.ideal, compiled.q_guess, 0.0)
    for (body, point), (x, y) in NINE_BAR_JOINTS_MM.items():
        px, py = _point(scene, compiled, q, body, point)
        # nine-bar.md prints positions to 1 µm (3 decimals in mm): the round-off is 0.5e-6 m,
        # within the 1e-6 m the foundation issue asks for.
        assert abs(px - x * 1e-3) <= 1e-6 and abs(py - y * 1e-3) <= 1e-6, (body, point, px, py)


def test_nine_bar_full_cycle_stroke_and_violation():
    res = simulate(load_scene("nine-bar"))
    assert res.method == "kinematics"
    assert res.crank_angle[-1] == pytest.approx(360.0)
    assert res.stats["max_position_violation"] <= 1e-8
    d = res.outputs["slider"]["displacement"]
    # nine-bar.md: stroke about 68.6 mm; sampled every 1°, the extremes are within
    # (ω Δt)² x''/8 ≈ 1e-6 m of the true ones.
    assert (d.max() - d.min()) * 1e3 == pytest.approx(68.6, abs=0.1)


def test_nine_bar_full_cycle_with_forward_dynamics():
    res = simulate(load_scene("nine-bar"), method="dynamics", integrator="dopri5",
                   rtol=1e-10, atol=1e-12)
    ref = simulate(load_scene("nine-bar"))
    assert res.stats["max_position_violation"] <= 1e-8
    d, dr = res.outputs["slider"]["displacement"], ref.outputs["slider"]["displacement"]
    assert np.max(np.abs(d - dr)) <= 1e-6 * np.max(np.abs(dr))


def test_unassemblable_geometry_names_the_violated_constraints():
    # A 2 mm rod on a crank that starts vertical (tip 50 mm above the slider line): the rod
    # cannot reach the line, the mechanism cannot close.
    scene = load_scene("slider-crank", overrides={"bodies.rod.points.B": [0.001, 0.0],
                                                  "bodies.rod.points.A": [-0.001, 0.0],
                                                  "drivers.crank.angle0": math.pi / 2})
    with pytest.raises(AssemblyError, match=r"cannot be assembled.*joints\.") as err:
        simulate(scene)
    assert "|Φ| =" in str(err.value)

