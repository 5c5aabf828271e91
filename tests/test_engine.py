"""The compiled step (latdyn/step/compiled.py, csrc/newton_step.c), the runtime's one Newton
iteration, against the reference step of tests/reference_step.py.

The reference restates the generalized-α Newton iteration in NumPy with SciPy's solve around the
same evaluation: with full Newton the compiled step takes
the same steps and iterations and equals it to 1e-10 relative, on genuinely 3D scenes
that use every part of the C evaluation (prescribed rotation, free bodies with inertia
and an initial velocity, hinges with springs, dampers, rest angles and torques, a
prescribed hinge, a latch, gravity, global and follower loads), on the dense and on
the band LU. Modified Newton converges to the Newton tolerance with fewer matrices.
"""
from __future__ import annotations

import copy

import numpy as np
import pytest

import latdyn
from reference_step import reference_engine
from latdyn.errors import SceneError
from latdyn.model.kernels import load_kernels

from test_inertia import free_l_frame, hinged_chain, rigid_motion, tilted_spin

try:
    load_kernels("c", "default")
    HAVE_C = True
except RuntimeError:
    HAVE_C = False

pytestmark = pytest.mark.skipif(not HAVE_C, reason="no C compiler: the compiled step needs one")


def loaded_arm(t_end=0.3, dt=0.005, lock_at=None, **solve):
    """A hinged arm on a free, heavy joint body: spring with a rest angle, damper, torque law,
    a prescribed hinge, gravity, a global load and a follower load in a body frame; with
    ``lock_at``, hinge c latches on the way (it reaches −0.12 at t ≈ 0.146 s).  Shear-deformable
    sections (GAy, GAz: Φ ≈ 0.2 per element), so the compliances pass through both steps."""
    R, shift = rigid_motion(11)
    P = lambda p: (R @ np.asarray(p, float) + shift).tolist()  # noqa: E731
    V = lambda v: (R @ np.asarray(v, float)).tolist()  # noqa: E731
    return {
        "gravity": V([0, -9.81, -2.0]),
        "sections": {"s": {"EA": 5e5, "EIy": 80.0, "EIz": 120.0, "GJ": 60.0, "rhoA": 0.8, "rhoIy": 1e-3,
                           "GAy": 3.0e4, "GAz": 2.0e4}},
        "bodies": {"base": {"at": P([0, 0, 0]), "fixed": True},
                   "hub": {"at": P([1, 0, 0]), "mass": 1.5, "com": V([0.05, 0.02, 0]),
                           "inertia": (R @ np.diag([0.02, 0.03, 0.04]) @ R.T).tolist()},
                   "elbow": {"at": P([2, 0.3, 0.1]), "mass": 0.2}},
        "beams": {
            "a": {"from": "base", "to": "hub", "section": "s", "elements": 2, "y_axis": V([0, 1, 0]),
                  "start": {"hinge": {"axis": V([0, 0.2, 1]), "stiffness": 40.0, "damping": 0.5,
                                      "rest_angle": 0.2, "torque": "3*sin(7*t)"}}},
            "b": {"from": {"body": "hub", "offset": V([0.0, 0.1, 0.0])}, "to": "elbow", "section": "s",
                  "elements": 2, "y_axis": V([0, 0, 1]),
                  "start": {"hinge": {"axis": V([1, 0, 0.3]), "angle": "0.4*t**2"}}},
            "c": {"from": "elbow", "to": P([2.6, 1.0, 0.4]), "section": "s", "elements": 2, "y_axis": V([0, 0, 1]),
                  "start": {"hinge": {"axis": V([0.2, 1, 0]), "stiffness": 5.0,
                                      **({"lock_at": lock_at} if lock_at is not None else {})}}}},
        "loads": [{"at": "a.node[1]", "force": [0.0, "2*t", 1.0]},
                  {"at": "c.end", "force": [0.3, 0.0, "-0.5*cos(3*t)"], "moment": [0.0, 0.1, 0.0], "frame": "hub"}],
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, **solve},
        "output": {"probes": {"tip_x": {"point": "c.end", "quantity": "position", "component": "x"},
                              "tip_z": {"point": "c.end", "quantity": "velocity", "component": "z"},
                              "hub_y": {"point": "hub", "quantity": "position", "component": "y"},
                              "a_hinge": {"hinge": "a.start", "quantity": "angle"},
                              "c_hinge": {"hinge": "c.start", "quantity": "rate"},
                              "kinetic": {"energy": "kinetic"}, "work": {"energy": "external_work"}}},
    }


