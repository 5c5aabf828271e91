"""Sensitivities of element section forces, cable tensions and lengths and points in a body frame
(latdyn/analyses/probe_derivatives.py; docs/parameters.md, "Section forces, cables and body frames").

References: Richardson-extrapolated central differences of whole runs (the perturbation varied, the step
fixed), with the helpers of the other sensitivity tests (imported): smooth transient runs and static paths
(tests/test_sensitivities_transient.py, h = 10⁻² p; the static scenes of tests/test_sensitivities.py),
runs through a latch (tests/test_sensitivities_events.py) and through a cable's slack and taut changes
(tests/test_sensitivities_cables.py), whose reference runs land on the events as the run does. Each check
holds every probe's largest error over the rows to 1e-6 of its largest sensitivity. The scenes are the
other tests' with these probes in place of theirs: genuinely 3D (a spinning arm with a hinge axis in no
coordinate plane, a wheel latching on a skew arm, a skew cable catching a flexible arm), planar (a frame
whose sections the planar model turns a quarter, a latching arm, a mass dropped on a cable)."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError
from latdyn.results.result import Result
from tests import test_sensitivities as static
from tests import test_sensitivities_cables as cables
from tests import test_sensitivities_events as events
from tests import test_sensitivities_transient as transient
from tests.cli_runs import latdyn_run


def _with_probes(text: str, probes: dict, **solve) -> str:
    """``text`` with these probes in place of its own (and ``solve`` keys set)."""
    data = yaml.safe_load(text)
    data["output"]["probes"] = probes
    data["solve"].update(solve)
    return yaml.safe_dump(data, sort_keys=False)


def _element(beam: str, i: int, quantity: str) -> dict:
    return {"element": f"{beam}.element[{i}]", "quantity": quantity}


def _in_frame(point: str, quantity: str, frame: str, component: str) -> dict:
    return {"point": point, "quantity": quantity, "frame": frame, "component": component}


#: the spinning 3D arm (hinge axis in no coordinate plane, a joint body off its node, gravity, rotary
#: inertia) with section forces of both beams and the tip in the knee's frame
SWING_3D = _with_probes(transient.SWING_3D, {
    "N_a1": _element("a", 1, "axial_force"), "My_a0": _element("a", 0, "moment_y"),
    "T_b0": _element("b", 0, "torque"), "Mz_b1": _element("b", 1, "moment_z"),
    "tip_in_knee": _in_frame("b.end", "position", "knee", "x"),
    "tip_moved_in_knee": _in_frame("b.end", "displacement", "knee", "norm"),
    "tip_speed_in_knee": _in_frame("b.end", "velocity", "knee", "y"),
    "mid_speed_in_knee": _in_frame("b.node[1]", "velocity", "knee", "z")},
    sensitivities=["F", "k", "EI", "G", "rho", "m"])


@pytest.fixture(scope="module")
def swing_3d():
    return transient._run(SWING_3D)


@pytest.mark.parametrize("name", ["F", "k", "EI", "G", "rho", "m"])
def test_3d_transient_probe_sensitivities_agree_with_richardson_central_differences(swing_3d, name):
    """A load, a hinge law, a section stiffness (EIy, EIz), the torsion GJ, the mass per length (ρA, ρIy, ρIz)
    and a body's mass (measured over the eight probes: F 7.5e-10, k 1.7e-8, EI 2.7e-8, G 6.1e-9, rho 3.1e-8,
    m 5.1e-9)."""
    transient._agree(swing_3d, SWING_3D, name, tolerance=1e-6)


#: the static 3D arm (transient.SWING_3D's shape, a follower load at the knee) with an axial stiffness whose
#: strains the central differences resolve: the axial force's round-off is EA times 1e-16 of a strain, and at
#: EA = 1e5 with h = 10⁻³ p (static._richardson) it was 1.3e-3 of the axial force's smallest derivative (by k),
#: at EA = 2000 7e-6; with h = 10⁻² p (transient._richardson, used for the static paths here too) 3.7e-7
ARM_3D = _with_probes(static.ARM_3D.replace("EA: 1.0e5", "EA: 2000.0"), {
    "N_a1": _element("a", 1, "axial_force"), "My_a0": _element("a", 0, "moment_y"),
    "T_b0": _element("b", 0, "torque"), "Mz_b2": _element("b", 2, "moment_z"),
    "tip_in_knee": _in_frame("b.end", "position", "knee", "y"),
    "tip_moved_in_knee": _in_frame("b.end", "displacement", "knee", "norm")})


@pytest.fixture(scope="module")
def arm_3d():
    return static._run(ARM_3D)


@pytest.mark.parametrize("name", ["F", "th0", "EI", "G"])
def test_3d_static_probe_sensitivities_agree_with_richardson_central_differences(arm_3d, name):
    """Load control, 4 steps: a load, the rest angle in the hinge's law, EIy and EIz, GJ (measured ≤ 3e-9)."""
    transient._agree(arm_3d, ARM_3D, name, tolerance=1e-6)


