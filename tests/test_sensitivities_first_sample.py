"""The sensitivities' first sample at t = 0 and the states' first rates when a parameter moves the start (issue 34;
latdyn/analyses/sensitivities.py ``SampledTerms.start``, ``ControllerStates.start``; the adjoint's
latdyn/analyses/adjoint_controller_states.py ``SamplesTransposed.start_transposed``,
``StatesTransposed.start_transposed``; docs/parameters.md, "Controllers").

A sampled controller samples its sensors at t = 0, and a continuous one with states takes its states' rates f_0 there;
an ``initial_velocity`` parameter moves the start's rates (δv_0), a geometry parameter its coordinates (δq_0) and,
under a rigid spin, its rates (ω × δX). Both methods now move the sensors by the start's δs_0 = D_q δq_0 + D_v δv_0 as
they do at a later sample or step: δy_0 = ∂f/∂s δs_0 + ∂f/∂p (held for the whole first period), δS_1 by ∂g/∂s δs_0,
δf_0 = ∂f/∂s δs_0 + ∂f/∂p; the adjoint adds δs_0ᵀ s̄ (the forward method's δs_0 on the start's moves,
``TransientSensitivities.start_moves``). On 5ef7564 both took δs_0 = 0: a sampled PD reading its hinge's rate was
0.24 off Richardson by the initial spin's W, one reading the tip's velocity 2.3e-2, a PI state integrating the
hinge's rate 3.7e-4, one integrating the tip's velocity (measured below), all reported as solved; the adjoint mirrored
them. Each scene is genuinely 3D (a skew hinge axis, a tip off the coordinate planes, a spin about a skew axis) and
typed as YAML. References: Richardson-extrapolated central differences of whole runs (every probe over its rows,
relative to its largest; ``solve.tol`` 1e-12; the perturbation varied, the time step fixed) and, for the adjoint, the
forward method (≤ 1e-10 relative, every probe's end, max and min by every parameter)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, latdyn_run_switched, summary_of
from tests.sensitivity_equality import assert_same_sensitivities, runs_with_the_loop_on_and_off
from tests.test_sensitivities_refusals_lifted import _adjoint_error, _richardson_end
from tests.test_sensitivities_refusals_lifted2 import _richardson_error

#: a flexible arm on a skew hinge spun at the start about a skew axis (the spin's rate W a parameter), its tip placed
#: at x = tx (a geometry parameter), under the controller CONTROLLER; every probe a controller here reads is probed
ARM = """
title: a flexible arm on a skew hinge, spun at the start, under a controller reading its start
parameters: {Kp: 6.0, Kd: 0.2, EI: 40.0, W: 1.5, tx: 0.6}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "EI", GJ: 30.0, rhoA: 1.0, rhoIy: 0.001, rhoIz: 0.001}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: ["tx", 0.3, 0.45], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3,
        start: {hinge: {axis: [1, -2, 0.5], damping: 0.1, torque: "pd"}}}
controllers:
  pd: CONTROLLER
initial_velocity: {angular: ["0.2*W", "-0.4*W", "0.1*W"]}
gravity: [0, 0, -4.0]
solve: {analysis: transient, t_end: 0.3, dt: 0.01, sensitivities: SENSITIVITIES}
output:
  every: 0.01
  probes:
    th: {hinge: arm.start, quantity: angle}
    w: {hinge: arm.start, quantity: rate}
    tip_x: {point: tip, quantity: position, component: x}
    tip_vz: {point: tip, quantity: velocity, component: z}
    pd_out: {controller: pd}
