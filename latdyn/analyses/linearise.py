"""What is linearised, and what is reported of it: modes of loaded and spinning structures,
buckling, linear models.

SCENE.md, "Linearisation".  The linearisation itself (M, C, K about a state, in a frame turning
with the prescribed rotations, and its modes) is :mod:`latdyn.analyses.linearisation`; here are
the states it is taken about (``solve.about``: initial, static, steady — the search is
:mod:`latdyn.analyses.steady` — or a transient's state), the modal analysis, the buckling
analysis (follower loads: :mod:`latdyn.analyses.stability`), the linear model for control design
and the mode-shape files.
"""
from __future__ import annotations

import copy
import time

from dataclasses import dataclass

import numpy as np

from latdyn.analyses import continuation, mechanism, stability
from latdyn.analyses.followers import follower_loads
from latdyn.analyses.linearisation import (
    Frame, Linearisation, Mode, _steps, at_rest, dominant_directions, frame_kinematics, frame_of, linearise,
    modes, reduce, tangent_q,
)
from latdyn.analyses.not_equilibria import controller_values
from latdyn.assembly.assembler import pack, unpack_free
from latdyn.assembly.control import actuator_gain
from latdyn.assembly.prepare import length_scale
from latdyn.errors import SceneError, SolverError
from latdyn.results.writer import ResultWriter


# ----------------------------------------------------------------------------- the states to linearise about
def _scene_copy(scene, **solve):
    """The scene with ``solve`` fields replaced (the model of a linearisation is always 3D,
    as the modal analysis's: latdyn.model.planar.find_plane)."""
    other = copy.copy(scene)
    other.solve = copy.copy(scene.solve)
    for key, value in solve.items():
        setattr(other.solve, key, value)
    return other


def _planar(prepared) -> str:
    """``solve.planar`` for the run that reaches the state: the model of ``prepared`` (3D for modes)."""
    return "off" if prepared.model.plane is None else "auto"


def static_state(prepared):
    """The equilibrium of the static analysis of the scene (its loads, ``steps``), load factor 1."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet

    other = prepare(_scene_copy(prepared.scene, analysis="static", planar=_planar(prepared)),
                    prepared.assembler.kernels.backend)
    probes = ProbeSet(other.assembler, other.state)
    writer = ResultWriter(None, probes.names, "load_factor")
    continuation.static_path(other, probes, writer, length_scale(other.model))
    return other, at_rest(other.state)


def transient_state(prepared, t: float):
    """The state a transient run of the same scene reaches at time ``t`` (3D model)."""
    from latdyn.assembly.prepare import prepare
    from latdyn.results.probes import ProbeSet
    from latdyn.timeloop.transient import transient

    scene = prepared.scene
    if scene.solve.dt is None:
        raise SceneError(scene.file, "solve.dt", "missing required key 'dt' (about: {t: T} runs the "
                                                 "transient of the scene to T with this step)")
    other = prepare(_scene_copy(scene, analysis="transient", t_end=float(t), planar=_planar(prepared)),
                    prepared.assembler.kernels.backend)
    probes = ProbeSet(other.assembler, other.state)
    transient(other, probes, ResultWriter(None, probes.names), False)
    return other, other.state


def state_about(prepared, about):
    """(prepared, state, frame, load factor) of ``solve.about``."""
    if about == "static":
        other, state = static_state(prepared)
        return other, state, Frame.inertial(), 1.0
    if about == "steady":  # latdyn/analyses/steady.py
        from latdyn.analyses.steady import steady_state

        other, state, frame, _ = steady_state(prepared)
        return other, state, frame, 1.0
    if isinstance(about, float):
        other, state = transient_state(prepared, about)
        return other, state, frame_of(other.model, state), 1.0
    return prepared, at_rest(prepared.state), Frame.inertial(), 1.0  # initial: at rest


# ----------------------------------------------------------------------------- the analyses
def modal_analysis(prepared, count: int, about="initial"):
    """Modes about ``about`` (SCENE.md): (list of :class:`Mode`, dominant directions, Linearisation,
    report).  ``report`` holds what the run says of the state beyond its modes: about a steady
    spin, ``steady_state`` (stable or not, how it was found: latdyn/analyses/steady.py) and
    ``warnings``; empty otherwise."""
    report = {}
    if about == "steady":
        from latdyn.analyses.steady import steady_state, steady_summary

        other, state, frame, search = steady_state(prepared)
        load_factor = 1.0
    else:
        other, state, frame, load_factor = state_about(prepared, about)
    if other.model.n_dofs == 0:
        return [], [], None, report
    lin = linearise(other.assembler, state, frame, load_factor)
    states = controller_states(lin)  # continuous controllers' states: the closed loop's first-order modes
    first_order = None if states is None else (lambda red: closed_loop_matrix(lin, red, states)[0])
    found = modes(lin, None if about in ("steady", "static") or isinstance(about, float) else count, first_order)
    if about == "steady":  # judged by all its roots, not only the listed ones
        report["steady_state"], report["warnings"] = steady_summary(search, found)
        found = found[:count]
    elif about == "static":  # an equilibrium the path reached on an unstable branch: say so
        warning = static_instability(found)
        report["warnings"] = [warning] if warning is not None else []
        found = found[:count]
    elif isinstance(about, float):  # a frozen state: say so where it turns in the frame of the modes,
        from latdyn.analyses.moving import turning_warning  # and where a root grows (all of them judged)

        growing = transient_growth(found, about)
        found = found[:count]
        warning = turning_warning(other.model, state, frame, found, about)
        report["warnings"] = [w for w in (growing, warning) if w]
    return found, dominant_directions(other.model, lin, found), lin, report


#: A growing root at or above this share of the model's highest natural frequency lies where the
#: mesh does not resolve the structure's modes: it moves with the elements (a discretisation root).
MESH_ROOT_SHARE = 0.5

#: What a growing root means, by its kind (a real root: divergence; a complex pair: flutter).
GROWTH_MEANS = {
    "divergence": ("the static path (solve.method) was followed past a bifurcation (a perfect column stays "
                   "straight past its Euler load) or onto an unstable branch, and the structure does not stay "
                   "in this state"),
    "flutter": ("the state is an equilibrium, but it oscillates away from it with growing amplitude, which no "
                "static path shows (a load that is not conservative, a follower force or a moment fixed in "
                "space, can feed it)"),
}


def growing_roots(found: list[Mode]) -> list[Mode]:
    """The roots of ``found`` (all the modes about a state) that grow by more than round-off (growth
    −ζ·|λ| above 1e-6 of the largest natural angular frequency), lowest natural frequency first."""
    top = max((2 * np.pi * m.natural_frequency_hz for m in found), default=0.0)
    return [m for m in found if m.damping_ratio < 0.0 and growth_rate(m) > 1e-6 * top]


def growth_rate(mode: Mode) -> float:
    """The growth rate −ζ·|λ| (1/s) of a root: its real part."""
    return -mode.damping_ratio * 2 * np.pi * mode.natural_frequency_hz


def _described(mode: Mode, growing: list[Mode], top_hz: float) -> str:
    """A growing root as a warning names it: its rate, its kind and, high in the spectrum, the
    mesh's part in it."""
    if mode.frequency_hz > 0.0:
        said = f"{growth_rate(mode):.4g} 1/s by flutter (a complex pair, oscillating at {mode.frequency_hz:.4g} Hz)"
    else:
        said = f"{growth_rate(mode):.4g} 1/s by divergence (a real root)"
    if mode is growing[0]:
        return said
    said += f", at {mode.natural_frequency_hz:.4g} Hz natural"
    if mode.natural_frequency_hz >= MESH_ROOT_SHARE * top_hz:
        return said + (f", in the upper half of the model's spectrum (highest {top_hz:.4g} Hz), which the mesh "
                       "does not resolve: a discretisation root, which moves with the elements")
    if mode is growing[-1]:
        return said + (", the highest of the growing roots: a mesh resolves its highest roots least, so its "
                       "rate may move with the elements (a finer mesh tells)")
    return said


