"""Cables beside controllers and beside explicit time dependence in the transient sensitivities' loop of steps (issue 34
item 2; latdyn/analyses/sensitivities_in_loop.py ``model_refusal``): the cables' columns of ∂r/∂p (csrc/cable_forces.c)
are added after the controllers' and the loads' and before ∂r/∂t δt_n (csrc/sensitivity_loop.c), as the per-step Python
path adds them (ParameterDerivatives.residual_derivatives, then CableSensitivities.residual_derivatives, then
TransientSensitivities._add_time_columns), so the sensitivities are that path's (the private switch
``SENSITIVITIES_IN_LOOP`` off) to the bit: a 3D mast hinged at its base, braced by three pretensioned cables, its hinge
driven by a PD controller (by the gains, the set point and the cables' and mast's values; with the controller's output
clipped; with a controller without parameters reading a cable's length); the shipped cable truss (its rest length held)
under a tip load of t, latching and its cables going taut and slack; a mass dropped on a slack cable under a load of t;
the PD mast under a push of t, its hinge torque the controller's output plus a torque of t, and (without cables) the
PD-driven 3D gimbal latching under a load of t: a hinge law that names a controller's output or an input takes the
loop beside explicit time dependence where its rate in t names t alone (``_rate_in_time_alone``).
Through the API and ``latdyn run``; the PD mast from the loop against Richardson central differences. And a guard: a
section value is a constant (no law of t or of an input, loader.py), so that a section parameter's derivative law is a
constant and the loop's section rows are too."""
from __future__ import annotations

import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.test_sensitivities_cables import DROP
from tests.test_sensitivities_events import _agree
from tests.test_sensitivities_in_loop_cables import MAST, _run, _same, truss
from tests.test_sensitivities_in_loop_linked_control import GIMBAL_PD

#: the 3D mast of test_sensitivities_in_loop_cables hinged at its base about y, braced by its three cables, a PD
#: controller driving the hinge towards ``ref`` (reading its angle and rate); by the gains, the set point, the
#: cables' EA and rest length, the mast's EI and the cable's ρA
MAST_PD = (MAST.replace("parameters: {EA: 50000.0,", "parameters: {Kp: 60.0, Kd: 4.0, ref: 0.05, EA: 50000.0,")
           .replace("mast: {from: base, to: top, section: s, elements: 4}",
                    "mast: {from: base, to: top, section: s, elements: 4,\n"
                    '         start: {hinge: {axis: [0, 1, 0], stiffness: 30.0, damping: 0.5, torque: "pd"}}}')
           .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - ang) - Kd*om"}\nsolve: {')
           .replace("    pull: {cable: g2, quantity: tension}\n",
                    "    pull: {cable: g2, quantity: tension}\n"
                    "    ang: {hinge: mast.start, quantity: angle}\n    om: {hinge: mast.start, quantity: rate}\n")
           .replace("sensitivities: [EA, L, EI, rho]", "sensitivities: [Kp, Kd, ref, EA, L, EI, rho]"))
#: the same with the controller's output clipped to ±3 N·m (its limits decide, by its compiled output, whether the
#: gains move the torque)
MAST_PD_CLIPPED = MAST_PD.replace('pd: {output: "Kp*(ref - ang) - Kd*om"}',
                                  'pd: {output: "Kp*(ref - ang) - Kd*om", limits: [-3.0, 3.0]}')
#: the mast's hinge driven by a controller without parameters that reads the length of cable g1 (its coupling in the
#: exact K on both paths), by the cables' and the mast's values
MAST_BY_LENGTH = (MAST_PD.replace('pd: {output: "Kp*(ref - ang) - Kd*om"}', 'hold: {output: "-40*(span - 2.5) - 2*om"}')
                  .replace("    ang: {hinge", "    span: {cable: g1, quantity: length}\n    ang: {hinge")
                  .replace('torque: "pd"', 'torque: "hold"').replace("[Kp, Kd, ref, EA", "[EA"))
#: the PD mast under a push of t at its top, its hinge torque the controller's output plus a torque of t (a hinge law of
#: t and a controller's output whose rate in t names t alone: tabulated as a law of t's; the cables make events, so
#: ∂r/∂t enters the steps)
MAST_PD_PUSHED = (MAST_PD.replace("- {at: top, force: [40, 25, 0]}",
                                  '- {at: top, force: ["40*(1 + 0.5*sin(15*t))", "25*cos(9*t)", 0]}')
                  .replace('torque: "pd"', 'torque: "pd + 0.3*sin(9*t)"'))
#: the same torque naming an input whose rate in t (u) reads it: stays on the Python path
MAST_PD_INPUT = (MAST_PD_PUSHED.replace('torque: "pd + 0.3*sin(9*t)"', 'torque: "pd + u*t"')
                 .replace("gravity:", "inputs: {u: 0.2}\ngravity:"))
#: the 3D gimbal of rigid links, PD-driven, latching, under a tip load of t (no cables: a controller's torque beside
#: explicit time dependence and a latch)
GIMBAL_PD_PUSHED = GIMBAL_PD.replace('force: [0, "P", "-0.5*P"]', 'force: [0, "P*(1 + sin(12*t))", "-0.5*P*cos(7*t)"]')
assert "0.3*sin(9*t)" in MAST_PD_PUSHED and "15*t" in MAST_PD_PUSHED and '"pd + u*t"' in MAST_PD_INPUT
assert "sin(12*t)" in GIMBAL_PD_PUSHED
assert 'torque: "pd"' in MAST_PD and "om: {hinge" in MAST_PD and "[Kp, Kd, ref, EA, L, EI, rho]" in MAST_PD
assert "limits: [-3.0, 3.0]" in MAST_PD_CLIPPED and 'torque: "hold"' in MAST_BY_LENGTH and "span: {cable" in MAST_BY_LENGTH


