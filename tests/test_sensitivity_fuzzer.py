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


def test_the_adjoints_end_row_alone_is_compared_at_the_last_row_and_a_wrong_one_flagged():
    # the adjoint's sensitivities.csv holds the last recorded row alone (docs/parameters.md)
    p, h = 1.3, 1e-3 * 1.3
    perturbed = [_run(p + h), _run(p - h), _run(p + h / 2), _run(p - h / 2)]
    for wrong, agrees in ((0.0, True), (1e-4, False)):
        base = _base(p, wrong)
        base["sens"] = {"y/p": base["sens"]["y/p"][-1:]}
        rows = [c for c in fuzz.compare(base, perturbed, "p", h, p) if c["where"].startswith("rows")]
        assert len(rows) == 1 and "t = 1" in rows[0]["where"]
        assert (rows[0]["error"] < 1e-9) == agrees and (rows[0]["error"] > fuzz.TOL) != agrees, rows


def test_a_max_whose_row_moves_with_the_parameter_is_not_compared():
    # two rows tie at p = 1 (seed 6 case 6: a probe of round-off, 9.668e-16 at row 2 and 9.666e-16 at row 30):
    # the max is |p - 1| + 1 there, not differentiable, and its differences are no reference
    def run(p):
        return {"x": T, "first": "t", "probes": {"y": np.where(T == 0.2, p, np.where(T == 1.0, 2.0 - p, 0.0))},
                "summary": {}}
    p, h = 1.0, 1e-3
    base = run(p)
    base["sens"] = {"y/p": np.where(T == 0.2, 1.0, np.where(T == 1.0, -1.0, 0.0))}
    base["summary"]["probe_sensitivities"] = {"y": {"end": {"p": -1.0}, "max": {"p": 1.0}, "min": {"p": 0.0}}}
    checks = fuzz.compare(base, [run(p + h), run(p - h), run(p + h / 2), run(p - h / 2)], "p", h, p)
    moved = [c for c in checks if c.get("not_compared")]
    assert [c["where"] for c in moved] == ["summary max"] and "not compared" in moved[0]["detail"]
    assert max(c["error"] for c in checks if not c.get("not_compared")) < 1e-9


def test_the_adjoint_is_checked_against_the_forward_methods_summary(tmp_path):
    # _against_forward reads both summaries; a derivative off by 1e-4 of the probe's largest is flagged
    def summary(dy, dt):
        return {"probe_sensitivities": {"y": {"end": {"p": dy}, "max": {"p": 2.0}}},
                "event_sensitivities": [{"joint": "c0", "kind": "taut", "t": 0.1, "dt": {"p": dt}}]}

    import json
    adjoint_out = tmp_path / "adjoint"
    adjoint_out.mkdir()

    def launch(spec, tag):
        out = tmp_path / tag
        out.mkdir(exist_ok=True)
        (out / "summary.json").write_text(json.dumps(summary(1.0, 0.5)))
        assert "sensitivity_method" not in spec["solve"]
        return 0, "", None, out

    scene = {"solve": {"sensitivity_method": "adjoint"}}
    for dy, dt, worst in ((1.0, 0.5, 0.0), (1.0 + 2e-4, 0.5, 1e-4), (1.0, 0.5 - 1e-4, 2e-4)):
        (adjoint_out / "summary.json").write_text(json.dumps(summary(dy, dt)))
        checks = fuzz._against_forward(scene, adjoint_out, launch)
        assert len(checks) == 3 and abs(max(c["error"] for c in checks) - worst) < 1e-12, checks


def test_a_probe_of_round_off_is_not_compared_and_a_small_real_one_still_is():
    # seed 7 case 1: a free structure at rest, its momentum 1e-20 (round-off), derivatives 1e-37 computed
    # against differences of 4e-21: no derivative to compare; a probe of 1e-6 keeps its relative check
    p, h = 0.03, 3e-5
    noise = np.random.default_rng(7).standard_normal((5, len(T))) * 1e-20

    def run(i, scale=0.0, dp=0.0):
        return {"x": T, "first": "t", "probes": {"y": noise[i] + scale * (p + dp) * T}, "summary": {}}

    base = run(4)
    base["sens"] = {"y/p": np.zeros(len(T))}
    base["summary"]["probe_sensitivities"] = {"y": {"end": {"p": 0.0}}}
    checks = fuzz.compare(base, [run(i) for i in range(4)], "p", h, p)
    assert len(checks) == 1 and checks[0]["not_compared"] and "round-off" in checks[0]["detail"], checks
    small = [run(i, 1e-6, dp) for i, dp in enumerate((h, -h, h / 2, -h / 2))]
    base = run(4, 1e-6)
    base["sens"] = {"y/p": 1e-6 * T * (1 + 1e-4)}
    rows = fuzz.compare(base, small, "p", h, p)[0]
    assert "not_compared" not in rows and rows["error"] > fuzz.TOL, rows


