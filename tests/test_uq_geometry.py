"""Geometric tolerances as uncertain inputs: point components, link lengths, and the error
measured against the nominal design."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mechrel.errors import EstimateWarning, SceneError, StudyError
from mechrel.scene import load_scene
from mechrel.scene.loader import get_value
from mechrel.uq import Normal, UncertainInputs, fosm
from mechrel.uq.problem.mechanism import MechanismModel, is_geometric


# --------------------------------------------------------------------------- scene paths

def test_a_point_component_is_a_scene_path():
    scene = load_scene("slider-crank", overrides={"bodies.rod.points.B[1]": 1e-3,
                                                  "ground.points.O[0]": -2e-4})
    assert scene.bodies["rod"].points["B"] == (0.06, 1e-3)  # the other component stays
    assert scene.ground["O"] == (-2e-4, 0.0)
    assert get_value(scene.raw, "bodies.rod.points.B[1]") == 1e-3


@pytest.mark.parametrize("length", [0.03, 0.05, 0.0512345, 0.2])
def test_a_length_moves_the_second_point_along_the_line_exactly(length):
    # crank O = (-0.025, 0), A = (0.025, 0) turned to a skew line so that both components move
    base = load_scene("slider-crank", overrides={"bodies.crank.points.O": [-0.01, -0.02],
                                                 "bodies.crank.points.A": [0.03, 0.01]})
    scene = load_scene(base, overrides={"bodies.crank.length(O,A)": length})
    o = np.array(scene.bodies["crank"].points["O"])
    a = np.array(scene.bodies["crank"].points["A"])
    a0 = np.array(base.bodies["crank"].points["A"])
    # |A - O| = L to rounding (a few ulp of the coordinates), O and the direction unchanged
    assert math.hypot(*(a - o)) == pytest.approx(length, rel=4e-16 * 8)
    assert np.array_equal(o, [-0.01, -0.02])
    u0 = (a0 - o) / np.linalg.norm(a0 - o)
    # off the original line by no more than a few ulp of L (the cross product with its direction)
    assert abs(u0[0] * (a - o)[1] - u0[1] * (a - o)[0]) < 4 * np.finfo(float).eps * length
    assert get_value(scene.raw, "bodies.crank.length(O,A)") == pytest.approx(length, rel=1e-15)
    assert scene.bodies["rod"] == base.bodies["rod"]


@pytest.mark.parametrize("override, fragment", [
    ("bodies.crank.points.A[2]=1", "has no component 2"),
    ("bodies.crank.mass[0]=1", "'bodies.crank.mass' = 0.3 has no component 0"),
    ("bodies.crank.length(O,A)=-1", "a length must be a number > 0"),
    ("bodies.crank.length(O,Z)=0.1", "bodies.crank.points.Z: not a value of the scene"),
    ("bodies.crank.points.A(1)=2", "malformed path"),
])
def test_bad_derived_paths_are_one_clear_error(override, fragment):
    with pytest.raises(SceneError, match=None) as info:
        load_scene("slider-crank", overrides=[override])
    assert fragment in str(info.value) and "allowed" in str(info.value)


def test_coincident_points_have_no_length_direction():
    with pytest.raises(SceneError, match="coincide"):
        load_scene("slider-crank", overrides={"bodies.crank.points.A": [-0.025, 0.0],
                                              "bodies.crank.length(O,A)": 0.05})


def test_geometric_paths_are_recognised():
    for p in ("ground.points.O4[0]", "bodies.rod.points.B", "bodies.crank.length(O,A)",
              "ground.length(O2,O4)"):
        assert is_geometric(p)
    for p in ("joints.C1.clearance", "drivers.crank1.speed", "bodies.rod.mass"):
        assert not is_geometric(p)


# --------------------------------------------------------------------------- the model

def test_an_ideal_scene_with_geometric_inputs_is_a_model_against_the_nominal_design():
    model = MechanismModel("slider-crank", ["bodies.crank.length(O,A)"], angle_step=30)
    assert np.array_equal(model.nominal, [0.05])
    assert np.max(np.abs(model.evaluate([0.05]))) < 1e-15  # the nominal design: no error
    # crank 0.1 mm longer: at 0° the slider is 0.1 mm further out (x = r + l)
    assert model.evaluate([0.0501])[0] == pytest.approx(1e-4, rel=1e-9)
    with pytest.raises(StudyError, match="no clearance joints"):
        MechanismModel("slider-crank", ["bodies.crank.length(O,A)"], reference="same-geometry")
    with pytest.raises(StudyError, match="no clearance joints"):
        MechanismModel("slider-crank", ["bodies.crank.mass"])
    with pytest.raises(StudyError, match="reference: 'ideal' is not a reference; allowed"):
        MechanismModel("slider-crank", ["bodies.crank.length(O,A)"], reference="ideal")
    with pytest.raises(StudyError, match=r"'bodies\.crank\.length\(O,Q\)' is not a value"):
        MechanismModel("slider-crank", ["bodies.crank.length(O,Q)"])


def _slider(r, l, theta, w):
    """Closed-form ideal slider-crank (crank r, rod l, no offset, crank angle θ = ω t):
    x = r cos θ + s, s = sqrt(l² − r² sin²θ); v = ω x', a = ω² x'' with
    x' = −r S − r² S C / s, x'' = −r C − r² (C² − S²)/s − r⁴ S² C²/s³ (S = sin θ, C = cos θ)."""
    S, C = np.sin(theta), np.cos(theta)
    s = np.sqrt(l * l - (r * S) ** 2)
    x = r * C + s
    dx = -r * S - r * r * S * C / s
    ddx = -r * C - r * r * (C * C - S * S) / s - r**4 * S * S * C * C / s**3
    return x, w * dx, w * w * ddx


