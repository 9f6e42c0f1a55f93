"""A study file's [design] section when it is read: a scene variable's base value from the
scene, and one clear error per wrong field (naming the field, the value and what is allowed)
before any simulation runs. The runs themselves: tests/test_uq_design.py."""

from __future__ import annotations

import copy

import pytest

from mechrel.errors import StudyError
from mechrel.scene import load_scene
from mechrel.study.design import design_model
from mechrel.study.study import _design_variables, load_study
from mechrel.uq.design.core import design_space

VISCOSITY = "joints.C.lubricant.viscosity"

STUDY = {
    "scene": "slider-crank-lubricated", "quantities": ["velocity"], "angle_step": 90.0,
    "cycles": 1, "allowable": {"velocity": {"mean": 0.3, "std": 0.0}},
    "inputs": {"clearance": {"paths": ["joints.C.clearance"], "distribution": "normal",
                             "mean": 0.3e-3, "std": 0.02e-3},
               "crank": {"paths": ["bodies.crank.length(O,A)"], "distribution": "uniform",
                         "lower": 0.0499, "upper": 0.0501}},
    "design": {"cost": "-mu + 1/t", "constraints": 0.9, "method": "mc",
               "variables": {"mu": {"kind": "scene", "paths": [VISCOSITY],
                                    "lower": 0.01, "upper": 0.5},
                             "t": {"kind": "std", "input": "clearance", "lower": 1e-6,
                                   "upper": 1e-4}}}}


def _space(study):
    return design_space(design_model(study), study.uncertain_inputs(),
                        _design_variables(study.design))


def _start(raw):
    space = _space(load_study(raw))
    return space.as_dict(space.start)


def test_a_scene_variable_starts_at_the_scene_value():
    scene_value = load_scene("slider-crank-lubricated").raw["joints"]["C"]["lubricant"][
        "viscosity"]
    assert scene_value == pytest.approx(0.4)  # what the scene file says
    study = load_study(STUDY)
    assert "start" not in study.design["variables"]["mu"]
    space = _space(study)
    # the base and the start of the scene variable are the scene's value (no start given),
    # the std variable's are the input's std
    assert space.as_dict(space.base) == pytest.approx({"mu": scene_value, "t": 0.02e-3})
    assert space.as_dict(space.start) == pytest.approx({"mu": scene_value, "t": 0.02e-3})


def test_a_scene_variable_starts_at_the_overridden_scene_value_and_within_its_bounds():
    raw = copy.deepcopy(STUDY)
    raw["scene_overrides"] = {VISCOSITY: 0.05}
    assert _start(raw)["mu"] == 0.05
    # a scene value outside the bounds: the optimiser starts on the nearer bound
    raw = copy.deepcopy(STUDY)
    raw["design"]["variables"]["mu"]["upper"] = 0.2
    assert _start(raw)["mu"] == 0.2
    # a start given is the start
    raw = copy.deepcopy(STUDY)
    raw["design"]["variables"]["mu"]["start"] = 0.1
    assert _start(raw)["mu"] == 0.1


def _var(**fields):
    return {"kind": "std", "input": "clearance", "lower": 1e-6, "upper": 1e-4, **fields}


def _with(**design):
    raw = copy.deepcopy(STUDY)
    raw["design"].update(design)
    return raw


def _with_var(name, spec):
    raw = copy.deepcopy(STUDY)
    raw["design"]["variables"][name] = spec
    return raw


def _scene_var(**fields):
    return {"kind": "scene", "paths": [VISCOSITY], "lower": 0.01, "upper": 0.5, **fields}


