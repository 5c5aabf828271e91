"""Sensitivities beside events, through the CLI and the API: the step sequence a run with solve.sensitivities takes
(latdyn/timeloop/loop.py ``_accept``, summary.json ``warnings``), and a reel paying out a massive cable
(latdyn/analyses/transient_sensitivities.py ``TransientSensitivities.land``).

A run with sensitivities lands on each event to 1e-12 and restarts at dt after it and after each step onto the grid, so
that its step sizes are differentiable in p; a run without lands on a hinge's event as it does (latdyn.timeloop.landing),
on a cable's change by at most 4 passes of its own, and grows its steps back from the short one (docs/parameters.md, "Sensitivities through events"). Those two rules are the whole
difference (measured: the run with sensitivities under the plain rules writes the plain run's probes to the bit); the
plain run under the sensitivities' restart came 16 times as many Newton cuts on docs/cables.md's damped truss (305
against 19 over 0.8 s, twice the CPU time), so the plain run keeps its rules and the run with sensitivities says so.

tests/test_sensitivities_in_loop_cables2.py's PD mast pushed by a load of t, its three-element massive cable g1 reeled
out (rest length L + 0.3 t): g1 goes slack near t = 0.097. The first trial across the change put element 2 first by
linear interpolation of its ends; the landing on element 2 ended with element 1 at gap −0.36, past its own change, and
the run was refused as "several cable elements changing between slack and taut at one instant" (before this file's
change). The landing now lands again on the element that changed first."""
from __future__ import annotations

import numpy as np
import yaml

import latdyn
from tests.cli_runs import latdyn_run, probe_columns, summary_of
from tests.test_sensitivities_in_loop_cables2 import MAST_PD_PUSHED
from tests.test_sensitivities_in_loop_controller_reads import BOOM_INPUT, CABLE_LIMIT

#: the warning of a run whose steps the sensitivities' rules took otherwise
OWN_STEPS = "of the run's steps are the sensitivities' own"


def _without_sensitivities(text: str) -> str:
    data = yaml.safe_load(text)
    data["solve"].pop("sensitivities")
    return yaml.safe_dump(data)


