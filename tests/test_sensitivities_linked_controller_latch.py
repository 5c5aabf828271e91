"""A gain multiplying a velocity read on a node that follows rigid links, through a latch: the event's (∂K/∂p) w at the
assembled rates held (latdyn/analyses/transient_sensitivities.py ``_advanced_at_held_rates``; docs/parameters.md, "The
impulse weight's derivative").

With rigid links or guides and a continuous controller the event's (∂K/∂p) w is a central difference of the static
∂r/∂p along w. The evaluation's K_red = Pᵀ K_all P + ∂Pᵀ/∂q · r_all is ∂r/∂q at every assembled rate held, the
dependent nodes' too (latdyn/assembly/linked.py: the dependent rates' move with q is not in the impulse's weight);
f3ab00e's difference completed the dependent nodes' rates at each moved configuration (``ProbeSet.values`` completes the
links in place), so it held Pᵀ (∂C_all/∂p) ∂(J v)/∂q w beside (∂K_red/∂p) w wherever ∂y/∂p reads a dependent node's
velocity: the gimbal's PD of a point's velocities on its inner ring (tests/test_weight_derivative_linked_last.py) was
2.7e-4 off Richardson differences of whole runs by its gain. A gain of a position read, a hinge's rate, and the same PD
without links were right.

On 3D YAML scenes: the gimbal of rigid links on skew hinges latching (t = 0.2727 s), its outer hinge driven by a PD of
its angle and the outer ring's velocity (a dependent node's, kind 3) — the smallest that shows it — and the gimbal with
its boom starting at an offset on the inner ring, a PD of that point's velocity (v + ω × T r, kind 6) and its velocity
in the tip body's axes (kind 13) each with its own gain; (∂K/∂p) w at a turned state with random rates against
Richardson-extrapolated differences of the evaluation's K w by the parameter (the scene prepared at p ± h); whole runs
by the gain against Richardson central differences of whole runs, through the API and ``latdyn run`` (loop on and off),
the adjoint's against the forward method's."""
from __future__ import annotations

import csv
from types import SimpleNamespace

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.assembler import unpack_free
from latdyn.assembly.prepare import prepare
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_adjoint_in_loop_links import _adjoint, _largest_gap
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_rigid_links import LATCH


def _with_pd(text: str, output: str, reads: str, sensitivities: str) -> str:
    """``text`` (the latching gimbal) with gains Kp, Kd, Kr, its outer hinge driven by a PD ``output`` of ``reads``
    (probes, read by the controller by name), ``solve.sensitivities`` ``sensitivities``."""
    out = (text.replace("parameters: {k1: 6.0,", "parameters: {Kp: 0.8, Kd: 0.5, Kr: 0.3, k1: 6.0,")
           .replace('stiffness: "k1", rest_angle: "rest"}}}', 'stiffness: "k1", rest_angle: "rest", torque: "pd"}}}')
           .replace("solve: {", f'controllers:\n  pd: {{output: "{output}"}}\nsolve: {{')
           .replace("    a1: {", reads + "    a1: {")
           .replace("sensitivities: [k1, m, P, EI, rho]", f"sensitivities: [{sensitivities}]"))
    assert out.count("pd") == 2 and "Kd: 0.5" in out and sensitivities in out
    return out


