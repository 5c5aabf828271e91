"""What benchmarks/fuzz_combined2.py found in int19's combinations (session 2026-11-28 eleventh, helper fuzz6).

1. A controller with states beside a controller reading a force whose law a parameter moves (sensctlread's
   ``sensed_force_slopes``, ∂f/∂s ∂F/∂p), at a step whose size is differentiated (the landing on a latch): the states'
   derivative by the step size (``ControllerStates.by_step_size``) ran the controllers' ∂r/∂p with one column but
   kept the sensed forces' slopes of every parameter, and the run ended in an internal error (ValueError:
   non-broadcastable output operand with shape (1,) … (3,)), through the API and the command (the fuzzer's boom
   s6-2). The step size's column now leaves the sensed forces' ∂F/∂p out (they are the parameters' columns).

2. A controller with a state that reads a cable's length, the cable's end on a prescribed base, through the cable's
   taut event (Python path): the sensitivities after the event were off by up to 2.4e-5 of the probe's largest (the
   tension by the hinge's damping c1; 06a6a72 the same) where Richardson differences of whole runs are resolved to
   6e-8; the same scene with the base fixed agreed to 1.6e-9. After the event every step ends at t + δt_e, and two
   terms of the time's derivative through the moving anchor were left out: the state's sensors' ∂s/∂t δt_{n+1} in
   δS_{n+1} and δf_{n+1} (ControllerStates._sensed, now along the prescribed motions as a probe's row), and in the
   residual's ∂r/∂t the output's dependence through S_{n+1} (ExplicitTime's coupling blocks are now evaluated with
   the states condensed as in the step, as the loop of steps evaluates them). Now 3.9e-9 (1.9e-6 with the first
   alone). The loop of steps declines a state reading a prescribed body's position or hinge angle beside events.
3. A continuous controller with states beside a controller reading an element's axial force took the loop of steps
   (60 of 60 steps), but its sensitivities differed from the per-step Python path's by round-off (4.4e-13 absolute
   here; 1.1e-14 and 1.8e-14 relative on the fuzzer's booms s6-68 and s6-98), where the loop's contract is the bit:
   with states, ``ControllerTerms.add`` read the sensed force from the probes' NumPy value, where the loop reads the
   step's evaluation's (``sensed_in_c``, which it took only without states). It takes ``sensed_in_c`` with states
   too now: bit-equal.
4. A controller's state named like a parameter: a parameter's name is replaced by its value in every expression text
before the text is read (latdyn/scene/expressions.py ``_with_parameters``), so a filter state ``F`` beside a load
parameter ``F`` was never read: the output and the state's own rate read F = 1.0, the run solved and said nothing
(the fuzzer's boom s5-5, whose filter gain ``wf`` then had sensitivities 0.0 on every probe, and Richardson
differences agreed: the state really was out of the loop). It is refused now, naming the file, the key and the clash
(latdyn/scene/controllers.py ``read_controllers``), through the command and the API alike."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_state_laws import _run

#: a PI controller on the 3D boom's hinge, which latches at 0.2 rad, beside a controller pushing the tip by the first
#: element's axial force, whose law the section's EA moves
PI_BESIDE_FORCE_READER = """\
title: a PI controller beside a controller reading an element's axial force, landing on a latch
gravity: [0, 0, -9.81]
parameters: {EA: 1.0e4, Ki: 2.0, Kr: 0.02}
sections:
  s: {EA: EA, EIy: 20, EIz: 30, GJ: 15, rhoA: 0.5, rhoIy: 0.005, rhoIz: 0.01}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  n1: {at: [0.5, -0.4, 0.3], mass: 0.7, inertia: [0.01, 0.01, 0.02]}
  n2: {at: [1.2, -0.1, 0.1], mass: 0.4, inertia: [0.01, 0.01, 0.02]}
