"""Taut cables on rigidly linked and guided bodies in the compiled Newton iteration (csrc/links.c).

A cable element's K and C blocks (the generated ``cable_force`` kernel's derivatives) act on the
coordinates of its two end nodes; where an end is a dependent node of a rigid link or a guided body,
the block is reduced onto the minimum coordinates through the projection P = [I; J] like every other
block (``assemble_linked``). The compiled iteration matrix is checked against
latdyn.assembly.linked's reduction and against central differences of the residual, in 3D; the
Newton iterations of a transient run show that the matrix is the exact one."""
from __future__ import annotations

import ctypes
import json

import numpy as np
import pytest

import latdyn

from cli_runs import latdyn_run, probe_columns, summary_of
from test_rigid import finite_difference
from test_rigid_native import scene_yaml

#: A free body A carrying a guided body B (spring and damper on the slide) that carries a rigid link to
#: a body D (a dependent node); pretensioned, damped cables from the fixed ground to B (the guided body),
#: to D (the rigidly linked body) and from A to D; gravity, loads; genuinely 3D (no axis in a plane).
LINKED_CABLES = """
gravity: [0.3, -1.0, -9.81]
sections:
  s: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.5, rhoIy: 0.01, rhoIz: 0.02}
bodies:
  ground: {at: [0, 0, 0], fixed: true}
  A: {at: [0, 0, 0.2], mass: 3, inertia: [0.2, 0.3, 0.4], com: [0.1, 0, 0.05]}
  B:
    at: [0.4, 0.2, 0.1]
    mass: 0.7
    inertia: [0.01, 0.02, 0.03]
    com: [0, 0.1, 0]
    guide: {on: A, axis: [1, 0.5, -0.3], stiffness: 7.0, damping: 0.3}
  D: {at: [1.0, 0.8, 0.2], mass: 0.4, inertia: [0.01, 0.01, 0.02], com: [0.02, 0, 0]}
beams:
  l: {from: B, to: D, section: s, rigid: true, start: {hinge: {axis: [0, 1, 1]}}}
cables:
  guided: {from: {body: ground, offset: [0.3, -0.6, 0.5]}, to: {body: B, offset: [0.05, 0, 0.02]},
           EA: 2.0e3, damping: 4.0, rest_length: 0.7}
  linked: {from: {body: ground, offset: [1.4, 0.9, 1.1]}, to: {body: D, offset: [0, 0.05, 0.03]},
           EA: 3.0e3, damping: 2.0, rest_length: 0.8}
  across: {from: {body: A, offset: [-0.2, 0.1, 0]}, to: D, EA: 1.0e3, damping: 1.0, rest_length: 1.1}
loads:
  - {at: B, force: [1, 2, 3], moment: [0.3, -0.2, 0.1]}
  - {at: D, force: [0, -4, 1]}
solve: {t_end: 0.1, dt: 0.01}
"""


def random_moving_state(prepared, seed):
    """A configuration near the initial one (the cables stay taut) with random rates and accelerations."""
    from latdyn.assembly.assembler import unpack_free

    model, assembler = prepared.model, prepared.assembler
    rng = np.random.default_rng(seed)
    n = model.n_dofs
    state = assembler.advance(prepared.state, 0.05 * rng.normal(size=n))
    unpack_free(model, 0.1 * rng.normal(size=n), state.v, state.w, state.theta_dot)
    unpack_free(model, rng.normal(size=n), state.a, state.alpha, state.theta_ddot)
    return state


