"""``run(scene)``: model → analysis → result files (SCENE.md, "Commands and results")."""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from . import __version__
from .analysis import modal_analysis, static_analysis
from .assembly import Assembler, State, free_velocity, initial_state, orthonormalize, pack, unpack_free
from .errors import SolverError
from .integrators import AlphaParameters, CentralDifference, GeneralizedAlpha, newton_diagnosis
from .kernels import load_kernels
from .model import Model
from .probes import SECTION_QUANTITIES, ProbeSet, section_forces
from .results import ResultWriter, progress_bar, state_labels
from .scene import Scene, load_scene


@dataclass
class Prepared:
    scene: Scene
    model: Model
    assembler: Assembler
    state: State


def prepare(scene, backend: str = "auto") -> Prepared:
    """Validate, build the model and refuse coordinates that nothing holds."""
    scene = load_scene(scene)
    model = Model.from_scene(scene)
    kernels = load_kernels(backend=backend, variant=scene.solve.formulation)
    assembler = Assembler(model, kernels, scene.gravity)
    state = initial_state(model)
    if 0 < model.n_dofs <= 3000:
        at_rest = state.copy()
        at_rest.v[:] = at_rest.w[:] = 0.0
        at_rest.theta_dot[:] = 0.0
        ev = assembler.evaluate(at_rest, matrices=True)
        model.check_held(ev.combined(1.0, 0.0, 0.0, dense=True), ev.combined(0.0, 0.0, 1.0, dense=True),
                         scene.file)
    return Prepared(scene, model, assembler, state)


def _length_scale(model: Model) -> float:
    points = np.array([n.position for n in model.nodes])
    span = float(np.ptp(points, axis=0).max()) if len(points) else 1.0
    return max(span, 1e-3)


def _mesh(model: Model, state: State) -> dict:
    """The ParaView parts (see latdyn.results): ``beams``, the grid points (one per model
    node and grid offset, shared by the elements that meet there) with the elements as
    lines; ``bodies``, every joint body as a vertex and a line from it to each grid point
    at an offset from it. Besides what the writer reads, each part keeps ``node`` and
    ``offset`` (r_g in node axes) of its points, their positions ``p0`` in ``state`` (t = 0)
    and its constant cell data."""
    ends = model.element_nodes.reshape(-1)
    offsets = model.element_offsets.reshape(-1, 3)
    _, first, inverse = np.unique(np.column_stack([ends, offsets]), axis=0, return_index=True,
                                  return_inverse=True)
    order = np.argsort(first)  # points in order of first use: a beam's points run start → end
    rank = np.empty_like(order)
    rank[order] = np.arange(len(order))
    node, offset = ends[first[order]], offsets[first[order]]
    beam_index = {name: i for i, name in enumerate(model.beam_elements)}

    def positions(nodes, r):
        return state.x[nodes] + np.einsum("nij,nj->ni", state.T[nodes], r)

    mesh = {"beams": {"n_points": len(node), "cells": [("line", rank[inverse.reshape(-1)].reshape(-1, 2))],
                      "node": node, "offset": offset, "p0": positions(node, offset),
                      "cell_data": {"beam": np.array([beam_index[b] for b in model.element_beam], dtype=np.int64)}}}
    names = list(model.body_node)
    if names:
        body_nodes = np.array([model.body_node[b] for b in names], dtype=np.int64)
        body_of_node = np.full(len(model.nodes), -1, dtype=np.int64)
        body_of_node[body_nodes] = np.arange(len(names))
        arm = (body_of_node[node] >= 0) & np.any(offset != 0.0, axis=1)
        n_b, n_c = len(names), int(arm.sum())
        points_node = np.concatenate([body_nodes, node[arm]])
        points_offset = np.concatenate([np.zeros((n_b, 3)), offset[arm]])
        cell_body = np.concatenate([np.arange(n_b), body_of_node[node[arm]]])
        mass = np.array([model.scene.bodies[b].mass for b in names], float)
        mesh["bodies"] = {
            "n_points": n_b + n_c,
            "cells": [("vertex", np.arange(n_b).reshape(-1, 1)),
                      ("line", np.column_stack([body_of_node[node[arm]], n_b + np.arange(n_c)]))],
            "node": points_node, "offset": points_offset, "p0": positions(points_node, points_offset),
            "cell_data": {"body": cell_body, "mass": np.concatenate([mass, np.zeros(n_c)]),
                          "kind": np.array([model.nodes[i].kind for i in body_nodes[cell_body]], dtype=np.int64)},
        }
    return mesh