def test_an_adjoint_end_row_of_zero_against_round_off_differences_agrees_and_a_real_one_is_still_checked():
    # hand scene G of 2026-11-27: a hinge latched at 0.15 rad by the end, the adjoint's end row 0 (exact) against
    # differences of round-off 9e-12 (h = 5e-4): reported 0.031 off, though both are below the floor of zero
    p, h = 0.5, 5e-4
    noise = np.random.default_rng(27).standard_normal((5, len(T))) * 1e-15

    def run(i, slope=0.0, dp=0.0):
        return {"x": T, "first": "t", "probes": {"y": 0.15 + noise[i] + slope * (p + dp) * T}, "summary": {}}

    base = run(4)
    base["sens"] = {"y/p": np.zeros(1)}       # the adjoint's sensitivities.csv: the last row alone
    base["summary"]["probe_sensitivities"] = {"y": {"end": {"p": 0.0}}}
    checks = fuzz.compare(base, [run(i) for i in range(4)], "p", h, p)
    assert max(c["error"] for c in checks) == 0.0 and checks[0]["zero"], checks
    # a derivative of 1e-6 (above the floor 3e-10) computed 1e-4 off is flagged
    slope = 1e-6
    perturbed = [run(i, slope, dp) for i, dp in enumerate((h, -h, h / 2, -h / 2))]
    base = run(4, slope)
    base["sens"] = {"y/p": np.array([slope * (1 + 1e-4)])}
    base["summary"]["probe_sensitivities"] = {"y": {"end": {"p": slope * (1 + 1e-4)}}}
    checks = fuzz.compare(base, perturbed, "p", h, p)
    assert all(c["error"] > fuzz.TOL for c in checks), checks


def test_a_parameter_of_value_zero_is_judged_by_its_perturbation_s_size_not_by_zero():
    # a coordinate 0 (--extended): h = 1e-3 * 0.1; the floor 1e-9 v / |p| was infinite at p = 0, so that any
    # derivative counted as zero; now the floor takes h / STEP for |p|
    p, h = 0.0, 1e-4

    def run(dp):
        return {"x": T, "first": "t", "probes": {"y": 1.0 + np.sin(T) * (p + dp)}, "summary": {}}

    base = run(0.0)
    base["sens"] = {"y/p": np.sin(T) * (1 + 1e-4)}
    checks = fuzz.compare(base, [run(h), run(-h), run(h / 2), run(-h / 2)], "p", h, p)
    assert checks[0]["error"] > fuzz.TOL and not checks[0]["zero"], checks


def test_the_aimed_families_draw_valid_scenes_of_what_they_aim_at():
    """``--aim``: every scene loads (SCENE.md); the loop family names only the kinds the loop of steps differentiates
    (section values, load components, initial velocities) and asks for the resume check on some cases; the links
    family runs adaptive steps on rigid links; the rates family puts a latch or stop beside a stiffness that moves
    with the rates (a compliant stop with damping, a controller, a damping law in the angle)."""
    import latdyn

    native = ("section", "load", "initial_velocity")
    resumed = 0
    for aim in fuzz.AIMS:
        for index in range(12):
            scene = fuzz.aimed_scene(21, index, aim)
            resumed += bool(scene["solve"].pop("resume_check", False))
            latdyn.load_scene(scene)
            names = scene["solve"]["sensitivities"]
            assert names and set(names) == set(scene["parameters"]), (aim, index)
            hinges = [b["start"]["hinge"] for b in scene["beams"].values() if "start" in b]
            if aim == "loop":
                assert all(name.split("_", 1)[1] in native for name in names), (index, names)
                assert not any(b.get("rigid") for b in scene["beams"].values()) and "controllers" not in scene
            elif aim == "links":
                assert scene["solve"]["adaptive"] and all(scene["beams"][f"arm{i}"].get("rigid")
                                                          for i in range(len(hinges)))
            else:
                second = hinges[1]
                assert "lock_at" in hinges[0] or "limits" in hinges[0]
                assert ("contact" in second or "controllers" in scene or "theta" in str(second.get("damping"))), index
    assert resumed > 0


def test_a_disagreement_below_what_whole_runs_resolve_is_unresolvable_and_a_real_one_is_not():
    """A derivative 1e-4 off where p moves the probe by its own size is flagged as before; one 10 % off where p moves
    it by 1e-8 of its size (seed 21 case 9: a free arm's GJ moving a hinge rate by 1e-14 over h) moves the
    perturbed runs by less than RESOLUTION of the probe: the differences cannot judge it (``unresolvable``)."""
    wrong = _checks(1e-4)
    assert not any(c.get("unresolvable") for c in wrong if c["error"] > fuzz.TOL), wrong
    p, h, eps = 1.3, 1.3e-3, 1e-8

    def run(q):
        return {"x": T, "first": "t", "probes": {"y": np.sin(T) + eps * np.exp(q * T)}, "summary": {}}

    base = run(p)
    base["sens"] = {"y/p": 1.1 * eps * T * np.exp(p * T)}
    checks = fuzz.compare(base, [run(p + h), run(p - h), run(p + h / 2), run(p - h / 2)], "p", h, p)
    rows = [c for c in checks if c["where"].startswith("rows")]
    assert rows and rows[0]["error"] > 0.05 and rows[0]["unresolvable"], rows
