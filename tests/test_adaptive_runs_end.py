"""Adaptive runs that end: the shipped slider-crank with ``adaptive: true`` added, and a run whose steps
collapse stopped with a message that names what shrank them and the remedy (docs/stepping.md,
"Adaptive steps that collapse").

``examples/slider_crank.yaml`` with ``solve.adaptive: true`` was reported to run past 300 s (a harness
that read the example with ``yaml.safe_load``, which cannot read its ``rod.node[2]`` in a flow mapping,
and counted the failure as a timeout); through latdyn it ends in about a second. The scenes are the
example's text with its solve line edited as a user edits it, run through the CLI and the API.
"""
from __future__ import annotations

from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of

EXAMPLE = Path(__file__).resolve().parents[1] / "examples" / "slider_crank.yaml"
SOLVE = "solve: {analysis: transient, t_end: 1.5, dt: 0.002}"


def slider_crank(solve: str) -> str:
    """The shipped example's text with its solve line replaced by ``solve``."""
    text = EXAMPLE.read_text()
    assert SOLVE in text, "the example's solve line changed: update SOLVE"
    return text.replace(SOLVE, solve)


def test_the_slider_crank_example_with_adaptive_steps_ends_near_a_fine_fixed_step_run(tmp_path):
    """The rod's mid-span deflection of adaptive runs (dt = 0.01 the largest step) against a fixed-step
    run at dt = 0.002/64: within error_tol · length (0.525 m) at error_tol 1e-4 (CLI) and 1e-5 (API),
    in a few hundred steps. Measured: 3.0e-6 m in 254 steps (4 rejected) and 3.2e-6 m in 567 steps
    (82 rejected), the slide 6.0e-8 and 8.3e-8 m off (docs/stepping.md, "Adaptive steps that collapse")."""
    reference = latdyn.run(latdyn.load_scene(_scene(tmp_path / "fine", slider_crank(
        "solve: {analysis: transient, t_end: 1.5, dt: 3.125e-5}"))))
    fine = {k: np.asarray(v) for k, v in reference.probes.items()}

    completed, out = latdyn_run(tmp_path, slider_crank(
        "solve: {analysis: transient, t_end: 1.5, dt: 0.01, adaptive: true, error_tol: 1.0e-4}"), quiet=True,
        timeout=60.0)
    assert completed.returncode == 0, completed.stderr
    cli = probe_columns(out)
    assert summary_of(out)["steps"] < 500
    np.testing.assert_allclose(cli["t"], np.asarray(reference.t), atol=1e-9)
    assert np.max(np.abs(cli["mid_span_y"] - fine["mid_span_y"])) < 1e-4 * 0.525
    assert np.max(np.abs(cli["slide"] - fine["slide"])) < 1e-4 * 0.525

    result = latdyn.run(latdyn.load_scene(_scene(tmp_path / "api", slider_crank(
        "solve: {analysis: transient, t_end: 1.5, dt: 0.01, adaptive: true, error_tol: 1.0e-5}"))))
    assert result.summary["status"] == "solved" and result.summary["steps"] < 1000
    api = {k: np.asarray(v) for k, v in result.probes.items()}
    np.testing.assert_allclose(np.asarray(result.t), np.asarray(reference.t), atol=1e-9)
    assert np.max(np.abs(api["mid_span_y"] - fine["mid_span_y"])) < 1e-5 * 0.525
    assert np.max(np.abs(api["slide"] - fine["slide"])) < 1e-5 * 0.525


def _scene(folder: Path, text: str) -> str:
    folder.mkdir()
    (folder / "scene.yaml").write_text(text)
    return str(folder / "scene.yaml")


def test_an_error_tol_that_asks_for_crawling_steps_ends_the_run_naming_error_tol(tmp_path):
    """error_tol 1e-18 (a local error of 5e-19 m a step) sizes the steps at 3.7e-8 s, under the crawling
    step min(100 dt_min, dt/1000) = 2e-7 s: the run ends after 1000 such steps, exit 1, and the message says
    the error estimate sized them and that a larger error_tol is the remedy (it once said only "the error
    estimate or Newton" and "a smaller solve.dt_min")."""
    completed, out = latdyn_run(tmp_path, slider_crank(
        "solve: {analysis: transient, t_end: 0.01, dt: 0.002, adaptive: true, error_tol: 1.0e-18}"), quiet=True,
        timeout=60.0)
    assert completed.returncode == 1, completed.stderr
    assert "the time step stays near the minimum step" in completed.stderr
    assert "the error estimate sizes the adaptive steps: error_tol = 1e-18" in completed.stderr
    assert "a larger solve.error_tol" in completed.stderr
    assert "Traceback" not in completed.stderr
    assert summary_of(out)["status"] == "failed"


def test_a_crawl_of_newton_cuts_is_said_to_be_newtons():
    """Steps kept short by Newton's cuts (with adaptive steps, the error estimate rejecting none of them):
    the message counts the cuts and names Newton, not error_tol."""
    from latdyn.errors import SolverError
    from latdyn.timeloop.control import CRAWL_STEPS, StepControl

    solve = SimpleNamespace(t_end=1.0, dt=1e-2, dt_min=None, adaptive=True, error_tol=1e-4)
    control = StepControl(solve, None, 1.0)
    run = SimpleNamespace(state=SimpleNamespace(t=0.1), h=control.dt, newton_cuts=0, far_roots=0)
    with pytest.raises(SolverError, match="stays near the minimum step") as failure:
        for _ in range(3 * CRAWL_STEPS):
            run.newton_cuts += 1
            run.state.t += 3e-8
            control.after_accepted(run, SimpleNamespace(), 3e-8, latched=False, stopped=False)
    message = str(failure.value)
    assert "Newton's failures cut 999" in message and "Newton does not converge at a larger step" in message
    assert "error_tol" not in message