"""


def _arm(controller: str, sensitivities: str) -> str:
    return ARM.replace("CONTROLLER", controller).replace("SENSITIVITIES", sensitivities)


#: (a) a PD sampled at 25 Hz (period 0.04 s) of the hinge's angle and rate
SAMPLED_RATE = _arm('{output: "Kp*(0.4 - th) - Kd*w", rate: 25}', "[W, Kd]")
#: (c) a PD sampled at 25 Hz whose derivative reads the tip's vertical velocity
SAMPLED_VELOCITY = _arm('{output: "Kp*(0.4 - th) - Kd*tip_vz", rate: 25}', "[W, Kd]")
#: a continuous PI whose state integrates the hinge's rate (its f_0 = w_0)
STATE_RATE = _arm('{output: "Kp*(0.4 - th) + Kd*E", states: {E: "w"}}', "[W, Kd]")
#: a continuous PI whose state integrates the tip's vertical velocity
STATE_VELOCITY = _arm('{output: "Kp*(0.4 - th) + Kd*E", states: {E: "tip_vz"}}', "[W, Kd]")
#: (b) with the geometry parameter: the sampled PD of the hinge's angle and rate (the tip's place moves the start's
#: coordinates and, under the spin, its rates, not the hinge's angle or rate)
GEOMETRY_RATE = _arm('{output: "Kp*(0.4 - th) - Kd*w", rate: 25}', "[tx, Kd]")
#: (b) a sampled PD reading the tip's position, which the geometry parameter moves: refused before and after
GEOMETRY_POSITION = _arm('{output: "Kp*(0.7 - tip_x) - Kd*w", rate: 25}', "[tx, Kp]")
assert all("CONTROLLER" not in s and "SENSITIVITIES" not in s for s in (SAMPLED_RATE, GEOMETRY_POSITION))

MOVED = {"sampled rate": SAMPLED_RATE, "sampled velocity": SAMPLED_VELOCITY, "state of a rate": STATE_RATE,
         "state of a velocity": STATE_VELOCITY}


def _with(text: str, **solve) -> dict:
    data = yaml.safe_load(text)
    data["solve"].update(solve)
    return data


@pytest.mark.parametrize("relative", [1e-4, 1e-3])
@pytest.mark.parametrize("case", list(MOVED))
def test_the_forward_method_by_the_initial_spin_agrees_with_richardson_central_differences(case, relative):
    """Every probe over its rows (the held output of the first sample among them) by the start's spin rate W. On
    5ef7564 (δs_0 = 0) off by 0.21 (sampled rate), 0.15 (sampled velocity), 6.8e-4 (state of the rate), 4.4e-4 (state
    of the velocity), both steps. Measured (steps 1e-4 / 1e-3 relative): 7.6e-9 / 9.8e-10, 6.5e-9 / 9.5e-10,
    6.8e-9 / 4.8e-10, 3.9e-9 / 6.6e-10."""
    text = MOVED[case]
    result = latdyn.run(latdyn.load_scene(_with(text, tol=1e-12, sensitivities=["W"])))
    assert abs(result.summary["probe_sensitivities"]["pd_out"]["end"]["W"]) > 0.0
    assert _richardson_error(text, result, "W", relative) <= 1e-6


def test_guard_the_geometry_parameter_beside_a_sampled_pd_of_the_hinge_agrees_with_richardson():
    """A guard (right on 5ef7564 too: the tip's place moves neither the hinge's angle nor its rate at the start, so
    δs_0 = 0 there): the forward method by tx against whole runs differenced. Measured: 4.4e-10 (steps 1e-3;
    3.9e-9 at 1e-4)."""
    result = latdyn.run(latdyn.load_scene(_with(GEOMETRY_RATE, tol=1e-12, sensitivities=["tx"])))
    assert _richardson_error(GEOMETRY_RATE, result, "tx", 1e-3) <= 1e-6


def test_guard_a_sampled_controller_reading_a_point_a_geometry_parameter_moves_stays_refused():
    """A guard (refused on 5ef7564 as here): geometry sensitivities beside a sampled controller reading a point's
    position stay refused, naming the file's key of the parameter and what is taken."""
    with pytest.raises(latdyn.SceneError, match=r"bodies\.tip\.at\[0\].*reads 'tip_x'"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(GEOMETRY_POSITION)))