beams:
  b0: {from: base, to: n1, section: s, elements: 2, y_axis: [0, 1, 0]}
  b1: {from: n1, to: n2, section: s, elements: 1, y_axis: [0, 1, 0], start: {hinge: {axis: [1.0, 0.5, -0.7], stiffness: 2.0, damping: 0.05, torque: pd, lock_at: 0.2}}}
loads:
  - {at: n2, force: [0, rd, 0]}
controllers:
  pd: {output: "8*(0.3 - a1) + Ki*S", states: {S: "0.2 - a1"}}
  rd: {output: "Kr*ax"}
solve: {analysis: transient, dt: 0.005, t_end: 0.3, sensitivities: [EA, Ki, Kr]}
output:
  every: 0.01
  probes:
    a1: {hinge: b1.start, quantity: angle}
    ax: {element: "b0.element[0]", quantity: axial_force}
"""
assert 'states: {S: "0.2 - a1"}' in PI_BESIDE_FORCE_READER and 'rd: {output: "Kr*ax"}' in PI_BESIDE_FORCE_READER


def test_a_state_beside_a_force_reader_through_a_latch_agrees_with_central_differences():
    """The run solves through the latch (t = 0.094), and its sensitivities by the PI's Ki and the reader's Kr agree
    with Richardson-extrapolated central differences of whole runs, the latch's time too (measured 1.1e-8 at
    h = 1e-3 p)."""
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(PI_BESIDE_FORCE_READER)))
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    for name in ("Ki", "Kr"):
        _agree(result, PI_BESIDE_FORCE_READER, name)


def test_a_state_beside_a_force_reader_through_a_latch_solves_by_the_command(tmp_path):
    run, out = latdyn_run(tmp_path, PI_BESIDE_FORCE_READER)
    assert run.returncode == 0 and "internal error" not in run.stderr, run.stderr
    assert (out / "sensitivities.csv").exists()

#: a filter state F in a controller driving a hinge, beside a load whose size is the parameter F
CLASH = """\
title: a controller's state named like a parameter
parameters: {F: 1.0, w: 5.0}
sections:
  s: {EA: 1.0e4, EIy: 20, EIz: 30, GJ: 15, rhoA: 0.5, rhoIy: 0.005, rhoIz: 0.01}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  n1: {at: [0.5, 0, 0], mass: 0.5, inertia: [0.01, 0.01, 0.02]}
  n2: {at: [1.0, 0.2, 0.1], mass: 0.5, inertia: [0.01, 0.01, 0.02]}
beams:
  b0: {from: base, to: n1, section: s, elements: 1}
  b1: {from: n1, to: n2, section: s, elements: 1, start: {hinge: {axis: [0, 0.3, 1], stiffness: 2.0, damping: 0.2, torque: ctl}}}
loads:
  - {at: n2, force: [0, 0, "-F"]}
controllers:
  ctl: {output: "-2*F", states: {F: "w*(a1 + 1 - F)"}}
solve: {analysis: transient, dt: 0.005, t_end: 0.02}
output:
  every: 0.005
  probes:
    a1: {hinge: b1.start, quantity: angle}
    out: {controller: ctl}
    state: {controller: ctl, state: F}
"""
assert 'states: {F: "w*(a1 + 1 - F)"}' in CLASH and "parameters: {F: 1.0" in CLASH


def test_a_state_named_like_a_parameter_is_refused_through_the_api():
    with pytest.raises(SceneError) as refused:
        latdyn.load_scene(yaml.safe_load(CLASH))
    message = str(refused.value)
    assert "controllers.ctl.states.F" in message and "already names a parameter (parameters.F)" in message, message


def test_a_state_named_like_a_parameter_is_refused_by_the_command(tmp_path):
    run, out = latdyn_run(tmp_path, CLASH)
    assert run.returncode != 0, run.stdout
    assert "Traceback" not in run.stderr, run.stderr
    assert "scene.yaml" in run.stderr and "controllers.ctl.states.F" in run.stderr, run.stderr
    assert "already names a parameter" in run.stderr and "expected a state name of its own" in run.stderr, run.stderr


def test_the_state_renamed_is_read():
    """The same scene with the state named S solves, and its output is the state's (not a constant −2)."""
    text = CLASH.replace('"-2*F", states: {F: "w*(a1 + 1 - F)"}', '"-2*S", states: {S: "w*(a1 + 1 - S)"}').replace(
        "state: F}", "state: S}")
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    out, state = result.probes["out"], result.probes["state"]
    assert state[-1] > 0.05 and abs(out[-1] + 2 * state[-1]) < 1e-12, (out, state)


