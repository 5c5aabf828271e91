"""``controllers`` (SCENE.md, "Added with the issues of 2026-11-26"): control laws in the loop.

Exact references: a rigid link on a hinge (a hub of inertia J about the hinge axis) under a sampled
PD controller is a double integrator with a zero-order-hold input, whose exact discrete-time
solution at the sample instants is θ_{k+1} = θ_k + T ω_k + u_k T²/2J, ω_{k+1} = ω_k + u_k T/J; with
a discrete integrator state S_{k+1} = S_k + e_k/rate. Planar (axis z) and genuinely 3D (axis
[0, 1, 1]/√2, the link along x)."""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns

#: a rigid link to a tip mass m at distance L, on a hinge about AXIS at the fixed hub: J = m L²
HUB = """
{inputs}
controllers:
{controllers}
sections:
  s: {{EA: 1, EIy: 1, EIz: 1, GJ: 1, rhoA: 0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
  tip: {{at: [0.5, 0, 0], mass: 4.0}}
beams:
  arm:
    from: hub
    to: tip
    section: s
    rigid: true
    start: {{hinge: {{axis: {axis}, torque: "{torque}"}}}}
solve: {solve}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
{probes}
"""
J = 4.0 * 0.5 ** 2
PLANAR, SPATIAL = "[0, 0, 1]", "[0, 0.7071067811865476, 0.7071067811865476]"


def hub(controllers: str, *, torque: str = "ctl", axis: str = PLANAR, solve: str = "{t_end: 2.0, dt: 0.01}",
        probes: str = "", inputs: str = "") -> str:
    return HUB.format(controllers=controllers, torque=torque, axis=axis, solve=solve, probes=probes, inputs=inputs)


SAMPLED_PI = """
  ctl:
    output: "-kp*(th - ref) - kd*om - ki*S"
    states: {S: "th - ref"}
    initial: {S: 0.5}
    rate: 10
"""


def discrete_pi(kp, kd, ki, ref, rate, n, S0=0.5):
    """The exact discrete-time solution of J θ̈ = u with u held over each sample interval."""
    T, th, om, S = 1.0 / rate, 0.0, 0.0, S0
    out = [(th, om, S)]
    for _ in range(n):
        u = -kp * (th - ref) - kd * om - ki * S
        S = S + (th - ref) / rate
        th, om = th + T * om + u * T * T / (2 * J), om + u * T / J
        out.append((th, om, S))
    return np.array(out)


@pytest.mark.parametrize("axis", [PLANAR, SPATIAL], ids=["planar", "3d"])
def test_sampled_pi_equals_the_exact_discrete_time_solution(tmp_path, axis):
    """Sampled at 10 Hz with dt = 0.03 (steps shortened onto the instants): at every sample instant
    the hinge angle, rate and the integrator state equal the discrete-time solution to round-off."""
    inputs = "inputs: {kp: 6.0, kd: 2.0, ki: 1.0, ref: 1.0}"
    text = hub(SAMPLED_PI, axis=axis, solve="{t_end: 3.0, dt: 0.03}", inputs=inputs,
               probes="    u: {controller: ctl}\n    Sp: {controller: ctl, state: S}")
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    exact = discrete_pi(6.0, 2.0, 1.0, 1.0, 10, 30)
    for k in range(31):
        row = int(np.argmin(np.abs(p["t"] - k / 10)))
        assert abs(p["t"][row] - k / 10) < 1e-12  # a step landed on the instant
        assert abs(p["th"][row] - exact[k, 0]) < 1e-10
        assert abs(p["om"][row] - exact[k, 1]) < 1e-10
        if k < 30:  # recorded at the instant: the new held output, and the state advanced by the sample
            th, om, S = exact[k]
            assert abs(p["u"][row] - (-6 * (th - 1) - 2 * om - 1.0 * S)) < 1e-9
            assert abs(p["Sp"][row] - exact[k + 1, 2]) < 1e-12


