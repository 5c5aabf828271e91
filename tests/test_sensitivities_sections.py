"""Sensitivities by section values for every formulation and for shear-flexible sections (docs/parameters.md,
"Section values"): the generated derivatives of the element's forces and energies by its section values
(``beam_internal_force_D_section``, ``beam_inertia_force_D_section``, ``beam_section_forces_D_section``,
``beam_energies_D_section``, ``beam_stiffness_D_section``: forward mode of the lowered kernels,
codegen/derivation.py ``section_tangent``) against central differences of the kernels, planar and 3D at
large-rotation states with shear; then whole runs — a shear-flexible (Timoshenko) 3D arm, skew, spinning, with a
hinge spring, by GAy, GAz, EIy, ρA, static and transient, with its energies and momenta; a shear-flexible arch
snapping through under arc length; the formulations cr4402 and no_stiffening by EA and EI — against Richardson
central differences of whole runs (tests/test_sensitivities_transient.py's ``_richardson``), through the API and
the CLI, and the adjoint against the forward method.

A variant generated before the section derivatives refuses these parameters naming the command that makes them;
a test of such a variant is skipped, saying which (the committed tree regenerates every variant at once).
"""
from __future__ import annotations

import json

import numpy as np
import pytest
import yaml

import element_states as es
from latdyn.model.kernels import generated_info, load_kernels
from test_planar import planar_state, planar_velocity
from test_sensitivities_transient import _agree, _run
from tests.cli_runs import latdyn_run

KERNELS = ("beam_internal_force_D_section", "beam_inertia_force_D_section", "beam_section_forces_D_section",
           "beam_energies_D_section", "beam_stiffness_D_section")


def _needs(variant: str) -> None:
    """Skip where ``variant`` was generated before the section derivatives (python -m codegen regenerates it)."""
    if not all(name in generated_info(variant) for name in KERNELS):
        pytest.skip(f"generated variant {variant!r} predates {KERNELS[0]} (python -m codegen --variant {variant})")


# ---------------------------------------------------------------------------------------------- the kernels
def _check_section_derivatives(kernels, state, qdot, acceleration, gravity) -> float:
    """Each of the nine section values' columns (EA … 1/GAz) of the five kernels against central differences of
    the force, energy and tangent kernels in that value (h = 1e-6 of it; the tangent along ``qdot``); returns the
    largest relative error."""
    geometry, section = state.geometry(), state.section
    by_force = np.asarray(kernels.beam_internal_force_D_section(geometry, section[None])[1]).reshape(14, 9)
    by_inertia = np.asarray(kernels.beam_inertia_force_D_section(geometry, qdot[None], acceleration[None],
                                                                 section[None], gravity[None])[1]).reshape(14, 9)
    by_sections = np.asarray(kernels.beam_section_forces_D_section(geometry, section[None])[1]).reshape(4, 9)
    by_energies = np.asarray(kernels.beam_energies_D_section(geometry, qdot[None], section[None],
                                                             gravity[None])[1]).reshape(3, 9)
    by_stiffness = np.asarray(kernels.beam_stiffness_D_section(geometry, qdot[None], section[None])[1]).reshape(14, 9)

    def outputs(block):
        return (np.asarray(kernels.beam_internal_force(geometry, block[None])[0]).reshape(14),
                np.asarray(kernels.beam_inertia_tangent(geometry, qdot[None], acceleration[None], block[None],
                                                        gravity[None])[0]).reshape(14),
                np.asarray(kernels.beam_strain_energy(geometry, block[None])[1]).reshape(4),
                np.array([np.asarray(kernels.beam_strain_energy(geometry, block[None])[0]).reshape(()),
                          np.asarray(kernels.beam_kinetic_energy(geometry, qdot[None], block[None])[0]).reshape(()),
                          np.asarray(kernels.beam_gravity(geometry, block[None], gravity[None])[1]).reshape(())]),
                np.asarray(kernels.beam_internal_force_D_q(geometry, block[None])[1]).reshape(14, 14) @ qdot)

    worst, moved = 0.0, 0
    for d in range(9):
        h = 1e-6 * section[d + 1]
        up, down = section.copy(), section.copy()
        up[d + 1] += h
        down[d + 1] -= h
        for generated, plus, minus in zip((by_force[:, d], by_inertia[:, d], by_sections[:, d], by_energies[:, d],
                                           by_stiffness[:, d]),
                                          outputs(up), outputs(down)):
            numeric = (plus - minus) / (2 * h)
            # relative to the derivative or, where it is small (a twist near zero), to the output per unit
            # relative change of the value: the differences' round-off is 1e-16 of the output over h
            scale = max(np.linalg.norm(numeric), np.linalg.norm(plus) / section[d + 1])
            if scale == 0.0:   # an output that is zero here
                assert np.all(generated == 0.0), d
                continue
            moved += np.linalg.norm(numeric) > 0.0
            worst = max(worst, np.linalg.norm(generated - numeric) / scale)
    assert moved >= 9 and worst <= 1e-6, (moved, worst)
    return worst