def compiled_iteration_matrix(assembler, state, beta_p, gamma_p, exact: bool = False):
    """latdyn_iteration_matrix at ``state`` (csrc/links.c assemble_linked), dense, and the pattern; ``exact``:
    with the inertia tangent (the elements' and the dependent rates' terms)."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha, matrix_pattern
    from latdyn.step.integrators import AlphaParameters

    n = assembler.model.n_dofs
    step = CompiledGeneralizedAlpha(assembler, AlphaParameters.for_method("generalized-alpha", 0.8), 1e-10, 25, 1.0)
    step.inertia_tangent = exact
    step._setup()
    native, factorization = step._native, step.factorization
    rows, cols = matrix_pattern(assembler)
    native.complete_links(state)
    native.evaluate(state, matrices=True, load_factor=1.0, inertia=True, inertia_tangent=exact)
    factorization.values[:] = np.nan  # every entry of the pattern is written
    native.library.latdyn_iteration_matrix(native.model_ref, native.work_ref, ctypes.byref(native.configuration(state)),
                                           beta_p, gamma_p, int(exact))
    matrix = np.zeros((n, n))
    matrix[rows, cols] = factorization.values[factorization.position(rows, cols)]
    in_pattern = np.zeros((n, n), dtype=bool)
    in_pattern[rows, cols] = True
    return matrix, in_pattern


@pytest.mark.parametrize("seed", [3, 4])
def test_compiled_iteration_matrix_of_cables_on_guided_and_linked_bodies(seed):
    """3D, at a random moving state with every cable taut and its damper pulling: the compiled iteration
    matrix β′M + γ′C + K (cable blocks reduced through the guide's and the link's J) equals
    latdyn.assembly.linked's on every entry to 1e-12 of the largest (measured 1.2e-16 … 2.8e-16), and
    the Python reduction's K, C and M equal central differences of the reduced residual (by q, v, a;
    step 1e-6) to 1e-7 of the largest (K at rest in the same configuration; measured K 5.1e-11,
    8.5e-11, C 3.1e-8, 1.3e-8, M 9.1e-9, 8.6e-9: round-off of differences of forces ~500 N). Without the cable blocks the compiled K was off by 3692 of
    3692 (the whole of the largest entry)."""
    from latdyn.assembly.linked import evaluate_linked
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(scene_yaml(LINKED_CABLES)))
    model, assembler = prepared.model, prepared.assembler
    assert model.n_dofs == 6 + 2 and any(e.prismatic for e in model.links.edges)  # A, B's slide, l's hinge
    state = random_moving_state(prepared, seed)
    python = evaluate_linked(model.links, assembler, state, True, 1.0, True)
    cables = assembler.native().cable_state(state)
    assert np.all(cables[:, 4] > 1.0), cables  # every cable taut, its total tension N > 0
    assert np.all(np.abs(cables[:, 1]) > 1e-3)  # and stretching or shortening: its damper acts
    for beta_p, gamma_p in ((0.0, 0.0), (0.0, 1.0), (400.0, 20.0)):  # K alone, C alone, an iteration's
        expected = np.asarray(python.combined(beta_p, gamma_p, 1.0, dense=True))
        matrix, in_pattern = compiled_iteration_matrix(assembler, state, beta_p, gamma_p)
        assert np.abs(expected[~in_pattern]).max(initial=0.0) == 0.0
        assert np.abs(matrix - expected).max() <= 1e-12 * np.abs(expected).max(), (beta_p, gamma_p)
    # with the inertia tangent (solve.newton: exact, or after a Newton failure) the compiled matrix holds the
    # dependent rates' term too, as the Python reduction with rates_term (the joint bodies' inertia
    # stiffness, which only the Python exact K adds, left out of both here)
    from latdyn.assembly.linked import reduce_linked

    assembler.native(True)
    assembler.complete_links(state)
    full = assembler.evaluate_assembled(state, True, 1.0, True, True)
    exact = reduce_linked(model.links, assembler, state, full, True, True, rates_term=True, inertia_tangent=True)
    for beta_p, gamma_p in ((0.0, 0.0), (400.0, 20.0)):
        expected = np.asarray(exact.combined(beta_p, gamma_p, 1.0, dense=True))
        matrix, _ = compiled_iteration_matrix(assembler, state, beta_p, gamma_p, exact=True)
        assert np.abs(matrix - expected).max() <= 1e-12 * np.abs(expected).max(), ("exact", beta_p, gamma_p)
    # the Python reduction against central differences of the reduced residual: C and M at the moving
    # state, K at rest in the same configuration (in motion the dependent nodes' rates J v and
    # accelerations J a + c(v) move with q too: tests/test_linked_rates.py)
    for (cm, cc), what in (((0.0, 1.0), "v"), ((1.0, 0.0), "a")):
        exact = np.asarray(python.combined(cm, cc, 0.0, dense=True))
        fd = finite_difference(prepared, state, what)
        assert np.abs(exact - fd).max() <= 1e-7 * np.abs(fd).max(), what
    at_rest = state.copy()
    for rates in ("v", "w", "theta_dot", "a", "alpha", "theta_ddot"):
        getattr(at_rest, rates)[:] = 0.0
    K = np.asarray(evaluate_linked(model.links, assembler, at_rest, True, 1.0, True).combined(0.0, 0.0, 1.0,
                                                                                                dense=True))
    K_fd = finite_difference(prepared, at_rest, "q")
    assert np.abs(K - K_fd).max() <= 1e-7 * np.abs(K_fd).max()


def newton_iterations(text: str, tmp_path) -> tuple[int, int]:
    """A transient run's Newton iterations and steps (summary.json)."""
    out = tmp_path / "out"
    latdyn.run(latdyn.load_scene(scene_yaml(text)), out_dir=str(out))
    summary = json.loads((out / "summary.json").read_text())
    return summary["newton_iterations"], summary["steps"]


