"""Malformed scenes: each is rejected with exactly one SceneError whose message names the file,
the field path, the offending value and what is allowed."""

from __future__ import annotations

import math

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechrel.errors import SceneError
from mechrel.scene import load_scene

BASE = """\
name = "test"
description = "a slider-crank for error tests"
gravity = [0.0, -9.81]

[ground.points]
O = [0.0, 0.0]

[bodies.crank]
mass = 0.30
inertia = 1e-4
position = [0.025, 0.0]
angle = 0.0
points = { O = [-0.025, 0.0], A = [0.025, 0.0] }

[bodies.rod]
mass = 0.21
inertia = 2.5e-4
position = [0.11, 0.0]
angle = 0.0
points = { A = [-0.06, 0.0], B = [0.06, 0.0] }

[bodies.slider]
mass = 0.14
inertia = 1e-4
position = [0.17, 0.0]
angle = 0.0
points = { B = [0.0, 0.0] }

[joints.O]
type = "revolute"
connects = ["ground.O", "crank.O"]

[joints.A]
type = "revolute"
connects = ["crank.A", "rod.A"]

[joints.C]
type = "revolute"
connects = ["rod.B", "slider.B"]
model = "dry"
clearance = 0.5e-3
bearing_radius = 10e-3
length = 40e-3

[joints.C.contact]
restitution = 0.9
poisson_bearing = 0.3
stiffness = "conformal"

[joints.C.friction]
coefficient = 0.01
v0 = 1e-4
v1 = 1e-2

[joints.C.lubricant]
viscosity = 0.4
eps0 = 0.1

[joints.C.transition]
eps_max = 0.99

[joints.G]
type = "translational"
connects = ["slider.B", "ground.O"]
direction = [1.0, 0.0]
angle = 0.0

[drivers.crank]
body = "crank"
law = "constant-speed"
angle0 = 0.0
speed = 523.5987755982989

[outputs.slider]
point = "slider.B"
axis = [1.0, 0.0]

[analysis]
cycles = 1
cycle_driver = "crank"
sample_step_angle = 0.017453292519943295

[solver]
integrator = "rk4"
step = 1e-6
rtol = 1e-8
max_steps = 1000000
"""


def _edit(*pairs: str):
    """Replace each ``old`` by its ``new`` (pairs ``old, new, old, new, ...``), each occurring
    exactly once."""
    def f(text: str) -> str:
        for old, new in zip(pairs[::2], pairs[1::2]):
            assert text.count(old) == 1, f"test bug: {old!r} occurs {text.count(old)} times"
            text = text.replace(old, new)
        return text
    return f


def _append(extra: str):
    return lambda text: text + extra