#: the planar frame whose sections' local z lies in the plane: the planar model turns them a quarter, and the
#: section forces are turned back (its in-plane moment is M_y)
PLANAR_TURNED = _with_probes(static.PLANAR_TURNED, {
    "My_a0": _element("a", 0, "moment_y"), "N_b1": _element("b", 1, "axial_force"),
    "My_b2": _element("b", 2, "moment_y"), "tip_in_knee": _in_frame("b.end", "displacement", "knee", "x")},
    sensitivities=["P", "EI"])


@pytest.mark.parametrize("name", ["P", "EI"])
def test_planar_static_section_forces_of_turned_sections_agree(name):
    """(measured: P 2.3e-8, EI 9.6e-8, the axial force's; the moments ≤ 6e-11)"""
    transient._agree(static._run(PLANAR_TURNED), PLANAR_TURNED, name, tolerance=1e-6)


def test_displacement_control_of_a_tilted_arch_gives_section_force_sensitivities():
    """The shallow 3D arch through its plateau under displacement control: the load factor moves with EI,
    and so do the crown's moments and a member's axial force (measured ≤ 1.6e-9)."""
    text = _with_probes(static.ARCH, {
        "N_s2": _element("s2", 1, "axial_force"), "Mz_s3": _element("s3", 0, "moment_z"),
        "My_s3": _element("s3", 0, "moment_y"), "n2_in_n3": _in_frame("n2", "position", "n3", "x")},
        sensitivities=["EI"])
    transient._agree(static._run(text), text, "EI", tolerance=1e-6)


#: the planar arm that latches (lock_at 0.8 at t = 0.4575): the root moment, an axial force and a node in
#: the tip body's frame, through the latch and the rows after it
LATCH_PLANAR = _with_probes(events.LATCH_PLANAR, {
    "Mz_root": _element("arm", 0, "moment_z"), "N_1": _element("arm", 1, "axial_force"),
    "mid_in_tip": _in_frame("arm.node[1]", "position", "tip", "y"),
    "mid_speed_in_tip": _in_frame("arm.node[1]", "velocity", "tip", "x")})


@pytest.mark.parametrize("name", ["k", "EI", "m"])
def test_section_forces_through_a_latch_agree_with_richardson_central_differences(name):
    """(measured: k 1.4e-8, EI 1.1e-8, m 2.1e-8; the latch time's derivative to 1e-7)"""
    result = events._run(LATCH_PLANAR, name)
    assert [e["kind"] for e in result.summary["events"]] == ["latch"]
    assert np.sum(result.t > result.summary["events"][0]["t"]) >= 3   # rows after the latch
    events._agree(result, LATCH_PLANAR, name)


