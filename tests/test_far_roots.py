"""A converged step whose hinge ends a whole turn from where its rate takes it is cut, not landed on
(latdyn.timeloop.progress.far_root, docs/energy.md "Steps that do not resolve a hinge"); a landing that ends
short of the event its trial crossed is said.

The scene is the fuzzer's seed 16 case 16 (benchmarks/fuzz_sensitivity_scenes/n_seed16_case16_refused.yaml), a
free 3D structure with a rigid stop at −0.597 on m0.end, run without sensitivities at dt = 0.03 (method newmark):
the trial step from t = 0.06 converged to θ = −6.17 at m0.end (rate 3.57 → −413.5 rad/s; θ_n + h θ̇_n = 0.083),
"past" the stop; the landing's first retry (0.00279 s) ended at −0.0267, 0.57 short of it, and the run went on from
there, silent. No step of the finer runs comes near the stop (θ ≥ −0.43 up to t = 0.3 at dt/4, dt/16, dt/120 and
adaptive with error_tol 1e-7): there was no crossing.
"""
from __future__ import annotations

import numpy as np
import yaml

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of
from test_sensitivities_fuzz_findings import TRIAL_PAST_A_STOP

#: the scene as the fuzzer saved it, without solve.sensitivities
PLAIN = TRIAL_PAST_A_STOP.replace("  sensitivities: [p0_hinge]\n", "")


def test_a_trial_a_whole_turn_past_a_stop_is_cut_not_landed_on(tmp_path):
    """The trial is cut to 0.015 s (said on stderr, counted in summary.json ``far_roots``); no event, no warning but the kink of its
    prescribed angle (a rate that jumps at t = 0.1).
    The rows of m0.end's z stay within the step's own error of the run at dt/16: 1.7e-3 (1.6e-3 before the mend,
    when the landing's short step stood in for the cut; dt/4: 6.4e-4)."""
    completed, out = latdyn_run(tmp_path, PLAIN)
    assert completed.returncode == 0, completed.stderr
    assert ("latdyn: the step from t = 0.06 of 0.03 converged to a root that puts hinge m0.end 6.26 rad from its "
            "predictor (more than π: a whole turn away, no motion); step cut to 0.015") in completed.stderr
    summary = summary_of(out)
    assert summary["far_roots"] == 1 and summary["events"] == []
    # the one warning: the scene's prescribed angle kinks at t = 0.1 (docs/energy.md, "Jumps of the laws")
    others = [w for w in summary.get("warnings") or [] if "the prescribed rate jumps at t = 0.1 (a kink)" not in w]
    assert others == []
    fine = latdyn.run(latdyn.load_scene(yaml.safe_load(PLAIN.replace("dt: 0.03", "dt: 0.001875"))))
    rows = probe_columns(out)
    reference = np.interp(rows["t"], np.asarray(fine.t), np.asarray(fine.probes["p0"]))
    assert np.abs(rows["p0"] - reference).max() < 2.5e-3


def test_a_landing_that_ends_short_of_the_stop_its_trial_crossed_is_said(monkeypatch):
    """With that cut taken away the landing keeps the retry of 0.00949 s, which closed 0.007 of the 0.572 rad to the
    stop, after a trial that turned the hinge by h |Δθ̇| = 12.5 rad: a warning names the hinge, the stop, the step
    and the remedy (before: nothing said)."""
    import latdyn.timeloop.loop as loop

    monkeypatch.setattr(loop, "far_root", lambda *args: None, raising=False)  # raising: the code before it had none
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(PLAIN)))
    said = [w for w in result.summary.get("warnings") or [] if "no shorter step reached it" in w]
    assert said, result.summary.get("warnings")
    assert said[0].startswith("the step from t = 0.06 of 0.03 s crossed the stop -0.597 of m0.end")
    assert "without resolving it (its rate changed by 417.1 rad/s over the step, which turns it by 12.5 > 0.25)" in said[0]
    assert "the step kept, 0.00949 s, ends 0.565 short of it" in said[0] and "rerun with a smaller dt" in said[0]