def _grid_points(assembler: Assembler, mesh: dict, state: State) -> dict:
    """One ParaView frame of ``state`` for the parts of :func:`_mesh` (vectorized)."""
    frame = {}
    for name, part in mesh.items():
        nodes = part["node"]
        R = state.T[nodes]
        r = np.einsum("nij,nj->ni", R, part["offset"])  # T r_g
        points = state.x[nodes] + r
        point_data = {"displacement": points - part["p0"], "velocity": state.v[nodes] + np.cross(state.w[nodes], r)}
        cell_data = dict(part["cell_data"])
        if name == "beams":
            cell_data.update(zip(SECTION_QUANTITIES, section_forces(assembler, state).T))
        else:
            point_data.update(angular_velocity=state.w[nodes], axis_x=R[:, :, 0], axis_y=R[:, :, 1], axis_z=R[:, :, 2])
        frame[name] = {"points": points, "point_data": point_data, "cell_data": cell_data}
    return frame


def run(scene, out_dir=None, backend: str = "auto", progress: bool = False):
    """Solve a scene and write its results; returns a :class:`latdyn.results.Result`."""
    wall0 = time.perf_counter()
    prepared = prepare(scene, backend)
    scene, model = prepared.scene, prepared.model
    analysis = scene.solve.analysis
    probes = ProbeSet(prepared.assembler, prepared.state)
    first = "load_factor" if analysis == "static" else "t"
    meta = {"analysis": analysis, "title": scene.title, "coordinates": model.n_dofs,
            "elements": len(model.element_nodes), "backend": prepared.assembler.kernels.backend,
            "formulation": scene.solve.formulation}
    frames = None
    if analysis == "transient":
        every = scene.output.every or scene.solve.dt
        frames = int(np.ceil(scene.solve.t_end / every)) + 1
    writer = ResultWriter(out_dir, probes.names, first_column=first, mesh=_mesh(model, prepared.state), meta=meta,
                          labels=state_labels([n.name for n in model.nodes], [f"{h.beam}.{h.end}" for h in model.hinges]),
                          attributes={"nodes": [n.name for n in model.nodes],
                                      "hinges": [f"{h.beam}.{h.end}" for h in model.hinges],
                                      "coordinates": model.dof_names()},
                          max_frames=200, expected_frames=frames)
    summary = {"latdyn_version": __version__, "scene_hash": scene.source_hash, "steps": 0,
               "newton_iterations": 0, "rejected_steps": 0, "energy_balance_error": None}
    writer.summary.update(summary)
    with writer:
        if analysis == "modes":
            frequencies = modal_analysis(prepared, scene.solve.count)
            writer.write_modes(frequencies)
            writer.summary["modes_hz"] = [float(f) for f in frequencies]
        elif analysis == "static":
            static_analysis(prepared, probes, writer, _length_scale(model))
        else:
            transient(prepared, probes, writer, progress)
        writer.summary["wall_time_s"] = time.perf_counter() - wall0
        writer.close(dict(writer.summary), status="solved")
    result = writer.result()
    if analysis == "modes":
        result.modes = np.asarray(writer.summary.get("modes_hz", []))
    return result


