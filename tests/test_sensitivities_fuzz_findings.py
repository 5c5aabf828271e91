"""What the extended sensitivity fuzzing of 2026-11-27 found (benchmarks/fuzz_sensitivities.py ``--extended``;
docs/verification.md, "Sensitivity fuzzing"), each reduced to the smallest scene that shows it, against
Richardson-extrapolated central differences of whole runs.

A hinge's axis as a parameter, its hinge on a fixed body, the structure started spinning (``initial_velocity``):
the hinge starts at the rate θ̇ = a·ω (latdyn/assembly/initial.py: its beam turns with ω, the fixed body does
not), which moves with the axis a. The start's sensitivities took the hinges' rates as unmoved (a·(ω − ω) = 0
holds between two free parts only), so δθ̇_0 was 0: the hinge's rate and its damper's torque were wrong from
the first row (found on a 3D two-arm scene with a latch: the shoulder's torque 0.0113 off at t = 0, the tip
4.5e-5, the latch time 1.2e-4). Now δθ̇_0 = δa·ω there (``ReferenceGeometry.initial_velocity_tangent``).

A joint-force probe at a row whose time moves with p (an event's row): its force's explicit time dependence (a
law in t) was left out — a held joint's reaction lacked ∂r_d/∂t δt_e, a free joint's law −∂f/∂t δt_e (found on a
3D arm carrying a latching guide pushed by ``F*sin(6*t)``: the guide's force at the latch's row 2-3% off for
every parameter). Now both are in (``TransientSensitivities._joint_forces``). Likewise a cable's tension beside a
reel (``rest_length`` in t) lacked ∂N/∂L0 · L0′(t) δt_e at such a row (``probe_derivatives._tension_in_time``).

A latch while a damped cable holds the tip taut: the impulse's weight M + dt² K moves with the rates where K does
(the damper's terms c ℓ̇), and its derivative took K along δq alone: the rows after the latch 4.7e-6 (tension) and
7.4e-6 (torque) off, the same at h = 1e-2 … 1e-4 (``TransientSensitivities._stiffness_by_rates``).

A parameter of the centre of mass of a body without mass or inertia ended the run with an internal error (an
IndexError: such a body has no joint-body row); its derivative is 0 exactly, now computed so, and a parameter of
the mass or inertia of such a body (a value 0) is refused naming ``solve.sensitivities``.

A controller's ``limits``, ``initial`` and ``rate`` took plain numbers only; now constant expressions of the
parameters as every number of a scene, their sensitivities refused naming the key.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_events import LATCH_PLANAR

#: a flexible arm hinged to the ground about an axis tilted by ``ax``, a tip body with rotary inertia, the whole
#: started spinning about z: the hinge starts at θ̇ = a·ω, a(ax) = (ax, 0.3, 1)/|…|
SPUN_HINGE_AXIS = """
parameters: {ax: 0.2}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: 0.7, inertia: [0.01, 0.02, 0.015]}
beams:
  arm: {from: g, to: b, section: s, elements: 1, start: {hinge: {axis: [ax, 0.3, 1], stiffness: 40, damping: 0.3}}}
initial_velocity: {angular: [0, 0, 1.5]}
solve: {analysis: transient, method: hht-alpha, t_end: 0.05, dt: 0.01, tol: 1.0e-12, sensitivities: [ax]}
output:
  probes:
    rate: {hinge: arm.start, quantity: rate}
    torque: {hinge: arm.start, quantity: torque}
    tip: {point: b, quantity: position, component: z}