def test_sampled_saturation_and_chain_api():
    """``limits`` clip the held output (not the state); a controller reads an earlier one by name
    and sees its new value at the same instant."""
    scene = latdyn.load_scene(yaml.safe_load(hub("""
  raw:
    output: "-20*(th - 1) - 4*om"
    rate: 20
  ctl:
    output: "raw"
    limits: [-1.5, 1.5]
    rate: 20
""", probes="    u: {controller: ctl}\n    r: {controller: raw}", solve="{t_end: 1.0, dt: 0.01}")))
    result = latdyn.run(scene)
    T, th, om = 0.05, 0.0, 0.0
    for k in range(20):
        raw = -20 * (th - 1) - 4 * om
        u = min(max(raw, -1.5), 1.5)
        row = int(np.argmin(np.abs(result.t - k * T)))
        assert abs(result.probes["r"][row] - raw) < 1e-9 and abs(result.probes["u"][row] - u) < 1e-12
        assert abs(result.probes["th"][row] - th) < 1e-10
        th, om = th + T * om + u * T * T / (2 * J), om + u * T / J


def test_sampled_controller_resumes_bit_for_bit(tmp_path, monkeypatch):
    """Interrupted between two samples and resumed (``--resume``): the held output and the state
    come back from the checkpoint and the files equal an uninterrupted run's."""
    from test_checkpoint import interrupt_at

    text = hub(SAMPLED_PI, inputs="inputs: {kp: 6.0, kd: 2.0, ki: 1.0, ref: 1.0}",
               probes="    u: {controller: ctl}\n    Sp: {controller: ctl, state: S}")
    scene = yaml.safe_load(text)
    full, out = tmp_path / "full", tmp_path / "out"
    latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.737)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert (out / "probes.csv").read_text() == (full / "probes.csv").read_text()


@pytest.mark.parametrize("controllers, key, says", [
    ("  t: {output: 1, rate: 1}", "controllers.t", "word of the expression language"),
    ("  ctl: {output: \"ctl + 1\", rate: 1}", "controllers.ctl.output", "a cycle"),
    ("  ctl: {output: \"later\", rate: 1}\n  later: {output: 1, rate: 1}", "controllers.ctl.output",
     "defined later"),
    ("  ctl: {output: \"u\", rate: 1}", "controllers.ctl.output", "through the probe 'u'"),
    ("  ctl: {output: \"E\"}", "controllers.ctl.output", "continuous controller cannot read the energy probe"),
    ("  ctl: {output: \"nope\", rate: 1}", "controllers.ctl.output", "name 'nope'"),
    ("  ctl: {output: 1, rate: 0}", "controllers.ctl.rate", "positive number"),
    ("  ctl: {output: 1, limits: [1, 1]}", "controllers.ctl.limits", "lo < hi"),
    ("  ctl: {output: 1, states: {theta: 1}}", "controllers.ctl.states.theta", "word of the expression language"),
    ("  ctl: {output: 1, states: {th: 1}}", "controllers.ctl.states.th", "already names a probe"),
    ("  ctl: {output: 1, initial: {S: 1}}", "controllers.ctl.initial.S", "expected one of the controller's states"),
    ("  ctl: {output: 1, gain: 2}", "controllers.ctl.gain", "unknown key"),
    ("  th: {output: 1}", "output.probes.th", "share one namespace"),
    # what this version does not run continuously (sampled, each runs)
    ("  a: {output: \"th\", states: {S: \"th\"}}\n  ctl: {output: \"a\"}", "controllers.ctl.output", "reads one with states"),
    ("  ctl: {output: \"E\", rate: 2}\n  c2: {output: \"th\"}", "beams.arm.start.hinge.torque", "a*y + b with a constant a"),
])
def test_refusals_name_the_key(controllers, key, says):
    """Each refusal in Python (the loader's, or the model's wiring for what is not built); the CLI's
    exit status 2 and message without a traceback: test_a_refusal_through_the_cli."""
    from latdyn.errors import SceneError

    torque = "c2*theta" if "c2:" in controllers else "ctl" if "continuous" in says or "states" in says else "0"
    text = hub(controllers, torque=torque, probes="    u: {controller: ctl}\n    E: {energy: kinetic}"
               if "ctl:" in controllers else "    E: {energy: kinetic}")
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert key in str(refused.value) and says in str(refused.value), str(refused.value)


def test_a_refusal_through_the_cli(tmp_path):
    completed, _ = latdyn_run(tmp_path, hub('  ctl: {output: "later", rate: 1}\n  later: {output: 1, rate: 1}'))
    assert completed.returncode == 2
    assert "controllers.ctl.output" in completed.stderr and "defined later" in completed.stderr
    assert "Traceback" not in completed.stderr


# ----------------------------------------------------------------------------- continuous controllers
CONTINUOUS_PD = """
  ctl:
    output: "-kp*(th - ref) - kd*om"
"""
GAINS = "inputs: {kp: 40.0, kd: 8.0, ref: 1.0}"


