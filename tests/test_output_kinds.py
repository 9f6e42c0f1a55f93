"""Output kinds (mechrel.outputs): a body's angle and rates, a clearance joint's eccentricity,
film and penetration; their scene syntax, errors, ideal references and the table's users."""

import math

import numpy as np
import pytest

from mechrel.errors import SceneError, StudyError
from mechrel.outputs import OUTPUT_KINDS, QUANTITY_INFO
from mechrel.scene import load_scene
from mechrel.simulation import simulate

FILM = {"kind": "joint", "joint": "A"}
IDEAL = {"joints.A.model": "ideal", "joints.B.model": "ideal", "outputs.film": FILM,
         "analysis.sample_step_angle": math.radians(5.0)}


def test_the_rocker_angle_is_the_closed_form_and_agrees_with_the_tip():
    # ideal four-bar: the rocker angle is atan2 of the tip B about O4 (circle intersection,
    # 1e-10 rad: assembly at 1e-12); its rates agree with the tip's motion along x, computed by
    # the point kind from the rocker's centre, to round-off: tip x = 0.14 + 0.12 cos θ
    res = simulate(load_scene("four-bar", overrides=IDEAL))
    th = np.radians(res.crank_angle)
    ax, ay = 0.05 * np.cos(th), 0.05 * np.sin(th)
    dx, dy = 0.14 - ax, -ay
    d = np.hypot(dx, dy)
    a = (0.15 ** 2 - 0.12 ** 2 + d * d) / (2 * d)
    h = np.sqrt(0.15 ** 2 - a * a)
    bx, by = ax + a * dx / d - h * dy / d, ay + a * dy / d + h * dx / d
    rocker = res.outputs["rocker"]
    assert np.max(np.abs(rocker["angle"] - np.arctan2(by, bx - 0.14))) < 1e-10
    # the film output of the (now ideal) joint A: concentric
    assert np.all(res.outputs["film"]["eccentricity_ratio"] < 1e-9)
    tip = res.outputs["tip"]
    theta, w, al = rocker["angle"], rocker["angular_velocity"], rocker["angular_acceleration"]
    assert np.allclose(tip["velocity"], -0.12 * w * np.sin(theta), rtol=0, atol=1e-12)
    assert np.allclose(tip["acceleration"], -0.12 * (al * np.sin(theta) + w * w * np.cos(theta)),
                       rtol=0, atol=1e-9)


def test_joint_outputs_against_the_journal_orbits():
    # ε from the output kind (point positions) against the simulation's own orbit
    # post-processing (compiled, from the eccentricity vector), h_min = c (1 − ε) and the
    # penetration of the dry pin B; the ideal joint is concentric
    scene = load_scene("four-bar", overrides={
        "outputs.film": FILM, "outputs.pin_b": {"kind": "joint", "joint": "B"}})
    res = simulate(scene)
    for name, joint, c in (("film", "A", 0.1e-3), ("pin_b", "B", 0.2e-3)):
        out = res.outputs[name]
        assert np.allclose(out["eccentricity_ratio"], res.orbits[joint]["eps"], rtol=0, atol=1e-9)
        assert np.allclose(out["min_film_thickness"], c * (1 - out["eccentricity_ratio"]),
                           rtol=0, atol=1e-15)
        assert np.array_equal(out["penetration"],
                              np.maximum(c * out["eccentricity_ratio"] - c, 0.0)) or \
            np.allclose(out["penetration"], np.maximum(c * (out["eccentricity_ratio"] - 1), 0),
                        rtol=0, atol=1e-15)
        assert np.all(res.ideal[name]["eccentricity_ratio"] == 0.0)
        assert np.all(res.ideal[name]["min_film_thickness"] == c)
    assert res.outputs["pin_b"]["penetration"].max() > 0      # the dry pin impacts
    assert res.outputs["film"]["penetration"].max() == 0      # the film keeps A off its wall
    frame = res.to_frame()
    assert "film.min_film_thickness.error" in frame and "rocker.angle.ideal" in frame


