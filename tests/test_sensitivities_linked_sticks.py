"""A hinge of a rigid link sticking and slipping by friction, the forward method (issue 34; latdyn/analyses/
transient_sensitivities.py ``_linked_held_forces``, ``_linked_held_stiffness_along``, ``_held_dependent_motion``, exact
since heldcol; docs/parameters.md, "Friction").

On a model with rigid links a held angle θ_j moves the reduced residual r_min = Pᵀ r_all not only through K_all's
column of it but through the dependent nodes that hang from the joint, through P and through the dependent rates;
it moves the impulse's and the restart's weight W = M + dt²K alike, and the probes on the dependent nodes; and the
restart after a stick or a release weighs with W at the accelerations before it, which the reduction's geometric
term reads (δv̇⁻ on the new numbering). 5a68b93 refused a stick on such a model. Measured on the gimbal below
(whole runs against Richardson-extrapolated central differences, the step fixed, each probe's largest error
over the rows relative to its largest sensitivity): with the refusal lifted and Pᵀ K_all's column alone (t_end 0.2,
h = 1e-4 p) the tip's sensitivities by Fc were 0.86 of themselves off, the outer hinge's angle 1.1; without the held
angles' move of W (h = 1e-3 p) 3.2e-3 (Fc), 3.3e-4 (EI); with δv̇⁻ 0 at the restarts (t_end 0.2, h = 1e-4 p)
1.1e-4 (m), 3.0e-5 (EI); without the dependent nodes' move the inner ring's position 2.25 (Fc), its velocity
5.1e-4 (Fc).

The scene: a gimbal of two rigid rings on skew hinges (3D) carrying a flexible boom, the inner ring's hinge against
Coulomb friction under a sinusoidal torque: stuck from t = 0, slipping, sticking and slipping again."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

import latdyn
from latdyn.errors import SceneError

GIMBAL = """
title: a gimbal of two rigid links on skew hinges, the inner hinge against friction under a sinusoidal torque
parameters: {k: 4.0, m: 0.3, EI: 20.0, Fc: 0.05, tau: 0.12}
sections:
  ring: {EA: 1.0e6, EIy: 1.0e3, EIz: 1.0e3, GJ: 1.0e3, rhoA: 0.8, rhoIy: 0.0008, rhoIz: 0.001}
  boom: {EA: 1.0e5, EIy: "EI", EIz: "1.2*EI", GJ: "0.7*EI", rhoA: 0.4, rhoIy: 0.0004, rhoIz: 0.0005}
bodies:
  base: {at: [0, 0, 0], fixed: true}
  outer: {at: [0.3, 0.1, 0.2], mass: "m", inertia: [0.002, 0.003, 0.0025]}
  inner: {at: [0.45, -0.05, 0.35], mass: 0.2, inertia: [0.001, 0.0012, 0.0015]}
  tip: {at: [1.0, 0.25, 0.55], mass: 0.1, inertia: [0.0002, 0.0002, 0.0002]}
beams:
  gim1: {from: base, to: outer, section: ring, rigid: true,
         start: {hinge: {axis: [0.2, 0.3, 1.0], stiffness: 6.0, damping: 0.02}}}
  gim2: {from: outer, to: inner, section: ring, rigid: true,
         start: {hinge: {axis: [1.0, -0.4, 0.3], stiffness: "k", torque: "tau*sin(15*t)",
                         friction: {coulomb: "Fc", stick_rate: 0.02}}}}
  boom: {from: inner, to: tip, section: boom, elements: 2}
loads:
  - {at: tip, force: [0, 0.3, -0.15]}
solve: {analysis: transient, dt: 0.005, t_end: 0.26, sensitivities: [Fc, k, m, EI]}
output:
  every: 0.01
  probes:
    tip_x: {point: tip, quantity: position, component: x}
    tip_z: {point: tip, quantity: displacement, component: z}
    inner_y: {point: inner, quantity: position, component: y}
    a1: {hinge: gim1.start, quantity: angle}
    a2: {hinge: gim2.start, quantity: angle}
    r2: {hinge: gim2.start, quantity: rate}
    vi: {point: inner, quantity: velocity, component: z}
    pin: {point: tip, quantity: position, frame: outer, component: y}
    vin: {point: tip, quantity: velocity, frame: inner, component: x}
    ke: {energy: kinetic}
    se: {energy: strain}
    te: {energy: total}
    lm: {momentum: linear, component: x}
    am: {momentum: angular, component: z}
    mz: {element: "boom.element[0]", quantity: moment_z}
    my: {element: "boom.element[1]", quantity: moment_y}
    t1: {hinge: gim1.start, quantity: torque}
    t2: {hinge: gim2.start, quantity: torque}
