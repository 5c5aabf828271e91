"""Sliding joints (``bodies.NAME.guide``) and the joint probes ``torque``/``force`` with
``summary.json`` ``joint_peaks`` (SCENE.md, "Added with the issues of 2026-11-26"; issue 32).

Every check has an exact reference: a bead on a frictionless rod turning at Ω (r₀ cosh Ωt), a spring
mass on an oblique guide (period 2π√(m/k), the start rate from ``initial_velocity``), two bodies on a
guide between them (the reduced mass), the rigid slider-crank's exact kinematics, a slide driven onto
a stop and onto a latch (time of arrival, the reaction that holds it), the drive torque of a pendulum
with a prescribed angle, and the tangent of a guide's kinematics against central differences."""
from __future__ import annotations

import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from latdyn.errors import SceneError
from test_rigid import finite_difference


def run_text(tmp_path, text: str):
    """A scene typed as YAML, through the API (``latdyn.load_scene`` of the file, ``latdyn.run``)."""
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return latdyn.run(latdyn.load_scene(str(path)))


BEAD = """
title: bead on a frictionless rod turning at a constant rate
bodies:
  rod:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [1, 1, 1], angle: "2*t"}
  bead:
    at: [0.1, -0.1, 0]
    mass: 0.5
    guide: {on: rod, axis: [1, -1, 0]}
solve: {t_end: 0.8, dt: 0.004, tol: 1e-12}
output:
  every: 0.04
  probes:
    s: {guide: bead, quantity: position}
    rate: {guide: bead, quantity: rate}
    r: {point: bead, quantity: position, component: norm}
    along: {point: bead, quantity: position, frame: rod, component: x}
"""


def test_bead_on_a_turning_rod_follows_cosh(tmp_path):
    """3D: the rod (the axis [1, −1, 0] through the centre, normal to the spin axis [1, 1, 1]) turns
    at Ω = 2; the bead, at rest on it, slides out as r = r₀ cosh Ωt (the centrifugal term of a
    slide on a turning body), its rate r₀Ω sinh Ωt, and stays on the rod."""
    result = run_text(tmp_path, BEAD)
    t, omega, r0 = result.t, 2.0, 0.1 * np.sqrt(2)
    exact = r0 * np.cosh(omega * t)
    assert np.abs(result.probes["r"] - exact).max() < 1.5e-5 * exact.max()  # measured 8.3e-6 (dt = 0.004)
    assert np.abs(result.probes["s"] - (exact - r0)).max() < 1.5e-5 * exact.max()
    rate = r0 * omega * np.sinh(omega * t)
    assert np.abs(result.probes["rate"] - rate).max() < 1e-5 * rate.max()
    # in the rod's axes the bead stays on the rod's x = −y line: its x is r/√2
    np.testing.assert_allclose(result.probes["along"], result.probes["r"] / np.sqrt(2), atol=1e-12)


def test_bead_on_a_rod_turning_in_its_plane_through_the_cli(tmp_path):
    """Planar: the rod along [1, −1, 0] turning about z at Ω = 2, the scene typed as YAML and run by
    ``latdyn run``: r = r₀ cosh Ωt (measured 8.3e-6 of r at dt = 0.004, as in 3D), on the rod."""
    completed, out = latdyn_run(tmp_path, BEAD.replace("axis: [1, 1, 1]", "axis: [0, 0, 1]"), quiet=True)
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    omega, r0 = 2.0, 0.1 * np.sqrt(2)
    exact = r0 * np.cosh(omega * p["t"])
    assert np.abs(p["r"] - exact).max() < 1.5e-5 * exact.max()
    rate = r0 * omega * np.sinh(omega * p["t"])
    assert np.abs(p["rate"] - rate).max() < 1e-5 * rate.max()
    np.testing.assert_allclose(p["along"], p["r"] / np.sqrt(2), atol=1e-12)