#: the gimbal latching (t = 0.2727 s), a PD of the outer hinge's angle and the outer ring's velocity's y (a node that
#: follows the links; no offset) driving the outer hinge
NODE_VELOCITY = _with_pd(LATCH, "Kp*(0.1 - a1) - Kd*vo", "", "Kd, k1")
#: the gimbal, its boom starting at an offset on the inner ring, a PD of that point's velocity (v + ω × T r) and its
#: velocity in the tip body's axes, nonlinear in them and the point's position, each velocity with its own gain;
#: Newton to 1e-12 (at the default tolerance the probe of the velocity in the tip's axes by Kr was 1.8e-6 off
#: Richardson differences of whole runs, round-off of the runs' own solutions)
OFFSET_VELOCITIES = _with_pd(
    LATCH.replace("boom: {from: inner, to: tip,", "boom: {from: {body: inner, offset: [0.04, 0.03, -0.05]}, to: tip,"),
    "Kp*(0.1 - by) - 0.3*Kd*vy*(1 + 2*by) - 0.2*Kp*vy**2 + Kr*vr*(1 + 2*by)",
    "    by: {point: boom.start, quantity: position, component: y}\n"
    "    vy: {point: boom.start, quantity: velocity, component: y}\n"
    "    vr: {point: boom.start, quantity: velocity, frame: tip, component: z}\n", "Kp, Kd, Kr, k1"
).replace("solve: {", "solve: {tol: 1.0e-12, ")
assert "offset: [0.04" in OFFSET_VELOCITIES and "tol: 1.0e-12" in OFFSET_VELOCITIES and "vr: {point: boom.start" in OFFSET_VELOCITIES
#: the smallest scene's PD with a state E reading the outer ring's velocity too (dE/dt = vo (1 + a1) − E/2) and its gain
#: Kr: its held δS's move along w is in the same difference (the adjoint refuses a state reading a rate)
NODE_VELOCITY_STATE = (NODE_VELOCITY.replace('pd: {output: "Kp*(0.1 - a1) - Kd*vo"}',
                                             'pd: {output: "Kp*(0.1 - a1) - Kd*vo + Kr*E", states: {E: "vo*(1 + a1) - 0.5*E"}}')
                       .replace("sensitivities: [Kd, k1]", "sensitivities: [Kd, Kr]"))
assert "states: {E" in NODE_VELOCITY_STATE and "[Kd, Kr]" in NODE_VELOCITY_STATE


def _stiffness_by_parameters(text: str):
    """(names, the package's (∂K/∂p) w (n, k) with the inertia forces' geometric term, its Richardson reference) at
    the scene's initial state turned and deformed by 0.05 times a normal draw, random rates and accelerations and a
    random w: the reference the evaluation's reduced K w of the scene prepared at p ± h, h/2 (h = 0.1 p: K is
    linear in these parameters, and the difference's round-off, K w of the elements ~1e5 times its ε over 2h, shrinks
    with the step), at that state, extrapolated."""
    data = yaml.safe_load(text)
    prepared = prepare(latdyn.load_scene(data))
    assembler, model = prepared.assembler, prepared.model
    rng = np.random.default_rng(11)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.05 * rng.normal(size=n))
    unpack_free(model, rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    assembler.complete_links(state)
    owner = TransientSensitivities(prepared)
    w = rng.normal(size=n)
    computed = owner._stiffness_derivative(state, w) + owner._geometric_derivative(state, w)

    def product(name, value):
        moved = yaml.safe_load(text)
        moved["parameters"][name] = value
        evaluation = prepare(latdyn.load_scene(moved)).assembler.evaluate(state.copy(), matrices=True)
        return np.asarray(evaluation.combined(0.0, 0.0, 1.0) @ w).reshape(-1)

    reference = np.zeros_like(computed)
    for c, name in enumerate(owner.names):
        p0 = data["parameters"][name]
        h = 0.1 * abs(p0)
        d1, d2 = ((product(name, p0 + s) - product(name, p0 - s)) / (2 * s) for s in (h, h / 2))
        reference[:, c] = (4 * d2 - d1) / 3
    return owner.names, computed, reference


@pytest.mark.parametrize("text", [NODE_VELOCITY, OFFSET_VELOCITIES], ids=["a node's velocity", "a point's velocities"])
def test_the_parameters_stiffness_derivative_holds_the_dependent_rates(text):
    """(∂K/∂p) w on the linked gimbal by each gain against Richardson-extrapolated differences of the evaluation's K w
    by the parameter (relative to the column's largest; the node's velocity's Kd, whose column K does not hold, to the
    largest of all): measured ≤ 4.1e-8 (Kd on the point's velocity; the node's velocity's Kd exactly 0, k1 1.7e-11);
    f3ab00e completed the dependent rates along w and was 4.4e-3 off by Kd on the node's velocity,
    1.7e-3 (Kp), 0.85 (Kd), 4.0e-3 (Kr) on the point's; the hinge's stiffness k1 was right on both (1.5e-11)."""
    names, computed, reference = _stiffness_by_parameters(text)
    largest = float(np.max(np.abs(reference)))
    errors = {name: float(np.max(np.abs(computed[:, c] - reference[:, c]))
                          / (float(np.max(np.abs(reference[:, c]))) or largest))   # a node's velocity: K holds no Kd
              for c, name in enumerate(names)}
    assert max(errors.values()) <= 5e-7, errors


def _sensitivity_columns(out) -> dict:
    """sensitivities.csv of a results folder: {(probe, parameter): column}."""
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    return {tuple(key.split("/")): np.array([float(r[key]) for r in rows]) for key in rows[0] if key != "t"}


@pytest.fixture(scope="module")
def node_velocity_run():
    """The smallest scene through the API."""
    return latdyn.run(latdyn.load_scene(yaml.safe_load(NODE_VELOCITY)))


def test_a_gain_of_a_dependent_nodes_velocity_agrees_with_richardson_through_the_latch(node_velocity_run):
    """The gimbal's whole runs by Kd (the gain of the outer ring's velocity) through the latch against Richardson
    central differences of whole runs (measured 1.5e-8; f3ab00e 6.2e-5 off on tip_x, 1.25e-4 on the worst probe at
    solve.tol 1e-12), and the adjoint's derivatives against the forward method's (2.2e-12)."""
    result = node_velocity_run
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _agree(result, NODE_VELOCITY, "Kd", tolerance=1e-6) < 1e-6
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(_adjoint(NODE_VELOCITY))))
    assert _largest_gap(adjoint.summary["probe_sensitivities"], result.summary["probe_sensitivities"]) <= 1e-10