def static_instability(found: list[Mode]) -> str | None:
    """The warning of modes about a static state that is unstable (None where no root grows): the
    lowest growing root, its rate and kind (divergence: a real root; flutter: a complex pair) and
    what that kind means (:data:`GROWTH_MEANS`); and, where another grows faster, that one too,
    named a discretisation root where it lies in the upper half of the model's spectrum
    (:data:`MESH_ROOT_SHARE`), and where it is the highest of the growing roots, said to be the
    root a mesh resolves least (its rate may move with the elements)."""
    growing = growing_roots(found)
    if not growing:
        return None
    top_hz = max(m.natural_frequency_hz for m in found)
    lowest, fastest = growing[0], max(growing, key=growth_rate)
    kind = "flutter" if lowest.frequency_hz > 0.0 else "divergence"
    grow = "grows" if len(growing) == 1 else "grow"
    warning = (f"modes about static: the static state is unstable: {len(growing)} of its roots {grow}; the lowest "
               f"grows at {_described(lowest, growing, top_hz)}: {GROWTH_MEANS[kind]}")
    if fastest is not lowest:
        warning += f"; the fastest grows at {_described(fastest, growing, top_hz)}"
    return warning


def transient_growth(found: list[Mode], t: float) -> str | None:
    """The warning of modes about ``{t: T}`` (all the roots ``found``) where a root grows (None where
    none does): the lowest growing root, its rate and kind, and the fastest where another; with the
    caveat that a state of a transient run is no equilibrium, so the growing root may be the motion
    itself linearised about where it is at T, not an instability of a state (docs/linearisation.md)."""
    growing = growing_roots(found)
    if not growing:
        return None
    top_hz = max(m.natural_frequency_hz for m in found)
    lowest, fastest = growing[0], max(growing, key=growth_rate)
    grow = "grows" if len(growing) == 1 else "grow"
    warning = (f"modes about {{t: {t:g}}}: the linearised system about the state at t = {t:g} has a root with a "
               f"positive real part: {len(growing)} of its roots {grow}; the lowest grows at "
               f"{_described(lowest, growing, top_hz)}")
    if fastest is not lowest:
        warning += f"; the fastest grows at {_described(fastest, growing, top_hz)}"
    return warning + (". The state of a transient run is not an equilibrium (unless the motion is steady there): "
                      "a growing root says that motions near this one part from it at that rate about t = "
                      f"{t:g}, and may be the motion itself, linearised where it is, rather than an unstable "
                      "state; about: static and about: steady judge an equilibrium")


def modes_table(found: list[Mode], directions: list[str]) -> dict:
    """The extra columns of ``modes.csv`` after ``frequency_hz``."""
    return {"damping_ratio": [m.damping_ratio for m in found],
            "natural_frequency_hz": [m.natural_frequency_hz for m in found]}


#: A limit point where Newton finds no equilibrium beyond is a fold only where the stability measure
#: falls towards it (as √(λ_c − λ): by 1/√2 as the bracket halves): it must fall below this fraction
#: of the previous value at the last step; where it does not, the tangent is regular there and the
#: step that missed the path left a path that only softens, not a fold (the search goes on).
FOLD_FALL = 0.9
#: Load factor of the pre-buckling state that gives the change of the tangent K_1 = (K(λ₁) − K₀)/λ₁.
PREBUCKLING_FACTOR = 1e-4
#: Lowest linearised buckling factor above which loads that also move nothing (‖K⁻¹q_ref‖_W ≤
#: ``continuation.LOADS_MOVE_NOTHING``) stress nothing either: their K₁ is the round-off of K(λ₁) − K₀ over λ₁
#: (a scene's loads zero at t = 0 gave 5.6e7 and up).
LOADS_STRESS_NOTHING = 1e6
#: The stability search stops when the bracket of the load factor is this narrow (relative).
STABILITY_TOL = 1e-7
#: An element whose end sections turn by more than this (rad) relative to each other, beyond their
#: unloaded turn, does not resolve the bending of the state there: an instability found at such a state
#: is the mesh's (``buckling_mesh_dependent``).  Measured: 0.2 rad at most at the instabilities of the
#: buckling tests (Euler, Greenhill, lateral buckling, arches, a toggle, a portal frame); 2.67 rad at
#: the far instability of an imperfect column at 4, 8 and 16 elements, where λ grows as 1/h²
#: (docs/static_paths.md, "Buckling").
ELEMENT_TURN_RESOLVED = 0.5 * np.pi