"""


def _run(text: str, sensitivities: bool = True, **moved):
    data = yaml.safe_load(text)
    data["parameters"].update(moved)
    if not sensitivities:
        del data["solve"]["sensitivities"]
    return latdyn.run(latdyn.load_scene(data))


#: the held angle's step in the tests' own central differences along it (rad)
ANGLE_STEP = 1e-5



def _richardson_errors(text: str, result, name: str) -> dict:
    """Each probe's largest distance over the rows of ``result``'s sensitivity by ``name`` from Richardson-extrapolated
    central differences of whole runs of ``text`` (h = 1e-3 |p| and h/2, the step fixed), relative to the
    reference's largest."""
    p0 = yaml.safe_load(text)["parameters"][name]
    h = 1e-3 * abs(p0)
    central = []
    for step in (h, h / 2):
        up, down = _run(text, False, **{name: p0 + step}), _run(text, False, **{name: p0 - step})
        central.append({k: (up.probes[k] - down.probes[k]) / (2 * step) for k in up.probes if k != "t"})
    errors = {}
    for probe in central[0]:
        expected = (4 * central[1][probe] - central[0][probe]) / 3
        errors[probe] = float(np.abs(result.sensitivities[(probe, name)] - expected).max() / np.abs(expected).max())
    return errors

def _along_the_angle(owner, state, of) -> np.ndarray:
    """Σ_j ∂of/∂θ_j δθ_j over the held angles, ``of(moved state)`` an array: a central difference in the test (step
    :data:`ANGLE_STEP`), the state's angle moved, the dependent nodes completed (the free rates and accelerations
    held)."""
    out = 0.0
    for j in np.flatnonzero(np.any(owner.held, axis=1)):
        values = []
        for sign in (1.0, -1.0):
            moved = state.copy()
            moved.theta[j] += sign * ANGLE_STEP
            owner.assembler.complete_links(moved)
            values.append(np.asarray(of(moved), float))
        slope = (values[0] - values[1]) / (2 * ANGLE_STEP)
        out = out + slope[..., None] * owner.held[j]
    return out


@pytest.fixture(scope="module")
def gimbal():
    """The gimbal's run, the held angle's three terms watched on the way (the reduced residual's column
    ``_linked_held_forces``, the weight's ``_linked_held_stiffness_along``, the dependent nodes' move
    ``_held_dependent_motion``): at their first two calls each against the tests' central differences along the
    angle, and every completion of the links at a state whose angles are not the state's own made inside them (an
    evaluation along the angle) counted."""
    from latdyn.analyses.transient_sensitivities import TransientSensitivities as Owner
    from latdyn.assembly.assembler import Assembler

    complete = Assembler.complete_links
    watched = {"moved": 0, "angles": None, "forces": [], "weight": [], "motion": []}

    def complete_counted(self, state):
        angles = watched["angles"]
        watched["moved"] += angles is not None and not np.array_equal(state.theta, angles)
        return complete(self, state)

    def inside(method, state, *args):
        watched["angles"] = state.theta.copy()
        try:
            return method(state, *args)
        finally:
            watched["angles"] = None

    forces, weight, motion = Owner._linked_held_forces, Owner._linked_held_stiffness_along, Owner._held_dependent_motion

    def forces_watched(self, state, inertia):
        out = inside(lambda *a: forces(self, *a), state, inertia)
        if len(watched["forces"]) < 2:
            watched["forces"].append((out, _along_the_angle(self, state, lambda moved: self.assembler.evaluate(
                moved, matrices=False, inertia=inertia).residual)))
        return out

    def weight_watched(self, state, w):
        out = inside(lambda *a: weight(self, *a), state, w)
        if len(watched["weight"]) < 2:
            watched["weight"].append((out, _along_the_angle(self, state, lambda moved: self.assembler.evaluate(
                moved, matrices=True).combined(0.0, 0.0, 1.0) @ w)))
        return out

    def motion_watched(self, state, dx, dpi, rates):
        before = dx.copy()
        inside(lambda *a: motion(self, *a), state, dx, dpi, rates)
        if len(watched["motion"]) < 2:
            nodes = self.model.links.dependent
            differenced = _along_the_angle(self, state, lambda moved: moved.x[nodes])
            watched["motion"].append(((dx - before)[nodes], differenced))

    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(Assembler, "complete_links", complete_counted)
        patch.setattr(Owner, "_linked_held_forces", forces_watched)
        patch.setattr(Owner, "_linked_held_stiffness_along", weight_watched)
        patch.setattr(Owner, "_held_dependent_motion", motion_watched)
        result = _run(GIMBAL)
    result.watched = watched
    return result


