"""A sample's scene and compiled arrays set from its values (issue 35): ``SceneValues`` gives
the scene ``with_overrides`` gives (equal, same canonical JSON, so the same hash) and, for a
value the scene refuses, the same error message; ``PreparedScene`` gives the arrays
``compile_scene`` gives, bitwise. Checked on every numeric value of every embedded scene that
a study can sample (points, lengths, joint and driver values), alone and in random groups,
good values and bad ones.

Cost: about a thousand validations and compilations of small scenes (milliseconds each); the
test of every numeric path is marked slow (a quarter of them run by default).
"""

from __future__ import annotations

import math
from types import MappingProxyType

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from mechrel.simulation import PreparedScene, locate_point
from mechrel.errors import SceneError
from mechrel.mechanics.system import compile_scene
from mechrel.scene import embedded_names, load_scene, with_overrides
from mechrel.scene._validate import _Builder
from mechrel.scene._values import SceneValues, table_of
from mechrel.scene.loader import canonical_json, thaw

SCENES = {name: load_scene(name) for name in embedded_names()}


def _numeric_paths(scene) -> list[str]:
    """Every numeric value of the tables a sample sets (ground and body points, bodies,
    joints, drivers), each array component on its own, and every length between two points
    of one body or of the ground."""
    out = []

    def walk(node, path):
        if isinstance(node, (dict, MappingProxyType)):
            for k, v in node.items():
                walk(v, f"{path}.{k}")
        elif isinstance(node, (list, tuple)):
            for i, v in enumerate(node):
                if isinstance(v, float):
                    out.append(f"{path}[{i}]")
        elif isinstance(node, float):
            out.append(path)

    raw = scene.raw
    for top in ("ground", "bodies", "joints", "drivers"):
        walk(raw.get(top, {}), top)
    for owner, points in [("ground", scene.ground)] + [
            (f"bodies.{b}", body.points) for b, body in scene.bodies.items()]:
        names = list(points)
        out += [f"{owner}.length({p},{q})" for p in names[:2] for q in names if q != p]
    return out


PATHS = {name: _numeric_paths(scene) for name, scene in SCENES.items()}


def _value_at(scene, path):
    from mechrel.scene.loader import get_value
    return float(get_value(scene.raw, path))


def _compare(scene, values, prepared=None):
    """SceneValues and PreparedScene against with_overrides and compile_scene."""
    try:
        want, want_error = with_overrides(scene, values), None
    except SceneError as exc:
        want, want_error = None, str(exc)
    prepared = prepared or PreparedScene(scene, list(values))
    try:
        got, compiled = prepared.at(values)
        got_error = None
    except SceneError as exc:
        got, got_error = None, str(exc)
    assert got_error == want_error, values
    if want is None:
        return
    assert got == want and canonical_json(got) == canonical_json(want), values
    _same_compiled(compiled, compile_scene(want), values)


def _same_compiled(a, b, why):
    for field in type(a)._fields:
        x, y = getattr(a, field), getattr(b, field)
        if field in ("dynamic", "assembly", "ideal"):
            for f in type(x)._fields:
                u, v = getattr(x, f), getattr(y, f)
                assert u.dtype == v.dtype and np.array_equal(u, v), (why, field, f)
        elif isinstance(x, np.ndarray):
            assert x.dtype == y.dtype and np.array_equal(x, y), (why, field)
        else:
            assert x == y, (why, field)


def _one_value_at_each_path(name, paths):
    scene = SCENES[name]
    for path in paths:
        x0 = _value_at(scene, path)
        prepared = PreparedScene(scene, [path])
        # the value nudged (a sample), zero, its negative and a huge one (most are refused by
        # some rule: the same message is expected)
        for value in (x0 * (1 + 1e-3) + 1e-6, 0.0, -abs(x0) - 1e-3, 1e200):
            _compare(scene, {path: value}, prepared)


@pytest.mark.parametrize("name", sorted(SCENES))
def test_one_value_at_every_fourth_numeric_path(name):
    # every kind of path (points, lengths, joint, sub-table and driver values) is among them
    _one_value_at_each_path(name, PATHS[name][::4])


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(SCENES))
def test_one_value_at_every_numeric_path(name):
    _one_value_at_each_path(name, PATHS[name])


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_groups_of_values_alone_or_refused_as_a_full_validation_refuses_them(data):
    name = data.draw(st.sampled_from(sorted(SCENES)))
    scene = SCENES[name]
    paths = data.draw(st.lists(st.sampled_from(PATHS[name]), min_size=1, max_size=4,
                               unique=True))
    values = {}
    for p in paths:
        x0 = _value_at(scene, p)
        values[p] = data.draw(st.one_of(
            st.floats(min_value=-1.0, max_value=1.0).map(lambda r, x0=x0: x0 * (1 + 1e-2 * r)),
            st.floats(allow_nan=False, allow_infinity=False, width=64)))
    _compare(scene, values)