@pytest.mark.parametrize("table, match", [
    ({"kind": "angle", "body": "rocker"},
     r"outputs\.x\.kind = \"angle\": unknown value; allowed: one of point, body, joint"),
    ({"kind": "body", "body": "roker"},
     r"outputs\.x\.body = \"roker\": unknown body \(did you mean 'rocker'\?\); allowed: one of "
     r"crank, coupler, rocker"),
    ({"kind": "body", "body": "rocker", "axis": [1.0, 0.0]},
     r"outputs\.x\.axis = \[1\.0, 0\.0\]: unknown field 'axis' for an output of kind 'body'"),
    ({"kind": "body"}, r"outputs\.x\.body: missing required field"),
    ({"kind": "joint", "joint": "O2"},
     r"outputs\.x\.joint = \"O2\": has no clearance; allowed: a revolute joint with a "
     r"clearance: one of A, B"),
    ({"kind": "joint", "joint": "Q"},
     r"outputs\.x\.joint = \"Q\": unknown joint.*allowed: a revolute joint with a clearance"),
])
def test_bad_output_tables_are_one_clear_scene_error(table, match):
    with pytest.raises(SceneError, match=r"embedded:four-bar: " + match):
        load_scene("four-bar", overrides={"outputs.x": table})


def test_every_kind_has_one_evaluator_and_the_catalogue_needs_no_mechanics():
    # the catalogue (ground floor) and the evaluators (simulation) are one row + one function
    # per kind: every kind has its evaluator, and no evaluator is for a kind not catalogued
    import ast
    from pathlib import Path

    import mechrel.outputs
    from mechrel.simulation.evaluators import EVALUATORS, evaluator

    assert set(EVALUATORS) == set(OUTPUT_KINDS)
    with pytest.raises(ValueError, match="'point' has an evaluator already: _point_values"):
        evaluator("point")
    tree = ast.parse(Path(mechrel.outputs.__file__).read_text())
    imported = [a.name for n in ast.walk(tree) if isinstance(n, ast.Import) for a in n.names]
    imported += ["." * n.level + (n.module or "") for n in ast.walk(tree)
                 if isinstance(n, ast.ImportFrom)]
    assert [m for m in imported if m.startswith((".", "mechrel"))] == []


def test_the_table_feeds_the_allowables_and_the_model():
    from mechrel.uq import DEFAULT_ALLOWABLES, MechanismModel
    from mechrel.uq.problem.allowables import resolve_allowables

    # the paper's allowables are the point kind's; the other kinds have none by default
    assert {k: (a.mean, a.std) for k, a in DEFAULT_ALLOWABLES.items()} == {
        "displacement": (0.012, 0.004), "velocity": (0.3, 0.1), "acceleration": (18.0, 6.0)}
    assert set(QUANTITY_INFO) == {q.name for k in OUTPUT_KINDS.values() for q in k.quantities}
    model = MechanismModel("four-bar", ["joints.B.clearance"], output="rocker")
    assert model.quantities == ("angle", "angular_velocity", "angular_acceleration")
    with pytest.raises(StudyError, match=r"allowable: no allowable error for quantity "
                       r"\['angle', 'angular_acceleration', 'angular_velocity'\]"):
        resolve_allowables(model.output_index, None)
    with pytest.raises(StudyError, match=r"quantities: \['velocity'\] must be a non-empty subset "
                       r"of \['eccentricity_ratio', 'min_film_thickness', 'penetration', "
                       r"'reaction_force'\] \(the "
                       r"quantities of output 'film', kind 'joint'\)"):
        MechanismModel("four-bar", ["joints.B.clearance"], output="film",
                       quantities=["velocity"], overrides={"outputs.film": FILM})
    film = MechanismModel("four-bar", ["joints.A.lubricant.viscosity"], output="film",
                          quantities=["min_film_thickness"], overrides={"outputs.film": FILM})
    y = film.evaluate(film.nominal)
    # error = h_min − c = −c ε: in (−c, 0] (angles, max, min); its max_abs is c × the largest
    # ε of the cycle
    assert np.all(y[:-1] <= 0) and np.all(y[:-1] > -0.1e-3)
    assert film.output_index[-1] == ("min_film_thickness", "max_abs")
    assert y[-1] == pytest.approx(0.1e-3 * 0.956, rel=0.01)