# (id, edit of BASE, substrings the message must contain: path, value, what is allowed)
CASES = [
    ("missing-mass", _edit("mass = 0.30\n", ""),
     ["bodies.crank.mass", "missing required field", "a finite number > 0 (kg)"]),
    ("missing-position", _edit("position = [0.11, 0.0]\n", ""),
     ["bodies.rod.position", "missing", "a pair [x, y] of finite numbers (m)"]),
    ("missing-joint-type",
     _edit('type = "revolute"\nconnects = ["ground.O"', 'connects = ["ground.O"'),
     ["joints.O.type", "missing", "one of revolute, translational, pin-in-slot, fixed-angle"]),
    ("missing-name", _edit('name = "test"\n', ""),
     ["name", "missing required field", "a string naming the scene"]),
    ("mass-wrong-type", _edit("mass = 0.30", 'mass = "heavy"'),
     ["bodies.crank.mass", '"heavy"', "expected a number, got a string", "> 0 (kg)"]),
    ("mass-bool", _edit("mass = 0.30", "mass = true"),
     ["bodies.crank.mass", "= true", "boolean", "a finite number > 0 (kg)"]),
    ("inertia-nan", _edit("inertia = 2.5e-4", "inertia = nan"),
     ["bodies.rod.inertia", "= nan", "not a finite number", "a finite number > 0 (kg m^2)"]),
    ("gravity-inf", _edit("gravity = [0.0, -9.81]", "gravity = [0.0, -inf]"),
     ["gravity", "[0.0, -inf]", "not a finite number", "a pair [x, y] of finite numbers (m/s^2)"]),
    ("gravity-3-components", _edit("gravity = [0.0, -9.81]", "gravity = [0.0, -9.81, 0.0]"),
     ["gravity", "[0.0, -9.81, 0.0]", "expected 2 components", "a pair [x, y]"]),
    ("mass-negative", _edit("mass = 0.30", "mass = -0.3"),
     ["bodies.crank.mass", "-0.3", "must be > 0", "a finite number > 0 (kg)"]),
    ("inertia-zero", _edit("inertia = 2.5e-4", "inertia = 0.0"),
     ["bodies.rod.inertia", "= 0.0", "must be > 0", "a finite number > 0 (kg m^2)"]),
    ("unknown-body-ref",
     _edit('connects = ["crank.A", "rod.A"]', 'connects = ["crank.A", "rdo.A"]'),
     ["joints.A.connects[1]", '"rdo.A"', "unknown body 'rdo'", "did you mean 'rod'",
      "ground, crank, rod, slider"]),
    ("unknown-point-ref",
     _edit('connects = ["crank.A", "rod.A"]', 'connects = ["crank.A", "rod.Z"]'),
     ["joints.A.connects[1]", '"rod.Z"', "unknown point 'Z' on rod", "rod.A, rod.B"]),
    ("malformed-point-ref",
     _edit('connects = ["crank.A", "rod.A"]', 'connects = ["crank.A", "rodA"]'),
     ["joints.A.connects[1]", '"rodA"', "not a point reference", "'body.point'"]),
    ("unknown-ground-point",
     _edit('connects = ["ground.O", "crank.O"]', 'connects = ["ground.X", "crank.O"]'),
     ["joints.O.connects[0]", '"ground.X"', "unknown point 'X' on ground", "ground.O"]),
    ("zero-length-link",
     _edit("A = [-0.06, 0.0], B = [0.06, 0.0]", "A = [-0.06, 0.0], B = [-0.06, 0.0]"),
     ["bodies.rod.points.B", "[-0.06, 0.0]", "zero-length link", "distinct positions"]),
    ("zero-direction", _edit("direction = [1.0, 0.0]", "direction = [0.0, 0.0]"),
     ["joints.G.direction", "[0.0, 0.0]", "zero-length vector", "not both zero"]),
    ("joint-to-itself", _edit('connects = ["crank.A", "rod.A"]', 'connects = ["rod.B", "rod.A"]'),
     ["joints.A.connects", '["rod.B", "rod.A"]', "connects body 'rod' to itself",
      "two points on different bodies"]),
    ("ground-to-ground",
     _edit('connects = ["ground.O", "crank.O"]', 'connects = ["ground.O", "ground.O"]'),
     ["joints.O.connects", "the ground to itself", "two points on different bodies"]),
    ("body-named-ground",
     _append('\n[bodies.ground]\nmass = 1.0\ninertia = 1.0\nposition = [0.0, 0.0]\n'),
     ["bodies.ground", "reserved", "any other identifier"]),
    ("name-with-dot", _edit("[bodies.rod]", '[bodies."r.od"]'),
     ['bodies."r.od" = "r.od"', "invalid body name", "identifier", "no dots"]),
    ("name-starts-with-digit", _edit("[joints.G]", "[joints.1G]"),
     ["joints.1G", '"1G"', "invalid joint name", "not starting with a digit"]),
    ("unknown-key-suggestion", _edit("mass = 0.21", "mas = 0.21"),
     ["bodies.rod.mas", "0.21", "unknown field 'mas'", "did you mean 'mass'",
      "fields mass, inertia"]),
    ("unknown-top-key", _edit("gravity = [0.0, -9.81]", "gravty = [0.0, -9.81]"),
     ["gravty", "[0.0, -9.81]", "did you mean 'gravity'", "fields name, description, gravity"]),
    ("key-of-other-joint-type",
     _edit('direction = [1.0, 0.0]', 'direction = [1.0, 0.0]\nmass = 1.0'),
     ["joints.G.mass", "1.0", "unknown field 'mass' for a translational joint",
      "fields type, connects, direction, angle"]),
    ("angle-on-pin-in-slot",
     _edit('type = "translational"', 'type = "pin-in-slot"'),
     ["joints.G.angle", "0.0", "unknown field 'angle' for a pin-in-slot joint",
      "belongs to translational or fixed-angle", "fields type, connects, direction"]),
    ("clearance-in-translational",
     _edit('direction = [1.0, 0.0]', 'direction = [1.0, 0.0]\nclearance = 1e-3'),
     ["joints.G.clearance", "0.001", "clearance in a translational joint is not supported",
      "journal in a circular bearing", "an ideal translational joint (no clearance)",
      "put the clearance in a revolute joint"]),
    ("model-in-pin-in-slot",
     _edit('type = "translational"\nconnects = ["slider.B", "ground.O"]\ndirection = [1.0, 0.0]\n'
           'angle = 0.0', 'type = "pin-in-slot"\nconnects = ["slider.B", "ground.O"]\n'
           'direction = [1.0, 0.0]\nmodel = "dry"\nclearance = 1e-4'),
     ["joints.G.model", '"dry"', "clearance in a pin-in-slot joint is not supported",
      "no model, clearance"]),
    ("unknown-integrator", _edit('integrator = "rk4"', 'integrator = "rk45"'),
     ["solver.integrator", '"rk45"', "did you mean 'rk4'",
      "one of auto, rk4, dopri5, radau, scipy-radau, bdf, lsoda"]),
    ("unknown-formulation",
     _edit('integrator = "rk4"', 'integrator = "rk4"\nformulation = "reducd"'),
     ["solver.formulation", '"reducd"', "did you mean 'reduced'",
      "one of auto, absolute, reduced"]),
    ("step-zero", _edit("step = 1e-6", "step = 0.0"),
     ["solver.step", "= 0.0", "must be > 0", "a finite number > 0 (s)"]),
    ("rtol-negative", _edit("rtol = 1e-8", "rtol = -1e-8"),
     ["solver.rtol", "-1e-08", "must be > 0", "a finite number in (0, 1)"]),
    ("rtol-one", _edit("rtol = 1e-8", "rtol = 1.0"),
     ["solver.rtol", "= 1.0", "must be < 1", "a finite number in (0, 1)"]),
    ("max-steps-float", _edit("max_steps = 1000000", "max_steps = 1e6"),
     ["solver.max_steps", "1000000.0", "expected an integer", "an integer in (0, 9.0072e+15]"]),
    # beyond 2**53 the float64 step count is not exact; beyond int64 numba could not even type it
    ("max-steps-huge", _edit("max_steps = 1000000", "max_steps = 100000000000000000000"),
     ["solver.max_steps", "100000000000000000000", "must be <= 9007199254740992"]),
    ("duration-and-cycles", _edit("cycles = 1\n", "cycles = 1\nduration = 0.1\n"),
     ["analysis", "duration = 0.1", "cycles = 1", "both duration and cycles",
      "exactly one of analysis.duration (s) or analysis.cycles"]),
    ("neither-duration-nor-cycles", _edit("cycles = 1\n", ""),
     ["analysis.duration", "neither duration nor cycles", "exactly one of analysis.duration"]),
    ("both-sample-steps", _edit("sample_step_angle = 0.017453292519943295",
                                "sample_step_angle = 0.017453292519943295\nsample_step = 1e-4"),
     ["analysis", "sample_step = 0.0001", "both sample_step and sample_step_angle",
      "exactly one of"]),
    ("cycle-driver-unknown", _edit('cycle_driver = "crank"', 'cycle_driver = "crnk"'),
     ["analysis.cycle_driver", '"crnk"', "unknown driver 'crnk'", "did you mean 'crank'",
      "a constant-speed driver with speed != 0: one of crank"]),
    ("cycle-driver-missing", _edit('cycle_driver = "crank"\n', ""),
     ["analysis.cycle_driver", "missing required field", "a constant-speed driver"]),
    ("cycle-driver-not-constant-speed",
     _edit('law = "constant-speed"\nangle0 = 0.0\nspeed = 523.5987755982989',
           'law = "constant-acceleration"\nangle0 = 0.0\nacceleration = 10.0'),
     ["analysis.cycle_driver", '"crank"', "has law 'constant-acceleration'",
      "a constant-speed driver with speed != 0"]),
    ("cycle-driver-zero-speed", _edit("speed = 523.5987755982989", "speed = 0.0"),
     ["analysis.cycle_driver", '"crank"', "has speed 0",
      "a constant-speed driver with speed != 0"]),
    ("sample-step-zero",
     _edit("sample_step_angle = 0.017453292519943295", "sample_step_angle = 0.0"),
     ["analysis.sample_step_angle", "= 0.0", "must be > 0", "a finite number > 0 (rad)"]),
    ("sample-step-too-large",
     _edit("sample_step_angle = 0.017453292519943295", "sample_step_angle = 7.0"),
     ["analysis.sample_step_angle", "= 7.0", "larger than the analysis span",
      "0 < sample_step_angle <= 6.28319 rad"]),
    ("output-axis-zero", _edit("axis = [1.0, 0.0]", "axis = [0.0, 0.0]"),
     ["outputs.slider.axis", "[0.0, 0.0]", "zero-length vector", "not both zero"]),
    ("output-on-ground", _edit('point = "slider.B"', 'point = "ground.O"'),
     ["outputs.slider.point", '"ground.O"', "a ground point is not allowed here",
      "a point on a moving body"]),
    ("clearance-ge-bearing-radius", _edit("clearance = 0.5e-3", "clearance = 10e-3"),
     ["joints.C.clearance", "0.01", "smaller than bearing_radius",
      "0 < clearance < bearing_radius (m)"]),
    ("nonideal-zero-clearance", _edit("clearance = 0.5e-3", "clearance = 0.0"),
     ["joints.C.clearance", "= 0.0", "a 'dry' clearance joint needs a clearance > 0",
      "a finite number > 0 (m)"]),
    ("nonideal-missing-length", _edit("length = 40e-3\n", ""),
     ["joints.C.length", "missing required field of a 'dry' clearance joint", "(m, > 0)"]),
    ("unknown-model", _edit('model = "dry"', 'model = "wet"'),
     ["joints.C.model", '"wet"', "unknown value", "one of ideal, dry, lubricated, transition"]),
    ("restitution-zero", _edit("restitution = 0.9", "restitution = 0.0"),
     ["joints.C.contact.restitution", "= 0.0", "must be > 0", "a finite number in (0, 1]"]),
    ("restitution-above-one", _edit("restitution = 0.9", "restitution = 1.5"),
     ["joints.C.contact.restitution", "= 1.5", "must be <= 1", "a finite number in (0, 1]"]),
    ("poisson-half", _edit("poisson_bearing = 0.3", "poisson_bearing = 0.5"),
     ["joints.C.contact.poisson_bearing", "= 0.5", "must be < 0.5", "in (-1, 0.5)"]),
    ("stiffness-unknown", _edit('stiffness = "conformal"', 'stiffness = "convex"'),
     ["joints.C.contact.stiffness", '"convex"', "unknown value", "one of conformal, paper"]),
    ("contact-unknown-key", _edit("restitution = 0.9", "restituton = 0.9"),
     ["joints.C.contact.restituton", "did you mean 'restitution'",
      "fields youngs_modulus_bearing"]),
    ("friction-v1-below-v0", _edit("v1 = 1e-2", "v1 = 1e-5"),
     ["joints.C.friction.v1", "1e-05", "greater than v0 = 0.0001", "v1 > v0 >= 0 (m/s)"]),
    ("viscosity-negative", _edit("viscosity = 0.4", "viscosity = -0.4"),
     ["joints.C.lubricant.viscosity", "-0.4", "must be >= 0", "a finite number >= 0 (Pa s)"]),
    ("viscosity-zero-lubricated",
     _edit('model = "dry"', 'model = "lubricated"', "viscosity = 0.4", "viscosity = 0"),
     ["joints.C.lubricant.viscosity", "= 0", "a 'lubricated' joint needs a film",
      "> 0 (Pa s) for models 'lubricated' and 'transition'"]),
    ("exponent-below-one", _edit("restitution = 0.9", "restitution = 0.9\nexponent = 0.5"),
     ["joints.C.contact.exponent", "= 0.5", "must be >= 1", "a finite number in [1, 3]"]),
    ("exponent-above-three", _edit("restitution = 0.9", "restitution = 0.9\nexponent = 3.5"),
     ["joints.C.contact.exponent", "= 3.5", "must be <= 3", "a finite number in [1, 3]"]),
    # eps0 = 1 is allowed (the paper's printed form); the range is the force law's (0, 1]
    ("eps0-above-one", _edit("eps0 = 0.1", "eps0 = 1.5"),
     ["joints.C.lubricant.eps0", "= 1.5", "must be <= 1", "in (0, 1]"]),
    ("bearing-unknown", _edit("eps0 = 0.1", 'eps0 = 0.1\nbearing = "shrot"'),
     ["joints.C.lubricant.bearing", "shrot", "did you mean 'short'", "one of long, short, finite"]),
    ("eps-max-one", _edit("eps_max = 0.99", "eps_max = 1"),
     ["joints.C.transition.eps_max", "= 1", "must be < 1", "in (0, 1)"]),
    ("eccentricity-outside-clearance",
     _edit("length = 40e-3", "length = 40e-3\ninitial_eccentricity = [1e-3, 0.0]"),
     ["joints.C.initial_eccentricity", "[0.001, 0.0]", "not inside the clearance circle",
      "|initial_eccentricity| < clearance"]),
    ("two-drivers-one-body", _append('\n[drivers.again]\nbody = "crank"\nlaw = "constant-speed"\n'
                                     'angle0 = 0.0\nspeed = 1.0\n'),
     ["drivers.again.body", '"crank"', "already driven by drivers.crank",
      "at most one driver per body"]),
    ("driver-unknown-body", _edit('body = "crank"', 'body = "crnk"'),
     ["drivers.crank.body", '"crnk"', "unknown body 'crnk'", "did you mean 'crank'",
      "one of crank, rod, slider"]),
    ("driver-field-of-other-law",
     _edit("speed = 523.5987755982989", "speed = 523.5987755982989\namplitude = 1.0"),
     ["drivers.crank.amplitude", "1.0", "not used by law 'constant-speed'",
      "fields body, law, angle0, speed"]),
    ("connects-wrong-length", _edit('connects = ["crank.A", "rod.A"]', 'connects = ["crank.A"]'),
     ["joints.A.connects", '["crank.A"]', "connects 2 points, got 1",
      "an array of 2 point references"]),
    ("translational-on-its-own-body",
     _edit('connects = ["slider.B", "ground.O"]', 'connects = ["rod.A", "rod.B"]'),
     ["joints.G.connects", '["rod.A", "rod.B"]', "connects body 'rod' to itself",
      "a point of one body and a point on the line of another"]),
    ("translational-unknown-line-point",
     _edit('connects = ["slider.B", "ground.O"]', 'connects = ["slider.B", "rod.Q"]'),
     ["joints.G.connects[1]", '"rod.Q"', "unknown point 'Q' on rod", "rod.A, rod.B"]),
    ("translational-missing-angle",
     _edit('direction = [1.0, 0.0]\nangle = 0.0', 'direction = [1.0, 0.0]'),
     ["joints.G.angle", "missing required field", "(rad)"]),
    ("points-and-global-points",
     _edit("points = { B = [0.0, 0.0] }",
           "points = { B = [0.0, 0.0] }\nglobal_points = { B = [0.17, 0.0] }"),
     ["bodies.slider", "both points and global_points are given",
      "exactly one of points (body frame, m) or global_points (ground coordinates"]),
    ("global-points-zero-length-link",
     _edit("points = { A = [-0.06, 0.0], B = [0.06, 0.0] }",
           "global_points = { A = [0.05, 0.0], B = [0.05, 0.0] }"),
     ["bodies.rod.global_points.B", "[0.05, 0.0]", "zero-length link"]),
    ("global-points-not-a-pair",
     _edit("points = { A = [-0.06, 0.0], B = [0.06, 0.0] }",
           "global_points = { A = [0.05, 0.0], B = 0.17 }"),
     ["bodies.rod.global_points.B", "0.17", "a pair [x, y]"]),
    ("points-not-a-table", _edit("points = { B = [0.0, 0.0] }", "points = 3"),
     ["bodies.slider.points", "= 3", "expected a table, got a number", "a table of named points"]),
]