def _stability(assembler, state, load_factor: float, K0_factor) -> float:
    """The lowest eigenvalue of the symmetric part of the static tangent against the unloaded one,
    min eig(K_T(λ), K₀): 1 unloaded, 0 where the loaded structure loses stability."""
    import scipy.linalg as sla

    K = tangent_q(assembler, state, load_factor, inertia=False)
    K = 0.5 * (K + K.T)
    return float(sla.eigh(K, b=K0_factor, eigvals_only=True, subset_by_index=[0, 0])[0])


def _element_turns(assembler, state, reference) -> np.ndarray:
    """The angle (rad) by which each element's end sections (the nodal frames T_e^i of Eq. 17, a
    hinged end's turned by its hinge) turn relative to each other at ``state``, beyond their turn in
    ``reference``: the bending and twist one element carries."""
    def relative(s):
        geometry = assembler.element_geometry(s)
        first, second = geometry[:, 12:21].reshape(-1, 3, 3), geometry[:, 21:30].reshape(-1, 3, 3)
        return np.einsum("nji,njk->nik", first, second)  # T_e¹ᵀ T_e²

    turn = np.einsum("nji,njk->nik", relative(reference), relative(state))
    cosine = 0.5 * (np.trace(turn, axis1=1, axis2=2) - 1.0)
    return np.arccos(np.clip(cosine, -1.0, 1.0))


def _unresolved(prepared, state, reference, load_factor: float) -> dict:
    """The flag of an instability the mesh does not resolve (``buckling_mesh_dependent``), with the
    element turned most within itself where it turns by more than :data:`ELEMENT_TURN_RESOLVED`, and
    its warning."""
    model = prepared.model
    if len(model.element_nodes) == 0:
        return {"buckling_mesh_dependent": False}
    turns = _element_turns(prepared.assembler, state, reference)
    worst = int(np.argmax(turns))
    if turns[worst] <= ELEMENT_TURN_RESOLVED:
        return {"buckling_mesh_dependent": False}
    beam = model.element_beam[worst]
    element = f"{beam}.element[{int(np.flatnonzero(model.beam_elements[beam] == worst)[0])}]"
    return {"buckling_mesh_dependent": True, "buckling_unresolved_element": element,
            "buckling_element_turn": float(turns[worst]),
            "warnings": [f"buckling: at load factor {load_factor:.6g} the static path turns element {element} by "
                         f"{np.degrees(turns[worst]):.0f}° within itself (more than "
                         f"{np.degrees(ELEMENT_TURN_RESOLVED):.0f}°): the mesh does not resolve that state, so the "
                         "instability found there is the discretisation's and changes with the mesh (an imperfect "
                         "column's grows as 1/h²), not a buckling load of the structure; more elements in beam "
                         f"{beam} tell whether the structure has one (buckling_mesh_dependent)"]}