def long_beam(t_end=0.05, dt=0.005, **solve):
    """A cantilever of 30 elements under a tip load: 180 coordinates, the band LU."""
    return {
        "sections": {"s": {"EA": 1e6, "EIy": 50.0, "EIz": 70.0, "GJ": 40.0, "rhoA": 1.0}},
        "bodies": {"wall": {"at": [0, 0, 0], "fixed": True}},
        "beams": {"b": {"from": "wall", "to": [3.0, 1.0, 0.5], "section": "s", "elements": 30}},
        "loads": [{"at": "b.end", "force": [0.0, "-20*t", "5*t"]}],
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, **solve},
        "output": {"probes": {"tip_y": {"point": "b.end", "quantity": "position", "component": "y"},
                              "tip_w": {"point": "b.end", "quantity": "velocity", "component": "z"},
                              "strain": {"energy": "strain"}}},
    }


def _run(raw, tmp_path, name, **solve):
    raw = copy.deepcopy(raw)
    if solve.get("engine") == "reference":  # the Newton iteration of tests/reference_step.py
        solve.pop("engine")
        with reference_engine():
            return _run(raw, tmp_path, name, **solve)
    raw["solve"].update(solve)
    out = tmp_path / name
    result = latdyn.run(latdyn.load_scene(raw), out)
    import json

    return result, json.loads((out / "summary.json").read_text())


def _relative_difference(a, b):
    worst = 0.0
    for name in a.probes:
        x, y = np.asarray(a.probes[name]), np.asarray(b.probes[name])
        scale = max(float(np.max(np.abs(x))), 1e-12)
        worst = max(worst, float(np.max(np.abs(x - y))) / scale)
    return worst


SCENES = {"tilted_spin": tilted_spin, "free_l_frame": free_l_frame, "hinged_chain": hinged_chain,
          "loaded_arm": loaded_arm, "long_beam": long_beam}


@pytest.mark.parametrize("method", ["generalized-alpha", "hht-alpha"])
@pytest.mark.parametrize("scene", sorted(SCENES))
def test_compiled_step_equals_the_reference_step(scene, method, tmp_path):
    raw = SCENES[scene](method=method)
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled", newton="full")
    assert python_summary["engine"] == "reference" and compiled_summary["engine"] == "compiled"
    for key in ("steps", "newton_iterations", "rejected_steps"):
        assert compiled_summary[key] == python_summary[key], key
    assert _relative_difference(python, compiled) <= 1e-10


def test_the_band_solver_is_exercised():
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    prepared = prepare(latdyn.load_scene(long_beam()))
    step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                    1e-8, 25, 3.0)
    step._setup()
    assert prepared.model.n_dofs == 180 and step.factorization.kind == "band" and step.factorization.kl < 40


def test_a_latch_in_the_compiled_step(tmp_path):
    """The latch is located by secant passes to within its tolerance (1e-7 rad), so round-off
    moves the event by ~1e-8 s: the engines agree to that, not to 1e-10."""
    raw = loaded_arm(lock_at=-0.12)
    python, python_summary = _run(raw, tmp_path, "python", engine="reference")
    compiled, compiled_summary = _run(raw, tmp_path, "compiled", engine="compiled")
    rate = np.asarray(compiled.probes["c_hinge"])
    assert np.any(rate != 0.0) and rate[-1] == 0.0  # the hinge moved, then latched
    assert compiled_summary["steps"] == python_summary["steps"]
    assert np.max(np.abs(np.asarray(python.t) - np.asarray(compiled.t))) < 1e-7
    assert _relative_difference(python, compiled) < 1e-5


