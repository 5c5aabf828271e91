"""One first-event rule and one landing for runs with and without ``solve.sensitivities`` (issue 34; the closing note
of 2026-11-28's twelfth session, "Read of the whole change"), and a run interrupted while its files are finished.

latdyn/timeloop/landing.py chooses the first event of a step (hinges and cable elements by the fraction of the step at
their crossing) for both runs, and lands on a hinge's event by one search (regula falsi on the step's size to
|θ − θ_event| ≤ 1e-12 · max(1, |θ_event|)). Before, the run without sensitivities took a secant from the step's start
to the events' tolerance (1e-7) in at most 4 passes, and ended short where a retry did: the planar arm's latch came
7.6e-5 s late there, 73 steps against the sensitivities' 61, and a compliant stop's onset took 59 against 45 (fuzz7's
finding 4, tests/test_fuzz_run_findings6.py). Now those runs take the same steps and write the same probes to the bit.
Scenes as YAML text, through ``latdyn run`` and ``latdyn.run``."""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.cli import main
from tests.cli_runs import latdyn_run, summary_of
from tests.test_guides_acceptance import LATCH_ON_A_SPINNING_ROD
from tests.test_sensitivities_events import LATCH_PLANAR
from tests.test_fuzz_run_findings6 import TIMED_FORCE_READER

OWN_STEPS = "of the run's steps are the sensitivities' own"


def test_a_latch_is_landed_on_alike_with_and_without_sensitivities_through_the_command(tmp_path):
    """The planar arm latching at 0.8 rad through ``latdyn run`` with its five parameters and without: 61 steps each,
    the latch at the same time and probes.csv's columns equal to the bit, no warning of the sensitivities' own steps
    (before: 61 against 73 steps, the latch 7.6e-5 s apart, the probes 2.0e-4 apart, and the warning)."""
    plain = LATCH_PLANAR.replace(", sensitivities: [k, c, EI, rho, m]", "")
    assert plain != LATCH_PLANAR
    (tmp_path / "with").mkdir()
    (tmp_path / "without").mkdir()
    done, out = latdyn_run(tmp_path / "with", LATCH_PLANAR)
    assert done.returncode == 0, done.stderr
    done_plain, out_plain = latdyn_run(tmp_path / "without", plain)
    assert done_plain.returncode == 0, done_plain.stderr
    a, b = summary_of(out), summary_of(out_plain)
    assert a["steps"] == b["steps"] == 61
    assert a["events"] == b["events"] and [e["kind"] for e in a["events"]] == ["latch"]
    assert OWN_STEPS not in done.stderr
    assert not any(OWN_STEPS in w for w in a.get("warnings", []))
    assert (out / "probes.csv").read_bytes() == (out_plain / "probes.csv").read_bytes()


def test_a_latch_without_sensitivities_lands_to_the_landing_tolerance(tmp_path):
    """The bead thrown out along a rod spinning at 3 rad/s latches at s = 0.1, where the latch holds it with
    −mΩ²(r₀ + 0.1) = −1.08 N: the force after the latch is that to 1e-12 (measured 1.6e-14; the landing to the
    events' tolerance left the bead 3.8e-8 m short, the force 5.2e-8 off)."""
    scene = tmp_path / "scene.yaml"
    scene.write_text(LATCH_ON_A_SPINNING_ROD)
    result = latdyn.run(latdyn.load_scene(scene))
    latch = np.arccosh(1.0 + 0.1 / 0.2) / 3.0
    after = result.t > latch + 1e-4
    assert np.abs(result.probes["f"][after] + 1.08).max() < 1e-12
    assert np.abs(result.probes["s"][after] - 0.1).max() < 1e-12


def test_a_run_interrupted_while_its_files_are_finished_resumes_to_the_uninterrupted_runs_files(tmp_path, monkeypatch,
                                                                                                   capsys):
    """Ctrl-C after the last step, while the run's files are finished (here as close_run starts), with sensitivities:
    the checkpoint of the last step is written (summary.json: status interrupted, its checkpoint_t the run's end), and
    ``latdyn run --resume`` finishes the files without a step: probes.csv and sensitivities.csv equal the uninterrupted
    run's byte for byte, summary.json says solved (before: no checkpoint, and --resume answered "no checkpoint …
    nothing to resume" while summary.json said interrupted; fuzz7's finding 5, found on fuzz_combined3's linked s9-9)."""
    import latdyn.solve as solve

    scene = tmp_path / "scene.yaml"
    scene.write_text(TIMED_FORCE_READER)
    whole = tmp_path / "whole"
    latdyn.run(latdyn.load_scene(scene), whole)
    close = solve.close_run

    def interrupted(*args, **kwargs):
        monkeypatch.setattr(solve, "close_run", close)
        raise KeyboardInterrupt

    monkeypatch.setattr(solve, "close_run", interrupted)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        latdyn.run(latdyn.load_scene(scene), out)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "interrupted" and summary["checkpoint_t"] == pytest.approx(0.3, abs=1e-12)
    capsys.readouterr()
    assert main(["run", str(scene), "-o", str(out), "--resume", "-q"]) == 0
    assert "Traceback" not in capsys.readouterr().err
    assert json.loads((out / "summary.json").read_text())["status"] == "solved"
    for name in ("probes.csv", "sensitivities.csv"):
        assert (out / name).read_bytes() == (whole / name).read_bytes(), name