SPRING = """
title: spring mass on an oblique guide, started by the scene's rigid motion
initial_velocity: {linear: [0.3, -0.1, 0.5]}
bodies:
  slider:
    at: [0.2, 0.1, 0.3]
    mass: 2.0
    guide: {axis: [1, 2, 2], stiffness: 50.0}
solve: {t_end: 1.5, dt: 0.005, tol: 1e-12}
output:
  every: 0.01
  probes:
    s: {guide: slider, quantity: position}
    f: {guide: slider, quantity: force}
    y: {point: slider, quantity: displacement, component: y}
"""


def test_spring_mass_on_an_oblique_guide(tmp_path):
    """s = (v₀/ω) sin ωt with ω = √(k/m) and v₀ = g·v (the component of the initial velocity along
    the axis); the guide applies −k s; the body moves along the axis only."""
    result = run_text(tmp_path, SPRING)
    t, s = result.t, result.probes["s"]
    g = np.array([1, 2, 2]) / 3.0
    v0, omega = g @ [0.3, -0.1, 0.5], np.sqrt(50.0 / 2.0)
    exact = v0 / omega * np.sin(omega * t)
    # the period error of generalized-α, O((ωh)²): measured 3.5e-4 of the amplitude over 1.5 s
    assert np.abs(s - exact).max() < 7e-4 * abs(v0 / omega)
    np.testing.assert_allclose(result.probes["f"], -50.0 * s, atol=1e-12)
    np.testing.assert_allclose(result.probes["y"], g[1] * s, atol=1e-12)


def test_guide_on_a_free_body_oscillates_with_the_reduced_mass(tmp_path):
    """3D, ``on`` a free body: B slides on A along an oblique axis through A's centre of mass, a
    spring with rest 0.1 between them; s = 0.1 (1 − cos ωt), ω = √(k/μ), μ = m_A m_B/(m_A + m_B)."""
    text = """
bodies:
  A: {at: [0, 0, 0], mass: 3.0, inertia: [0.1, 0.2, 0.3]}
  B:
    at: [0.2, 0.4, 0.4]
    mass: 1.0
    guide: {on: A, axis: [1, 2, 2], stiffness: 50.0, rest: 0.1}
solve: {t_end: 0.6, dt: 0.0025, tol: 1e-12, rho_inf: 1.0}
output:
  every: 0.01
  probes:
    s: {guide: B, quantity: position}
    f: {guide: B, quantity: force}
    px: {momentum: linear, component: x}
"""
    result = run_text(tmp_path, text)
    mu = 3.0 * 1.0 / 4.0
    omega = np.sqrt(50.0 / mu)
    exact = 0.1 * (1.0 - np.cos(omega * result.t))
    assert np.abs(result.probes["s"] - exact).max() < 2e-4 * 0.2  # measured 8.4e-5 of the swing (dt = 0.0025)
    np.testing.assert_allclose(result.probes["f"], -50.0 * (result.probes["s"] - 0.1), atol=1e-12)
    assert np.abs(result.probes["px"]).max() < 1e-10  # nothing outside acts: the momentum stays zero


SLIDER_CRANK = """
title: slider-crank, crank turning at 10 rad/s
sections:
  rod: {EA: 1.0e10, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 0.0}
bodies:
  crank:
    at: [0, 0, 0]
    motion:
      rotation: {axis: [0, 0, 1], angle: "10*t"}
  slider:
    at: [0.4, 0, 0]
    mass: 0.5
    guide: {axis: [1, 0, 0]}
beams:
  rod:
    from: {body: crank, offset: [0.1, 0, 0]}
    to: slider
    section: rod
    start: {hinge: {axis: [0, 0, 1]}}
    end: {hinge: {axis: [0, 0, 1]}}
solve: {t_end: 0.3, dt: 0.01, tol: 1e-12}
output:
  every: 0.01
  probes:
    s: {guide: slider, quantity: position}
    x: {point: slider, quantity: position, component: x}
"""