def test_the_smallest_scene_through_the_cli_loop_on_and_off(tmp_path, node_velocity_run):
    """``latdyn run`` of the smallest scene: the sensitivities.csv it writes by Kd against Richardson central differences
    of whole runs (f3ab00e's 6.2e-5 off), the API's, its event sensitivities the API's, and the loop of steps off
    writing the same bytes (the events take the Python path on both)."""
    run, out = latdyn_run(tmp_path, NODE_VELOCITY, quiet=True)
    assert run.returncode == 0, run.stderr
    summary = summary_of(out)
    assert [e["kind"] for e in summary["events"]] == ["latch"]
    columns = _sensitivity_columns(out)
    written = SimpleNamespace(sensitivities=columns, summary=summary, probes=None)
    assert _agree(written, NODE_VELOCITY, "Kd", tolerance=1e-6) < 1e-6
    for (probe, name), values in node_velocity_run.sensitivities.items():
        np.testing.assert_allclose(columns[(probe, name)], values, rtol=1e-14, atol=1e-15 * np.abs(values).max())
    assert summary["event_sensitivities"] == yaml.safe_load(yaml.safe_dump(
        node_velocity_run.summary["event_sensitivities"]))
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("gain", ["Kd", "Kr"])
def test_the_gains_of_a_points_velocities_at_an_offset_agree_with_richardson(gain):
    """The gimbal with its boom at an offset on the inner ring: whole runs by the gain of the point's velocity (Kd) and
    of its velocity in the tip's axes (Kr) against Richardson differences of whole runs (measured 2.0e-8 and 7.7e-8;
    on f3ab00e tip_x was 2.0e-4 and 1.0e-2 off)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(OFFSET_VELOCITIES)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _agree(result, OFFSET_VELOCITIES, gain, tolerance=1e-6) < 1e-6


def test_a_gain_of_a_dependent_nodes_velocity_beside_a_state_agrees_with_richardson():
    """The smallest scene with the PD's state reading the outer ring's velocity: whole runs by Kd through the latch
    against Richardson differences of whole runs (measured 8.9e-9; at solve.tol 1e-12 1.27e-4 off on f3ab00e, 8.2e-9
    here; the state's gain Kr 1.3e-7 on both, the reference's own error between its steps)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(NODE_VELOCITY_STATE)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert _agree(result, NODE_VELOCITY_STATE, "Kd", tolerance=1e-6) < 1e-6