"""


def _run(text: str, **values):
    data = yaml.safe_load(text)
    data["parameters"].update(values)
    return latdyn.run(latdyn.load_scene(data))


def _richardson(text: str, name: str, h: float) -> dict:
    """d(probe)/d(name) over the rows: (4 D(h/2) − D(h))/3 of central differences D of whole runs."""
    p0 = yaml.safe_load(text)["parameters"][name]
    central = []
    for step in (h, h / 2):
        up, down = _run(text, **{name: p0 + step}), _run(text, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


def _assert_agree(result, text: str, probes: tuple, name: str = "k", h: float = 0.02) -> None:
    """Every row of ``probes``' sensitivities by ``name`` within 1e-7 of the probe's largest, against
    :func:`_richardson`."""
    expected = _richardson(text, name, h)
    for probe in probes:
        computed = result.sensitivities[(probe, name)]
        error = np.abs(computed - expected[probe]).max() / np.abs(expected[probe]).max()
        assert error <= 1e-7, (probe, error)


def test_a_hinge_axis_on_a_fixed_body_moves_the_spun_start_s_hinge_rate(tmp_path):
    """The rate at t = 0 is a·ω: its derivative (∂a/∂ax)·ω = −0.2497 (closed form). Measured after the mend: every
    row of the three probes within 4.2e-11 of its largest sensitivity (h = 1e-3). Before: the first rows of the
    rate and the torque 0 (against −0.2497 and 0.0749), the rows 0.198 (rate), 0.050 (torque), 0.025 (tip) off."""
    completed, out = latdyn_run(tmp_path, SPUN_HINGE_AXIS, quiet=True)
    assert completed.returncode == 0, completed.stderr
    result = _run(SPUN_HINGE_AXIS)
    v = np.array([0.2, 0.3, 1.0])
    a = v / np.linalg.norm(v)
    da = (np.array([1.0, 0, 0]) - a * a[0]) / np.linalg.norm(v)
    omega = np.array([0, 0, 1.5])
    assert abs(result.probes["rate"][0] - a @ omega) < 1e-12
    assert abs(result.sensitivities[("rate", "ax")][0] - da @ omega) < 1e-12
    _assert_agree(result, SPUN_HINGE_AXIS, ("rate", "torque", "tip"), "ax", 1e-3)
    # the CLI writes the same derivative
    with open(out / "sensitivities.csv", encoding="utf-8") as f:
        header = f.readline().strip().split(",")
        first = [float(x) for x in f.readline().split(",")]
    assert abs(first[header.index("rate/ax")] - da @ omega) < 1e-12


#: a hinge driven by a saturated PI controller whose limits, initial state and sample rate are parameters
CONTROLLER_NUMBERS = """
parameters: {I0: 0.02, lim: 0.6, hz: 200}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: 0.7, inertia: [0.01, 0.02, 0.015]}
beams:
  arm: {from: g, to: b, section: s, elements: 1, start: {hinge: {axis: [0.2, 0.3, 1], damping: 0.5, torque: ctl}}}
controllers:
  ctl: {output: "-30*(h - 0.15) - 4*I", states: {I: "h - 0.15"}, initial: {I: I0}, limits: ["-lim", lim], rate: hz}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.03, dt: 0.01, tol: 1.0e-12%s}
output:
  probes:
    h: {hinge: arm.start, quantity: angle}
    u: {controller: ctl}
"""


def test_a_controller_s_limits_initial_state_and_rate_may_be_parameters_and_their_sensitivities_are_refused(tmp_path):
    """SCENE.md: any number of a scene may be an expression of the parameters. A controller's ``limits``,
    ``initial`` and ``rate`` were read as plain numbers only (exit 2: ``controllers.ctl.limits[0]: expected a
    number, got '-lim'``), so the fuzzer's parameters there were refused as a type error. Now they load to the
    numbers they name (the run equal to the scene written with numbers, bit for bit), and a sensitivity by one
    of them — not differentiated — is refused naming the key, never computed as 0."""
    named = _run(CONTROLLER_NUMBERS % "")
    numbers = yaml.safe_load(CONTROLLER_NUMBERS % "")
    del numbers["parameters"]
    numbers["controllers"]["ctl"].update(initial={"I": 0.02}, limits=[-0.6, 0.6], rate=200)
    plain = latdyn.run(latdyn.load_scene(numbers))
    assert np.abs(named.probes["u"]).max() == 0.6      # saturated: the limits act
    for probe in ("h", "u"):
        np.testing.assert_array_equal(named.probes[probe], plain.probes[probe])
    for name, key in (("I0", "controllers.ctl.initial.I"), ("lim", "controllers.ctl.limits[0]"),
                      ("hz", "controllers.ctl.rate")):
        (tmp_path / name).mkdir()
        completed, _ = latdyn_run(tmp_path / name, CONTROLLER_NUMBERS % f", sensitivities: [{name}]", quiet=True)
        assert completed.returncode == 2, completed.stderr
        assert f"solve.sensitivities: parameter '{name}' is used at {key}" in completed.stderr
        assert "Traceback" not in completed.stderr
    # an expression in t is no constant: refused naming the key
    (tmp_path / "t").mkdir()
    completed, _ = latdyn_run(tmp_path / "t", (CONTROLLER_NUMBERS % "").replace('["-lim", lim]', '["-lim*t", lim]'),
                              quiet=True)
    assert completed.returncode == 2
    assert "controllers.ctl.limits[0]: expected a constant (a number or an expression without t)" in completed.stderr


#: a 3D arm latching at its ground hinge, pushed by a torque in t, a fore arm on it whose hinge torque is a law in
#: t: the latch's row moves with p, and both torques there depend on t explicitly
TORQUES_IN_TIME_AT_A_LATCH = """
parameters: {k: 20.0}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: 0.7, inertia: [0.01, 0.02, 0.015]}
  c: {at: [1.3, 0.5, 0.2], mass: 0.3, inertia: [0.004, 0.005, 0.006]}
