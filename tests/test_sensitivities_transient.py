"""Exact sensitivities of transient runs (latdyn/analyses/transient_sensitivities.py): direct
differentiation of the discrete generalized-α step.

Reference: central differences of whole runs (without solve.sensitivities) at p ± h and p ± h/2,
Richardson-extrapolated ((4 D(h/2) − D(h))/3), the perturbation varied, the time step fixed. Checked
on a genuinely 3D structure (two beams at an angle, a hinge whose axis lies in no coordinate plane,
a joint body with a centre of mass off its node, a load turning with it, gravity, a spin at t = 0)
with rotary inertia, and without it (directions without inertia: the twist) from rest; on a planar
one for generalized-α, HHT and Newmark; objectivity; the CLI's files and summary; checkpoint and
resume; the refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests.cli_runs import latdyn_run, latdyn_run_switched
from tests.resumed_runs import interrupted_and_whole

SWING_3D = """
title: 3D arm with a hinged second beam and a joint body, spinning at t = 0 under gravity
gravity: [0, 0, -9.81]
parameters: {F: 2.0, k: 30.0, c: 0.2, th0: 0.1, EI: 20.0, G: 15.0, rho: 0.5, m: 0.8, cx: 0.05, J: 0.01}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.5*EI", GJ: "G", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: "m", com: ["cx", 0, "-cx"], inertia: ["J", "J", "2*J"]}
beams:
  a: {from: base, to: knee, section: s, elements: 2, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k*(1 + (theta - th0)**2)", damping: "c", rest_angle: "th0"}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}
initial_velocity: {angular: [0, 0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.04, sensitivities: [F, k, c, th0, EI, G, rho, m, cx, J]}
output:
  every: 0.01
  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_y: {point: b.end, quantity: position, component: y}
    tip_z: {point: b.end, quantity: position, component: z}
    tip_d: {point: b.end, quantity: displacement, component: norm}
    hinge: {hinge: b.start, quantity: angle}
"""

#: SWING_3D without rotary inertia on the beams (their twist has no inertia), from rest in
#: equilibrium: no gravity, no spin, the loads growing from zero, the rest angle zero
FROM_REST_3D = (SWING_3D.replace(', rhoIy: "0.01*rho", rhoIz: "0.02*rho"', "")
                .replace("gravity: [0, 0, -9.81]\n", "").replace("initial_velocity: {angular: [0, 0, 2.0]}\n", "")
                .replace('["0.3*F", "-F", "0.5*F"]', '["0.3*F*t", "-F*t", "0.5*F*t"]')
                .replace("th0: 0.1", "th0: 0.0").replace("t_end: 0.04", "t_end: 0.06"))

PLANAR = """
title: planar hinged arm with a tip body, pushed from rest
parameters: {P: 3.0, k: 8.0, c: 0.3, tau: 0.4, Mz: 0.5, EI: 5.0, rho: 0.5, m: 0.4, J: 0.02}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "EI", GJ: 4.0, rhoA: "rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.2, 0], mass: "m", inertia: ["J", "J", "J"]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "k + 0.5*k*theta**2", damping: "c", torque: "tau*sin(20*t)"}}
loads:
  - {at: tip, force: ["0.2*P*t", "-P*t", 0], moment: [0, 0, "-Mz*t"]}
solve: {analysis: transient, dt: 0.01, t_end: 0.2, sensitivities: [P, k, c, tau, Mz, EI, rho, m, J]}
output:
  every: 0.05
  probes:
    tip_y: {point: tip, quantity: displacement, component: y}
    tip_x: {point: tip, quantity: position, component: x}
    hinge: {hinge: arm.start, quantity: angle}
"""


def _run(text: str, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    return latdyn.run(latdyn.load_scene(data))


def _richardson(text: str, name: str) -> dict:
    """d(probe)/d(name) over the rows by Richardson-extrapolated central differences of whole runs."""
    data = yaml.safe_load(text)
    del data["solve"]["sensitivities"]
    plain = yaml.safe_dump(data)
    p0 = data["parameters"][name]
    h = 1e-2 * abs(p0)   # large enough that round-off (1e-16 of the probes) stays below 1e-7 of their derivatives
    central = []
    for step in (h, h / 2):
        up, down = _run(plain, **{name: p0 + step}), _run(plain, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


def _agree(result, text: str, name: str, tolerance: float) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` against the extrapolated differences,
    relative to each probe's largest sensitivity; asserted ≤ ``tolerance``."""
    worst = 0.0
    for probe, expected in _richardson(text, name).items():
        scale = np.abs(expected).max()
        assert scale > 1e-9, (probe, name)
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / scale
        assert error <= tolerance, (probe, name, error)
        worst = max(worst, error)
    return worst


@pytest.fixture(scope="module")
def swing_3d():
    return _run(SWING_3D)


#: one parameter of each kind whose perturbation needs no new compiled laws (sections, bodies), and
#: the hinge laws (stiffness law, rest angle); loads and damping are checked on the planar arm
@pytest.mark.parametrize("name", ["k", "th0", "EI", "G", "rho", "m", "cx", "J"])
def test_3d_transient_sensitivities_agree_with_richardson_central_differences(swing_3d, name):
    """A spinning 3D arm under gravity with rotary inertia (measured 3e-10 … 1e-8 of each probe's
    largest sensitivity on 2 loaded cores)."""
    assert len(swing_3d.t) == 5
    _agree(swing_3d, SWING_3D, name, 1e-6)
    assert all(swing_3d.sensitivities[(probe, name)][0] == 0.0 for probe in swing_3d.probes)   # δq_0 = 0


def test_3d_transient_sensitivities_by_the_initial_velocity_agree():
    """The rigid motion at t = 0 (its linear and angular velocity, ``about`` fixed) moves the start's
    velocities and through them the consistent accelerations (measured 8e-10)."""
    text = (SWING_3D.replace("parameters: {", "parameters: {W: 2.0, ")
            .replace("initial_velocity: {angular: [0, 0, 2.0]}",
                     'initial_velocity: {angular: [0, "0.3*W", "W"], linear: ["0.1*W", 0, 0]}')
            .replace("sensitivities: [F, k, c, th0, EI, G, rho, m, cx, J]", "sensitivities: [W]"))
    _agree(_run(text), text, "W", 1e-6)


@pytest.mark.parametrize("name", ["F", "EI", "rho", "J"])
def test_3d_transient_sensitivities_without_rotary_inertia_from_rest_agree(name):
    """The beams' twist without inertia (the start's split into directions with and without inertia,
    differentiated at rest in equilibrium): measured ≤ 5e-8."""
    _agree(_run(FROM_REST_3D), FROM_REST_3D, name, 1e-6)


@pytest.mark.parametrize("method, newton", [("generalized-alpha", "full"), ("hht-alpha", "full"),
                                            ("newmark", "modified")])
def test_planar_transient_sensitivities_agree_for_each_implicit_method(method, newton, monkeypatch):
    """Load force and moment, hinge damping and torque, the section's mass (measured ≤ 2e-8); modified
    Newton holds older factorizations, which the sensitivities do not use. The per-step Python path (the switch
    off), and the loop of steps (its hinge law in θ compiled: latdyn/analyses/derivative_laws.py) to its bits."""
    text = PLANAR.replace("analysis: transient,", f"analysis: transient, method: {method}, newton: {newton},")
    in_loop = _run(text)
    monkeypatch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", False)
    result = _run(text)
    assert result.summary["time_loop"] == "python"
    assert in_loop.summary["time_loop"] == "compiled" and in_loop.summary["sensitivity_steps_in_loop"] > 0
    for key, values in result.sensitivities.items():
        np.testing.assert_array_equal(in_loop.sensitivities[key], values, err_msg=str(key))
    for name in ("P", "Mz", "c", "tau", "rho") if method == "generalized-alpha" else ("rho", "m"):
        _agree(result, text, name, 1e-6)


def _turned(text: str, rotation: np.ndarray) -> str:
    """SWING_3D moved rigidly by ``rotation`` about the origin: points, the hinge axis, the sections'
    axes, the centre of mass and inertia of the body, the global load, gravity and the spin."""
    data = yaml.safe_load(text)
    turn = lambda v: [float(c) for c in rotation @ np.asarray(v, float)]  # noqa: E731
    data["bodies"]["knee"]["at"] = turn(data["bodies"]["knee"]["at"])
    data["beams"]["b"]["to"] = turn(data["beams"]["b"]["to"])
    data["beams"]["b"]["start"]["hinge"]["axis"] = turn(data["beams"]["b"]["start"]["hinge"]["axis"])
    for beam in data["beams"].values():
        beam["y_axis"] = turn(beam["y_axis"])
    data["gravity"] = turn(data["gravity"])
    data["initial_velocity"]["angular"] = turn(data["initial_velocity"]["angular"])
    knee = data["bodies"]["knee"]
    knee["com"] = ["+".join(f"({float(rotation[i, j])!r})*({c})" for j, c in enumerate(knee["com"]))
                   for i in range(3)]
    knee["inertia"] = [["+".join(f"({float(rotation[i, a] * rotation[j, a])!r})*({d})"
                             for a, d in enumerate(knee["inertia"])) for j in range(3)] for i in range(3)]
    load = data["loads"][0]
    load["force"] = ["+".join(f"({float(rotation[i, j])!r})*({c})" for j, c in enumerate(load["force"]))
                     for i in range(3)]
    data["loads"] = [load]
    data["output"]["probes"] = {k: v for k, v in data["output"]["probes"].items() if k != "tip_d"}
    data["solve"]["sensitivities"] = ["k", "EI", "rho", "m", "cx", "J"]
    return yaml.safe_dump(data)


def test_sensitivities_of_a_rigidly_turned_scene_are_the_turned_sensitivities():
    """A point's sensitivities turn with the scene, a hinge angle's stay (the knee's turning load left
    out: a body's axes are the global ones at t = 0, so it would not turn with the scene)."""
    angle, axis = 0.7, np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew
    base, turned = _run(_turned(SWING_3D, np.eye(3))), _run(_turned(SWING_3D, rotation))
    for name in ("k", "EI", "rho", "m", "cx", "J"):
        s = lambda r, p: r.sensitivities[(p, name)]  # noqa: E731
        moved = rotation @ np.array([s(base, "tip_x"), s(base, "tip_y"), s(base, "tip_z")])
        got = np.array([s(turned, "tip_x"), s(turned, "tip_y"), s(turned, "tip_z")])
        scale = np.abs(moved).max()
        assert scale > 1e-6
        assert np.abs(got - moved).max() <= 1e-8 * scale, name
        assert np.abs(s(turned, "hinge") - s(base, "hinge")).max() <= 1e-8 * np.abs(s(base, "hinge")).max(), name


def test_the_joint_body_is_linear_in_mass_and_inertia_and_quadratic_in_the_centre_of_mass():
    """What the body sensitivities rest on (latdyn.analyses.sensitivities._body_forces): joint_body's
    force is additive in (m, I) at a fixed centre of mass (the kernel with ∂m/∂p, ∂I/∂p is its derivative),
    and its third differences in c vanish (of degree two in c, whose derivative the generated
    joint_body_D_com gives: tests/test_joints.py)."""
    from latdyn.model.kernels import load_kernels
    from latdyn.numerics.so3 import expm_so3

    kernels = load_kernels("c", "default")
    rng = np.random.default_rng(34)
    frame = expm_so3(rng.normal(size=3)).reshape(1, 9)
    motion, gravity = rng.normal(size=(1, 9)), np.array([[0.3, -9.81, 1.2]])

    def force(block):
        return np.asarray(kernels.joint_body(frame, motion, block[None], gravity)[0]).reshape(6)

    inertia = rng.normal(size=(3, 3))
    body = np.concatenate([[0.7], rng.normal(size=3), (inertia @ inertia.T).reshape(9)])
    mass_only, inertia_only = body.copy(), body.copy()
    mass_only[4:] = 0.0
    inertia_only[0] = 0.0
    assert np.abs(force(mass_only) + force(inertia_only) - force(body)).max() <= 1e-13 * np.abs(force(body)).max()
    along = np.zeros(13)
    along[1:4] = rng.normal(size=3)
    third = force(body + 3 * along) - 3 * force(body + 2 * along) + 3 * force(body + along) - force(body)
    assert np.abs(third).max() <= 1e-12 * np.abs(force(body + 3 * along)).max()


def test_the_cli_writes_sensitivities_csv_and_the_summary(tmp_path):
    text = PLANAR.replace("[P, k, c, tau, Mz, EI, rho, m, J]", "[P, rho]")
    run, out = latdyn_run(tmp_path, text)
    assert run.returncode == 0, run.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0]
    assert header == "t,tip_y/P,tip_y/rho,tip_x/P,tip_x/rho,hinge/P,hinge/rho"
    result = Result.load(out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["event_sensitivities"] == []
    for probe in ("tip_y", "tip_x", "hinge"):
        values = result.probes[probe]
        for which, row in (("end", -1), ("max", int(np.argmax(values))), ("min", int(np.argmin(values)))):
            assert summary["probe_sensitivities"][probe][which] == {
                name: result.sensitivities[(probe, name)][row] for name in ("P", "rho")}
    api = _run(text)
    for key, values in api.sensitivities.items():
        np.testing.assert_array_equal(values, result.sensitivities[key])


def test_an_interrupted_and_resumed_run_has_the_same_sensitivities(tmp_path, monkeypatch):
    """The carried sensitivities ride in the checkpoint: the resumed sensitivities.csv is the
    uninterrupted one, byte for byte."""
    scene = yaml.safe_load(PLANAR.replace("[P, k, c, tau, Mz, EI, rho, m, J]", "[P, k, rho]"))
    out, whole = interrupted_and_whole(scene, tmp_path, monkeypatch, 0.12)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    assert (out / "probes.csv").read_bytes() == (whole / "probes.csv").read_bytes()


def test_a_modified_newton_run_with_sensitivities_has_the_states_of_the_run_without(tmp_path):
    """``newton: modified`` holds its factorization from step to step; the sensitivities' evaluation of the
    exact matrices between the steps leaves it held (the native model has the inertia tangent's buffers
    from the start), so the run's states are the run's without sensitivities (the loop of steps in C) to
    the bit: probes.csv byte for byte and as many factorizations, through the CLI. Before, the first
    sensitivity step rebuilt the native model, one factorization more moved the states by 4.5e-11."""
    data = yaml.safe_load(SWING_3D)
    data["solve"].update(newton="modified", t_end=0.1)
    data["output"]["every"] = 0.005
    (tmp_path / "with").mkdir()
    (tmp_path / "with" / "scene.yaml").write_text(yaml.safe_dump(data))
    with_out = tmp_path / "with" / "out"   # the per-step Python path (its hinge law in θ takes the loop else)
    completed = latdyn_run_switched(tmp_path / "with", tmp_path / "with" / "scene.yaml", with_out,
                                    "import latdyn.analyses.sensitivities_in_loop as m; m.SENSITIVITIES_IN_LOOP = False")
    assert completed.returncode == 0, completed.stderr
    del data["solve"]["sensitivities"]
    (tmp_path / "without").mkdir()
    completed, without_out = latdyn_run(tmp_path / "without", yaml.safe_dump(data), quiet=True)
    assert completed.returncode == 0, completed.stderr
    summaries = [json.loads((out / "summary.json").read_text()) for out in (with_out, without_out)]
    assert [s["time_loop"] for s in summaries] == ["python", "compiled"]
    assert summaries[0]["factorizations"] == summaries[1]["factorizations"] < summaries[1]["steps"]
    assert (with_out / "probes.csv").read_bytes() == (without_out / "probes.csv").read_bytes()


@pytest.mark.parametrize("change, expected", [
    ({"method": "explicit"}, "not for method explicit"),
])
def test_what_is_not_differentiated_is_refused(change, expected):
    data = yaml.safe_load(PLANAR)
    data["solve"].update(change)
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert refused.value.key == "solve.sensitivities" and expected in str(refused.value)


def test_a_start_off_rest_without_rotary_inertia_is_refused_for_parameters_that_move_m_and_k(tmp_path):
    """Directions without inertia and accelerations at t = 0: the start's derivative through M and K
    is not computed, so a section's value is refused (exit 2 naming solve.sensitivities), while a
    global load's amplitude is exact there."""
    text = (FROM_REST_3D.replace("title:", "gravity: [0, 0, -9.81]\ntitle:")
            .replace('  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}\n', ""))
    run, out = latdyn_run(tmp_path, text.replace("[F, k, c, th0, EI, G, rho, m, cx, J]", "[EI]"))
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "without inertia" in run.stderr
    assert "Traceback" not in run.stderr
    loads = text.replace("[F, k, c, th0, EI, G, rho, m, cx, J]", "[F]").replace("t_end: 0.06", "t_end: 0.03")
    _agree(_run(loads), loads, "F", 1e-6)


#: a 3D cantilever of 22 elements (132 coordinates: the sparse LU's storage, past the dense limit of
#: 120), tilted out of every coordinate plane, rotary inertia, a tip load growing from zero
LONG_3D = """
title: tilted 3D cantilever, sparse
parameters: {EI: 50.0, rho: 1.0}
sections:
  s: {EA: 1.0e5, EIy: "EI", EIz: "1.6*EI", GJ: 40.0, rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
beams:
  arm: {from: base, to: [3.0, 1.0, 0.5], section: s, elements: 22}
loads:
  - {at: arm.end, force: ["20*t", "-100*t", "30*t"]}
solve: {analysis: transient, dt: 0.002, t_end: 0.012, sensitivities: [EI, rho]}
output:
  every: 0.004
  probes:
    tip_y: {point: arm.end, quantity: position, component: y}
    tip_z: {point: arm.end, quantity: displacement, component: z}
"""


def test_sensitivities_on_the_sparse_storage_agree():
    """Past the dense limit the matrices are CSR (K J, the bodies' blocks, the sparse LU): measured
    ≤ 1e-8 against the extrapolated differences."""
    from latdyn.numerics.linalg import DENSE_LIMIT

    result = _run(LONG_3D)
    assert result.summary["coordinates"] > DENSE_LIMIT
    for name in ("EI", "rho"):
        _agree(result, LONG_3D, name, 1e-6)


def test_a_run_stepped_from_python_refuses_sensitivities():
    """latdyn.Simulation steps the time loop without them: refused, not silently left out."""
    with pytest.raises(SceneError) as refused:
        latdyn.Simulation(latdyn.load_scene(yaml.safe_load(PLANAR))).advance_to(0.05)
    assert refused.value.key == "solve.sensitivities" and "latdyn.Simulation" in str(refused.value)