def test_the_fast_path_is_taken_for_what_samples_set():
    scene = SCENES["nine-bar-lubricated"]
    prepared = PreparedScene(scene, ["joints.C1.clearance", "joints.C2.lubricant.viscosity",
                                     "drivers.crank2.speed", "bodies.rod3.points.B[1]",
                                     "ground.points.H[0]", "bodies.crank1.length(O,A)"])
    assert prepared.values.incremental and prepared.patchable
    # numbers at a joint's numeric fields: the rest of the joint (its points, model, other
    # fields and parameters) kept as validated; an eccentricity component is not one of them
    assert set(prepared.values._numeric) == {"C1", "C2"}
    ecc = SceneValues(scene, ["joints.C1.clearance", "joints.C1.initial_eccentricity[0]"])
    assert ecc.incremental and not ecc._numeric
    # a value that is not a float at such a path: the joint validated as any other table,
    # with the full validation's message
    at = SceneValues(scene, ["joints.C1.clearance", "joints.C2.lubricant.viscosity"])
    for bad in ("wide", True, [1e-4], 3):
        values = {"joints.C1.clearance": 4e-4, "joints.C2.lubricant.viscosity": bad}
        try:
            want = with_overrides(scene, values)
        except SceneError as exc:
            with pytest.raises(SceneError) as got:
                at(values)
            assert str(got.value) == str(exc), bad
        else:
            assert at(values) == want and canonical_json(at(values)) == canonical_json(want)
    # a mass, a joint's model or its initial eccentricity, or the solver: compiled in full
    for path in ("bodies.rod3.mass", "joints.C1.initial_eccentricity[0]", "solver.rtol"):
        other = PreparedScene(scene, ["joints.C1.clearance", path])
        assert not other.patchable, path
        assert other.values.incremental == (path != "solver.rtol"), path
        _compare(scene, {"joints.C1.clearance": 4e-4,
                         path: _value_at(scene, path) * 0.9 if path != "solver.rtol" else 1e-6})
    assert table_of("analysis.cycles") is None


def test_a_bad_value_fails_with_the_message_of_a_full_validation():
    scene = SCENES["nine-bar-lubricated"]
    cases = {
        "joints.C1.clearance": (-1e-4, "joints.C1.clearance = -0.0001: must be >= 0"),
        "joints.C2.lubricant.viscosity": (0.0, "a film of zero viscosity carries no load"),
        "bodies.crank1.length(O,A)": (-0.1, "a length must be a number > 0"),
        "joints.C1.bearing_radius": (1e-4, "must be smaller than bearing_radius"),
    }
    for path, (value, words) in cases.items():
        at = SceneValues(scene, [path])
        with pytest.raises(SceneError, match=words.replace("(", r"\(").replace(")", r"\)")
                           .replace(".", r"\.")) as got:
            at({path: value})
        with pytest.raises(SceneError) as want:
            with_overrides(scene, {path: value})
        assert str(got.value) == str(want.value)
    # two bad values: the one a full validation meets first (the joints before the drivers)
    values = {"drivers.crank1.speed": math.inf, "joints.C2.clearance": -1.0}
    with pytest.raises(SceneError) as want:
        with_overrides(scene, values)
    with pytest.raises(SceneError) as got:
        SceneValues(scene, list(values))(values)
    assert str(got.value) == str(want.value) and "joints.C2.clearance" in str(got.value)


def test_joint_driver_and_output_rules_read_only_the_names_of_points():
    # what SceneValues relies on to leave joints, drivers and outputs alone when only
    # coordinates change: their validation gives the same result whatever the coordinates
    for name, scene in SCENES.items():
        raw = thaw(scene.raw)
        b = _Builder(name)
        nan = (math.nan, math.nan)
        ground = {p: nan for p in scene.ground}
        bodies = {n: body.__class__(**{**body.__dict__, "points": MappingProxyType(
            {p: nan for p in body.points})}) for n, body in scene.bodies.items()}
        joints = b._joints(raw.get("joints", {}), bodies, ground)
        assert joints == dict(scene.joints), name
        assert b._drivers(raw.get("drivers", {}), bodies) == dict(scene.drivers), name
        assert b._outputs(raw.get("outputs", {}), bodies, ground, joints) == \
            dict(scene.outputs), name


def test_a_point_that_enters_the_arrays_as_a_copy_is_located():
    scene = SCENES["slider-crank"]
    compiled = compile_scene(scene)
    where = locate_point(scene, compiled, "crank", "A")
    fields = {(s, f) for s, f, _ in where}
    # the crank pin A carries the revolute joint A (crank–rod) in every system
    assert {("dynamic", "rev_si"), ("ideal", "rev_si")} <= fields or \
        {("dynamic", "rev_sj"), ("ideal", "rev_sj")} <= fields
    for s, f, rows in where:
        arr = getattr(getattr(compiled, s), f) if s else getattr(compiled, f)
        assert np.array_equal(arr[rows], np.tile(scene.bodies["crank"].points["A"],
                                                 (rows.size, 1)))


