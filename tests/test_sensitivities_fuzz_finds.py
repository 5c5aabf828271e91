"""What the sensitivity fuzzer found (benchmarks/fuzz_sensitivities.py; docs/verification.md, "Sensitivity
fuzzing"), each reduced to the smallest scene that shows it, against Richardson-extrapolated central
differences of whole runs or with the refusal it now gets.

A damped cable going taut: the landing on its change of side was a plain secant through the last two trials,
which left the zero where the gap is not monotone in the step's size (−20 at the step's start, +5.1 at 0.89 h,
+2.5 at h): its next trial fell past the step, the landing stopped 5e-5 off the change and the run said, in a
warning, that its sensitivities were "not exact to better than that" — the event times' derivatives were O(1)
wrong (0.4 to 2 relative), the probes' up to 1.6. Now regula falsi keeps the zero bracketed. A cable whose
ends start at its rest length (the default) and move apart changes side at the start of the first step, where
no step can land: refused when it happens (exit 1, naming the cable), no longer reported as solved.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of

#: a flexible arm with a tip body, tied back to the ground by a damped cable a little longer than the
#: distance of its ends (slack at t = 0); the tip thrown outwards and sideways: the cable goes taut and
#: slack twice in 0.05 s. Planar (the plane z = 0).
DAMPED_CABLE = """
parameters: {c: 8.0}
sections:
  s: {EA: 1.0e6, EIy: 600, EIz: 600, GJ: 1000, rhoA: 1.6, rhoIy: 0.0002, rhoIz: 0.0002}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b: {at: [1.5, 0, 0], mass: 1.3, inertia: [0.05, 0.05, 0.05]}
beams:
  arm: {from: g, to: b, section: s, elements: 2}
cables:
  c0: {from: b, to: g, EA: 1.0e5, damping: c%s}
initial_velocity: {linear: [0.3, 1.0, 0]}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.05, dt: 0.01, tol: 1.0e-12, sensitivities: [c]}
output:
  probes:
    tension: {cable: c0, quantity: tension}
    tip: {point: b, quantity: position, component: x}
"""
SLACK_AT_START = DAMPED_CABLE % ", rest_length: 1.5003"
AT_REST_LENGTH = DAMPED_CABLE % ""
#: the same in 3D: the arm along (1, 0.8, 0.7), unequal section and body axes, the cable to an anchor off every
#: plane of the arm, the tip thrown along (0.6, 0.9, 0.7): taut, slack, taut, slack in 0.02 s
DAMPED_CABLE_3D = """
parameters: {c: 8.0}
sections:
  s: {EA: 1.0e6, EIy: 600, EIz: 450, GJ: 1000, rhoA: 1.6, rhoIy: 0.0002, rhoIz: 0.0003}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  a: {at: [0.2, -0.3, 0.1], fixed: true}
  b: {at: [1.0, 0.8, 0.7], mass: 1.3, inertia: [0.05, 0.04, 0.06]}
beams:
  arm: {from: g, to: b, section: s, elements: 2}
cables:
  c0: {from: b, to: a, EA: 1.0e5, damping: c, rest_length: 1.4868}
initial_velocity: {linear: [0.6, 0.9, 0.7]}
solve: {analysis: transient, method: generalized-alpha, t_end: 0.02, dt: 0.01, tol: 1.0e-12, sensitivities: [c]}
output:
  probes:
    tension: {cable: c0, quantity: tension}
    tip: {point: b, quantity: position, component: z}
"""


def _run(text: str, c: float | None = None):
    data = yaml.safe_load(text)
    if c is not None:
        data["parameters"]["c"] = c
    return latdyn.run(latdyn.load_scene(data))


@pytest.mark.parametrize("text", [SLACK_AT_START, DAMPED_CABLE_3D], ids=["planar", "3d"])
def test_a_damped_cable_going_taut_is_landed_on_and_its_sensitivities_agree_with_richardson_differences(text):
    """Measured, planar: the probes' rows 2.7e-8 (the tip's x) and 1.4e-8 (tension) of their largest
    sensitivity, the slack event's time 8.8e-9; the taut event's time does not depend on the damper (computed 0 exactly, the
    differences 7e-14). Before the mend: 0.94 (the tip), 1.96 and 1.7 (the events' times). 3D: rows 5.3e-9 (the tip's z),
    event times ≤ 2.9e-9 of the largest; before the mend the events' times 0.4 to 1 off."""
    result = _run(text)
    assert not [w for w in result.summary.get("warnings", []) if "landed" in w]
    kinds = [e["kind"] for e in result.summary["events"]]
    assert kinds[:2] == ["taut", "slack"], kinds
    p0, h = 8.0, 8e-3
    central, times = [], []
    for step in (h, h / 2):
        up, down = _run(text, p0 + step), _run(text, p0 - step)
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]] == kinds
        assert len(up.t) == len(down.t) == len(result.t)
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
        times.append(np.array([(a["t"] - b["t"]) / (2 * step)
                               for a, b in zip(up.summary["events"], down.summary["events"])]))
    for probe in ("tip", "tension"):
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, "c")] - expected).max() / np.abs(expected).max()
        assert error <= 1e-6, (probe, error)
    expected_dt = (4 * times[1] - times[0]) / 3
    computed_dt = np.array([e["dt"]["c"] for e in result.summary["event_sensitivities"]])
    assert np.abs(computed_dt - expected_dt).max() <= 1e-6 * np.abs(expected_dt).max(), (computed_dt, expected_dt)