beams:
  fore: {from: b, to: c, section: s, elements: 1, start: {hinge: {axis: [0.1, 1, 0.4], stiffness: 8, damping: 0.2,
         torque: "2*sin(9*t)"}}}
  arm: {from: g, to: b, section: s, elements: 1, start: {hinge: {axis: [0.2, 0.3, 1], stiffness: k, damping: 0.5,
        torque: "3*sin(6*t) + 1", lock_at: 0.01}}}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.2, dt: 0.01, tol: 1.0e-12, sensitivities: [k]}
output:
  probes:
    torque: {hinge: arm.start, quantity: torque}
    elbow: {hinge: fore.start, quantity: torque}
"""


def test_joint_forces_at_an_event_s_row_move_with_their_laws_in_time(tmp_path):
    """At the latch's row (t_e = 0.198) the held shoulder's reaction and the free elbow's law. Measured after the
    mend: rows within 1.1e-8 (shoulder) and 2.2e-9 (elbow) of each probe's largest sensitivity; before: 0.046 and
    0.25 off at the latch's row (every other row 1.4e-10)."""
    completed, out = latdyn_run(tmp_path, TORQUES_IN_TIME_AT_A_LATCH, quiet=True)
    assert completed.returncode == 0, completed.stderr
    result = _run(TORQUES_IN_TIME_AT_A_LATCH)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    _assert_agree(result, TORQUES_IN_TIME_AT_A_LATCH, ("torque", "elbow"))


#: a 3D arm latching at its ground hinge, its tip tied to an anchor by a cable reeled in (rest length in t), taut
#: throughout: at the latch's row the tension depends on t through the reel
REEL_AT_A_LATCH = """
parameters: {k: 20.0}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  a: {at: [0.9, 0.9, 0.3], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: 0.7, inertia: [0.01, 0.02, 0.015]}
beams:
  arm: {from: g, to: b, section: s, elements: 1, start: {hinge: {axis: [0.2, 0.3, 1], stiffness: k, damping: 0.5,
        torque: 4.0, lock_at: 0.01}}}
cables:
  c0: {from: b, to: a, EA: 2000.0, rest_length: "0.79 - 0.4*t"}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.06, dt: 0.01, tol: 1.0e-12, sensitivities: [k]}
output:
  probes:
    n: {cable: c0, quantity: tension}
    torque: {hinge: arm.start, quantity: torque}
"""


def test_a_reeled_cable_s_tension_at_an_event_s_row_moves_with_the_reel():
    """The latch at t_e = 0.0176 (row 2). Measured (t_end 0.2): every row of the tension and the torque within
    7.7e-9 of its largest sensitivity; before the mend the tension's latch row 1.5 off (its other rows 7e-9)."""
    result = _run(REEL_AT_A_LATCH)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert not [e for e in result.summary.get("cable_events", [])]
    _assert_agree(result, REEL_AT_A_LATCH, ("n", "torque"))


#: a 3D arm whose end body has no mass or inertia, only a centre of mass named by a parameter (fuzzer seed 15
#: case 3, reduced)
MASSLESS_COM = """
parameters: {c: -0.001, m: 0.0}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: m, com: [c, 0, 0]}
beams:
  arm: {from: g, to: b, section: s, elements: 2, start: {hinge: {axis: [0.2, 0.3, 1], stiffness: 20, torque: 1.0}}}
gravity: [0, 0, -9.81]
solve: {analysis: transient, method: newmark, t_end: 0.03, dt: 0.01, tol: 1.0e-12, sensitivities: [%s]}
output:
  probes:
    tip: {point: b, quantity: position, component: z}
"""