def test_modified_newton_reaches_the_newton_tolerance_with_fewer_matrices(tmp_path):
    """Modified Newton stops on the same increment test, so it differs from full Newton by
    the Newton tolerance, far below the error of the time step (measured here against the
    same scene at half the step)."""
    raw = hinged_chain(t_end=0.4)
    full, full_summary = _run(raw, tmp_path, "full", engine="compiled", newton="full")
    modified, modified_summary = _run(raw, tmp_path, "modified", engine="compiled", newton="modified")
    halved, _ = _run(hinged_chain(t_end=0.4, dt=0.0025), tmp_path, "halved", engine="compiled", newton="full")
    assert modified_summary["newton"] == "modified"
    assert modified_summary["factorizations"] < full_summary["factorizations"]
    step_error = max(float(np.max(np.abs(np.asarray(full.probes[name]) - np.asarray(halved.probes[name])[::2])))
                     / max(float(np.max(np.abs(full.probes[name]))), 1e-12) for name in full.probes)
    assert _relative_difference(full, modified) < 0.01 * step_error


def test_rigid_links_step_in_c_with_modified_newton(tmp_path):
    """A model with a rigid link takes the C Newton iteration (its reduction in C too,
    csrc/links.c): modified Newton keeps the factorization and converges to the same solution."""
    raw = hinged_chain(t_end=0.1)
    raw["beams"]["l2"]["rigid"] = True
    full, full_summary = _run(raw, tmp_path, "full", engine="compiled", newton="full")
    modified, modified_summary = _run(raw, tmp_path, "modified", engine="compiled", newton="modified")
    assert full_summary["engine"] == modified_summary["engine"] == "compiled"
    assert modified_summary["factorizations"] < full_summary["factorizations"]  # measured 13 against 60
    assert _relative_difference(full, modified) < 1e-6  # measured 5.1e-8 (tol 1e-8 on the increment)


def test_engine_and_newton_keys_are_validated():
    raw = hinged_chain()
    raw["solve"]["engine"] = "fast"
    with pytest.raises(SceneError, match="solve.engine"):
        latdyn.load_scene(raw)
    raw["solve"]["engine"] = "auto"
    raw["solve"]["newton"] = "quasi"
    with pytest.raises(SceneError, match="solve.newton"):
        latdyn.load_scene(raw)


@pytest.mark.parametrize("threads", [2, 3])
def test_threaded_element_kernels_are_bit_identical(threads):
    """The element part of the compiled step on OpenMP threads (csrc/newton_step.c) changes no
    arithmetic: each element's kernels write its own rows, the scatter stays serial in element
    order. Forced on for 30 elements (threshold 1) with 2 and 3 threads (uneven ranges), the
    states, accelerations and iteration counts equal the serial step's bit for bit."""
    from latdyn.step.compiled import CompiledGeneralizedAlpha
    from latdyn.assembly.library import openmp_threads
    from latdyn.step.integrators import AlphaParameters
    from latdyn.assembly.prepare import prepare

    if openmp_threads() == 0:
        pytest.skip("the compiled step was built without OpenMP (the compiler has no -fopenmp)")
    runs = []
    for parallel in (0, 1):
        prepared = prepare(latdyn.load_scene(long_beam()))
        step = CompiledGeneralizedAlpha(prepared.assembler, AlphaParameters.for_method("generalized-alpha", 0.8),
                                        1e-8, 25, 3.0, parallel_elements=parallel, threads=threads)
        state = prepared.state
        step.start(state)
        iterations = []
        for _ in range(5):
            state, stats = step.step(state, 0.005)
            assert stats.converged
            step.accept()
            iterations.append(stats.iterations)
        runs.append((state, iterations, step.a.copy(), step._native.model.parallel_elements))
    (serial, serial_iterations, serial_a, off), (threaded, threaded_iterations, threaded_a, on) = runs
    assert off == 0 and on == 1
    assert serial_iterations == threaded_iterations
    assert np.array_equal(serial_a, threaded_a)
    for name in ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot"):
        assert np.array_equal(getattr(serial, name), getattr(threaded, name)), name