def test_rigid_slider_crank_follows_the_exact_kinematics(tmp_path):
    """Through the CLI: crank R = 0.1 turned at 10 rad/s, connecting rod L = 0.3 (EA = 1e10: its
    stretch under the slider's inertia force is 1e-12 of its length), slider on a ground guide:
    x = R cos θ + √(L² − R² sin² θ) to 1e-8."""
    completed, out = latdyn_run(tmp_path, SLIDER_CRANK)
    assert completed.returncode == 0, completed.stderr
    columns = probe_columns(out)
    theta = 10.0 * columns["t"]
    exact = 0.1 * np.cos(theta) + np.sqrt(0.09 - (0.1 * np.sin(theta)) ** 2)
    assert np.abs(columns["x"] - exact).max() < 1e-8  # measured 2.0e-10
    assert np.abs(columns["s"] + 0.4 - exact).max() < 1e-8


def test_slide_onto_a_stop_and_onto_a_latch(tmp_path):
    """A constant force F = 4 along the guide drives m = 2 from rest: s = F t²/(2m) until the
    stop at 0.5 (restitution 0: it rests there) or the latch at 0.3; then the stop or the latch
    holds it with the reaction −F, and the joint's peak is the drive, +F at t = 0."""
    for extra, end in (("limits: [-1, 0.5]", 0.5), ("lock_at: 0.3", 0.3)):
        text = f"""
bodies:
  carriage:
    at: [0, 0, 0]
    mass: 2.0
    guide: {{axis: [0, 1, 0], force: 4.0, {extra}}}
solve: {{t_end: 1.0, dt: 0.01}}
output:
  probes:
    s: {{guide: carriage, quantity: position}}
    rate: {{guide: carriage, quantity: rate}}
    f: {{guide: carriage, quantity: force}}
"""
        result = run_text(tmp_path, text)
        t, s, f = result.t, result.probes["s"], result.probes["f"]
        arrival = np.sqrt(2.0 * end * 2.0 / 4.0)
        before = t < arrival - 0.005  # the step that lands on the stop ends within its tolerance
        np.testing.assert_allclose(s[before], t[before] ** 2, atol=1e-10)  # F/(2m) = 1
        np.testing.assert_allclose(f[before], 4.0)
        after = t > arrival + 0.02
        assert np.abs(s[after] - end).max() < 1e-6  # the latch lands within its tolerance, 1e-7
        np.testing.assert_allclose(result.probes["rate"][after], 0.0, atol=1e-9)
        np.testing.assert_allclose(f[after], -4.0, atol=1e-9)
        assert result.summary["joint_peaks"] == {"carriage": {"peak": 4.0, "t": 0.0}}


PENDULUM = """
title: a pendulum driven through a prescribed angle, with a spring in parallel
gravity: [0, -9.81, 0]
sections:
  rod: {EA: 1.0e9, EIy: 1.0e6, EIz: 1.0e6, GJ: 1.0e6, rhoA: 2.0}
bodies:
  pivot: {at: [0, 0, 0], fixed: true}
  bob: {at: [0, -1.5, 0], mass: 0.7}
beams:
  arm:
    from: pivot
    to: bob
    section: rod
    rigid: true
    start: {hinge: {axis: [0, 0, 1], angle: "0.8*sin(3*t)", stiffness: 2.0}}
solve: {t_end: 0.6, dt: 0.02}
output:
  every: 0.04
  probes:
    tau: {hinge: arm.start, quantity: torque}
"""