def pd_exact(t, kp=40.0, kd=8.0, ref=1.0):
    """θ(t) of J θ̈ = −kp (θ − ref) − kd θ̇ from rest at 0 (underdamped)."""
    wn, zeta = math.sqrt(kp / J), kd / (2 * math.sqrt(kp * J))
    wd = wn * math.sqrt(1 - zeta ** 2)
    return ref * (1 - np.exp(-zeta * wn * t) * (np.cos(wd * t) + zeta * wn / wd * np.sin(wd * t)))


def test_continuous_pd_slew_cli_planar(tmp_path):
    """A continuous PD on the hinge angle and rate probes slews the hub: θ(t) against the exact
    second-order solution (generalized-α's O(h²) error, measured 3.4e-5, 8.5e-6, 2.1e-6 at h = 0.004,
    0.002, 0.001; run here at 0.004); its exact
    derivatives in Newton's matrix make each step of this linear loop converge in two iterations."""
    completed, out = latdyn_run(tmp_path, hub(CONTINUOUS_PD, inputs=GAINS, solve="{t_end: 1.5, dt: 0.004}",
                                              probes="    u: {controller: ctl}"))
    assert completed.returncode == 0, completed.stderr
    p = probe_columns(out)
    assert np.max(np.abs(p["th"] - pd_exact(p["t"]))) < 4e-5
    assert np.max(np.abs(p["u"] - (-40 * (p["th"] - 1) - 8 * p["om"]))) < 1e-9
    summary = json.loads((out / "summary.json").read_text())
    assert summary["newton_iterations"] <= 2 * summary["steps"]


def test_continuous_pd_slew_api_3d():
    scene = latdyn.load_scene(yaml.safe_load(hub(CONTINUOUS_PD, inputs=GAINS, axis=SPATIAL,
                                                 solve="{t_end: 1.5, dt: 0.004}")))
    result = latdyn.run(scene)
    assert np.max(np.abs(result.probes["th"] - pd_exact(result.t))) < 4e-5


def test_saturated_pd_against_an_independent_integration():
    """limits [-3, 3] on a stiff PD: θ against scipy's solve_ivp of J θ̈ = clip(u) (rtol 1e-10)."""
    from scipy.integrate import solve_ivp

    text = hub(CONTINUOUS_PD.replace('om"', 'om"\n    limits: [-3, 3]'), inputs="inputs: {kp: 200.0, kd: 30.0, ref: 1.0}",
               solve="{t_end: 1.0, dt: 0.002}", probes="    u: {controller: ctl}")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))

    def rhs(t, x):
        return [x[1], min(max(-200 * (x[0] - 1) - 30 * x[1], -3.0), 3.0) / J]

    reference = solve_ivp(rhs, (0, 1), [0.0, 0.0], t_eval=result.t, rtol=1e-10, atol=1e-12, method="DOP853")
    assert np.max(np.abs(result.probes["u"])) <= 3.0 + 1e-12
    assert np.any(np.abs(result.probes["u"]) == 3.0)  # it saturated
    assert np.max(np.abs(result.probes["th"] - reference.y[0])) < 1e-4  # measured 5.1e-5 of 1.19 at dt = 0.002


def linear_model_of(text: str) -> dict:
    import tempfile
    from pathlib import Path

    with tempfile.TemporaryDirectory() as folder:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)), Path(folder))
        with np.load(Path(folder) / "linear_model.npz") as data:
            return {k: data[k] for k in data.files}


@pytest.mark.parametrize("axis", [PLANAR, SPATIAL], ids=["planar", "3d"])
def test_closed_loop_linear_model_is_open_loop_plus_bkc(axis):
    """Static output feedback u = K y, K = [−kp, −kd] on y = [θ, θ̇]: the linear model of the scene
    with the controller has A = A_ol + B K C of the scene without it, to round-off; its mode's
    damping ratio is the loop's, kd / 2√(kp J)."""
    modes = '{analysis: modes, count: 1, linear_model: {inputs: [arm.start], outputs: [th, om]}}'
    closed = linear_model_of(hub(CONTINUOUS_PD, inputs=GAINS, axis=axis, solve=modes))
    opened = linear_model_of(hub("  other: {output: 0}", torque="0", inputs=GAINS, axis=axis, solve=modes))
    K = np.array([[-40.0, -8.0]])
    expected = opened["A"] + opened["B"] @ K @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) < 1e-9 * np.max(np.abs(expected))
    eigenvalues = np.linalg.eigvals(closed["A"])
    zeta = -eigenvalues.real / np.abs(eigenvalues)
    assert np.allclose(zeta, 8.0 / (2 * math.sqrt(40.0 * J)), rtol=1e-9)


