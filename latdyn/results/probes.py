"""Probe values from a state (SCENE.md, ``output.probes``)."""
from __future__ import annotations

import numpy as np

from latdyn.assembly.assembler import Assembler, State
from latdyn.assembly.native_model import STATE_FIELDS
from latdyn.model.planar import section_moments_back
from latdyn.scene.loader import ELEMENT_QUANTITIES

_COMPONENT = {"x": 0, "y": 1, "z": 2}

#: the energies of a row, in the order of Assembler.energies and of the rows the loop records
ENERGIES = ("kinetic", "strain", "potential")

#: the columns of :func:`section_forces`, as spelled by ``{element: ..., quantity: ...}`` probes
#: the section forces a probe records, in the kernel's order (the scene's element probe quantities)
SECTION_QUANTITIES = ELEMENT_QUANTITIES


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
        #: the static path's load factor of the row being recorded (its loads, gravity and applied torques
        #: ramped: the joint forces' reactions at that λ); 1 in a transient
        self.load_factor = 1.0
        self._continuous = any(p.kind == "controller" and p.state is None  # a continuous controller's output
                               and not self.model.scene.controllers[p.controller].sampled for p in self.probes)
        self._need_cables = "cable" in kinds
        self._need_joint_forces = any(p.kind in ("hinge", "guide") and p.quantity in ("torque", "force")
                                      for p in self.probes)

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

        One evaluation of the equations of motion at ``state`` (``latdyn_joint_forces`` of
        csrc/rows.c, the same C that records them in a row of the loop of steps): the residual of the
        joint's coordinate is r = G + f, with f its law (spring, damper, applied torque or force: the
        generated ``hinge_force``, as the evaluation summed it, ``joint_forces`` of csrc/evaluate.c)
        and G all the rest (inertia, the structure, loads).

        - A free joint applies its law: −f.
        - A joint without a coordinate (prescribed, latched, stuck by friction, resting on its rigid
          stop: latdyn.timeloop.events.settle_on_stops) applies, besides its law, the reaction that
          holds it, the multiplier of its constraint: r (the residual of that coordinate's equation,
          the law in it). That is the value reported: the drive torque a prescribed angle needs, the
          load a latch carries, the load a stop holds.

        Where every joint is free and no continuous controller runs, the evaluation is of the joints'
        laws alone (the same values: a row of a truss with sprung hinges pays no element kernel for them)."""
        key = (id(state), float(state.t), state.theta.tobytes(), state.theta_dot.tobytes(), self.load_factor)
        if self._joint_forces is not None and self._joint_forces[0] == key:  # the same row's state
            return self._joint_forces[1]
        out = (self.assembler.native().joint_forces(state, self.load_factor) if len(self.model.hinges)
               else np.zeros(0))
        self._joint_forces = (key, out)
        return out

    @property
    def needs_controller_outputs(self) -> bool:
        """Whether the probes read a controller's output, recorded in each row of a loop of steps: a
        continuous one's evaluated at the row's state (``latdyn_controller_outputs_at``), a sampled one's
        as held there (the loop of steps samples on the way: latdyn.timeloop.sampling)."""
        return any(p.kind == "controller" and p.state is None for p in self.probes)

    @property
    def needs_controller_states(self) -> bool:
        """Whether the probes read a controller's state (recorded in each row: a continuous one's changes
        every step, a sampled one's at its samples on the way)."""
        return any(p.kind == "controller" and p.state is not None for p in self.probes)

    @property
    def needs(self) -> tuple[bool, bool]:
        """Whether the probes read the momenta, and the section forces."""
        return self._need_momentum, self._need_sections

    @property
    def needs_cables(self) -> bool:
        """Whether the probes read the cable elements' states."""
        return self._need_cables

    def values(self, state: State, energies: dict | None = None) -> list[float]:
        """Probe values in file order; ``energies`` may be passed when already computed."""
        self.assembler.complete_links(state)
        if energies is None and self._need_energy:
            energies = self.assembler.energies(state)
        energies = energies or {"kinetic": 0.0, "strain": 0.0, "potential": 0.0}
        momentum = np.concatenate(self.assembler.momentum(state))[None] if self._need_momentum else None
        sections = kernel_section_forces(self.assembler, state)[None] if self._need_sections else None
        joint_forces = self.joint_forces(state)[None] if self._need_joint_forces else None
        cable_states = self.assembler.native().cable_state(state)[None] if self._need_cables else None
        if self._continuous:  # the continuous controllers' outputs at this state, as a row in C has them
            self.assembler.native().controller_outputs_at(state)
        one = State(np.array([state.t]), *(np.asarray(getattr(state, name))[None] for name in STATE_FIELDS))
        out = self.rows(one, np.array([[energies["kinetic"], energies["strain"], energies["potential"]]]),
                        np.array([self.external_work]), np.array([self.dissipated]), momentum, sections,
                        joint_forces, cable_states)[0].tolist()
        return out

    def rows(self, states: State, energies: np.ndarray, external_work: np.ndarray, dissipated: np.ndarray,
             momentum: np.ndarray | None, sections: np.ndarray | None, joint_forces: np.ndarray | None,
             cable_states: np.ndarray | None, controller_states: np.ndarray | None = None,
             controller_outputs: np.ndarray | None = None) -> np.ndarray:
        """Probe values of k rows, (k, probes) in file order: ``states`` the rows' state arrays with a
        leading row axis (:meth:`_point`), ``energies`` (k, 3) kinetic, strain, potential, the external
        work and dissipated energy (k,), ``momentum`` (k, 6) [P, H] and ``sections`` (k, n_elements, 4)
        as the strain-energy kernel gives them, ``joint_forces`` (k, joints) as :meth:`joint_forces`
        gives them and ``cable_states`` (k, cable elements, 5) as
        :meth:`latdyn.assembly.native_model.NativeModel.cable_state` gives them, where the probes read
        them, and ``controller_states`` (k, the scene's controller states) and ``controller_outputs`` (k,
        the scene's controller outputs) where recorded in the row (else the scene's as they are now:
        :meth:`values` evaluates the continuous controllers' outputs at its state first)."""
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
                    out[:, i] = joint_forces[:, j]
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
            elif p.kind == "controller":
                scene = m.scene
                if p.state is None:
                    out[:, i] = (scene.controller_outputs[p.controller] if controller_outputs is None
                                 else controller_outputs[:, scene.controller_outputs.index(p.controller)])
                else:
                    name = f"{p.controller}.{p.state}"
                    out[:, i] = (scene.controller_states[name] if controller_states is None
                                 else controller_states[:, scene.controller_states.index(name)])
            elif p.kind == "cable":
                out[:, i] = [cable_value(m.cables, cable_states[r], p.beam, p.quantity) for r in range(k)]
            else:  # pragma: no cover - the scene validator refuses other kinds
                raise ValueError(p.kind)
        return out


def _turned(T: np.ndarray, r: np.ndarray) -> np.ndarray:
    """T r over the last two axes of T (any leading axes), as elementwise sums (the same rounding for
    one row as for a block)."""
    return (T * r[..., None, :]).sum(axis=-1)


def _turned_back(T: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tᵀ v over the last two axes of T (any leading axes)."""
    return (T * v[..., :, None]).sum(axis=-2)