def test_the_held_angles_terms_are_exact_not_differenced(gimbal):
    """The held angle's terms come from the exact reduced K's column of θ_j, its move of K w and J's column of it
    (heldcol), no state along the angle made inside them (before, central differences: two reduced evaluations per
    held joint at every ∂r/∂p and every weighing, two completions at every row: 88 such completions in this run), and
    they agree with the tests' central differences along θ_j (step 1e-5 rad) of the reduced residual, of K w and of
    the dependent positions: measured 6.5e-11, 1.4e-10 and 2.6e-11 of the largest entry, the differences' truncation.
    Fails on the base (the completions along the angle counted)."""
    watched = gimbal.watched
    assert len(watched["forces"]) == 2 and len(watched["motion"]) == 2 and len(watched["weight"]) >= 1
    assert watched["moved"] == 0, watched["moved"]
    for exact, differenced in watched["forces"] + watched["weight"] + watched["motion"]:
        scale = np.abs(differenced).max()
        assert scale > 0.0
        assert np.abs(exact - differenced).max() <= 1e-8 * scale, np.abs(exact - differenced).max() / scale


def test_the_inner_ring_sticks_and_slips(gimbal):
    """Stuck from t = 0 (its rate 0), slipping from t ≈ 0.11, stuck again from t ≈ 0.14, slipping again from
    t ≈ 0.22: the runs below hold the sticks, the releases and the steps while stuck."""
    rate = gimbal.probes["r2"]
    stuck = rate == 0.0
    assert stuck[0] and not stuck.all()
    changes = int(np.count_nonzero(stuck[1:] != stuck[:-1]))
    assert changes >= 3, changes


@pytest.mark.parametrize("name", ["Fc", "k", "m", "EI"])
def test_the_gimbal_sticking_by_friction_agrees_with_richardson_central_differences(gimbal, name):
    """Each probe's sensitivity over the rows against Richardson-extrapolated central differences of whole runs
    (h = 1e-3 p and h/2, the step fixed), relative to the probe's largest: measured ≤ 1.4e-8 (Fc), 2.9e-8 (k),
    4.4e-8 (m), 1.5e-8 (EI) with the exact held terms (heldcol; 1.5e-8, 2.9e-8, 4.4e-8, 1.5e-8 with the central
    differences before); at h = 1e-4 p the reference's own noise (h against h/2) reached 3e-6 (m). The probes in a
    body's axes, the energies, momenta, bending moments and the outer hinge's torque refused before heldcol: ≤ 3.3e-8
    (vin, m); the stuck ring's own torque (its reaction, with the held angle's column since heldcol: 64 times its
    sensitivity off without) 1.1e-7 (Fc, EI), 6.6e-7 (m: 2.1e-7 at h = 3e-3 p, 3.4e-6 at 3e-4 p, the reference's
    noise)."""
    errors = _richardson_errors(GIMBAL, gimbal, name)
    for probe, error in errors.items():
        assert error <= 1e-6, (probe, name, error)


def test_the_discrete_adjoint_still_refuses_the_stick_on_rigid_links():
    """Guard: the adjoint does not transpose the held angle through the reduction; it refuses, naming the
    friction (exit 2 through the CLI)."""
    data = yaml.safe_load(GIMBAL)
    data["solve"]["sensitivity_method"] = "adjoint"
    with pytest.raises(SceneError, match=r"beams\.gim2\.start\.hinge\.friction.*guides or rigid links"):
        latdyn.run(latdyn.load_scene(data))


@pytest.mark.parametrize("probe, load", [
    ("ew: {energy: external_work}", "  - {at: inner, force: [0.1, 0, 0]}\n")])
def test_a_stick_on_rigid_links_beside_a_probe_not_checked_is_refused_naming_the_friction(probe, load):
    """Guard: the external work beside a load on a node that follows the links (its power's move with the held
    angle not carried) is refused beside a held angle on rigid links, naming the friction and the probe. (An
    element's axial force, refused here before workstick, is checked in
    :func:`test_the_external_work_through_sticks_on_rigid_links_agrees_with_richardson_central_differences`.)"""
    text = GIMBAL.replace("    t1: {hinge: gim1.start", f"    {probe}\n    t1: {{hinge: gim1.start").replace(
        "loads:\n", "loads:\n" + load)
    assert probe in text and load in text
    with pytest.raises(SceneError, match=r"beams\.gim2\.start\.hinge\.friction.*probe '" + probe[:2] + "'"):
        _run(text)


