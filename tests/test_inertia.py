"""Directions without inertia, in genuinely 3D scenes under random rigid motions.

Euler–Bernoulli beams without rotary inertia and massless joints are the common
case: each nodal twist, and the spin of a massless joint about its hinge, has no
inertia.  A scene rotated and translated as a whole must give the same answer in
its own frames (to 1e-8 relative) with the same step and iteration counts, for
every method; modes of a truss of massless joints must equal those of the same
truss with a negligible rotary inertia.
"""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import latdyn
from latdyn.numerics.so3 import expm_so3
from latdyn.numerics.inertia import MASSLESS_TOL, joint_blocks, joint_groups, split_inertia
from latdyn.assembly.prepare import prepare

SPIN_UP = "Piecewise((6/15*(t**2/2 + (15/(2*pi))**2*(cos(2*pi*t/15) - 1)), t < 15), (6*(t - 7.5), True))"


def rigid_motion(seed: int):
    """A random rotation (not about a coordinate axis) and translation."""
    rng = np.random.default_rng(seed)
    return Rotation.random(random_state=rng).as_matrix(), rng.uniform(-5.0, 5.0, 3)


def _movers(R, shift):
    point = lambda p: (R @ np.asarray(p, float) + shift).tolist()  # noqa: E731
    vector = lambda v: (R @ np.asarray(v, float)).tolist()  # noqa: E731
    return point, vector


def _section(rotary: float, **properties) -> dict:
    """A section, with rotary inertia per length rhoIy = rhoIz = ``rotary`` when it is not 0."""
    return {**properties, **({"rhoIy": rotary, "rhoIz": rotary} if rotary else {})}


def _xyz_probes(point, quantity="position", frame=None, prefix="p"):
    probes = {}
    for c in "xyz":
        probe = {"point": point, "quantity": quantity, "component": c}
        if frame:
            probe["frame"] = frame
        probes[f"{prefix}_{c}"] = probe
    return probes


def tilted_spin(R=np.eye(3), shift=np.zeros(3), t_end=0.6, dt=0.005, rotary=0.0, **solve):
    """The spin-up beam (Kane, Ryan & Banerjee) driven about a hub axis, no rotary inertia unless asked."""
    P, V = _movers(R, shift)
    return {
        "sections": {"arm": _section(rotary, EA=2.8e7, EIy=1.4e4, EIz=2.1e4, GJ=1.0e4, rhoA=1.2)},
        "bodies": {"hub": {"at": P([0, 0, 0]), "motion": {"rotation": {"axis": V([0, 0.3, 1]), "angle": SPIN_UP}}}},
        "beams": {"arm": {"from": "hub", "to": P([10, 0, 0]), "section": "arm", "elements": 4,
                          "y_axis": V([0, 1, 0])}},
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, **solve},
        "output": {"probes": {**_xyz_probes("arm.end", frame="hub", prefix="tip"),
                              **_xyz_probes("arm.node[2]", quantity="velocity", prefix="mid_v"),
                              "kinetic": {"energy": "kinetic"}, "strain": {"energy": "strain"}}},
    }


def free_l_frame(R=np.eye(3), shift=np.zeros(3), t_end=0.3, dt=0.005, rotary=0.0, **solve):
    """A free L-frame tumbling in space: beams without rotary inertia (unless asked), a point mass at one tip."""
    P, V = _movers(R, shift)
    return {
        "sections": {"s": _section(rotary, EA=1e5, EIy=40.0, EIz=60.0, GJ=30.0, rhoA=0.5)},
        "initial_velocity": {"linear": V([0.2, 0.0, 0.1]), "angular": V([0.3, 1.1, 2.0]), "about": P([0, 0, 0])},
        "bodies": {"corner": {"at": P([0, 0, 0]), "mass": 2.0,
                              "inertia": (R @ np.diag([0.1, 0.2, 0.3]) @ R.T).tolist()},
                   "tip": {"at": P([0, 1.5, 0]), "mass": 0.3}},
        "beams": {"a": {"from": "corner", "to": P([2, 0, 0]), "section": "s", "elements": 3, "y_axis": V([0, 1, 0])},
                  "b": {"from": "corner", "to": "tip", "section": "s", "elements": 3, "y_axis": V([0, 0, 1])}},
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, **solve},
        "output": {"probes": {**_xyz_probes("a.end", frame="corner", prefix="a_end"),
                              **_xyz_probes("tip", frame="corner", prefix="tip"),
                              "kinetic": {"energy": "kinetic"}, "strain": {"energy": "strain"}}},
    }


