"""Pictures: ``mechrel draw`` and ``mechrel animate`` (src/mechrel/io/drawing.py)."""

from __future__ import annotations

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
from PIL import Image  # noqa: E402

from mechrel.cli.main import main  # noqa: E402
from mechrel.errors import AssemblyError, MechrelError  # noqa: E402
from mechrel.io import drawing  # noqa: E402
from mechrel.scene import embedded_names, load_scene  # noqa: E402
from mechrel.simulation import simulate  # noqa: E402


@pytest.mark.parametrize("name", embedded_names())
def test_draw_every_embedded_scene(name, tmp_path):
    scene = load_scene(name)
    fig = drawing.draw_scene(scene)
    ax = fig.axes[0]
    # one artist per body (a polygon or a bar) and one marker per revolute joint, placed at
    # the assembled position of the joint's first point
    q = drawing.assembled_configuration(scene)
    pos = drawing.point_positions(scene, q)
    markers = {(round(x, 6), round(y, 6)) for line in ax.lines if line.get_marker() == "o"
               for x, y in zip(*line.get_data())}
    for joint in scene.joints.values():
        if joint.type == "revolute":
            x, y = pos[str(joint.points[0])] * 1e3
            assert (round(x, 6), round(y, 6)) in markers, joint.name
    # every point lies inside the drawn area
    x0, x1 = ax.get_xlim()
    y0, y1 = ax.get_ylim()
    for p in pos.values():
        assert x0 < p[0] * 1e3 < x1 and y0 < p[1] * 1e3 < y1
    path = tmp_path / f"{name}.png"
    fig.savefig(path, dpi=80)
    plt.close(fig)
    assert Image.open(path).size[0] > 300


def test_no_body_is_drawn_in_the_clearance_joints_red():
    # the drawing marks clearance joints in red and says so in its title: a body in a red of
    # the palette (the four-bar's rocker was) reads as a clearance joint. Hue at least 20°
    # from tab:red's, or a grey (saturation below 0.2).
    import colorsys

    from matplotlib.colors import to_rgb

    red = colorsys.rgb_to_hsv(*to_rgb("tab:red"))[0] * 360.0
    for c in drawing._BODY_COLORS:
        h, s_, _ = colorsys.rgb_to_hsv(*to_rgb(c))
        gap = abs((h * 360.0 - red + 180.0) % 360.0 - 180.0)
        assert gap >= 20.0 or s_ < 0.2, c


def test_point_positions_agree_with_the_simulated_outputs():
    # the drawing's kinematics against the simulator's output points (slider-crank, ideal):
    # the same coordinates through two code paths, equal to round-off
    res = simulate(load_scene("slider-crank"))
    pos = drawing.point_positions(res.scene, res.q)
    assert np.max(np.abs(pos["slider.B"][:, 0] - res.outputs["slider"]["displacement"])) < 1e-14
    # the crank tip stays on its 0.05 m circle about the ground pivot
    assert np.allclose(np.hypot(*pos["crank.A"].T), 0.05, atol=1e-12)


def test_nine_bar_drawing_places_the_slider_pin_of_the_reconstruction():
    scene = load_scene("nine-bar")
    pos = drawing.point_positions(scene, drawing.assembled_configuration(scene))
    # docs/reference.md: S = (670.000, −575.769) mm at t = 0, printed to 1 µm
    assert pos["slider.S"] * 1e3 == pytest.approx([670.0, -575.769], abs=1e-3)


def test_draw_cli_writes_the_figure_and_rejects_an_unknown_type(tmp_path, capsys):
    out = tmp_path / "nine-bar.png"
    assert main(["draw", "nine-bar-lubricated", "--out", str(out)]) == 0
    assert Image.open(out).size == (840, 720)  # 7 x 6 in at 120 dpi
    assert main(["draw", "nine-bar", "--out", str(tmp_path / "x.jpg")]) == 2
    err = capsys.readouterr().err
    assert "--out = " in err
    assert "x.jpg': unknown file type '.jpg'; allowed: .png, .pdf, .svg" in err


