"""Issue 34: gradients the forward method refused on 86d57d9, now computed (docs/parameters.md, "Transient
sensitivities").

1. A point's velocity beside guides (in the global frame and in a body's, of the guided body itself, of a free node in
the guided body's axes, read by a controller that drives the guide): a guided body is a dependent node of the links'
reduction, whose rates δv_dep = P δv + ∂(J v)/∂q δq come from the generated ``prismatic_link_edge_rates_D_q``
(latdyn/analyses/link_sensitivities.py ``dependent_rates``, which the rigid links' velocities and the guided energies
already took). Against Richardson-extrapolated central differences of whole runs (``solve.tol`` 1e-12), the loop of
steps on and off to the bit, the adjoint against the forward method, the CLI against the API.

2. A parameter in a hinge's torque or a guide's force that names a continuous controller (``"Kt*pd + 0.1*Kt*Kt"``,
τ = a y + b with a, b of the parameter): ∂τ/∂p at fixed y is a derivative law reading the controller's output at the
state, as the step's own laws read it (the scene's ``controller_outputs``, the compiled derivative laws bound to them
on both paths); y's own δy is the step's matrix's coupling and, for a parameter inside the output too,
``ControllerTerms.add``'s a dy/dp. At a rigid stop the impulse weight's (∂K/∂p) w of such a parameter is the difference
of the static ∂r/∂p along w, which now reads y at the moved states (``TransientSensitivities._controller_outputs_at``;
left at the step's outputs the wheel's stop was 1.8e-7 off, the same at steps 1e-3 … 1e-5). A load component that names
a controller and a parameter, and static paths, stay refused.

3. Energy and momentum probes with cables: each element's strain energy ½ EA (ℓ − L0)²/L0 (where the recorded energy
counts it) by the generated ``cable_force``'s residual rows at c = 0 and its ``cable_strain_energy``, ``reel_force``
outputs; the lumped point masses' kinetic and potential energy and momenta as the joint bodies' rows they are, by rhoA
and the rest length through their masses (``energy_sensitivities._StateForms._cables``). The external work and the
dissipated energy with cables stay refused. And by a rigid link's section ρA, ρIy, ρIz: its joint body's mass and
inertia move (``rigid_link_inertia`` of the derivative values, as ∂r/∂p takes them), its energies and momenta as a
body's by its mass and inertia (``energy_sensitivities._StateForms._link_blocks``).

Every case here was refused on 86d57d9 (SceneError naming ``solve.sensitivities``)."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, the_loop_off_writes_the_same
from tests.reference_runs import reference_runs
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_cables import CABLE_3D
from tests.test_sensitivities_controllers import WHEEL
from tests.test_sensitivities_guides import GUIDE_3D, STOP_3D
from tests.test_sensitivities_refusals_lifted import BEAD_ON_GIMBAL, ENERGIES, _adjoint_error, _both
from tests.test_sensitivities_rigid_links import GIMBAL

#: a point's velocity: the guided slider's in the global frame and in the arm tip's axes, the tip's and the arm's
#: middle node's in the slider's axes
_VELOCITIES = ("    slider_vz: {point: slider, quantity: velocity, component: z}\n"
               "    slider_vx: {point: slider, quantity: velocity, component: x}\n"
               "    slider_vt: {point: slider, quantity: velocity, frame: tip, component: y}\n"
               "    tip_vs: {point: tip, quantity: velocity, frame: slider, component: x}\n"
               "    mid_vs: {point: \"arm.node[1]\", quantity: velocity, frame: slider, component: z}\n")
_SLIDE = "    s: {guide: slider, quantity: position}\n"
#: the mass on a skew guide at the tip of the flexible 3D arm with the velocity probes, the guide's force a controller
#: of the slider's and the tip's velocities (gain Kv)
GUIDE_VELOCITY = (GUIDE_3D.replace("parameters: {k:", "parameters: {Kv: 0.8, k:")
                  .replace('rest: "rest"}}', 'rest: "rest", force: "damp"}}')
                  .replace("solve: {", 'controllers:\n  damp: {output: "-Kv*slider_vz - 0.3*Kv*tip_vy"}\nsolve: {')
                  .replace(_SLIDE, _SLIDE + _VELOCITIES
                           + "    tip_vy: {point: tip, quantity: velocity, component: y}\n")
                  .replace("sensitivities: [k, m, EI, rest]", "sensitivities: [Kv, k, m, EI]"))
#: the slider hitting its rigid stop (e = 0.5) with the velocity probes
STOP_VELOCITY = STOP_3D.replace(_SLIDE, _SLIDE + _VELOCITIES)
#: the bead on a skew guide on the gimbal's inner ring (rigid links), hitting its stops three times, its velocity probed
BEAD_VELOCITY = BEAD_ON_GIMBAL.replace(
    "    bead_y:", "    bead_vy: {point: bead, quantity: velocity, component: y}\n"
    "    bead_vz: {point: bead, quantity: velocity, component: z}\n"
    "    tip_vb: {point: tip, quantity: velocity, frame: bead, component: x}\n    bead_y:")
assert "damp:" in GUIDE_VELOCITY and "slider_vt" in STOP_VELOCITY and "bead_vy" in BEAD_VELOCITY


def _run(text: str, **parameters):
    """``text`` through the API at ``parameters``, Newton's tolerance 1e-12 (the references' runs too)."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    data["solve"]["tol"] = 1e-12
    return latdyn.run(latdyn.load_scene(data))