def buckling_analysis(prepared, count: int = 6) -> dict:
    """The lowest load factor at which the loaded structure loses stability (SCENE.md).

    ``buckling_factor``: the load factor λ at which the tangent of the static equilibrium path
    K_T(λ) (loads, gravity and hinge torques times λ, as the static analysis) stops being
    positive definite: the zero of f(λ) = min eig(K_T(λ), K₀), found by stepping along the path
    (the static analysis's Newton at each λ, :func:`latdyn.analyses.continuation.newton_fixed` on the
    analytic tangent; the stability tangents by :func:`tangent_q`) with secant predictions and regula
    falsi once bracketed.  This is a bifurcation (an Euler column, lateral buckling) or a limit point (then Newton stops beyond it: ``buckling_kind`` says which was seen).

    ``linearised_buckling_factors``: the classical linearised estimate about the unloaded
    configuration, the smallest μ > 0 of det(K₀ + μ K₁) = 0 with K₁ = (K(λ₁) − K₀)/λ₁ at the small
    load factor λ₁ = PREBUCKLING_FACTOR.  K₁ holds the stress (geometric) stiffness and also the
    initial-displacement stiffness of the pre-buckling deflection; where a load bends the
    structure (a cantilever's tip load) the latter makes spurious low factors (measured: 0.14
    for a cantilever with EI_strong/EI_weak = 100 whose lateral buckling is at 1.0), so it is
    reported, not used.  For a column (axial pre-buckling) the two agree.

    Under follower loads (:func:`latdyn.analyses.followers.follower_loads`) the symmetric part of
    the tangent tells nothing: divergence and flutter are searched instead
    (:func:`latdyn.analyses.stability.search`, ``solve.flutter``); conservative problems take the
    search above, unchanged (``instability``: ``buckling`` or ``none``).
    """
    import scipy.linalg as sla

    from latdyn.analyses.not_equilibria import states_not_at_rest, stops_passed  # the path's own caveats

    model, assembler = prepared.model, prepared.assembler
    if model.n_dofs == 0:
        return {"buckling_factor": None}
    started = time.perf_counter()
    reference = at_rest(prepared.state)
    K0 = tangent_q(assembler, reference, 0.0, inertia=False)
    K0s = 0.5 * (K0 + K0.T)
    path = continuation.Path(prepared, None, None, length_scale(model))  # Newton's settings and counters
    try:
        np.linalg.cholesky(K0s)
    except np.linalg.LinAlgError:
        free = mechanism.coordinate_names(model, mechanism.free_directions(K0, path.weight)[0])
        raise SolverError("buckling: the unloaded structure is not held (its tangent is not positive definite"
                          + (f"; nothing holds {', '.join(free)}: no stiffness, no support" if free else "")
                          + "): a free structure or a mechanism has no buckling load") from None
    follower = follower_loads(model, reference)
    loaded, _, _, converged = continuation.newton_fixed(path, reference, PREBUCKLING_FACTOR)
    if not converged:
        raise SolverError(f"buckling: no static equilibrium at load factor {PREBUCKLING_FACTOR:g}")
    K1 = (tangent_q(assembler, loaded, PREBUCKLING_FACTOR, inertia=False) - K0) / PREBUCKLING_FACTOR
    nu = sla.eigvals(-K1, K0)
    nu = nu[np.isfinite(nu)]
    if follower:  # directions the load does not change (axial, torsion) give ν of round-off, 1/ν ~ 1e11
        nu = nu[np.abs(nu) > 1e-9 * max(float(np.abs(nu).max(initial=0.0)), 1e-300)]
    linearised = np.sort([1.0 / v.real for v in nu if v.real > 0 and abs(v.imag) <= 1e-8 * abs(v)])
    if follower:  # non-conservative: divergence and flutter along the path (latdyn/analyses/stability.py)
        step = min(1.0 / prepared.scene.solve.steps, 0.5 * float(linearised[0]) if len(linearised) else 1.0)
        flutter = prepared.scene.solve.flutter is not False
        out = stability.search(prepared, path, reference, K0s, step, flutter, STABILITY_TOL)
        out.update(follower_loads=[f"loads[{i}]" for i in follower],
                   linearised_buckling_factors=[float(x) for x in linearised[:count]],
                   buckling_s=time.perf_counter() - started)
        if not flutter:
            out.update(flutter_factor=None, flutter_searched_to=None)  # not searched
        return out  # its warnings are said by the caller (solve: stderr and summary.json)

    stresses_nothing = len(linearised) == 0 or linearised[0] > LOADS_STRESS_NOTHING
    moved = path.iterate(reference, 0.0).dq_lambda if stresses_nothing else None   # a factorization: only then
    if moved is not None and path.norm(moved) <= continuation.LOADS_MOVE_NOTHING:
        # conservative loads zero at t = 0 (a load in t): they neither move the structure nor stress it (K₁ is round-off:
        # linearised factors 5.6e7 and up), and the path's search went on to a "limit point" at λ ~ 1e13
        # where Newton meets round-off. A dead load on a straight chain of rigid links moves nothing and
        # stresses it (Ziegler's column: factors of order 1): searched as before
        raise SolverError(f"buckling: the loads move nothing (the full load moves the structure by "
                          f"{path.norm(moved):.3g} of its size, at most {continuation.LOADS_MOVE_NOTHING:g}, and its "
                          f"lowest linearised buckling factor is "
                          f"{(f'{linearised[0]:.3g}' if len(linearised) else 'none')}; a static analysis takes the "
                          "loads, gravity and torques at t = 0, where a load in t may be zero): no load factor of "
                          "them buckles the structure")
    # along the path: f(λ) = min eig(K_T(λ), K₀) from f(0) = 1 to its zero
    lam, f, state = 0.0, 1.0, reference
    step = min(1.0 / prepared.scene.solve.steps,
               0.5 * float(linearised[0]) if len(linearised) else 1.0)
    below = (lam, f, state)
    above = None
    kind, evaluations, falling = None, 0, True
    passed = []  # the first stable state of the path past a rigid stop or latch, or off a controller's rest
    for _ in range(200):
        if above is None:
            target = below[0] + step
        else:  # regula falsi in the bracket
            (l0, f0, _), (l1, f1) = below, above
            target = l0 + (l1 - l0) * f0 / (f0 - f1)
            target = min(max(target, l0 + 0.01 * (l1 - l0)), l1 - 0.01 * (l1 - l0))
        trial, _, _, converged = continuation.newton_fixed(path, below[2], target)
        if converged and path.left_the_path(below[2], below[0], trial, target):
            converged = False  # it snapped onto another branch past a limit point: as no equilibrium
        if not converged:
            if above is None and step > STABILITY_TOL * max(below[0], 1e-12):
                step *= 0.5
                above_limit = target
                kind = "limit point (Newton finds no equilibrium beyond)"
                continue
            break
        value = _stability(assembler, trial, target, K0s)
        evaluations += 1
        if value > 0.0:
            l0, f0 = below[0], below[1]
            below, falling = (target, value, trial), value < FOLD_FALL * f0
            passed = passed or stops_passed(model, trial, load_factor=target) or states_not_at_rest(
                assembler, trial, f"buckling: the static path at load factor {target:.6g}")
            if above is None:  # secant prediction of the zero, at most doubling the step
                slope = (value - f0) / (target - l0)
                guess = target - value / slope if slope < 0 else np.inf
                step = min(max(guess - target, 0.05 * step), 2 * step) if np.isfinite(guess) else 2 * step
                if kind is not None:
                    step = min(step, 0.5 * (above_limit - target))
        else:
            above = (target, value)
            kind = "bifurcation or limit point (tangent singular)"
        width = (above[0] if above is not None else (above_limit if kind else np.inf)) - below[0]
        if width <= STABILITY_TOL * max(below[0], 1e-12):
            if above is None and kind is not None and not falling:  # the tangent stays regular up to it:
                kind, step = None, 0.1 * below[0]  # no fold; the step that missed it left a path that softens
                continue
            break
        if above is None and below[0] > 1e6 * max(1.0, float(linearised[0]) if len(linearised) else 1.0):
            break
    if above is not None:
        (l0, f0, _), (l1, f1) = below, above
        factor = l0 + (l1 - l0) * f0 / (f0 - f1)
    elif kind is not None:
        factor = below[0]
    else:
        factor = None
    # an instability at a state one element does not resolve (an element folded within itself) is the
    # mesh's: flagged (docs/static_paths.md, "Buckling")
    resolution = {} if factor is None else _unresolved(prepared, below[2], reference, float(factor))
    passed = passed + resolution.pop("warnings", [])
    return {"buckling_factor": None if factor is None else float(factor),
            "buckling_kind": kind, "conservative": True,
            "instability": "none" if factor is None else "buckling", **resolution,
            **({"flutter_factor": None, "flutter_searched_to": None}  # conservative: no flutter to search
               if prepared.scene.solve.flutter else {}),
            "linearised_buckling_factors": [float(x) for x in linearised[:count]],
            "stability_evaluations": evaluations,
            "buckling_s": time.perf_counter() - started,
            **({"warnings": passed} if passed else {})}  # said by the caller (solve: stderr and summary.json)


