"""The clearance-model recipe: a row of the table is the one registration of a model.

A dummy model is registered here (its row, the code of an existing compiled law, one
:func:`register_model` call) and must work end to end: scene validation, packing, the compiled
system, a simulation, FOSM's smoothness warning. The package must not name a model outside the
table, and the parameter tables must be made from the rows' declarations.
"""

from __future__ import annotations

import ast
from dataclasses import fields
from pathlib import Path

import numpy as np
import pytest

import mechrel
from mechrel.errors import EstimateWarning, SceneError
from mechrel.forces import params as P
from mechrel.forces.models import (
    MODEL_DRY, MODELS, PARAMS, SUBTABLE_PARAMS, SUBTABLES, ClearanceModel, register_model,
    unregister_model,
)
from mechrel.scene import SUBTABLE_CLASSES, load_scene
from mechrel.simulation import simulate

PACKAGE = Path(mechrel.__file__).parent

# --- the dummy model: "one file's worth of code" ----------------------------------------------
# Dry contact without friction (it declares the contact parameters only), non-smooth. It runs
# the compiled dry law (a new law would bring its own code and its branch in clearance_force).
DUMMY = ClearanceModel(
    name="dummy-contact", code=MODEL_DRY,
    summary="a test's frictionless dry contact",
    has_contact=True, has_film=False, stiff=False, chaotic=True, smooth=False,
    requires=("contact",), params=tuple(p for p in PARAMS.values() if p.sub == "contact"),
    solver=("dopri5", {"rtol": 1e-8, "atol": 1e-11}), precedence=1,
)


@pytest.fixture
def dummy():
    register_model(DUMMY)  # the one registration
    try:
        yield DUMMY
    finally:
        unregister_model(DUMMY.name)
    assert DUMMY.name not in MODELS


def _scene(model: str, **extra):
    return load_scene("slider-crank-dry", overrides={"joints.C.model": model,
                                                     "analysis.cycles": 0.05, **extra})


def test_a_registered_model_is_validated_by_its_row(dummy):
    scene = _scene(dummy.name)
    joint = scene.joints["C"]
    assert joint.clearance_model is dummy and joint.contact.restitution == 0.9
    # a value of one of its parameters is checked by the parameter's declaration
    with pytest.raises(SceneError, match=r"joints\.C\.contact\.restitution = 1\.5.*\(0, 1\]"):
        _scene(dummy.name, **{"joints.C.contact.restitution": 1.5})
    # a model name outside the table: the message lists the table, the new row included
    with pytest.raises(SceneError) as err:
        _scene("no-such-model")
    assert "allowed: one of " + ", ".join(("ideal", *MODELS)) in str(err.value)
    assert dummy.name in str(err.value)


def test_a_registered_model_compiles_and_simulates(dummy):
    # the dummy reads no friction: it is the dry law with friction switched off, bitwise
    got = simulate(_scene(dummy.name))
    ref = simulate(_scene("dry", **{"joints.C.friction.coefficient": 0.0}))
    packed = P.unpack_params(P.pack_params(model=dummy.name, clearance=1e-4,
                                           bearing_radius=1e-2, length=1e-2, stiffness=1e10))
    assert packed["friction_coefficient"] == 0.0 and packed["model"] == "dry"
    assert got.stats["n_steps"] > 0
    for name, series in ref.outputs.items():
        for q, values in series.items():
            np.testing.assert_array_equal(got.outputs[name][q], values)
    assert got.orbits.keys() == ref.orbits.keys()


def test_fosm_warns_on_a_registered_non_smooth_model(dummy):
    from mechrel.uq import Normal, UncertainInputs, fosm
    from mechrel.uq.problem.mechanism import MechanismModel

    model = MechanismModel("slider-crank-dry", ["joints.C.clearance"], angle_step=90.0,
                           cycles=1, overrides={"joints.C.model": dummy.name})
    assert model.nonsmooth.startswith("dry contact in joint C")
    inputs = UncertainInputs.from_specs({"joints.C.clearance": Normal(0.5e-3, 1e-5)})
    with pytest.warns(EstimateWarning) as record:  # the others: kinks and flat outputs
        res = fosm(model=model, inputs=inputs, progress=False)
    said = "fosm: the model is not smooth (dry contact in joint C"
    assert any(str(w.message).startswith(said) for w in record)
    assert any(w.startswith(said) for w in res.warnings)
    # a smooth row makes no such claim
    assert MechanismModel("slider-crank-lubricated", ["joints.C.clearance"]).nonsmooth is None


def test_registration_errors_name_the_problem(dummy):
    with pytest.raises(ValueError, match="already registered"):
        register_model(DUMMY)
    with pytest.raises(ValueError, match="no branch in the compiled force law"):
        register_model(ClearanceModel(**{**{f.name: getattr(DUMMY, f.name)
                                            for f in fields(DUMMY)},
                                         "name": "x", "code": 99}))
    with pytest.raises(ValueError, match="cannot be removed"):
        unregister_model("dry")