def test_drive_torque_of_a_prescribed_pendulum(tmp_path):
    """Through the CLI: the torque the hinge applies to hold θ = 0.8 sin 3t is the required drive,
    τ = I θ̈ + m_g g sin θ + k θ (I about the pivot: bob and rod; m_g the first moment), exact
    at every row; ``joint_peaks`` holds its largest magnitude on the rows and the time."""
    completed, out = latdyn_run(tmp_path, PENDULUM)
    assert completed.returncode == 0, completed.stderr
    columns = probe_columns(out)
    t = columns["t"]
    theta = 0.8 * np.sin(3.0 * t)
    inertia = 0.7 * 1.5 ** 2 + 2.0 * 1.5 ** 3 / 3.0
    first_moment = 0.7 * 1.5 + 2.0 * 1.5 ** 2 / 2.0
    exact = inertia * (-9.0 * theta) + first_moment * 9.81 * np.sin(theta) + 2.0 * theta
    assert np.abs(columns["tau"] - exact).max() < 1e-12 * np.abs(exact).max()  # measured 2.9e-15
    peak = summary_of(out)["joint_peaks"]["arm.start"]
    k = int(np.argmax(np.abs(exact)))
    assert peak["t"] == pytest.approx(t[k]) and peak["peak"] == pytest.approx(exact[k], rel=1e-12)


def test_guide_force_of_a_prescribed_slide_under_gravity(tmp_path):
    """A vertical guide with s = 0.2 sin 5t prescribed lifts m = 1.5 against gravity: the force it
    applies is m (s̈ + g)."""
    text = """
gravity: [0, 0, -9.81]
bodies:
  lift:
    at: [1, 2, 3]
    mass: 1.5
    guide: {axis: [0, 0, 1], position: "0.2*sin(5*t)"}
solve: {t_end: 0.5, dt: 0.01}
output:
  every: 0.05
  probes:
    f: {guide: lift, quantity: force}
    z: {point: lift, quantity: position, component: z}
"""
    result = run_text(tmp_path, text)
    t = result.t
    np.testing.assert_allclose(result.probes["f"], 1.5 * (-5.0 * np.sin(5.0 * t) + 9.81), rtol=1e-12)
    np.testing.assert_allclose(result.probes["z"], 3.0 + 0.2 * np.sin(5.0 * t), atol=1e-14)