TWO_BODIES = """
{controllers}
sections:
  s: {{EA: 1.0e4, EIy: 50.0, EIz: 80.0, GJ: 40.0, rhoA: 0.5}}
bodies:
  base: {{at: [0, 0, 0], fixed: true}}
  a: {{at: [1, 0, 0], mass: 2.0, inertia: [0.1, 0.1, 0.1]}}
  b: {{at: [2, 1, 0], mass: 1.0, inertia: [0.1, 0.1, 0.1]}}
beams:
  post: {{from: base, to: a, section: s, elements: 2}}
  arm: {{from: a, to: b, section: s, elements: 2}}
loads:
  - {{at: a, force: [0, 0, "{force}"]}}
solve: {{analysis: modes, count: 4, linear_model: {{inputs: [a.force.z], outputs: [zb]}}}}
output:
  probes:
    zb: {{point: b, quantity: displacement, component: z}}
"""


def test_non_collocated_load_controller_3d_linear_model():
    """A force along z on body a driven by the z displacement of body b at the other end of an
    elastic beam (non-collocated: a's equations coupled to b's coordinate): A = A_ol + B K C."""
    scene = TWO_BODIES
    closed = linear_model_of(scene.format(controllers='controllers:\n  ctl: {output: "-30*zb"}', force="ctl"))
    opened = linear_model_of(scene.format(controllers="", force="0"))
    expected = opened["A"] + opened["B"] @ np.array([[-30.0]]) @ opened["C"]
    assert np.max(np.abs(closed["A"] - expected)) < 1e-8 * np.max(np.abs(expected))


def test_modes_hold_a_sampled_controller_and_say_so(tmp_path):
    """A sampled controller is held in a modal analysis (its output at the initial state), and
    summary.json warnings says so; the continuous one beside it is in the closed loop."""
    text = hub(SAMPLED_PI.replace("ctl:", "held:") + CONTINUOUS_PD, inputs="inputs: {kp: 40.0, kd: 8.0, ki: 1.0, ref: 1.0}",
               solve="{analysis: modes, count: 1}", probes="    h: {controller: held}")
    completed, out = latdyn_run(tmp_path, text)
    assert completed.returncode == 0, completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert any("sampled controllers (held) are held" in w for w in summary["warnings"])
    assert summary["damping_ratios"][0] == pytest.approx(8.0 / (2 * math.sqrt(40.0 * J)), rel=1e-9)


FLEXIBLE = """
inputs: {{kp: 400.0, kd: 60.0, kt: 5.0}}
controllers:
  ctl: {{output: "-kp*th - kd*om - kt*vt"}}
sections:
  s: {{EA: 1.0e6, EIy: 100.0, EIz: 100.0, GJ: 80.0, rhoA: 1.0}}
bodies:
  hub: {{at: [0, 0, 0], fixed: true}}
beams:
  arm:
    from: hub
    to: [2, 0, 0]
    section: s
    elements: 4
    start: {{hinge: {{axis: [0, 0, 1], torque: "ctl"}}}}
initial_velocity: {{angular: [0, 0, 0.01]}}
solve: {solve}
output:
  probes:
    th: {{hinge: arm.start, quantity: angle}}
    om: {{hinge: arm.start, quantity: rate}}
    vt: {{point: arm.end, quantity: velocity, component: y}}
"""