def test_a_stick_on_rigid_links_beside_a_latch_is_refused_naming_the_friction():
    """Guard: beside a latch, a rigid stop or a cable (not differentiated with the held angle through the
    reduction) the stick is refused, naming the friction."""
    text = GIMBAL.replace("stiffness: 6.0, damping: 0.02}", "stiffness: 6.0, damping: 0.02, lock_at: 0.5}")
    assert "lock_at: 0.5" in text
    with pytest.raises(SceneError, match=r"beams\.gim2\.start\.hinge\.friction.*beside latches, rigid stops"):
        _run(text)


#: the gimbal with the inner ring's hinge frictionless and the friction on a hinge at the flexible boom's end (a
#: free node's hinge in a model with rigid links: nothing hangs from it), stuck from t = 0, slipping, stuck at
#: t = 0.11 and slipping on
FLEXIBLE_END = GIMBAL.replace("""stiffness: "k", torque: "tau*sin(15*t)",
                         friction: {coulomb: "Fc", stick_rate: 0.02}}}}""", """stiffness: "k", damping: 0.01}}}""").replace(
    "boom: {from: inner, to: tip, section: boom, elements: 2}",
    """boom: {from: inner, to: tip, section: boom, elements: 2,
         end: {hinge: {axis: [0.3, 1.0, -0.2], stiffness: 0.5, torque: "0.6*tau*sin(15*t)",
                       friction: {coulomb: "0.2*Fc", stick_rate: 0.02}}}}""").replace(
    "r2: {hinge: gim2.start", "r2: {hinge: boom.end").replace("a2: {hinge: gim2.start", "a2: {hinge: boom.end").replace(
    "sensitivities: [Fc, k, m, EI]", "sensitivities: [Fc, EI]")
assert "boom.end" in FLEXIBLE_END and "0.2*Fc" in FLEXIBLE_END and "sensitivities: [Fc, EI]" in FLEXIBLE_END


@pytest.fixture(scope="module")
def flexible_end():
    return _run(FLEXIBLE_END)


@pytest.mark.parametrize("name", ["Fc", "EI"])
def test_a_flexible_nodes_hinge_sticking_beside_rigid_links_agrees_with_richardson_central_differences(
        flexible_end, name):
    """The same path for a hinge on a free node (Pᵀ K_all's column alone would do there: nothing hangs from it):
    measured ≤ 3.0e-7 (Fc; the differences' truncation h against h/2 1e-4, which Richardson removes), 1.3e-7 (EI),
    the exact column (heldcol) and the central difference before alike: Newton's tolerance, 1.7e-9 (EI) at
    ``tol: 1e-12``, Fc 2.6e-8 there at h = 3e-4 p."""
    rate = flexible_end.probes["r2"]
    assert rate[0] == 0.0 and np.count_nonzero(rate[1:] == 0.0) >= 1 and np.count_nonzero(rate) > 10
    errors = _richardson_errors(FLEXIBLE_END, flexible_end, name)
    for probe, error in errors.items():
        assert error <= 1e-6, (probe, name, error)


#: the gimbal with the outer ring's hinge against friction too: held from t = 0 beside the inner one (both held at
#: once on the first rows), then slipping
TWO_HELD = GIMBAL.replace("stiffness: 6.0, damping: 0.02}",
                          'stiffness: 6.0, damping: 0.02, friction: {coulomb: "0.6*Fc", stick_rate: 0.02}}').replace(
    "    t1: {hinge: gim1.start, quantity: torque}\n", "    r1: {hinge: gim1.start, quantity: rate}\n")
assert "0.6*Fc" in TWO_HELD and "r1: {hinge: gim1.start" in TWO_HELD


def test_two_rings_held_at_once_agree_with_richardson_central_differences():
    """Both rings' hinges held at once (each held angle's column, its move of K w and of the dependent nodes, summed
    over the held joints): the probes by Fc against Richardson differences as above, measured ≤ 1.1e-7 (t2, the inner
    ring's reaction), the others ≤ 4.0e-8 (vin); by k 2.1e-7 (tip_z), as with the central differences before heldcol
    (the probes then allowed)."""
    result = _run(TWO_HELD)
    both = (result.probes["r1"] == 0.0) & (result.probes["r2"] == 0.0)
    assert both[0] and np.count_nonzero(both) >= 2 and not both.all()
    errors = _richardson_errors(TWO_HELD, result, "Fc")
    for probe, error in errors.items():
        assert error <= 1e-6, (probe, error)


