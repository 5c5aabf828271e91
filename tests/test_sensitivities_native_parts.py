"""The native parts of the forward sensitivity step (docs/performance.md, "Forward sensitivities: where a step goes"):
∂r/∂p of the section values in one call (``latdyn_section_parameter_forces``, csrc/parameter_forces.c) and the
exact M, C, K scattered onto the assembler's pattern in one call (``latdyn_exact_matrix_values``,
csrc/sensitivity_step.c). A 3D arm with a hinged second beam and a joint body under gravity, one parameter moving
four section values of a section (EA, EIy, EIz, GJ) and one its three inertias: the native call taken, its
sensitivities those of the Python path (the kernels called from Python, einsum, np.add.at) to round-off, through the
API and the CLI; M, C and K the np.bincount of the evaluation's blocks to the bit.
"""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.analyses.sensitivities import ParameterDerivatives
from latdyn.analyses.transient_sensitivities import TransientSensitivities
from latdyn.assembly.native_model import NativeModel
from tests.cli_runs import latdyn_run

ARM = """
title: 3D arm with a hinged second beam and a joint body under gravity, section values by E and rho
gravity: [0, 0, -9.81]
parameters: {E: 1.0, rho: 0.5, F: 2.0}
sections:
  s: {EA: "1.0e4*E", EIy: "20*E", EIz: "30*E", GJ: "15*E", rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]}
beams:
  a: {from: base, to: knee, section: s, elements: 3, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 3
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: 30.0, damping: 0.2}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
  - {at: knee, force: [0, 0, "-2*F*t"], frame: knee}
initial_velocity: {angular: [0, 0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.04, sensitivities: [E, rho, F]}
output:
  every: 0.01
  probes:
    tip_z: {point: b.end, quantity: position, component: z}
    hinge: {hinge: b.start, quantity: angle}
"""


@pytest.fixture(autouse=True)
def _every_step_from_python(monkeypatch):
    """These parts serve the per-step Python path (an event's step, a landing, a parameter kind the loop of steps
    does not take: latdyn/analyses/sensitivities_in_loop.py), which the arm's runs here are held to."""
    monkeypatch.setattr("latdyn.analyses.sensitivities_in_loop.SENSITIVITIES_IN_LOOP", False)


def _run(monkeypatch, native: bool):
    """The arm's run through the API, the section values' ∂r/∂p by the native call (``native``) or from Python;
    (the result, how many native calls served it)."""
    calls = []
    served = NativeModel.section_parameter_forces

    def counted(self, *args, **kwargs):
        calls.append(1)
        return served(self, *args, **kwargs)

    with monkeypatch.context() as patch:
        patch.setattr(NativeModel, "section_parameter_forces", counted)
        if not native:
            patch.setattr(ParameterDerivatives, "_section_kernel_addresses", lambda self: None)
        return latdyn.run(latdyn.load_scene(yaml.safe_load(ARM))), len(calls)


def test_the_section_values_derivatives_in_one_native_call_are_the_python_paths(monkeypatch, tmp_path):
    native, calls = _run(monkeypatch, True)
    python, none = _run(monkeypatch, False)
    assert calls > 8 and none == 0   # the start and every step's ∂r/∂p by the one call
    for key, values in python.sensitivities.items():
        scale = np.abs(values).max()
        assert scale > 0.0, key
        # four section values' products summed in their order, where einsum sums them in SIMD lanes
        assert np.abs(native.sensitivities[key] - values).max() <= 1e-13 * scale, key
    completed, out = latdyn_run(tmp_path, ARM)
    assert completed.returncode == 0, completed.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0].split(",")
    table = np.loadtxt(out / "sensitivities.csv", delimiter=",", skiprows=1)
    for (probe, name), values in native.sensitivities.items():
        column = table[:, header.index(f"{probe}/{name}")]
        assert np.allclose(column, values, rtol=1e-12, atol=1e-14 * np.abs(values).max()), (probe, name)


def test_the_exact_matrices_on_the_pattern_are_the_bincount_of_the_blocks(monkeypatch):
    taken = {}
    step = TransientSensitivities.step

    def kept(self, carried, old, new, *args, **kwargs):
        taken.update(owner=self, state=new)
        return step(self, carried, old, new, *args, **kwargs)

    monkeypatch.setattr(TransientSensitivities, "step", kept)
    latdyn.run(latdyn.load_scene(yaml.safe_load(ARM)))
    assembler, state = taken["owner"].assembler, taken["state"]
    model = assembler.model
    assert len(model.body_nodes) and len(model.free_hinges)

    def refused(*args, **kwargs):
        raise AssertionError("exact_matrix_values scattered by np.bincount, not in its one native call")

    with monkeypatch.context() as patch:
        patch.setattr(np, "bincount", refused)
        values = assembler.exact_matrix_values(state)
    # the reference: the blocks of one evaluation concatenated in the pattern's order, summed by np.bincount
    b = assembler.native(True).buffers
    elements, bodies, loads, cables, couplings, free = assembler._exact_layout
    body = b["body_stiffness"].take(bodies) + assembler.joint_body_inertia_stiffness(state).take(bodies)
    zeros = np.zeros
    data = np.concatenate([
        b["mass"].take(elements), b["body_mass"].take(bodies), zeros(len(free)), zeros(len(loads) + len(cables)),
        zeros(len(couplings)),
        b["quadratic_D"].take(elements), b["body_damping"].take(bodies), b["hinge_d_rate"][free], zeros(len(loads)),
        b["cable_damping"].take(cables), b["coupling_damping"].take(couplings),
        b["tangent"].take(elements) + b["inertia_tangent"].take(elements), body, b["hinge_d_theta"][free],
        b["load_blocks"].take(loads), b["cable_stiffness"].take(cables), b["coupling_stiffness"].take(couplings)])
    reference = np.bincount(assembler._positions3, weights=data, minlength=3 * assembler._nnz).reshape(3, -1)
    assert np.any(b["load_blocks"]) and np.any(b["body_damping"]) and np.any(b["hinge_d_rate"])
    assert values.tobytes() == reference.tobytes()


def test_the_joint_bodies_inertia_stiffness_gathered_in_c_is_the_kernel_called_from_python(monkeypatch):
    result_state = {}
    step = TransientSensitivities.step

    def kept(self, carried, old, new, *args, **kwargs):
        result_state.update(owner=self, state=new)
        return step(self, carried, old, new, *args, **kwargs)

    monkeypatch.setattr(TransientSensitivities, "step", kept)
    latdyn.run(latdyn.load_scene(yaml.safe_load(ARM)))
    assembler, state = result_state["owner"].assembler, result_state["state"]
    native = assembler.joint_body_inertia_stiffness(state)
    monkeypatch.setattr(type(assembler), "_body_stiffness_kernel", lambda self: None)
    from_python = assembler.joint_body_inertia_stiffness(state)
    assert np.any(from_python) and native.tobytes() == from_python.tobytes()


def test_a_states_c_view_is_made_again_only_where_its_arrays_changed():
    from latdyn.assembly.prepare import prepare

    prepared = prepare(yaml.safe_load(ARM))
    native, state = prepared.assembler.native(), prepared.state.copy()
    view = native.configuration(state)
    assert native.configuration(state) is view   # the same arrays: the same view, nothing taken anew
    state.x = state.x.copy()                     # an array replaced: a view of the new one
    moved = native.configuration(state)
    assert moved is not view and moved.x == state.x.ctypes.data
    state.T = np.asfortranarray(state.T)         # not C-contiguous: a copy, viewed anew at each call
    assert native.configuration(state) is not native.configuration(state)