def test_section_forces_of_a_3d_wheel_latching_agree():
    """The wheel on a hinge at the end of a skew arm latches at t = 1.058; the arm's moment, torque and axial
    force and a node's velocity in the wheel's frame by the wheel's inertia (measured 1.8e-7)."""
    text = _with_probes(events.LATCH_3D, {
        "My_0": _element("arm", 0, "moment_y"), "T_1": _element("arm", 1, "torque"),
        "N_1": _element("arm", 1, "axial_force"), "mid_speed_in_wheel": _in_frame("arm.node[1]", "velocity",
                                                                                 "wheel", "z")})
    events._agree(events._run(text, "J"), text, "J")


CABLE_PROBES = {"N": {"cable": "rope", "quantity": "tension"}, "length": {"cable": "rope", "quantity": "length"}}


@pytest.mark.parametrize("text, name, relative", [
    (_with_probes(cables.DROP, CABLE_PROBES), "L", 1e-4), (_with_probes(cables.DROP, CABLE_PROBES), "EA", 1e-4),
    (_with_probes(cables.DAMPED, CABLE_PROBES), "c", 1e-4), (_with_probes(cables.DAMPED, CABLE_PROBES), "L", 1e-5)],
    ids=["rest_length", "EA", "damped_c", "damped_rest_length"])
def test_a_cables_tension_and_length_through_taut_and_slack_agree(text, name, relative):
    """A mass dropped on a slack cable: taut at 0.319 s, slack after the bounce; the tension is 0 while slack
    (its derivative too), EA(ℓ − L)/L (+ c ℓ̇, damped) while taut (measured: L 3.9e-11, EA 2.1e-10,
    damped c 3.1e-10, L 8.6e-10)."""
    result = events._run(text, name)
    assert [e["kind"] for e in result.summary["events"]] == ["taut", "slack"]
    slack = result.probes["N"] == 0.0
    assert slack.any() and (~slack).any()
    assert np.all(result.sensitivities[("N", name)][slack] == 0.0)
    cables._agree(result, text, name, relative=relative, tolerance=1e-6)


def test_a_skew_cable_catching_a_3d_arm_has_exact_tension_and_length_sensitivities():
    """CABLE_3D (taut, slack, taut, slack in 0.25 s; the cable from an anchor off the arm's plane to a point off
    the tip body's centre): its tension and length by the rest length (measured 1.0e-7)."""
    probes = {"N": {"cable": "stay", "quantity": "tension"}, "length": {"cable": "stay", "quantity": "length"}}
    text = _with_probes(cables.CABLE_3D, probes)
    cables._agree(events._run(text, "L"), text, "L", relative=1e-5)


def test_the_adjoint_of_section_forces_and_body_frames_equals_the_forward_method(swing_3d):
    """The adjoint seeds the same forms (probe_forms: ∂y/∂q, ∂y/∂v and the explicit ∂S/∂p of a section value):
    each probe's end, max and min by every parameter equal the forward method's (measured 9.6e-15 of each
    output's largest)."""
    data = yaml.safe_load(SWING_3D)
    data["solve"]["sensitivity_method"] = "adjoint"
    adjoint = latdyn.run(latdyn.load_scene(data))
    for probe, by_which in swing_3d.summary["probe_sensitivities"].items():
        for which, forward in by_which.items():
            got = adjoint.summary["probe_sensitivities"][probe][which]
            scale = max(abs(v) for v in forward.values()) or 1.0
            assert max(abs(got[n] - forward[n]) for n in forward) <= 1e-12 * scale, (probe, which)


def test_the_cli_writes_the_probes_sensitivities_and_the_api_gives_the_same(tmp_path, swing_3d):
    """``python -m latdyn run``: sensitivities.csv holds a column per probe and parameter, read back equal to
    the API's."""
    run, out = latdyn_run(tmp_path, SWING_3D)
    assert run.returncode == 0, run.stderr
    header = (out / "sensitivities.csv").read_text().splitlines()[0].split(",")
    assert header[:3] == ["t", "N_a1/F", "N_a1/k"] and "mid_speed_in_knee/m" in header
    written = Result.load(out)
    assert set(written.sensitivities) == set(swing_3d.sensitivities)
    for key, values in swing_3d.sensitivities.items():
        np.testing.assert_array_equal(written.sensitivities[key], values)


