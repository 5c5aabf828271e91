"""One Newton (issue 31, item 4): the static paths on the native Newton iteration.

Load control, arc length and displacement control take their Newton iterations from the static mode of
csrc/newton_step.c (:class:`latdyn.step.compiled.StaticNewton`): one evaluation, the time step's matrix
storage and LU, its convergence test. Checked here:

- the native iteration equals the evaluation and factorization from Python (r, q_ref, δq_r = −K⁻¹r,
  δq_λ = K⁻¹q_ref) to round-off on a genuinely 3D arm: a rigid link on a skew hinge (reduced onto the
  minimum coordinates in C), a flexible beam on a second skew hinge with a spring, skew gravity and a
  follower force and moment in the tip's frame (K unsymmetric), at a loaded state away from the start;
  its convergence measure is the time step's (``increment_size``);
- a closed form through the CLI and the API: a cantilever with EIy = EIz bent by a dead tip moment about
  a skew axis n ⟂ x rolls into the circle of radius ρ = EI/M in the plane ⟂ n (Euler's elastica under
  pure bending), by load control in the same Newton iterations as before the change (measured 1.45e-6 L);
- the von Mises truss of the gallery turned into a skew plane (genuinely 3D): arc length through the CLI
  and displacement control through the API put every path point on the closed form P(w) (measured
  9.1e-14 and 1.2e-13 of max P) and find both limit loads ±max P (5e-4 to 8.5e-4, the vertex estimate);
- the first Factorization of a process pins the OpenBLAS behind its LAPACK to one thread.

Every scene is YAML text as a user types it.
"""
from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

import latdyn
from cli_runs import latdyn_run, probe_columns, summary_of
from latdyn.analyses.continuation import Path as StaticPath
from latdyn.assembly.prepare import length_scale, prepare
from latdyn.step.integrators import increment_size

ARM = """\
title: skew arm on a rigid link, follower tip load
gravity: [0.3, -9.81, 1.2]
sections:
  s: {EA: 1.0e5, EIy: 20.0, EIz: 30.0, GJ: 15.0, rhoA: 2.0, rhoIy: 0.1, rhoIz: 0.1}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  elbow: {at: [0.5, 0.2, 0.1], mass: 1.0, inertia: [0.01, 0.02, 0.03]}
  tip: {at: [1.2, 0.5, 0.6], mass: 0.5}
beams:
  link: {from: base, to: elbow, section: s, rigid: true, start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: 80.0}}}
  arm: {from: elbow, to: tip, section: s, elements: 4, start: {hinge: {axis: [1.0, 0.2, 0.1], stiffness: 50.0}}}
loads:
  - {at: tip, force: [0, 3.0, -2.0], moment: [0.5, 0, 0.2], frame: tip}
solve: {analysis: static, steps: 4}
output:
  paraview_every: 0
  probes:
    tip_z: {point: tip, quantity: position, component: z}
"""


class _Writer:
    summary: dict = {}


def test_the_native_static_iteration_equals_the_evaluation_and_factorization_from_python(tmp_path):
    scene = tmp_path / "arm.yaml"
    scene.write_text(ARM)
    prepared = prepare(latdyn.load_scene(str(scene)))
    assert prepared.model.links is not None and prepared.model.n_dofs > 10
    path = StaticPath(prepared, None, _Writer(), length_scale(prepared.model))
    assembler = prepared.assembler
    state = prepared.state.copy()
    for _ in range(2):  # a loaded state away from the start, off equilibrium
        step = path.iterate(state, 0.6)
        state = path.step_to(state, 0.7 * step.dq_r)
    for lam in (0.6, 1.0):
        native = path.iterate(state, lam)
        ev = assembler.evaluate(state, matrices=True, load_factor=lam, inertia=False)
        shifted = assembler.evaluate(state, matrices=False, load_factor=lam + 1.0, inertia=False)
        K = ev.stiffness.toarray() if hasattr(ev.stiffness, "toarray") else np.asarray(ev.stiffness)
        assert np.max(np.abs(K - K.T)) > 1e-6 * np.max(np.abs(K))  # the follower load: K unsymmetric
        q_ref = ev.residual - shifted.residual
        dq_r, dq_l = np.linalg.solve(K, -ev.residual), np.linalg.solve(K, q_ref)

        def relative(a, b):
            return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))

        assert relative(native.residual, ev.residual) <= 1e-12
        assert relative(native.reference, q_ref) <= 1e-12
        assert relative(native.dq_r, dq_r) <= 1e-9
        assert relative(native.dq_lambda, dq_l) <= 1e-9
        assert native.size == increment_size(prepared.assembler, native.dq_r, path.length_scale)
        assert relative(path.tangent(state, lam), K) <= 1e-12  # the eigenvalue counts' K, from the dense storage
        assert path.increment_size(dq_r) == increment_size(prepared.assembler, dq_r, path.length_scale)