def test_cli_simulate_plots_every_output(tmp_path, capsys):
    from mechrel.cli.main import main

    out = tmp_path / "fb.csv"
    assert main(["simulate", "four-bar", "--set", "analysis.cycles=0.25", "--no-progress",
                 "--set", 'outputs.film={kind = "joint", joint = "A"}', "--out", str(out)]) == 0
    text = capsys.readouterr().out
    for line in ("output tip (point):", "output rocker (body):", "output film (joint):",
                 "min_film_thickness", "angle"):
        assert line in text
    assert out.with_suffix(".png").stat().st_size > 0
    import pandas as pd
    cols = pd.read_csv(out).columns
    assert "rocker.angular_acceleration.error" in cols and "film.eccentricity_ratio" in cols


def test_path_deviation_is_the_distance_from_the_ideal_path():
    # the coupler midpoint's curve: the deviation (polyline of 7200 instants, distance to its
    # segments) against an independent one, the distance to the nearest vertex of the ideal
    # path sampled at 20 times as many instants by the same kinematic analysis, which is
    # between the true distance d and sqrt(d² + (ds/2)²), ds its longest chord; 1e-8 m for
    # the polyline's sag
    from scipy.spatial import cKDTree

    from mechrel.mechanics.kinematics import assemble, kinematic_analysis
    from mechrel.mechanics.system import compile_scene
    from mechrel.simulation.evaluators import distance_to_path, ideal_path
    scene = load_scene("four-bar", overrides={
        "bodies.coupler.points.M": [0.0, 0.03],
        "outputs.curve": {"kind": "path", "point": "coupler.M"},
        "outputs.mx": {"point": "coupler.M", "axis": [1.0, 0.0]},
        "outputs.my": {"point": "coupler.M", "axis": [0.0, 1.0]}})
    res = simulate(scene, extremes=True)
    mx, my = res.outputs["mx"]["displacement"], res.outputs["my"]["displacement"]
    cs = compile_scene(scene)
    q0, _ = assemble(cs.ideal, cs.q_guess, 0.0)
    T = np.linspace(0.0, cs.period, 144_001)
    Q = kinematic_analysis(cs.ideal, q0, T)[0]
    b = cs.body_index["coupler"]
    th = Q[:, 3 * b + 2]
    fine = np.column_stack([Q[:, 3 * b] - 0.03 * np.sin(th), Q[:, 3 * b + 1] + 0.03 * np.cos(th)])
    d_ref = cKDTree(fine).query(np.column_stack([mx, my]))[0]
    dev = res.outputs["curve"]["path_deviation"]
    ds = np.max(np.hypot(*np.diff(fine, axis=0).T))
    assert np.all(dev <= d_ref + 1e-8)
    assert np.all(d_ref <= np.sqrt(dev ** 2 + (ds / 2) ** 2) + 1e-8)
    assert dev.max() > 1e-5  # the clearances move the point off its curve by tens of µm
    # the deviation is smaller than the same-time distance (timing along the path is no error)
    same_time = np.hypot(res.error("mx", "displacement"), res.error("my", "displacement"))
    assert np.all(dev <= same_time + 1e-12) and np.any(dev < 0.5 * same_time)
    assert np.all(res.ideal["curve"]["path_deviation"] == 0.0)
    assert res.extremes["curve"]["path_deviation"]["max_abs"] >= dev[-361:].max()
    path = ideal_path(scene, scene.outputs["curve"].point)
    assert np.max(distance_to_path(path[100:200, 0], path[100:200, 1], path)) < 1e-15
    with pytest.raises(SceneError, match=r"outputs\.c\.axis = .*unknown field 'axis' for an "
                       r"output of kind 'path'"):
        load_scene("four-bar", overrides={"outputs.c": {"kind": "path", "point": "rocker.B",
                                                        "axis": [1.0, 0.0]}})


