"""The parameters' part of an event's impulse weight derivative, (∂K/∂p) w, generated for a cable's rest length and
ρA and for compliant stops' and friction's laws (latdyn/analyses/parameter_stiffness.py, docs/parameters.md "The
impulse weight's derivative"): the two new kernels against Richardson differences of what they differentiate; on
genuinely 3D latching booms under a skew gravity — a massive cable whose rest length and ρA are parameters, a spar
pressed on its hinge's compliant stop, a wheel's hinge slipping with friction — no parameter takes the central
difference along w, and each column agrees with Richardson differences *in the parameter* of the evaluation's K w
(the blocks a parameter can move: the elements' left out, whose round-off would swamp the reference). The old
difference along w of the static ∂r/∂p left the cable's masses' weight out of K (the static ∂r/∂p holds no cable
weight): ρA's column was 0 (1.0 off) and a rest length's 0.05–0.3 off; through the latch the whole runs'
sensitivities by them were 2.1e-6 and 3.1e-6 off Richardson differences of whole runs, now ≤ 5.3e-9; the loop of
steps on and off (API and ``latdyn run``) give the same bits. Beside a PD controller and beside an angle friction
holds, the parameters' own parts are generated too, the controllers' and the held angle's terms of ∂r/∂p differenced
apart, and with rigid links through the reduction, its geometric term exact (before, such a run differenced the
whole static ∂r/∂p for every parameter)."""
from __future__ import annotations

import csv

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.parameter_stiffness import exact_parameters
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.prepare import prepare
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_weight_derivative_parameters import PARAMETER_BOOM, _richardson_along
from tests.test_weight_derivative_rest import BOOM, _boom_state, _row
from tests.test_weight_derivative_rest import CONTROLLED_BOOM as CONTROLLED_PD_BOOM

#: the boom of tests/test_weight_derivative_parameters.py (a wheel latching at 0.5 rad at the end of a 3D arm under a
#: skew gravity, its hinge's laws of θ and t, a follower load of t) with its cable given mass: rest length "L" and
#: ρA "rA", each end's lumped mass at the end's offset from its node
CABLE_BOOM = (PARAMETER_BOOM.replace("rest_length: 0.9", 'rest_length: "L", rhoA: "rA"', 1)
              .replace("xc: 0.05}", "xc: 0.05, L: 0.9, rA: 0.5}", 1)
              .replace("sensitivities: [EA, P, k, c, m, xc, cd, q, r]", "sensitivities: [L, rA, EA]"))
#: the boom of tests/test_weight_derivative_rest.py under a skew gravity, its spar hinged at its start on the wheel
#: about a skew axis with a compliant stop at ±0.02 rad whose stiffness, exponent and damping are parameters: the
#: spar hangs pressed on its stop when the wheel latches
STOP_BOOM = (BOOM.replace("section: s, elements: 1}", "section: s, elements: 1,\n         start: {hinge: {axis: "
                          "[0.3, 0.2, 1.0], limits: [-0.02, 0.02], contact: {stiffness: \"kc\", exponent: \"nc\", "
                          "damping: \"cc\"}}}}", 1)
             .replace("EA: 2.0, P: 0.3}", "EA: 2.0, P: 0.3, kc: 3.0, nc: 1.5, cc: 0.2}", 1)
             .replace("sections: {s:", "gravity: [1.0, -2.0, -9.81]\nsections: {s:", 1)
             .replace("sensitivities: [EA, P, k]", "sensitivities: [kc, nc, cc]"))
#: the boom of tests/test_weight_derivative_rest.py, its wheel's hinge slipping with Coulomb and viscous friction until
#: it latches
FRICTION_BOOM = (BOOM.replace("rest_angle: 1.0,", 'rest_angle: 1.0, friction: {coulomb: "Fc", viscous: "cv"},', 1)
                 .replace("EA: 2.0, P: 0.3}", "EA: 2.0, P: 0.3, Fc: 0.02, cv: 0.01}", 1)
                 .replace("sensitivities: [EA, P, k]", "sensitivities: [Fc, cv]"))


def _stiffness_product(text: str, state, w: np.ndarray, **parameters) -> np.ndarray:
    """The evaluation's K w at ``state`` of the scene with ``parameters`` set, less the elements' block (no parameter
    here moves it; its 1e7 entries' round-off would swamp a difference in a parameter)."""
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    prepared = prepare(latdyn.load_scene(data))
    blocks = prepared.assembler.evaluate(state.copy(), matrices=True).flat_blocks("stiffness")
    blocks[0] = 0.0 * blocks[0]
    return np.asarray(prepared.assembler.assemble(blocks) @ w)