def test_the_increment_size_is_the_time_steps_own_measure(tmp_path):
    """Statics, continuation and steady motion judge Newton by the time step's measure, written once
    (csrc/newton_step.c increment_size through NativeModel.increment_size): per free node |Δd|/ℓ and |Δπ|, per
    free hinge |Δθ|, the largest; exact references (3-4-12-13 triangles)."""
    scene = tmp_path / "arm.yaml"
    scene.write_text(ARM)
    prepared = prepare(latdyn.load_scene(str(scene)))
    model, length = prepared.model, 2.0
    node = model.node_dofs[model.free_nodes[-1]]
    hinge = model.hinge_dofs[model.free_hinges[-1]]
    for translation, rotation, turn, largest in ((2.0, 0.5, 0.25, 13.0), (0.1, 0.5, 0.25, 6.5),
                                                 (0.1, 0.05, 7.0, 7.0)):
        dx = np.zeros(model.n_dofs)
        dx[node[0:3]] = np.multiply((3.0, 4.0, 12.0), translation)
        dx[node[3:6]] = np.multiply((3.0, 4.0, 12.0), rotation)
        dx[hinge] = -turn
        assert increment_size(prepared.assembler, dx, length) == largest
        assert prepared.assembler.native().increment_size(dx, length) == largest


#: EI = 2, L = 1, M = π EI / L at λ = 1: half a circle of radius ρ = EI/M = 1/π; the axis n = (0, 0.6, 0.8).
PURE_BENDING = """\
title: cantilever rolled by a dead tip moment about a skew axis
sections:
  s: {EA: 1.0e7, EIy: 2.0, EIz: 2.0, GJ: 1.0, rhoA: 1.0, rhoIy: 1.0, rhoIz: 1.0}
bodies:
  root: {at: [0, 0, 0], fixed: true}
beams:
  beam: {from: root, to: [1, 0, 0], section: s, elements: 16}
loads:
  - {at: beam.end, moment: [0, "1.2*pi", "1.6*pi"]}
solve: {analysis: static, steps: 8}
output:
  paraview_every: 0
  probes:
    x: {point: beam.end, quantity: position, component: x}
    y: {point: beam.end, quantity: position, component: y}
    z: {point: beam.end, quantity: position, component: z}
"""


def _circle_tip(moment: np.ndarray, EI: float = 2.0, L: float = 1.0) -> np.ndarray:
    """The tip of a beam along x rolled by the moment vector M ⟂ x: the circle of radius EI/|M| in the
    plane ⟂ M, curving towards M × x."""
    M = float(np.linalg.norm(moment))
    if M == 0.0:
        return np.array([L, 0.0, 0.0])
    n, rho = moment / M, EI / M
    return rho * (math.sin(L / rho) * np.array([1.0, 0, 0]) + (1 - math.cos(L / rho)) * np.cross(n, [1.0, 0, 0]))