@pytest.mark.parametrize("case_id, edit, expected", CASES, ids=[c[0] for c in CASES])
def test_malformed_scene(tmp_path, case_id, edit, expected):
    path = tmp_path / f"{case_id}.toml"
    path.write_text(edit(BASE), encoding="utf-8")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    err = info.value
    assert type(err) is SceneError
    assert err.__cause__ is None and (err.__context__ is None or err.__suppress_context__)
    msg = str(err)
    assert msg.startswith(str(path) + ": ")
    assert "allowed:" in msg
    for part in expected:
        assert part in msg, f"{part!r} not in {msg!r}"
    assert err.source == str(path)


def test_malformed_count():
    assert len(CASES) >= 20


def test_base_is_valid(tmp_path):
    path = tmp_path / "ok.toml"
    path.write_text(BASE, encoding="utf-8")
    s = load_scene(path)
    assert s.source == str(path) and s.joints["C"].is_clearance


def test_toml_syntax_error_reports_line_and_column(tmp_path):
    path = tmp_path / "syntax.toml"
    path.write_text(BASE.replace("mass = 0.21", "mass = = 0.21"), encoding="utf-8")
    with pytest.raises(SceneError) as info:
        load_scene(path)
    msg = str(info.value)
    line = BASE.splitlines().index("mass = 0.21") + 1
    assert msg.startswith(str(path)) and "TOML syntax error" in msg
    assert f"line {line}" in msg and "column" in msg
    assert info.value.__cause__ is None and info.value.__suppress_context__


