"""Cables in the sensitivities' loop of steps in C (latdyn/analyses/sensitivities_in_loop.py, csrc/cable_forces.c;
issue 34 item 2): a cable's EA, damping, rest length and ρA. The generated ``cable_force_D_rest_length`` (codegen/joints.py,
which the Python path now calls where it took a two-point difference) against central differences; a 3D mast braced by
three pretensioned cables (one with mass and inner nodes, one damped, one at an offset), a weight on a damped cable with
mass, a mass dropped on a slack cable and the shipped cable truss (its reel held: constant rest length) cut to 0.5 s
take their smooth steps in the loop, and the sensitivities and the events' time derivatives are the per-step Python
path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, through the API and through ``latdyn run``; the
slack/taut changes and the steps that end near one from Python; the mast from the loop against Richardson central
differences. The shipped truss with its reel (a rest length in t beside the cables' events) takes the loop too:
tests/test_sensitivities_in_loop_prescribed.py."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.model.kernels import load_kernels
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_cables import cable_inputs
from tests.test_sensitivities_cables import DROP

ROOT = Path(__file__).resolve().parents[1]

#: a 3D mast braced by three pretensioned cables (taut throughout), swaying from a rigid initial turn under a
#: steady load at its top: EA and the rest length L of all three, ρA of the one with mass (three elements), EI
MAST = """
title: a 3D mast braced by three pretensioned cables, swaying under a push at its top and a steady load
parameters: {EA: 50000.0, L: 2.49, EI: 400.0, rho: 0.05}
gravity: [0, 0, -9.81]
initial_velocity: {angular: [0.15, -0.2, 0]}
sections:
  s: {EA: 1.0e6, EIy: "EI", EIz: "1.2*EI", GJ: 300.0, rhoA: 2.0, rhoIy: 0.002, rhoIz: 0.002}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  top: {at: [0, 0, 2], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
  a1: {at: [1.5, 0, 0], fixed: true}
  a2: {at: [-0.75, 1.299038105676658, 0], fixed: true}
  a3: {at: [-0.75, -1.299038105676658, 0], fixed: true}
beams:
  mast: {from: base, to: top, section: s, elements: 4}
cables:
  g1: {from: top, to: a1, EA: "EA", rest_length: "L", rhoA: "rho", elements: 3}
  g2: {from: top, to: a2, EA: "EA", rest_length: "L", damping: 20.0}
  g3: {from: {body: top, offset: [0.02, 0, 0]}, to: a3, EA: "1.1*EA", rest_length: "L"}
loads:
  - {at: top, force: [40, 25, 0]}
solve: {analysis: transient, dt: 0.002, t_end: 0.1, sensitivities: [EA, L, EI, rho]}
output:
  every: 0.01
  probes:
    top_x: {point: top, quantity: position, component: x}
    top_y: {point: top, quantity: position, component: y}
    mid_x: {point: "mast.node[2]", quantity: displacement, component: x}
    sag: {point: "g1.node[1]", quantity: position, component: z}
    pull: {cable: g2, quantity: tension}
"""

#: a weight on a damped cable with mass (two elements), hanging stretched and swinging out from a turn
WEIGHT = """
title: a weight on a damped cable, swinging
parameters: {EA: 4000.0, c: 15.0, L: 1.0, rho: 0.3, m: 2.0}
gravity: [0, 0, -9.81]
initial_velocity: {angular: [0.8, -1.5, 0]}
bodies:
  top: {at: [0, 0, 0], fixed: true}
  bob: {at: [0.1, 0.05, -1.0], mass: "m", inertia: [0.01, 0.01, 0.01]}
cables:
  rope: {from: top, to: bob, EA: "EA", rest_length: "L", damping: "c", rhoA: "rho", elements: 2}
solve: {analysis: transient, dt: 0.002, t_end: 0.2, sensitivities: [EA, c, L, rho, m]}
output:
  every: 0.01
  probes:
    x: {point: bob, quantity: position, component: x}
    z: {point: bob, quantity: position, component: z}
    knot: {point: "rope.node[1]", quantity: position, component: y}
    pull: {cable: rope, quantity: tension}
    length: {cable: rope, quantity: length}
"""


def truss(reel: bool) -> str:
    """examples/cable_deploying_truss.yaml cut to 0.5 s, by its cables' EA and its longerons' EIy, with rotary inertia
    (sensitivities through latches ask for it) and without its kinetic energy probe (energy and momentum
    sensitivities with cables are refused); ``reel`` False: the cables' rest length held at 1.8 m (no law in t)."""
    data = yaml.safe_load((ROOT / "examples" / "cable_deploying_truss.yaml").read_text())
    data["parameters"] = {"EA": 2000.0, "EI": 2000.0}
    data["sections"]["longeron"]["EIy"] = "EI"
    for section in data["sections"].values():
        section.update(rhoIy=1.0e-4, rhoIz=1.0e-4)
    for cable in data["cables"].values():
        cable["EA"] = "EA"
        if not reel:
            cable["rest_length"] = 1.8
    del data["output"]["probes"]["kinetic"]
    data["solve"].update(t_end=0.5, sensitivities=["EA", "EI"])
    return yaml.safe_dump(data, sort_keys=False)


def _run(text: str, monkeypatch, in_loop: bool):
    """The scene's run through the API, its smooth steps' sensitivities in the loop of steps or from Python."""
    with monkeypatch.context() as patch:
        patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(text)))


