"""Controllers that read inputs, a cable's tension, an element's section force or a joint's force, in the
sensitivities' loop of steps (issue 34 item 2; latdyn/analyses/sensitivities_in_loop.py ``_controller_refusal`` and
``_reads``, csrc/sensitivity_loop.c ``controller_parameter_forces``; the Python path's
latdyn/analyses/sensitivities.py ``_force_sensor_refusal``).

An input is constant in a run: the compiled laws read the scene's inputs' array (bound before each call of the loop),
∂/∂p and ∂/∂t of it are 0. A force sensor's coupling along δq, δv is in the step's exact K and C (csrc/evaluate.c
``sensor_jacobian``: the generated cable_tension, beam_section_forces_D_q, the joint's hinge_force), the controller's
∂f/∂p is read at the value the evaluation left in Work (``sensor_values``, the same C on both paths). Each scene is 3D; the loop's
sensitivities are the per-step Python path's (the private switch ``SENSITIVITIES_IN_LOOP`` off) to the bit, and they
agree with Richardson-extrapolated central differences. A parameter in the sensed force's own laws is differentiated
on the Python path (its ∂F/∂p through ∂f/∂s), which the loop does not take yet."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.reference_runs import reference_runs
from tests.test_sensitivities_cables import CABLE_3D
from tests.test_sensitivities_in_loop_controllers2 import CHAIN
from tests.test_sensitivities_in_loop_state_laws import _run, _same
from tests.test_sensitivities_native_parts import ARM

#: the 3D arm's skew hinge driven by a PD controller with a set point and a feed-forward from inputs,
#: y = Kp (ref − θ) − Kd θ̇ + ff·ref; its gains and a section value as parameters
BOOM_INPUT = (ARM.replace("t_end: 0.04", "t_end: 0.3")
              .replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}",
                       "inputs: {ref: 0.4, ff: 0.5}\nparameters: {E: 1.0, rho: 0.5, F: 2.0, Kp: 20.0, Kd: 1.5}")
              .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: 2.0, damping: 0.2, torque: "pd"}')
              .replace("solve: {", 'controllers:\n  pd: {output: "Kp*(ref - hinge) - Kd*rate + ff*ref"}\nsolve: {')
              .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                       "    hinge: {hinge: b.start, quantity: angle}\n    rate: {hinge: b.start, quantity: rate}\n")
              .replace("sensitivities: [E, rho, F]", "sensitivities: [E, Kp, Kd]"))
#: the arm's skew hinge's torque (its spring and damper) read by a clipped controller that pushes the tip in the
#: knee's axes; the gain, a section value and the load as parameters
ARM_TORQUE = (ARM.replace("t_end: 0.04", "t_end: 0.3")
              .replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}", "parameters: {E: 1.0, rho: 0.5, F: 2.0, Kt: 0.4}")
              .replace('  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}\n',
                       '  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}\n'
                       '  - {at: b.end, force: [0, "0.3*relief", 0], moment: ["0.05*relief", 0, 0], frame: knee}\n')
              .replace("solve: {", 'controllers:\n  relief: {output: "Kt*tq + 0.2*hinge", limits: [-6, 6]}\nsolve: {')
              .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                       "    hinge: {hinge: b.start, quantity: angle}\n    tq: {hinge: b.start, quantity: torque}\n")
              .replace("sensitivities: [E, rho, F]", "sensitivities: [E, F, Kt]"))
#: the first element's axial force fed back to the skew hinge; the gain, the load and the knee's mass as parameters
ARM_AXIAL = (ARM.replace("t_end: 0.04", "t_end: 0.3")
             .replace("parameters: {E: 1.0, rho: 0.5, F: 2.0}", "parameters: {E: 1.0, rho: 0.5, F: 2.0, Ka: 0.05, m: 0.8}")
             .replace("mass: 0.8,", 'mass: "m",')
             .replace("stiffness: 30.0, damping: 0.2}", 'stiffness: 30.0, damping: 0.2, torque: "ax_ctl"}')
             .replace("solve: {", 'controllers:\n  ax_ctl: {output: "-Ka*ax - 2*hinge"}\nsolve: {')
             .replace("    hinge: {hinge: b.start, quantity: angle}\n",
                      '    hinge: {hinge: b.start, quantity: angle}\n'
                      '    ax: {element: "a.element[0]", quantity: axial_force}\n')
             .replace("sensitivities: [E, rho, F]", "sensitivities: [F, Ka, m]"))
#: tests/test_sensitivities_cables.py's skew cable catching the arm's tip mass, the arm now on a skew root hinge whose
#: torque a clipped controller sets from the hinge's angle and the cable's tension (taut, slack, taut, slack, taut)
CABLE_LIMIT = (CABLE_3D.replace("parameters: {EA: 5000.0,", "parameters: {Kp: 3.0, Kt: 0.02, EA: 5000.0,")
               .replace("arm: {from: base, to: tip, section: s, elements: 3}",
                        "arm: {from: base, to: tip, section: s, elements: 3, start: {hinge: {axis: [0, 0.6, 0.8], "
                        'stiffness: 4.0, damping: 0.3, torque: "lim"}}}')
               .replace("solve: {", 'controllers:\n  lim: {output: "Kp*(0.2 - root) - Kt*pull", limits: [-4, 4]}\n'
                                    "solve: {")
               .replace("sensitivities: [EA, L, EI, c]", "sensitivities: [Kp, Kt, EI, m]")
               .replace("    tip_z:", "    root: {hinge: arm.start, quantity: angle}\n"
                                     "    pull: {cable: stay, quantity: tension}\n    tip_z:"))
#: the tension limit's controller on the cable's length instead (a sensor of its elements' end nodes)
CABLE_SPAN = (CABLE_LIMIT.replace("Kt*pull", "Kt*span").replace("Kt: 0.02", "Kt: 2.0")
              .replace("    pull: {cable: stay, quantity: tension}\n",
                       "    pull: {cable: stay, quantity: tension}\n    span: {cable: stay, quantity: length}\n"))
#: tests/test_sensitivities_in_loop_controllers2.py's chain with the estimator reading an input
CHAIN_INPUT = (CHAIN.replace("parameters: {", "inputs: {u: 0.1}\nparameters: {")
               .replace('"angle + 0.1*tip_y', '"angle + u*tip_y'))
assert all(mark in text for text, mark in ((BOOM_INPUT, "ff*ref"), (ARM_TORQUE, "Kt*tq"), (ARM_AXIAL, "Ka*ax"),
                                           (CABLE_LIMIT, "Kt*pull"), (CHAIN_INPUT, "u*tip_y"), (CABLE_SPAN, "Kt*span")))


@pytest.mark.parametrize("text", [BOOM_INPUT, ARM_TORQUE, ARM_AXIAL, CHAIN_INPUT],
                         ids=["PD with inputs", "hinge torque read", "axial force read", "chain reading an input"])
def test_controllers_reading_inputs_and_forces_take_every_step_in_the_loop(text, monkeypatch):
    """Every step in the loop of steps; the Python path's sensitivities to the bit."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] == 60
    _same(native, python)