def test_planar_section_derivatives_against_finite_differences():
    """default_xy: at random planar states with hinges, offsets and shear (1/GA > 0), every column of the five
    kernels (measured ≤ 3e-8 of the derivative's scale: the differences' own error); the inertia force reads EIz
    and 1/GAy through the shear factor of its shape functions."""
    kernels = load_kernels(backend="auto", variant="default_xy")
    rng = np.random.default_rng(341)
    for _ in range(2):
        state = planar_state(rng, 2, deformation=0.3)
        _check_section_derivatives(kernels, state, planar_velocity(rng, 2), planar_velocity(rng, 2),
                                   np.array([rng.normal(), rng.normal(), 0.0]) * 9.81)


@pytest.mark.parametrize("variant", ["default", "cr4402_xy", "no_stiffening_xy"])
def test_section_derivatives_of_other_variants_against_finite_differences(variant):
    """3D (default, random large-rotation states of every regime with hinges, offsets and shear) and the planar
    cr4402 and no_stiffening variants."""
    _needs(variant)
    kernels = load_kernels(backend="auto", variant=variant)
    rng = np.random.default_rng(342)
    if variant == "default":
        for regime in es.REGIMES.values():
            _check_section_derivatives(kernels, es.random_state(rng, deformation=regime), rng.normal(size=14),
                                       rng.normal(size=14), rng.normal(size=3) * 9.81)
    else:
        state = planar_state(rng, 2, deformation=0.3)
        _check_section_derivatives(kernels, state, planar_velocity(rng, 2), planar_velocity(rng, 2),
                                   np.array([0.4, -9.81, 0.0]))


# ---------------------------------------------------------------------------------------------- whole runs
#: a Timoshenko arm: the skew 3D arm of tests/test_sensitivities_transient.py with a shear-flexible section (Φ =
#: 12 EI/(GA L²) ≈ 0.3–1.4 on its elements), spinning at t = 0 under gravity, a hinge spring at the knee; the
#: section forces of one element as probes
SHEAR_SWING_3D = """
title: shear-flexible 3D arm with a hinged second beam, spinning at t = 0 under gravity
gravity: [0, 0, -9.81]
parameters: {F: 2.0, k: 30.0, EI: 20.0, rho: 0.5, GAy: 1500.0, GAz: 900.0}
sections:
  s: {EA: 1.0e4, EIy: "EI", EIz: "1.5*EI", GJ: 15.0, rhoA: "rho", rhoIy: "0.01*rho", rhoIz: "0.02*rho",
      GAy: "GAy", GAz: "GAz"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [1, 0, 0], mass: 0.8, com: [0.05, 0, -0.05], inertia: [0.01, 0.01, 0.02]}
beams:
  a: {from: base, to: knee, section: s, elements: 2, y_axis: [0, 1, 0]}
  b:
    from: knee
    to: [1.6, 0.5, 0.4]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0.6, 0.8], stiffness: "k*(1 + theta**2)", damping: 0.2, rest_angle: 0.1}}
loads:
  - {at: b.end, force: ["0.3*F", "-F", "0.5*F"]}
initial_velocity: {angular: [0, 0, 2.0]}
solve: {analysis: transient, dt: 0.005, t_end: 0.03, sensitivities: [GAy, GAz, EI, rho]}
output:
  every: 0.01
  probes:
    tip_x: {point: b.end, quantity: position, component: x}
    tip_y: {point: b.end, quantity: position, component: y}
    tip_z: {point: b.end, quantity: position, component: z}
    hinge: {hinge: b.start, quantity: angle}
    moment: {element: "a.element[0]", quantity: moment_z}
    shear_moment: {element: "a.element[0]", quantity: moment_y}
"""