def _same(native, python) -> None:
    """The sensitivities, the probes' and the events' time derivatives of ``native`` are ``python``'s to the bit."""
    assert_same_sensitivities(native, python, python_steps_in_loop=False, nonzero="some", events_may_be_absent=True)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_rest_length_kernel_against_differences(backend):
    """``cable_force_D_rest_length``: ∂(force, [ℓ, ℓ̇, ℓ − L0, N_el, N])/∂L0 against central differences of
    ``cable_force`` in L0, and ∂N/∂L0 against −EA ℓ/L0² by hand."""
    kernels = load_kernels(backend, "default")
    geometry, velocity, section = cable_inputs(6)
    by_force, by_state = (np.asarray(a) for a in kernels.cable_force_D_rest_length(geometry, velocity, section))
    by_force, by_state = by_force.reshape(6, 12), by_state.reshape(6, 5)
    for b in range(6):
        step = 1e-6 * section[b, 0]
        up, down = section[b].copy(), section[b].copy()
        up[0] += step
        down[0] -= step
        ahead = kernels.cable_force(geometry[b:b + 1], velocity[b:b + 1], up[None])
        behind = kernels.cable_force(geometry[b:b + 1], velocity[b:b + 1], down[None])
        for out, got in ((0, by_force[b]), (3, by_state[b])):
            expected = (np.asarray(ahead[out]) - np.asarray(behind[out])).reshape(-1) / (2 * step)
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-7 * np.abs(got).max())
        length = np.linalg.norm((geometry[b, 3:6] + geometry[b, 9:12])
                                                     - (geometry[b, 0:3] + geometry[b, 6:9]))
        assert by_state[b, 4] == pytest.approx(-section[b, 2] * length / section[b, 0] ** 2, rel=1e-13)


@pytest.mark.parametrize("text", [MAST, WEIGHT], ids=["3D mast braced by cables", "weight on a damped cable"])
def test_cables_kept_taut_take_every_step_in_the_loop_and_are_the_python_paths(text, monkeypatch):
    """Every step in the loop of steps (in C), the sensitivities the per-step Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] > 0
    assert python.summary["sensitivity_steps_in_loop"] == 0 and not native.summary.get("events")
    _same(native, python)


@pytest.mark.parametrize("text", [DROP, truss(reel=False)], ids=["mass dropped on a slack cable",
                                                                  "cable truss, its rest length held"])
def test_cables_changing_slack_and_taut_are_the_python_paths(text, monkeypatch):
    """Through the cables' slack and taut changes (their steps, and those ending near one, from Python) the smooth
    steps in the loop; the sensitivities and the events' time derivatives the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert 0.8 * steps < in_loop < steps and python.summary["sensitivity_steps_in_loop"] == 0
    assert {"taut", "slack"} <= {event["kind"] for event in native.summary["events"]}
    assert native.summary["event_sensitivities"]
    _same(native, python)


@pytest.mark.parametrize("name", ["L", "rho"])
def test_the_mast_from_the_loop_agrees_with_richardson_central_differences(name, monkeypatch):
    """The mast's sensitivities by the rest length (the generated cable_force_D_rest_length, and the lumped masses'
    through the mass of the rest length) and by ρA (the lumped masses alone), from the loop of steps, against
    Richardson-extrapolated central differences of whole runs."""
    native = _run(MAST, monkeypatch, True)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"]
    data = yaml.safe_load(MAST)
    data["solve"].pop("sensitivities")
    p0 = data["parameters"][name]
    central = []
    for step in (1e-4 * p0, 0.5e-4 * p0):
        runs = []
        for sign in (1, -1):
            data["parameters"][name] = p0 + sign * step
            runs.append(latdyn.run(latdyn.load_scene(data)).probes)
        central.append({probe: (runs[0][probe] - runs[1][probe]) / (2 * step) for probe in runs[0]})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(native.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
        assert error < 1e-6, (probe, error)


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the mast takes the loop; with the switch off (a process of its own) it writes the same
    sensitivities.csv and probes.csv, byte for byte, and summary.json's probe sensitivities."""
    completed, out = latdyn_run(tmp_path, MAST)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 50
    the_loop_off_writes_the_same(tmp_path, out)