def test_a_static_body_frame_velocity_is_refused_naming_the_key():
    data = yaml.safe_load(static.ARM_3D)
    data["output"]["probes"] = {"p": _in_frame("b.end", "velocity", "knee", "x")}
    with pytest.raises(SceneError) as refused:
        latdyn.run(latdyn.load_scene(data))
    assert refused.value.key == "solve.sensitivities" and "transient runs only" in str(refused.value)


# ---------------------------------------------------------------------------------------------- geometry parameters
def _check_section_forces_reference(kernels, state, reference):
    """beam_section_forces_D_reference along ``reference`` against central differences of the section forces at
    the moved reference data (tests/test_sensitivities_geometry.py's ``_reference_moved``)."""
    import test_sensitivities_geometry as geometry

    def forces(eps):
        moved, section = geometry._reference_moved(state, reference, eps)
        return np.asarray(kernels.beam_strain_energy(moved, section)[1]).reshape(4)

    values, derivative = kernels.beam_section_forces_D_reference(state.geometry(), state.section[None], reference[None])
    np.testing.assert_allclose(np.asarray(values).reshape(4), forces(0.0), rtol=0, atol=1e-12 * np.abs(values).max())
    numeric = (forces(geometry.H) - forces(-geometry.H)) / (2 * geometry.H)
    error = np.linalg.norm(np.asarray(derivative).reshape(4) - numeric) / np.linalg.norm(numeric)
    assert error <= 1e-6, error
    return error


def test_the_section_forces_reference_derivative_against_finite_differences():
    """The generated ∂S/∂(reference data) along a variation (moved fixed ends, offsets, nodal frames, L0, hinge
    axes), planar (default_xy: in-plane variations) and 3D (default: random large-rotation states with hinges,
    offsets and shear), against central differences of the section forces (h = 1e-6; measured ≤ 1.3e-9 planar,
    2.1e-9 3D, the differences' own error)."""
    import element_states as es
    import test_sensitivities_geometry as geometry
    from test_planar import planar_state

    from latdyn.model.kernels import load_kernels

    rng = np.random.default_rng(342)
    kernels = load_kernels(backend="auto", variant="default_xy")
    for _ in range(3):
        _check_section_forces_reference(kernels, planar_state(rng, 2, deformation=0.3),
                                        geometry._planar_reference(rng, 2))
    kernels = load_kernels(backend="auto", variant="default")
    for regime in es.REGIMES.values():
        reference = rng.normal(size=25)
        reference[18] *= 0.1
        _check_section_forces_reference(kernels, es.random_state(rng, deformation=regime), reference)


def _geometry_scenes():
    import test_sensitivities_geometry as geometry

    swing = _with_probes(geometry.PLANAR_SWING, {
        "M_0": _element("arm", 0, "moment_z"), "N_1": _element("arm", 1, "axial_force"),
        "M_2": _element("arm", 2, "moment_z"), "mid_in_tip": _in_frame("arm.node[1]", "position", "tip", "y"),
        "mid_moved_in_tip": _in_frame("arm.node[1]", "displacement", "tip", "x"),
        "mid_speed_in_tip": _in_frame("arm.node[1]", "velocity", "tip", "x"),
        "base_in_tip": _in_frame("base", "displacement", "tip", "norm")})
    knee = _with_probes(geometry.KNEE_3D, {
        "N_a1": _element("a", 1, "axial_force"), "My_a0": _element("a", 0, "moment_y"),
        "T_b0": _element("b", 0, "torque"), "Mz_b1": _element("b", 1, "moment_z"),
        "tip_in_knee": _in_frame("b.end", "position", "knee", "z"),
        "root_moved_in_knee": _in_frame("b.start", "displacement", "knee", "y"),
        "tip_speed_in_knee": _in_frame("b.end", "velocity", "knee", "x"),
        "base_in_knee": _in_frame("base", "position", "knee", "x")})
    static_knee = _with_probes(geometry.STATIC_KNEE_3D, yaml.safe_load(knee)["output"]["probes"])
    static_knee = _with_probes(static_knee, {k: v for k, v in yaml.safe_load(static_knee)["output"]["probes"].items()
                                             if "speed" not in k})
    return {"planar_swing": (swing, ["yb", "L"]), "knee_3d": (knee, ["X", "tz", "dy"]),
            "static_knee_3d": (static_knee, ["X", "dy"])}


