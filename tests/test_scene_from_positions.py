"""Scenes written from joint positions (``global_points``): the body frame derived by the
loader, the canonical form and its hash, overrides on the points as written; and the claim of
docs/scenes.md that a rough initial pose assembles onto the drawn configuration."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from mechrel.mechanics.kinematics import assemble
from mechrel.mechanics.system import compile_scene
from mechrel.scene import canonical_json, embedded_names, load_scene, scene_hash, with_overrides
from mechrel.scene.loader import get_value, thaw
from mechrel.simulation import simulate

# The embedded scenes' hashes before global_points, pin-in-slot joints and translational
# joints between moving bodies were added (tools/compare_trees.py's "before" tree): the
# new optional fields stay out of the canonical form when unset, so none of them moved.
HASHES = {
    "double-pendulum": "b6229695f5d7db04b1cb5e0ae09a1ade1e4750bdd6357f4889bfed329506bc58",
    "four-bar": "14d6136daa14e535d286e50d5fb9207e40d43fd8be3a39210643756027a4d7d2",
    "nine-bar": "37f23c7ce77e1018f61939f80712f413371f89decddf6f57f39ad56f5aafa4c2",
    "nine-bar-dry": "88535221b1b5335533d54748919b49df6a2e0e824a270877867beb4977d1f06e",
    "nine-bar-lubricated": "9d3c00710a11d0d4dcb592334fc4c02113f5140d85764b9d2e6d479de80d4f87",
    "slider-crank": "1e3b37394ae9e8dad39074cd3d85f022a6aa91e8fe1fae0ede5d448ae972b5c9",
    "slider-crank-dry": "9f3158c6aff6079809a549164d2631fc0551df9cc611b727ec53eba119d590c9",
    "slider-crank-lubricated":
        "9fd8444c66b7cacee36db9d36ea4f26e8ca969576920154f7cfd447711178c3a",
}


def test_the_existing_scenes_keep_their_hash():
    for name, digest in HASHES.items():
        scene = load_scene(name)
        assert scene_hash(scene) == digest, name
        assert "global_points" not in canonical_json(scene)


def _slider_crank_from_positions():
    """The embedded slider-crank, its bodies given by their points in ground coordinates at
    t = 0 (crank angle 0: O = 0, A = 0.05, B = 0.17 on the x axis)."""
    raw = thaw(load_scene("slider-crank").raw)
    raw["name"] = "slider-crank-from-positions"
    for name, pts in (("crank", {"O": [0.0, 0.0], "A": [0.05, 0.0]}),
                      ("rod", {"A": [0.05, 0.0], "B": [0.17, 0.0]}),
                      ("slider", {"B": [0.17, 0.0]})):
        del raw["bodies"][name]["points"]
        raw["bodies"][name]["global_points"] = pts
    return raw


def test_a_scene_from_joint_positions_is_the_same_mechanism():
    exact = load_scene("slider-crank")
    placed = load_scene(_slider_crank_from_positions())
    for name, body in placed.bodies.items():
        # the body frame at angle 0: each point is g − position, one rounded subtraction; the
        # decimal literals of the two forms then differ by the binary representation errors of
        # g and position (≤ ulp/2 each: 1.4e-17 at 0.17, 7e-18 at 0.11) and that rounding
        for p, s in body.points.items():
            g, c = body.global_points[p], body.position
            assert s == (g[0] - c[0], g[1] - c[1])
            assert s == pytest.approx(exact.bodies[name].points[p], abs=3e-17)
        assert body.global_points is not None and exact.bodies[name].global_points is None
    a, b = simulate(exact), simulate(placed)
    for q in ("displacement", "velocity", "acceleration"):
        ref = a.outputs["slider"][q]
        assert np.max(np.abs(b.outputs["slider"][q] - ref)) <= 1e-12 * np.max(np.abs(ref))


def test_the_canonical_form_keeps_what_was_written():
    scene = load_scene(_slider_crank_from_positions())
    raw = scene.raw["bodies"]["rod"]
    assert "points" not in raw and dict(raw["global_points"]) == {"A": (0.05, 0.0),
                                                                   "B": (0.17, 0.0)}
    again = load_scene(scene.raw)
    assert dataclasses.replace(again, source=scene.source) == scene
    assert scene_hash(again) == scene_hash(scene)
    # another layout of the same file, the same hash
    raw = _slider_crank_from_positions()
    raw["bodies"]["rod"]["global_points"] = {"B": [0.17, 0], "A": [0.05, 0]}
    assert scene_hash(load_scene(raw)) == scene_hash(scene)


def test_overrides_and_uncertain_inputs_address_the_points_as_written():
    scene = load_scene(_slider_crank_from_positions())
    longer = with_overrides(scene, {"bodies.rod.length(A,B)": 0.13})
    assert longer.bodies["rod"].global_points["B"] == pytest.approx((0.18, 0.0), abs=1e-15)
    assert math.dist(*longer.bodies["rod"].points.values()) == pytest.approx(0.13, abs=1e-15)
    assert get_value(longer.raw, "bodies.rod.length(A,B)") == pytest.approx(0.13, abs=1e-15)
    raised = with_overrides(scene, ["bodies.rod.global_points.B[1]=0.001"])
    assert raised.bodies["rod"].points["B"] == pytest.approx((0.06, 0.001), abs=1e-15)
    # the slider follows: the rod is 0.13 m now, so at crank angle 0 the slider is at 0.18 m
    assert simulate(longer).outputs["slider"]["displacement"][0] == pytest.approx(0.18, abs=1e-12)


def test_a_frame_at_an_angle():
    # the crank's frame along O -> A (angle 0.6435 = atan2(0.03, 0.04)): its points become
    # (∓0.025, 0) in it, a driver starting at that angle starts where it is drawn, and a body
    # output reads the absolute direction of O -> A
    raw = thaw(load_scene("slider-crank").raw)
    th = math.atan2(0.03, 0.04)
    raw["bodies"]["crank"] = {"mass": 0.3, "inertia": 1e-4, "position": [0.02, 0.015],
                              "angle": th,
                              "global_points": {"O": [0.0, 0.0], "A": [0.04, 0.03]}}
    raw["drivers"]["crank"]["angle0"] = th
    raw["outputs"]["crank"] = {"kind": "body", "body": "crank"}
    scene = load_scene(raw)
    for p, x in (("O", -0.025), ("A", 0.025)):  # a rotation: a few ulps of 0.025 (3.5e-18)
        assert scene.bodies["crank"].points[p] == pytest.approx((x, 0.0), abs=2e-17)
    c = compile_scene(scene)
    q, _ = assemble(c.ideal, c.q_guess, 0.0)
    assert q[:3] == pytest.approx([0.02, 0.015, th], abs=1e-12)
    res = simulate(scene)
    assert res.outputs["crank"]["angle"][0] == pytest.approx(th, abs=1e-12)


def test_a_line_on_a_body_written_at_an_angle():
    # the Whitworth's lever given at an angle of 0.3 rad (its points still in ground
    # coordinates): the slot's direction, written in ground axes as drawn, turns into the
    # lever's frame with it, so the mechanism is the same, only the lever's angle reads 0.3
    # more
    raw = thaw(load_scene("whitworth", overrides={"joints.A.model": "ideal"}).raw)
    raw["bodies"]["lever"]["angle"] = 0.3
    raw["joints"]["slot"]["angle"] = -0.3  # the block's angle relative to the lever's
    a = simulate(load_scene("whitworth", overrides={"joints.A.model": "ideal"}))
    b = simulate(load_scene(raw))
    assert np.max(np.abs(b.outputs["ram"]["displacement"] - a.outputs["ram"]["displacement"])
                  ) <= 1e-12
    assert np.max(np.abs(b.outputs["lever"]["angle"] - a.outputs["lever"]["angle"] - 0.3)
                  ) <= 1e-12


@pytest.mark.parametrize("name", ["four-bar", "slider-crank", "nine-bar", "whitworth",
                                  "inverted-slider-crank"])
def test_a_rough_pose_assembles_on_the_drawn_branch(name):
    # docs/scenes.md: positions to about a centimetre and angles to about 0.05 rad are enough.
    # 50 random guesses in that box (each coordinate uniform) assemble onto the configuration
    # of the exact guess, to the assembly tolerance's order (1e-12 m; 1e-9 allows for the
    # conditioning of the Jacobian at the solution)
    c = compile_scene(load_scene(name))
    q0, _ = assemble(c.ideal, c.q_guess, 0.0)
    rng = np.random.default_rng(sum(map(ord, name)))
    nb = c.q_guess.size // 3
    for _ in range(50):
        g = c.q_guess.copy()
        g[0::3] += rng.uniform(-0.01, 0.01, nb)
        g[1::3] += rng.uniform(-0.01, 0.01, nb)
        g[2::3] += rng.uniform(-0.05, 0.05, nb)
        q, _ = assemble(c.ideal, g, 0.0)
        assert np.max(np.abs(q - q0)) <= 1e-9


def test_the_embedded_scenes_from_joint_positions_are_drawn_as_written():
    # the drawn configuration is the assembled one at t = 0: the bodies' frames at their
    # centres of mass with angle 0, so q_guess is the assembled q
    for name in ("whitworth", "inverted-slider-crank"):
        scene = load_scene(name)
        assert all(b.global_points is not None for b in scene.bodies.values())
        c = compile_scene(scene)
        q, _ = assemble(c.ideal, c.q_guess, 0.0)
        assert np.max(np.abs(q - c.q_guess)) <= 1e-15
    assert set(HASHES) | {"whitworth", "inverted-slider-crank"} == set(embedded_names())