def test_a_run_whose_steps_the_sensitivities_chose_says_so_and_stays_within_the_steps_error(tmp_path):
    """The clipped controller on the skew cable's tension (five taut and slack changes): with sensitivities 69
    steps, 7 of them the sensitivities' own (five landings, two restarts after steps onto the grid), a warning in
    summary.json; without, 82 steps and no warning. Their probes differ (the cable's changes land 2.8e-4 s apart), by
    less than a fifth of either's own error against a run at dt/8 (measured 0.047 to 0.14 of it; the tension 1.1e-2 of
    its largest apart, 0.24 off the reference). Before this change the run with sensitivities said nothing."""
    (tmp_path / "with").mkdir()
    (tmp_path / "without").mkdir()
    completed, out = latdyn_run(tmp_path / "with", CABLE_LIMIT, quiet=True)
    assert completed.returncode == 0, completed.stderr
    warnings = [w for w in summary_of(out).get("warnings", []) if OWN_STEPS in w]
    assert len(warnings) == 1 and warnings[0].startswith("7 " + OWN_STEPS), summary_of(out).get("warnings")
    assert "docs/parameters.md" in warnings[0] and summary_of(out)["steps"] == 69
    plain_text = _without_sensitivities(CABLE_LIMIT)
    completed, plain_out = latdyn_run(tmp_path / "without", plain_text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    assert not any(OWN_STEPS in w for w in summary_of(plain_out).get("warnings", []))
    assert summary_of(plain_out)["steps"] == 82
    with_, without = probe_columns(out), probe_columns(plain_out)
    data = yaml.safe_load(plain_text)
    data["solve"]["dt"] /= 8
    reference = latdyn.run(latdyn.load_scene(data)).probes
    for probe, values in reference.items():
        scale = np.abs(values).max()
        apart = np.abs(with_[probe] - without[probe]).max() / scale
        errors = [np.abs(run[probe] - values).max() / scale for run in (with_, without)]
        assert 0 < apart < 0.2 * min(errors), (probe, apart, errors)


def test_a_run_without_events_takes_the_same_steps_with_and_without_sensitivities():
    """The PD boom with inputs (no event): the same probes to the bit, no warning."""
    with_ = latdyn.run(latdyn.load_scene(yaml.safe_load(BOOM_INPUT)))
    without = latdyn.run(latdyn.load_scene(yaml.safe_load(_without_sensitivities(BOOM_INPUT))))
    assert not any(OWN_STEPS in w for w in with_.summary.get("warnings", []))
    assert all(np.array_equal(with_.probes[k], without.probes[k]) for k in without.probes)

#: the pushed PD mast with cable g1 paying out (L + 0.3 t) to t = 0.1, sensitivities by EA
REEL_OUT = (MAST_PD_PUSHED.replace('rest_length: "L", rhoA', 'rest_length: "L + 0.3*t", rhoA')
            .replace("sensitivities: [Kp, Kd, ref, EA, L, EI, rho]", "sensitivities: [EA]"))
assert "L + 0.3*t" in REEL_OUT and "sensitivities: [EA]" in REEL_OUT and "t_end: 0.1" in REEL_OUT


def _scene(**values):
    data = yaml.safe_load(REEL_OUT)
    data["parameters"].update(values)
    return latdyn.load_scene(data)


def test_a_reel_paying_out_a_massive_cable_lands_on_its_first_elements_change(tmp_path):
    """The CLI's run lands on g1's slack change (one event, the run solved) and writes the API's probes; the
    sensitivities by EA agree with Richardson-extrapolated central differences of whole runs (steps 1e-4 and 5e-5
    of EA) within 1e-5 of each probe's largest (measured 5.3e-9 to 5e-7)."""
    completed, out = latdyn_run(tmp_path, REEL_OUT)
    assert completed.returncode == 0, completed.stderr
    summary = summary_of(out)
    assert [(e["cable"], e["state"]) for e in summary["cable_events"]] == [("g1", "slack")]
    result = latdyn.run(_scene())
    assert result.summary["cable_events"] == summary["cable_events"]
    columns = probe_columns(out)
    assert all(np.array_equal(columns[k], result.probes[k]) for k in result.probes)
    ea = yaml.safe_load(REEL_OUT)["parameters"]["EA"]
    central = []
    for step in (1e-4 * ea, 5e-5 * ea):
        up, down = latdyn.run(_scene(EA=ea + step)), latdyn.run(_scene(EA=ea - step))
        assert up.summary["cable_events"][0]["state"] == down.summary["cable_events"][0]["state"] == "slack"
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes})
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        error = np.abs(result.sensitivities[(probe, "EA")] - expected).max() / np.abs(expected).max()
        assert error <= 1e-5, (probe, error)


def test_a_change_at_a_steps_start_is_refused_naming_the_file_the_key_and_the_remedy(tmp_path):
    """The same reel with L 1e-4 above its value at dt = 2e-3: an element of g1 turns back at the instant it changed
    side (t = 0.092), which no step lands on; refused (exit 1), the message naming the scene file,
    solve.sensitivities and solve.dt (before: neither the file nor the keys). At dt = 1e-3 it runs (measured: L at
    ±1e-4 and ±5e-5 of its value, 105–112 steps, two changes of g1)."""
    length = yaml.safe_load(REEL_OUT)["parameters"]["L"]
    text = REEL_OUT.replace(f"L: {length!r}", f"L: {length * (1 + 1e-4)!r}")
    assert text != REEL_OUT
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 1, completed.stderr
    message = completed.stderr
    assert f"{tmp_path / 'scene.yaml'}: solve.sensitivities: the sensitivities at t = 0.0919534 meet cables.g1 " \
           "changing side at the start of a step" in message, message
    assert "a solve.dt smaller than 0.002" in message and "Traceback" not in message
    assert summary_of(out)["status"] != "solved"
    finer = latdyn.run(latdyn.load_scene(yaml.safe_load(text.replace("dt: 0.002", "dt: 0.001"))))
    assert finer.summary["status"] == "solved"