def test_a_centre_of_mass_of_a_body_without_mass_moves_nothing_and_its_mass_at_zero_is_refused(tmp_path):
    """Before: both ended with ``internal error: IndexError`` (exit 1, a traceback's report). Now the centre of
    mass's derivative is 0 in every row (the differences of whole runs are 0 too: the body has no inertia), and a
    mass of 0 named as a parameter is refused (exit 2)."""
    (tmp_path / "com").mkdir()
    completed, out = latdyn_run(tmp_path / "com", MASSLESS_COM % "c", quiet=True)
    assert completed.returncode == 0, completed.stderr
    result = _run(MASSLESS_COM % "c")
    assert not np.any(result.sensitivities[("tip", "c")])
    np.testing.assert_array_equal(_run(MASSLESS_COM % "c", c=0.05).probes["tip"], result.probes["tip"])
    (tmp_path / "mass").mkdir()
    completed, _ = latdyn_run(tmp_path / "mass", MASSLESS_COM % "m", quiet=True)
    assert completed.returncode == 2, completed.stderr
    assert "solve.sensitivities: bodies.b has neither mass nor inertia" in completed.stderr
    assert "internal error" not in completed.stderr


#: REEL_AT_A_LATCH with a constant rest length and a damper: the cable taut through the latch
DAMPED_CABLE_AT_A_LATCH = REEL_AT_A_LATCH.replace('rest_length: "0.79 - 0.4*t"', "damping: 3.0, rest_length: 0.75")


def test_a_latch_beside_a_damped_taut_cable_moves_the_impulse_s_weight_with_the_rates():
    """Measured (t_end 0.2): after the mend the tension's rows within 4.1e-9, the torque's 1.4e-8 of their largest
    sensitivity (h = 1e-3 k); before 4.7e-6 and 7.4e-6 (the same at h = 1e-2, 1e-4: not the differences')."""
    result = _run(DAMPED_CABLE_AT_A_LATCH)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    _assert_agree(result, DAMPED_CABLE_AT_A_LATCH, ("n", "torque"))


def _assert_adjoint_agrees(text: str, names: tuple, bound: float = 1e-8, kinds: tuple = ("latch",)) -> None:
    """The adjoint's summary (``probe_sensitivities``' end rows, ``event_sensitivities``) within ``bound`` of the
    forward method's, relative to the probe's largest end sensitivity."""
    forward = _run(text)
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(text.replace(
        "tol: 1.0e-12,", "tol: 1.0e-12, sensitivity_method: adjoint,"))))
    assert adjoint.summary["events"] == forward.summary["events"]
    assert [e["kind"] for e in forward.summary["events"]] == list(kinds)
    for probe, by_name in forward.summary["probe_sensitivities"].items():
        expected = np.array([by_name["end"][name] for name in names])
        computed = np.array([adjoint.summary["probe_sensitivities"][probe]["end"][name] for name in names])
        assert np.abs(computed - expected).max() <= bound * max(np.abs(expected).max(), 1e-12), (probe, computed,
                                                                                                 expected)
    for mine, theirs in zip(adjoint.summary["event_sensitivities"], forward.summary["event_sensitivities"]):
        for name in names:
            assert abs(mine["dt"][name] - theirs["dt"][name]) <= 1e-8 * abs(theirs["dt"][name]) + 1e-15


def test_the_adjoint_takes_a_latch_beside_a_damped_cable():
    """The adjoint's transposed weight derivative lacked the rates' term that the forward method takes: on the same
    scene (t_end 0.2) its summary differed from the forward method's by up to 1.9e-5 of the probe's largest (the
    tension's end), reported as solved; refused since fdbaeb4. Now the transposed term
    (AdjointSensitivities._stiffness_by_rates_transposed): 1.35e-11 from the forward method, 1.4e-8 from Richardson
    differences (benchmarks/fuzz_sensitivities.py --scene, the scene with sensitivity_method: adjoint)."""
    _assert_adjoint_agrees(DAMPED_CABLE_AT_A_LATCH, ("k",))