def _by_the_parameter(text: str, name: str, state, w: np.ndarray, relative: float = 2e-3) -> np.ndarray:
    """∂(K w)/∂p at fixed configuration and rates: Richardson-extrapolated central differences in the parameter
    (steps h, h/2, h = ``relative`` of its value)."""
    value = yaml.safe_load(text)["parameters"][name]
    h = relative * abs(value)
    central = [(_stiffness_product(text, state, w, **{name: value + s})
                - _stiffness_product(text, state, w, **{name: value - s})) / (2 * s) for s in (h, h / 2)]
    return (4 * central[1] - central[0]) / 3


def test_the_cable_stiffness_by_its_rest_length_is_richardsons_of_the_stiffness_along_w():
    """``cable_stiffness_D_rest_length`` at random taut geometries, rates, sections and directions is the derivative
    by L0 of ``cable_stiffness_D_q``'s K_c w (Richardson, steps 1e-3 and 5e-4 of L0; measured ≤ 3.2e-13 relative)."""
    kernels = load_kernels("auto", "default")
    rng = np.random.default_rng(18)
    for _ in range(4):
        geometry, velocity, w = rng.normal(size=12), 0.3 * rng.normal(size=12), rng.normal(size=12)
        span = np.linalg.norm(geometry[3:6] + geometry[9:12] - geometry[0:3] - geometry[6:9])
        section = np.array([0.8 * span, 0.0, 2.0 + rng.random(), 0.4 * rng.random()])

        def along(rest):
            moved = section.copy()
            moved[0] = rest
            return np.asarray(kernels.cable_stiffness_D_q(_row(geometry), _row(velocity), _row(moved), _row(w))[0])[0]

        computed = np.asarray(kernels.cable_stiffness_D_rest_length(_row(geometry), _row(velocity), _row(section),
                                                                    _row(w))[0])[0]
        h = 1e-3 * section[0]
        central = [(along(section[0] + s) - along(section[0] - s)) / (2 * s) for s in (h, h / 2)]
        numeric = (4 * central[1] - central[0]) / 3
        assert np.abs(computed - numeric).max() <= 1e-9 * np.abs(numeric).max()


def test_the_contact_stiffness_by_its_law_is_richardsons_of_the_hinge_stiffness():
    """``contact_stiffness_D_law`` at angles in both stops' contact, at rates that load and unload them (one clipped:
    the damper cancels the spring) and out of contact, is the derivative by (k, n, c) of ``hinge_force``'s
    ∂f/∂θ with the laws' slots 0 (Richardson, steps 1e-3 and 5e-4 of each value; measured ≤ 7e-12 relative)."""
    kernels = load_kernels("auto", "default")
    laws = np.zeros((1, 9))
    cases = [(0.35, 0.4), (0.33, -0.5), (-0.42, 0.7), (-0.45, -0.2), (0.32, -20.0), (0.1, 0.3)]
    for theta, rate in cases:
        contact = np.array([[-0.4, 0.3, 5.0, 1.7, 0.6, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0]])
        at = np.array([[theta, rate, 0.0, 1.0]])
        computed = np.asarray(kernels.contact_stiffness_D_law(at, contact)[0]).reshape(3)
        for slot in range(3):
            def stiffness(value):
                moved = contact.copy()
                moved[0, 2 + slot] = value
                return float(np.asarray(kernels.hinge_force(at, laws, moved)[1]).reshape(-1)[0])

            value = contact[0, 2 + slot]
            h = 1e-3 * value
            central = [(stiffness(value + s) - stiffness(value - s)) / (2 * s) for s in (h, h / 2)]
            numeric = (4 * central[1] - central[0]) / 3
            assert abs(computed[slot] - numeric) <= 1e-8 * max(abs(numeric), 1e-12), (theta, rate, slot)
        if theta == 0.1:
            assert not np.any(computed)   # out of contact


def _exact_and_agreeing(text: str, state, w: np.ndarray, prepared, tolerance: float) -> dict:
    """Assert every parameter of ``text`` takes the generated path and each column of (∂K/∂p) w agrees with
    :func:`_by_the_parameter` to ``tolerance`` of its largest entry; the errors by name."""
    owner = TransientSensitivities(prepared)
    assert exact_parameters(owner).all(), dict(zip(owner.names, exact_parameters(owner)))
    computed = owner._stiffness_derivative(state, w)
    errors = {}
    for column, name in enumerate(owner.names):
        reference = _by_the_parameter(text, name, state, w)[:len(w)]
        scale = np.abs(reference).max()
        errors[name] = np.abs(computed[:, column] - reference).max() / max(scale, 1e-300) if scale else \
            np.abs(computed[:, column]).max()
    assert max(errors.values()) <= tolerance, errors
    return errors


