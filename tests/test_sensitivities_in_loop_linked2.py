"""Prescribed motions on models with rigid links or guides in the sensitivities' loop of steps (issue 34 item 2;
csrc/linked_prescribed_rates.c, latdyn/analyses/prescribed_rates.py ``PrescribedRates.linked``): ∂r/∂t through a
prescribed body or hinge angle that rigid links or a guide hang from is exact on both paths (it was a five-point
difference in t of the residual): the dependent nodes move with the prescribed coordinates through J, ∂c/∂v and the
dependent rates' ∂/∂q, the blocks' K, C and M take those moves, Pᵀ reduces them, and the geometric term ∂(Pᵀ)/∂q_p q̇_p
· r_all adds the turning of the links' own map. The runs take the loop, their sensitivities the per-step Python
path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and the CLI.

Scenes: a slider-crank whose rigid crank is driven by a prescribed angle, its slider bouncing off a stop on its
guide; the 3D gimbal of rigid links of tests/test_sensitivities_rigid_links.py on a base slewing about a skew axis,
its inner ring latching; the bead on a turning rod of tests/test_sensitivities_guides.py bouncing off its stop, and
the 3D guide on a turning hub latching."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
import tests.test_sensitivities_guides as guides
import tests.test_sensitivities_rigid_links as links
from tests.test_sensitivities_time_laws import ANGLE_LATCH
from tests.cli_runs import latdyn_run, summary_of

#: the slider-crank of tests/test_sensitivities_rigid_links.py, its rigid crank turned by the prescribed angle
#: 2 t + t² (a torque no more), the slider free of its stops, and beside it a swing: a rigid link hung from the
#: crank's pin on a hinge with a spring, bouncing off a stop at 0.008 rad (restitution 0.7) at 0.115 s and 0.272 s
CRANK_STOP = links.SLIDER_CRANK.replace('start: {hinge: {axis: [0, 0, 1], torque: "tau"}}}',
                                        'start: {hinge: {axis: [0, 0, 1], angle: "2.0*t + 1.0*t**2"}}}').replace(
    "parameters: {tau: 2.0, m: 1.0, k: 30.0}", "parameters: {m: 1.0, k: 30.0, ks: 2.0, mb: 0.2}").replace(
    ', limits: [-0.05, 0.03], restitution: 0.5}', '}').replace(
    "beams:\n", "  bob: {at: [0.1, -0.1, 0], mass: \"mb\", inertia: [0.001, 0.001, 0.001]}\nbeams:\n").replace(
    "  rod: {from: pin,", "  swing: {from: pin, to: bob, section: crank, rigid: true,\n"
    "          start: {hinge: {axis: [0, 0, 1], stiffness: \"ks\", limits: [-0.2, 0.008], restitution: 0.7}}}\n"
    "  rod: {from: pin,").replace(
    "sensitivities: [tau, m]", "sensitivities: [m, ks, mb]").replace("t_end: 0.22", "t_end: 0.3").replace(
    "driven by a torque", "driven by a prescribed angle, a swing on its pin").replace(
    "    crank: {hinge: crank.start, quantity: angle}\n    px: {point: pin, quantity: position, component: x}\n",
    "    sw: {hinge: swing.start, quantity: angle}\n"
    "    by: {point: bob, quantity: position, component: y}\n")
assert 'angle: "2.0*t + 1.0*t**2"' in CRANK_STOP and "restitution: 0.7" in CRANK_STOP and "sw: {hinge" in CRANK_STOP

#: the gimbal's inner ring latching (tests/test_sensitivities_rigid_links.py LATCH) on a base slewing about the
#: skew axis (0.3, −0.2, 1) by 0.8 t² − 0.5 t³ and translating by 0.05 sin 3t
GIMBAL_SLEW = links.LATCH.replace(
    "base: {at: [0, 0, 0], fixed: true}",
    'base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", 0, 0], '
    'rotation: {axis: [0.3, -0.2, 1.0], angle: "0.8*t**2 - 0.5*t**3"}}}')
assert "0.8*t**2 - 0.5*t**3" in GIMBAL_SLEW

#: the step (times dt) of :func:`difference_in_t`
TIME_STEP = 1e-2


def difference_in_t(rates, state, inertia: bool = True, on_all: bool = False) -> np.ndarray:
    """ExplicitTime.through_prescribed (``rates`` an ExplicitTime) by a five-point central difference in t of the
    residual, the prescribed nodes and angles moved to t ± η, ± 2η, η = 0.01 dt (truncation (ηω)⁴/30, round-off
    ε|r|/η): the reference of the exact form, which the package computed this way before (ExplicitTime
    ``difference_in_t``, PRESCRIBED_TIME_STEP) on models with rigid links or guides and for controllers reading a
    prescribed coordinate."""
    assembler = rates.owner.assembler
    eta = TIME_STEP * float(rates.owner.scene.solve.dt)

    def residual(shift):
        moved = state.copy()
        assembler.apply_prescribed(moved, state.t + shift)
        moved.t = state.t
        if on_all:
            ev = assembler.evaluate_assembled(moved, False, 1.0, inertia)
            return np.concatenate([ev.residual, ev.reaction, [0.0]])
        return np.asarray(assembler.evaluate(moved, matrices=False, inertia=inertia).residual, float)

    return (8.0 * (residual(eta) - residual(-eta)) - (residual(2 * eta) - residual(-2 * eta))) / (12.0 * eta)


#: scene: (text, events, steps not in the loop: each event's and the landing after it)
SCENES = {"slider-crank, prescribed crank, a swing on a stop": (CRANK_STOP, ["stop", "stop"], 4),
          "3D gimbal on a slewing base, latching": (GIMBAL_SLEW, ["latch"], 2),
          "bead on a turning rod, a stop": (guides.BEAD_STOP, ["stop"], 2),
          "3D guide on a turning hub, latching": (guides.HUB_LATCH_3D, ["latch"], 2)}


def _run(text: str, monkeypatch, in_loop: bool, only: str | None = None):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    data = yaml.safe_load(text)
    if only is not None:
        data["solve"]["sensitivities"] = [only]
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(data))


@pytest.mark.parametrize("name", list(SCENES))
def test_prescribed_motions_on_linked_models_take_the_loop(name, monkeypatch):
    """Every smooth step in the loop (all but each event's and the landing after it); the sensitivities, the
    probes and the events' sensitivities the Python path's to the bit."""
    text, kinds, beside = SCENES[name]
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == kinds
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - beside
    assert python.summary["sensitivity_steps_in_loop"] == 0
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key in native.sensitivities:
        assert np.array_equal(native.sensitivities[key], python.sensitivities[key]), key
    for probe in native.probes:
        assert np.array_equal(native.probes[probe], python.probes[probe]), probe
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


def _exact_against_difference(text: str, monkeypatch) -> tuple:
    """(calls, the largest relative difference): PrescribedRates itself (not through_prescribed, which took the
    difference where the exact form did not hold before) against :func:`difference_in_t`, on the free coordinates and
    on all, at every state the Python path asks ∂r/∂t at, its prescribed coordinates and rates set to the laws'."""
    from latdyn.analyses import transient_sensitivities as ts

    worst, calls = [0.0], [0]
    exact = ts.ExplicitTime.through_prescribed

    def compared(self, state, inertia=True, on_all=False):
        moved = state.copy()
        self.owner.assembler.apply_prescribed(moved, moved.t)
        if self.owner.model.links is not None:
            total, reduced = self.motions.linked(moved, inertia)
        else:
            total = self.motions(moved, inertia)
            reduced = self.owner._on_free_coordinates(moved, total[:, None])[:, 0]   # noqa: SLF001
        for value, whole in ((reduced, False), (total, True)):
            difference = difference_in_t(self, moved, inertia, whole)
            worst[0] = max(worst[0], np.abs(value - difference).max() / np.abs(difference).max())
        calls[0] += 1
        return exact(self, state, inertia, on_all)

    monkeypatch.setattr(ts.ExplicitTime, "through_prescribed", compared)
    _run(text, monkeypatch, False)
    return calls[0], worst[0]


@pytest.mark.parametrize("name", ["slider-crank, prescribed crank, a swing on a stop",
                                  "3D gimbal on a slewing base, latching"])
def test_the_exact_rate_in_t_on_linked_models_equals_the_five_point_difference(name, monkeypatch):
    """PrescribedRates.linked against the five-point difference in t of the residual (:func:`difference_in_t`),
    on the free coordinates and on all, at every state the run asks ∂r/∂t at, its prescribed coordinates and rates
    set to the laws' (the states at rest the impulses' weights use hold the prescribed rates at 0, which the
    difference would set again). Measured ≤ 1.9e-12 of the largest entry on the slider-crank (84 calls), 9.3e-12 on
    the gimbal (48 calls)."""
    calls, worst = _exact_against_difference(SCENES[name][0], monkeypatch)
    assert calls > 40 and worst <= 1e-9


def test_the_gimbal_on_its_slewing_base_agrees_with_richardson_differences(monkeypatch):
    """The run through the loop against Richardson-extrapolated central differences of whole runs (the helpers of
    tests/test_sensitivities_events.py) for the outer hinge's spring k1: the probes and the latch time (measured
    6.0e-8 of each probe's largest, as on the Python path with the five-point difference in t)."""
    import tests.test_sensitivities_events as events

    result = _run(GIMBAL_SLEW, monkeypatch, True, only="k1")
    assert result.summary["sensitivity_steps_in_loop"] == result.summary["steps"] - 2
    assert events._agree(result, GIMBAL_SLEW, "k1") <= 2e-7


def test_the_cli_writes_the_python_paths_files_for_the_slider_crank(tmp_path):
    """``latdyn run`` on the slider-crank takes the loop; the same command with the switch off (a process of its
    own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, CRANK_STOP)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["sensitivity_steps_in_loop"] == summary["steps"] - 4
    from tests.cli_runs import the_loop_off_writes_the_same

    the_loop_off_writes_the_same(tmp_path, out)


def _driven_by_a_controller(text: str, gains: str, law: str, output: str, after: str, sensors: str,
                            sensitivities: tuple) -> str:
    """``text`` with the parameters ``gains`` first, the hinge law ``law`` given the torque "pd", the controller pd
    of ``output`` and the probes ``sensors`` after the probe line ``after``, its sensitivities ``sensitivities``
    (old, new)."""
    return (text.replace("parameters: {", "parameters: {" + gains + ", ").replace(law, law + ' torque: "pd",')
            .replace("solve: {", 'controllers:\n  pd: {output: "' + output + '"}\nsolve: {')
            .replace(after, after + sensors).replace(*sensitivities))


#: the slider-crank's swing driven by a controller that reads the prescribed crank's angle and rate (its stop
#: met at 0.079, 0.187 and 0.256 s)
CRANK_PD = _driven_by_a_controller(
    CRANK_STOP, "Kp: 0.01, Kd: 0.005", 'stiffness: "ks",', "Kp*sin(ca) + Kd*cr",
    "    sw: {hinge: swing.start, quantity: angle}\n",
    "    ca: {hinge: crank.start, quantity: angle}\n    cr: {hinge: crank.start, quantity: rate}\n",
    ("sensitivities: [m, ks, mb]", "sensitivities: [Kp, Kd, ks, mb]"))
assert 'torque: "pd"' in CRANK_PD and "cr: {hinge" in CRANK_PD

#: the prescribed hinge angle beside a latching arm of tests/test_sensitivities_time_laws.py, the arm's hinge driven
#: by a controller that reads the prescribed angle and its rate (no rigid links: the coupling alone)
ANGLE_PD = _driven_by_a_controller(
    ANGLE_LATCH, "Kp: 0.3, Kd: 0.1", "rest_angle: 2.0,", "Kp*fa + Kd*fr",
    "    hinge: {hinge: arm.start, quantity: angle}\n",
    "    fa: {hinge: fore.start, quantity: angle}\n    fr: {hinge: fore.start, quantity: rate}\n",
    ("sensitivities: [k]", "sensitivities: [k, Kp, Kd]"))
assert 'torque: "pd"' in ANGLE_PD and "fr: {hinge" in ANGLE_PD
CONTROLLED = {"slider-crank's swing driven by a controller reading the crank": (CRANK_PD, ["stop"] * 3, 6),
              "arm driven by a controller reading a prescribed angle, latching": (ANGLE_PD, ["latch"], 2)}


@pytest.mark.parametrize("name", list(CONTROLLED))
def test_controllers_reading_a_prescribed_coordinate_take_the_loop(name, monkeypatch):
    """A controller's sensor on a prescribed coordinate: its coupling entry times the motion's rate in ∂r/∂t
    (csrc/prescribed_rates.c). Every smooth step in the loop, bit for bit with the Python path."""
    text, kinds, beside = CONTROLLED[name]
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == kinds
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - beside
    assert python.summary["sensitivity_steps_in_loop"] == 0
    for key in native.sensitivities:
        assert np.array_equal(native.sensitivities[key], python.sensitivities[key]), key
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]


@pytest.mark.parametrize("name", list(CONTROLLED))
def test_a_controllers_coupling_on_a_prescribed_coordinate_is_exact(name, monkeypatch):
    """∂r/∂t with the controller's coupling against the five-point difference in t at every state the run asks it
    at (its prescribed coordinates and rates set to the laws'): measured ≤ 2.0e-12 of the largest entry on the
    slider-crank (96 calls), 9.8e-13 on the arm (106 calls)."""
    calls, worst = _exact_against_difference(CONTROLLED[name][0], monkeypatch)
    assert calls > 40 and worst <= 1e-9


#: the 3D gimbal (tests/test_sensitivities_rigid_links.py) with its dissipated energy: the damper on the inner ring's
#: hinge (a rigid link's), by its damping c2, the spring k1 and the load P
GIMBAL_DISSIPATED = links.GIMBAL.replace("sensitivities: [k1, m, P, EI, rho]", "sensitivities: [c2, k1, P]").replace(
    "    tip_x: {point: tip, quantity: position, component: x}\n",
    "    tip_x: {point: tip, quantity: position, component: x}\n    D: {energy: dissipated}\n")
assert "D: {energy: dissipated}" in GIMBAL_DISSIPATED


def test_the_dissipated_energy_of_a_gimbal_of_rigid_links_takes_the_loop(monkeypatch):
    """The dissipated energy on a model with rigid links (the dampers' δθ, δθ̇ are free coordinates: a rigid link's
    hinge is one; csrc/work_accounts.c on both paths): every step in the loop, bit for bit with the Python path,
    and against Richardson differences for c2 (measured 4.7e-9 of each probe's largest, the energy among them;
    k1 3.4e-9)."""
    import tests.test_sensitivities_events as events

    native, python = _run(GIMBAL_DISSIPATED, monkeypatch, True), _run(GIMBAL_DISSIPATED, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"]
    assert python.summary["sensitivity_steps_in_loop"] == 0
    for key in native.sensitivities:
        assert np.array_equal(native.sensitivities[key], python.sensitivities[key]), key
    assert np.abs(native.sensitivities[("D", "c2")]).max() > 0
    assert events._agree(_run(GIMBAL_DISSIPATED, monkeypatch, True, only="c2"), GIMBAL_DISSIPATED, "c2") <= 1e-7