@pytest.mark.parametrize("case", list(MOVED))
def test_the_adjoint_equals_the_forward_method_and_richardson_where_the_start_moves(case):
    """Every probe's end, max and min by every parameter: the forward method's to 1e-10 relative; and every probe's
    end value by W against whole runs differenced (steps 1e-3 relative, ``solve.tol`` 1e-12), relative to the largest
    over the probes, ≤ 1e-6. On 5ef7564 the adjoint equalled that commit's forward method, both wrong: 1.6e-2, 0.15,
    2.4e-4, 1.6e-4 off these end values (and 1.8e-2, 0.13, 9.1e-4 off this change's forward method, the first three).
    Measured: adjoint = forward 1.1e-13, 2.0e-13, 5.6e-13, 8.1e-13; against the end values 1.0e-9, 1.3e-9, 6.6e-11,
    3.7e-10."""
    text = MOVED[case]
    forward = latdyn.run(latdyn.load_scene(_with(text, tol=1e-12)))
    adjoint = latdyn.run(latdyn.load_scene(_with(text, tol=1e-12, sensitivity_method="adjoint")))
    assert _adjoint_error(forward, adjoint) <= 1e-10
    expected = _richardson_end(_with_tol(text), "W", forward, 1e-3)
    computed = adjoint.summary["probe_sensitivities"]
    scale = max(abs(v) for v in expected.values())
    assert max(abs(computed[k]["end"]["W"] - v) for k, v in expected.items()) <= 1e-6 * scale


def _with_tol(text: str) -> str:
    return yaml.safe_dump(_with(text, tol=1e-12), sort_keys=False)


def test_guard_the_adjoint_by_the_geometry_parameter_equals_the_forward_method():
    """A guard (equal on 5ef7564 too, as the forward method's guard above is right there): the adjoint by tx and Kd
    beside the sampled PD of the hinge, the forward method's to 1e-10 relative. Measured: 3.6e-12 (tol 1e-12)."""
    forward = latdyn.run(latdyn.load_scene(_with(GEOMETRY_RATE)))
    adjoint = latdyn.run(latdyn.load_scene(_with(GEOMETRY_RATE, sensitivity_method="adjoint")))
    assert _adjoint_error(forward, adjoint) <= 1e-10


@pytest.mark.parametrize("case", list(MOVED))
def test_guard_the_loop_of_steps_on_and_off_give_the_same_bits(case):
    """A guard (bit-equal on 5ef7564 too): the forward method's loop of steps in C and the per-step Python path write
    the same sensitivities."""
    runs = runs_with_the_loop_on_and_off(MOVED[case])
    assert_same_sensitivities(runs[True], runs[False], nonzero="each")


def test_the_cli_equals_the_api_bit_for_bit_both_methods(tmp_path):
    """``python -m latdyn run`` writes the API's probe sensitivities to the bit, forward and adjoint; with the
    adjoint's loop off (a fresh process) the same again. The first sample's held output by W, exact: the spin
    ω = W (0.2, −0.4, 0.1) lies along the hinge's axis, so the tip at (0.6, 0.3, 0.45) starts at vz = 0.3 W and
    δy_0 = −Kd · 0.3 = −0.06 (0 on 5ef7564)."""
    for method in ("forward", "adjoint"):
        data = _with(SAMPLED_VELOCITY, sensitivity_method=method)
        (tmp_path / method).mkdir()
        completed, out = latdyn_run(tmp_path / method, yaml.safe_dump(data, sort_keys=False))
        assert completed.returncode == 0, completed.stderr
        written = summary_of(out)
        api = latdyn.run(latdyn.load_scene(data))
        assert written["probe_sensitivities"] == api.summary["probe_sensitivities"]
        assert written["probe_sensitivities"]["pd_out"]["end"]["W"] != 0.0
        if method == "forward":
            rows = np.genfromtxt(out / "sensitivities.csv", delimiter=",", names=True)
            assert rows["pd_outW"][0] == pytest.approx(-0.06, rel=1e-12)
            assert api.sensitivities[("pd_out", "W")][0] == rows["pd_outW"][0]
    off = latdyn_run_switched(tmp_path, tmp_path / "adjoint" / "scene.yaml", tmp_path / "off",
                              "import latdyn.analyses.adjoint_in_loop as m; m.ADJOINT_IN_LOOP = False")
    assert off.returncode == 0, off.stderr
    assert summary_of(tmp_path / "off")["probe_sensitivities"] == written["probe_sensitivities"]
