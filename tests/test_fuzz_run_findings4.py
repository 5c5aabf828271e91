"""The outside check of int18's merges (work accounts, prescribed motions, reels and laws of the state and t, points'
sensors, chains, load actuators, sampled controllers, cables beside controllers and t, sparse step matrices in the
sensitivities' loop of steps; fuzz5, 2026-11-28): benchmarks/fuzz_combined.py's random 3D scenes that combine them
found no difference between the loop and the per-step Python path, the API and ``latdyn run``, or an interrupted and
resumed run and the whole one (docs/performance.md has no entry: nothing here is a speed). This file holds the
combination its runs tried that no other test holds: a 3D boom on a base prescribed in t, a hinge driven by a clipped
PD controller reading a hinge and a point's velocity, hinge laws of t and of the state and t, a latch, a cable going
taut, a sampled controller at 125 Hz reading a point in a body's axes and driving a load in that body's axes, the PD
controller driving a load too. On ca1051c every step took the Python path (``sensitivity_steps_in_loop`` 0)."""
from __future__ import annotations

import numpy as np
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of
from tests.resumed_runs import resumed_inside_the_loop_is_whole

#: benchmarks/fuzz_combined.py seed 4 case 3, the sampled controller ``dig`` made to drive a load at n3 (in n2's axes)
BOOM = """
title: a 3D boom on a moving base, a latch, a cable, PD and sampled controllers
gravity: [0, 0, 0]
parameters: {E: 1.0, Kd: 0.66, G: 5.39, k2: 2.0}
sections:
  s: {EA: "1.0e4*E", EIy: "20*E", EIz: "30*E", GJ: "15*E", rhoA: "0.5", rhoIy: "0.01*0.5", rhoIz: "0.02*0.5"}
bodies:
  base: {at: [0, 0, 0], motion: {translation: ["0.05*sin(3*t)", 0, "0.02*t**2"]}}
  n1: {at: [0.7694, -0.0138, -0.1599], mass: 0.8157, com: [0.02, 0, -0.01], inertia: [0.01, 0.01, 0.02]}
  n2: {at: [1.4472, 0.2164, -0.0206], mass: 0.8685, com: [0.02, 0, -0.01], inertia: [0.01, 0.01, 0.02]}
  n3: {at: [1.9582, -0.026, -0.1534], mass: 0.8221, com: [0.02, 0, -0.01], inertia: [0.01, 0.01, 0.02]}
  n4: {at: [2.4146, -0.0844, -0.2625], mass: 0.829, com: [0.02, 0, -0.01], inertia: [0.01, 0.01, 0.02]}
beams:
  b0: {from: base, to: n1, section: s, elements: 1, y_axis: [0, 0, 1]}
  b1: {from: n1, to: n2, section: s, elements: 3, y_axis: [0, 0, 1], start: {hinge: {axis: [1.0, 0.61, 0.66], stiffness: "1.5*(1 + t)", damping: 0.2, torque: "pd"}}}
  b2: {from: n2, to: n3, section: s, elements: 3, y_axis: [0, 0, 1], start: {hinge: {axis: [-0.85, -0.25, 1.0], stiffness: "k2*(1 + 2*t)", damping: 0.05, torque: "0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot", rest_angle: 1.2, lock_at: 0.4}}}
  b3: {from: n3, to: n4, section: s, elements: 1, y_axis: [0, 0, 1], start: {hinge: {axis: [1.0, 0.73, -0.27], stiffness: "1.5*(1 + t)", damping: 0.2, torque: "0.3*sin(4*t)*cos(theta) + 0.1*t*theta_dot"}}}
loads:
  - {at: n3, force: ["0.2*dig", 0, "-0.1*dig"], frame: n2}
  - {at: n4, force: [0, "0.3*pd", 0], moment: ["0.05*pd", 0, 0], frame: n1}
cables:
  tie: {from: base, to: n4, EA: "2000.0", rest_length: 2.4351}
controllers:
  pd: {output: "11.6793*(0.3 - a1) - Kd*(w1 + 0.3*tip_vy)", limits: [-3, 3]}
  dig: {output: "G*(0.2 - p_y) - 0.5*a1", rate: 125}
solve: {analysis: transient, dt: 0.004, t_end: 0.2, sensitivities: [G, Kd, k2, E]}
output:
  every: 0.02
  probes:
    tip_z: {point: n4, quantity: position, component: z}
    tip_vy: {point: n4, quantity: velocity, component: y}
    a1: {hinge: b1.start, quantity: angle}
    w1: {hinge: b1.start, quantity: rate}
    p_y: {point: n4, quantity: position, frame: n1, component: y}
    pull: {cable: tie, quantity: tension}
"""


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene through the API, with every loop switch on, or off (the per-step Python path)."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        patch.setattr("latdyn.timeloop.loop.SENSITIVITY_ROWS_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _end(text: str, name: str, value: float) -> dict[str, float]:
    """The probes' last values with parameter ``name`` set to ``value`` (the other sensitivities not asked)."""
    scene = yaml.safe_load(text)
    scene["parameters"][name] = value
    scene["solve"]["sensitivities"] = [name]
    return {key: values[-1] for key, values in latdyn.run(latdyn.load_scene(scene)).probes.items()}