@pytest.mark.parametrize("case", ["planar_swing", "knee_3d", "static_knee_3d"])
def test_section_forces_and_body_frames_by_geometry_parameters_agree(case):
    """A fixed base and a tip body moved (planar, transient), the 3D knee's place, the hinged beam's free end and
    its offset from the knee (transient, and static under gravity): the section forces through their reference
    data (beam_section_forces_D_reference), points in a body's frame through the moved offsets, fixed nodes
    and starts (tests/test_sensitivities_geometry.py's scenes and reference, h = 3·10⁻³ p; measured: planar yb
    2.9e-9, L 4.7e-9; 3D X 2.0e-8, tz 2.1e-8, dy 1.2e-8; static X 1.3e-9, dy 8.9e-9). The hinged beam's root,
    rigidly at its offset from the knee, keeps a zero displacement in the knee's frame as dy moves the offset."""
    import test_sensitivities_geometry as geometry

    text, names = _geometry_scenes()[case]
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    for name in names:
        geometry._agree(result, text, name, tolerance=1e-6)


def test_the_root_moment_of_a_cantilever_by_its_length_is_the_beam_theorys():
    """A cantilever of length L under a tip load P (tests/test_sensitivities_geometry.py's): the moment at the
    first element's middle, L/8 from the root, is P (L − L/8), so dM/dL = 7P/8 (to the element's geometric
    nonlinearity, 5e-5), and the unstressed start's section forces move with no parameter (0 at λ = 0)."""
    import test_sensitivities_geometry as geometry

    text = _with_probes(geometry.CANTILEVER, {"M_0": _element("arm", 0, "moment_z"),
                                              "tip_in_base": _in_frame("tip", "displacement", "base", "y")})
    result = latdyn.run(latdyn.load_scene(yaml.safe_load(text)))
    slope = result.sensitivities[("M_0", "L")]
    assert slope[0] == 0.0
    assert abs(abs(slope[-1]) - 7 * 50.0 / 8) <= 1e-4 * 7 * 50.0 / 8
    geometry._agree(result, text, "L", tolerance=1e-6)


def _controller_reading(text: str, replace: tuple, probes: str) -> str:
    """tests/test_sensitivities_controller_states.py's scene ``text`` with EIy = EI, EIz = 1.2 EI named, its
    controller's law changed (``replace``) to read the added ``probes``."""
    return (text.replace("parameters: {Kf: 3.0,", "parameters: {EI: 40.0, Kf: 3.0,")
            .replace("EIy: 40.0, EIz: 40.0", 'EIy: "EI", EIz: "1.2*EI"').replace(*replace) + probes)