def test_the_parameter_tables_derive_from_the_rows():
    slotted = [p for p in PARAMS.values() if p.slot is not None]
    # every declared slot has an index, a pack default and (for a number) its range
    assert P.PARAM_NAMES[6:] == tuple(p.slot for p in slotted)
    assert len(set(P.PARAM_NAMES)) == P.N_PARAMS == len(P.PARAM_NAMES)
    for p in slotted:
        assert P.DEFAULTS[p.slot] == p.pack_default
        if p.limit:
            assert {k: v for k, v in P.LIMITS[p.slot].items() if k != "unit"} == dict(p.limit)
    # the scene's sub-tables: a class each, whose fields are the declared keys and defaults
    assert tuple(SUBTABLE_CLASSES) == SUBTABLES
    for sub, cls in SUBTABLE_CLASSES.items():
        declared = {p.key: p.default for p in PARAMS.values() if p.sub == sub}
        assert {f.name: f.default for f in fields(cls)} == declared
        assert set(SUBTABLE_PARAMS[sub]) <= set(declared)
    for row in MODELS.values():
        assert set(row.requires) <= set(row.reads) <= set(SUBTABLES)


def _model_names_in_code(path: Path) -> list[tuple[int, str]]:
    """String literals (docstrings excepted) that name a clearance model."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    docs = {id(st.value) for node in ast.walk(tree) if isinstance(getattr(node, "body", None), list)
            for st in node.body
            if isinstance(st, ast.Expr) and isinstance(st.value, ast.Constant)}
    found = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            if node.value in MODELS or any(f"'{m}'" in node.value or f'"{m}"' in node.value
                                           for m in MODELS):
                found.append((node.lineno, node.value))
    return found


def test_no_model_name_is_written_outside_the_table():
    table = PACKAGE / "forces" / "models.py"
    assert _model_names_in_code(table)  # the check sees the names where they are
    hits = {str(p.relative_to(PACKAGE)): _model_names_in_code(p)
            for p in sorted(PACKAGE.rglob("*.py")) if p != table}
    assert {k: v for k, v in hits.items() if v} == {}


# --- the scene's identity leaves out parameters added at their default --------------------------

def test_adding_a_parameter_with_a_default_moves_no_scene_hash(monkeypatch):
    from dataclasses import field, make_dataclass
    from types import MappingProxyType

    from mechrel.forces import models
    from mechrel.forces.models import Param
    from mechrel.scene import _schema, _validate, embedded_names, scene_hash

    before = {n: scene_hash(load_scene(n)) for n in embedded_names()}
    assert len(set(before.values())) == len(before)
    # a new contact parameter, declared as a model's new parameter is (not hashed at default)
    new = Param("contact", "damping_ratio", 0.0, "-", limit=MappingProxyType({"ge": 0}),
                summary="a test's new parameter")
    params = MappingProxyType({**models.PARAMS, (new.sub, new.key): new})
    old = SUBTABLE_CLASSES["contact"]
    contact = make_dataclass("Contact", [(f.name, f.type, field(default=f.default))
                                         for f in fields(old)]
                             + [(new.key, float, field(default=new.default))],
                             bases=old.__bases__, frozen=True)
    classes = MappingProxyType({**SUBTABLE_CLASSES, "contact": contact})
    monkeypatch.setattr(_validate, "PARAMS", params)
    monkeypatch.setattr(_validate, "SUBTABLE_CLASSES", classes)
    monkeypatch.setitem(_schema.SCHEMA["joints"].child["contact"], new.key, None)  # overrides

    after = {n: load_scene(n) for n in embedded_names()}
    assert any(getattr(j.contact, "damping_ratio", None) == 0.0
               for s in after.values() for j in s.joints.values())  # the field is there
    assert {n: scene_hash(s) for n, s in after.items()} == before
    # set away from its default, it is part of the identity
    moved = load_scene("slider-crank-dry", overrides={"joints.C.contact.damping_ratio": 0.1})
    assert moved.joints["C"].contact.damping_ratio == 0.1
    assert scene_hash(moved) != before["slider-crank-dry"]


def test_a_new_solver_field_at_its_default_is_not_hashed():
    from mechrel.scene._validate import _HASHED_AT_DEFAULT, _table
    from mechrel.scene.model import Solver

    scene = load_scene("slider-crank")
    # every field of today is hashed as before; a field outside the list only when set
    assert _table(scene.solver, _HASHED_AT_DEFAULT[Solver]) == {
        k: v for k, v in ((f.name, getattr(scene.solver, f.name)) for f in fields(Solver))
        if v is not None}
    assert _table(scene.solver, frozenset()) == {
        f.name: getattr(scene.solver, f.name) for f in fields(Solver)
        if getattr(scene.solver, f.name) not in (None, f.default)}


# The parameters of mechrel 0.33, whose defaults stay in the scene hash (so that the hashes of
# the scenes written before did not move). A historical record, never to grow: a parameter
# declared since must leave Param.hashed_at_default False, or adding it moves every hash.
HASHED_AT_DEFAULT_0_33 = {
    ("contact", k) for k in ("youngs_modulus_bearing", "youngs_modulus_journal",
                             "poisson_bearing", "poisson_journal", "restitution", "exponent",
                             "stiffness", "impact_speed_floor")
} | {("friction", k) for k in ("coefficient", "v0", "v1")} | {
    ("lubricant", k) for k in ("viscosity", "lam", "eps0", "bearing", "cavitation",
                               "shear_torque")
} | {("transition", k) for k in ("e1", "eps_max")}


def test_only_the_parameters_of_0_33_are_hashed_at_their_default():
    assert {k for k, p in PARAMS.items() if p.hashed_at_default} <= HASHED_AT_DEFAULT_0_33
