"""The generated rigid link's inertia (codegen/joints.py, "Rigid link's inertia"; generated/joints.*): the joint-body
block (m, c, I) of a uniform slender rod, derived by integrating over the rod with the element's section moments,
against the closed form the runtime held before it was generated (latdyn/model/model.py, mass ρA L at mid-length,
E diag((ρIy + ρIz) L, ρA L³/12 + ρIy L, ρA L³/12 + ρIz L) Eᵀ with the loader's frame E); its derivatives by the end
points (``rigid_link_inertia_D_ends``, which replaced the hand-written ``link_inertia_moved``) and by the section values
(``rigid_link_inertia_D_section``, which replaced evaluating the block at the derivative values) against central
differences of that closed form on the scene the loader reads with the points moved (the loader's rule for ŷ included),
and of the kernel itself with its rule held; the NumPy and C kernels equal to round-off."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.model.kernels import joint_kernel
from latdyn.model.model import Model, rigid_link_rows

#: three rigid links in 3D: l1 skew without a y_axis (ŷ = global Z × x̂), l2 with a y_axis given oblique to it, l3
#: vertical without one (ŷ = e_y less its part along x̂); their sections' ρIy ≠ ρIz, so ŷ's turn moves I
LINKS = """
title: three rigid links, skew, with a y_axis given and vertical
sections:
  rod: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 0.7, rhoIy: 0.004, rhoIz: 0.011}
  bar: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 1.3, rhoIy: 0.02, rhoIz: 0.006}
bodies:
  base: {at: [0.1, -0.2, 0.05], fixed: true}
  b1: {at: [0.5, 0.1, 0.35], mass: 0.2, inertia: [0.001, 0.001, 0.001]}
  b2: {at: [0.8, 0.45, 0.2], mass: 0.2, inertia: [0.001, 0.001, 0.001]}
  b3: {at: [0.8, 0.45, 0.75], mass: 0.2, inertia: [0.001, 0.001, 0.001]}
beams:
  l1: {from: base, to: b1, section: rod, rigid: true, start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: 5.0}}}
  l2: {from: b1, to: b2, section: bar, rigid: true, y_axis: [0.3, 1.0, 0.4],
       start: {hinge: {axis: [1.0, -0.4, 0.3], stiffness: 4.0}}}
  l3: {from: b2, to: b3, section: rod, rigid: true, start: {hinge: {axis: [0.0, 1.0, 0.0], stiffness: 3.0}}}