def test_a_sampled_controller_reading_a_section_force_and_a_body_frame_agrees():
    """The 3D flexible arm's PI sampled at 50 Hz (clipped) reads the root moment too, whose explicit ∂M/∂EI enters
    its held output, and a node in the tip body's axes (measured: EI 6.2e-10, Kf 2.2e-9, with h = 10⁻³ p: at 10⁻² p the differences' truncation
    was 2e-6)."""
    import test_sensitivities_controller_states as states

    text = _controller_reading(states.SAMPLED_ARM, ('"-Kf*(tip_z - 0.66) - 0.2*I"', '"-Kf*(tip_z - 0.66) - 0.2*I '
                                                    '+ 0.03*Mr + 0.05*(rel + 0.444)"'),
                               '    Mr: {element: "arm.element[0]", quantity: moment_y}\n'
                               '    rel: {point: "arm.node[1]", quantity: position, frame: tip, component: x}\n')
    result = states._run(text, ["EI", "Kf"])
    for name in ("EI", "Kf"):
        errors = states._richardson_errors(text, result, name, 1e-3)
        assert max(errors.values()) <= 1e-6, (name, errors)


def test_a_controller_with_states_reading_a_point_in_a_body_frame_agrees():
    """The 3D arm's low-pass filter state reads a node's position in the tip body's axes (measured: EI 9.4e-10,
    Kf 1.2e-8)."""
    import test_sensitivities_controller_states as states

    text = _controller_reading(states.FILTERED_ARM, ('states: {F: "(tip_z - 0.66 - F)/tau"}',
                                                     'states: {F: "(tip_z - 0.66 + 0.5*(rel + 0.444) - F)/tau"}'),
                               '    rel: {point: "arm.node[1]", quantity: position, frame: tip, component: x}\n')
    result = states._run(text, ["EI", "Kf"])
    for name in ("EI", "Kf"):
        errors = states._richardson_errors(text, result, name, 1e-3)
        assert max(errors.values()) <= 1e-6, (name, errors)


def test_section_forces_of_a_3d_arch_snapping_through_under_arc_length_agree():
    """The tilted 3D arch of tests/test_sensitivities_static_arc.py through its snap-through (a maximum and a
    minimum of λ), each row at its arc length from the one before: the crown members' moments and axial force
    and a node in the crown body's frame by EI (measured ≤ 8.5e-11; that file's reference and tolerance)."""
    import copy

    import test_sensitivities_static_arc as arc

    scene = copy.deepcopy(arc.SPATIAL)
    scene["output"]["probes"] = {"Mz_s1": _element("s1", 1, "moment_z"), "My_s2": _element("s2", 0, "moment_y"),
                                 "N_s1": _element("s1", 0, "axial_force"),
                                 "n1_in_n2": _in_frame("n1", "displacement", "n2", "norm")}
    result, summary = arc._run(scene, ["EI"])
    arc._snaps_through(result, summary)
    arc._check(result, summary, arc._richardson(scene, "EI"), "EI")


def test_section_forces_and_body_frames_with_a_guided_slider_agree():
    """The mass sliding on a skew guide at the tip of a flexible 3D arm (tests/test_sensitivities_guides.py's):
    the arm's section forces, the slider (a dependent node, moved by the guides' reduction) in the tip's frame
    and a node in the slider's frame, by EI (measured 3.4e-8; m 6.4e-8, not run here), with that file's
    reference (h = 10⁻⁴ p: at 10⁻² p the differences' truncation was 8e-6)."""
    import test_sensitivities_guides as guides

    text = _with_probes(guides.GUIDE_3D, {
        "My_0": _element("arm", 0, "moment_y"), "N_2": _element("arm", 2, "axial_force"),
        "slider_in_tip": _in_frame("slider", "position", "tip", "x"),
        "mid_moved_in_slider": _in_frame("arm.node[1]", "displacement", "slider", "norm")})
    guides._agree(guides._run(text, "EI"), text, "EI")