def test_a_cable_at_its_rest_length_going_taut_at_once_is_refused_not_reported_as_solved(tmp_path):
    """Its change sits at the first step's start, where no step lands: before the mend exit 0 with the taut
    event's time derivative −1.1e-4 (exactly 0: the damper acts only once taut) and the tip's 1.6 off."""
    completed, out = latdyn_run(tmp_path, AT_REST_LENGTH, quiet=True)
    assert completed.returncode == 1, completed.stderr
    assert (f"the solver failed: {tmp_path / 'scene.yaml'}: solve.sensitivities: the sensitivities at t = 0 meet "
            "cables.c0 changing side") in completed.stderr
    assert "Traceback" not in completed.stderr
    assert summary_of(out)["status"] != "solved"
    # without sensitivities the same scene runs (the run itself is not at fault)
    completed, out = latdyn_run(tmp_path, AT_REST_LENGTH.replace(", sensitivities: [c]", ""), quiet=True)
    assert completed.returncode == 0, completed.stderr


#: a free body and a tip body joined by a rigid link and by a damped cable along it at its rest length: the
#: link keeps the cable's length, whose gap only grazes zero at round-off (fuzzer seed 3 case 17, reduced)
CABLE_BESIDE_A_RIGID_LINK = """
parameters: {c: 19.0}
sections:
  s: {EA: 4.0e6, EIy: 1600, EIz: 990, GJ: 777, rhoA: 1.7, rhoIy: 0.0037, rhoIz: 0.0037}
bodies:
  g: {at: [0, 0, 0], mass: 4.3, inertia: [0.32, 0.32, 0.32]}
  b: {at: [0, -1.69, 0], mass: 0.47}
beams:
  link: {from: g, to: b, section: s, rigid: true}
cables:
  c0: {from: g, to: b, EA: 25858.0, damping: c}
initial_velocity: {linear: [0.3, 0.52, 0], angular: [0, 0, 1.57]}
solve: {analysis: transient, method: hht-alpha, t_end: 0.2, dt: 0.01, tol: 1.0e-12, sensitivities: [c]}
output:
  probes:
    x: {point: b, quantity: position, component: x}
"""


def test_a_cable_grazing_its_change_is_ended_not_reported_as_solved(tmp_path):
    """Before the mend: exit 0, 8 taut and slack events at round-off (the gap's rate 7e-13 N/s), their times'
    derivatives by c up to 2.9e-5 and the tip's 1.6e-8 — all exactly 0 (the damper never acts: the link keeps
    the cable's length). Now the grazing change ends the run (exit 1) naming the cable."""
    completed, out = latdyn_run(tmp_path, CABLE_BESIDE_A_RIGID_LINK, quiet=True)
    assert completed.returncode == 1, completed.stderr
    assert "meet cables.c0 changing side while its gap barely moves" in completed.stderr
    assert "Traceback" not in completed.stderr
    assert summary_of(out)["status"] != "solved"


#: a 3D rigid link on a hinge whose angle is prescribed (1.52 t²), its end hinge latching at 0.102 rad under a
#: torque law scaled by k, a flexible beam on from the latching body (fuzzer seed 4 case 6, reduced)
LATCH_BEHIND_A_RIGID_LINK = """
parameters: {k: 1.0}
sections:
  s: {EA: 1.3e6, EIy: 568, EIz: 568, GJ: 1270, rhoA: 2.5, rhoIy: 0.0034, rhoIz: 0.0034}
bodies:
  g: {at: [0, 0, 0], fixed: true}
  b0: {at: [1.0, 1.0, 0.0], mass: 1.1, inertia: [0.2, 0.2, 0.2]}
beams:
  m0:
    from: g
    to: b0
    section: s
    rigid: true
    start: {hinge: {axis: [-0.845, 0.503, -0.18], angle: 1.52*t**2}}
    end: {hinge: {axis: [-0.734, -0.415, -0.538], torque: "k*(-2.05*exp(-t) - 1.3*theta_dot)", lock_at: 0.102}}
  m1: {from: b0, to: [1.0, 2.46, 0.0], section: s, elements: 2}
solve: {analysis: transient, method: hht-alpha, t_end: 0.2, dt: 0.01, tol: 1.0e-12, sensitivities: [k]}
output:
  probes:
    rel: {point: "m1.node[1]", quantity: displacement, component: z, frame: b0}
"""