def _richardson_error(text: str, result, name: str, relative: float = 1e-4) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (each probe over its rows, relative to its largest)
    against Richardson-extrapolated central differences of whole runs (steps ``relative`` and half of it); the event
    times' derivatives (summary.json event_sensitivities) likewise, relative to the largest."""
    p0 = yaml.safe_load(text)["parameters"][name]
    run = reference_runs(text, result, lambda **moved: _run(text, **moved))
    central, times = [], []
    for step in (relative * abs(p0), relative / 2 * abs(p0)):
        up, down = run(**{name: p0 + step}), run(**{name: p0 - step})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        worst = max(worst, np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max())
    if len(times[0]):
        expected = (4 * times[1] - times[0]) / 3
        computed = np.array([event["dt"][name] for event in result.summary["event_sensitivities"]])
        worst = max(worst, np.abs(computed - expected).max() / np.abs(expected).max())
    return worst


# ------------------------------------------------------------------------------ 1. a point's velocity beside guides
@pytest.mark.parametrize("text, names, events", [
    (GUIDE_VELOCITY, ["Kv", "m"], []), (STOP_VELOCITY, ["EI"], ["stop"]), (BEAD_VELOCITY, ["ks"], ["stop"] * 3)],
    ids=["guide-controller", "guide-stop", "guide-on-links-stops"])
def test_a_points_velocity_beside_guides_agrees_with_richardson_central_differences(text, names, events):
    """Measured (every probe's worst over the rows, relative to its largest; the event times too): the guide with the
    controller Kv 4.0e-8, k 2.1e-9, m 2.5e-9, EI 3.6e-9 (the body frames' velocities without the controller k 9.3e-9,
    m 6.1e-9, EI 2.3e-9); the stop k 2.8e-9, m 2.7e-9, EI 3.4e-9; the bead on the gimbal ks 7.5e-9, k1 8.5e-10,
    ms 1.9e-9."""
    result = _run(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    for name in names:
        assert _richardson_error(text, result, name) <= 1e-6, name


@pytest.mark.parametrize("text", [GUIDE_VELOCITY, STOP_VELOCITY, BEAD_VELOCITY],
                         ids=["guide-controller", "guide-stop", "guide-on-links-stops"])
def test_a_points_velocity_beside_guides_is_the_same_with_the_loop_on_and_off(text):
    """The loop of steps takes the smooth steps (80 of 80, 59 of 61, 27 of 33) and writes the per-step Python path's
    sensitivities to the bit; the adjoint gives the forward method's (measured 7.0e-13, 5.3e-14, 2.5e-12)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="some")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0
    forward, adjoint = _both(text)
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_a_points_velocity_beside_guides_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the guide with the controller: summary.json's probe sensitivities those of ``latdyn.run`` on
    the same text to the bit, sensitivities.csv's end row too; the loop off in a fresh process writes the same files."""
    run, out = latdyn_run(tmp_path, GUIDE_VELOCITY)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(GUIDE_VELOCITY)))
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    header, *_, last = (out / "sensitivities.csv").read_text().splitlines()
    columns = dict(zip(header.split(","), (float(x) for x in last.split(","))))
    assert columns["slider_vz/Kv"] == api.summary["probe_sensitivities"]["slider_vz"]["end"]["Kv"]
    the_loop_off_writes_the_same(tmp_path, out)


# -------------------------------------------------- 2. a parameter in a hinge torque or guide force naming a controller
#: the wheel on a hinge out of the coordinate planes turned by chained controllers
#: (tests/test_sensitivities_controllers.py), its torque Kt pd + 0.1 Kt² (pd clipped from 0.15 s to 0.20 s), Kt inside
#: pd's output too
WHEEL_KT = (WHEEL.replace("parameters: {Kp", "parameters: {Kt: 2.0, Kp")
            .replace('torque: "2*pd + 0.1"', 'torque: "Kt*pd + 0.1*Kt*Kt"')
            .replace('- 0.5*(tip_x - 0.66)"', '- 0.5*Kt*(tip_x - 0.66)"')
            .replace("sensitivities: [Kp, a0, g, k, Kl]", "sensitivities: [Kt, Kp, k]"))