def test_draw_cli_names_a_bad_scene_value(tmp_path, capsys):
    assert main(["draw", "nine-bar", "--set", "joints.C1.clearance=-1",
                 "--out", str(tmp_path / "x.png")]) == 2
    assert "joints.C1.clearance = -1" in capsys.readouterr().err
    assert not (tmp_path / "x.png").exists()


def _done(anim):
    """Close an animation inspected frame by frame (not saved: tell matplotlib it was drawn)."""
    anim._draw_was_started = True
    plt.close(anim._fig)


SHORT = ["--set", "analysis.cycles=0.25", "--no-progress"]


def test_animate_cli_gif_and_html(tmp_path):
    gif, html = tmp_path / "a.gif", tmp_path / "a.html"
    assert main(["animate", "slider-crank-lubricated", *SHORT, "--frames", "8",
                 "--out", str(gif)]) == 0
    with Image.open(gif) as im:
        assert im.n_frames == 8
    assert main(["animate", "slider-crank-lubricated", *SHORT, "--frames", "5", "--fps", "10",
                 "--quantity", "acceleration", "--out", str(html)]) == 0
    text = html.read_text(encoding="utf-8")
    assert "<script" in text and text.count("data:image/png;base64") == 5


def test_animation_content():
    res = simulate(load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.25}))
    anim = drawing.animate(res, frames=6, magnify=50.0)
    fig = anim._fig
    ax, ax2 = fig.axes
    # the traced curve is the slider's displacement error in mm over the crank angle
    grey = ax2.lines[0]
    assert np.allclose(grey.get_ydata(), res.error("slider", "displacement") * 1e3)
    # the clearance circle is drawn with radius magnify · c around the bearing point
    anim._func(5)
    i = np.unique(np.linspace(0, res.time.size - 1, 6).round().astype(int))[5]
    centre = drawing.point_positions(res.scene, res.q[i])["rod.B"] * 1e3
    circles = [ln for ln in ax.lines if len(ln.get_xdata()) == 100]
    assert len(circles) == 1
    r = np.hypot(circles[0].get_xdata() - centre[0], circles[0].get_ydata() - centre[1])
    assert np.allclose(r, 50.0 * 0.5e-3 * 1e3)
    labels = [t.get_text() for t in ax.get_legend().get_texts()]
    assert "journal orbits, clearance circle magnified ×50" in labels
    assert "ideal mechanism (ghost)" in labels
    _done(anim)


def test_animation_names_each_joints_magnification():
    # the four-bar's pins have clearances 0.1 mm (A) and 0.2 mm (B) drawn as circles of one
    # radius: the legend names each joint's factor (it read "×170/85", which joint which?)
    import re

    res = simulate(load_scene("four-bar", overrides={"analysis.cycles": 0.05}))
    anim = drawing.animate(res, frames=3)
    labels = [t.get_text() for t in anim._fig.axes[0].get_legend().get_texts()]
    found = [re.fullmatch(r"journal orbits, clearance circle magnified ×(\d+) \(A\), "
                          r"×(\d+) \(B\)", t) for t in labels]
    m = next(f for f in found if f is not None)
    a, b = int(m[1]), int(m[2])
    assert abs(a / b - 2.0) <= 1.0 / b  # c_B / c_A = 2, each factor rounded to an integer
    _done(anim)


def test_animate_errors(monkeypatch):
    res = simulate(load_scene("slider-crank"))
    with pytest.raises(MechrelError, match="output = 'rocker': not an output of scene "
                                           "'slider-crank'; allowed: slider"):
        drawing.animate(res, output="rocker")
    with pytest.raises(MechrelError, match=r"quantity = 'jerk': not a quantity of output "
                       r"'slider' \(kind 'point'\); allowed: displacement, velocity, "
                       r"acceleration"):
        drawing.animate(res, quantity="jerk")
    with pytest.raises(MechrelError, match="frames = 1: too few; allowed: an integer >= 2"):
        drawing.animate(res, frames=1)
    monkeypatch.setattr(matplotlib.animation.writers, "is_available", lambda name: False)
    with pytest.raises(MechrelError, match="writing MP4 needs ffmpeg, which is not installed; "
                                           "allowed: .gif or .html"):
        drawing.check_animation_path("anim.mp4")
    with pytest.raises(MechrelError, match="unknown file type '.avi'; allowed: .gif, .html, .mp4"):
        drawing.check_animation_path("anim.avi")


