"""The inertia tangent in Newton's matrix (latdyn.step.integrators.inertia_tangent): the very flexible
pendulum D4 as published (ρI = 0) and the compiled step against the Python one with it.

Without the inertia tangent, Newton diverges on the twist of the bent elements of D4 at
t ≈ 0.45 s whatever the step ("Newton failed below the minimum step"; docs/verification.md,
"D4 very flexible pendulum as published").
"""
from __future__ import annotations

import copy
from pathlib import Path

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.model.kernels import load_kernels

from test_engine import _relative_difference, _run, loaded_arm

try:
    load_kernels("c", "default")
    HAVE_C = True
except RuntimeError:
    HAVE_C = False

pytestmark = pytest.mark.skipif(not HAVE_C, reason="no C compiler: the compiled step needs one")

D4 = Path(__file__).resolve().parents[1] / "examples" / "benchmarks" / "D4_flexible_pendulum.yaml"


def d4(**solve) -> dict:
    """D4 in the 3D model (planar: off): its out-of-plane coordinates and twists without inertia
    are what this file is about (in the planar model the scene runs with full Newton)."""
    raw = yaml.safe_load(D4.read_text())
    raw["solve"].update({"planar": "off", **solve})
    raw["output"]["probes"]["tip_z"] = {"point": "pendulum.end", "quantity": "position", "component": "z"}
    return raw


def test_d4_as_published_passes_the_newton_failure_at_045_s(tmp_path):
    """The scene with full Newton (Newmark, dt 1 ms): the first Newton failure (t ≈ 0.51 s with the
    mean corotational frame of `default`; 0.45 s with node 1's frame) switches the run to the inertia
    tangent, and it goes on, without cutting the step there."""
    result, summary = _run(d4(t_end=0.6, newton="full"), tmp_path, "d4")
    assert summary["status"] == "solved"
    assert 0.40 < summary["inertia_tangent_from"] < 0.55
    assert result.t[-1] == pytest.approx(0.6)
    energy = np.asarray(result.probes["energy"])
    assert np.max(np.abs(energy - energy[0])) / np.max(np.abs(result.probes["potential"])) < 5e-4


def test_d4_with_the_inertia_tangent_from_the_start_runs_through_1_s(tmp_path):
    """``newton: exact``: 1 s, no step cut, energy kept to Newmark's time error (4.0e-4 of the
    largest |potential| at dt 1 ms, 1.0e-4 at 0.5 ms, 2.5e-5 at 0.25 ms: second order), and the
    planar motion stays planar (the out-of-plane motion grows from round-off, to ~1e-14 m)."""
    result, summary = _run(d4(newton="exact"), tmp_path, "d4")
    assert summary["status"] == "solved" and summary["newton_cuts"] == 0
    assert summary["inertia_tangent_from"] == 0.0
    assert result.t[-1] == pytest.approx(1.0)
    energy = np.asarray(result.probes["energy"])
    drift = np.max(np.abs(energy - energy[0])) / np.max(np.abs(result.probes["potential"]))
    assert drift < 5e-4
    assert np.max(np.abs(result.probes["tip_z"])) < 1e-6


@pytest.mark.parametrize("method", ["generalized-alpha", "newmark"])
def test_compiled_step_equals_the_reference_step_with_the_inertia_tangent(method, tmp_path):
    raw = loaded_arm(t_end=0.1, method=method, newton="exact")
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled")
    assert python_summary["newton"] == compiled_summary["newton"] == "exact"
    for key in ("steps", "newton_iterations", "rejected_steps"):
        assert compiled_summary[key] == python_summary[key], key
    assert _relative_difference(python, compiled) <= 1e-10


def test_the_inertia_tangent_is_the_derivative_of_the_inertia_and_gravity_forces():
    """Against central differences of the whole residual at a random large-rotation state with
    random velocities and accelerations: K + inertia tangent is the residual's tangent."""
    from latdyn.assembly.assembler import unpack_free
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(copy.deepcopy(loaded_arm())))
    model, assembler = prepared.model, prepared.assembler
    rng = np.random.default_rng(3)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.4 * rng.standard_normal(n))
    unpack_free(model, rng.standard_normal(n), state.v, state.w, state.theta_dot)
    unpack_free(model, 5 * rng.standard_normal(n), state.a, state.alpha, state.theta_ddot)
    ev = assembler.evaluate(state, matrices=True, inertia_tangent=True, length=3.0)
    tangent = ev.stiffness.toarray()
    exact = np.zeros((n, n))
    for j in range(n):
        e = np.zeros(n)
        e[j] = 1e-6
        exact[:, j] = (assembler.evaluate(assembler.advance(state, e), matrices=False).residual
                       - assembler.evaluate(assembler.advance(state, -e), matrices=False).residual) / 2e-6
    # joint bodies' inertia forces are not in the element tangent: compare away from their columns
    bodies = model.node_dofs[model.body_nodes].ravel()
    keep = np.setdiff1d(np.arange(n), bodies[bodies < n])
    error = np.abs(tangent - exact)[:, keep]
    assert error.max() <= 1e-5 * np.abs(exact).max()