def test_tangent_of_a_guide_by_finite_differences():
    """K = ∂r/∂q (static, with the slide's geometric term (g × f)·δω of the parent), C = ∂r/∂v
    (Coriolis of the slide on a turning body) and M = ∂r/∂v̇ against central differences, at a
    random large-rotation configuration: a free body carrying a guided body that carries a rigid
    link, with loads, gravity and a spring on the slide."""
    scene = {
        "gravity": [0.3, -1.0, -9.81],
        "sections": {"s": {"EA": 1e6, "EIy": 1e3, "EIz": 1e3, "GJ": 1e3, "rhoA": 1.5, "rhoIy": 0.01,
                           "rhoIz": 0.02}},
        "bodies": {"A": {"at": [0, 0, 0], "mass": 3, "inertia": [0.2, 0.3, 0.4], "com": [0.1, 0, 0.05]},
                   "B": {"at": [0.4, 0.2, 0.1], "mass": 0.7, "inertia": [0.01, 0.02, 0.03], "com": [0, 0.1, 0],
                         "guide": {"on": "A", "axis": [1, 0.5, -0.3], "stiffness": 7.0, "damping": 0.3}}},
        "beams": {"l": {"from": "B", "to": [1.0, 0.8, 0.2], "section": "s", "rigid": True,
                        "start": {"hinge": {"axis": [0, 1, 1]}}}},
        "loads": [{"at": "B", "force": [1, 2, 3], "moment": [0.3, -0.2, 0.1]}, {"at": "l.end", "force": [0, -4, 1]}],
        "solve": {"analysis": "static"},
    }
    rng = np.random.default_rng(3)
    prepared = prepare(scene)
    model, assembler = prepared.model, prepared.assembler
    n = model.n_dofs
    assert n == 6 + 2  # A, the slide and the link's hinge
    state = assembler.advance(prepared.state, rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    static = assembler.evaluate(state, matrices=True, inertia=False)
    K = static.combined(0.0, 0.0, 1.0, dense=True)
    K_fd = finite_difference(prepared, state, "q", inertia=False)
    assert np.abs(K - K_fd).max() < 1e-7 * np.abs(K_fd).max()
    dynamic = assembler.evaluate(state, matrices=True)
    for (cm, cc), what in (((0.0, 1.0), "v"), ((1.0, 0.0), "a")):
        exact = dynamic.combined(cm, cc, 0.0, dense=True)
        fd = finite_difference(prepared, state, what)
        assert np.abs(exact - fd).max() < 1e-7 * np.abs(fd).max()


@pytest.mark.parametrize("body, key, expected", [
    ("{at: [0, 0, 0], mass: 1, fixed: true, guide: {axis: [1, 0, 0]}}", "bodies.b.guide", "no fixed or motion"),
    ("{at: [0, 0, 0], mass: 1, guide: {axis: [1, 0, 0], stiffness: 'theta*2'}}", "bodies.b.guide.stiffness",
     "s, s_dot and t"),
    ("{at: [0, 0, 0], mass: 1, guide: {on: nowhere, axis: [1, 0, 0]}}", "bodies.b.guide.on", "body"),
    ("{at: [0, 0, 0], mass: 1, guide: {axis: [0, 0, 0]}}", "bodies.b.guide.axis", ""),
    ("{at: [0, 0, 0], mass: 1, guide: {axis: [1, 0, 0], limits: [0.1, 0.5]}}", "bodies.b.guide.limits", "lo <= 0"),
    ("{at: [0, 0, 0], mass: 1, guide: {axis: [1, 0, 0], slide: 1}}", "bodies.b.guide", "slide"),
])
def test_bad_guides_are_refused_with_the_key(tmp_path, body, key, expected):
    path = tmp_path / "bad.yaml"
    path.write_text(f"bodies:\n  b: {body}\nsolve: {{t_end: 0.1, dt: 0.01}}\n")
    with pytest.raises(SceneError) as caught:
        latdyn.load_scene(str(path))
    assert caught.value.key.startswith(key) and expected in str(caught.value)


def test_guides_in_a_loop_and_probes_of_no_guide_are_refused(tmp_path):
    """Through the CLI: exit status 2 and the key path, no traceback."""
    loop = """
bodies:
  a: {at: [0, 0, 0], mass: 1, guide: {on: b, axis: [1, 0, 0]}}
  b: {at: [1, 0, 0], mass: 1, guide: {on: a, axis: [0, 1, 0]}}
solve: {t_end: 0.1, dt: 0.01}
"""
    completed, _ = latdyn_run(tmp_path, loop)
    assert completed.returncode == 2 and "bodies.a.guide.on" in completed.stderr and "loop" in completed.stderr
    assert "Traceback" not in completed.stderr
    path = tmp_path / "probe.yaml"
    path.write_text("bodies:\n  a: {at: [0, 0, 0], mass: 1}\nsolve: {t_end: 0.1, dt: 0.01}\n"
                    "output: {probes: {f: {guide: a, quantity: force}}}\n")
    with pytest.raises(SceneError) as caught:
        latdyn.load_scene(str(path))
    assert caught.value.key == "output.probes.f.guide"


def test_interrupted_guide_run_resumes_bit_for_bit_and_draws_the_slider(tmp_path, monkeypatch):
    """The slider-crank with a damped guide, interrupted at t = 0.1 (before the guide's peak force) and
    resumed: the files, summary.json's joint_peaks included, equal the uninterrupted run's; the
    ParaView bodies (and the structure picture drawn from them) carry the guided slider."""
    from latdyn.results.structure import load_structure
    from test_checkpoint import assert_same_files, interrupt_at

    scene = latdyn.load_scene(str(_written(tmp_path, SLIDER_CRANK.replace(
        "guide: {axis: [1, 0, 0]}", "guide: {axis: [1, 0, 0], damping: 0.5}"))))
    full, out = tmp_path / "full", tmp_path / "out"
    reference = latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.1)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert_same_files(full, out)
    t = reference.t  # the guide applies −c ṡ, ṡ of the exact kinematics: its largest on the rows
    theta = 10.0 * t
    rate = -10.0 * 0.1 * np.sin(theta) * (1.0 + 0.1 * np.cos(theta) / np.sqrt(0.09 - (0.1 * np.sin(theta)) ** 2))
    k = int(np.argmax(np.abs(rate)))
    peak = reference.summary["joint_peaks"]["slider"]
    assert peak["t"] == pytest.approx(t[k]) and peak["t"] > 0.1
    assert peak["peak"] == pytest.approx(-0.5 * rate[k], rel=5e-5)  # measured 1.9e-5: the step's rate, dt = 0.01
    history = load_structure(full)
    slider = history.body_points[:, history.bodies[~history.body_fixed]]
    theta = 10.0 * history.times
    exact = 0.1 * np.cos(theta) + np.sqrt(0.09 - (0.1 * np.sin(theta)) ** 2)
    assert np.abs(slider[:, :, 0] - exact[:, None]).min(axis=1).max() < 1e-8