#: fuzzer seed 16 case 16 (benchmarks/fuzz_sensitivity_scenes/n_seed16_case16_refused.yaml): its trial step from
#: t = 0.06 of 0.03 s converges to θ = −6.17 at m0.end, past its stop at −0.597, and no shorter step reaches the
#: stop (θ ≈ −0.03 at 0.0028, 0.0053 and 0.0095 s; Newton fails at 0.0154 s)
TRIAL_PAST_A_STOP = """
title: fuzz
sections:
  s0: {EA: 2065049.0, EIy: 1124.0, EIz: 1124.0, GJ: 394.0, rhoA: 1.665, rhoIy: 0.00932, rhoIz: 0.00932}
  s1: {EA: 1712514.0, EIy: 1668.0, EIz: 1668.0, GJ: 1543.8, rhoA: 0.34, rhoIy: 0.00098, rhoIz: 0.00098}
bodies:
  g:
    at: [0, 0, 0]
    mass: 1.81
    inertia: [0.581, 0.581, 0.581]
  b0:
    at: [1.04, 0.0, 0.0]
  b1:
    at: [1.04, 0.0, 1.11]
    mass: 2.066
  gd:
    at: [-0.95, -0.48, 0.26]
    mass: 2.731
    guide:
      axis: [1.0, 0.0, 0.0]
      'on': b0
      force: 3.97*t - 12.23*s_dot
    inertia: [0.0343, 0.0343, 0.0343]
beams:
  m0:
    from: g
    section: s0
    to:
      body: b0
      offset: [0, 0, 0]
    elements: 3
    start:
      hinge:
        axis: [0.8, 0.574, -0.173]
        angle:
          table:
          - [0, 0]
          - [0.1, 0.05]
          - [1, 0.3]
    end:
      hinge:
        axis: [0.502, -0.828, 0.252]
        torque: p0_hinge*(-18.49*exp(-t) - 0.55*theta_dot)
        limits: [-0.597, 0.719]
  m1:
    from: b0
    section: s1
    to: b1
    elements: 2
    start:
      hinge:
        axis: [0.0, 1.0, -0.0]
        limits: [-0.517, 0.427]
        contact: {stiffness: 58566.0, damping: 20.62}
gravity: [0, 0, -9.81]
loads:
- at: m1.node[1]
  moment: [0, -18.39*sin(3*t), 0]
- at: g
  force: [-5.29*sin(3*t), 0, 0]
solve:
  analysis: transient
  method: newmark
  t_end: 0.09
  dt: 0.03
  tol: 1.0e-12
  sensitivities: [p0_hinge]
output:
  probes:
    p0: {point: m0.end, quantity: position, component: z}
    p1: {point: m0.end, quantity: position, component: y}
    h_m1_start: {hinge: m1.start, quantity: angle}
    g_slide: {guide: gd, quantity: rate}
parameters: {p0_hinge: 1.0}
"""


def test_a_trial_a_whole_turn_past_a_stop_is_cut_and_its_sensitivities_agree(tmp_path):
    """The trial of 0.03 s from t = 0.06 converged to θ = −6.17 at m0.end, 6.26 rad from θ_n + h θ̇_n (a root a whole
    turn away, latdyn.timeloop.progress.far_root); its landing kept a step of 0.00949 s short of the stop, a function
    of p through the search (δh = 0 taken): rows up to 1.77e-2 of the probe's largest sensitivity off, then refused
    (TransientSensitivities._refuse_landing_short). Now that trial is cut in half, as after a failure of Newton, and
    no landing is made: the run is solved and every row of the four probes agrees with central differences to
    1.6e-10 of its largest (benchmarks/fuzz_sensitivities.py --scene, 16 checks); here p0's within 1e-7 of
    Richardson differences (before: exit 1). Run to 0.09 s (it ran to 0.3): the prescribed angle's table has an inner
    node at t = 0.1, a kink, where the run now lands and applies the impulse it implies, a restart the sensitivities
    refuse (naming the law: tests/test_prescribed_motion_work.py)."""
    completed, _ = latdyn_run(tmp_path, TRIAL_PAST_A_STOP, quiet=True)
    assert completed.returncode == 0, completed.stderr
    assert ("the step from t = 0.06 of 0.03 converged to a root that puts hinge m0.end 6.26 rad from its predictor"
            in completed.stderr)
    _assert_agree(_run(TRIAL_PAST_A_STOP), TRIAL_PAST_A_STOP, ("p0",), "p0_hinge", 1e-3)


def test_a_landing_that_keeps_a_step_short_of_the_event_is_refused(monkeypatch):
    """A landing whose search ends short of the event keeps a step whose size is a function of p, not
    differentiated: refused when it happens, naming the joint and the cause, on the planar latch of
    tests/test_sensitivities_events.py with one pass of the search (its step kept 0.00121 rad short of the latch).
    (The fuzzer's scene that found it, seed 16 case 16, is now cut before any landing: the test above.)"""
    import latdyn.analyses.transient_sensitivities as transient_sensitivities

    with pytest.raises(latdyn.SolverError, match="shortened toward the lock_at 0.8 of arm.start"):
        monkeypatch.setattr(transient_sensitivities, "LANDING_PASSES", 1)
        latdyn.run(latdyn.load_scene(yaml.safe_load(LATCH_PLANAR)))