BAD = [
    # the variables
    (_with_var("t", _var(kind="width")),
     r"<mapping>: design\.variables\.t\.kind = \"width\": unknown value \(did you mean "
     r"'half_width'\?\); allowed: one of mean, std, half_width, scene$"),
    (_with_var("t", _var(lower=1e-4, upper=1e-6)),
     r"design\.variables\.t\.upper = 1e-06: not above lower \(0\.0001\); allowed: "
     r"upper > lower$"),
    (_with_var("t", _var(start=1e-3)),
     r"design\.variables\.t\.start = 0\.001: must be <= 0\.0001; allowed: a finite number in "
     r"\[1e-06, 0\.0001\]$"),
    (_with_var("t", _var(lower=0.0)),
     r"design\.variables\.t\.lower = 0\.0: must be > 0; allowed: a finite number > 0 \(a std "
     r"or half-width is positive\)$"),
    (_with_var("t", _var(input="gap")),
     r"design\.variables\.t\.input = \"gap\": unknown value; allowed: one of clearance, crank$"),
    (_with_var("t", _var(kind="half_width")),
     r"design\.variables\.t\.kind = 'half_width': needs a bounded input, but 'clearance' is "
     r"Normal\(.*\); allowed: kind 'std', or a bounded distribution"),
    (_with(variables={"m1": _var(kind="mean", lower=0.1e-3, upper=0.5e-3),
                      "m2": _var(kind="mean", lower=0.1e-3, upper=0.5e-3)}, cost="m1 + m2"),
     r"design\.variables\.m2\.input = 'clearance': already has a mean variable \(m1\); "
     r"allowed: at most one mean and one std or half_width variable per input"),
    # a scene variable's paths, read in the scene
    (_with_var("mu", _scene_var(paths=["joints.C.lubricant.viscosty"])),
     r"design\.variables\.mu\.paths = \[\"joints\.C\.lubricant\.viscosty\"\]: "
     r"'joints\.C\.lubricant\.viscosty': not a value of the scene \(no 'viscosty' there\); "
     r"allowed: a dotted scene path"),
    (_with_var("mu", _scene_var(paths=["joints.C.model"])),
     r"design\.variables\.mu\.paths = \[\"joints\.C\.model\"\]: 'joints\.C\.model' holds "
     r"'lubricated', not a number; allowed: dotted paths of numeric scene values"),
    (_with_var("mu", _scene_var(paths=[VISCOSITY, "joints.C.clearance"])),
     r"design\.variables\.mu\.start: missing, and the paths hold different values in the "
     r"scene \(0\.4, 0\.0005\): no one base value; allowed: a start value within the bounds"),
    # the cost
    (_with(cost="-mu + 1/u"),
     r"design\.cost = \"-mu \+ 1/u\": unknown name 'u'; allowed: numbers, the design "
     r"variables \(mu, t\)"),
    (_with(cost="1/(mu - 0.4) + 1/t"),
     r"design\.cost = '1/\(mu - 0\.4\) \+ 1/t': not finite at the start design "
     r"\(mu = 0\.4, t = 2e-05\): inf; allowed: an expression with a finite value"),
    # the constraints
    (_with(constraints={"reliability": 0.9, "quantity": "acceleration"}),
     r"design\.constraints\[0\]\.quantity = \"acceleration\": unknown value; allowed: one of "
     r"all, velocity$"),
    (_with(constraints=1.0),
     r"design\.constraints\[0\]\.reliability = 1\.0: must be < 1; allowed: a finite number in "
     r"\(0, 1\)$"),
    (_with(constraints=[{"reliability": 0}]),
     r"design\.constraints\[0\]\.reliability = 0: must be > 0; allowed: a finite number in "
     r"\(0, 1\)$"),
    (_with(constraints=[{"reliability": 0.9}, {"reliability": 0.99, "quantity": "all"}]),
     r"design\.constraints: quantity 'all' \(whole-cycle\) is constrained twice; allowed: one "
     r"constraint per quantity and basis$"),
    # the method, the verification
    (_with(method="sora"),
     r"design\.method = \"sora\": unknown value; allowed: one of ak, mc$"),
    (_with(verify={"method": "subset", "p0": 0.3}),
     r"design\.verify\.p0: got 0\.3 with n_per_level = 500; allowed: 1/p0 and n_per_level·p0 "
     r"integers"),
]


@pytest.mark.parametrize("raw,message", BAD, ids=[m[:40] for _, m in BAD])
def test_a_wrong_design_field_is_one_error_naming_it(raw, message):
    with pytest.raises(StudyError, match=message):
        load_study(raw)


def test_an_empty_design_table_is_named_as_empty_not_as_missing():
    # `[design]` with nothing under it was read as no [design] section at all, and
    # `mechrel design` then said "the study has no [design] section"
    raw = {**copy.deepcopy(STUDY), "design": {}}
    with pytest.raises(StudyError, match=r"^<mapping>: design = \{\}: an empty \[design\] "
                       r"table; allowed: a \[design\] table with variables, cost and "
                       r"constraints \(docs/studies\.md, 'Design for reliability'\), or none$"):
        load_study(raw)
    no_design = {k: v for k, v in STUDY.items() if k != "design"}
    assert load_study(no_design).design is None