def test_a_massive_cables_rest_length_and_rhoa_are_generated_and_agree_with_the_parameters_difference():
    """The cable's rest length (``cable_stiffness_D_rest_length`` and its masses' weight) and ρA (its masses' weight
    stiffness, ``joint_body_gravity_stiffness_D_q``) beside EA: each column within 1e-9 of Richardson in the parameter
    of K w (measured ≤ 4.0e-12; the difference along w it replaces: ρA 1.0 off — its column was 0 —, L 0.052)."""
    prepared, state, rng = _boom_state(CABLE_BOOM)
    w = rng.normal(size=prepared.model.n_dofs)
    assert prepared.assembler.native().cable_state(state)[0, 4] > 0   # taut
    _exact_and_agreeing(CABLE_BOOM, state, w, prepared, 1e-9)


def _spar_on_its_stop(text: str, penetration: float, rate: float):
    """The stop boom's state of :func:`_boom_state`, its spar's hinge moved ``penetration`` past its upper or lower
    limit (its sign) at the rate ``rate``."""
    prepared, state, rng = _boom_state(text)
    model = prepared.model
    j = model.hinge_index("spar", "start")
    d = int(model.hinge_dofs[j])
    limit = 0.02 if penetration > 0 else -0.02
    move = np.zeros(model.n_dofs)
    move[d] = limit + penetration - float(state.theta[j])
    state = prepared.assembler.advance(state, move)
    state.theta_dot[j] = rate
    return prepared, state, rng


@pytest.mark.parametrize("penetration, rate", [(0.03, 0.2), (-0.01, 0.5)])
def test_a_compliant_stops_law_is_generated_and_agrees_with_the_parameters_difference(penetration, rate):
    """The spar pressed on either stop, loading and unloading it: the stop's stiffness, exponent and damping
    (``contact_stiffness_D_law``) each within 2e-10 of Richardson in the parameter of K w (measured ≤ 2.4e-11, the
    exponent's, the reference's truncation; the difference along w it replaces 2.9e-9 and 2.6e-8 here, 8e-10 at the
    run's latch)."""
    prepared, state, rng = _spar_on_its_stop(STOP_BOOM, penetration, rate)
    w = rng.normal(size=prepared.model.n_dofs)
    errors = _exact_and_agreeing(STOP_BOOM, state, w, prepared, 2e-10)
    assert len(errors) == 3


def test_frictions_part_is_zero_without_a_difference():
    """Friction's force depends on θ̇ alone: its part of K, and of (∂K/∂p) w, is 0, taken without the difference
    (which, two evaluations of ∂r/∂p, gave 0 as well) — and Richardson in the parameter agrees."""
    prepared, state, rng = _boom_state(FRICTION_BOOM)
    w = rng.normal(size=prepared.model.n_dofs)
    owner = TransientSensitivities(prepared)
    assert exact_parameters(owner).all()
    assert not np.any(owner._stiffness_derivative(state, w))
    for name in owner.names:
        assert np.abs(_by_the_parameter(FRICTION_BOOM, name, state, w)).max() <= 1e-12


@pytest.fixture(scope="module")
def cable_runs():
    """The cable boom's sensitivities with the loop of steps on and off (API)."""
    return runs_with_the_loop_on_and_off(CABLE_BOOM)


@pytest.fixture(scope="module")
def by_rhoa():
    """{probe: the sensitivity by ρA} of the cable boom as Richardson-extrapolated central differences of whole runs
    (steps 1e-4 and 5e-5 of the value; API)."""
    value = yaml.safe_load(CABLE_BOOM)["parameters"]["rA"]
    h = 1e-4 * value

    def run(step):
        data = yaml.safe_load(CABLE_BOOM)
        data["parameters"]["rA"] = value + step
        data["solve"]["sensitivities"] = ["rA"]
        return latdyn.run(latdyn.load_scene(data)).probes

    central = []
    for s in (h, h / 2):
        up, down = run(s), run(-s)
        central.append({k: (up[k] - down[k]) / (2 * s) for k in up})
    return {probe: (4 * central[1][probe] - central[0][probe]) / 3 for probe in central[0]}