#: the same with a set point of the angle (no law in t) and a rigid stop at 0.2 rad (e = 0.8), hit twice
WHEEL_KT_STOPS = (WHEEL_KT.replace('lead: {output: "a0 + g*sin(3*t)"}', 'lead: {output: "a0 + 0.3*angle"}')
                  .replace('torque: "Kt*pd + 0.1*Kt*Kt"',
                           'torque: "Kt*pd + 0.1*Kt*Kt", limits: [-1, 0.2], restitution: 0.8')
                  .replace("t_end: 0.5", "t_end: 0.4"))
#: the mass on the skew guide at the flexible arm's tip, the guide's force Kf damp + 0.1 Kf of a controller of the
#: slide, hitting its rigid stop (e = 0.5)
GUIDE_KF_STOP = (STOP_3D.replace("parameters: {k:", "parameters: {Kf: 1.5, Kv: 0.8, k:")
                 .replace("restitution: 0.5}}", 'restitution: 0.5, force: "Kf*damp + 0.1*Kf"}}')
                 .replace("solve: {", 'controllers:\n  damp: {output: "-Kv*s_rate - 0.5*s"}\nsolve: {')
                 .replace("sensitivities: [k, m, EI, rest]", "sensitivities: [Kf, Kv, k]"))
assert "Kt*pd" in WHEEL_KT and "restitution: 0.8" in WHEEL_KT_STOPS and "Kf*damp" in GUIDE_KF_STOP


@pytest.mark.parametrize("text, name, events, tolerance", [
    (WHEEL_KT, "Kt", [], 1e-6), (WHEEL_KT_STOPS, "Kt", ["stop", "stop"], 1e-7), (GUIDE_KF_STOP, "Kf", ["stop"], 1e-7)],
    ids=["wheel", "wheel-stops", "guide-stop"])
def test_a_parameter_in_a_joint_law_naming_a_controller_agrees_with_richardson_central_differences(text, name, events,
                                                                                                  tolerance):
    """Measured (every probe's worst over the rows, relative to its largest; the event times too): the wheel Kt 1.9e-8
    (Kt in the torque alone 1.7e-8); its stops Kt 2.4e-9; the guide's stop Kf 1.5e-8 (without the stop Kf 3.3e-8, Kv
    2.4e-8). With the impulse weight's difference reading y at the step's outputs (not the moved states') the stops
    were 3.7e-7 and 9.0e-7 off: hence 1e-7 there."""
    result = _run(text)
    assert [e["kind"] for e in result.summary["events"]] == events
    assert _richardson_error(text, result, name) <= tolerance


@pytest.mark.parametrize("text", [WHEEL_KT, WHEEL_KT_STOPS, GUIDE_KF_STOP], ids=["wheel", "wheel-stops", "guide-stop"])
def test_a_parameter_in_a_joint_law_naming_a_controller_is_the_same_with_the_loop_on_and_off(text):
    """The loop takes the smooth steps (50 of 50, 38 of 42, 59 of 61) to the per-step Python path's bits; the adjoint
    gives the forward method's where it takes the run (no law in t beside the events: measured 1.7e-13 on the wheel's
    stops, 6.5e-14 on the guide's)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0
    if text is not WHEEL_KT:   # WHEEL_KT's lead is a law in t beside no event: the adjoint takes it too
        forward, adjoint = _both(text)
        assert _adjoint_error(forward, adjoint) <= 1e-10


def test_a_parameter_in_a_joint_law_naming_a_controller_through_the_cli_equals_the_api(tmp_path):
    """``latdyn run`` of the wheel's stops: summary.json's probe and event sensitivities those of ``latdyn.run`` to the
    bit; the loop off in a fresh process writes the same files."""
    run, out = latdyn_run(tmp_path, WHEEL_KT_STOPS)
    assert run.returncode == 0, run.stderr
    summary = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(WHEEL_KT_STOPS)))
    assert summary["probe_sensitivities"] == api.summary["probe_sensitivities"]
    assert summary["event_sensitivities"] == api.summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


def test_a_load_naming_a_controller_and_a_parameter_stays_refused():
    """A load component's derivative law is one of t alone: ``"0.5*push + Kl"`` stays refused naming the key."""
    data = yaml.safe_load(WHEEL)
    data["loads"][0]["moment"] = ["0.5*push + Kl", 0, 0]
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities"
    assert "used at loads[0].moment[0], a law that names a controller" in str(info.value)