#: a 3D cantilever whose tip a pretensioned skew stay holds, loaded statically
STAYED = """
title: a 3D cantilever whose tip a pretensioned skew stay holds, static
parameters: {F: 3.0, EI: 40.0}
sections: {s: {EA: 1.0e5, EIy: "EI", EIz: "1.3*EI", GJ: "0.8*EI", rhoA: 0.5}}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  anchor: {at: [0.3, 0.6, 0.9], fixed: true}
  tip: {at: [0.6666666666666666, 0.3333333333333333, 0.0]}
beams:
  arm: {from: base, to: tip, section: s, elements: 3}
cables:
  stay: {from: anchor, to: {body: tip, offset: [0.05, -0.02, 0.03]}, EA: 5000.0, rest_length: 1.0}
loads:
  - {at: tip, force: [0.2, "0.3*F", "-F"]}
solve: {analysis: static, method: load-control, steps: 4, sensitivities: [F, EI]}
output:
  probes:
    N: {cable: stay, quantity: tension}
    length: {cable: stay, quantity: length}
    M_0: {element: "arm.element[0]", quantity: moment_z}
"""


#: STAYED under gravity with a stay of three elements with mass (its inner nodes sag: its length sums three)
STAYED_HEAVY = STAYED.replace("rest_length: 1.0}", "rest_length: 1.0, elements: 3, rhoA: 0.3}").replace(
    "title:", "gravity: [0, 0, -9.81]\ntitle:")


@pytest.mark.parametrize("text", [STAYED, STAYED_HEAVY], ids=["stay", "heavy_stay"])
@pytest.mark.parametrize("name", ["F", "EI"])
def test_a_stays_tension_and_length_on_a_static_path_agree(text, name):
    """Load control of the stayed cantilever (the stay taut throughout): its tension and length and the root
    moment by the load and the arm's EI (measured: F 4.1e-11, EI 7.8e-11; the heavy stay of three elements
    under gravity F 9.6e-11, EI 1.3e-10)."""
    transient._agree(static._run(text), text, name, tolerance=1e-6)


def test_a_rigidly_turned_scene_has_the_same_section_force_sensitivities_and_turned_body_frame_ones():
    """Objectivity (tests/test_sensitivities_transient.py's turned scene: points, hinge axis, section axes, the
    body's centre of mass and inertia, load, gravity and spin turned by R, 0.7 rad about a skew axis): the section
    forces, in the turned section axes, keep their sensitivities; a point in the knee's frame, whose axes are
    the global ones at t = 0 (so T_b turns to R T_b Rᵀ), has its sensitivities turned by R (measured ≤ 4.7e-13
    of each's largest)."""
    angle, axis = 0.7, np.array([1.0, -2.0, 0.5]) / np.linalg.norm([1.0, -2.0, 0.5])
    skew = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    rotation = np.eye(3) + np.sin(angle) * skew + (1 - np.cos(angle)) * skew @ skew
    probes = {"N_a1": _element("a", 1, "axial_force"), "My_a0": _element("a", 0, "moment_y"),
              "T_b0": _element("b", 0, "torque"), "Mz_b1": _element("b", 1, "moment_z"),
              **{f"tip_{c}": _in_frame("b.end", "position", "knee", c) for c in "xyz"},
              **{f"speed_{c}": _in_frame("b.node[1]", "velocity", "knee", c) for c in "xyz"}}
    text = _with_probes(transient.SWING_3D, probes)
    base = transient._run(transient._turned(text, np.eye(3)))
    turned = transient._run(transient._turned(text, rotation))
    for name in ("k", "EI", "rho", "m", "cx", "J"):
        for probe in ("N_a1", "My_a0", "T_b0", "Mz_b1"):
            expected = base.sensitivities[(probe, name)]
            assert np.abs(turned.sensitivities[(probe, name)] - expected).max() <= 1e-8 * np.abs(expected).max()
        for point in ("tip", "speed"):
            moved = rotation @ np.array([base.sensitivities[(f"{point}_{c}", name)] for c in "xyz"])
            got = np.array([turned.sensitivities[(f"{point}_{c}", name)] for c in "xyz"])
            assert np.abs(got - moved).max() <= 1e-8 * np.abs(moved).max(), (point, name)