def test_fosm_sigma_of_length_tolerances_is_the_closed_form_sensitivity():
    # FOSM's σ_i = sqrt((∂i/∂r σ_r)² + (∂i/∂l σ_l)²) against the exact derivatives of the closed
    # form (complex step: exact to rounding for an analytic function, no difference quotient).
    # FOSM's automatic step for a kinematic model is h = (tol/size)^(1/3)·|μ| ≈ 2.6e-4 |μ|
    # (tol = 1e-12 m Newton tolerance, size 0.06 m): central-difference truncation
    # ≈ (h/|μ|)² ≈ 7e-8 relative, Newton noise tol/h ≈ 1e-12/1.3e-5 ≈ 8e-8 of a unit slope,
    # both below the 1e-6 asked for. σ passes through 0 at the dead centres (v), so the bound is
    # relative to the curve's largest σ.
    model = MechanismModel("slider-crank", {"crank": ["bodies.crank.length(O,A)"],
                                            "rod": ["bodies.rod.length(A,B)"]}, angle_step=18)
    inputs = UncertainInputs.from_specs({"crank": Normal(0.05, 20e-6),
                                         "rod": Normal(0.12, 30e-6)})
    # the velocity at the dead centres (0°, 180°, 360°) is zero for any lengths: σ_i = 0 there,
    # and FOSM says that its β = ∞ there comes from a zero gradient
    with pytest.warns(EstimateWarning, match=r"gradient is zero at 3 of 63 outputs, e\.g\. "
                      r"\(velocity, 0°\), \(velocity, 180°\), \(velocity, 360°\)"):
        res = fosm(model=model, inputs=inputs, progress=False)
    # and that the cycle extremes of an error that is zero at the nominal design (|e| has its kink
    # there) are not differentiable: their σ/β rows are NaN, with the warning naming them
    assert len(res.warnings) == 2
    assert any("gradient is zero at 3 of 63" in w for w in res.warnings)
    assert any("9 cycle extreme(s) are not differentiable at the means" in w for w in res.warnings)
    w = load_scene("slider-crank").drivers["crank"].speed
    theta = np.radians(model.crank_angles)
    h = 1e-30
    dr = [np.imag(v) / h for v in _slider(0.05 + 1j * h, 0.12, theta, w)]
    dl = [np.imag(v) / h for v in _slider(0.05, 0.12 + 1j * h, theta, w)]
    # the rows at the analysis angles (the model appends each quantity's cycle extremes)
    from mechrel.uq.problem.allowables import per_angle_mask
    table = res.table[per_angle_mask(res.table.index)]
    for k, q in enumerate(("displacement", "velocity", "acceleration")):
        expected = np.hypot(dr[k] * 20e-6, dl[k] * 30e-6)
        got = table.xs(q, level="quantity")["std"].to_numpy()
        assert got.shape == expected.shape == (21,)
        assert np.max(np.abs(got - expected)) <= 1e-6 * np.max(expected), q
        mu = table.xs(q, level="quantity")["mean"].to_numpy()
        assert np.max(np.abs(mu)) <= 1e-9 * np.max(expected)  # the nominal design: no error
    # the gradient itself, per input
    g = res.gradient[per_angle_mask(res.gradient.index)].xs("displacement", level="quantity")
    assert np.max(np.abs(g["crank"].to_numpy() - dr[0])) <= 1e-6
    assert np.max(np.abs(g["rod"].to_numpy() - dl[0])) <= 1e-6


def test_study_files_and_set_accept_geometric_inputs_and_the_reference(tmp_path, capsys):
    from mechrel.cli.main import main
    from mechrel.study.study import load_study

    raw = {"scene": "slider-crank", "angle_step": 30.0,
           "inputs": {"pivot_y": {"paths": ["ground.points.O[1]"], "distribution": "normal",
                                  "mean": 0.0, "std": 1e-5},
                      "crank": {"paths": ["bodies.crank.length(O,A)"],
                                "distribution": "normal", "mean": 0.05, "std": 1e-5}}}
    study = load_study(raw)
    assert study.reference == "nominal"
    assert study.model().nominal_reference
    with pytest.raises(StudyError, match="reference"):
        load_study({**raw, "reference": "ideal"})
    assert load_study({**raw, "reference": "same-geometry"}).reference == "same-geometry"
    # the CLI: a geometric override of the scene and the study's reference by --set
    f = tmp_path / "s.toml"
    f.write_text('scene = "slider-crank"\nangle_step = 30.0\n[inputs.crank]\n'
                 'paths = ["bodies.crank.length(O,A)"]\ndistribution = "normal"\n'
                 'mean = 0.05\nstd = 1e-5\n[reliability]\nmethods = ["fosm"]\n')
    assert main(["reliability", str(f), "--set", "bodies.rod.points.B[1]=1e-4",
                 "--out", str(tmp_path / "o"), "--no-progress", "--jobs", "1"]) == 0
    assert main(["reliability", str(f), "--set", "reference=same-geometry",
                 "--out", str(tmp_path / "o"), "--no-progress"]) == 2
    assert "no clearance joints" in capsys.readouterr().err
