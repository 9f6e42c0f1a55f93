"""simulate(scene, reference=...): errors against another design's ideal mechanism."""

import math

import numpy as np
import pytest

from mechrel.errors import SimulationError
from mechrel.scene import load_scene
from mechrel.simulation import simulate

# rod 0.12 m -> 0.1215 m: a rod-length tolerance on the ideal slider-crank
LONG_ROD = {"bodies.rod.points": {"A": [-0.06075, 0.0], "B": [0.06075, 0.0]},
            "bodies.rod.position": [0.11075, 0.0], "bodies.slider.position": [0.1715, 0.0],
            "analysis.sample_step_angle": math.radians(10.0)}


def _slider_x(r, l, theta):
    return r * np.cos(theta) + np.sqrt(l * l - (r * np.sin(theta)) ** 2)


def test_reference_errors_of_a_longer_rod_equal_the_closed_form():
    # the ideal slider-crank with a 1.5 mm longer rod, measured against the nominal design: the
    # error is the closed-form difference of the slider positions. Both sides are kinematic
    # analyses assembled to 1e-12 m, so 1e-10 m covers them with margin.
    nominal = load_scene("slider-crank", overrides={"analysis.sample_step_angle":
                                                    math.radians(10.0)})
    scene = load_scene("slider-crank", overrides=LONG_ROD)
    res = simulate(scene, reference=nominal)
    theta = np.radians(res.crank_angle)
    expected = _slider_x(0.05, 0.1215, theta) - _slider_x(0.05, 0.12, theta)
    err = res.error("slider", "displacement")
    assert np.max(np.abs(err - expected)) < 1e-10
    assert np.max(np.abs(expected)) > 1e-3  # the tolerance is far below the effect
    frame = res.to_frame()
    assert "slider.displacement.error" in frame
    assert res.provenance["reference"] == "slider-crank"
    # without a reference an ideal scene has no counterpart and no error
    assert simulate(scene).ideal is None


def test_reference_equal_to_the_scene_changes_nothing():
    # the dry slider-crank against itself as the reference: bitwise the run without one
    scene = load_scene("slider-crank-dry", overrides={"analysis.cycles": 0.2})
    a = simulate(scene)
    b = simulate(scene, reference=scene)
    for qty in ("displacement", "velocity", "acceleration"):
        assert np.array_equal(a.outputs["slider"][qty], b.outputs["slider"][qty])
        assert np.array_equal(a.ideal["slider"][qty], b.ideal["slider"][qty])


def test_reference_of_a_clearance_scene_is_the_reference_design():
    # a dry joint in a longer-rod design against the nominal ideal: the ideal counterpart is the
    # nominal closed form, not the longer rod's
    nominal = load_scene("slider-crank", overrides={"analysis.sample_step_angle":
                                                    math.radians(10.0)})
    scene = load_scene("slider-crank-dry", overrides={**LONG_ROD, "analysis.cycles": 0.2})
    res = simulate(scene, reference=nominal)
    theta = np.radians(res.crank_angle)
    assert np.max(np.abs(res.ideal["slider"]["displacement"]
                         - _slider_x(0.05, 0.12, theta))) < 1e-10


@pytest.mark.parametrize("override, match", [
    ({"outputs": {"tip": {"point": "slider.B", "axis": [1.0, 0.0]}}},
     r"reference = embedded:slider-crank: output names \('tip',\) differ from the scene's "
     r"\('slider',\); allowed: a reference with the scene's output names"),
    ({"bodies.slider.points": {"B": [0.0, 0.0]}, "drivers.crank.speed": 100.0},
     r"reference = embedded:slider-crank: drivers .* differ from the scene's .*; allowed: a "
     r"reference with the scene's drivers"),
])
def test_incompatible_reference_is_a_clear_error(override, match):
    scene = load_scene("slider-crank")
    reference = load_scene("slider-crank", overrides=override)
    with pytest.raises(SimulationError, match=match):
        simulate(scene, reference=reference)


def test_reference_with_other_bodies_is_a_clear_error():
    with pytest.raises(SimulationError, match=r"reference = embedded:double-pendulum: bodies "
                       r".* differ from the scene's \('crank', 'rod', 'slider'\)"):
        simulate(load_scene("slider-crank"), reference=load_scene("double-pendulum"))
    with pytest.raises(SimulationError, match=r"reference = 'nominal': not a Scene"):
        simulate(load_scene("slider-crank"), reference="nominal")