def hinged_chain(R=np.eye(3), shift=np.zeros(3), t_end=0.4, dt=0.005, rotary=0.0, **solve):
    """Three links on massless joint bodies, hinges about skew axes, gravity: a 3D pendulum chain."""
    P, V = _movers(R, shift)
    hinge = lambda axis: {"hinge": {"axis": V(axis)}}  # noqa: E731
    return {
        "gravity": V([0, 0, -9.81]),
        "sections": {"s": _section(rotary, EA=2e6, EIy=300.0, EIz=500.0, GJ=200.0, rhoA=1.5)},
        "bodies": {"base": {"at": P([0, 0, 0]), "fixed": True},
                   "j1": {"at": P([1, 0, 0])},
                   "j2": {"at": P([1.8, 0.6, 0])}},
        "beams": {"l1": {"from": "base", "to": "j1", "section": "s", "elements": 2, "start": hinge([0, 1, 0.2]),
                         "y_axis": V([0, 1, 0])},
                  "l2": {"from": "j1", "to": "j2", "section": "s", "elements": 2, "start": hinge([0.3, 0.2, 1]),
                         "y_axis": V([0, 0, 1])},
                  "l3": {"from": "j2", "to": P([2.4, 1.4, 0.3]), "section": "s", "elements": 2,
                         "start": hinge([1, 0, 0.4]), "y_axis": V([0, 0, 1])}},
        "solve": {"analysis": "transient", "t_end": t_end, "dt": dt, **solve},
        "output": {"probes": {**_xyz_probes("l3.end", prefix="tip"),
                              "h1": {"hinge": "l1.start", "quantity": "angle"},
                              "h2": {"hinge": "l2.start", "quantity": "angle"},
                              "h3": {"hinge": "l3.start", "quantity": "rate"},
                              "kinetic": {"energy": "kinetic"}}},
    }


def _vectors(result, prefix):
    return np.stack([result.probes[f"{prefix}_{c}"] for c in "xyz"], axis=1)


def _compare(plain, moved, R, shift, vectors=(), points_global=(), scalars=()):
    """Probes of the moved scene, mapped back, against the plain scene: the largest relative difference."""
    worst = 0.0
    for prefix in vectors:
        ref = _vectors(plain, prefix) @ R.T  # body-frame and velocity components rotate with the scene
        worst = max(worst, np.abs(_vectors(moved, prefix) - ref).max() / np.abs(ref).max())
    for prefix in points_global:
        ref = _vectors(plain, prefix) @ R.T + shift
        worst = max(worst, np.abs(_vectors(moved, prefix) - ref).max() / np.abs(ref).max())
    for name in scalars:
        ref = plain.probes[name]
        worst = max(worst, np.abs(moved.probes[name] - ref).max() / max(np.abs(ref).max(), 1e-300))
    return worst


COUNTS = ("steps", "newton_iterations", "rejected_steps")

CASES = {
    "tilted_spin": (tilted_spin, dict(vectors=("tip", "mid_v"), scalars=("kinetic", "strain"))),
    "free_l_frame": (free_l_frame, dict(vectors=("a_end", "tip"), scalars=("kinetic", "strain"))),
    "hinged_chain": (hinged_chain, dict(points_global=("tip",), scalars=("h1", "h2", "h3", "kinetic"))),
}

METHODS = {
    "generalized-alpha": {},
    "hht-alpha": {"method": "hht-alpha", "rho_inf": 0.7},
    "newmark": {"method": "newmark"},
    "adaptive": {"adaptive": True, "error_tol": 1e-5},
}


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method", sorted(METHODS))
def test_rigidly_moved_scene_without_rotary_inertia_gives_the_same_answer(case, method):
    build, compare = CASES[case]
    R, shift = rigid_motion(seed=sorted(CASES).index(case) * 10 + sorted(METHODS).index(method))
    plain = latdyn.run(build(**METHODS[method]))
    moved = latdyn.run(build(R, shift, **METHODS[method]))
    assert _compare(plain, moved, R, shift, **compare) < 1e-8
    assert {k: moved.summary[k] for k in COUNTS} == {k: plain.summary[k] for k in COUNTS}
    assert plain.summary["rejected_steps"] == 0 or method == "adaptive"