def _state_from(model, template, arrays: dict):
    """A State from the flat arrays of ``State.as_dict`` (a recorded load step)."""
    state = template.copy()
    for key in ("x", "T", "v", "w", "theta", "theta_dot"):
        if key in arrays:
            getattr(state, key).flat[:] = arrays[key]
    return state


# ----------------------------------------------------------------------------- linear models
def _input_forces(model, state, inputs, assembler=None) -> np.ndarray:
    """F (n × k): the generalized force of each unit input (``Scene.solve.linear_model``)."""
    scene = model.scene
    F = np.zeros((model.n_total + 1, len(inputs)))
    for j, (kind, ref) in enumerate(inputs):
        if kind == "hinge":
            F[model.hinge_dofs[model.hinge_index(*ref)], j] = 1.0
            continue
        if kind == "input":
            F[:, j] = _scene_input_force(model, assembler, state, ref, j)
            continue
        if kind == "load":
            load = scene.loads[ref]
            point = load.at
            f = np.array([g.value(state.t) for g in load.force]) if load.force else np.zeros(3)
            mo = np.array([g.value(state.t) for g in load.moment]) if load.moment else np.zeros(3)
            f, mo = _load_axes(model, state, load, f, mo)
        else:
            point, axis = ref
            f, mo = np.zeros(3), np.zeros(3)
            (f if kind == "force" else mo)[axis] = 1.0
        F[:, j] += _point_force(model, assembler, state, point, f, mo, "solve.linear_model.inputs",
                                "expected an input at a point that moves")
    return F[:model.n_dofs]


def _load_axes(model, state, load, f, mo):
    """A load's force and moment components in global axes (``frame``: a body's axes at the state)."""
    if load.frame == "global":
        return f, mo
    R = state.T[model.body_node[load.frame]]
    return R @ f, R @ mo


def _point_force(model, assembler, state, point, f, mo, key: str, expected: str) -> np.ndarray:
    """The generalized force (n_total + 1) of a force ``f`` (global) at the scene point ``point`` and a
    moment ``mo``: the generated point_load kernel's wrench on the point's node, through Jᵀ of the
    links' map where the node follows rigid links or a guide; refused (``key``, ``expected``) at a
    fixed or prescribed point."""
    F = np.zeros(model.n_total + 1)
    node, r = model.point(point)
    if model.links is not None and node in set(model.links.dependent):
        F[:model.n_dofs] += _dependent_input_force(model, assembler, state, node, r, f, mo)
    elif node in set(model.free_nodes.tolist()):
        F[model.node_dofs[node]] += _node_wrench(assembler, state, node, r, f, mo)
    else:
        raise SceneError(model.scene.file, key, f"{expected}; {model.nodes[node].name} is fixed or prescribed")
    return F


def _node_wrench(assembler, state, node, r, f, mo) -> np.ndarray:
    """(F, r_g × F + Mo) on ``node`` of a force ``f`` (global) at the offset ``r`` (node axes) and a
    moment ``mo``: the generated ``point_load`` kernel (Eq. 2; its load_force is minus this)."""
    row = lambda a: np.ascontiguousarray(np.reshape(a, (1, -1)), dtype=float)  # noqa: E731
    velocity = np.concatenate([state.v[node], state.w[node]])
    force = assembler.kernels.point_load(row(state.T[node]), row(r), row(np.concatenate([f, mo])), row(np.eye(3)),
                                         row(velocity))[0]
    return -np.asarray(force, dtype=float).reshape(6)


def _dependent_input_force(model, assembler, state, node, r, f, mo) -> np.ndarray:
    """The generalized force (n,) of a force ``f`` at the offset ``r`` (body axes) of a node that
    follows rigid links or a guide, and a moment ``mo``: Jᵀ (f, (T r) × f + mo) with J the node's rows
    of the links' map onto the minimum coordinates (δx, δπ per unit of each column, as the compiled
    step composes it: :meth:`latdyn.assembly.native_model.NativeModel.complete_links`), the reduction
    Pᵀ that carries the loads on dependent nodes in every analysis."""
    assembler.complete_links(state)  # the node placed, and its J in the native links' buffers
    native = assembler.native().links
    s = native.slot_of_node[int(node)]
    columns = native.columns[s, :native.count[s]]
    J = native.jacobian[s, :, :len(columns)]
    wrench = _node_wrench(assembler, state, node, r, f, mo)
    generalized = J[:3].T @ wrench[:3] + J[3:].T @ wrench[3:]
    force = np.zeros(model.n_dofs)
    free = columns < model.n_dofs
    np.add.at(force, columns[free], generalized[free])
    return force