def test_an_ideal_scene_animates_its_outputs():
    # no clearance joint: no ghost, no orbit, the output itself is traced
    res = simulate(load_scene("slider-crank"))
    anim = drawing.animate(res, frames=3)
    ax, ax2 = anim._fig.axes
    assert ax.get_legend() is None
    assert ax2.get_ylabel() == "slider displacement (mm)"
    assert math.isclose(ax2.lines[0].get_ydata().max(), 170.0, abs_tol=1e-9)
    _done(anim)


@pytest.mark.parametrize("name", ["four-bar", "nine-bar", "slider-crank"])
def test_the_configuration_at_t_is_the_one_the_motion_reaches(name):
    # drawn at t, a mechanism is where its drivers have taken it from t = 0 (a crank one turn
    # later is back where it started; assembled at t straight from the scene's guesses, the
    # four-bar and the nine-bar failed there); checked against the kinematic analysis at t
    from mechrel.mechanics.kinematics import kinematic_analysis
    from mechrel.mechanics.system import compile_scene

    scene = load_scene(name)
    c = compile_scene(scene)
    q0 = drawing.assembled_configuration(scene)
    k = c.cycle_driver
    period = c.period
    for t in (0.37 * period, period, 2.5 * period):
        q = drawing.assembled_configuration(scene, t)
        Q, _, _, _ = kinematic_analysis(c.ideal, q0, np.array([0.0, t]))
        # both solve the same constraints to |Φ| <= 1e-12 m from nearby starts: the same
        # configuration to round-off times the Jacobian's conditioning (1e-9 m is generous)
        np.testing.assert_allclose(q, Q[1], rtol=0, atol=1e-9, err_msg=f"{name} t={t}")
    assert k >= 0
    back = drawing.point_positions(scene, drawing.assembled_configuration(scene, period))
    start = drawing.point_positions(scene, q0)
    for point, xy in start.items():
        np.testing.assert_allclose(back[point], xy, rtol=0, atol=1e-9, err_msg=point)


def test_a_time_too_far_to_follow_is_refused_with_the_limit():
    scene = load_scene("four-bar")
    with pytest.raises(AssemblyError, match=r"^t = 1e\+06 s: the drivers turn by 5\.24e\+07 rad "
                       r"from t = 0, 6e\+08 steps of 5 degrees to follow, more than 100000; "
                       r"allowed: \|t\| up to about 167 s$"):
        drawing.assembled_configuration(scene, 1e6)


def test_a_magnification_wider_than_the_mechanism_is_refused(tmp_path, capsys):
    # --magnify 1e300 drew a clearance circle of 5e296 m: matplotlib's layout collapsed with a
    # UserWarning naming its source; the limit is the mechanism's size over the clearance
    res = simulate(load_scene("slider-crank-lubricated", overrides={"analysis.cycles": 0.25}))
    extent = drawing._extent(drawing.point_positions(res.scene, res.q))
    limit = extent / 0.5e-3
    with pytest.raises(MechrelError, match=rf"^animate: magnify = 1e\+300: the clearance circle "
                       rf"of radius 0\.0005 m would be drawn with a radius of 5e\+296 m, more "
                       rf"than the mechanism's size \({extent:.3g} m\), and the drawing "
                       rf"collapses; allowed: magnify <= {limit:.4g} for this scene$"):
        drawing.animate(res, frames=2, magnify=1e300)
    _done(drawing.animate(res, frames=2, magnify=limit))  # at the limit: drawn
    assert main(["animate", "slider-crank-lubricated", *SHORT, "--frames", "2", "--magnify",
                 "1e300", "--out", str(tmp_path / "never.gif")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and err.startswith("mechrel: error: animate: magnify = ")