#: fuzz6 boom s6-11 (its PD's state left out: not needed): a filter state Sf on the cable's length span, the cable
#: from a prescribed base to the tip, going taut at 0.124 s
TAUT_STATE = """\
title: a filter state on a cable's length through its taut event (fuzz6 boom s6-11)
gravity: [0, 0, -9.81]
parameters: {Kp: 17.11, Kd: 0.48, k1: 2.0, c1: 0.2, k2: 2.0, r2: 0.3, EA: 2000.0, wf: 28.6, Kr: 0.056}
sections:
  s: {EA: 1.0e4*1.0, EIy: 20*1.0, EIz: 30*1.0, GJ: 15*1.0, rhoA: '0.5', rhoIy: 0.01*0.5, rhoIz: 0.02*0.5}
bodies:
  base:
    at: [0, 0, 0]
    motion:
      translation: [0.05*sin(3*t), 0, 0.02*t**2]
  n1:
    at: [0.5532, -0.1758, -0.1166]
    mass: 0.9635
    com: [0.02, 0, -0.01]
    inertia: [0.01, 0.01, 0.02]
  n2:
    at: [1.0187, -0.4542, 0.2418]
    mass: 0.773
    com: [0.02, 0, -0.01]
    inertia: [0.01, 0.01, 0.02]
  n3:
    at: [1.4958, -0.5583, 0.4781]
    mass: 0.5023
    com: [0.02, 0, -0.01]
    inertia: [0.01, 0.01, 0.02]
beams:
  b0:
    from: base
    to: n1
    section: s
    elements: 1
    y_axis: [0, 0, 1]
  b1:
    from: n1
    to: n2
    section: s
    elements: 3
    y_axis: [0, 1, 0]
    start:
      hinge:
        axis: [1.0, 0.87, 0.32]
        stiffness: k1
        damping: c1
        torque: 0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot + rd
        rest_angle: 1.2
        limits: [-1.0, 0.4]
        restitution: 0.5
  b2:
    from: n2
    to: n3
    section: s
    elements: 3
    y_axis: [0, 1, 0]
    start:
      hinge:
        axis: [-0.51, 1.0, -0.57]
        stiffness: k2
        damping: (0.05)*(1 + theta_dot**2)
        torque: pd + 0.5*sin(9*t)
        rest_angle: r2
loads:
- at: n3
  force: [0.3*1.0, -1.0*t, 0.5*1.0*sin(5*t)]
cables:
  tie: {from: base, to: n3, EA: EA, rest_length: 1.67}
controllers:
  pd:
    output: Kp*(0.3 - a2) - 0.3*tip_z
    limits: [-1.5, 1.5]
  rd:
    output: Kr*span - 0.4*Sf
    states: {Sf: wf*(span - Sf)}
    limits: [-1.5, 1.5]
solve:
  analysis: transient
  dt: 0.004
  t_end: 0.2
  sensitivities: [c1]
  method: newmark
output:
  every: 0.004
  probes:
    tip_z: {point: n3, quantity: position, component: z}
    tip_vy: {point: n3, quantity: velocity, component: y}
    a2: {hinge: b2.start, quantity: angle}
    w2: {hinge: b2.start, quantity: rate}
    p_y: {point: n3, quantity: position, frame: n2, component: y}
    pull: {cable: tie, quantity: tension}
    span: {cable: tie, quantity: length}
"""
assert "states: {Sf: wf*(span - Sf)}" in TAUT_STATE and "translation: [0.05*sin(3*t)" in TAUT_STATE