def _scene_input_force(model, assembler, state, name: str, j: int) -> np.ndarray:
    """The generalized force of a unit change of the scene's input ``name`` (SCENE.md ``inputs``;
    ``solve.linear_model.inputs[j]``), exact: ∂τ/∂u of every hinge torque and ∂f/∂u of every load
    component that names it (SymPy derivatives at the state, the other inputs at their current
    values), and of every continuous controller whose output reads it, on that controller's
    actuators (∂y/∂u; 0 at a limit). An input in a stiffness, a damping or a prescribed motion is
    refused (what it changes is not a force)."""
    import sympy as sp

    scene = model.scene
    u = sp.Symbol(name, real=True)
    key = f"solve.linear_model.inputs[{j}]"
    values = {sp.Symbol(n, real=True): v for n, v in {**scene.inputs.current(),
                                                       **scene.controller_outputs.current()}.items()}
    values[sp.Symbol("t", real=True)] = float(state.t)

    def rate(law, extra=None):
        if law is None or name not in getattr(law, "input_names", ()):
            return 0.0
        if hasattr(law, "d_theta"):  # a HingeLaw: (θ, θ̇, t, inputs…), (f, …)
            symbols, (f, *_) = law.expressions
            at = dict(values)
            at.update({symbols[0]: extra[0], symbols[1]: extra[1]})
        else:
            f, at = law.expr, values
        return float(sp.diff(f, u).evalf(subs=at))

    for what, laws in [(f"bodies.{b}.motion", [*(body.translation or ()), body.rotation_angle])
                       for b, body in scene.bodies.items()] + \
            [(f"beams.{h.beam}.{h.end}.hinge", [h.stiffness, h.damping, h.angle]) for h in model.hinges]:
        if any(name in getattr(law, "input_names", ()) for law in laws):
            raise SceneError(scene.file, key, f"input {name!r} changes a stiffness, a damping or a prescribed motion "
                                              f"({what}), not a force; expected an input of hinge torques, load "
                                              "components or controllers")
    F = np.zeros(model.n_total + 1)
    for k, h in enumerate(model.hinges):
        F[model.hinge_dofs[k]] += rate(h.torque, (float(state.theta[k]), float(state.theta_dot[k])))
    components = [(l, load, offset + p, law) for l, load in enumerate(scene.loads)
                  for offset, laws in ((0, load.force), (3, load.moment)) for p, law in enumerate(laws or ())]
    gains = _controller_input_gains(model, assembler, state, u, values)
    for l, load, c, law in components:
        derivative = rate(law) + gains.get(("load", l, c), 0.0)
        if derivative == 0.0:
            continue
        f, mo = np.zeros(3), np.zeros(3)
        (f if c < 3 else mo)[c % 3] = derivative
        f, mo = _load_axes(model, state, load, f, mo)
        F += _point_force(model, assembler, state, load.at, f, mo, key, "expected an input of loads at points that move")
    for k in range(len(model.hinges)):
        F[model.hinge_dofs[k]] += gains.get(("hinge", k, 0), 0.0)
    F[model.n_total] = 0.0  # the dummy of constrained coordinates
    return F


def _controller_input_gains(model, assembler, state, u, values) -> dict:
    """∂y/∂u of each continuous controller that reads the input ``u``, by actuator:
    {("hinge", k, 0) | ("load", l, component): ∂y/∂u} (0 at a limit)."""
    import sympy as sp

    from latdyn.results.probes import ProbeSet

    scene = model.scene
    continuous = [c for c in scene.controllers.values() if not c.sampled]
    if not any(u.name in c.reads for c in continuous):
        return {}
    probes = ProbeSet(assembler, assembler.initial_state())
    at = dict(values)
    at.update({sp.Symbol(n, real=True): v for n, v in zip(probes.names, probes.values(state.copy()))})
    gains, total = {}, {}  # total: dy/du of each continuous controller, through the earlier ones it reads
    recording = {p.name: p.controller for p in scene.output.probes if p.kind == "controller" and p.state is None}
    for c in continuous:  # file order: the chain rule through the outputs of earlier continuous ones
        y = float(c.output_expr.evalf(subs=at))
        at[sp.Symbol(c.name, real=True)] = min(max(y, c.limits[0]), c.limits[1]) if c.limits is not None else y
        if c.limits is not None and not c.limits[0] <= y <= c.limits[1]:
            total[c.name] = 0.0
            continue
        dy = float(sp.diff(c.output_expr, u).evalf(subs=at))
        dy += sum(float(sp.diff(c.output_expr, x).evalf(subs=at)) * total[recording.get(x.name, x.name)]
                  for x in c.output_expr.free_symbols if recording.get(x.name, x.name) in total)
        total[c.name] = dy
        if dy == 0.0:
            continue
        for k, h in enumerate(model.hinges):
            a = actuator_gain(h.torque, c.name)  # ∂τ/∂y: 1 for the name alone
            if a is not None:
                gains[("hinge", k, 0)] = gains.get(("hinge", k, 0), 0.0) + a * dy
        for l, load in enumerate(scene.loads):
            for offset, laws in ((0, load.force), (3, load.moment)):
                for p, law in enumerate(laws or ()):
                    a = actuator_gain(law, c.name)
                    if a is not None:
                        gains[("load", l, offset + p)] = gains.get(("load", l, offset + p), 0.0) + a * dy
    return gains


def _actuator_force(model, assembler, state, name: str, gain: float) -> np.ndarray:
    """The generalized force (n_total + 1) of the actuators of the continuous controller ``name`` at the
    output ``gain``: the hinge torques, guide forces and load components that the model's wiring
    (:func:`latdyn.assembly.control.wiring`, ``assembler.control``) drives by it, each ∂τ/∂y times the
    output (1 for the name alone); a load through :func:`_point_force`, the inputs' point path (the
    generated point_load kernel; Jᵀ of the links' map at a node that follows rigid links or a guide)."""
    control = assembler.control
    k = [c.name for c in control.controllers].index(name)
    F = np.zeros(model.n_total + 1)
    for kind, index, component, controller, a in zip(control.actuator_kind, control.actuator_index,
                                                      control.actuator_component, control.actuator_controller,
                                                      control.actuator_gain):
        if controller != k:
            continue
        alone = (control.hinge_controller[index] if kind == 0 else control.load_controller[index, component]) == k
        value = (1.0 if alone else float(a)) * gain  # ∂τ/∂y (the wiring's 0 marks the name alone) times y
        if kind == 0:
            F[model.hinge_dofs[index]] += value
            continue
        load = assembler.loads[index]
        f, mo = np.zeros(3), np.zeros(3)
        (f if component < 3 else mo)[component % 3] = value
        f, mo = _load_axes(model, state, load, f, mo)
        F += _point_force(model, assembler, state, load.at, f, mo, f"controllers.{name}",
                          "expected a controller's load at a point that moves")
    F[model.n_total] = 0.0
    return F


