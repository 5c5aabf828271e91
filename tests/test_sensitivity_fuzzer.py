"""The sensitivity fuzzer's judge (benchmarks/fuzz_sensitivities.py) on made-up runs, so that a campaign can
fail: Richardson differences of a known function, a right derivative agreeing and a wrong one flagged, rows
and events alike. The campaigns themselves are too slow for the suite (10-100 s a case): docs/verification.md,
"Sensitivity fuzzing"."""
from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import fuzz_sensitivities as fuzz  # noqa: E402

T = np.linspace(0.0, 1.0, 11)


def _run(p: float) -> dict:
    """A made-up run of parameter p: a probe exp(p t) sin t and one event at t_e = p²/10."""
    return {"x": T, "first": "t", "probes": {"y": np.exp(p * T) * np.sin(T)},
            "summary": {"events": [{"joint": "c0", "kind": "taut", "t": p * p / 10}]}}


def _base(p: float, wrong: float = 0.0) -> dict:
    run = _run(p)
    dy = T * np.exp(p * T) * np.sin(T) * (1 + wrong)
    run["sens"] = {"y/p": dy}
    run["summary"]["probe_sensitivities"] = {"y": {"end": {"p": dy[-1]}, "max": {"p": dy[-1]}, "min": {"p": 0.0}}}
    run["summary"]["event_sensitivities"] = [{"joint": "c0", "kind": "taut", "t": p * p / 10,
                                              "dt": {"p": p / 5 * (1 + wrong)}}]
    return run


def _checks(wrong: float) -> list[dict]:
    p, h = 1.3, 1e-3 * 1.3
    perturbed = [_run(p + h), _run(p - h), _run(p + h / 2), _run(p - h / 2)]
    return fuzz.compare(_base(p, wrong), perturbed, "p", h, p)


def test_richardson_differences_of_a_smooth_function_are_its_derivative_to_fourth_order():
    h = 1e-2
    values = [np.exp(1 + d) for d in (h, -h, h / 2, -h / 2)]
    assert abs(fuzz._richardson(values) / h - np.exp(1)) < 1e-9


def test_a_right_derivative_agrees_and_a_wrong_one_is_flagged_in_rows_summary_and_events():
    right = _checks(0.0)
    assert {c["where"].split(" (")[0] for c in right} == {"rows", "summary end", "summary max", "summary min", "dt"}
    assert max(c["error"] for c in right) < 1e-9
    wrong = _checks(1e-4)       # a derivative 1e-4 off: each check must see it (tolerance 1e-5)
    flagged = {c["where"].split(" (")[0] for c in wrong if c["error"] > fuzz.TOL}
    assert flagged == {"rows", "summary end", "summary max", "dt"}, wrong
