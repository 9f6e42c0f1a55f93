"""One rule per value (mechrel._checks): the same bad value gives the same rule's message from
the command line, the study file and the Python API."""

from __future__ import annotations

import re
import tomllib
from importlib import resources

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from mechrel._checks import ARGS, Checker
from mechrel.cli import args as cli_args
from mechrel.cli.main import main
from mechrel.errors import MechrelError, SceneError, StudyError
from mechrel.study.study import load_study
from mechrel.uq import (
    Allowable, Normal, UncertainInputs, evaluate, linear_model, monte_carlo, monte_carlo_design,
    sobol_indices,
)

INPUTS = UncertainInputs.from_specs({"x0": Normal(0.0, 1.0), "x1": Normal(1.0, 0.5)})
MODEL = linear_model(np.array([0.1, -0.5]), np.array([[0.5, 0.0], [0.2, 0.3]]), INPUTS.names)
ALLOW = Allowable(1.0, 0.3)


def _study_raw() -> dict:
    data = resources.files("mechrel.study").joinpath("data", "nine-bar-lubricated.toml")
    return tomllib.loads(data.read_text("utf-8"))


def _study_message(path: str, value) -> str:
    raw = _study_raw()
    section, _, key = path.rpartition(".")
    (raw.setdefault(section, {}) if section else raw)[key] = value
    with pytest.raises(StudyError) as info:
        load_study(raw)
    return str(info.value)


def _cli_message(option: str, text: str, capsys) -> str:
    with pytest.raises(SystemExit) as info:
        main(["reliability", "nine-bar-lubricated", "--no-progress", option, text])
    assert info.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    m = re.search(rf"argument {re.escape(option)}: (.*)$", err)
    assert m, err
    return m.group(1)


def _api_message(call) -> str:
    with pytest.raises(StudyError) as info:
        call()
    return str(info.value)


# (study path, study value, CLI option and text, API call, expected tail "VALUE: PROBLEM; ...")
CASES = [
    pytest.param("reliability.n", 1, "--n", "1",
                 lambda: monte_carlo(model=MODEL, inputs=INPUTS, n=1, allowable=ALLOW),
                 "1: must be >= 2; allowed: an integer >= 2 (a sample count)", id="n=1"),
    pytest.param("sensitivity.n", 0, "--n", "0",
                 lambda: sobol_indices(model=MODEL, inputs=INPUTS, n=0),
                 "0: must be >= 2; allowed: an integer >= 2 (a sample count)", id="n=0"),
    pytest.param("reliability.n", 2.5, "--n", "2.5",
                 lambda: monte_carlo_design(INPUTS, n=2.5),
                 "2.5: expected an integer, got a number; allowed: an integer >= 2 "
                 "(a sample count)", id="n=2.5"),
    pytest.param("reliability.seed", -1, "--seed", "-1",
                 lambda: monte_carlo(model=MODEL, inputs=INPUTS, n=8, seed=-1,
                                     allowable=ALLOW),
                 "-1: must be >= 0; allowed: an integer >= 0 (a seed)", id="seed=-1"),
    pytest.param("reliability.max_failure_fraction", 1.5, "--max-failure-fraction", "1.5",
                 lambda: monte_carlo(model=MODEL, inputs=INPUTS, n=8, allowable=ALLOW,
                                     max_failure_fraction=1.5),
                 "1.5: must be <= 1; allowed: a finite number in [0, 1]", id="fraction=1.5"),
]


@pytest.mark.parametrize("study_path, study_value, option, text, call, tail", CASES)
def test_same_value_same_message_in_every_layer(study_path, study_value, option, text, call,
                                                tail, capsys):
    study = _study_message(study_path, study_value)
    assert study == f"<mapping>: {study_path} = {tail}"
    assert _cli_message(option, text, capsys) == tail
    api = _api_message(call)
    name = {"--max-failure-fraction": "max_failure_fraction"}.get(option, option[2:])
    assert api == f"{name} = {tail}"


def test_jobs_rule_is_shared_by_the_command_line_and_the_executor(capsys):
    tail = "0: must be >= 1 or -1; allowed: an integer >= 1, or -1 (all cores or all the " \
           "cluster's workers)"
    assert _cli_message("--jobs", "0", capsys) == tail
    X = INPUTS.sample(4, seed=1)
    assert _api_message(lambda: evaluate(MODEL, X, n_jobs=0)) == f"n_jobs = {tail}"


def test_angle_step_rule_is_shared_by_the_study_and_the_model():
    from mechrel.uq.problem.mechanism import MechanismModel

    tail = "7: does not divide 360 degrees; allowed: a divisor of 360 (degrees), e.g. 18, 10 or 5"
    assert _study_message("angle_step", 7) == f"<mapping>: angle_step = {tail}"
    paths = {"c": ("joints.C1.clearance",)}
    api = _api_message(lambda: MechanismModel("nine-bar-lubricated", paths, angle_step=7))
    assert api == f"angle_step = {tail}"


@given(st.one_of(st.integers(-10**6, 10**6), st.floats(allow_nan=True, allow_infinity=True),
                 st.text(max_size=6)))
def test_command_line_types_apply_the_api_rules(value):
    """For any text, the argparse type accepts exactly what the API rule accepts, with the same
    value, and refuses with the API rule's message (without the path)."""
    text = str(value)
    for name in ("sample_count", "seed", "jobs", "fraction"):
        convert = getattr(cli_args, name)
        parsed = value
        if isinstance(value, str):
            try:
                parsed = int(text)
            except ValueError:
                try:
                    parsed = float(text)
                except ValueError:
                    parsed = text
        try:
            expected = getattr(ARGS, name)("x", parsed)
        except StudyError as exc:
            with pytest.raises(Exception) as info:
                convert(text)
            assert str(info.value) == str(exc).removeprefix("x = ")
        else:
            assert convert(text) == expected


def test_checker_raises_the_error_class_it_is_given():
    with pytest.raises(SceneError, match=r"^f\.toml: a\.b = -1: must be >= 0"):
        Checker("f.toml").number("a.b", -1, ge=0)
    with pytest.raises(StudyError, match=r"^f\.toml: a\.b = -1: must be >= 0") as info:
        Checker("f.toml", error=StudyError).number("a.b", -1, ge=0)
    assert isinstance(info.value, MechrelError) and info.value.path == "a.b"
    assert info.value.source == "f.toml"


@pytest.mark.parametrize("value, ok", [(2, True), (np.int64(3), True), (True, False),
                                       (np.bool_(True), False), (2.0, False), ("2", False)])
def test_sample_count_types(value, ok):
    if ok:
        assert ARGS.sample_count("n", value) == int(value)
    else:
        with pytest.raises(StudyError, match=r"^n = .*: expected an integer"):
            ARGS.sample_count("n", value)
