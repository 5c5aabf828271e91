"""The discrete adjoint by geometry parameters (issue 34; latdyn/analyses/adjoint_sensitivities.py, docs/parameters.md
"The discrete adjoint"): a number that places the structure — a body's ``at``, an end's ``offset``, a beam's free end,
``y_axis``, a hinge's ``axis`` — moves the start (δq_0 = δX, δv_0 = ω × δX and a hinge's δa·ω, the start's
accelerations through K_0 and C_0), ∂r/∂p at every step (the generated ``*_D_reference`` kernels) and the probes at a
fixed state (a point's offset, a held node, a displacement's start; a section force's reference geometry). The reverse
pass seeds the start's move transposed, takes ∂r/∂X's columns transposed each step through the same kernels and seeds
the probes' explicit parts; at an event the forward method's maps, geometry included, transposed.

References: the forward method on the same scene (both are the exact derivative of the same discrete run: ≤ 1e-10 of
each output's largest derivative, event times too) and Richardson-extrapolated central differences of whole runs
(the coordinate moved, the step fixed). Scenes: a 3D lattice tower of 27 joint bodies whose interior node coordinates
are the parameters (benchmarks/adjoint_geometry_cost.py ``lattice_tower``, written out as the YAML a user runs), a
3D boom swung by its root hinge's spring into its latch whose hinge point moves, and a spinning 3D knee with every
probe kind the forward method differentiates by geometry. Each case was refused on 86d57d9 (exit 2 naming
``solve.sensitivity_method``: "the adjoint does not take geometry parameters yet")."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from benchmarks.adjoint_geometry_cost import coordinate_names, lattice_tower
from tests.cli_runs import latdyn_run
from tests.test_sensitivities_adjoint import _disagreement
from tests.test_sensitivities_geometry import KNEE_3D

#: every third coordinate of the interior stations, x, y and z in turn: x1a, y1b, z1c, x2a, … (21)
LATTICE_NAMES = [coordinate_names()[3 * j + j % 3] for j in range(21)]

#: a 3D boom swung open by its root hinge's spring (axis (1, −2, 0.5), in no coordinate plane) under a skew gravity
#: until the hinge latches at 0.5 rad (t = 0.41 s); the hinge point is the base's ``at`` plus the root's offset
BOOM_LATCH = """
title: a 3D boom swung open on its root hinge by its spring into the latch; the hinge point moved
gravity: [0.5, -1.0, -2.0]
parameters: {bx: 0.02, oy: 0.03, oz: 0.1, k: 20.0}
sections: {s: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.2e3, GJ: 800.0, rhoA: 1.0, rhoIy: 0.01, rhoIz: 0.012}}
bodies:
  base: {at: ["bx", 0, 0], fixed: true}
  elbow: {at: [0.4, 0.2, 0.5], mass: 0.5, inertia: [0.01, 0.01, 0.01]}
  tip: {at: [0.9, 0.6, 0.7], mass: 1.0, com: [0.05, 0, 0], inertia: [0.05, 0.05, 0.06]}
beams:
  root:
    from: {body: base, offset: [0, "oy", "oz"]}
    to: elbow
    section: s
    elements: 2
    start: {hinge: {axis: [1, -2, 0.5], stiffness: "k", damping: 0.05, rest_angle: 1.0, lock_at: 0.5}}
  outer: {from: elbow, to: tip, section: s, elements: 2}
solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.01, t_end: 0.5, sensitivities: [bx, oy, oz, k]}
output:
  every: 0.02
  probes:
    angle: {hinge: root.start, quantity: angle}
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: displacement, component: z}
    elbow: {point: elbow, quantity: displacement, component: norm}