def _worst(computed: dict, reference: dict) -> float:
    """The largest error of ``computed`` (probe → column) against ``reference``, relative to each probe's largest."""
    return max(np.abs(computed[probe] - expected).max() / np.abs(expected).max()
               for probe, expected in reference.items())


def test_through_the_latch_the_cables_sensitivities_agree_with_richardson_and_the_loop_keeps_the_bits(cable_runs,
                                                                                                      by_rhoa):
    """Through the latch the sensitivities by ρA agree with Richardson differences of whole runs to 1e-7 (measured
    5.3e-9; 3.1e-6 with the masses' weight stiffness left out), and the loop of steps on and off give the same bits."""
    native, python = cable_runs[True], cable_runs[False]
    assert [e["kind"] for e in native.summary["events"]] == ["latch"]
    assert_same_sensitivities(native, python, nonzero="each")
    assert native.summary["sensitivity_steps_in_loop"] > 0
    assert _worst({probe: native.sensitivities[(probe, "rA")] for probe in by_rhoa}, by_rhoa) < 1e-7


def test_latdyn_run_writes_the_apis_sensitivities_and_the_loop_off_the_same(tmp_path, cable_runs, by_rhoa):
    """``latdyn run`` of the cable boom: sensitivities.csv's columns by ρA agree with Richardson differences of whole
    runs to 1e-7, the latch's event sensitivities in summary.json are the API's, and the loop of steps off writes the
    same files byte for byte."""
    run, out = latdyn_run(tmp_path, CABLE_BOOM)
    assert run.returncode == 0, run.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    columns = {key: np.array([float(row[key]) for row in rows]) for key in rows[0]}
    assert _worst({probe: columns[f"{probe}/rA"] for probe in by_rhoa}, by_rhoa) < 1e-7
    summary = summary_of(out)
    assert summary["event_sensitivities"] == cable_runs[True].summary["event_sensitivities"]
    the_loop_off_writes_the_same(tmp_path, out)


def test_the_stop_booms_latch_takes_no_difference_and_the_loop_keeps_the_bits(monkeypatch):
    """The stop boom through its latch with the spar on its compliant stop: no central difference of the static
    ∂r/∂p along w is taken (the old path's two evaluations at the latch), and the loop of steps on and off give the
    same bits (API), with steps in the loop."""
    differenced = []
    original = TransientSensitivities.residual_derivatives

    def counted(self, state, load_factor, inertia=False, on_all=False, sections=True, element_gravity=True):
        if not element_gravity:   # the static ∂r/∂p without the elements' weight: the difference along w
            differenced.append(float(state.t))
        return original(self, state, load_factor, inertia, on_all, sections, element_gravity)

    monkeypatch.setattr(TransientSensitivities, "residual_derivatives", counted)
    runs = runs_with_the_loop_on_and_off(STOP_BOOM)
    assert [e["kind"] for e in runs[True].summary["events"]] == ["latch"]
    assert differenced == []
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")
    assert runs[True].summary["sensitivity_steps_in_loop"] > 0


#: the boom of tests/test_weight_derivative_rest.py under a skew gravity, its hinge's spring a law of θ beside a PD
#: controller nonlinear in the angle driving the same hinge (``pd``), with the hinge's stiffness, the controller's
#: gain, the cable's EA, the follower load's component and the wheel's mass as parameters
CONTROLLED_BOOM = (CONTROLLED_PD_BOOM.replace('stiffness: "k", damping: "c"', 'stiffness: "k*(1 + 0.5*theta**2)", '
                                              'damping: "c"', 1)
                   .replace("sections: {s:", "gravity: [1.0, -2.0, -9.81]\nsections: {s:", 1)
                   .replace("sensitivities: [Kp, k]", "sensitivities: [Kp, k, EA, P, m]"))


def test_beside_a_controller_the_parameters_own_part_is_generated_and_the_controllers_apart():
    """Beside a PD controller every parameter takes the generated path (before, with controllers, all took the
    difference of the whole static ∂r/∂p along w) with the controllers' terms of ∂r/∂p differenced apart: against
    Richardson differences of the static ∂r/∂p along w (no cable mass here: the same quantity), the spring's, the
    cable's, the load's and the mass's columns within 5e-12 (measured ≤ 5.6e-13; the whole difference 9.7e-12 –
    8.0e-11), the gain's (the controllers' part alone, as before) within 1e-10 (measured 6.6e-12)."""
    prepared, state, rng = _boom_state(CONTROLLED_BOOM)
    w = rng.normal(size=prepared.model.n_dofs)
    owner = TransientSensitivities(prepared)
    assert exact_parameters(owner).all()
    computed = owner._stiffness_derivative(state, w)
    reference = _richardson_along(owner, state, w, 1e-3)
    errors = dict(zip(owner.names, np.abs(computed - reference).max(axis=0) / np.abs(reference).max(axis=0)))
    assert errors["Kp"] <= 1e-10 and max(errors[name] for name in ("k", "EA", "P", "m")) <= 5e-12, errors