def _written(tmp_path, text: str):
    path = tmp_path / "scene.yaml"
    path.write_text(text)
    return path


def test_static_sag_and_frequency_of_a_guided_spring_mass(tmp_path):
    """Static: s = m g·a/k on a tilted guide, the guide holding the weight's component, k s; modes: the
    frequency √(k/m)/2π."""
    text = """
gravity: [0, 0, -9.81]
bodies:
  m: {at: [0, 0, 0], mass: 2.0, guide: {axis: [0, 0.6, 0.8], stiffness: 50.0}}
solve: {analysis: static, steps: 2}
output: {probes: {s: {guide: m, quantity: position}, f: {guide: m, quantity: force}}}
"""
    result = run_text(tmp_path, text)
    sag = -2.0 * 9.81 * 0.8 / 50.0
    assert result.probes["s"][-1] == pytest.approx(sag, rel=1e-12)
    assert result.probes["f"][-1] == pytest.approx(-50.0 * sag, rel=1e-12)
    out = tmp_path / "modes"
    latdyn.run(latdyn.load_scene(str(_written(tmp_path, text.replace("{analysis: static, steps: 2}",
                                                                     "{analysis: modes, count: 1}")))), out)
    frequency = float((out / "modes.csv").read_text().splitlines()[1].split(",")[1])
    assert frequency == pytest.approx(5.0 / (2.0 * np.pi), rel=1e-12)


def test_the_key_on_read_as_a_boolean_is_refused_with_a_hint(tmp_path):
    """A mapping from ``yaml.safe_load`` (YAML 1.1) holds the key ``on`` as True: refused with the key
    and the fix, not a message about True; latdyn's own reader of the same text reads the word."""
    import yaml

    with pytest.raises(SceneError) as caught:
        latdyn.load_scene(yaml.safe_load(BEAD))
    assert caught.value.key == "bodies.bead.guide.on" and "quote it" in str(caught.value)
    assert latdyn.load_scene(str(_written(tmp_path, BEAD))).bodies["bead"].guide.on == "rod"


def test_torque_of_a_held_hinge_of_a_flexible_cantilever(tmp_path):
    """Static: a flexible beam whose root hinge is held at angle 0 carries a tip force P along y; the
    hinge applies −P x_tip (x_tip the deformed tip's lever arm), the moment that holds the beam."""
    text = """
sections:
  s: {EA: 1.0e7, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.0}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  arm:
    from: root
    to: [2, 0, 0]
    section: s
    elements: 4
    start: {hinge: {axis: [0, 0, 1], angle: 0}}
loads:
  - {at: arm.end, force: [0, 3, 0]}
solve: {analysis: static, steps: 1}
output:
  probes:
    tau: {hinge: arm.start, quantity: torque}
    x: {point: arm.end, quantity: position, component: x}
"""
    result = run_text(tmp_path, text)
    assert result.probes["x"][-1] < 2.0 - 1e-6  # deformed: the lever arm is the current one
    assert result.probes["tau"][-1] == pytest.approx(-3.0 * result.probes["x"][-1], rel=1e-10)