#: the same arm at rest under a load in four load steps
SHEAR_STATIC_3D = (SHEAR_SWING_3D.replace("gravity: [0, 0, -9.81]\n", "")
                   .replace("initial_velocity: {angular: [0, 0, 2.0]}\n", "")
                   .replace("analysis: transient, dt: 0.005, t_end: 0.03", "analysis: static, steps: 4")
                   .replace("sensitivities: [GAy, GAz, EI, rho]", "sensitivities: [GAy, GAz, EI]")
                   .replace("  every: 0.01\n", ""))

#: a planar hinged arm with a tip body in another formulation (FORMULATION replaced), by EA and EI
FORMULATION_PLANAR = """
title: planar hinged arm with a tip body, pushed from rest
parameters: {P: 3.0, EA: 2000.0, EI: 5.0}
sections:
  s: {EA: "EA", EIy: "EI", EIz: "EI", GJ: 4.0, rhoA: 0.5}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  tip: {at: [1.0, 0.2, 0], mass: 0.4, inertia: [0.02, 0.02, 0.02]}
beams:
  arm:
    from: base
    to: tip
    section: s
    elements: 3
    start: {hinge: {axis: [0, 0, 1], stiffness: "8 + 4*theta**2"}}
loads:
  - {at: tip, force: ["2*P*t", "-10*P*t", 0]}
solve: {analysis: transient, dt: 0.01, t_end: 0.1, formulation: FORMULATION, sensitivities: [EA, EI]}
output:
  every: 0.05
  probes:
    tip_y: {point: tip, quantity: displacement, component: y}
    tip_x: {point: tip, quantity: position, component: x}
    axial: {element: "arm.element[0]", quantity: axial_force}
"""


def test_a_shear_flexible_3d_arm_static_by_ga_and_ei_agrees_with_richardson_differences():
    """Static load control of the Timoshenko arm by GAy, GAz and EI (the element nonlinear in them through
    Φ = 12 EI/(GA L²)): tip positions, the hinge angle and one element's bending moments (measured ≤ 3e-8)."""
    _needs("default")
    result = _run(SHEAR_STATIC_3D)
    for name in ("GAy", "GAz", "EI"):
        assert _agree(result, SHEAR_STATIC_3D, name, 1e-6) <= 1e-6


def test_a_shear_flexible_spinning_3d_arm_transient_agrees_with_richardson_differences():
    """Generalized-α through the Timoshenko arm, spinning under gravity, by GAy, GAz, EI and ρA (the inertia
    force reads EI and 1/GA through its shape functions' shear factor; measured ≤ 3e-8)."""
    _needs("default")
    result = _run(SHEAR_SWING_3D)
    for name in ("GAy", "GAz", "EI", "rho"):
        assert _agree(result, SHEAR_SWING_3D, name, 1e-6) <= 1e-6


@pytest.mark.parametrize("formulation", ["cr4402", "no_stiffening"])
def test_other_formulations_by_ea_and_ei_agree_with_richardson_differences(formulation):
    """A transient planar arm in formulation cr4402 and no_stiffening, by EA and EI, an axial force among the
    probes (measured ≤ 2.3e-8)."""
    _needs(f"{formulation}_xy")
    text = FORMULATION_PLANAR.replace("FORMULATION", formulation)
    result = _run(text)
    assert result.summary.get("planar") is not False
    for name in ("EA", "EI"):
        assert _agree(result, text, name, 1e-6) <= 1e-6


