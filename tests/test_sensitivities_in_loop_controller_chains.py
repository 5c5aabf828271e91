"""Chains of controllers whose first link reads a force whose own laws a parameter moves, in the sensitivities' loop of
steps (issue 34 item 2; latdyn/analyses/derivative_laws.py ``chained_outputs``, csrc/sensitivity_loop.c
``controller_parameter_forces``).

The 3D wheel of tests/test_weight_derivative_controllers_held.py (FORCE_CHAINED: its arm on a skew root hinge with a
spring ks (1 + 3θ²), ``pd`` reading that hinge's torque, ``push`` reading ``pd`` and driving a load in the wheel's
axes, a rigid stop hit once) with a parameter of the read force's laws alone in ``solve.sensitivities``: no controller
has a partial ∂f/∂p, and the slope enters the chain at ``pd`` through ∂f/∂s ∂F/∂p. Before, ``chained_outputs`` started
the chain only at controllers with partials, so ``push``'s output was not compiled and the loop left its slope 0: the
loop's sensitivities were 0.12 (the wheel's angle by ks) to 0.19 (by the section's EIz) of their largest off the
Python path (the private switch ``SENSITIVITIES_IN_LOOP`` off), which agrees with Richardson differences of whole
runs. Each case here failed so (checked on 279ca0e); now the loop and the Python path give the same bits."""
from __future__ import annotations

import pytest

import latdyn
from tests.cli_runs import latdyn_run, summary_of, the_loop_off_writes_the_same
from tests.sensitivity_equality import assert_same_sensitivities
from tests.test_sensitivities_in_loop_controller_reads import _agree, _scene
from tests.test_sensitivities_in_loop_state_laws import _run
from tests.test_weight_derivative_controllers_held import FORCE_CHAINED

#: the chain by the read hinge's spring ks alone
CHAIN_KS = FORCE_CHAINED.replace("sensitivities: [ks, Kp]", "sensitivities: [ks]")
#: the same, pd driving no torque: the chain reaches the structure through push's load alone
CHAIN_LOAD = CHAIN_KS.replace('torque: "Kt*pd + 0.1*Kt*Kt"', 'torque: "0.3 + 0.1*Kt*Kt"')
#: a chain of three: pull reads push and pd, and turns the wheel's load's moment
CHAIN_THREE = (CHAIN_KS.replace('  push: {output: "Kl*(0.7 - tip_x) + 0.2*pd"}',
                                '  push: {output: "Kl*(0.7 - tip_x) + 0.2*pd"}\n'
                                '  pull: {output: "0.5*push*(1 + 0.3*pd) - 0.2*angle"}')
               .replace('moment: ["0.5*push", 0, 0]', 'moment: ["0.5*pull", 0, 0]'))
#: pd reading a stay's tension instead, the stay's EA (EAc) the parameter; the stay goes slack and taut again
CHAIN_TENSION = (CHAIN_KS.replace("parameters: {ks: 40.0,", "parameters: {EAc: 300.0, ks: 40.0,")
                 .replace("controllers:", "cables:\n  stay: {from: {body: base, offset: [0.3, -0.4, 0.9]}, to: wheel, "
                                          'EA: "EAc", rest_length: 0.6, damping: 0.2}\ncontrollers:')
                 .replace("0.4*tq + 0.2*tq*angle", "0.004*pull + 0.002*pull*angle")
                 .replace("    tq: {hinge: arm.start, quantity: torque}\n",
                          "    tq: {hinge: arm.start, quantity: torque}\n    pull: {cable: stay, quantity: tension}\n")
                 .replace("sensitivities: [ks]", "sensitivities: [EAc]"))
#: pd reading the first element's bending moment about z, the section's EIz (EI) the parameter
CHAIN_SECTION = (CHAIN_KS.replace("parameters: {ks: 40.0,", "parameters: {EI: 10000.0, ks: 40.0,")
                 .replace("EIz: 1.0e4,", 'EIz: "EI",')
                 .replace("0.4*tq + 0.2*tq*angle", "0.04*my + 0.02*my*angle")
                 .replace("    tq: {hinge: arm.start, quantity: torque}\n",
                          '    tq: {hinge: arm.start, quantity: torque}\n'
                          '    my: {element: "arm.element[0]", quantity: moment_z}\n')
                 .replace("sensitivities: [ks]", "sensitivities: [EI]"))
assert "sensitivities: [ks]" in CHAIN_KS and '"0.3 + 0.1*Kt*Kt"' in CHAIN_LOAD and '"0.5*pull"' in CHAIN_THREE
assert "0.004*pull" in CHAIN_TENSION and "[EAc]" in CHAIN_TENSION and 'EIz: "EI"' in CHAIN_SECTION
assert "0.04*my" in CHAIN_SECTION and "[EI]" in CHAIN_SECTION


@pytest.mark.parametrize("text, in_loop", [(CHAIN_KS, 39), (CHAIN_LOAD, 40), (CHAIN_THREE, 38), (CHAIN_TENSION, 37),
                                           (CHAIN_SECTION, 39)],
                         ids=["joint torque", "through push's load alone", "chain of three", "cable tension",
                              "section force"])
def test_a_chain_from_a_moved_force_takes_the_loop_with_the_python_paths_bits(text, in_loop, monkeypatch):
    """The loop takes every smooth step (all but the stop's and the landing after it, and the stay's slack and taut
    changes') and its sensitivities, extremes and event derivatives are the per-step Python path's to the bit, every
    column nonzero (before: 0.05–0.19 of the largest off)."""
    native, python = _run(text, monkeypatch, True), _run(text, monkeypatch, False)
    assert native.summary["time_loop"] == "compiled"
    assert native.summary["sensitivity_steps_in_loop"] == in_loop
    assert_same_sensitivities(native, python, nonzero="each")


def test_the_chain_by_the_read_joints_spring_agrees_with_differences():
    """By ks, every probe over the rows within 1e-6 of Richardson-extrapolated central differences of whole runs
    (measured 4.2e-8 on the wheel's angle; before, the loop's was 0.12 off; through the stay's EA 2.9e-8, the
    section's EIz and the chain of three: docs/performance.md "Controller chains from a moved force in the loop")."""
    result = latdyn.run(_scene(CHAIN_KS, "ks"))
    assert result.summary["sensitivity_steps_in_loop"] == 39
    _agree(result, CHAIN_KS, "ks")


def test_latdyn_run_writes_the_python_paths_files(tmp_path):
    """``latdyn run`` on the chain by ks takes the loop; the same command with the loop off (a process of its own)
    writes the same sensitivities.csv and probes.csv byte for byte and summary.json's sensitivities."""
    completed, out = latdyn_run(tmp_path, CHAIN_KS)
    assert completed.returncode == 0, completed.stderr
    assert summary_of(out)["sensitivity_steps_in_loop"] == 39
    the_loop_off_writes_the_same(tmp_path, out)