def truss_pulled() -> str:
    """The shipped cable truss (test_sensitivities_in_loop_cables.truss, its rest length held) with its cables let out
    to 2.6 m and a load of t at its tip station (by F), over 0.8 s: its bays latch at 0.55 s and its cables go taut and
    slack after; by the cables' EA, the longerons' EI and F."""
    data = yaml.safe_load(truss(reel=False))
    data["parameters"]["F"] = 0.5
    for cable in data["cables"].values():
        cable["rest_length"] = 2.6
    data["loads"] = [{"at": "s3a", "force": ["F*(1 + sin(6*t))", 0, "0.5*F*cos(4*t)"]}]
    data["solve"].update(t_end=0.8, sensitivities=["EA", "EI", "F"])
    return yaml.safe_dump(data, sort_keys=False)


#: a mass dropped on a slack cable (test_sensitivities_cables.DROP) under a load of t, by F, the rest length and EA
DROP_PULLED = (DROP.replace("parameters: {L: 1.0,", "parameters: {F: 2.0, L: 1.0,")
               .replace("solve: {", 'loads:\n  - {at: bob, force: ["F*sin(9*t)", "0.5*F*t", "-F*(1 + cos(13*t))"]}\n'
                                    "solve: {")
               .replace("sensitivities: [L, EA]", "sensitivities: [L, EA, F]"))
assert "F*sin(9*t)" in DROP_PULLED and "[L, EA, F]" in DROP_PULLED


@pytest.mark.parametrize("text", [MAST_PD, MAST_PD_CLIPPED, MAST_BY_LENGTH, MAST_PD_PUSHED],
                         ids=["PD", "PD clipped", "a controller reading a cable's length", "PD and laws of t"])
def test_a_cable_braced_mast_with_a_controlled_hinge_takes_every_step_in_the_loop(text, monkeypatch):
    """Every step in the loop of steps (in C), the sensitivities the per-step Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled" and python.summary["time_loop"] == "python"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 50
    assert python.summary["sensitivity_steps_in_loop"] == 0 and not native.summary.get("events")
    _same(native, python)


@pytest.mark.parametrize("text, kinds", [(truss_pulled(), {"latch", "taut", "slack"}), (DROP_PULLED, {"taut", "slack"})],
                         ids=["cable truss latching under a load of t", "mass dropped on a cable under a load of t"])
def test_cables_beside_a_load_of_t_and_events_are_the_python_paths(text, kinds, monkeypatch):
    """The smooth steps between the latches and the cables' changes in the loop, ∂r/∂t δt_n in their columns; the
    sensitivities and the events' time derivatives the Python path's to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert 0.8 * steps < in_loop < steps and python.summary["sensitivity_steps_in_loop"] == 0
    assert kinds <= {event["kind"] for event in native.summary["events"]}
    assert native.summary["event_sensitivities"]
    _same(native, python)


def test_a_controlled_gimbal_latching_under_a_load_of_t_is_the_python_paths(monkeypatch):
    """A hinge torque that is a controller's output beside explicit time dependence and events (its rate in t, 0, a
    value of t alone): the smooth steps in the loop, the sensitivities and the latch's time derivative the Python
    path's to the bit."""
    native, python = _run(GIMBAL_PD_PUSHED, monkeypatch, True), _run(GIMBAL_PD_PUSHED, monkeypatch, False)
    steps, in_loop = native.summary["steps"], native.summary["sensitivity_steps_in_loop"]
    assert 0.9 * steps < in_loop < steps and python.summary["sensitivity_steps_in_loop"] == 0
    assert [event["kind"] for event in native.summary["events"]] == ["latch"]
    _same(native, python)


def test_a_hinge_law_whose_rate_in_t_reads_an_input_keeps_the_python_path(monkeypatch):
    """Guard: a torque ``pd + u*t`` (its rate in t, u, reads an input: not tabulated) keeps every step on the Python
    path, whichever the switch."""
    native = _run(MAST_PD_INPUT, monkeypatch, True)
    assert native.summary["sensitivity_steps_in_loop"] == 0 and native.summary["time_loop"] == "python"


@pytest.mark.parametrize("name", ["Kp", "L"])
def test_the_pd_mast_from_the_loop_agrees_with_richardson_central_differences(name, monkeypatch):
    """The PD mast's sensitivities by a gain (the controller's compiled partial) and by the cables' rest length (the
    generated cable_force_D_rest_length), from the loop of steps, against Richardson-extrapolated central differences
    of whole runs, to 1e-6 of each probe's largest."""
    native = _run(MAST_PD, monkeypatch, True)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"]
    _agree(native, MAST_PD, name)


def test_the_cli_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the PD mast takes the loop for every step; with the switch off (a process of its own) it
    writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's probe sensitivities."""
    completed, out = latdyn_run(tmp_path, MAST_PD)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and summary["sensitivity_steps_in_loop"] == summary["steps"] == 50
    the_loop_off_writes_the_same(tmp_path, out)


@pytest.mark.parametrize("value, extra", [('"EI*(1 + 0.5*t)"', ""), ('"EI*u"', "inputs: {u: 1.0}\n")],
                         ids=["a law of t", "a law of an input"])
def test_a_section_value_is_a_constant(value, extra):
    """Guard (the loop's section rows are constant: ``refusal`` asks ``law.is_constant`` of a section parameter's
    derivative law, which no scene can make otherwise): a section value of t or of an input is refused where the scene
    is read, naming the key."""
    text = extra + MAST.replace('EIy: "EI"', f"EIy: {value}")
    with pytest.raises(SceneError, match=r"sections\.s\.EIy: expected a constant"):
        latdyn.load_scene(yaml.safe_load(text))
