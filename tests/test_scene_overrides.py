"""Dotted overrides, ``extends`` variants, ``with_overrides``, the read-only raw mapping and the
scene hash."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from mechrel.errors import SceneError
from mechrel.scene import (
    load_scene, parse_override, parse_value, scene_hash, with_overrides,
)
from mechrel.scene.loader import canonical_json, deep_merge


# --------------------------------------------------------------------------- values

@pytest.mark.parametrize("text, value", [
    ("0.3e-3", 0.3e-3), ("1e-3", 1e-3), ("2", 2), ("-4.5", -4.5), ("inf", math.inf),
    ('"dry"', "dry"), ("dry", "dry"), ("scipy-radau", "scipy-radau"),
    (" lubricated ", "lubricated"),
    ("[1.0, 2.0]", [1.0, 2.0]), ("true", True), ("false", False),
    ("{ viscosity = 0.2 }", {"viscosity": 0.2}), (".5", 0.5), ("5.", 5.0), ("", ""),
    ("1.0.0", "1.0.0"), ("a = 1", "a = 1"),
])
def test_parse_value(text, value):
    assert parse_value(text) == value
    assert type(parse_value(text)) is type(value)


def test_parse_override_splits_at_first_equals():
    assert parse_override("joints.C1.model=dry") == ("joints.C1.model", "dry")
    assert parse_override(" description = a=b ") == ("description", "a=b")
    with pytest.raises(SceneError, match="expected PATH=VALUE"):
        parse_override("joints.C1.model")


# --------------------------------------------------------------------------- overrides

def test_dotted_overrides_as_strings():
    s = load_scene("nine-bar", overrides=["joints.C1.clearance=0.3e-3", "joints.C1.model=dry",
                                          "joints.C2.model=lubricated", "gravity=[0.0, 0.0]",
                                          "solver.integrator=radau", "solver.rtol=1e-7"])
    c1, c2 = s.joints["C1"], s.joints["C2"]
    assert c1.clearance == 0.3e-3 and c1.model == "dry" and c2.model == "lubricated"
    assert s.gravity == (0.0, 0.0)
    assert s.solver.integrator == "radau" and s.solver.rtol == 1e-7
    assert s.source == "embedded:nine-bar"


def test_overrides_as_mapping_and_pairs():
    a = load_scene("nine-bar", overrides={"joints.C1.lubricant.viscosity": 0.4,
                                          "joints.C1.model": "lubricated"})
    b = load_scene("nine-bar", overrides=[("joints.C1.lubricant.viscosity", 0.4),
                                          "joints.C1.model=lubricated"])
    c = load_scene("nine-bar", overrides="joints.C1.model=lubricated")  # a single string
    assert a.joints["C1"].lubricant.viscosity == 0.4 == b.joints["C1"].lubricant.viscosity
    assert scene_hash(a) == scene_hash(b)
    assert c.joints["C1"].model == "lubricated" and c.joints["C1"].lubricant.viscosity == 0.1


def test_override_into_missing_sub_table_uses_defaults():
    s = load_scene("slider-crank",
                   overrides=["joints.C.model=transition", "joints.C.transition.e1=2e-5"])
    t = s.joints["C"].transition
    assert t.e1 == 2e-5 and t.eps_max == 0.99  # default filled
    assert s.joints["C"].lubricant.viscosity == 0.4 and s.joints["C"].contact is not None


def test_override_later_wins_and_whole_tables():
    s = load_scene("slider-crank", overrides=["bodies.rod.mass=1", "bodies.rod.mass=2",
                                              "joints.C.friction={coefficient = 0.2}",
                                              "bodies.rod.points.M=[0.0, 0.0]"])
    assert s.bodies["rod"].mass == 2.0
    assert s.joints["C"].friction.coefficient == 0.2 and s.joints["C"].friction.v1 == 1e-2
    assert s.bodies["rod"].points["M"] == (0.0, 0.0)


def test_override_switches_exclusive_analysis_keys():
    s = load_scene("nine-bar", overrides=["analysis.duration=0.1"])
    assert s.analysis.duration == 0.1 and s.analysis.cycles is None
    assert s.analysis.cycle_driver == "crank1"  # still needed by sample_step_angle
    s = load_scene("nine-bar", overrides=["analysis.sample_step=1e-3"])
    assert s.analysis.sample_step == 1e-3 and s.analysis.sample_step_angle is None


def test_ideal_joint_carries_clearance_data():
    ideal = load_scene("nine-bar")
    assert ideal.clearance_joints == ()
    assert ideal.joints["C1"].clearance == 0.5e-3  # carried, ignored while ideal
    dry = load_scene("nine-bar", overrides=["joints.C1.model=dry"])
    assert [j.name for j in dry.clearance_joints] == ["C1"]


def test_with_overrides():
    base = load_scene("nine-bar")
    s = with_overrides(base, {"joints.C1.clearance": 0.7e-3})
    assert s.joints["C1"].clearance == 0.7e-3 and base.joints["C1"].clearance == 0.5e-3
    assert s.source == base.source
    assert with_overrides(base, ()) == base
    assert scene_hash(with_overrides(base, ())) == scene_hash(base)
    assert load_scene(base, overrides={"joints.C1.clearance": 0.7e-3}) == s
    # a scene built without the loader (empty raw) still works
    bare = dataclasses.replace(base, raw={})
    assert with_overrides(bare, {"joints.C1.clearance": 0.7e-3}) == s
    with pytest.raises(SceneError, match=r"^embedded:nine-bar: joints\.C1\.clearance = 0\.02"):
        with_overrides(base, ["joints.C1.clearance=0.02"])


# --------------------------------------------------------------------------- extends

def _write(path: Path, text: str) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


def test_extends_embedded_deep_merges(tmp_path):
    p = _write(tmp_path / "v.toml", """