"""

#: tests/test_sensitivities_geometry.py's knee spinning under gravity, every geometry key a parameter (the knee's
#: ``at``, the hinged beam's offset, free end, ``y_axis`` and hinge axis) and every probe kind the forward method
#: differentiates by geometry: positions, displacements and velocities (their norms too), in global and in the knee's
#: axes, the hinge's angle, rate and torque, section forces
EVERY_PROBE = (KNEE_3D.replace("parameters: {X: 1.0, Y: 0.1, tz: 0.4, dy: 0.05, F: 2.0}",
                               "parameters: {X: 1.0, Y: 0.1, tz: 0.4, dy: 0.05, ay: 0.6, w: 0.3, F: 2.0}\n"
                               "initial_velocity: {angular: [0.5, -0.3, 2.0]}")
               .replace("y_axis: [0, 0, 1]", 'y_axis: ["w", 0, 1]')
               .replace("axis: [0, 0.6, 0.8]", 'axis: [0, "ay", 0.8]')
               .replace("  - {at: knee, force:",
                        '  - {at: b.start, force: ["0.5*F", 0, "-F"], moment: [0, "0.2*F", 0]}\n  - {at: knee, force:')
               .replace("solve: {analysis: transient, dt: 0.005, t_end: 0.04, sensitivities: [X, Y, tz, dy]}",
                        "solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.005, t_end: 0.04,\n"
                        "        sensitivities: [X, Y, tz, dy, ay, w, F]}")
               .split("  probes:\n")[0] + """  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_d: {point: b.end, quantity: displacement, component: norm}
    root_z: {point: b.start, quantity: displacement, component: z}
    tip_v: {point: b.end, quantity: velocity, component: y}
    tip_vn: {point: b.end, quantity: velocity, component: norm}
    hinge: {hinge: b.start, quantity: angle}
    rate: {hinge: b.start, quantity: rate}
    torque: {hinge: b.start, quantity: torque}
    Mr: {element: "a.element[0]", quantity: moment_y}
    N1: {element: "b.element[1]", quantity: axial_force}
    rel: {point: b.end, quantity: position, frame: knee, component: x}
    reld: {point: b.end, quantity: displacement, frame: knee, component: z}
    relv: {point: b.end, quantity: velocity, frame: knee, component: y}