def test_load_control_rolls_a_cantilever_into_the_circle_of_pure_bending(tmp_path):
    moment = 2 * math.pi * np.array([0.0, 0.6, 0.8])  # |M| = 2π: half a circle at λ = 1
    completed, out = latdyn_run(tmp_path, PURE_BENDING, quiet=True)
    assert completed.returncode == 0, completed.stderr
    columns = probe_columns(out)
    tips = np.column_stack([columns["x"], columns["y"], columns["z"]])
    expected = np.array([_circle_tip(lam * moment) for lam in columns["load_factor"]])
    assert len(tips) == 9
    error = float(np.max(np.linalg.norm(tips - expected, axis=1)))
    assert error <= 5e-6, error  # measured 1.45e-6 L (16 elements)
    summary = summary_of(out)
    assert summary["newton_iterations"] == NEWTON_ITERATIONS and summary["rejected_steps"] == 0
    api = latdyn.run(latdyn.load_scene(str(tmp_path / "scene.yaml")))
    assert np.array_equal(np.asarray(api.probes["z"]), columns["z"]) or \
        float(np.max(np.abs(np.asarray(api.probes["z"]) - columns["z"]))) <= 1e-12


#: The Newton iterations of PURE_BENDING's 8 load steps (the Python loop took the same).
NEWTON_ITERATIONS = 64


def test_newton_in_one_call_equals_its_iterations_from_python_and_the_pivoted_solve(tmp_path):
    """StaticNewton.newton (the whole Newton in C) against newton_from_python (one native iteration a
    call, the way on where a sparse LU's static pivots fail) and _pivoted (that iteration solved by
    Factorization from Python): the same iterations, the same state."""
    scene = tmp_path / "arm.yaml"
    scene.write_text(ARM)
    prepared = prepare(latdyn.load_scene(str(scene)))
    path = StaticPath(prepared, None, _Writer(), length_scale(prepared.model))
    start = prepared.state.copy()
    native, residual, iterations, converged = path.newton.newton(start, 0.8)
    python, _, python_iterations, python_converged = path.newton.newton_from_python(start.copy(), 0.8)
    assert converged and python_converged and iterations == python_iterations >= 3
    assert np.max(np.abs(native.x - python.x)) <= 1e-12 and np.max(np.abs(native.theta - python.theta)) <= 1e-12
    step = path.iterate(start, 0.8)
    pivoted = path.newton._pivoted(start, 0.8, step.residual, step.reference)
    for a, b in ((pivoted.dq_r, step.dq_r), (pivoted.dq_lambda, step.dq_lambda)):
        assert np.max(np.abs(a - b)) <= 1e-9 * np.max(np.abs(b))
    assert pivoted.size == step.size or abs(pivoted.size - step.size) <= 1e-12 * step.size


def test_the_first_factorization_of_a_process_pins_the_openblas_behind_its_lapack():
    """Each LAPACK call of the native LU runs on one OpenBLAS thread (csrc/factorization.c). The first
    Factorization of a process pinned the only OpenBLAS loaded then, NumPy's, while its getrs was
    SciPy's: two right-hand sides (the static iteration's [−r, q_ref]) took 24 ms on 29 coordinates
    under load instead of 6 µs. In a fresh process: the pinned library is SciPy's own."""
    code = ("from latdyn.assembly.factorization import Factorization\n"
            "f = Factorization((), (), 3, kind='dense')\n"
            "import scipy.linalg\n"
            "from latdyn.numerics.linalg import openblas_thread_functions\n"
            "print(f.structure.get_blas_threads == openblas_thread_functions()[0])\n")
    root = Path(__file__).resolve().parents[1]
    completed = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=root, timeout=60,
                               env={**os.environ, "PYTHONPATH": str(root)})
    assert completed.returncode == 0, completed.stderr
    assert completed.stdout.strip() == "True"


def _skew_rotation() -> np.ndarray:
    """50° about (1, 1, 1)/√3 (Rodrigues): the von Mises truss out of every coordinate plane."""
    axis, angle = np.ones(3) / math.sqrt(3.0), math.radians(50.0)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(angle) * k + (1 - math.cos(angle)) * k @ k


