"""Probe values from a state (SCENE.md, ``output.probes``)."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import Assembler, State
from latdyn.assembly.native_model import STATE_FIELDS
from latdyn.model.model import lock_tolerance
from latdyn.model.planar import section_moments_back

_COMPONENT = {"x": 0, "y": 1, "z": 2}

#: the energies of a row, in the order of Assembler.energies and of the rows the loop records
ENERGIES = ("kinetic", "strain", "potential")

#: the columns of :func:`section_forces`, as spelled by ``{element: ..., quantity: ...}`` probes
SECTION_QUANTITIES = ("axial_force", "torque", "moment_y", "moment_z")


def cable_value(cables, state: np.ndarray, name: str, quantity: str) -> float:
    """A ``{cable: NAME, quantity: tension|length}`` probe from the cable elements' [ℓ, ℓ̇, ℓ − L0,
    N_el, N] (``state``, :meth:`latdyn.assembly.native_model.NativeModel.cable_state`): the tension N of
    its first element (0 while slack), or its length along the cable, Σ ℓ over its elements."""
    k = cables.names.index(name)
    elements = cables.cable == k
    if quantity == "tension":
        return float(state[cables.first[k], 4])
    return float(state[elements, 0].sum())


def section_forces(assembler: Assembler, state: State, geometry: np.ndarray | None = None,
                   kernel_sections: np.ndarray | None = None) -> np.ndarray:
    """Mid-element section forces of every element, shape (n_elem, 4), columns
    :data:`SECTION_QUANTITIES`; ``geometry`` may be passed when already computed, or the
    strain-energy kernel's section forces ``kernel_sections`` (a row recorded where the step runs)."""
    sections = kernel_section_forces(assembler, state, geometry) if kernel_sections is None else kernel_sections
    return section_moments_back(assembler.model, sections)  # a planar model turned some sections


def kernel_section_forces(assembler: Assembler, state: State, geometry: np.ndarray | None = None) -> np.ndarray:
    """The strain-energy kernel's mid-element section forces at ``state``, (n_elem, 4), in the
    sections' own axes (before :func:`section_moments_back`; what the rows recorded in the loop of
    steps hold)."""
    if geometry is None:
        geometry = assembler.element_geometry(state)
    return assembler.kernels.beam_strain_energy(geometry, assembler.model.element_sections)[1]