# The same scenes with rotary inertia (rhoIy = rhoIz = rhoA × (1 cm)²): every nodal twist then has
# inertia, and the answer must again be the same in the scene's own frames.
ROTARY = {"tilted_spin": 1.2e-4, "free_l_frame": 5e-5, "hinged_chain": 1.5e-4}
ROTARY_METHODS = ("generalized-alpha", "newmark")


@pytest.mark.parametrize("case", sorted(CASES))
@pytest.mark.parametrize("method", ROTARY_METHODS)
def test_rigidly_moved_scene_with_rotary_inertia_gives_the_same_answer(case, method):
    build, compare = CASES[case]
    R, shift = rigid_motion(seed=100 + sorted(CASES).index(case) * 10 + ROTARY_METHODS.index(method))
    rotary = ROTARY[case]
    prepared = prepare(build(R, shift, rotary=rotary))
    mass = prepared.assembler.evaluate(prepared.state, matrices=True).combined(1.0, 0.0, 0.0, dense=True)
    assert split_inertia(prepared.model, mass).n_massless == 0
    plain = latdyn.run(build(rotary=rotary, **METHODS[method]))
    moved = latdyn.run(build(R, shift, rotary=rotary, **METHODS[method]))
    assert _compare(plain, moved, R, shift, **compare) < 1e-8
    assert {k: moved.summary[k] for k in COUNTS} == {k: plain.summary[k] for k in COUNTS}
    assert plain.summary["rejected_steps"] == 0


# The explicit step on the same scenes.  Steps below the stability limits 2/ω_max of the condensed
# models at t = 0 (8.7e-4 s for the L-frame, 2.6e-4 s for the chain); before the light directions
# were condensed (latdyn.numerics.inertia), the L-frame blew up at t ≈ 0.0126 s whatever the step.
EXPLICIT = {"free_l_frame": dict(dt=2e-4, t_end=0.05), "hinged_chain": dict(dt=1e-4, t_end=0.05)}
# Largest tip difference, explicit against Newmark at the same step (both second order).  Against
# Newmark at 1e-5 s over 0.1 s, the tip errors explicit / Newmark were 8.7e-7 / 1.9e-6 m at h = 4e-4 s,
# 2.3e-7 / 4.7e-7 at 2e-4, 5.9e-8 / 1.2e-7 at 1e-4 for the L-frame (÷3.8–4 per halving), and
# 7.1e-7 / 1.1e-6 at 2e-4, 2.8e-7 / 4.8e-7 at 1e-4 for the chain.  Over these spans the differences are
# 4.8e-7 m (L-frame) and 3.3e-7 m (chain); the tolerances are 3× those.  Before the fix the explicit
# run of the L-frame failed (SolverError) at t ≈ 0.0126 s.
EXPLICIT_TOL = {"free_l_frame": 1.5e-6, "hinged_chain": 1.0e-6}


@pytest.mark.parametrize("case", sorted(EXPLICIT))
def test_explicit_method_is_invariant_and_agrees_with_the_implicit_method(case):
    build, compare = CASES[case]
    R, shift = rigid_motion(seed=77)
    span = EXPLICIT[case]
    plain = latdyn.run(build(method="explicit", **span))
    moved = latdyn.run(build(R, shift, method="explicit", **span))
    assert _compare(plain, moved, R, shift, **compare) < 1e-8
    steps = round(span["t_end"] / span["dt"])
    assert moved.summary["steps"] == plain.summary["steps"] == steps
    assert plain.summary["rejected_steps"] == moved.summary["rejected_steps"] == 0
    implicit = latdyn.run(build(method="newmark", **span))
    difference = np.abs(_vectors(plain, "tip") - _vectors(implicit, "tip")).max()
    assert difference < EXPLICIT_TOL[case]


def test_explicit_method_is_second_order_without_rotary_inertia():
    """Self-convergence on the L-frame: successive differences of the tip fall ×4 per halving of h.

    Measured over 0.1 s: 6.17e-7 m (h = 4e-4 → 2e-4 s) and 1.59e-7 m (2e-4 → 1e-4 s), ratio 3.88.
    Velocity forces evaluated at v_{n+½} instead of the predictor of v_{n+1} (an O(h) error in the
    accelerations) gave 6.08e-7 and 2.07e-7, ratio 2.93; an O(1) error does not converge at all.
    """
    tips = []
    for dt in (4e-4, 2e-4, 1e-4):
        scene = free_l_frame(method="explicit", dt=dt, t_end=0.1)
        scene["output"]["every"] = 0.002
        result = latdyn.run(scene)
        assert result.summary["rejected_steps"] == 0
        tips.append(_vectors(result, "tip"))
    coarse, fine = np.abs(tips[0] - tips[1]).max(), np.abs(tips[1] - tips[2]).max()
    assert coarse / fine > 3.4