solve: {analysis: transient, dt: 0.01, t_end: 0.02}
"""


def closed_form(beam) -> np.ndarray:
    """The block [m, c, I] of a rigid link by hand, in the loader's frame (beam.y_axis): the formula
    latdyn/model/model.py held before the generated kernel."""
    vector = beam.end.point - beam.start.point
    length = np.linalg.norm(vector)
    x = vector / length
    frame = np.column_stack([x, beam.y_axis, np.cross(x, beam.y_axis)])
    s = beam.section
    rod = s.rhoA * length ** 3 / 12.0
    inertia = frame @ np.diag([(s.rhoIy + s.rhoIz) * length, rod + s.rhoIy * length, rod + s.rhoIz * length]) @ frame.T
    return np.concatenate([[s.rhoA * length], 0.5 * vector, inertia.reshape(9)])


def _scene(moves=None):
    """LINKS as loaded, with {(body, coordinate): shift} moved and {(section, value): shift} changed."""
    data = yaml.safe_load(LINKS)
    for (where, key), shift in (moves or {}).items():
        if where in data["bodies"]:
            data["bodies"][where]["at"][key] += shift
        else:
            data["sections"][where][key] += shift
    return latdyn.load_scene(data)


def _generated():
    """The generated kernels on both backends: the NumPy module's and the C library's (the one the model calls)."""
    import latdyn_generated.joints as numpy_kernels

    return {"numpy": numpy_kernels, "c": {name: joint_kernel(name) for name in
                                          ("rigid_link_inertia", "rigid_link_inertia_D_ends",
                                           "rigid_link_inertia_D_section")}}


def _call(kernels, name, *rows):
    function = kernels[name] if isinstance(kernels, dict) else getattr(kernels, name)
    return np.asarray(function(*rows)[0])


def test_the_models_link_blocks_are_the_closed_form():
    """Model.from_scene's joint-body blocks of the three links (the generated kernel) equal the closed form in the
    loader's frame to round-off (measured 1.8e-16 of the block's largest entry)."""
    scene = _scene()
    model = Model.from_scene(scene)
    for name, beam in scene.beams.items():
        node = next(i for i, n in enumerate(model.nodes) if n.name == f"{name}.link")
        b = int(np.flatnonzero(model.body_nodes == node)[0])
        block = np.concatenate([[model.body_mass[b]], model.body_com[b], model.body_inertia[b].reshape(9)])
        expected = closed_form(beam)
        assert np.abs(block - expected).max() <= 1e-15 * np.abs(expected).max(), name


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_derivatives_by_the_ends_are_the_loaded_models(backend):
    """∂[m; c; I]/∂[A; B] of l1 (ŷ = Z × x̂, turning with the link) and l2 (y_axis given) against central differences
    of the closed form on the scene loaded with each body's point moved (the loader's rule for ŷ at the moved points),
    step 1e-5: ≤ 1e-9 of the block's derivative (measured 1.2e-10 on both backends; 1.1e-8 at a step of 1e-4, 9.9e-11
    at 1e-6: the truncation's h²). Not l3: a vertical link's ŷ jumps from e_y to ±Z × x̂ under a sideways move (the
    loader's rule is discontinuous there: I jumps by (ρIz − ρIy) L = 3.9e-3 under a move along y, which a central
    difference hides, the jump being even), so only its rule held is checked (below)."""
    kernels, scene, h = _generated()[backend], _scene(), 1e-5
    ends = {"l1": ("base", "b1"), "l2": ("b1", "b2")}
    for name, (start, end) in ends.items():
        derivative = _call(kernels, "rigid_link_inertia_D_ends", *rigid_link_rows(scene.beams[name]))[0]
        scale = np.abs(derivative).max()
        for column, body in enumerate((start, end)):
            for k in range(3):
                up = closed_form(_scene({(body, k): h}).beams[name])
                down = closed_form(_scene({(body, k): -h}).beams[name])
                difference = (up - down) / (2 * h)
                assert np.abs(derivative[:, 3 * column + k] - difference).max() <= 1e-9 * scale, (name, body, k)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_the_derivatives_by_the_section_are_the_loaded_models(backend):
    """∂[m; c; I]/∂[ρA, ρIy, ρIz] of each link against the difference of the closed form on the scene loaded with
    the section's value changed (the block is linear in them: no truncation), ≤ 1e-9 of its largest (measured 5.1e-13,
    the difference's round-off)."""
    kernels, scene, h = _generated()[backend], _scene(), 1e-4
    for name, beam in scene.beams.items():
        derivative = _call(kernels, "rigid_link_inertia_D_section", *rigid_link_rows(beam))[0]
        for column, value in enumerate(("rhoA", "rhoIy", "rhoIz")):
            key = (beam.section.name, value)
            difference = (closed_form(_scene({key: h}).beams[name]) - closed_form(_scene({key: -h}).beams[name])) / (2 * h)
            assert np.abs(derivative[:, column] - difference).max() <= 1e-9 * np.abs(difference).max(), (name, value)


