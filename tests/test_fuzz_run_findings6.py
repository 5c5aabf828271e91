"""What the fuzz7 helper found in the open items and in benchmarks/fuzz_combined3.py's combinations (session
2026-11-28 twelfth).

1. A massless slide held only by a controller's negative stiffness (``8*s + sin(t)``; s = −sin(t)/8 exactly) was
   solved with "the energy balance drifts: energy_balance_error 1". The structure holds nothing (no mass, no element,
   no spring) and dissipates nothing, so its created energy is −W, and W = ∫ ctl ds is the work of a force that
   equilibrium makes 0 (its round-off: 4e-19 J here): the ratio is |W|/|W| = 1 whatever W. The round-off floor of the
   balance (½ Σ EA L (8 ε)² over the elements, progress.energy_round_off) is 0 without elements. The balance is now 0
   where the structure held and dissipated nothing beyond that floor (progress.TransientProgress.held_scale), as it
   was where every energy stayed within it.
2. sensstates' WHEEL_STOP (a PI on a filtered angle driving a wheel onto its stop; energy_balance_error 0.426 at
   dt = 0.01): the account is complete. The controller's work on the hinge is in W and the stop's losses in D: with the
   arm massless (rigid through the jump) the same scene balances to 9.9e-5 at dt = 0.01 (a guard below). With the
   arm's inertia the impacts' jumps are weighted by M + dt²K (docs/energy.md, "Impacts on flexible parts with
   inertia"): at dt = 0.01 the first impact removes 0.420 J (the rigid arm's 0.077), and the second, 0.025 s later,
   raises the kinetic energy by 0.217 J, which the balance keeps as created (events.hinge_events: a jump that raises
   the kinetic energy is not a negative dissipation). The motion after the impacts is not converged in dt
   (declared loss 0.44, 0.38, 0.23, 0.14, 0.12 J at dt = 0.01 … 5e-4): the warning is right, and says why.
3. A controller whose output names t reading an element's axial force whose law a parameter moves (EA), in a run
   with events: the time's column of the step (``ExplicitTime``, whose controllers' terms ``_controller_time_rates``
   copies with one column, t) kept the sensed forces' ∂F/∂p of every parameter, and the run ended in ValueError:
   non-broadcastable output operand with shape (1,) … (k,), through the API and the command (the fuzzer's boom s8-2,
   a cable going slack; here a latch). fuzz6's finding 1 was the same slip in the step size's column. The time's
   column now leaves the sensed forces' ∂F/∂p out (they are the parameters' columns; a force whose law names t is
   refused beside events before the run).
4. A compliant stop's onset was landed on otherwise with and without sensitivities (45 against 59 steps): one landing
   rule now (latdyn/timeloop/landing.py; 2026-11-28's thirteenth session).
5. A run interrupted after its last step is resumable: tests/test_event_landing_one_rule.py.
"""
from __future__ import annotations

import json

import numpy as np
import yaml

import latdyn
from tests.cli_runs import latdyn_run, summary_of
from tests.test_sensitivities_events import _agree
from tests.test_fuzz_run_findings5 import PI_BESIDE_FORCE_READER
from tests.test_held_check import MASSLESS_UNSTABLE_SLIDE
from tests.test_sensitivities_in_loop_controller_integral import WHEEL_STOP
from tests.test_sensitivities_in_loop_linked_controllers import BEAD


def test_a_massless_slide_held_by_a_controller_has_no_energy_balance_to_break(tmp_path):
    """The massless slide's balance is 0 and no drift is warned of, through the command and the API; its motion is
    still the exact −sin(t)/8 (energy_balance_error 1 with the warning before)."""
    completed, out = latdyn_run(tmp_path, MASSLESS_UNSTABLE_SLIDE)
    assert completed.returncode == 0, completed.stderr
    assert "energy balance drifts" not in completed.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["energy_balance_error"] == 0.0 and not summary.get("warnings")
    data = yaml.safe_load(MASSLESS_UNSTABLE_SLIDE)
    data["output"]["probes"]["W"] = {"energy": "external_work"}
    result = latdyn.run(latdyn.load_scene(data))
    assert result.summary["energy_balance_error"] == 0.0
    np.testing.assert_allclose(result.probes["s"], -np.sin(result.t) / 8.0, atol=1e-12)
    assert np.abs(result.probes["W"]).max() < 1e-15   # the work of a force that equilibrium makes 0