def test_not_utf8(tmp_path):
    path = tmp_path / "latin1.toml"
    path.write_bytes(BASE.replace("a slider-crank", "caf\xe9").encode("latin-1"))
    with pytest.raises(SceneError, match="not UTF-8"):
        load_scene(path)


def test_missing_file_and_unknown_scene(tmp_path):
    with pytest.raises(SceneError, match="no such scene file .*allowed: an existing TOML file"):
        load_scene(tmp_path / "absent.toml")
    with pytest.raises(SceneError, match=r"unknown scene 'nine-bra' \(did you mean 'nine-bar'\?\)"):
        load_scene("nine-bra")
    with pytest.raises(SceneError, match="allowed: an embedded scene name"):
        load_scene(42)


def test_mapping_source_errors_are_labelled():
    with pytest.raises(SceneError) as info:
        load_scene({"name": "x"})
    assert str(info.value).startswith("<mapping>: bodies: missing required field")
    with pytest.raises(SceneError, match="<mapping>: bodies = 3: expected a table"):
        load_scene({"name": "x", "bodies": 3, "analysis": {}})
    with pytest.raises(SceneError, match="no bodies defined"):
        load_scene({"name": "x", "bodies": {}, "analysis": {}})


# --------------------------------------------------------------------------- overrides