def test_flexible_slewing_beam_with_tip_feedback_decays_as_its_closed_loop_eigenvalues():
    """A flexible beam on a hinge under PD plus tip-velocity feedback (non-collocated), set turning
    slowly: the two least-damped in-plane modes fitted to the hinge angle of the nonlinear transient
    (t ≥ 1 s) have the decay rate and frequency of the closed loop's eigenvalues from linear_model.
    Measured: λ₁ = −1.4334 + 8.3243i: σ 2.1e-4 |λ|, ω 8e-5 |λ|; λ₂ = −1.4717 + 54.025i: σ 2.0e-4 |λ|,
    ω 8.8e-4 |λ| (generalized-α's period error (ω dt)²/12 at dt = 0.002, rho_inf 1); the two modes
    leave 0.4 % of the angle unexplained (the faster ones)."""
    from scipy.optimize import curve_fit

    A = linear_model_of(FLEXIBLE.format(solve="{analysis: modes, count: 2, linear_model: "
                                              "{inputs: [arm.start], outputs: [th]}}"))["A"]
    eigenvalues = np.linalg.eigvals(A)
    # the damped in-plane modes the step resolves (ω dt < 0.2); the undamped ones are out of plane
    controlled = eigenvalues[(eigenvalues.real < -1e-6) & (eigenvalues.imag > 0) & (eigenvalues.imag < 100)]
    slowest = controlled[np.argsort(-controlled.real)][:2]
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(FLEXIBLE.format(solve="{t_end: 6.0, dt: 0.002, rho_inf: 1.0}"))))
    late = result.t >= 1.0
    t, theta = result.t[late], result.probes["th"][late]

    def two_modes(t, s1, w1, a1, b1, s2, w2, a2, b2):
        return (np.exp(s1 * t) * (a1 * np.cos(w1 * t) + b1 * np.sin(w1 * t))
                + np.exp(s2 * t) * (a2 * np.cos(w2 * t) + b2 * np.sin(w2 * t)))

    start = [slowest[0].real, slowest[0].imag, 1e-4, 1e-4, slowest[1].real, slowest[1].imag, 1e-6, 1e-6]
    fitted, _ = curve_fit(two_modes, t, theta, p0=start, maxfev=20000)
    for lam, (sigma, omega), tolerance in zip(slowest, (fitted[0:2], fitted[4:6]), (5e-4, 2e-3)):
        assert abs(sigma - lam.real) < tolerance * abs(lam) and abs(omega - lam.imag) < tolerance * abs(lam)
    assert np.max(np.abs(two_modes(t, *fitted) - theta)) < 1e-2 * np.max(np.abs(theta))


def test_continuous_controller_resumes_bit_for_bit(tmp_path, monkeypatch):
    """A continuous controller keeps nothing between steps (its output is a function of the state):
    interrupted and resumed, probes.csv equals the uninterrupted run's."""
    from test_checkpoint import interrupt_at

    scene = yaml.safe_load(hub(CONTINUOUS_PD, inputs=GAINS, probes="    u: {controller: ctl}"))
    full, out = tmp_path / "full", tmp_path / "out"
    latdyn.run(scene, full)
    with monkeypatch.context() as m:
        interrupt_at(m, 0.737)
        with pytest.raises(KeyboardInterrupt):
            latdyn.run(scene, out)
    latdyn.run(scene, out, resume=True)
    assert (out / "probes.csv").read_text() == (full / "probes.csv").read_text()


def test_linear_model_inputs_name_scene_inputs():
    """``solve.linear_model.inputs`` may name a scene input: its B column is the exact derivative of
    the forces that name it — a load component "3*w" gives 3 × the column of the force input, and
    the reference of a continuous PD (torque = −kp (θ − ref) − kd θ̇) gives kp × the hinge torque's."""
    modes = "{analysis: modes, count: 1, linear_model: {inputs: [arm.start, ref], outputs: [th]}}"
    B = linear_model_of(hub(CONTINUOUS_PD, inputs=GAINS, solve=modes))["B"]
    assert np.max(np.abs(B[:, 0])) > 0 and np.max(np.abs(B[:, 1] - 40.0 * B[:, 0])) < 1e-12 * np.max(np.abs(B))
    text = "inputs: {w: 0.5}\n" + TWO_BODIES.format(controllers="", force="3*w").replace(
        "inputs: [a.force.z]", "inputs: [w, a.force.z]")
    B = linear_model_of(text)["B"]
    assert np.max(np.abs(B[:, 1])) > 0 and np.max(np.abs(B[:, 0] - 3.0 * B[:, 1])) < 1e-12 * np.max(np.abs(B))


def test_static_equilibrium_held_by_a_continuous_controller():
    """Gravity on the hub's tip mass held by a P controller alone (the hinge has no spring): the static
    path ends where kp θ + m g L cos θ = 0 (the controller is not ramped with the loads)."""
    from scipy.optimize import brentq

    text = hub('  ctl: {output: "-400*th"}', solve="{analysis: static, steps: 4}").replace(
        "sections:", "gravity: [0, -9.81, 0]\nsections:")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    exact = brentq(lambda th: 400 * th + 4.0 * 9.81 * 0.5 * math.cos(th), -1, 1)
    assert abs(result.probes["th"][-1] - exact) < 1e-9