@dataclass
class ControllerStates:
    """The continuous controllers' states S in a linear model, about the state: the generalized force
    per unit δS on their actuators (``force``: g ∂y/∂S, n × p), and δṠ = ``by_sensor`` δs + ``by_state`` δS
    + ``by_input`` δu (∂f/∂s, ∂f/∂S, ∂f/∂u: SymPy's derivatives at the state), s the ``sensors`` (probes)."""

    names: list
    sensors: list
    force: np.ndarray
    by_sensor: np.ndarray
    by_state: np.ndarray
    by_input: np.ndarray
    output_gain: dict  # controller name -> ∂y/∂S over all states (0 at a limit)


def controller_states(lin: Linearisation, input_names=()) -> ControllerStates | None:
    """The continuous controllers' states about the linearisation's state (:class:`ControllerStates`),
    None without. ``input_names``: the scene inputs that are columns of B (None where a column is not one)."""
    import sympy as sp

    from latdyn.results.probes import ProbeSet

    model, state = lin.model, lin.state
    scene = model.scene
    continuous = [c for c in scene.controllers.values() if not c.sampled and c.states]
    if not continuous:
        return None
    probes = ProbeSet(lin.assembler, lin.assembler.initial_state())
    values = controller_values(lin.assembler, state, probes)
    sensors = [n for n in probes.names if any(n in c.reads for c in continuous)]
    p = sum(len(c.states) for c in continuous)
    force = np.zeros((model.n_dofs, p))
    by_sensor, by_state = np.zeros((p, len(sensors))), np.zeros((p, p))
    by_input = np.zeros((p, len(input_names)))
    names, gains, first = [], {}, 0
    for c in continuous:
        symbol = {x.name: x for x in c.symbols}
        at = {x: float(state.t) if x.name == "t" else
              (scene.controller_states[f"{c.name}.{x.name}"] if x.name in c.states else values[x.name]) for x in c.symbols}
        y = float(c.output_expr.evalf(subs=at))
        held = c.limits is None or c.limits[0] <= y <= c.limits[1]
        gains[c.name] = np.zeros(p)
        for j, (s, f) in enumerate(zip(c.states, c.state_exprs)):
            dy = float(sp.diff(c.output_expr, symbol[s]).evalf(subs=at)) if held else 0.0
            gains[c.name][first + j] = dy
            force[:, first + j] = _actuator_force(model, lin.assembler, state, c.name, dy)[:model.n_dofs]
            for i, sensor in enumerate(sensors):
                if sensor in symbol:
                    by_sensor[first + j, i] = float(sp.diff(f, symbol[sensor]).evalf(subs=at))
            for l, other in enumerate(c.states):
                by_state[first + j, first + l] = float(sp.diff(f, symbol[other]).evalf(subs=at))
            for k, u in enumerate(input_names):
                if u is not None and u in symbol:
                    by_input[first + j, k] = float(sp.diff(f, symbol[u]).evalf(subs=at))
            names.append(f"{c.name}.{s}")
        first += len(c.states)
    return ControllerStates(names, sensors, force, by_sensor, by_state, by_input, gains)


def closed_loop_matrix(lin: Linearisation, red, states: ControllerStates) -> tuple[np.ndarray, dict]:
    """A of ẋ = A x, x = [z, ż, S]: the structure's rows with the states' forces, and the states' rows
    δṠ = ∂f/∂s (C_s [z, ż] + C_s,u D_S δS) + ∂f/∂S δS, the sensors' C_s from the probes (as the linear
    model's outputs) and D_S the static displacement of the directions without inertia under the
    states' forces; with the pieces the linear model's B and C take (``parts``)."""
    m, p = red.n_massive, len(states.names)
    Minv = np.linalg.inv(red.mass)
    B_S, D_S = red.condense(states.force)
    _, Cq, Cv = _output_jacobians(lin, states.sensors)
    A1, _, _ = frame_kinematics(lin.model, lin.state, lin.frame)
    Cs = Cq + Cv @ A1
    A = np.block([[np.zeros((m, m)), np.eye(m), np.zeros((m, p))],
                  [-Minv @ red.stiffness, -Minv @ red.damping, Minv @ B_S],
                  [states.by_sensor @ Cs @ red.transform, states.by_sensor @ Cv @ red.transform,
                   states.by_state + states.by_sensor @ Cs @ D_S]])
    return A, {"Cs": Cs, "D_S": D_S}


def _output_jacobians(lin: Linearisation, names: list[str]):
    """y₀, ∂y/∂q (at fixed velocities) and ∂y/∂v of the named probes, by central differences of
    the probe functions (latdyn/probes.py)."""
    from latdyn.results.probes import ProbeSet

    model, assembler, state = lin.model, lin.assembler, lin.state
    probes = ProbeSet(assembler, assembler.initial_state())
    index = [probes.names.index(name) for name in names]

    def y(s):
        return np.array(probes.values(s))[index]

    n = model.n_dofs
    h = _steps(model, length_scale(model))
    Cq, Cv = np.zeros((len(names), n)), np.zeros((len(names), n))
    v0 = pack(model, state.v, state.w, state.theta_dot)[:n]
    for j in range(n):
        e = np.zeros(n)
        e[j] = h[j]
        Cq[:, j] = (y(assembler.advance(state, e)) - y(assembler.advance(state, -e))) / (2 * h[j])
        plus, minus = state.copy(), state.copy()
        unpack_free(model, v0 + e, plus.v, plus.w, plus.theta_dot)
        unpack_free(model, v0 - e, minus.v, minus.w, minus.theta_dot)
        Cv[:, j] = (y(plus) - y(minus)) / (2 * h[j])
    return y(state.copy()), Cq, Cv