@pytest.mark.parametrize("text, changes", [(CABLE_LIMIT, ["taut", "slack", "taut", "slack", "taut"]),
                                           (CABLE_SPAN, ["taut", "slack", "taut", "slack"])],
                         ids=["tension", "length"])
def test_a_controller_on_a_cables_tension_or_length_takes_the_smooth_steps_in_the_loop(text, changes, monkeypatch):
    """The cable's changes and the steps near them from Python (csrc/cable_forces.c ``cable_near_change``), the
    other steps in the loop (measured 45 of 69, 46 of 64); the Python path's sensitivities to the bit (by the length's
    gain against Richardson differences 6.9e-10–1.9e-9, measured)."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert [e["kind"] for e in native.summary["events"]] == changes
    assert native.summary["time_loop"] == "compiled"
    assert 40 <= native.summary["sensitivity_steps_in_loop"] < native.summary["steps"]
    _same(native, python)


def _scene(text: str, only: str | None = None, **values):
    data = yaml.safe_load(text)
    data["parameters"].update(values)
    if only is not None:   # (a run with sensitivities lands on events as the differentiated run does)
        data["solve"]["sensitivities"] = [only]
    return latdyn.load_scene(data)


def _agree(result, text: str, name: str) -> None:
    """``result``'s sensitivities by ``name``, every probe over the rows, within 1e-6 of each probe's largest of
    Richardson-extrapolated central differences of whole runs (steps 1e-4 and 5e-5 of the value; without
    sensitivities where they write ``result``'s probes: tests/reference_runs.py)."""
    p0 = yaml.safe_load(text)["parameters"][name]
    run = reference_runs(text, result, lambda **moved: latdyn.run(_scene(text, name, **moved)))
    central = []
    for step in (1e-4 * abs(p0), 5e-5 * abs(p0)):
        up, down = run(**{name: p0 + step}), run(**{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max()
        assert error <= 1e-6, (probe, name, error)


@pytest.mark.parametrize("text, name", [(BOOM_INPUT, "Kp"), (ARM_TORQUE, "Kt"), (ARM_AXIAL, "Ka"), (CABLE_LIMIT, "Kt")],
                         ids=["input set point", "hinge torque", "axial force", "cable tension"])
def test_the_sensitivities_agree_with_differences(text, name):
    """The sensitivities by the gain on the input or the force, every probe over the rows, against
    Richardson-extrapolated central differences (steps 1e-4 and 5e-5 of the value): measured 4e-9 to 4e-8 of each
    probe's largest."""
    result = latdyn.run(_scene(text, name))
    assert result.summary["sensitivity_steps_in_loop"] > 0
    _agree(result, text, name)


def test_an_input_set_before_the_run_is_the_one_the_loop_reads(monkeypatch):
    """The boom's set point set on the loaded scene before ``latdyn.run`` (latdyn.scene.inputs: the array the compiled
    laws read): the loop and the Python path give the same bits, and not those of the scene's value."""
    runs = []
    for in_loop in (True, False):
        scene = latdyn.load_scene(yaml.safe_load(BOOM_INPUT))
        scene.inputs.set("ref", 0.9)
        with monkeypatch.context() as patch:
            patch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", in_loop)
            runs.append(latdyn.run(scene))
    native, python = runs
    assert native.summary["sensitivity_steps_in_loop"] == 60
    _same(native, python)
    as_written = _run(BOOM_INPUT, monkeypatch, True)
    assert not np.array_equal(as_written.sensitivities[("hinge", "Kp")], native.sensitivities[("hinge", "Kp")])


def test_the_cli_writes_the_python_paths_files_for_the_tension_limit(tmp_path):
    """``latdyn run`` on the cable's tension limit takes the loop; the same command with the switch off (a process of
    its own) writes the same sensitivities.csv and probes.csv, byte for byte, and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, CABLE_LIMIT)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert summary["time_loop"] == "compiled" and 40 <= summary["sensitivity_steps_in_loop"] < summary["steps"]
    the_loop_off_writes_the_same(tmp_path, out)


#: the scenes with a parameter in the sensed force's own laws: the hinge's stiffness 30 E, the section's E (EA, EI, GJ
#: of the element read), the cable's EA, damping and rest length
TORQUE_K = ARM_TORQUE.replace("stiffness: 30.0", 'stiffness: "30*E"')
AXIAL_E = ARM_AXIAL.replace("[F, Ka, m]", "[F, Ka, E]")
CABLE_EA = CABLE_LIMIT.replace("[Kp, Kt, EI, m]", "[Kp, Kt, EA, c]")
assert 'stiffness: "30*E"' in TORQUE_K and "[F, Ka, E]" in AXIAL_E and "[Kp, Kt, EA, c]" in CABLE_EA


@pytest.mark.parametrize("text, name, in_python", [(AXIAL_E, "E", 0), (CABLE_EA, "EA", 24)],
                         ids=["section values", "cable EA"])
def test_a_parameter_in_the_sensed_forces_laws_is_differentiated(text, name, in_python, monkeypatch):
    """The force's own ∂F/∂p through ∂f/∂s (ControllerTerms.sensed_force_slopes: the generated
    beam_section_forces_D_section through csrc/parameter_forces.c section_force_slope, the cable's tension's from
    cable_force, csrc/cable_forces.c cable_tension_slope in the loop): in the loop of steps (every step; the cable's
    but the 24 at and after its five changes), the same bits with the switch either way, and agreement with Richardson
    differences (measured 1.1e-9–5.6e-8, the cable's damping c too, 3.3e-8). The hinge's (TORQUE_K) takes the loop:
    tests/test_sensitivities_in_loop_controller_reads2.py."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["sensitivity_steps_in_loop"] == native.summary["steps"] - in_python > 0
    _same(native, python)
    result = latdyn.run(_scene(text, name))
    _agree(result, text, name)


def test_a_force_read_by_a_controller_with_states_is_refused_naming_it():
    """A controller with states reading the hinge's torque: its states' step would need the force's δs along δq; a
    SceneError naming solve.sensitivities and the controller."""
    text = ARM_TORQUE.replace('"Kt*tq + 0.2*hinge", limits: [-6, 6]}', '"Kt*tq + 0.2*hinge + I", states: {I: "tq"}}')
    assert "states: {I:" in text
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    assert "solve.sensitivities" in str(refused.value) and "relief reads 'tq'" in str(refused.value), str(refused.value)
    assert "with states that reads a force" in str(refused.value), str(refused.value)