def test_reaction_forces():
    # ideal four-bar: |λ| of joints A and B against an independent inverse dynamics, the
    # Newton-Euler equations of the coupler and the rocker solved for the pin forces
    # (6 equations, 6 unknowns) from the simulated accelerations; 1e-6 relative (the
    # kinematic accelerations and the Schur solve agree to round-off)
    scene = load_scene("four-bar", overrides={
        **IDEAL, "outputs.pin_b": {"kind": "joint", "joint": "B"}})
    res = simulate(scene)
    cp, rk = 3, 6  # coupler and rocker coordinates in q (bodies crank, coupler, rocker)
    mc, Jc, mr, Jr, g = 0.24, 4.5e-4, 0.19, 2.28e-4, np.array([0.0, -9.81])
    fa, fb = [], []
    for q, a in zip(res.q, res.a):
        def at(i, sx, sy):
            th = q[i + 2]
            return np.array([np.cos(th) * sx - np.sin(th) * sy, np.sin(th) * sx + np.cos(th) * sy])
        rA, rB = at(cp, -0.075, 0.0), at(cp, 0.075, 0.0)        # from the coupler's centre
        rB2, rO = at(rk, 0.06, 0.0), at(rk, -0.06, 0.0)          # from the rocker's centre
        M = np.zeros((6, 6))  # unknowns F_A (on coupler), F_B (on coupler), F_O4 (on rocker)
        M[0:2, 0:2] = M[0:2, 2:4] = np.eye(2)
        M[2, 0:2] = [-rA[1], rA[0]]
        M[2, 2:4] = [-rB[1], rB[0]]
        M[3:5, 2:4] = -np.eye(2)
        M[3:5, 4:6] = np.eye(2)
        M[5, 2:4] = [rB2[1], -rB2[0]]
        M[5, 4:6] = [-rO[1], rO[0]]
        rhs = np.concatenate([mc * a[cp:cp + 2] - mc * g, [Jc * a[cp + 2]],
                              mr * a[rk:rk + 2] - mr * g, [Jr * a[rk + 2]]])
        F = np.linalg.solve(M, rhs)
        fa.append(np.hypot(*F[0:2]))
        fb.append(np.hypot(*F[2:4]))
    assert np.allclose(res.outputs["film"]["reaction_force"], fa, rtol=1e-6, atol=1e-9)
    assert np.allclose(res.outputs["pin_b"]["reaction_force"], fb, rtol=1e-6, atol=1e-9)
    # with clearances: the dry pin B carries force only in contact; the ideal reference is the
    # ideal mechanism's |λ|
    dyn = simulate(load_scene("four-bar", overrides={
        "outputs.pin_b": {"kind": "joint", "joint": "B"}}), extremes=True)
    f, pen = dyn.outputs["pin_b"]["reaction_force"], dyn.outputs["pin_b"]["penetration"]
    assert np.all(f[pen == 0] == 0) and np.all(f[pen > 0] > 0)
    assert dyn.ideal["pin_b"]["reaction_force"].min() > 0
    assert dyn.extremes["pin_b"]["reaction_force"]["max_abs"] >= np.abs(
        dyn.error("pin_b", "reaction_force")[-361:]).max()


# --------------------------------------------------------------------------- every kind, everywhere
# One output of each kind of the table on the four-bar (a new kind must add its example here:
# the first test fails until it does). The coupler gets a point M for the path.
EXAMPLES = {
    "point": {"point": "rocker.B", "axis": [1.0, 0.0]},
    "body": {"kind": "body", "body": "rocker"},
    "joint": {"kind": "joint", "joint": "A"},
    "path": {"kind": "path", "point": "coupler.M"},
}
COUPLER_M = {"bodies.coupler.points.M": [0.0, 0.03]}