def test_twist_of_a_bent_element_is_light_and_the_explicit_split_condenses_it():
    """The cause of the explicit blow-up: CR-4402's deflections use the chord's components in the
    nodal frame (Eqs. 14–15), which turn with the node's twist, so a bent element gives the twist an
    inertia ~ φ².  Past MASSLESS_TOL it counted as massive, with a frequency no explicit step resolves.
    The light twist is at the bent node with node 1's corotational frame (`cr4402`) and at its neighbour
    with the mean frame (`default`): twisting the bent node turns both its elements' frames by half and
    their effects cancel; twisting the neighbour turns the second element's frame alone."""
    prepared = prepare(free_l_frame())
    model, assembler = prepared.model, prepared.assembler
    node = int(model.beam_nodes["a"][1])
    groups = []
    for interior in model.beam_nodes["a"][1:-1]:
        dofs = set(model.node_dofs[int(interior)].tolist())
        groups.append(next(i for i, g in enumerate(joint_groups(model)) if dofs & set(g.tolist())))
    relative = []
    for phi in (0.0, 1e-3, 2e-3, 1e-2):
        state = prepared.state.copy()
        state.T[node] = expm_so3(np.array([0.0, 0.0, phi])) @ state.T[node]  # bend beam a at its node 1
        ev = assembler.evaluate(state, matrices=True)
        M, K = ev.combined(1.0, 0.0, 0.0, dense=True), ev.combined(0.0, 0.0, 1.0, dense=True)
        joint = joint_blocks(model, M)
        ratios = []
        for group in groups:  # the interior nodes of beam a: the lightest direction of each, relative
            root = 1.0 / np.sqrt(joint.scale[group])
            eigenvalues = np.linalg.eigvalsh(joint.blocks[group] * root[:, None] * root[None, :])
            ratios.append(eigenvalues[0] / eigenvalues[-1])
        relative.append(max(ratios))
        exact, explicit = split_inertia(model, M), split_inertia(model, M, stiffness=K, step=2e-4)
        assert explicit.n_massless == 6  # 4 interior twists, the two free ends' twists
        assert explicit.n_light == (0 if phi == 0 else 1)
        assert exact.n_massless == (6 if phi == 0 else 5)
    assert relative[0] < 1e-15
    np.testing.assert_allclose(relative[2] / relative[1], 4.0, rtol=1e-3)  # ∝ φ²
    assert relative[3] > 1e3 * MASSLESS_TOL


def test_twist_and_massless_hinge_spin_found_in_any_frame():
    """Each beam node's twist (about the current tangent) and nothing else has no inertia."""
    for seed in range(3):
        R, shift = rigid_motion(seed)
        prepared = prepare(hinged_chain(R, shift))
        model = prepared.model
        ev = prepared.assembler.evaluate(prepared.state, matrices=True)
        M = ev.combined(1.0, 0.0, 0.0, dense=True)
        split = split_inertia(model, M)
        Qc, Qm = split.massless, split.massive
        # the twists of the 3 interior nodes and of l3's free end; at j1 and j2 a clamped link end
        # and a hinged one with skew axes leave no direction without inertia
        assert split.n_massless == 3 + 1
        assert np.abs(M @ Qc).max() < 1e-12 * np.abs(M).max()
        assert np.linalg.eigvalsh(Qm.T @ M @ Qm).min() > 0
        assert np.linalg.matrix_rank(np.hstack([Qm, Qc])) == model.n_dofs
        # j1 (+ hinge of l2), j2 (+ hinge of l3), 3 interior nodes, l3's end, l1's hinge on the fixed base
        assert joint_groups(model).shape[0] == 7