def test_zero_length_links_checked_when_points_or_connections_change_only():
    # the check reads the points and the joints' type and points: a point moved onto another
    # joint's point fails as a full validation fails; values of force laws, drivers or a
    # joint's clearance never run it (they cannot make a link of zero length)
    scene = SCENES["slider-crank"]
    values = {"bodies.rod.points.B": [-0.06, 0.0]}
    with pytest.raises(SceneError) as want:
        with_overrides(scene, values)
    assert "zero-length link" in str(want.value)
    at = SceneValues(scene, list(values))
    assert at._links
    with pytest.raises(SceneError) as got:
        at(values)
    assert str(got.value) == str(want.value)
    nine = SCENES["nine-bar-lubricated"]
    assert not SceneValues(nine, ["joints.C1.clearance", "joints.C2.lubricant.viscosity",
                                  "drivers.crank1.speed"])._links
    assert SceneValues(nine, ["joints.C1.clearance", "joints.C1.connects"])._links
    assert SceneValues(nine, ["ground.points.H[0]"])._links


def test_outputs_validated_again_only_when_what_they_read_of_a_joint_changes():
    # an output of kind "joint" needs a revolute joint with a clearance: a clearance that
    # stays > 0 keeps the scene's outputs (the same mapping); one set to 0 on an ideal joint
    # an output names fails as a full validation fails
    raw = thaw(SCENES["nine-bar-lubricated"].raw)
    raw["outputs"]["film"] = {"kind": "joint", "joint": "C1"}
    base = load_scene(raw)
    at = SceneValues(base, ["joints.C1.clearance"])
    assert at({"joints.C1.clearance": 4e-4}).outputs is base.outputs
    ideal = with_overrides(base, {"joints.C1.model": "ideal"})
    assert ideal.joints["C1"].clearance > 0 and "film" in ideal.outputs
    values = {"joints.C1.clearance": 0.0}
    with pytest.raises(SceneError) as want:
        with_overrides(ideal, values)
    assert "outputs.film.joint" in str(want.value) and "has no clearance" in str(want.value)
    with pytest.raises(SceneError) as got:
        SceneValues(ideal, list(values))(values)
    assert str(got.value) == str(want.value)
    _compare(ideal, values)


def test_the_ideal_start_is_the_scenes_own_only_where_the_values_leave_it():
    # the assembly at t = 0 reads the ideal mechanism's arrays and the drivers' angles at
    # t = 0: a speed or a force-law value leaves it (the scene's positions, bitwise those a
    # full compilation assembles); a driver's angle0 or a point moves it (None: the run
    # assembles its own)
    from mechrel.mechanics.kinematics import assemble_positions

    scene = SCENES["nine-bar-lubricated"]
    paths = ["joints.C1.clearance", "joints.C2.lubricant.viscosity", "drivers.crank1.speed",
             "drivers.crank2.speed", "drivers.crank1.angle0"]
    prepared = PreparedScene(scene, paths)
    # with a point among the paths every run writes the points again: never the scene's start
    moved = PreparedScene(scene, paths + ["bodies.crank1.length(O,A)"])
    tol = scene.solver.assembly_tolerance
    for values, same in (
            ({"joints.C1.clearance": 4e-4, "drivers.crank1.speed": -9.0,
              "drivers.crank2.speed": 9.9}, True),
            ({"joints.C2.lubricant.viscosity": 0.2}, True),
            ({"drivers.crank1.angle0": _value_at(scene, "drivers.crank1.angle0") + 0.1},
             False),
            ({"bodies.crank1.length(O,A)": _value_at(scene, "bodies.crank1.length(O,A)")
              * 1.01}, False)):
        at = moved if "bodies.crank1.length(O,A)" in values else prepared
        got, compiled = at.at(values)
        q0 = at.ideal_start(got, compiled)
        assert (q0 is not None) == same, values
        full = compile_scene(with_overrides(scene, values))
        want = assemble_positions(full.ideal, full.q_guess, 0.0, tol=tol)
        if same:
            assert q0.tobytes() == want.tobytes(), values
            q0[:] = np.nan  # a copy: the next run's start is untouched
    # a scene that does not assemble: no start, the run reports its own failure
    assert prepared.ideal_start(*prepared.at({"drivers.crank1.speed": -9.0})) is not None
    wide = PreparedScene(scene, ["drivers.crank1.speed"])
    wide._start = ()
    assert wide.ideal_start(*wide.at({"drivers.crank1.speed": -9.0})) is None


def test_a_batch_with_the_ideal_start_reused_is_bitwise_one_without(monkeypatch):
    from mechrel.study.study import load_study

    study = load_study("nine-bar-lubricated")
    X = study.uncertain_inputs().sample(2, "sobol", 20221014)
    Y = study.model().evaluate_batch(X)
    reused = []
    original = PreparedScene.ideal_start
    monkeypatch.setattr(PreparedScene, "ideal_start",
                        lambda self, s, c: reused.append(original(self, s, c)) or None)
    assert np.array_equal(study.model().evaluate_batch(X), Y)
    assert len(reused) == 2 and all(q is not None for q in reused)