def test_every_output_kind_has_an_example():
    assert set(EXAMPLES) == set(OUTPUT_KINDS)


def _allowables(kind):
    """A [allowable.QUANTITY] table for every quantity of the kind (the default allowables
    cover only the point's): means of the order of the quantities' errors."""
    return "".join(f"[allowable.{q.name}]\nmean = {1e-3 * (1 + k)}\nstd = {1e-4 * (1 + k)}\n"
                   for k, q in enumerate(OUTPUT_KINDS[kind].quantities))


def test_simulate_prints_and_plots_every_kind(tmp_path, capsys):
    from mechrel.cli.main import main

    sets = [f"outputs.o_{k}={_toml(t)}" for k, t in EXAMPLES.items()]
    sets += [f"{p}={_toml(v)}" for p, v in COUPLER_M.items()]
    out = tmp_path / "fb.csv"
    args = ["simulate", "four-bar", "--set", "analysis.cycles=0.05", "--no-progress",
            "--out", str(out)]
    for s in sets:
        args += ["--set", s]
    assert main(args) == 0
    text = capsys.readouterr().out
    for kind in EXAMPLES:
        assert f"output o_{kind} ({kind}):" in text
        for q in OUTPUT_KINDS[kind].quantities:
            assert f"    {q.name} error " in text
    assert out.with_suffix(".png").stat().st_size > 0