#: two hinged arms, the first latching: its law's ∂τ/∂θ = −k − 80 c θ θ̇ moves with the rate, and so does the
#: impulse's weight M + dt² K at the latch
LATCH_BESIDE_A_RATE_STIFFNESS = """
parameters: {k: 20.0, c: 0.5}
sections:
  s: {EA: 2.0e6, EIy: 900, EIz: 600, GJ: 500, rhoA: 1.2, rhoIy: 0.0004, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [0.8, 0.1, 0.3], mass: 0.7, inertia: [0.01, 0.02, 0.015]}
  d: {at: [1.3, 0.5, 0.2], mass: 0.4, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: g, to: b, section: s, elements: 1, start: {hinge: {axis: [0.2, 0.3, 1],
        torque: -k*theta - c*(1 + 40*theta**2)*theta_dot + 4.0, lock_at: 0.01}}}
  fore: {from: b, to: d, section: s, elements: 1, start: {hinge: {axis: [0, 0.4, 1],
        torque: -8*theta - c*(1 + 30*theta**2)*theta_dot - 2.0}}}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.2, dt: 0.01, tol: 1.0e-12, sensitivities: [k, c]}
output:
  probes:
    torque: {hinge: arm.start, quantity: torque}
    a2: {hinge: fore.start, quantity: angle}
    y: {point: d, quantity: position, component: y}
"""


def test_a_latch_beside_a_hinge_law_whose_stiffness_moves_with_the_rate():
    """The forward method takes ∂(K w)/∂v δv (1417580) for a hinge law as for a damped cable. Measured (h = 1e-3):
    every row within 1.2e-8 of its probe's largest sensitivity (k and c; the latch time 5e-10); with that term left
    out 2.1e-4 (y by k). A damping law in θ and a stiffness law in θ̇ beside the latch agree likewise (2.3e-8,
    8.9e-9; benchmarks/fuzz_sensitivity_scenes/o_latch_beside_a_rate_stiffness.yaml)."""
    result = _run(LATCH_BESIDE_A_RATE_STIFFNESS)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    _assert_agree(result, LATCH_BESIDE_A_RATE_STIFFNESS, ("torque", "a2", "y"), "k", 0.02)


def test_the_adjoint_takes_a_latch_beside_a_hinge_law_whose_stiffness_moves_with_the_rate():
    """The adjoint's transposed weight lacked that term: on LATCH_BESIDE_A_RATE_STIFFNESS its end rows were up to
    3.2e-4 (y by k) off the Richardson differences and the forward method's, reported as solved. With
    AdjointSensitivities._stiffness_by_rates_transposed: the torque law 2e-8 off the differences (60 checks with the
    forward method's), a damping law in theta 2.6e-8 (its summary 3.4e-13 from the forward method's), a stiffness law
    in theta_dot 6.8e-9 (2.0e-13)."""
    law = "torque: -k*theta - c*(1 + 40*theta**2)*theta_dot + 4.0"
    for written in (law, "stiffness: k, damping: c*(1 + 40*theta**2), torque: 4.0",
                    "stiffness: k*(1 + 0.1*theta_dot**2), damping: c, torque: 4.0"):
        _assert_adjoint_agrees(LATCH_BESIDE_A_RATE_STIFFNESS.replace(law, written), ("k", "c"))
    # no latch; the fore arm's hinge hits a rigid stop twice (restitution 0.95, t = 0.075 and 0.084): the impulse's
    # and the restart's terms. Measured: 2.1e-8 off the differences, 8.7e-13 from the forward method; with the
    # restart's transposed term left out 9.5e-5, with both 9.5e-5
    stops = (LATCH_BESIDE_A_RATE_STIFFNESS.replace(", lock_at: 0.01}}}", "}}}")
             .replace("theta_dot - 2.0}}}", "theta_dot - 0.5, limits: [-0.03, 0.5], restitution: 0.95}}}")
             .replace("t_end: 0.2", "t_end: 0.15"))
    _assert_adjoint_agrees(stops, ("k", "c"), kinds=["stop", "stop"])