@pytest.mark.parametrize("override, expected", [
    ("joints.C.clearence=1e-3", ["joints.C.clearence", "unknown field 'clearence'",
                                 "did you mean 'clearance'", "fields type, connects"]),
    ("gravity.y=-1", ["'gravity' is a value, not a table", "gravity.y", "'gravity' itself"]),
    ("bodies.crnk.mass=1.0", ["unknown body 'crnk' at 'bodies.crnk'", "did you mean 'crank'",
                              "one of crank, rod, slider"]),
    ("bodies.rod.points.A.x=1", ["'bodies.rod.points.A' is a value, not a table"]),
    ("joints..model=dry", ["malformed path 'joints..model'", "a dotted path"]),
    ("analysis.cycle=2", ["unknown field 'cycle'", "did you mean 'cycles'"]),
    ("joints.C.model", ["expected PATH=VALUE", "joints.C1.clearance=0.3e-3"]),
    ("extends=nine-bar", ["unknown field 'extends'"]),
])
def test_bad_override(tmp_path, override, expected):
    path = tmp_path / "s.toml"
    path.write_text(BASE, encoding="utf-8")
    with pytest.raises(SceneError) as info:
        load_scene(path, overrides=[override])
    msg = str(info.value)
    for part in expected:
        assert part in msg, f"{part!r} not in {msg!r}"
    if "=" in override:
        assert msg.startswith(str(path)) and f"override '{override}'" in msg and "allowed:" in msg