def _toml(value):
    """A scene value as the TOML literal of a --set."""
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k} = {_toml(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_toml(v) for v in value) + "]"
    return f'"{value}"' if isinstance(value, str) else repr(value)


@pytest.mark.parametrize("kind", list(EXAMPLES))
def test_animate_draws_every_kind(kind, tmp_path, capsys):
    # the crash of the issue: `mechrel animate --output rocker` raised KeyError 'displacement'
    # after simulating (the default quantity was a point's); now every kind's quantities, the
    # first by default and each one by --quantity, and a wrong one before anything runs
    from mechrel.cli.main import main

    base = ["animate", "four-bar", "--set", "analysis.cycles=0.05", "--no-progress",
            "--frames", "2", "--output", f"o_{kind}",
            "--set", f"outputs.o_{kind}={_toml(EXAMPLES[kind])}"]
    for p, v in COUPLER_M.items():
        base += ["--set", f"{p}={_toml(v)}"]
    html = tmp_path / f"{kind}.html"
    assert main(base + ["--out", str(html)]) == 0
    assert html.stat().st_size > 0
    last = OUTPUT_KINDS[kind].quantities[-1].name
    assert main(base + ["--quantity", last, "--out", str(html)]) == 0
    capsys.readouterr()
    assert main(base + ["--quantity", "jerk", "--out", str(html)]) == 2
    err = capsys.readouterr()
    assert f"quantity = 'jerk': not a quantity of output 'o_{kind}' (kind '{kind}')" in err.err
    assert "scene four-bar" not in err.out  # refused before simulating


def test_draw_shows_the_scene_whatever_its_outputs(tmp_path):
    from mechrel.cli.main import main

    args = ["draw", "four-bar", "--out", str(tmp_path / "fb.png")]
    for k, t in EXAMPLES.items():
        args += ["--set", f"outputs.o_{k}={_toml(t)}"]
    for p, v in COUPLER_M.items():
        args += ["--set", f"{p}={_toml(v)}"]
    assert main(args) == 0 and (tmp_path / "fb.png").stat().st_size > 0


@pytest.mark.parametrize("kind", list(EXAMPLES))
def test_studies_and_their_figures_take_every_kind(kind, tmp_path, capsys):
    # FOSM reliability (2 d + 1 = 5 runs) and Sobol sensitivity (N (d + 2) = 32 runs) of the
    # ideal four-bar (kinematic analysis: milliseconds a run; every 20° of the crank) with two
    # link-length tolerances, on an output of each kind: tables, figures and the summary
    from mechrel.cli.main import main

    study = tmp_path / "study.toml"
    overrides = {"joints.A.model": "ideal", "joints.B.model": "ideal",
                 "analysis.sample_step_angle": math.radians(20.0),
                 f"outputs.o_{kind}": EXAMPLES[kind], **COUPLER_M}
    study.write_text(
        f'scene = "four-bar"\noutput = "o_{kind}"\ncycles = 1\n[scene_overrides]\n'
        + "".join(f'"{p}" = {_toml(v)}\n' for p, v in overrides.items())
        + '[inputs.crank]\npaths = ["bodies.crank.length(O,A)"]\ndistribution = "normal"\n'
          'mean = 0.05\nstd = 1e-4\n'
          '[inputs.rocker]\npaths = ["bodies.rocker.length(O,B)"]\ndistribution = "normal"\n'
          'mean = 0.12\nstd = 1e-4\n'
        + _allowables(kind), encoding="utf-8")
    out = tmp_path / "out"
    assert main(["reliability", str(study), "--method", "fosm", "--jobs", "1", "--out",
                 str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    for q in OUTPUT_KINDS[kind].quantities:
        assert f"  {q.name}: " in text
    for name in ("reliability.csv", "reliability.png", "summary.json"):
        assert (out / name).stat().st_size > 0
    assert main(["sensitivity", str(study), "--n", "8", "--jobs", "1", "--out", str(out),
                 "--no-progress"]) == 0
    figures = [p for p in out.iterdir() if p.name.startswith("sensitivity")
               and p.suffix == ".png"]
    assert figures and all(p.stat().st_size > 0 for p in figures)


@pytest.mark.parametrize("kind", list(EXAMPLES))
def test_the_accuracy_study_measures_every_kind(kind):
    # the first output's own quantities (the accuracy study measured a point's three, and a
    # scene whose first output was a body failed with KeyError 'displacement')
    from mechrel.study.accuracy import _curves, perturbed_scenes, run_ensemble

    scene = load_scene("four-bar", overrides={
        "analysis.cycles": 0.05, "outputs": {"o": EXAMPLES[kind]}, **COUPLER_M})
    res = simulate(scene)
    assert list(_curves(res, "o")) == [q.name for q in OUTPUT_KINDS[kind].quantities]
    run = run_ensemble(perturbed_scenes(scene, 2), "dopri5", {"rtol": 1e-6, "atol": 1e-9})
    assert run.statistics.shape == (2, len(OUTPUT_KINDS[kind].quantities), 3)


def test_a_path_against_a_reference_design_is_its_distance_from_the_reference_path():
    # an ideal four-bar with a longer crank against the nominal design: the coupler point's
    # path deviation is its distance from the nominal path (it read 0, the deviation of a point
    # from its own path, so a study of path tolerances on an ideal mechanism found nothing)
    from mechrel.simulation.evaluators import distance_to_path, ideal_path
    over = {"joints.A.model": "ideal", "joints.B.model": "ideal",
            "outputs.curve": EXAMPLES["path"], "outputs.mx": {"point": "coupler.M",
                                                              "axis": [1.0, 0.0]},
            "outputs.my": {"point": "coupler.M", "axis": [0.0, 1.0]}, **COUPLER_M}
    nominal = load_scene("four-bar", overrides=over)
    longer = load_scene("four-bar", overrides={**over, "bodies.crank.length(O,A)": 0.0502})
    res = simulate(longer, reference=nominal, extremes=True)
    mx, my = res.outputs["mx"]["displacement"], res.outputs["my"]["displacement"]
    path = ideal_path(nominal, nominal.outputs["curve"].point)
    dev = res.outputs["curve"]["path_deviation"]
    assert np.array_equal(dev, distance_to_path(mx, my, path))
    assert 1e-5 < dev.max() < 1e-3  # 0.2 mm longer crank: the curve moves by a fraction of it
    assert np.array_equal(res.error("curve", "path_deviation"), dev)  # the reference's is 0
    assert res.extremes["curve"]["path_deviation"]["max_abs"] >= dev[-361:].max() - 1e-12
    # without a reference the ideal point lies on its own path
    assert np.all(simulate(nominal).outputs["curve"]["path_deviation"] == 0.0)


@pytest.mark.parametrize("layout", ["contiguous", "columns of a wider state"])
def test_the_compiled_point_kind_has_the_bits_of_its_numpy_formulas(layout):
    # the point kind's position, velocity and acceleration along its axis are compiled in one
    # pass after NumPy's cos and sin: bit for bit the NumPy expressions the values were first
    # computed with (a changed order of operations, or a fused multiply-add, changes the last
    # bit of many of 500 random rows)
    from mechrel.simulation.evaluators import _point_motion

    rng = np.random.default_rng(7)
    n, b = 9, 1
    Q, V, A = (rng.normal(size=(500, 2 * n + 2)) for _ in range(3))
    if layout == "contiguous":
        Q, V, A = (np.ascontiguousarray(X[:, :n]) for X in (Q, V, A))
    else:
        Q, V, A = Q[:, :n], V[:, n:2 * n], A[:, :n]
    sx, sy = 0.137, -0.051
    ux, uy = math.cos(0.3), math.sin(0.3)
    th, w, al = Q[:, 3 * b + 2], V[:, 3 * b + 2], A[:, 3 * b + 2]
    c, s = np.cos(th), np.sin(th)
    ax, ay = c * sx - s * sy, s * sx + c * sy
    px, py = Q[:, 3 * b] + ax, Q[:, 3 * b + 1] + ay
    vx, vy = V[:, 3 * b] - ay * w, V[:, 3 * b + 1] + ax * w
    accx = A[:, 3 * b] - ay * al - ax * w * w
    accy = A[:, 3 * b + 1] + ax * al - ay * w * w
    x, v, a = _point_motion(Q, V, A, b, sx, sy, ux, uy, c, s)
    assert np.array_equal(x, px * ux + py * uy)
    assert np.array_equal(v, vx * ux + vy * uy)
    assert np.array_equal(a, accx * ux + accy * uy)


@pytest.mark.parametrize("kind", sorted(EXAMPLES))
def test_every_kind_computes_each_row_from_that_row_alone(kind):
    # the evaluator contract: a row's values depend on that row's state alone (the cycle
    # extremes take the window's values at the output instants from the run's outputs and
    # compute the rest on the solution log's rows: mechrel.simulation.run._window_values).
    # On the dry and lubricated four-bar: the values of any subset of the rows, in any order,
    # are bitwise those rows of the values of all of them, actual and ideal states both
    from mechrel.mechanics.system import compile_scene
    from mechrel.simulation.evaluators import values

    scene = load_scene("four-bar", overrides={**COUPLER_M, "outputs.x": EXAMPLES[kind]})
    res = simulate(scene)
    c = compile_scene(scene)
    H = np.zeros((res.time.size, c.dynamic.n_contacts))  # an impact speed per contact joint
    H[:, :] = np.linspace(0.0, 0.3, res.time.size)[:, None]
    rows = np.random.default_rng(5).permutation(res.time.size)[: res.time.size // 3]
    for ideal in (False, True):
        whole = values(scene, c, res.time, res.q, res.v, res.a, H=H, ideal=ideal)["x"]
        part = values(scene, c, res.time[rows], res.q[rows], res.v[rows], res.a[rows],
                      H=H[rows], ideal=ideal)["x"]
        assert whole.keys() == part.keys() == {q.name for q in OUTPUT_KINDS[kind].quantities}
        for q, v in whole.items():
            assert np.array_equal(part[q], v[rows]), (ideal, q)