#: a planar (default_xy) hinged frame with a shear-flexible section, its second beam's section axes turned a
#: quarter (y_axis along z: the planar model swaps the section's y and z values, GAy with GAz), under a tip load
SHEAR_PLANAR = """
title: planar shear-flexible frame, one beam's section turned a quarter
parameters: {P: 40.0, EI: 5.0, GAy: 300.0, GAz: 200.0}
sections:
  s: {EA: 1.0e4, EIy: "2*EI", EIz: "EI", GJ: 4.0, rhoA: 0.5, GAy: "GAy", GAz: "GAz"}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  knee: {at: [0.6, 0.3, 0]}
beams:
  a: {from: base, to: knee, section: s, elements: 2}
  b:
    from: knee
    to: [1.2, 0.1, 0]
    section: s
    elements: 2
    y_axis: [0, 0, 1]
    start: {hinge: {axis: [0, 0, 1], stiffness: "6 + 3*theta**2"}}
loads:
  - {at: b.end, force: ["0.2*P", "-P", 0]}
solve: {analysis: static, steps: 3, sensitivities: [GAy, GAz, EI]}
output:
  probes:
    tip_y: {point: b.end, quantity: position, component: y}
    tip_x: {point: b.end, quantity: position, component: x}
    hinge: {hinge: b.start, quantity: angle}
    moment: {element: "a.element[1]", quantity: moment_z}
    turned_moment: {element: "b.element[0]", quantity: moment_y}
"""


def test_a_planar_shear_flexible_frame_through_the_cli_and_the_api_agrees_with_richardson_differences(tmp_path):
    """Through ``python -m latdyn run`` and ``latdyn.run``: a planar shear-flexible frame (one section turned a
    quarter) by GAy, GAz and EI against Richardson differences of whole runs (measured ≤ 3.4e-9); sensitivities.csv
    holds the API's numbers."""
    import csv

    result = _run(SHEAR_PLANAR)
    assert result.summary.get("planar") is not False
    for name in ("GAy", "GAz", "EI"):
        assert _agree(result, SHEAR_PLANAR, name, 1e-6) <= 1e-6
    run, out = latdyn_run(tmp_path, SHEAR_PLANAR)
    assert run.returncode == 0, run.stderr
    with open(out / "sensitivities.csv") as f:
        rows = list(csv.DictReader(f))
    for column in ("tip_y/GAy", "turned_moment/GAz", "moment/EI"):
        probe, name = column.split("/")
        np.testing.assert_allclose([float(r[column]) for r in rows], result.sensitivities[(probe, name)],
                                   rtol=1e-12, atol=1e-300)
    summary = json.loads((out / "summary.json").read_text())
    assert "GAz" in summary["probe_sensitivities"]["tip_y"]["end"]


def _shear_arch() -> dict:
    """tests/test_sensitivities_static_arc.py's planar arch snapping through under arc length, its section
    shear-flexible (Φ = 12 EI/(GA L²) ≈ 0.4 on its elements), GA a parameter."""
    from test_sensitivities_static_arc import PLANAR as ARCH

    arch = yaml.safe_load(yaml.safe_dump(ARCH))
    arch["parameters"]["GA"] = 2000.0
    arch["sections"]["s"].update(GAy="GA", GAz="2*GA")
    return arch


@pytest.mark.parametrize("name", ["GA", "EI", "EA0"])
def test_a_shear_flexible_arch_under_arc_length_agrees_with_richardson_differences(name):
    """Arc length through a snap-through of a shear-flexible arch by GA, EI and EA: the first step's length moves
    with the start's ∂K/∂p v (the generated ``beam_stiffness_D_section``), the rows and the limit loads with the
    bordered solve (measured ≤ 1.6e-9 of each quantity's largest)."""
    from test_sensitivities_static_arc import _check, _richardson, _run as arc_run, _snaps_through

    arch = _shear_arch()
    result, summary = arc_run(arch, [name])
    _snaps_through(result, summary)
    _check(result, summary, _richardson(arch, name), name)


