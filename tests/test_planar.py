"""The planar model (``solve.planar``): generated planar kernels and in-plane coordinates.

Kernels: at a configuration of a coordinate plane, the planar variant's in-plane rows and
columns equal the 3D element's (codegen/formulation.py ``Plane``), its out-of-plane ones are
zero, and its derivatives agree with finite differences along the in-plane coordinates.
Runtime: a scene that stays in a plane gives the same answer with ``planar: auto`` as with
``planar: off``, in all three coordinate planes, with its out-of-plane coordinates removed.
"""
from __future__ import annotations

import contextlib

from dataclasses import replace

import numpy as np
import pytest

import element_states as es
from reference_step import reference_engine
from latdyn.model.kernels import PLANE_SUFFIXES, known_variants, load_kernels, planar_variant

FORMULATIONS = ("default", "cr4402", "no_stiffening")
H = 1e-6


def in_plane_coordinates(normal: int) -> np.ndarray:
    """Indices of q^e that stay in the plane: d_i, d_j, π_n, θ per end."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    return np.array([base + k for base in (0, 7) for k in (i, j, 3 + normal, 6)])


def planar_state(rng, normal: int, deformation: float = 0.3, hinges=(True, True)):
    """A random element state in the plane x_normal = c: bodies turned about n, in-plane offsets,
    hinge axes ±n (or none), nodal frames with local z = +n, local rotations ≈ ``deformation`` rad."""
    i, j = (normal + 1) % 3, (normal + 2) % 3
    n = np.zeros(3)
    n[normal] = 1.0

    def in_plane(vector2):
        v = np.zeros(3)
        v[i], v[j] = vector2
        return v

    level = rng.normal()
    alpha = rng.uniform(-np.pi, np.pi)
    direction = in_plane((np.cos(alpha), np.sin(alpha)))
    frame0 = np.column_stack([direction, np.cross(n, direction), n])
    length = 1.3
    g1 = in_plane(rng.normal(size=2)) + level * n
    g2 = g1 + length * direction + in_plane(rng.normal(size=2)) * 0.1 * deformation
    ends = []
    for g, hinge in zip((g1, g2), hinges):
        turn = rng.uniform(-np.pi, np.pi)
        body = es.expm_so3(turn * n)
        offset = in_plane(rng.normal(size=2) * 0.3)  # body axes: turning about n keeps it in the plane
        axis = n * rng.choice([-1.0, 1.0]) if hinge else np.zeros(3)
        theta = rng.normal() * 0.7 if hinge else 0.0
        # the nodal frame body·R(a, θ)·E0 = frame0 turned by a small local rotation
        local = rng.normal() * deformation
        E0 = es.expm_so3(-axis * theta) @ body.T @ es.expm_so3(local * n) @ frame0
        ends.append(es.End(g - body @ offset, body, offset, axis, E0, theta))
    section = np.array([length, 3.0e3, 20.0, 30.0, 15.0, 1.3, 0.02, 0.03, *es.SHEAR_COMPLIANCES])
    return es.ElementState(ends[0], ends[1], section)


def planar_velocity(rng, normal):
    qdot = np.zeros(14)
    qdot[in_plane_coordinates(normal)] = rng.normal(size=8)
    return qdot


CASES = [(f, normal) for f in FORMULATIONS for normal in PLANE_SUFFIXES]


def test_every_formulation_has_planar_variants():
    variants = known_variants()
    for formulation, normal in CASES:
        assert planar_variant(formulation, normal) in variants


@pytest.fixture(scope="module", params=CASES, ids=[f"{f}_{PLANE_SUFFIXES[n]}" for f, n in CASES])
def pair(request):
    formulation, normal = request.param
    return normal, load_kernels("numpy", formulation), load_kernels("numpy", planar_variant(formulation, normal))


def test_planar_kernels_equal_the_3d_element_in_the_plane(pair):
    normal, full, planar = pair
    rng = np.random.default_rng(normal)
    keep = in_plane_coordinates(normal)
    out = np.setdiff1d(np.arange(14), keep)
    for hinges in ((True, True), (False, True), (False, False)):
        s = planar_state(rng, normal, hinges=hinges)
        geometry, section = s.geometry(), s.section[None]
        qdot = planar_velocity(rng, normal)[None]
        acceleration = planar_velocity(rng, normal)[None]
        gravity = np.zeros((1, 3))
        gravity[0, (normal + 1) % 3], gravity[0, (normal + 2) % 3] = rng.normal(size=2)
        pairs = [
            (full.beam_deformation(geometry, section), planar.beam_deformation(geometry, section), None),
            (full.beam_strain_energy(geometry, section), planar.beam_strain_energy(geometry, section), None),
            (full.beam_internal_force_D_q(geometry, section), planar.beam_internal_force_D_q(geometry, section),
             "vector-matrix"),
            (full.beam_mass_matrix(geometry, section), planar.beam_mass_matrix(geometry, section), "matrix"),
            (full.beam_quadratic_velocity(geometry, qdot, section),
             planar.beam_quadratic_velocity(geometry, qdot, section), "vector"),
            (full.beam_quadratic_velocity_D_qdot(geometry, qdot, section),
             planar.beam_quadratic_velocity_D_qdot(geometry, qdot, section), "vector-matrix"),
            (full.beam_kinetic_energy(geometry, qdot, section), planar.beam_kinetic_energy(geometry, qdot, section),
             None),
            (full.beam_gravity(geometry, section, gravity), planar.beam_gravity(geometry, section, gravity),
             "vector"),
            (full.beam_inertia_tangent(geometry, qdot, acceleration, section, gravity),
             planar.beam_inertia_tangent(geometry, qdot, acceleration, section, gravity), "vector-matrix"),
        ]
        for expected_outputs, actual_outputs, kind in pairs:
            for k, (expected, actual) in enumerate(zip(expected_outputs, actual_outputs)):
                expected, actual = expected[0], actual[0]
                shape = "matrix" if (kind == "matrix" or (kind == "vector-matrix" and k == 1)) else (
                    "vector" if kind else None)
                scale = max(np.abs(expected).max(), 1e-300)
                if shape == "matrix":
                    np.testing.assert_allclose(actual[np.ix_(keep, keep)], expected[np.ix_(keep, keep)],
                                               rtol=0, atol=1e-11 * scale)
                    assert not np.any(actual[out, :]) and not np.any(actual[:, out])
                elif shape == "vector" and expected.shape == (14,):
                    np.testing.assert_allclose(actual[keep], expected[keep], rtol=0, atol=1e-11 * scale)
                    assert not np.any(actual[out])
                else:
                    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-11 * scale)


def test_planar_derivatives_against_finite_differences(pair):
    """F = ∂U/∂q, ∂F/∂q and ∂g/∂q̇ along the in-plane coordinates (the planar kernels are derived
    with the out-of-plane values put in before differentiation)."""
    normal, _, planar = pair
    rng = np.random.default_rng(10 + normal)
    keep = in_plane_coordinates(normal)
    for _ in range(3):
        s = planar_state(rng, normal, deformation=0.5)
        section = s.section[None]

        def moved(k, h):
            dq = np.zeros(14)
            dq[k] = h
            return s.moved(dq).geometry()

        energy = lambda g: planar.beam_strain_energy(g, section)[0][0]  # noqa: E731
        force, tangent = (x[0] for x in planar.beam_internal_force_D_q(s.geometry(), section))
        numeric_force = np.array([(energy(moved(k, H)) - energy(moved(k, -H))) / (2 * H) for k in keep])
        np.testing.assert_allclose(force[keep], numeric_force, rtol=0, atol=1e-6 * np.abs(force).max())
        internal = lambda g: planar.beam_internal_force(g, section)[0][0]  # noqa: E731
        numeric_tangent = np.column_stack([(internal(moved(k, H)) - internal(moved(k, -H))) / (2 * H)
                                           for k in keep])
        np.testing.assert_allclose(tangent[:, keep], numeric_tangent, rtol=0, atol=1e-6 * np.abs(tangent).max())
        qdot = planar_velocity(rng, normal)
        g = lambda v: planar.beam_quadratic_velocity(s.geometry(), v[None], section)[0][0]  # noqa: E731
        (_, exact) = planar.beam_quadratic_velocity_D_qdot(s.geometry(), qdot[None], section)
        unit = np.eye(14)
        numeric = np.column_stack([(g(qdot + H * unit[k]) - g(qdot - H * unit[k])) / (2 * H) for k in keep])
        np.testing.assert_allclose(exact[0][:, keep], numeric, rtol=0, atol=1e-6 * np.abs(exact).max())
        # the inertia tangent ∂(M a + g − Q)/∂q at fixed in-plane rates and accelerations
        acceleration = planar_velocity(rng, normal)
        gravity = np.zeros((1, 3))
        gravity[0, (normal + 1) % 3], gravity[0, (normal + 2) % 3] = rng.normal(size=2)
        inertia = lambda g: planar.beam_inertia_tangent(g, qdot[None], acceleration[None], section,  # noqa: E731
                                                        gravity)[0][0]
        (_, exact) = planar.beam_inertia_tangent(s.geometry(), qdot[None], acceleration[None], section, gravity)
        numeric = np.column_stack([(inertia(moved(k, H)) - inertia(moved(k, -H))) / (2 * H) for k in keep])
        np.testing.assert_allclose(exact[0][:, keep], numeric, rtol=0, atol=1e-6 * np.abs(exact).max())


def test_planar_gravity_tangent_against_finite_differences(pair):
    """∂Q/∂q of the planar gravity load (beam_gravity_D_q) along the in-plane coordinates, its load
    equal to beam_gravity's, and equal to the 3D element's tangent in the plane."""
    normal, full, planar = pair
    assert hasattr(planar, "beam_gravity_D_q") and hasattr(full, "beam_gravity_D_q"), \
        "every variant is generated with beam_gravity_D_q"
    rng = np.random.default_rng(20 + normal)
    keep = in_plane_coordinates(normal)
    for _ in range(3):
        s = planar_state(rng, normal, deformation=0.5)
        section = s.section[None]
        gravity = np.zeros((1, 3))
        gravity[0, (normal + 1) % 3], gravity[0, (normal + 2) % 3] = rng.normal(size=2)

        def moved(k, h):
            dq = np.zeros(14)
            dq[k] = h
            return s.moved(dq).geometry()

        load = lambda g: planar.beam_gravity(g, section, gravity)[0][0]  # noqa: E731
        force, tangent = (x[0] for x in planar.beam_gravity_D_q(s.geometry(), section, gravity))
        np.testing.assert_allclose(force, load(s.geometry()), rtol=0, atol=1e-12 * np.abs(force).max())
        numeric = np.column_stack([(load(moved(k, H)) - load(moved(k, -H))) / (2 * H) for k in keep])
        np.testing.assert_allclose(tangent[:, keep], numeric, rtol=0, atol=1e-6 * np.abs(tangent).max())
        in_3d = full.beam_gravity_D_q(s.geometry(), section, gravity)[1][0]
        np.testing.assert_allclose(tangent[np.ix_(keep, keep)], in_3d[np.ix_(keep, keep)], rtol=0,
                                   atol=1e-11 * np.abs(in_3d).max())


# ----------------------------------------------------------------------------- runtime
import copy  # noqa: E402

import latdyn  # noqa: E402
from latdyn.model.model import Model  # noqa: E402
from latdyn.scene.loader import load_scene  # noqa: E402

#: permutation taking the xy-plane scene below into the plane normal to axis n (a proper rotation)
PERMUTATIONS = {2: (0, 1, 2), 0: (1, 2, 0), 1: (2, 0, 1)}


def chain_scene(t_end=0.25, **solve):
    """A planar scene with everything that could leave the plane kept in it: a prescribed rotating
    base, hinges with spring (rest angle), damper and torque law, a joint body with mass, a centre
    of mass off its reference point and a product of inertia in the plane, gravity, a follower load
    with a moment, an initial velocity, and a beam whose section y axis is the plane's normal
    (turned a quarter in the planar model), with unequal section values and shear stiffnesses."""
    return {
        "title": "planar chain",
        "gravity": [0.5, -9.81, 0],
        "initial_velocity": {"linear": [0.1, -0.05, 0], "angular": [0, 0, 0.3]},
        "sections": {"a": {"EA": 2e4, "EIy": 40.0, "EIz": 25.0, "GJ": 10.0, "rhoA": 0.6,
                           "rhoIy": 2e-3, "rhoIz": 1e-3},
                     "b": {"EA": 1e4, "EIy": 6.0, "EIz": 9.0, "GJ": 4.0, "rhoA": 0.4, "GAy": 300.0, "GAz": 500.0}},
        "bodies": {
            "base": {"at": [0, 0, 0], "motion": {"rotation": {"axis": [0, 0, 1], "angle": "0.4*sin(3*t)"}}},
            "joint": {"at": [1.2, 0.3, 0], "mass": 0.3, "com": [0.05, -0.02, 0],
                      "inertia": [[0.01, 0.002, 0], [0.002, 0.02, 0], [0, 0, 0.03]]},
        },
        "beams": {
            "arm": {"from": {"body": "base", "offset": [0.1, 0.05, 0]}, "to": "joint", "section": "a",
                    "elements": 3, "y_axis": [-0.25, 1.1, 0],
                    "start": {"hinge": {"axis": [0, 0, 1], "stiffness": 30.0, "damping": 0.2, "rest_angle": 0.2}}},
            "tip": {"from": "joint", "to": [2.0, -0.4, 0], "section": "b", "elements": 2, "y_axis": [0, 0, 1],
                    "start": {"hinge": {"axis": [0, 0, -1], "stiffness": 5.0, "torque": "0.3*sin(5*t)"}}},
        },
        "loads": [{"at": "tip.end", "force": [0.2, "0.5*t", 0], "moment": [0, 0, 0.05], "frame": "joint"}],
        "solve": {"t_end": t_end, "dt": 0.005, **solve},
        "output": {"probes": [
            {"name": "tip", "point": "tip.end", "quantity": "position", "component": "norm"},
            {"name": "tip_speed", "point": "tip.end", "quantity": "velocity", "component": "norm"},
            {"name": "joint_rel", "point": "joint", "quantity": "position", "frame": "base", "component": "norm"},
            {"name": "hinge", "hinge": "tip.start", "quantity": "angle"},
            {"name": "hinge_rate", "hinge": "arm.start", "quantity": "rate"},
            {"name": "energy", "energy": "total"},
            {"name": "work", "energy": "external_work"},
            {"name": "axial", "element": "tip.element[0]", "quantity": "axial_force"},
            {"name": "bending", "element": "tip.element[1]", "quantity": "moment_y"},
            {"name": "bending_arm", "element": "arm.element[2]", "quantity": "moment_z"},
        ]},
    }


def rotated(raw, normal):
    """The scene with every vector taken by the cyclic permutation that maps e_z to e_normal."""
    perm = PERMUTATIONS[normal]

    def vec(v):
        out = [0] * 3
        for k in range(3):
            out[perm[k]] = v[k]
        return out

    raw = copy.deepcopy(raw)
    raw["gravity"] = vec(raw["gravity"])
    raw["initial_velocity"] = {k: vec(v) for k, v in raw["initial_velocity"].items()}
    for body in raw["bodies"].values():
        body["at"] = vec(body["at"])
        if "com" in body:
            body["com"] = vec(body["com"])
        if "inertia" in body:
            I = np.array(body["inertia"], float)
            Q = np.eye(3)[:, list(perm)]
            body["inertia"] = (Q @ I @ Q.T).tolist()
        if "motion" in body:
            body["motion"]["rotation"]["axis"] = vec(body["motion"]["rotation"]["axis"])
    for beam in raw["beams"].values():
        for key in ("from", "to"):
            if isinstance(beam[key], list):
                beam[key] = vec(beam[key])
            elif isinstance(beam[key], dict):
                beam[key]["offset"] = vec(beam[key]["offset"])
        if "y_axis" in beam:
            beam["y_axis"] = vec(beam["y_axis"])
        for key in ("start", "end"):
            if isinstance(beam.get(key), dict):
                beam[key]["hinge"]["axis"] = vec(beam[key]["hinge"]["axis"])
    for load in raw["loads"]:
        for key in ("force", "moment"):
            load[key] = vec(load[key])
    return raw


def _relative(a, b):
    """max |a − b| over max |b|, the latter at least 1e-6 (probes of this scene are O(0.01 … 10);
    a probe that is zero by symmetry compares round-off with round-off)."""
    return float(np.max(np.abs(a - b)) / max(np.max(np.abs(b)), 1e-6))


@pytest.mark.parametrize("normal", [2, 0, 1], ids=["xy", "yz", "zx"])
def test_planar_model_equals_3d_model(normal):
    raw = rotated(chain_scene(), normal)
    planar_scene = load_scene(raw)
    model = Model.from_scene(planar_scene)
    assert model.plane == normal
    n_free = len(model.free_nodes)
    assert model.n_dofs == 3 * n_free + len(model.free_hinges)
    assert np.any(np.abs(np.abs(model.section_turns) - np.pi / 2) < 1e-12)  # the tip's section turned
    off = copy.deepcopy(raw)
    off["solve"]["planar"] = "off"
    assert Model.from_scene(load_scene(off)).plane is None
    planar, full = latdyn.run(raw), latdyn.run(off)
    assert len(planar.t) == len(full.t)
    for name in full.probes:
        assert _relative(planar.probes[name], full.probes[name]) <= 1e-8, name
    assert planar.summary["coordinates"] < full.summary["coordinates"]


def test_same_answer_in_every_plane_and_both_engines():
    results = {normal: latdyn.run(rotated(chain_scene(t_end=0.15), normal)) for normal in (2, 0, 1)}
    with reference_engine():
        python = latdyn.run(rotated(chain_scene(t_end=0.15), 0))
    for name in results[2].probes:
        for normal in (0, 1):
            assert _relative(results[normal].probes[name], results[2].probes[name]) <= 1e-10, name
        assert _relative(python.probes[name], results[0].probes[name]) <= 1e-10, name


def test_scenes_that_leave_the_plane_stay_3d():
    raw = chain_scene()
    cases = {
        "gravity": lambda r: r.__setitem__("gravity", [0, -9.81, 0.1]),
        "hinge.axis": lambda r: r["beams"]["arm"]["start"]["hinge"].__setitem__("axis", [0, 0.1, 1]),
        "moment": lambda r: r["loads"][0].__setitem__("moment", [0.01, 0, 0.05]),
        "inertia": lambda r: r["bodies"]["joint"].__setitem__("inertia", [[0.01, 0, 0.001], [0, 0.02, 0],
                                                                          [0.001, 0, 0.03]]),
        "initial_velocity": lambda r: r["initial_velocity"].__setitem__("angular", [0.1, 0, 0.3]),
        "y_axis": lambda r: r["beams"]["tip"].__setitem__("y_axis", [0, 1, 1]),
        "to": lambda r: r["beams"]["tip"].__setitem__("to", [2.0, -0.4, 0.01]),
    }
    for what, change in cases.items():
        r = copy.deepcopy(raw)
        change(r)
        model = Model.from_scene(load_scene(r))
        assert model.plane is None, what
        assert model.n_dofs == 6 * len(model.free_nodes) + len(model.free_hinges)
        assert what.split(".")[-1] in model.plane_reason, (what, model.plane_reason)
    modes = copy.deepcopy(raw)
    modes["solve"] = {"analysis": "modes"}
    assert Model.from_scene(load_scene(modes)).plane is None


def test_planar_key_is_validated(tmp_path):
    from latdyn.errors import SceneError

    raw = chain_scene()
    raw["solve"]["planar"] = "yes"
    with pytest.raises(SceneError, match="solve.planar"):
        load_scene(raw)


@pytest.mark.parametrize("solve", [
    {"analysis": "static", "steps": 4},
    {"method": "explicit", "dt": 1e-4, "t_end": 0.02},
], ids=["static", "explicit"])
def test_planar_model_equals_3d_model_in_other_analyses(solve):
    """Static load stepping and the explicit method (with its split of directions without inertia)
    give the planar model's answer equal to the 3D model's. (Adaptive runs do not: the step
    controller's norm differs between the models, latdyn/model/planar.py.)"""
    raw = chain_scene()
    raw["solve"] = {k: v for k, v in raw["solve"].items() if k not in ("t_end", "dt")}
    raw["solve"].update({"t_end": 0.05, "dt": 0.005, **solve})
    if solve.get("analysis") == "static":
        del raw["solve"]["t_end"], raw["solve"]["dt"]
        raw["bodies"]["base"] = {"at": [0, 0, 0], "fixed": True}
        raw["initial_velocity"] = {"linear": [0, 0, 0], "angular": [0, 0, 0]}
    off = copy.deepcopy(raw)
    off["solve"]["planar"] = "off"
    planar, full = latdyn.run(raw), latdyn.run(off)
    assert Model.from_scene(load_scene(raw)).plane == 2
    assert len(planar.t) == len(full.t)
    for name in full.probes:
        assert _relative(planar.probes[name], full.probes[name]) <= 1e-8, name


def test_check_says_whether_the_scene_is_planar(tmp_path):
    import subprocess
    import sys

    import yaml

    path = tmp_path / "chain.yaml"
    path.write_text(yaml.safe_dump(chain_scene()))
    out = subprocess.run([sys.executable, "-m", "latdyn", "check", str(path)], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr
    assert "planar: xy plane (z = 0): in-plane coordinates only" in out.stdout
    assert "3 coordinates per free node" in out.stdout
    raw = chain_scene()
    raw["gravity"] = [0, -9.81, 1.0]
    path.write_text(yaml.safe_dump(raw))
    out = subprocess.run([sys.executable, "-m", "latdyn", "check", str(path)], capture_output=True, text=True)
    assert "planar: no, 3D model (xy: gravity has an out-of-plane component" in out.stdout


def test_planar_model_with_the_inertia_tangent():
    """solve.newton: exact (the inertia tangent from the start, latdyn.step.integrators.inertia_rounds)
    perturbs only the coordinates a planar node has; Python and compiled steps agree, and the
    planar model equals the 3D one."""
    results = {}
    for planar in ("auto", "off"):
        for engine in ("reference", "compiled"):
            raw = chain_scene(t_end=0.05, newton="exact")
            raw["solve"]["planar"] = planar
            with reference_engine() if engine == "reference" else contextlib.nullcontext():
                results[planar, engine] = latdyn.run(raw)
    reference = results["off", "reference"]
    for key, result in results.items():
        assert len(result.t) == len(reference.t), key
        for name in reference.probes:
            assert _relative(result.probes[name], reference.probes[name]) <= 1e-8, (key, name)
    for name in reference.probes:
        assert _relative(results["auto", "reference"].probes[name], results["auto", "compiled"].probes[name]) <= 1e-10


def test_planar_inertia_matrices_kernel_is_the_separate_kernels_and_its_rate_derivative(pair):
    """beam_inertia_matrices of a planar variant (M, g, ∂g/∂q̇ in one kernel, the compiled step's evaluation
    with matrices): each output the planar variant's separate kernel's to round-off, and ∂g/∂q̇ along the
    in-plane rates the central difference of its own g."""
    normal, _, planar = pair
    if "beam_inertia_matrices" not in planar.names:  # the runtime then calls the two kernels
        pytest.skip(f"variant {planar.variant!r} generated before beam_inertia_matrices")
    rng = np.random.default_rng(30 + normal)
    keep = in_plane_coordinates(normal)
    unit = np.eye(14)
    for _ in range(3):
        s = planar_state(rng, normal, deformation=0.5)
        geometry, section = s.geometry(), s.section[None]
        qdot = planar_velocity(rng, normal)
        M, g, dg = (x[0] for x in planar.beam_inertia_matrices(geometry, qdot[None], section))
        separate = (planar.beam_mass_matrix(geometry, section)[0][0],
                    planar.beam_quadratic_velocity(geometry, qdot[None], section)[0][0],
                    planar.beam_quadratic_velocity_D_qdot(geometry, qdot[None], section)[1][0])
        for value, expected in zip((M, g, dg), separate):
            np.testing.assert_allclose(value, expected, rtol=0, atol=1e-12 * max(np.abs(expected).max(), 1e-300))
        rates = lambda v: planar.beam_inertia_matrices(geometry, v[None], section)[1][0]  # noqa: E731
        numeric = np.column_stack([(rates(qdot + H * unit[k]) - rates(qdot - H * unit[k])) / (2 * H) for k in keep])
        np.testing.assert_allclose(dg[:, keep], numeric, rtol=0, atol=1e-6 * np.abs(dg).max())