def linear_model(lin: Linearisation, spec: dict) -> dict:
    """A, B, C, D of ẋ = A x + B u, y − y₀ = C x + D u about the linearisation's state, x = [z, ż]
    (the directions with inertia, module docstring), u the named inputs, y the named probes;
    arrays for ``numpy.savez`` (``scipy.signal.StateSpace(A, B, C, D)``)."""
    red = reduce(lin)
    m = red.n_massive
    F = _input_forces(lin.model, lin.state, spec["inputs"], lin.assembler)
    Br, Du = red.condense(F)
    Minv = np.linalg.inv(red.mass)
    A = np.block([[np.zeros((m, m)), np.eye(m)], [-Minv @ red.stiffness, -Minv @ red.damping]])
    B = np.vstack([np.zeros((m, F.shape[1])), Minv @ Br])
    y0, Cq, Cv = _output_jacobians(lin, spec["outputs"])
    A1, _, _ = frame_kinematics(lin.model, lin.state, lin.frame)
    Cy = Cq + Cv @ A1  # δv = u̇ + A₁u
    C = np.hstack([Cy @ red.transform, Cv @ red.transform])
    D = Cy @ Du
    names = lin.model.dof_names()
    # a state's name: the coordinate it moves most (the basis is block-diagonal by joint)
    z_names = [names[int(np.argmax(np.abs(red.basis[:, k])))] for k in range(m)]
    extra = controller_states(lin, [ref if kind == "input" else None for kind, ref in spec["inputs"]])
    if extra is not None:  # the continuous controllers' states: x = [z, ż, S]
        A, parts = closed_loop_matrix(lin, red, extra)
        B = np.vstack([B, extra.by_sensor @ parts["Cs"] @ Du + extra.by_input])
        C = np.hstack([C, Cy @ parts["D_S"]])
        scene = lin.model.scene
        for row, name in enumerate(spec["outputs"]):
            probe = next(q for q in scene.output.probes if q.name == name)
            if probe.kind != "controller":
                continue
            if probe.state is not None and f"{probe.controller}.{probe.state}" in extra.names:
                C[row, 2 * m + extra.names.index(f"{probe.controller}.{probe.state}")] = 1.0
            elif probe.state is None and probe.controller in extra.output_gain:
                C[row, 2 * m:] += extra.output_gain[probe.controller]
    return {"A": A, "B": B, "C": C, "D": D, "y0": y0,
            "inputs": np.array(spec["input_names"]), "outputs": np.array(spec["outputs"]),
            "states": np.array(z_names + [f"d/dt {s}" for s in z_names]
                               + ([f"controller {n}" for n in extra.names] if extra is not None else [])),
            "state_description": np.array(
                "x = [z, dz/dt]: the coordinates with inertia (directions without inertia condensed "
                "statically), perturbations about the state in the frame turning at frame_omega, "
                "global components at time t; inputs: hinge torques (N m), point forces (N) and moments "
                "(N m) in global axes, loads[i] scale factors; outputs: probe values minus y0"),
            "t": np.array(lin.state.t), "frame_omega": lin.frame.omega, "load_factor": np.array(lin.load_factor)}


def write_linear_model(prepared, out_dir, summary: dict, lin: Linearisation | None = None) -> dict:
    """``OUT/linear_model.npz`` about ``solve.about`` (SCENE.md); ``lin`` when already computed."""
    scene = prepared.scene
    if lin is None:
        other, state, frame, load_factor = state_about(prepared, scene.solve.about)
        lin = linearise(other.assembler, state, frame, load_factor)
    arrays = linear_model(lin, scene.solve.linear_model)
    if out_dir is not None:
        from pathlib import Path

        np.savez(Path(out_dir) / LINEAR_MODEL_FILE, **arrays)
    summary["linear_model"] = {"states": int(arrays["A"].shape[0]), "inputs": int(arrays["B"].shape[1]),
                               "outputs": int(arrays["C"].shape[0])}
    return arrays


LINEAR_MODEL_FILE = "linear_model.npz"


#: Frames per period of each mode's animation (``OUT/paraview/modes``).
MODE_FRAMES = 16
#: The largest translation of an animated mode, times the scene's size ℓ (or rotation, rad).
MODE_AMPLITUDE = 0.05
MODES_DIR = "modes"


def write_mode_shapes(lin: Linearisation, found: list[Mode], out_dir) -> list[str]:
    """The mode shapes as ParaView animations: ``OUT/paraview/modes/mode_<k>/<part>.vtkhdf``
    (latdyn.results.paraview's parts and fields), one period in :data:`MODE_FRAMES` frames whose "time" is
    the phase as a fraction of the period; the state ⊕ a·Re(φ e^{2πi·phase}), φ scaled so that its
    largest translation is MODE_AMPLITUDE·ℓ (a mode without translation: its largest rotation
    MODE_AMPLITUDE rad).  ``displacement`` is then the mode's motion about the state."""
    import shutil
    from pathlib import Path

    from latdyn.results import paraview as paraview

    if out_dir is None or not found:
        return []
    folder = Path(out_dir) / paraview.PARAVIEW_DIR / MODES_DIR
    if folder.is_dir():  # ours: an earlier run's modes go
        shutil.rmtree(folder)
    model, assembler, state = lin.model, lin.assembler, lin.state
    length = length_scale(model)
    mesh = paraview.parts(model, state)
    translations = model.node_dofs[model.free_nodes, 0:3].ravel()
    translations = translations[translations < model.n_dofs]
    written = []
    for k, mode in enumerate(found, start=1):
        phi = mode.shape / max(np.abs(mode.shape).max(), 1e-300)
        moved = np.abs(phi[translations]).max() if len(translations) else 0.0
        scale = MODE_AMPLITUDE * (length / moved if moved > 1e-6 else 1.0)
        writer = paraview.ParaviewWriter(folder / f"mode_{k:02d}", mesh, every=None)
        try:
            for j in range(MODE_FRAMES + 1):
                phase = j / MODE_FRAMES
                shifted = assembler.advance(state, scale * np.real(phi * np.exp(2j * np.pi * phase)))
                writer.record(phase, paraview.frame(assembler, mesh, shifted))
        finally:
            writer.close()
        written += [f"{paraview.PARAVIEW_DIR}/{MODES_DIR}/mode_{k:02d}/{name}" for name in
                    (Path(f).name for f in writer.files)]
    return written