def test_beside_a_held_angle_the_parameters_own_part_is_generated_and_the_held_terms_apart(monkeypatch):
    """The 3D panel of tests/test_sensitivities_friction.py stuck by friction: at its event with the angle held (t =
    0.22) every parameter takes the generated path (before, a held angle sent all to the difference of the whole
    static ∂r/∂p along w) with the held angle's terms (K's columns of it times its δθ) taken apart, and each
    column agrees with Richardson differences of the static ∂r/∂p along w to 2e-10 of its largest entry (measured
    4.1e-11 with the held terms' difference, as the whole difference's; 1.3e-13 and 1.1e-13 since ctrlhand's exact
    held columns, the reference's held columns W's K's: without the elements' gravity tangent, which the static
    evaluation's held, 8.6e-6 off, tests/test_weight_derivative_controllers_held.py)."""
    from tests.test_sensitivities_friction import STUCK_3D

    seen = []
    original = TransientSensitivities._stiffness_derivative

    def checked(self, state, w):
        out = original(self, state, w)
        if self.held is not None and np.any(self.held):
            reference = _richardson_along(self, state, w, 1e-3)
            seen.append((exact_parameters(self).copy(),
                         np.abs(out - reference).max(axis=0) / np.abs(reference).max(axis=0)))
        return out

    monkeypatch.setattr(TransientSensitivities, "_stiffness_derivative", checked)
    latdyn.run(latdyn.load_scene(yaml.safe_load(STUCK_3D)))
    assert len(seen) == 1
    exact, errors = seen[0]
    assert exact.all() and errors.max() <= 2e-10, errors


def test_with_rigid_links_the_parameters_part_is_generated_through_the_reduction(monkeypatch):
    """The 3D gimbal of rigid links on skew hinges (tests/test_sensitivities_rigid_links.py, tethered by a cable with
    mass, under a skew gravity) latching: every parameter takes the generated path — its parts along P w, reduced,
    and the reduction's geometric term of its static ∂r_all/∂p, a rigid link's ρA through its body's weight stiffness
    (before, with rigid links or guides, all took the difference of the whole reduced static ∂r/∂p along w) —, each
    column within 2e-10 of Richardson differences of the reduced static ∂r/∂p along w (measured ≤ 5.4e-11; the
    difference it replaces 5.3e-12 – 3.0e-9)."""
    from tests.test_sensitivities_rigid_links import TETHER

    text = (TETHER.replace('damping: "c2"}}}', 'damping: "c2", lock_at: 0.15}}}').replace("t_end: 0.3", "t_end: 0.1")
            .replace("parameters: {L: 0.5,", "parameters: {L: 0.5, EA: 300.0, rA: 0.2,")
            .replace('EA: 300.0, rest_length: "L"', 'EA: "EA", rhoA: "rA", rest_length: "L"')
            .replace("sensitivities: [L, k1]", "sensitivities: [L, EA, rA, k1, m, P, EI, rho]")
            .replace("solve:", "gravity: [0.5, -1.0, -9.81]\nsolve:", 1))
    seen = []
    original = TransientSensitivities._stiffness_derivative

    def checked(self, state, w):
        out = original(self, state, w)
        step = 1e-3 * (self.length or 1.0) / float(np.max(np.abs(w)))

        def static(moved):
            return self.residual_derivatives(moved, 1.0, sections=True, element_gravity=False)

        advance = self.assembler.advance
        central = [(static(advance(state, h * w)) - static(advance(state, -h * w))) / (2 * h) for h in (step, step / 2)]
        reference = (4 * central[1] - central[0]) / 3
        moved = np.abs(reference).max(axis=0) > 0.0
        seen.append((exact_parameters(self).copy(), moved,
                     np.abs(out - reference).max(axis=0)[moved] / np.abs(reference).max(axis=0)[moved]))
        return out

    monkeypatch.setattr(TransientSensitivities, "_stiffness_derivative", checked)
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"] and len(seen) == 1
    exact, moved, errors = seen[0]
    assert exact.all() and moved.sum() >= 4 and errors.max() <= 2e-10, errors