def _rows_against_richardson(text: str, name: str) -> float:
    """The largest error of ``name``'s sensitivities over every row, relative to each probe's largest, against
    Richardson-extrapolated central differences of whole runs (h = 1e-3 |p|, ``solve.tol: 1e-12``)."""
    def run(value=None):
        data = yaml.safe_load(text)
        data["solve"]["tol"] = 1e-12
        if value is not None:
            data["parameters"][name] = value
        return latdyn.run(latdyn.load_scene(data))

    result, p0 = run(), float(yaml.safe_load(text)["parameters"][name])
    h, central = 1e-3 * abs(p0), []
    for step in (h, h / 2):
        up, down = run(p0 + step), run(p0 - step)
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in result.summary["events"]]
        central.append({k: (np.asarray(up.probes[k]) - np.asarray(down.probes[k])) / (2 * step) for k in up.probes})
    worst = 0.0
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        computed = np.asarray(result.sensitivities[(probe, name)])
        scale = max(float(np.abs(computed).max()), float(np.abs(expected).max()))
        if scale == 0.0:   # a probe neither run moves: both derivatives exactly 0
            continue
        worst = max(worst, float(np.abs(computed - expected).max()) / scale)
    return worst


def test_a_state_on_a_cable_length_from_a_fixed_base_through_taut_agrees():
    """The control: the same scene with the base fixed (measured 1.6e-9)."""
    text = TAUT_STATE.replace("    motion:\n      translation: [0.05*sin(3*t), 0, 0.02*t**2]\n", "    fixed: true\n")
    assert "fixed: true" in text
    assert _rows_against_richardson(text, "c1") < 1e-6


def test_a_state_on_a_cable_length_from_a_prescribed_base_through_taut_agrees():
    """Measured 3.9e-9 (2.4e-5 before the mend; 1.9e-6 with the sensors' ∂s/∂t δt alone)."""
    assert _rows_against_richardson(TAUT_STATE, "c1") < 1e-7


def test_a_state_beside_a_force_reader_in_the_loop_is_the_python_paths_to_the_bit_when_it_reads_an_angle(monkeypatch):
    """The control of the xfail below: the reader on the hinge's angle, bit-equal (60 of 60 steps in the loop)."""
    text = (PI_BESIDE_FORCE_READER.replace(", lock_at: 0.2", "").replace('rd: {output: "Kr*ax"}', 'rd: {output: "Kr*1000*a1"}')
            .replace("parameters: {EA: 1.0e4,", "parameters: {").replace("EA: EA,", "EA: 1.0e4,")
            .replace("sensitivities: [EA, Ki, Kr]", "sensitivities: [Ki, Kr]"))
    _loop_against_python(text, monkeypatch)


def test_a_state_beside_a_force_reader_in_the_loop_is_the_python_paths_to_the_bit(monkeypatch):
    text = (PI_BESIDE_FORCE_READER.replace(", lock_at: 0.2", "").replace("parameters: {EA: 1.0e4,", "parameters: {")
            .replace("EA: EA,", "EA: 1.0e4,").replace("sensitivities: [EA, Ki, Kr]", "sensitivities: [Ki, Kr]"))
    _loop_against_python(text, monkeypatch)


def _loop_against_python(text: str, monkeypatch) -> None:
    assert "lock_at" not in text and "sensitivities: [Ki, Kr]" in text and "EA: 1.0e4," in text
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 60
    assert python.summary["sensitivity_steps_in_loop"] == 0
    for key in native.sensitivities:
        assert np.array_equal(np.asarray(native.sensitivities[key]), np.asarray(python.sensitivities[key])), key