def _drive_power(model: Model, state: State, reaction: np.ndarray) -> float:
    """Power of the constraint forces that impose prescribed motion."""
    velocities = pack(model, state.v, state.w, state.theta_dot)[model.n_dofs:model.n_total]
    return float(reaction @ velocities)


def _lock_tolerance(lock: float) -> float:
    return 1e-7 * max(1.0, abs(lock))


def _lock_events(model: Model, old: State, new: State) -> tuple[list[int], list[tuple[int, float]]]:
    """Free hinges with a lock_at, over the step old → new: those that reach it (started on
    it, or ended within tolerance), and those that cross it with the fraction of the step
    at the crossing (linear interpolation of the angle)."""
    reached, crossing = [], []
    for k in model.free_hinges:
        lock = model.hinges[k].lock_at
        if lock is None:
            continue
        before, after = old.theta[k] - lock, new.theta[k] - lock
        if before == 0.0 or abs(after) <= _lock_tolerance(lock):
            reached.append(k)
        elif before * after < 0.0:
            crossing.append((k, before / (before - after)))
    return reached, crossing


def _crossing_fraction(model: Model, old: State, new: State) -> float | None:
    """The fraction of the step at which the first hinge crosses its lock_at, or None."""
    _, crossing = _lock_events(model, old, new)
    return min(f for _, f in crossing) if crossing else None


def _latch_hinges(prepared: Prepared, integrator, old: State, new: State, h: float) -> bool:
    """Latch every free hinge whose angle crossed its lock_at during the step.

    The latch is a perfectly plastic impulsive constraint θ̇ = 0: the free
    velocities jump by the projection that conserves momentum,
    v⁺ = v⁻ − A⁻¹n (nᵀA⁻¹n)⁻¹ nᵀv⁻, with A = M + h²K (M alone may be singular).
    """
    model, assembler = prepared.model, prepared.assembler
    reached, crossing = _lock_events(model, old, new)
    latched = reached + [k for k, _ in crossing]
    if not latched:
        return False

    ev = assembler.evaluate(new, matrices=True)
    A = ev.combined(1.0, 0.0, h * h, dense=True)
    v = free_velocity(model, new)
    Nmat = np.zeros((model.n_dofs, len(latched)))
    for j, k in enumerate(latched):
        Nmat[model.hinge_dofs[k], j] = 1.0
    AiN = np.linalg.solve(A, Nmat)
    lam = np.linalg.solve(Nmat.T @ AiN, Nmat.T @ v)
    v = v - AiN @ lam
    unpack_free(model, v, new.v, new.w, new.theta_dot)
    # carry the algorithmic acceleration across the renumbering
    a_lin, a_ang, a_h = np.zeros_like(new.v), np.zeros_like(new.w), np.zeros_like(new.theta)
    unpack_free(model, integrator.a, a_lin, a_ang, a_h)
    for k in latched:
        model.locked[k] = True
        new.theta_dot[k] = new.theta_ddot[k] = 0.0
        a_h[k] = 0.0
    model.number_coordinates()
    assembler.reindex()
    integrator.a = pack(model, a_lin, a_ang, a_h)[: model.n_dofs]
    return True