#: the same scene with the latching body's own point and rates read, and the point's velocity in its frame
BEHIND_A_RIGID_LINK_READ_ON_THE_BODY = LATCH_BEHIND_A_RIGID_LINK + """\
    relv: {point: "m1.node[1]", quantity: velocity, component: z, frame: b0}
    body: {point: b0, quantity: displacement, component: y}
    body_v: {point: b0, quantity: velocity, component: z}
"""


def test_a_point_in_the_frame_of_a_body_latching_behind_a_rigid_link_at_the_latch_row():
    """The row at the latch (t = 0.198) against Richardson differences (h = 1e-3 k). The latch's time moves
    with k, and the prescribed hinge angle carries b0 (behind the rigid link) on by its own rates there: the
    dependent node's δx, δπ took P δq alone (the free coordinates'), so b0's point read 0 and the point in its
    frame −0.0238 against 0.00041 (3.0 times the probe's largest sensitivity off). Now (δx, δπ) += (v°, ω°) δt
    and the rates ∂v/∂t at fixed free coordinates and rates (TransientSensitivities._dependent_in_time). Measured
    (the error over the probe's largest sensitivity, every row): rel 1.9e-10, relv 2.8e-9, body 1.3e-10, body_v
    1.4e-10 (before: 3.0, 2.3, 1.0, 1.0); the point in the global frame 8.2e-11, unchanged."""
    result = _run_k(BEHIND_A_RIGID_LINK_READ_ON_THE_BODY)
    (latch,) = result.summary["events"]
    row = int(np.flatnonzero(result.t == latch["t"])[0])
    names, h, central = ("rel", "relv", "body", "body_v"), 1e-3, []
    for step in (h, h / 2):
        up = _run_k(BEHIND_A_RIGID_LINK_READ_ON_THE_BODY, 1 + step)
        down = _run_k(BEHIND_A_RIGID_LINK_READ_ON_THE_BODY, 1 - step)
        central.append({name: (up.probes[name] - down.probes[name]) / (2 * step) for name in names})
    for name in names:
        expected = (4 * central[1][name] - central[0][name]) / 3
        computed = result.sensitivities[(name, "k")]
        assert abs(expected[row]) > 1e-3 * np.abs(expected).max(), name   # the latch's row moves: the check can fail
        np.testing.assert_allclose(computed, expected, rtol=0, atol=1e-6 * np.abs(expected).max(), err_msg=name)


def _run_k(text: str, k: float | None = None):
    data = yaml.safe_load(text)
    if k is not None:
        data["parameters"]["k"] = k
    return latdyn.run(latdyn.load_scene(data))


#: a hinge whose torque law scales a controller's output by a parameter, on a static path (fuzzer seed 6 case
#: 11, reduced): static sensitivities take no parameter of a controller, and a law that names one they cannot
#: differentiate (its derivative names the controller, which a static law cannot read)
CONTROLLER_LAW_STATIC = """
parameters: {k: 1.0}
sections:
  s0: {EA: 4.0e6, EIy: 300.0, EIz: 1500.0, GJ: 600.0, rhoA: 0.8}
bodies:
  g: {at: [0, 0, 0], fixed: true}
beams:
  m0:
    from: g
    section: s0
    to: [1.0, 0, 0]
    elements: 2
    start:
      hinge: {axis: [0, 0, 1], stiffness: 50.0, torque: "k*(ctl)"}
loads:
- {at: m0.end, force: [0, 1.0, 0]}
solve: {analysis: static, method: load-control, steps: 2, sensitivities: [k]}
output:
  probes:
    a: {hinge: m0.start, quantity: angle}
controllers:
  ctl: {output: "2.0 - a"}
"""


@pytest.mark.parametrize("method", ["load-control", "arc-length"])
def test_a_parameter_in_a_static_law_that_names_a_controller_is_refused_naming_the_key(tmp_path, method):
    """Before the mend: exit 2 with `<scene>: parameters: name 'ctl' in 'p__0*(ctl)' is not allowed` — neither
    the file nor the key the user wrote, and the derivative's internal placeholder. Now refused before the run
    as the transient method refuses it, naming the file, solve.sensitivities and the law's key."""
    text = CONTROLLER_LAW_STATIC.replace("load-control", method)
    completed, _ = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 2, completed.stderr
    message = completed.stderr.strip().splitlines()[-1]
    assert "scene.yaml: solve.sensitivities: parameter 'k' is used at beams.m0.start.hinge.torque" in message, message
    assert "p__" not in message and "Traceback" not in completed.stderr
    with pytest.raises(latdyn.SceneError, match=r"solve\.sensitivities: .*beams\.m0\.start\.hinge\.torque"):
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    # the same law without the parameter in it runs (the refusal is the parameter's, not the controller's)
    completed, _ = latdyn_run(tmp_path, text.replace('"k*(ctl)"', '"ctl"').replace("stiffness: 50.0",
                                                                                    "stiffness: k*50.0"), quiet=True)
    assert completed.returncode == 0, completed.stderr
