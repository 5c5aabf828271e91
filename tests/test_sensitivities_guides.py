"""Transient sensitivities of guided bodies (bodies.NAME.guide; latdyn/analyses/transient_sensitivities.py,
docs/parameters.md "Guides"): a guide's stiffness, damping and rest, the guided body's mass and the sections
of the beam that carries it, against Richardson-extrapolated central differences of whole runs (perturbations
1e-4 and 5e-5 relative), through a guide's latch and stop on a moving body; the reduction's M and C,
which the step's derivative uses as they are, against differences of the residual."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError

#: a bead on a rod that a prescribed motion turns at Ω = 2 rad/s, on a spring along the rod: the centrifugal
#: pull mΩ² s against k — the Coriolis and centrifugal terms of a guide on a moving body
BEAD = """
title: a bead on a rod turning at a constant rate, held by a spring
parameters: {k: 3.0, c: 0.1, m: 0.5, rest: 0.05}
bodies:
  rod: {at: [0, 0, 0], motion: {rotation: {axis: [0, 0, 1], angle: "2.0*t"}}}
  bead: {at: [0.2, 0, 0], mass: "m", inertia: [0.001, 0.001, 0.001],
         guide: {'on': rod, axis: [1, 0, 0], stiffness: "k", damping: "c", rest: "rest"}}
solve: {analysis: transient, dt: 0.01, t_end: 1.0, sensitivities: [k, c, m, rest]}
output:
  every: 0.05
  probes:
    x: {point: bead, quantity: position, component: x}
    y: {point: bead, quantity: position, component: y}
    s: {guide: bead, quantity: position}
"""

#: a mass on a skew guide (axis (1, −2, 2)/3) fixed to the tip body of a flexible arm with rotary inertia,
#: out of the coordinate planes, under gravity
GUIDE_3D = """
title: a mass sliding on a skew guide at the tip of a flexible arm, under gravity
parameters: {k: 40.0, c: 0.3, m: 0.4, rest: 0.02, EI: 30.0}
gravity: [0, 0, -9.81]
sections:
  s: {EA: 100000.0, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.001, rhoIz: 0.0013}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.6666666666666666], mass: 0.2, inertia: [0.002, 0.003, 0.004]}
  slider: {at: [0.7, 0.35, 0.7], mass: "m", inertia: [0.001, 0.002, 0.0015],
           guide: {'on': tip, axis: [1, -2, 2], stiffness: "k", damping: "c", rest: "rest"}}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
solve: {analysis: transient, dt: 0.005, t_end: 0.4, sensitivities: [k, m, EI, rest]}
output:
  every: 0.01
  probes:
    s: {guide: slider, quantity: position}
    slider_z: {point: slider, quantity: position, component: z}
    slider_y: {point: slider, quantity: position, component: y}
    mid_x: {point: "arm.node[1]", quantity: displacement, component: x}