#: the gimbal with its external work and the boom's axial force and torque recorded, at Newton's tolerance 1e-12 (at
#: the default the reference's own noise, 6.7e-6 of the work's largest by EI, hides the derivative's agreement), the
#: boom's EA 1e3 (at 1e5 its axial force's central differences are the roundoff of a stretch 100 times smaller: 2.0e-6,
#: 6.2e-6, 2.0e-5 of its largest off at h = 1e-3, 3e-4, 1e-4 p, growing as 1/h)
EXTERNAL_WORK = GIMBAL.replace(
    "    t1: {hinge: gim1.start", "    ew: {energy: external_work}\n"
    "    nx: {element: \"boom.element[1]\", quantity: axial_force}\n"
    "    tx: {element: \"boom.element[1]\", quantity: torque}\n    t1: {hinge: gim1.start").replace(
    "solve: {analysis: transient,", "solve: {analysis: transient, tol: 1.0e-12,").replace(
    "boom: {EA: 1.0e5,", "boom: {EA: 1.0e3,")
assert "quantity: axial_force" in EXTERNAL_WORK and "tol: 1.0e-12" in EXTERNAL_WORK and "EA: 1.0e3" in EXTERNAL_WORK


def test_the_external_work_through_sticks_on_rigid_links_agrees_with_richardson_central_differences():
    """The external work beside the inner ring's sticks (refused before heldcol): at a stick or a release the loop
    evaluates the step's end again after the jump (the coordinates renumbered), as after a latch, and the work's
    derivative takes the same correction (latdyn/analyses/energy_sensitivities.py ``external_work_after_event``);
    without it the work by Fc was 3.6e-3 of itself off from the second stick on. The boom's axial force and torque
    too (refused before workstick). Measured (boom's EA 1e3, by Fc): work 7.3e-10, axial force
    7.2e-9, torque 1.3e-9, the other probes ≤ 5.2e-9 (my); by EI (not run here) 5.4e-10, 3.2e-9, 9.1e-10, ≤ 5.6e-9 (t2)."""
    result = _run(EXTERNAL_WORK)
    errors = _richardson_errors(EXTERNAL_WORK, result, "Fc")
    for probe, error in errors.items():
        assert error <= {"ew": 1e-8, "nx": 1e-7, "tx": 1e-7}.get(probe, 1e-6), (probe, error)


#: the gimbal under gravity [0, 0, -1] with its potential energy recorded, at Newton's tolerance 1e-12: the inner ring
#: stuck from t = 0, released at 0.08, stuck again at 0.10, released at 0.15, stuck again at 0.16
UNDER_GRAVITY = GIMBAL.replace("sections:", "gravity: [0, 0, -1.0]\nsections:").replace(
    "    t1: {hinge: gim1.start", "    pe: {energy: potential}\n    t1: {hinge: gim1.start").replace(
    "solve: {analysis: transient,", "solve: {analysis: transient, tol: 1.0e-12,").replace(
    "sensitivities: [Fc, k, m, EI]", "sensitivities: [Fc]")
assert "pe: {energy: potential}" in UNDER_GRAVITY and "sensitivities: [Fc]" in UNDER_GRAVITY


def test_the_potential_energy_beside_sticks_on_rigid_links_agrees_with_richardson_central_differences():
    """The potential energy beside the inner ring's sticks under gravity (refused before workstick: its forms of the
    held angle are those of the other energies, the stuck joint's slot included). Measured 1.8e-9 (Fc; by m, EI, k,
    not run here: 4.5e-12, 9.2e-10, 1.3e-8), the other probes <= 6.7e-8 (t2)."""
    result = _run(UNDER_GRAVITY)
    assert list(np.flatnonzero(result.probes["r2"] == 0.0)) == [0, 1, 2, 3, 4, 5, 6, 7, 10, 11, 12, 13, 14, 16, 17,
                                                                  18, 19, 20]
    errors = _richardson_errors(UNDER_GRAVITY, result, "Fc")
    for probe, error in errors.items():
        assert error <= (1e-8 if probe == "pe" else 1e-6), (probe, error)