def slide_pulled_by_cables(steps: int = 1) -> tuple[str, float]:
    """A body B guided along the skew axis n on the fixed ground (a spring k on the slide) carrying a
    rigid link to a body D, its hinge's axis n with a spring; two pretensioned, damped cables along n,
    one on B and one on D (a dependent node): D moves with the slide and the cable's line meets the
    hinge's axis's direction, so the hinge stays at 0. The equilibrium is linear in the slide s:
    k s = Σ EA_i (d_i − s − L_i)/L_i, d_i the cables' initial lengths, L_i their rest lengths."""
    n = np.array([1.0, 2.0, 2.0]) / 3.0
    B, D = np.array([0.3, 0.1, 0.2]), np.array([0.8, -0.3, 0.3])
    k, cables = 5000.0, [(2000.0, 1.0, 0.9), (3000.0, 1.0, 0.85)]  # EA, d, L
    s = sum(EA * (d - L) / L for EA, d, L in cables) / (k + sum(EA / L for EA, _, L in cables))
    v = lambda x: "[" + ", ".join(repr(float(c)) for c in x) + "]"  # noqa: E731
    text = f"""
bodies:
  ground: {{at: [0, 0, 0], fixed: true}}
  B: {{at: {v(B)}, mass: 0.7, inertia: [0.01, 0.02, 0.03], guide: {{axis: {v(n)}, stiffness: {k}}}}}
  D: {{at: {v(D)}, mass: 0.4, inertia: [0.01, 0.01, 0.02]}}
sections:
  s: {{EA: 1.0, EIy: 1.0, EIz: 1.0, GJ: 1.0, rhoA: 0.5}}
beams:
  l: {{from: B, to: D, section: s, rigid: true, start: {{hinge: {{axis: {v(n)}, stiffness: 5.0}}}}}}
cables:
  onB: {{from: {{body: ground, offset: {v(B + cables[0][1] * n)}}}, to: B, EA: {cables[0][0]}, damping: 3.0,
        rest_length: {cables[0][2]}}}
  onD: {{from: {{body: ground, offset: {v(D + cables[1][1] * n)}}}, to: D, EA: {cables[1][0]}, damping: 2.0,
        rest_length: {cables[1][2]}}}
solve: {{analysis: static, steps: {steps}}}
output:
  probes:
    s: {{guide: B, quantity: position}}
    angle: {{hinge: l.start, quantity: angle}}
    NB: {{cable: onB, quantity: tension}}
    ND: {{cable: onD, quantity: tension}}
"""
    return text, s


def test_static_slide_pulled_by_cables_on_a_guided_and_a_linked_body(tmp_path):
    """Through the CLI: the static equilibrium of slide_pulled_by_cables is the exact s (measured
    error 4.2e-17 m of 0.070) with the cables' tensions EA (d − s − L)/L (1.4e-15 relative), the hinge
    at 0 (5.4e-17 rad); the problem is linear in s, and with the cables' blocks in the compiled
    (reduced) matrix Newton takes 2 iterations (measured; without them, the matrix of the slide's and
    the hinge's springs alone, the static Newton failed after 330 iterations, exit 1)."""
    text, s = slide_pulled_by_cables()
    completed, out = latdyn_run(tmp_path, text, quiet=True)
    assert completed.returncode == 0, completed.stderr
    probes, summary = probe_columns(out), summary_of(out)
    assert summary["status"] == "solved" and summary["steps"] == 1
    assert summary["newton_iterations"] <= 3
    assert probes["s"][-1] == pytest.approx(s, abs=1e-12)
    assert abs(probes["angle"][-1]) <= 1e-12
    assert probes["NB"][-1] == pytest.approx(2000.0 * (1.0 - s - 0.9) / 0.9, rel=1e-11)
    assert probes["ND"][-1] == pytest.approx(3000.0 * (1.0 - s - 0.85) / 0.85, rel=1e-11)