def test_the_wheel_driven_onto_its_stop_balances_its_controllers_work_and_the_stops_loss():
    """WHEEL_STOP without its sensitivities, the arm massless (rigid through the impact's jump): the controller's work
    on the hinge and the stop's declared loss close the balance (measured 9.9e-5 at dt = 0.01; 0.426 with the arm's
    inertia, whose weighted jumps are the cause: the module's docstring)."""
    data = yaml.safe_load(WHEEL_STOP)
    del data["solve"]["sensitivities"]
    data["sections"]["s"].update(rhoA=0, rhoIy=0, rhoIz=0)
    result = latdyn.run(latdyn.load_scene(data))
    assert [e["kind"] for e in result.summary["events"]] == ["stop"]
    assert result.summary["dissipated_energy"] > 0.05
    assert result.summary["energy_balance_error"] < 1e-3


#: findings5's boom, its hinge driven by a torque of t (latching at 0.2 rad), beside a controller of t pushing the tip
#: by the first element's axial force, whose law the section's EA moves
TIMED_FORCE_READER = (PI_BESIDE_FORCE_READER
                      .replace("title: a PI controller beside", "title: a torque of t beside")
                      .replace("parameters: {EA: 1.0e4, Ki: 2.0, Kr: 0.02}", "parameters: {EA: 10000.0, Kr: 0.02}")
                      .replace("torque: pd, lock_at", 'torque: "8*(0.3 - t)", lock_at')
                      .replace('  pd: {output: "8*(0.3 - a1) + Ki*S", states: {S: "0.2 - a1"}}\n', "")
                      .replace('rd: {output: "Kr*ax"}', 'rd: {output: "Kr*ax + 0.1*sin(3*t)"}')
                      .replace("sensitivities: [EA, Ki, Kr]", "sensitivities: [EA, Kr]"))
assert "Kr*ax + 0.1*sin(3*t)" in TIMED_FORCE_READER and "pd" not in TIMED_FORCE_READER
assert "[EA, Kr]" in TIMED_FORCE_READER and "{EA: 10000.0, Kr: 0.02}" in TIMED_FORCE_READER


def test_a_timed_controller_reading_a_force_moved_by_a_parameter_solves_through_a_latch(tmp_path):
    """The command solves it (an internal error before), and the API's sensitivities by EA (the sensed force's
    parameter) agree with Richardson-extrapolated central differences of whole runs, the latch's time too (measured
    1.5e-9; by Kr 1.2e-7)."""
    completed, out = latdyn_run(tmp_path, TIMED_FORCE_READER)
    assert completed.returncode == 0, completed.stderr
    assert [e["kind"] for e in summary_of(out)["events"]] == ["latch"]
    data = yaml.safe_load(TIMED_FORCE_READER)
    data["solve"]["sensitivities"] = ["EA"]
    assert _agree(latdyn.run(latdyn.load_scene(data)), TIMED_FORCE_READER, "EA") <= 1e-6


#: the guided bead of tests/test_sensitivities_in_loop_linked_controllers.py with its stops compliant (Hunt–Crossley,
#: n = 1): its slide meets the stop at 0.097 s (an onset, no event entry)
COMPLIANT_BEAD = (BEAD.replace("limits: [-0.05, 0.03], restitution: 0.5}",
                               "limits: [-0.05, 0.03], contact: {stiffness: 73.2, damping: 1.0}}")
                  .replace("sensitivities: [Kp, Kd, ref, tau, m, k]", "sensitivities: [k, ref]"))
assert "contact: {stiffness: 73.2" in COMPLIANT_BEAD and "[k, ref]" in COMPLIANT_BEAD


def test_a_run_lands_on_a_compliant_stops_onset_alike_with_and_without_sensitivities():
    """The bead with and without ``solve.sensitivities`` (fuzz7's finding 4): 45 steps each, the onset landed on at
    t = 0.0970522 in one step by the same search (latdyn.timeloop.landing), probes equal to the bit, no warning of the
    sensitivities' own steps. Before: 45 against 59 (without, the secant passes ended 3e-5 s short at 0.0970219, the
    next steps landed with slivers of 3e-5 and 4.3e-7 s and grew back from them by doubling), probes 6.2e-4 apart, and
    no warning said so."""
    with_them = yaml.safe_load(COMPLIANT_BEAD)
    without = yaml.safe_load(COMPLIANT_BEAD)
    del without["solve"]["sensitivities"]
    a, b = latdyn.run(latdyn.load_scene(with_them)), latdyn.run(latdyn.load_scene(without))
    assert a.summary["steps"] == b.summary["steps"] == 45
    for k in a.probes:
        assert np.array_equal(a.probes[k], b.probes[k]), k
    assert not any("the sensitivities' own" in w for w in a.summary.get("warnings", []))


# fuzz7's finding 5 (a run interrupted after its last step, while its files are finished: summary.json said
# "interrupted" and --resume "no checkpoint … nothing to resume"): the last step's checkpoint is written then, and
# --resume finishes the files, tests/test_event_landing_one_rule.py