def transient(prepared: Prepared, probes: ProbeSet, writer: ResultWriter, progress: bool) -> None:
    scene, model, assembler = prepared.scene, prepared.model, prepared.assembler
    solve = scene.solve
    length = _length_scale(model)
    tol = solve.tol if solve.tol is not None else 1e-9
    if solve.method == "explicit":
        integrator = CentralDifference(assembler, tol, solve.max_iterations, length)
    else:
        integrator = GeneralizedAlpha(assembler, AlphaParameters.for_method(solve.method, solve.rho_inf), tol,
                                      solve.max_iterations, length)
    state = prepared.state
    integrator.start(state)
    t_end, dt = float(solve.t_end), float(solve.dt)
    dt_min = solve.dt_min if solve.dt_min is not None else dt * 1e-6
    every = scene.output.every
    ev0 = assembler.evaluate(state, matrices=False)
    power = ev0.external_power + _drive_power(model, state, ev0.reaction)
    energy0 = assembler.energies(state)
    total0 = sum(energy0.values())
    balance_error, energy_scale = 0.0, max(abs(total0), 1e-300)

    def record(s: State, energies: dict | None = None) -> None:
        writer.record(s.t, probes.values(s, energies), state=s.as_dict(),
                      frame=lambda snapshot=s.copy(): _grid_points(assembler, writer.mesh, snapshot))

    record(state)
    next_output = (every if every else 0.0)
    h = dt
    steps = iterations = rejected = 0
    bar = progress_bar(t_end, enabled=progress)
    try:
        while state.t < t_end - 1e-12 * t_end:
            h = min(h, t_end - state.t)
            new, stats = integrator.step(state, h)
            accept = stats.converged
            if accept and solve.adaptive:
                error = integrator.error_estimate(h) / (solve.error_tol * length)
                if error > 1.0:
                    accept = False
                    iterations += stats.iterations
                    rejected += 1
                    h = max(h * max(0.2, 0.9 * error ** (-1 / 3)), dt_min)
                    continue
            iterations += stats.iterations
            if not accept:
                rejected += 1
                if h / 2 < dt_min:
                    raise SolverError("Newton failed below the minimum step",
                                      newton_diagnosis(model, stats.residual, state.t + h, h, assembler, state))
                h /= 2
                continue
            # a hinge reaching lock_at inside the step: shorten the step to land on it (secant, ≤ 4 passes)
            for _ in range(4):
                fraction = _crossing_fraction(model, state, new)
                if fraction is None:
                    break
                retry, retry_stats = integrator.step(state, h * max(fraction, 1e-6))
                if not retry_stats.converged:
                    break
                iterations += retry_stats.iterations
                new, stats, h = retry, retry_stats, h * max(fraction, 1e-6)
            integrator.accept()
            _latch_hinges(prepared, integrator, state, new, h)
            # power of loads and prescribed motion: from the last Newton evaluation
            # (within the Newton tolerance of the converged state) when there is one
            ev = getattr(integrator, "last_evaluation", None)
            if ev is None or len(ev.reaction) != model.n_total - model.n_dofs:
                ev = assembler.evaluate(new, matrices=False)
            new_power = ev.external_power + _drive_power(model, new, ev.reaction)
            probes.external_work += 0.5 * h * (power + new_power)
            power = new_power
            state = new
            steps += 1
            if steps % 256 == 0:  # exp updates keep T on SO(3) to round-off; remove the drift of long runs
                state.T[model.free_nodes] = orthonormalize(state.T[model.free_nodes])
            writer.summary.update(steps=steps, newton_iterations=iterations, rejected_steps=rejected)
            if every is None or state.t >= next_output - 1e-9 * dt:
                energies = assembler.energies(state)
                drift = abs(sum(energies.values()) - total0 - probes.external_work)
                energy_scale = max(energy_scale, abs(sum(energies.values())), abs(probes.external_work))
                balance_error = max(balance_error, drift)
                record(state, energies)
                if every:
                    while next_output <= state.t + 1e-9 * dt:
                        next_output += every
            bar.update(state.t)
            if solve.adaptive:
                error = integrator.error_estimate(h) / (solve.error_tol * length)
                h = min(dt, h * min(2.0, 0.9 * max(error, 1e-10) ** (-1 / 3)))
            elif stats.iterations and h < dt:
                h = min(dt, 2 * h)  # recover the nominal step after a cut
    finally:
        bar.close()
        writer.summary.update(steps=steps, newton_iterations=iterations, rejected_steps=rejected,
                              energy_balance_error=balance_error / energy_scale,
                              newton_iterations_per_step=iterations / max(steps, 1),
                              method=solve.method)