def test_the_kernels_derivatives_with_the_rule_held_and_both_backends_equal():
    """On random links under each rule (ŷ from Z × x̂, from a given h, from e_y) the kernels' ∂/∂[A; B] and ∂/∂section
    equal central differences of the kernel's own block with its rule held (step 1e-6, ≤ 1e-8 of the derivative's
    largest; measured 6.7e-10 by the ends, 4.3e-10 by the section), and the NumPy and C kernels agree to ≤ 1e-14 of
    each output's largest (measured: to the bit)."""
    rng = np.random.default_rng(20261128)
    n = 6
    ends = rng.normal(size=(n, 6))
    rules = np.zeros((n, 4))
    rules[0::3, 3] = 1.0
    rules[1::3, 0:3] = rng.normal(size=(len(rules[1::3]), 3))
    rules[2::3, 1] = 1.0
    sections = rng.uniform(0.01, 2.0, (n, 3))
    both = _generated()
    for name in ("rigid_link_inertia", "rigid_link_inertia_D_ends", "rigid_link_inertia_D_section"):
        a, b = _call(both["numpy"], name, ends, rules, sections), _call(both["c"], name, ends, rules, sections)
        assert np.abs(a - b).max() <= 1e-14 * np.abs(a).max(), name
    kernels, h = both["c"], 1e-6
    by_ends = _call(kernels, "rigid_link_inertia_D_ends", ends, rules, sections)
    by_section = _call(kernels, "rigid_link_inertia_D_section", ends, rules, sections)
    for k in range(6):
        up, down = ends.copy(), ends.copy()
        up[:, k] += h
        down[:, k] -= h
        difference = (_call(kernels, "rigid_link_inertia", up, rules, sections)
                      - _call(kernels, "rigid_link_inertia", down, rules, sections)) / (2 * h)
        for row in range(n):
            assert np.abs(by_ends[row, :, k] - difference[row]).max() <= 1e-8 * np.abs(by_ends[row]).max(), (row, k)
    for k in range(3):
        up, down = sections.copy(), sections.copy()
        up[:, k] += h
        down[:, k] -= h
        difference = (_call(kernels, "rigid_link_inertia", ends, rules, up)
                      - _call(kernels, "rigid_link_inertia", ends, rules, down)) / (2 * h)
        for row in range(n):
            assert np.abs(by_section[row, :, k] - difference[row]).max() <= 1e-8 * np.abs(by_section[row]).max()


#: LINKS with a parameter Y moving b3 (the vertical link l3's end) sideways by ``axis``, l3's sensitivities asked for
TILTED = LINKS.replace("title: three rigid links, skew, with a y_axis given and vertical",
                       "title: the vertical link's end moved\nparameters: {Y: 0.0}").replace(
    "solve: {analysis: transient, dt: 0.01, t_end: 0.02}",
    "solve: {analysis: transient, dt: 0.01, t_end: 0.02, sensitivities: [Y]}\n"
    "output:\n  probes:\n    z3: {point: b3, quantity: position, component: z}")


@pytest.mark.parametrize("axis, refused", [(1, True), (0, False)], ids=["along-y", "along-x"])
def test_a_vertical_links_tilt_along_y_is_refused_where_its_frame_jumps(tmp_path, axis, refused):
    """Moving the vertical link l3's end along y (no y_axis, ρIy ≠ ρIz) turns the loader's ŷ by 90° at once: no
    derivative exists, and the run is refused before it starts — through the API (SceneError naming
    solve.sensitivities and the beam) and the CLI (exit 2, no traceback, no results folder); along x ŷ is continuous
    and the run is taken."""
    at = ["0.8", "0.45", "0.75"]
    at[axis] = f"{at[axis]} + Y"
    text = TILTED.replace("b3: {at: [0.8, 0.45, 0.75]", f"b3: {{at: [{', '.join(at)}]")
    assert text != TILTED
    scene = tmp_path / "tilt.yaml"
    scene.write_text(text)
    out = tmp_path / "out"
    import subprocess
    import sys
    run = subprocess.run([sys.executable, "-m", "latdyn", "run", str(scene), "-o", str(out), "-q"],
                         capture_output=True, text=True, timeout=300)
    assert "Traceback" not in run.stderr
    if refused:
        with pytest.raises(latdyn.SceneError) as error:
            latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
        assert error.value.key == "solve.sensitivities" and "vertical beam 'l3'" in str(error.value)
        assert run.returncode == 2 and "l3" in run.stderr and not out.exists()
    else:
        assert run.returncode == 0, run.stderr