"""


def _run(text: str, only: str | None = None, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    return latdyn.run(latdyn.load_scene(data))


def _agree(result, text: str, name: str, tolerance: float = 1e-6) -> float:
    """The largest error of ``result``'s sensitivities by ``name`` (each probe over the rows, relative to its
    largest) against Richardson-extrapolated central differences (1e-4 and 5e-5 relative); the event times'
    derivatives (summary.json event_sensitivities) likewise."""
    p0 = yaml.safe_load(text)["parameters"][name]
    central, times = [], []
    for step in (1e-4 * abs(p0), 5e-5 * abs(p0)):
        up, down = _run(text, name, **{name: p0 + step}), _run(text, name, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step) for a, b in zip(up.summary["events"],
                                                                              down.summary["events"])]))
    expected_dt = (4 * times[1] - times[0]) / 3
    computed_dt = [event["dt"][name] for event in result.summary["event_sensitivities"]]
    assert computed_dt == pytest.approx(expected_dt, rel=1e-6), name
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
        assert error <= tolerance, (probe, name, error)
        worst = max(worst, error)
    return worst


@pytest.fixture(scope="module")
def bead():
    return _run(BEAD)


@pytest.mark.parametrize("name", ["k"])
def test_a_bead_on_a_turning_rod_agrees_with_richardson_central_differences(bead, name):
    """Measured: k 8.5e-10 of each probe's largest sensitivity (and m 3.7e-10, c 2.1e-10, rest 1.1e-10, not
    run here to keep the file fast)."""
    assert bead.probes["s"][-1] > 0.4   # the centrifugal pull drives it out along the rod
    _agree(bead, BEAD, name)


#: GUIDE_3D's slider latching at s = −0.05 (t = 0.240 s), and bouncing off a rigid stop there with
#: restitution 0.5 (ending before it comes back to rest on it)
LATCH_3D = GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", lock_at: -0.05}}')
STOP_3D = GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", limits: [-0.05, 1.0], restitution: 0.5}}').replace(
    "t_end: 0.4", "t_end: 0.3")


@pytest.mark.parametrize("text, kind, name", [(LATCH_3D, "latch", "EI"), (STOP_3D, "stop", "m")])
def test_a_3d_guide_latching_or_hitting_its_stop_on_a_flexible_arm_agrees_with_richardson_central_differences(
        text, kind, name):
    """The hinges' event machinery on the slide, on a guide whose body moves (the tip of the flexible arm):
    the impulse weight M + dt²K of the reduction depends on the rates through its geometric term, which the
    jump's derivative follows. Measured: latch k 2.4e-8, m 5.8e-9, EI 5.7e-9, rest 1.3e-8; stop k 3.9e-8,
    m 1.0e-8; the event times to 1e-9; without the latch and the stop k 5.7e-9, m 3.3e-10, EI 3.7e-10,
    rest 1.3e-8 (the run before the event is each test's first 0.24 s)."""
    result = _run(text, name)
    assert [(e["joint"], e["kind"]) for e in result.summary["events"]] == [("slider", kind)]
    _agree(result, text, name)


def test_the_reductions_mass_and_damping_matrices_of_a_guided_body_are_the_residuals_derivatives():
    """The step's derivative takes M and C of the reduction onto the slide as they are (and K, which the
    reduction leaves incomplete, as r_q by differences): at a moving state of the bead (after 0.5 s) M and C
    against central differences of the residual by the accelerations and the rates (measured ≤ 1e-9 of
    max|·|), while the reduction's K misses the centrifugal −mΩ² (what _guided_matrices takes instead)."""
    from latdyn.analyses.linearisation import tangent_q_by_differences
    from latdyn.assembly.assembler import free_acceleration, free_velocity, unpack_free
    from latdyn.assembly.prepare import prepare

    data = yaml.safe_load(BEAD)
    data["solve"]["t_end"] = 0.5
    data["solve"].pop("sensitivities")
    scene = latdyn.load_scene(data)
    result = latdyn.run(scene)
    prepared = prepare(latdyn.load_scene(data))
    assembler, model = prepared.assembler, prepared.model
    state = prepared.state.copy()
    s, rate = result.probes["s"][-1], 0.3
    state.theta[0], state.theta_dot[0], state.theta_ddot[0], state.t = s, rate, 0.7, 0.5
    assembler.complete_links(state)
    ev = assembler.evaluate(state, matrices=True)
    M, C, K = (np.asarray(ev.combined(*c, dense=True)) for c in ((1, 0, 0), (0, 1, 0), (0, 0, 1)))

    def residual(rates, accelerations):
        moved = state.copy()
        unpack_free(model, rates, moved.v, moved.w, moved.theta_dot)
        unpack_free(model, accelerations, moved.a, moved.alpha, moved.theta_ddot)
        assembler.complete_links(moved)
        return assembler.evaluate(moved, matrices=False).residual

    v, a, eta = free_velocity(model, state), free_acceleration(model, state), 1e-6
    unit = np.eye(model.n_dofs)
    dM = np.column_stack([(residual(v, a + eta * e) - residual(v, a - eta * e)) / (2 * eta) for e in unit])
    dC = np.column_stack([(residual(v + eta * e, a) - residual(v - eta * e, a)) / (2 * eta) for e in unit])
    assert np.abs(dM - M).max() <= 1e-9 * np.abs(M).max()
    assert np.abs(dC - C).max() <= 1e-9 * max(np.abs(C).max(), 1.0)
    exact = tangent_q_by_differences(assembler, state)
    assert abs((exact - K)[0, 0] + 0.5 * 2.0 ** 2) <= 1e-6   # −mΩ², the centrifugal stiffness


def test_guide_events_with_laws_in_time_and_friction_are_refused_naming_the_key(tmp_path):
    """A latch on a guide whose rod turns by a prescribed motion (a law in t: the event moves the later steps
    in time), and friction on a guide, are refused before the run (exit 2 from the CLI, naming
    solve.sensitivities and the guided body, no traceback)."""
    from tests.cli_runs import latdyn_run

    latch = BEAD.replace('rest: "rest"}}', 'rest: "rest", lock_at: 0.3}}')
    with pytest.raises(SceneError, match="bead") as refused:
        _run(latch)
    assert refused.value.key == "solve.sensitivities"
    rubbing = GUIDE_3D.replace('rest: "rest"}}', 'rest: "rest", friction: {coulomb: 0.1}}}')
    with pytest.raises(SceneError, match="friction") as refused:
        _run(rubbing)
    run, _ = latdyn_run(tmp_path, latch.replace("'on'", "on"))
    assert run.returncode == 2 and "solve.sensitivities" in run.stderr and "Traceback" not in run.stderr