def test_override_through_a_non_table_value(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(BASE, encoding="utf-8")
    with pytest.raises(SceneError, match=r"'joints\.C\.contact' = 3 is not a table"):
        load_scene(path, overrides=["joints.C.contact=3", "joints.C.contact.restitution=0.5"])


def test_override_value_is_validated_and_named(tmp_path):
    path = tmp_path / "s.toml"
    path.write_text(BASE, encoding="utf-8")
    with pytest.raises(SceneError) as info:
        load_scene(path, overrides=["bodies.rod.mass=-2"])
    msg = str(info.value)
    assert "bodies.rod.mass = -2: must be > 0; allowed: a finite number > 0 (kg)" in msg
    assert "(value set by override 'bodies.rod.mass=-2')" in msg


# --------------------------------------------------------------------------- properties

@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(mass=st.floats(min_value=1e-12, max_value=1e12, allow_nan=False, allow_infinity=False))
def test_any_positive_finite_mass_loads(mass):
    s = load_scene("slider-crank", overrides={"bodies.rod.mass": mass})
    assert s.bodies["rod"].mass == mass
    s2 = load_scene("slider-crank", overrides=[f"bodies.rod.mass={mass!r}"])
    assert s2.bodies["rod"].mass == mass


@settings(max_examples=60, deadline=None)
@given(mass=st.one_of(st.floats(max_value=0.0), st.integers(max_value=0),
                      st.just(math.inf), st.just(-math.inf), st.booleans(),
                      st.text(max_size=5)))
def test_any_non_positive_or_non_number_mass_is_rejected(mass):
    with pytest.raises(SceneError) as info:
        load_scene("slider-crank", overrides={"bodies.crank.mass": mass})
    msg = str(info.value)
    assert "bodies.crank.mass = " in msg and "allowed: a finite number > 0 (kg)" in msg


@settings(max_examples=150, deadline=None)
@given(path=st.lists(st.sampled_from(["joints", "C", "bodies", "rod", "mass", "contact",
                                      "restitution", "analysis", "cycles", "solver", "x",
                                      "points", "B", "model", "lubricant", "viscosity", ""]),
                     min_size=1, max_size=5).map(".".join),
       value=st.text(max_size=12))
def test_arbitrary_overrides_only_raise_scene_errors(path, value):
    try:
        load_scene("slider-crank", overrides=[f"{path}={value}"])
    except SceneError as e:
        assert str(e)