extends = "nine-bar"
name = "nine-bar-tight"
[joints.C1]
model = "dry"
clearance = 0.3e-3
[joints.C1.lubricant]
viscosity = 0.2
""")
    s = load_scene(p)
    base = load_scene("nine-bar")
    c1 = s.joints["C1"]
    assert s.name == "nine-bar-tight" and s.description == base.description
    assert c1.model == "dry" and c1.clearance == 0.3e-3
    assert c1.bearing_radius == 15e-3 and c1.contact == base.joints["C1"].contact  # merged
    assert c1.lubricant.viscosity == 0.2 and c1.lubricant.lam == base.joints["C1"].lubricant.lam
    assert s.joints["C2"] == base.joints["C2"] and s.bodies == base.bodies
    assert s.source == str(p) and "extends" not in s.raw


def test_extends_relative_path_chain_and_array_replacement(tmp_path):
    _write(tmp_path / "base" / "a.toml", """
extends = "slider-crank"
name = "a"
gravity = [0.0, 0.0]
""")
    p = _write(tmp_path / "b.toml", """
extends = "base/a.toml"
name = "b"
[bodies.rod]
points = { A = [-0.06, 0.0], B = [0.06, 0.0], M = [0.0, 0.01] }
[analysis]
duration = 0.05
sample_step = 1e-4
""")
    s = load_scene(str(p))
    assert s.name == "b" and s.gravity == (0.0, 0.0)
    assert set(s.bodies["rod"].points) == {"A", "B", "M"}
    assert s.bodies["rod"].mass == 0.21
    # a layer that sets duration / sample_step drops the inherited cycles / sample_step_angle
    assert s.analysis.duration == 0.05 and s.analysis.cycles is None
    assert s.analysis.sample_step == 1e-4 and s.analysis.sample_step_angle is None


def test_extends_with_overrides(tmp_path):
    p = _write(tmp_path / "v.toml", 'extends = "slider-crank-dry"\nname = "v"\n')
    s = load_scene(p, overrides=["joints.C.contact.restitution=0.5"])
    assert s.joints["C"].model == "dry" and s.joints["C"].contact.restitution == 0.5
    assert s.analysis.cycles == 2


def test_extends_from_mapping_source():
    s = load_scene({"extends": "slider-crank", "name": "m", "joints": {"C": {"model": "dry"}}})
    assert s.joints["C"].is_clearance and s.source is None


@pytest.mark.parametrize("text, expected", [
    ('extends = "nine-bra"\n', ["extends = \"nine-bra\"", "unknown embedded scene",
                                "did you mean 'nine-bar'", "allowed: an embedded scene name"]),
    ('extends = "missing.toml"\n', ["extends = \"missing.toml\"", "no such file", "allowed:"]),
    ("extends = 3\n", ["extends = 3", "expected a non-empty string", "allowed:"]),
    ('extends = "self.toml"\n', ["circular extends", "allowed: a chain of bases that ends"]),
])
def test_extends_errors(tmp_path, text, expected):
    p = _write(tmp_path / "self.toml", text + 'name = "x"\n')
    with pytest.raises(SceneError) as info:
        load_scene(p)
    msg = str(info.value)
    assert msg.startswith(str(p))
    for part in expected:
        assert part in msg, f"{part!r} not in {msg!r}"


def test_extends_cycle_through_two_files(tmp_path):
    _write(tmp_path / "a.toml", 'extends = "b.toml"\nname = "a"\n')
    _write(tmp_path / "b.toml", 'extends = "a.toml"\nname = "b"\n')
    with pytest.raises(SceneError, match="circular extends"):
        load_scene(tmp_path / "a.toml")


def test_error_in_base_names_the_base(tmp_path):
    _write(tmp_path / "base.toml", 'name = "base"\nbodies = [\n')
    p = _write(tmp_path / "v.toml", 'extends = "base.toml"\n')
    with pytest.raises(SceneError) as info:
        load_scene(p)
    assert str(info.value).startswith(str(tmp_path / "base.toml")) and "line" in str(info.value)


def test_deep_merge_rules():
    base = {"a": {"x": 1, "y": [1, 2]}, "b": 1, "analysis": {"cycles": 1, "sample_step": 0.1}}
    over = {"a": {"y": [3]}, "c": {"z": 1}, "analysis": {"duration": 2.0}}
    out = deep_merge(base, over)
    assert out == {"a": {"x": 1, "y": [3]}, "b": 1, "c": {"z": 1},
                   "analysis": {"duration": 2.0, "sample_step": 0.1}}
    assert base["a"]["y"] == [1, 2]  # inputs untouched


# --------------------------------------------------------------------------- raw and hash

def test_raw_is_read_only_and_canonical():
    s = load_scene("slider-crank")
    with pytest.raises(TypeError):
        s.raw["name"] = "x"
    with pytest.raises(TypeError):
        s.raw["bodies"]["crank"]["mass"] = 1.0
    assert isinstance(s.raw["gravity"], tuple)
    # defaults are written out, so the raw mapping describes the scene completely
    assert s.raw["joints"]["C"]["contact"]["exponent"] == 1.5
    assert s.raw["solver"]["integrator"] == "auto"
    assert s.raw["joints"]["O"]["model"] == "ideal"


SCENE_A = """
name = "h"
[ground.points]
O = [0, 0]
[bodies.bar]
mass = 1
inertia = 0.1
position = [0.5, 0]
points = { O = [-0.5, 0] }
[joints.O]
type = "revolute"
connects = ["ground.O", "bar.O"]
[analysis]
duration = 1
sample_step = 0.01
"""

SCENE_B = """# same content: other order, floats, defaults written out, inline tables
name = "h"
description = ""
gravity = [0.0, -9.81]
analysis = { sample_step = 0.01, duration = 1.0 }
[joints.O]
connects = ["ground.O", "bar.O"]
type = "revolute"
model = "ideal"
[bodies.bar]
points.O = [-0.5, 0.0]
position = [0.5, 0.0]
inertia = 0.1
angle = 0.0
mass = 1.0
[ground]
points = { O = [0.0, 0.0] }
[solver]
integrator = "auto"
"""


def test_hash_stability(tmp_path):
    a = load_scene(_write(tmp_path / "a.toml", SCENE_A))
    b = load_scene(_write(tmp_path / "sub" / "b.toml", SCENE_B))
    h = scene_hash(a)
    assert len(h) == 64 and int(h, 16) >= 0
    assert scene_hash(b) == h  # same content, different file, layout and formatting
    assert scene_hash(load_scene(_write(tmp_path / "a.toml", SCENE_A))) == h  # reload
    assert scene_hash(load_scene(a.raw)) == h
    assert canonical_json(a) == canonical_json(b)
    changed = load_scene(tmp_path / "a.toml", overrides={"bodies.bar.mass": 1.0000001})
    assert scene_hash(changed) != h
    assert scene_hash(load_scene(tmp_path / "a.toml", overrides=["gravity=[0.0, -9.80665]"])) != h


def test_embedded_hashes_are_distinct():
    from mechrel.scene import embedded_names
    hashes = {scene_hash(load_scene(n)) for n in embedded_names()}
    assert len(hashes) == len(embedded_names())


@settings(max_examples=40, deadline=None)
@given(c=st.floats(min_value=1e-6, max_value=14e-3, allow_nan=False),
       mu=st.floats(min_value=0.0, max_value=10.0, allow_nan=False))
def test_hash_tracks_values(c, mu):
    ov = {"joints.C1.clearance": c, "joints.C1.lubricant.viscosity": mu}
    s1 = load_scene("nine-bar", overrides=ov)
    s2 = with_overrides(load_scene("nine-bar"), ov)
    assert scene_hash(s1) == scene_hash(s2)
    assert (scene_hash(s1) == scene_hash(load_scene("nine-bar"))) == (c == 0.5e-3 and mu == 0.1)