def truss(rotary: float, bays: int = 4):
    """A 3D truss tower of massless joints (no rotary inertia unless asked), clamped at the base."""
    section = {"EA": 5e6, "EIy": 80.0, "EIz": 80.0, "GJ": 60.0, "rhoA": 0.8}
    if rotary:
        section.update(rhoIy=rotary, rhoIz=rotary)
    corners = [(0, 0), (1, 0), (0.5, 0.85)]
    bodies, beams = {}, {}
    for level in range(bays + 1):
        for k, (x, y) in enumerate(corners):
            bodies[f"n{level}_{k}"] = {"at": [x, y, 1.2 * level], **({"fixed": True} if level == 0 else {})}
    for level in range(bays + 1):
        for k in range(3):
            a, b = f"n{level}_{k}", f"n{level}_{(k + 1) % 3}"
            if level:
                beams[f"ring{level}_{k}"] = {"from": a, "to": b, "section": "s"}
                beams[f"leg{level}_{k}"] = {"from": f"n{level - 1}_{k}", "to": a, "section": "s"}
                beams[f"brace{level}_{k}"] = {"from": f"n{level - 1}_{k}", "to": b, "section": "s"}
    return {"sections": {"s": section}, "bodies": bodies, "beams": beams,
            "solve": {"analysis": "modes", "count": 8}}


def planar_truss(rotary: float, bays: int = 10):
    """Issue 7's case: a planar Pratt truss of massless joints on two clamped supports, two
    elements per member, beams without rotary inertia unless asked (it moves in 3D)."""
    section = {"EA": 5e6, "EIy": 80.0, "EIz": 80.0, "GJ": 60.0, "rhoA": 0.8}
    if rotary:
        section.update(rhoIy=rotary, rhoIz=rotary)
    bodies, beams = {}, {}
    for i in range(bays + 1):
        bodies[f"b{i}"] = {"at": [1.0 * i, 0.0, 0.0], **({"fixed": True} if i in (0, bays) else {})}
        bodies[f"t{i}"] = {"at": [1.0 * i, 1.0, 0.0]}
        beams[f"vertical{i}"] = {"from": f"b{i}", "to": f"t{i}", "section": "s", "elements": 2}
    for i in range(bays):
        beams[f"bottom{i}"] = {"from": f"b{i}", "to": f"b{i + 1}", "section": "s", "elements": 2}
        beams[f"top{i}"] = {"from": f"t{i}", "to": f"t{i + 1}", "section": "s", "elements": 2}
        # diagonals falling towards mid-span
        a, b = (f"b{i}", f"t{i + 1}") if i < bays // 2 else (f"t{i}", f"b{i + 1}")
        beams[f"diagonal{i}"] = {"from": a, "to": b, "section": "s", "elements": 2}
    return {"sections": {"s": section}, "bodies": bodies, "beams": beams,
            "solve": {"analysis": "modes", "count": 10}}


def test_modes_of_a_truss_of_massless_joints_match_negligible_rotary_inertia():
    exact = latdyn.run(truss(rotary=0.0)).modes
    negligible = latdyn.run(truss(rotary=1e-9)).modes
    assert len(exact) == 8 and np.all(exact > 0)
    np.testing.assert_allclose(exact, negligible, rtol=1e-6)


def test_modes_of_the_planar_truss_of_massless_joints_are_the_limit_of_vanishing_rotary_inertia():
    """Issue 7's crash (`eigh`: M not positive definite): 10 bays, 366 coordinates, 41 twists without inertia.

    The frequencies with rotary inertia ρI differ from the exact ones by 5.72·ρI relative (largest over the
    ten modes; linear: 5.720e-5, 5.720e-6, 5.721e-7 at ρI = 1e-5, 1e-6, 1e-7).  Below that the tiny
    inertia makes the generalized eigenproblem ill-conditioned: at ρI = 1e-9 the difference was 2.6e-7
    in one run and 1.4e-6 in another (round-off, of either sign over the modes), at 1e-10 1.2e-5.  The
    exact condensation is the accurate limit; the comparison at 1e-9 can only be as tight as its round-off.
    """
    exact = latdyn.run(planar_truss(rotary=0.0)).modes
    assert len(exact) == 10 and np.all(exact > 0)
    np.testing.assert_allclose(exact, latdyn.run(planar_truss(rotary=1e-9)).modes, rtol=1e-5)
    # the exact model is the limit ρI → 0: the difference falls linearly (round-off at 1e-6 is ~1e-9)
    coarse, fine = (np.abs(latdyn.run(planar_truss(rotary=r)).modes / exact - 1).max() for r in (1e-5, 1e-6))
    assert 5e-5 < coarse < 6e-5
    np.testing.assert_allclose(coarse / fine, 10.0, rtol=1e-2)