def _skew_von_mises(solve: str) -> str:
    """The gallery's von Mises truss (half-span 10, rise 1, EA = 1e4, P = 20 λ) rotated by _skew_rotation."""
    R = _skew_rotation()

    def v(x):
        return "[" + ", ".join(repr(float(c)) for c in R @ np.asarray(x, float)) + "]"

    return f"""\
title: von Mises truss in a skew plane
sections:
  bar: {{EA: 1.0e4, EIy: 1.0e4, EIz: 1.0e4, GJ: 1.0e4, rhoA: 1.0}}
bodies:
  left: {{at: {v([-10, 0, 0])}, fixed: true}}
  apex: {{at: {v([0, 1, 0])}}}
  right: {{at: {v([10, 0, 0])}, fixed: true}}
beams:
  a: {{from: left, to: apex, section: bar, elements: 1, start: {{hinge: {{axis: {v([0, 0, 1])}}}}}}}
  b: {{from: apex, to: right, section: bar, elements: 1, start: {{hinge: {{axis: {v([0, 0, 1])}}}}},
      end: {{hinge: {{axis: {v([0, 0, 1])}}}}}}}
loads:
  - {{at: apex, force: {v([0, -20.0, 0])}}}
solve: {solve}
output:
  paraview_every: 0
  probes:
    dx: {{point: apex, quantity: displacement, component: x}}
    dy: {{point: apex, quantity: displacement, component: y}}
    dz: {{point: apex, quantity: displacement, component: z}}
"""


def _von_mises_load(w):
    """The closed form P(w) of the truss (docs: examples/gallery/plot_06_snap_through.py)."""
    a, h, EA = 10.0, 1.0, 1.0e4
    L0, L = math.hypot(a, h), np.hypot(a, h - w)
    return 2.0 * EA * (L - L0) / L0 * (w - h) / L


def _deflection(columns) -> np.ndarray:
    """The apex's deflection w along the truss's downward direction −R e_y."""
    down = -_skew_rotation() @ np.array([0.0, 1.0, 0.0])
    return np.column_stack([columns["dx"], columns["dy"], columns["dz"]]) @ down


P_MAX = 3.8108719  # max P(w) over 0 ≤ w ≤ h, N (the gallery's closed form)


def test_arc_length_and_displacement_control_follow_a_skew_von_mises_truss_through_its_snap(tmp_path):
    """Genuinely 3D: the truss in a skew plane. Arc length (CLI) and displacement control (API) put every
    path point on the closed form P(w) and find its limit loads ±max P."""
    assert abs(float(np.max(_von_mises_load(np.linspace(0, 1, 200_001)))) - P_MAX) < 1e-6
    completed, out = latdyn_run(tmp_path, _skew_von_mises("{analysis: static, method: arc-length, steps: 10, "
                                                          "max_steps: 300}"), quiet=True)
    assert completed.returncode == 0, completed.stderr
    columns = probe_columns(out)
    w, load = _deflection(columns), 20.0 * columns["load_factor"]
    arc_error = float(np.max(np.abs(load - _von_mises_load(w)))) / P_MAX
    assert arc_error <= 1e-8, arc_error
    assert w[-1] > 2.0 and columns["load_factor"][-1] == 1.0
    maximum, minimum = summary_of(out)["limit_points"]
    # located (latdyn.analyses.limit_points): measured 1.1e-9, the rounding of P_MAX to 8 digits
    assert abs(20 * maximum["load_factor"] / P_MAX - 1) < 1e-7 and abs(20 * minimum["load_factor"] / P_MAX + 1) < 1e-7

    down = -_skew_rotation() @ np.array([0.0, 1.0, 0.0])
    scene = tmp_path / "control.yaml"
    scene.write_text(_skew_von_mises("{analysis: static, method: displacement-control, steps: 25, control: "
                                     "{point: apex, direction: [" + ", ".join(repr(float(c)) for c in down) +
                                     "], to: 2.5}}"))
    result = latdyn.run(latdyn.load_scene(str(scene)))
    columns = {k: np.asarray(v) for k, v in result.probes.items()}
    w, load = _deflection(columns), 20.0 * np.asarray(result.t)
    assert np.allclose(w, np.linspace(0.0, 2.5, 26), atol=1e-9)
    control_error = float(np.max(np.abs(load - _von_mises_load(w)))) / P_MAX
    assert control_error <= 1e-8, control_error
    kinds = [p["kind"] for p in result.summary["limit_points"]]
    assert kinds == ["maximum", "minimum"]