class ProbeSet:
    """Evaluates the scene's probes; expensive groups (energies, momentum) once per call."""

    def __init__(self, assembler: Assembler, initial: State):
        self.assembler = assembler
        self.model = assembler.model
        self.probes = self.model.scene.output.probes
        self.names = [p.name for p in self.probes]
        self.initial = initial.copy()
        self.external_work = 0.0
        self.dissipated = 0.0  # declared dissipation so far (the time loop's, docs/energy.md)
        kinds = {p.kind for p in self.probes}
        self._need_energy = "energy" in kinds
        self._need_momentum = "momentum" in kinds
        self._need_sections = "element" in kinds
        self._joint_forces = None  # (key of the state, forces) of the last call of joint_forces
        self._continuous = any(p.kind == "controller" and not self.model.scene.controllers[p.controller].sampled
                               for p in self.probes)
        self._need_cables = "cable" in kinds

    def _point(self, probe, states: State) -> np.ndarray:
        """A point probe at every row of ``states`` (state arrays with a leading row axis: x (k, n, 3),
        T (k, n, 3, 3), …): (k,) values. The same arithmetic for one row as for a block, so that rows
        recorded in the loop of steps equal those recorded one by one."""
        m = self.model
        node, r = m.point(probe.point)
        offset = _turned(states.T[:, node], r)
        p = states.x[:, node] + offset
        if probe.quantity == "velocity":
            value = states.v[:, node] + np.cross(states.w[:, node], offset)
        else:
            value = p
        if probe.frame != "global":
            b = m.body_node[probe.frame]
            R, xb = states.T[:, b], states.x[:, b]
            if probe.quantity == "velocity":
                value = _turned_back(R, value - states.v[:, b] - np.cross(states.w[:, b], p - xb))
            else:
                value = _turned_back(R, p - xb)
                if probe.quantity == "displacement":
                    b0 = self.initial
                    p0 = b0.x[node] + _turned(b0.T[node], r)
                    value = value - _turned_back(b0.T[b], p0 - b0.x[b])
        elif probe.quantity == "displacement":
            value = value - (self.initial.x[node] + _turned(self.initial.T[node], r))
        if probe.component == "norm" or probe.component is None:
            return np.sqrt((value * value).sum(axis=-1))
        return value[:, _COMPONENT[probe.component]]

    def joint_forces(self, state: State) -> np.ndarray:
        """The generalized force each joint (hinge or guide, in model order) applies on its coordinate,
        positive when it drives θ or s up (SCENE.md, the joint probes ``torque``/``force``).

        One evaluation of the equations of motion at ``state``: the residual of the joint's
        coordinate is r = G + f, with f its law (spring, damper, applied torque or force: the
        generated ``hinge_force``, as the evaluation summed it, ``joint_forces`` of
        csrc/evaluate.c) and G all the rest (inertia, the structure, loads).

        - A free joint applies its law: −f.
        - A joint without a coordinate (prescribed, latched) applies, besides its law, the reaction
          that holds it, the multiplier of its constraint: r (the residual of that coordinate's
          equation, the law in it). That is the value reported: the drive torque a prescribed angle
          needs, the load a latch carries.
        - A free joint resting on a rigid stop (on it within the events' tolerance and not moving
          away) is held by the stop when, unheld, it would accelerate into it: then the stop's
          reaction is reported, r with the joint's own acceleration zero (the other accelerations as
          the step left them); otherwise −f."""
        key = (id(state), float(state.t), state.theta.tobytes(), state.theta_dot.tobytes())
        if self._joint_forces is not None and self._joint_forces[0] == key:  # the same row's state
            return self._joint_forces[1]
        m, assembler = self.model, self.assembler
        out = np.zeros(len(m.hinges))
        if not len(out):
            return out
        resting = [k for k in m.free_hinges if _on_stop(m.hinges[k], state, int(k))]
        held = state
        if resting:
            held = state.copy()
            held.theta_ddot[resting] = 0.0
        ev = assembler.evaluate(held, matrices=False)
        f = assembler.native().buffers["joint_forces"].copy()
        n = m.n_dofs
        for k in range(len(out)):
            d = int(m.hinge_dofs[k])
            out[k] = 0.0 - f[k] if d < n else float(ev.reaction[d - n])  # 0.0 − f: no −0.0
        for k in resting:
            side = _on_stop(m.hinges[k], state, int(k))
            held_by_stop = float(ev.residual[m.hinge_dofs[k]])  # r at θ̈ = 0
            if side * held_by_stop < 0.0:  # unheld it would accelerate into the stop: the stop holds it
                out[k] = held_by_stop
        self._joint_forces = (key, out)
        return out

    @property
    def rows_in_loop(self) -> bool:
        """Whether the loop of steps may record this scene's rows where it runs (:meth:`rows`): every
        probe but a controller's (whose values are those of the laws at the row, which only the
        evaluation of that row's step holds)."""
        return not any(p.kind == "controller" for p in self.probes)

    @property
    def needs(self) -> tuple[bool, bool]:
        """Whether the probes read the momenta, and the section forces."""
        return self._need_momentum, self._need_sections

    def values(self, state: State, energies: dict | None = None) -> list[float]:
        """Probe values in file order; ``energies`` may be passed when already computed."""
        self.assembler.complete_links(state)
        if energies is None and self._need_energy:
            energies = self.assembler.energies(state)
        energies = energies or {"kinetic": 0.0, "strain": 0.0, "potential": 0.0}
        momentum = np.concatenate(self.assembler.momentum(state))[None] if self._need_momentum else None
        sections = kernel_section_forces(self.assembler, state)[None] if self._need_sections else None
        one = State(np.array([state.t]), *(np.asarray(getattr(state, name))[None] for name in STATE_FIELDS))
        out = self.rows(one, np.array([[energies["kinetic"], energies["strain"], energies["potential"]]]),
                        np.array([self.external_work]), np.array([self.dissipated]), momentum, sections,
                        lambda r: state)[0].tolist()
        if self._continuous:
            self._continuous_outputs(state, out)
        return out

    def rows(self, states: State, energies: np.ndarray, external_work: np.ndarray, dissipated: np.ndarray,
             momentum: np.ndarray | None, sections: np.ndarray | None, state_of) -> np.ndarray:
        """Probe values of k rows, (k, probes) in file order: ``states`` the rows' state arrays with a
        leading row axis (:meth:`_point`), ``energies`` (k, 3) kinetic, strain, potential, the external
        work and dissipated energy (k,), ``momentum`` (k, 6) [P, H] and ``sections`` (k, n_elements, 4)
        as the strain-energy kernel gives them, where the probes read them; ``state_of(r)`` row r's
        :class:`State`, for the probes evaluated at one state (joint forces, cables). A continuous
        controller's output is :meth:`values`'s."""
        m = self.model
        k = len(states.t)
        out = np.empty((k, len(self.probes)))
        if sections is not None:
            sections = section_moments_back(m, sections)  # a planar model turned some sections
        for i, p in enumerate(self.probes):
            if p.kind == "point":
                out[:, i] = self._point(p, states)
            elif p.kind in ("hinge", "guide"):
                j = m.hinge_index(p.beam, p.end) if p.kind == "hinge" else m.hinge_index(p.body, "guide")
                if p.quantity in ("angle", "position"):
                    out[:, i] = states.theta[:, j]
                elif p.quantity == "rate":
                    out[:, i] = states.theta_dot[:, j]
                else:  # torque | force
                    out[:, i] = [self.joint_forces(state_of(r))[j] for r in range(k)]
            elif p.kind == "energy":
                kind = p.quantity
                if kind == "external_work":
                    out[:, i] = external_work
                elif kind == "dissipated":
                    out[:, i] = dissipated
                elif kind == "total":
                    out[:, i] = energies[:, 0] + energies[:, 1] + energies[:, 2]
                else:
                    out[:, i] = energies[:, ENERGIES.index(kind)]
            elif p.kind == "momentum":
                out[:, i] = momentum[:, _COMPONENT[p.component] + (0 if p.quantity == "linear" else 3)]
            elif p.kind == "element":
                e = int(m.beam_elements[p.beam][p.element])
                out[:, i] = sections[:, e, SECTION_QUANTITIES.index(p.quantity)]
            elif p.kind == "controller":  # a sampled one's held output or a state; a continuous one's: values
                scene = m.scene
                out[:, i] = (scene.controller_outputs[p.controller] if p.state is None
                             else scene.controller_states[f"{p.controller}.{p.state}"])
            elif p.kind == "cable":
                native = self.assembler.native()
                out[:, i] = [cable_value(m.cables, native.cable_state(state_of(r)), p.beam, p.quantity)
                             for r in range(k)]
            else:  # pragma: no cover - the scene validator refuses other kinds
                raise ValueError(p.kind)
        return out

    def _continuous_outputs(self, state: State, out: list) -> None:
        """The outputs of continuous controllers at ``state``, from the values of the probes they read
        (the expression the compiled evaluation uses, here in Python; clipped to its limits)."""
        scene = self.model.scene
        values = dict(zip(self.names, out))
        computed = {}  # in file order: a controller reads the continuous ones before it at this state
        recording = {p.name: p.controller for p in self.probes if p.kind == "controller" and p.state is None
                     and not scene.controllers[p.controller].sampled}  # a probe of one: its output
        for c in scene.controllers.values():
            if c.sampled:
                continue
            read = [computed[n] if n in computed else computed[recording[n]] if n in recording
                    else values[n] if n in values else scene.inputs[n] if n in scene.inputs
                    else scene.controller_outputs[n] for n in c.reads]
            own = [scene.controller_states[f"{c.name}.{s}"] for s in c.states]  # S at the accepted state
            computed[c.name] = c.clip(float(c.functions()[0](float(state.t), *read, *own)))
        for i, p in enumerate(self.probes):
            if p.kind == "controller" and p.state is None and p.controller in computed:
                out[i] = computed[p.controller]


def _turned(T: np.ndarray, r: np.ndarray) -> np.ndarray:
    """T r over the last two axes of T (any leading axes), as elementwise sums (the same rounding for
    one row as for a block)."""
    return (T * r[..., None, :]).sum(axis=-1)


def _turned_back(T: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tᵀ v over the last two axes of T (any leading axes)."""
    return (T * v[..., :, None]).sum(axis=-2)


def _on_stop(joint, state: State, k: int) -> int:
    """+1 (−1) when joint ``k`` rests on its upper (lower) rigid stop: on it within the events'
    tolerance and not moving away; 0 otherwise."""
    if joint.limits is None:
        return 0
    for side, stop in ((-1, joint.limits[0]), (1, joint.limits[1])):
        tolerance = lock_tolerance(stop)
        if abs(state.theta[k] - stop) <= tolerance and side * state.theta_dot[k] >= -tolerance:
            return side
    return 0