""")


def _lattice(names: list[str], method: str = "adjoint") -> str:
    data = lattice_tower(names)
    data["solve"]["sensitivity_method"] = method
    return yaml.safe_dump(data, sort_keys=False)


def _forward(text: str) -> str:
    forward = text.replace("sensitivity_method: adjoint", "sensitivity_method: forward")
    assert forward != text
    return forward


def _run(text: str, **parameters):
    data = yaml.safe_load(text)
    data["parameters"].update(parameters)
    return latdyn.run(latdyn.load_scene(data))


def _event_disagreement(forward: list, adjoint: list) -> float:
    """The largest difference of two ``event_sensitivities``' dt, relative to each event's largest."""
    assert [(e["joint"], e["kind"], e["t"]) for e in forward] == [(e["joint"], e["kind"], e["t"]) for e in adjoint]
    worst = 0.0
    for f, a in zip(forward, adjoint):
        assert list(f["dt"]) == list(a["dt"])
        values = np.array([[f["dt"][n], a["dt"][n]] for n in f["dt"]])
        worst = max(worst, float(np.abs(values[:, 1] - values[:, 0]).max() / np.abs(values[:, 0]).max()))
    return worst


def _richardson_end(text: str, name: str, step: float, landed: bool = False) -> dict:
    """{probe: d(its last value)/d(name)} by Richardson-extrapolated central differences of whole runs (steps ``step``
    and half of it, absolute: a coordinate may be 0); ``landed``: the runs ask for the sensitivity by ``name`` (the
    forward method's), so that their steps land on the events as the adjoint's run does."""
    data = yaml.safe_load(text)
    if landed:
        data["solve"].update(sensitivities=[name], sensitivity_method="forward")
    else:
        del data["solve"]["sensitivities"], data["solve"]["sensitivity_method"]
    plain = yaml.safe_dump(data)
    p0 = float(data["parameters"][name])
    central = []
    for h in (step, step / 2):
        up, down = _run(plain, **{name: p0 + h}), _run(plain, **{name: p0 - h})
        assert [e["kind"] for e in up.summary["events"]] == [e["kind"] for e in down.summary["events"]]
        central.append({k: (up.probes[k][-1] - down.probes[k][-1]) / (2 * h) for k in up.probes})
    return {k: (4 * central[1][k] - central[0][k]) / 3 for k in central[0]}


def _richardson_error(adjoint: dict, text: str, name: str, step: float, landed: bool = False) -> float:
    """The largest error of the adjoint's end derivatives by ``name`` against :func:`_richardson_end`, relative to the
    largest over the probes."""
    expected = _richardson_end(text, name, step, landed)
    scale = max(abs(v) for v in expected.values())
    return max(abs(adjoint[probe]["end"][name] - value) / scale for probe, value in expected.items())


# ---------------------------------------------------------------------------------------------- the lattice
def test_a_lattice_by_21_of_its_node_coordinates_cli_api_and_the_forward_method(tmp_path):
    """The tower's tip displacement (z and norm) by 21 interior node coordinates: the CLI's adjoint (summary.json)
    is the API's to the bit and the forward method's to 2.1e-10 of each output's largest derivative (measured; the
    tip_z end by z4c, 1.3e-13 absolute). That is the round-off floor of either method here, not a missing term: the
    forward method's own derivative by a parameter P placing a node at ``z + 0.3*P`` differs from 0.3 × its derivative
    by the coordinate by up to 3.8e-10 (z5c, x1a; the adjoint's by up to 7.7e-11): a node's move enters ∂r/∂X and K δq
    through the members' axial stiffness (EA/L = 8e6 N/m), which cancel to leave a bending response (EI/L³ = 2.6e3 N/m),
    so the round-off of the one is 1e-10 … 1e-9 of the other. The bound here is that floor's."""
    text = _lattice(LATTICE_NAMES)
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    cli = json.loads((out / "summary.json").read_text())
    api = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert cli["probe_sensitivities"] == api.summary["probe_sensitivities"]
    forward = latdyn.run(latdyn.load_scene(yaml.safe_load(_lattice(LATTICE_NAMES, "forward"))))
    assert _disagreement(forward.summary["probe_sensitivities"], api.summary["probe_sensitivities"]) <= 1e-9
    ends = np.array([api.summary["probe_sensitivities"]["tip_z"]["end"][name] for name in LATTICE_NAMES])
    assert np.all(ends != 0.0)


@pytest.mark.parametrize("name", ["z3a", "y5c"])
def test_the_lattice_agrees_with_richardson_central_differences(name):
    """Each probe's end by a node's z and y coordinate against whole runs differenced (steps 2 mm and 1 mm; measured
    z3a 1.9e-8, y5c 2.3e-9 of the larger probe's derivative)."""
    text = _lattice([name])
    adjoint = latdyn.run(latdyn.load_scene(yaml.safe_load(text))).summary["probe_sensitivities"]
    assert _richardson_error(adjoint, text, name, 2e-3) <= 1e-6


def test_the_lattice_loop_on_and_off_give_the_same_bits(monkeypatch):
    """The adjoint's forward pass stores every step in the loop of steps and its reverse pass takes each natively
    (latdyn/analyses/adjoint_in_loop.py); with both switched off, the same derivatives to the bit."""
    text = _lattice(LATTICE_NAMES[:6])
    runs = {}
    for on in (True, False):
        with monkeypatch.context() as patch:
            patch.setattr("latdyn.analyses.adjoint_in_loop.ADJOINT_IN_LOOP", on)
            patch.setattr("latdyn.analyses.adjoint_in_loop.REVERSE_NATIVE", on)
            runs[on] = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert runs[True].summary["sensitivity_steps_in_loop"] == runs[True].summary["steps"] > 0
    assert runs[False].summary["sensitivity_steps_in_loop"] == 0
    assert runs[True].summary["probe_sensitivities"] == runs[False].summary["probe_sensitivities"]


# ---------------------------------------------------------------------------------------------- through a latch
@pytest.fixture(scope="module")
def boom():
    return latdyn.run(latdyn.load_scene(yaml.safe_load(BOOM_LATCH)))


def test_a_boom_whose_hinge_point_moves_through_its_latch_equals_the_forward_method(boom, tmp_path):
    """The latch at 0.41 s, its time's derivative by the hinge point's three coordinates and the spring: the
    adjoint's probes and event time equal the forward method's to 9.1e-13 and 1.7e-12 (measured); the CLI's
    summary.json is the API's to the bit."""
    forward = _run(_forward(BOOM_LATCH))
    assert [e["kind"] for e in boom.summary["events"]] == ["latch"]
    assert _disagreement(forward.summary["probe_sensitivities"], boom.summary["probe_sensitivities"]) <= 1e-10
    assert _event_disagreement(forward.summary["event_sensitivities"], boom.summary["event_sensitivities"]) <= 1e-10
    completed, out = latdyn_run(tmp_path, BOOM_LATCH, quiet=True)
    assert completed.returncode == 0, completed.stderr
    cli = json.loads((out / "summary.json").read_text())
    assert cli["probe_sensitivities"] == boom.summary["probe_sensitivities"]
    assert cli["event_sensitivities"] == boom.summary["event_sensitivities"]


@pytest.mark.parametrize("name", ["bx", "oz"])
def test_the_boom_agrees_with_richardson_central_differences(boom, name):
    """Each probe's end by the base's x and the offset's z, the runs landing on the latch (steps 1e-4 and 5e-5;
    measured bx 2.7e-8, oz 6.7e-9 of the largest probe's derivative; oy 5.8e-9, k 2.8e-9 not run here)."""
    assert _richardson_error(boom.summary["probe_sensitivities"], BOOM_LATCH, name, 1e-4, landed=True) <= 1e-6


# ---------------------------------------------------------------------------------------------- every probe kind
def test_every_probe_kind_by_every_geometry_key_equals_the_forward_method():
    """Positions, displacements and velocities (norms too) in global and the knee's axes, the hinge's angle, rate and
    torque, section forces, by the knee's ``at``, an offset, a free end, a ``y_axis`` and a hinge axis, spinning at
    t = 0: measured ≤ 1.7e-12 of each output's largest derivative (the axial force; the rest ≤ 2.4e-13)."""
    adjoint = _run(EVERY_PROBE)
    forward = _run(_forward(EVERY_PROBE))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


# ---------------------------------------------------------------------------------------------- friction
#: a flexible arm on a friction hinge (Coulomb, static, viscous; its axis tilted off z) at a fixed base, slewing at
#: t = 0 (the initial spin W about z: the hinge's rate a·ω on the fixed base) and slowed by the friction under gravity;
#: it slips throughout (its rate between 2.10 and 1.15 rad/s at the rows); Newton's tolerance 1e-12 for the
#: references
SLEWING = """
title: a flexible arm slewing on a friction hinge at a fixed base, spun at t = 0 and slowed by the friction
parameters: {Fc: 0.3, Fs: 0.4, cv: 0.05, EI: 200.0, m: 0.5, W: 2.0}
gravity: [0, 0, -9.81]
initial_velocity: {angular: [0, 0, "W"]}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5, rhoIy: 0.01, rhoIz: 0.013}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.2, 0.1], mass: "m", com: [0.05, 0, 0], inertia: [0.02, 0.03, 0.04]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0.1, -0.2, 1], friction: {coulomb: "Fc", static: "Fs", viscous: "cv"}}}
solve: {analysis: transient, sensitivity_method: adjoint, dt: 0.005, t_end: 0.3, tol: 1.0e-12,
        sensitivities: [Fc, cv, EI, m, W]}
output:
  every: 0.01
  probes:
    angle: {hinge: arm.start, quantity: angle}
    rate: {hinge: arm.start, quantity: rate}
    torque: {hinge: arm.start, quantity: torque}
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: displacement, component: z}
    mid: {point: "arm.node[1]", quantity: displacement, component: norm}
"""

#: SLEWING braked ten times harder: its hinge sticks at t = 0.284 (the end of a step cut after Newton failed)
SLEWING_STOPS = (SLEWING.replace("parameters: {Fc: 0.3, Fs: 0.4,", "parameters: {Fc: 3.0, Fs: 4.0,")
                 .replace("t_end: 0.3,", "t_end: 0.8,"))
assert SLEWING_STOPS.count("3.0, Fs: 4.0") == 1 and "t_end: 0.8," in SLEWING_STOPS


@pytest.fixture(scope="module")
def slewing():
    return _run(SLEWING)


def test_a_slewing_arm_slipping_on_its_friction_equals_the_forward_method(slewing, tmp_path):
    """Friction while the joint slips is a force of the residual (its rate derivative in the exact matrices, its law's
    values through the generated ``friction_force_D_law``): the adjoint by the friction's Coulomb and viscous values,
    the arm's EI, the tip's mass and the spin equals the forward method's to 8.9e-13 of each output's largest
    derivative (measured; refused on 86d57d9, "a joint that sticks is an event"); the CLI's summary.json is the
    API's."""
    assert np.all(slewing.probes["rate"] > 1.1)
    forward = _run(_forward(SLEWING))
    assert _disagreement(forward.summary["probe_sensitivities"], slewing.summary["probe_sensitivities"]) <= 1e-10
    completed, out = latdyn_run(tmp_path, SLEWING, quiet=True)
    assert completed.returncode == 0, completed.stderr
    assert json.loads((out / "summary.json").read_text())["probe_sensitivities"] == \
        slewing.summary["probe_sensitivities"]


@pytest.mark.parametrize("name, step", [("Fc", 3e-5), ("W", 2e-4)])
def test_the_slewing_arm_agrees_with_richardson_central_differences(slewing, name, step):
    """Each probe's end by the Coulomb level and the spin (steps 1e-4 of them; measured Fc 2.6e-8, W 2.0e-9; EI 1.1e-7,
    cv 1.5e-7, m 7.1e-8 not run here)."""
    assert _richardson_error(slewing.summary["probe_sensitivities"], SLEWING, name, step) <= 1e-6


def test_a_panel_stuck_from_t0_is_taken():
    """A joint stuck from t = 0 and released by its torque (tests/test_sensitivities_friction.py's panel; refused at
    t = 0 on 40bf44a) equals the forward method. (The braked arm beside its torque probe, refused here when its hinge
    stuck until 5a68b93, is taken: tests/test_adjoint_friction_sticks_beside.py.)"""
    from tests.test_sensitivities_friction import STUCK
    stuck = yaml.safe_load(STUCK)
    forward = latdyn.run(latdyn.load_scene(stuck))
    stuck["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(stuck))
    assert _disagreement(forward.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def test_a_guides_compliant_stop_equals_the_forward_method():
    """A guide's compliant stop (its onset) was let through on 86d57d9 without its onset's time carried:
    tests/test_sensitivities_friction.py's slider driven into its guide's compliant stop came out 1.2e-3 … 7.6e-2 off
    the forward method (measured). Its onset is now transposed as a hinge's (latdyn/analyses/adjoint_sensitivities.py,
    the step-size rule ``onset``; tests/test_adjoint_events_more.py): the adjoint equals the forward method."""
    from tests.test_sensitivities_friction import GUIDE
    from tests.test_sensitivities_refusals_lifted import _adjoint_error, _both
    forward, adjoint = _both(GUIDE)
    assert _adjoint_error(forward, adjoint) < 1e-10


def test_the_boom_interrupted_before_its_latch_resumes_to_the_same_derivatives(tmp_path, monkeypatch):
    """The stored trajectory rides in the checkpoint; the geometry's derivatives are made anew from the scene on
    resume: interrupted at t = 0.2 (before the latch), resumed, sensitivities.csv and summary.json's probe and event
    sensitivities are the uninterrupted run's byte for byte."""
    from tests.resumed_runs import interrupted_and_whole

    out, whole = interrupted_and_whole(yaml.safe_load(BOOM_LATCH), tmp_path, monkeypatch, 0.2)
    assert (out / "sensitivities.csv").read_bytes() == (whole / "sensitivities.csv").read_bytes()
    resumed, uninterrupted = (json.loads((folder / "summary.json").read_text()) for folder in (out, whole))
    assert resumed["probe_sensitivities"] == uninterrupted["probe_sensitivities"]
    assert resumed["event_sensitivities"] == uninterrupted["event_sensitivities"]