def test_the_combined_boom_takes_the_loop_equals_the_python_path_and_richardson(monkeypatch):
    """Every step but the cable's going taut (t = 0.064 s) and the landing after it in the loop; the sensitivities,
    the probes' and the events' to the bit the Python path's; the sampled controller's gain G and the law of t's k2
    against Richardson differences of whole runs (h = 1e-3 |p|) within 1e-6 of each probe's largest sensitivity
    (measured: 1.3e-8 at worst over the four parameters)."""
    native, python = _run(BOOM, monkeypatch, True), _run(BOOM, monkeypatch, False)
    assert [event["kind"] for event in native.summary["events"]] == ["taut"]
    assert native.summary["time_loop"] == "compiled" and python.summary["sensitivity_steps_in_loop"] == 0
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - 2 == 49
    assert native.sensitivities.keys() == python.sensitivities.keys()
    for key, values in python.sensitivities.items():
        np.testing.assert_array_equal(native.sensitivities[key], values, err_msg=str(key))
    for key, values in python.probes.items():
        np.testing.assert_array_equal(native.probes[key], values, err_msg=key)
    assert native.summary["probe_sensitivities"] == python.summary["probe_sensitivities"]
    assert native.summary["event_sensitivities"] == python.summary["event_sensitivities"]
    for name in ("G", "k2"):
        value = yaml.safe_load(BOOM)["parameters"][name]
        h = 1e-3 * abs(value)
        ends = {step: _end(BOOM, name, value + step) for step in (h, -h, h / 2, -h / 2)}
        for probe in ("tip_z", "a1", "p_y", "pull"):
            wide = (ends[h][probe] - ends[-h][probe]) / (2 * h)
            narrow = (ends[h / 2][probe] - ends[-h / 2][probe]) / h
            column = native.sensitivities[(probe, name)]
            assert abs(column[-1] - (4 * narrow - wide) / 3) <= 1e-6 * np.abs(column).max(), (probe, name)


def test_the_combined_boom_through_the_command_and_resumed_after_the_cable_went_taut(tmp_path, monkeypatch):
    """``latdyn run`` writes the API's sensitivities.csv and probes.csv byte for byte; interrupted (Ctrl-C) in the loop
    after the cable went taut and resumed, the run's files are the whole run's."""
    (tmp_path / "command").mkdir()
    (tmp_path / "resumed").mkdir()
    completed, out = latdyn_run(tmp_path / "command", BOOM)
    assert completed.returncode == 0, completed.stderr
    assert summary_of(out)["sensitivity_steps_in_loop"] == 49
    api = tmp_path / "api"
    latdyn.run(latdyn.load_scene(yaml.safe_load(BOOM)), api)
    for name in ("sensitivities.csv", "probes.csv"):
        assert (out / name).read_bytes() == (api / name).read_bytes(), name
    resumed_inside_the_loop_is_whole(yaml.safe_load(BOOM), tmp_path / "resumed", monkeypatch, 0.1)