# ---------------------------------------------------------------------------- 3. energies and momenta with cables
_ENERGIES = ("    T: {energy: kinetic}\n    U: {energy: strain}\n    V: {energy: potential}\n    E: {energy: total}\n"
             "    px: {momentum: linear, component: x}\n    hz: {momentum: angular, component: z}\n")
#: a tip mass on the flexible 3D arm falls until a skew damped stay catches it, slack and taut twice, energies probed
CABLE_ENERGIES = CABLE_3D.replace("    tip_z:", _ENERGIES + "    tip_z:")
#: the same stay with mass (rhoA, two elements: lumped point masses, an inner node), taut and slack twice to 0.12 s
MASSIVE_CABLE_ENERGIES = (CABLE_ENERGIES.replace('damping: "c"}', 'damping: "c", rhoA: "rho", elements: 2}')
                          .replace("parameters: {EA", "parameters: {rho: 0.3, EA")
                          .replace("sensitivities: [EA, L, EI, c]", "sensitivities: [rho, L, EA]")
                          .replace("t_end: 0.25", "t_end: 0.12"))
#: the gimbal of two rigid rings (section ρA = rho, ρIy = 0.001 rho) carrying a flexible boom, under gravity, its
#: energies and momenta probed
GIMBAL_ENERGIES = (GIMBAL.replace("sections:", "gravity: [0, 0, -9.81]\nsections:", 1)
                   .replace("    tip_x:", ENERGIES + "    V: {energy: potential}\n    tip_x:"))
assert "U: {energy: strain}" in CABLE_ENERGIES and 'rhoA: "rho"' in MASSIVE_CABLE_ENERGIES
assert "gravity:" in GIMBAL_ENERGIES and "V: {energy: potential}" in GIMBAL_ENERGIES


@pytest.mark.parametrize("text, name, changes", [(CABLE_ENERGIES, "EA", 4), (MASSIVE_CABLE_ENERGIES, "rho", 4),
                                                 (GIMBAL_ENERGIES, "rho", 0)],
                         ids=["stay", "stay-with-mass", "rigid-links-rho"])
def test_energies_and_momenta_with_cables_or_by_a_rigid_links_rho_agree_with_richardson(text, name, changes):
    """Measured (every probe's worst over the rows, relative to its largest; the cable's changes' times too): the stay
    EA 6.5e-9, c 1.9e-7, EI 1.3e-8, L 1.8e-7 (steps 1e-5 relative); with mass rho 1.4e-8, EA 1.6e-8, L 4.9e-9 (steps
    1e-6 relative; to 0.25 s, eight changes: rho 1.9e-8, EA 1.9e-8, L 6.9e-8); the gimbal by its rings' rho 2.1e-9
    (its latch, without gravity, 4.8e-9; with the rings' mass and inertia left out of the forms T, U, px, hz were
    0.94–3.3 off). With the cable rows of the strain energy of the wrong sign U and E were 1.2–21 off (EA, c, EI)."""
    result = _run(text)
    assert len(result.summary["events"]) == changes
    assert _richardson_error(text, result, name) <= 1e-6


@pytest.mark.parametrize("text", [CABLE_ENERGIES, MASSIVE_CABLE_ENERGIES, GIMBAL_ENERGIES],
                         ids=["stay", "stay-with-mass", "rigid-links-rho"])
def test_energies_and_momenta_with_cables_or_by_a_rigid_links_rho_are_the_same_with_the_loop_on_and_off(text):
    """The loop takes the smooth steps (46 of 62, 15 of 60) to the Python path's bits; the adjoint gives the forward
    method's (measured 7.8e-12, 1.0e-12, the gimbal 1.5e-12; the gimbal's tether 7.0e-12)."""
    runs = runs_with_the_loop_on_and_off(text)
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0
    forward, adjoint = _both(text)
    assert _adjoint_error(forward, adjoint) <= 1e-10


def test_the_external_work_with_cables_stays_refused():
    """A reel's work and a damped element's dissipation are sums over the steps not differentiated yet: refused naming
    ``solve.sensitivities`` and the probe."""
    data = yaml.safe_load(CABLE_ENERGIES)
    data["output"]["probes"]["W"] = {"energy": "external_work"}
    with pytest.raises(SceneError) as info:
        latdyn.run(latdyn.load_scene(data))
    assert info.value.key == "solve.sensitivities" and "external work with cables" in str(info.value)