def test_the_ctypes_mirrors_have_the_compilers_layout():
    """Every struct the C library reads is mirrored once in latdyn/assembly/library.py; their sizes and
    every field's offset are those the compiler gives csrc/newton_step.c and the evaluate.c it
    inlines (a stale mirror once gave wrong section properties, bb8e361)."""
    import ctypes

    from latdyn import native
    from latdyn.assembly import library

    mirrors = {"Model": library.ModelData, "Links": library.LinksData, "Work": library.WorkData,
               "Configuration": library.ConfigurationData,
               "StepVectors": library.VectorsData, "StepControl": library.ControlData, "Advance": library.AdvanceData,
               "Rows": library.RowsData,
               "SparseLU": library.SparseLUStructure, "EvaluationControl": library.EvaluationData,
               "SensitivityStep": library.SensitivityStepStructure}
    lines, expected = [], []
    for c_name, mirror in mirrors.items():
        lines.append(f"    out[{len(expected)}] = (int64_t)sizeof({c_name});")
        expected.append((c_name, "sizeof", ctypes.sizeof(mirror)))
        for field, _ in mirror._fields_:
            lines.append(f"    out[{len(expected)}] = (int64_t)offsetof({c_name}, {field});")
            expected.append((c_name, field, getattr(mirror, field).offset))
    probe = (library.library_source("newton_step.c") + b"\n#include <stddef.h>\nvoid latdyn_layout(int64_t *out)\n{\n"
             + "\n".join(lines).encode() + b"\n}\n")
    lib = native.load(native.build("layout_probe", probe, native.C_FLAGS))
    out = np.zeros(len(expected), np.int64)
    lib.latdyn_layout(out.ctypes.data_as(ctypes.c_void_p))
    wrong = [f"{struct}.{field}: C {int(value)}, ctypes {offset}"
             for (struct, field, offset), value in zip(expected, out) if value != offset]
    assert not wrong, "\n".join(wrong)


def test_full_newtons_contraction_estimate_is_off_by_default_and_within_the_tolerance_when_on(monkeypatch, tmp_path):
    """Full Newton stops on |Δx_k| ≤ tol (the default); with ``estimate_error`` on (csrc/newton_step.c
    newton_converged: ρ/(1 − ρ)|Δx_k| ≤ tol, ρ = |Δx_k|/|Δx_{k−1}|, measured and not adopted:
    docs/performance.md, "Fewer iterations where they buy nothing") it takes fewer iterations on the 3D
    chain with a rigid link, and stays within the tolerance's reach of full Newton at tol 1e-12."""
    from latdyn.step import compiled

    raw = hinged_chain(t_end=0.1)
    raw["beams"]["l2"]["rigid"] = True
    shipped, shipped_summary = _run(raw, tmp_path, "shipped", engine="compiled", newton="full")
    tight, _ = _run(raw, tmp_path, "tight", engine="compiled", newton="full", tol=1e-12)
    made = compiled.CompiledGeneralizedAlpha.__init__

    def with_the_estimate(self, *args, **kwargs):
        made(self, *args, **kwargs)
        self.estimate_error = True

    monkeypatch.setattr(compiled.CompiledGeneralizedAlpha, "__init__", with_the_estimate)
    estimated, estimated_summary = _run(raw, tmp_path, "estimated", engine="compiled", newton="full")
    assert shipped_summary["newton_iterations"] == 60 and estimated_summary["newton_iterations"] == 40  # 3 → 2 a step
    assert _relative_difference(tight, shipped) < 1e-7  # measured 6.8e-9
    # measured 6.8e-6: the hinge rate h3, whose Newton error grows by γ/(βh) times the position's
    assert 1e-7 < _relative_difference(tight, estimated) < 2e-5