#: FORMULATION_PLANAR in the default formulation with a shear-flexible section (Φ ≈ 2.6 on its elements), by GAy
SHEAR_PLANAR_TRANSIENT = (FORMULATION_PLANAR.replace("formulation: FORMULATION, ", "")
                          .replace("parameters: {P: 3.0,", "parameters: {P: 3.0, GAy: 200.0,")
                          .replace("rhoA: 0.5}", "rhoA: 0.5, GAy: \"GAy\", GAz: 400.0}")
                          .replace("sensitivities: [EA, EI]", "sensitivities: [EA, EI, GAy]"))


def test_a_planar_shear_flexible_arm_transient_forward_and_adjoint_agree_with_richardson_differences():
    """Generalized-α through a planar shear-flexible arm by EA, EI and GAy against Richardson differences of whole
    runs (measured ≤ 1e-8), and the discrete adjoint (whose ∂r/∂p is the same batched section derivative,
    transposed) against the forward method (measured 2.5e-14)."""
    from test_sensitivities_adjoint import _adjoint, _disagreement

    result = _run(SHEAR_PLANAR_TRANSIENT)
    for name in ("EA", "EI", "GAy"):
        assert _agree(result, SHEAR_PLANAR_TRANSIENT, name, 1e-6) <= 1e-6
    adjoint = _run(_adjoint(SHEAR_PLANAR_TRANSIENT))
    assert _disagreement(result.summary["probe_sensitivities"], adjoint.summary["probe_sensitivities"]) <= 1e-10


def _with_energies(text: str) -> str:
    """``text`` under gravity with its probes' energies and momenta besides (their explicit ∂/∂p from
    ``beam_energies_D_section`` and ``beam_inertia_force_D_section``)."""
    data = yaml.safe_load(text)
    data.setdefault("gravity", [0.3, -9.81, 0.0] if "P" in data["parameters"] else [0.0, 0.0, -9.81])
    data["output"]["probes"].update(kinetic={"energy": "kinetic"}, strain={"energy": "strain"},
                                    potential={"energy": "potential"}, total={"energy": "total"},
                                    px={"momentum": "linear", "component": "x"},
                                    hz={"momentum": "angular", "component": "z"})
    return yaml.safe_dump(data)


@pytest.mark.parametrize("text, variant, names", [
    (SHEAR_PLANAR_TRANSIENT, "default_xy", ("EI", "GAy")),
    (SHEAR_SWING_3D, "default", ("GAz", "EI", "rho"))], ids=["planar", "3d"])
def test_energies_and_momenta_of_shear_flexible_arms_agree_with_richardson_differences(text, variant, names):
    """Kinetic, strain, potential and total energy and the linear and angular momentum of the shear-flexible
    arms under gravity, transient, by EI, GA and ρA (measured ≤ 6.6e-8 planar, ≤ 2.7e-8 3D)."""
    _needs(variant)
    text = _with_energies(text)
    result = _run(text)
    for name in names:
        assert _agree(result, text, name, 1e-6) <= 1e-6


def test_every_generated_variant_holds_the_section_derivatives():
    """The sensitivities by section values call the generated derivatives by the section values
    (beam_*_D_section, latdyn.model.kernels.ON_DEMAND; the joints' cable_tension_D_q_D_section is not a beam
    variant's). A runtime refusal checked, at every parameter use, that the
    scene's variant held them, for variants generated before them; every variant is generated with them
    (``codegen --check`` holds the tree to the generators), so it never fired and was removed: this holds it here,
    for every variant in the tree."""
    import glob
    import importlib
    from pathlib import Path

    from latdyn.model.kernels import ON_DEMAND, PACKAGE

    stems = sorted(Path(p).stem for p in glob.glob(str(Path(__file__).resolve().parents[1] / "generated" / "beam_*.py")))
    assert len(stems) == 12
    for stem in stems:
        held = set(importlib.import_module(f"{PACKAGE}.{stem}").KERNELS)
        assert {name for name in ON_DEMAND if name.startswith("beam_") and name.endswith("_D_section")} <= held, stem
