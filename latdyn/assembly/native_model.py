"""The model as the runtime's C library reads it, and the one evaluation of its equations of motion.

:class:`NativeModel` lays a :class:`~latdyn.model.model.Model` out as the ``Model`` and ``Work``
structs of ``csrc/evaluate.c`` (mirrored in :mod:`latdyn.assembly.library`) for one numbering of
the coordinates: index arrays, the sections, the addresses of the generated kernels, and the
scene's laws — compiled by the code generator (:mod:`latdyn.assembly.compiled_laws`), or, where a
law does not print in C, Python callbacks that the C code calls in their place, so that every
scene evaluates natively. :meth:`NativeModel.evaluate` is ``latdyn_evaluate``: residual and
reactions, the power of loads and hinge torques, and the element, body, hinge and load blocks of
K, M and C, each in its own Work buffer; :class:`latdyn.assembly.assembler.Assembler` turns them
into an :class:`~latdyn.assembly.evaluation.Evaluation`. :meth:`NativeModel.advance_free` and
:meth:`NativeModel.prescribe` are the configuration update q ∘ exp(Δ) and the prescribed motion
(``latdyn_advance_free``, ``latdyn_prescribe``), the Newton step's own. The compiled step
(:mod:`latdyn.step.compiled`) adds the iteration matrix's storage (:meth:`NativeModel.hold_matrix`)
and steps on the same structs.
"""
from __future__ import annotations

import contextlib
import ctypes

import numpy as np

from latdyn.assembly.compiled_laws import LawsUnavailable, compile_laws, unprintable
from latdyn.assembly.control import BODY_VELOCITY, CABLE_TENSION, SECTION_FORCE
from latdyn.assembly.library import (
    ConfigurationData,
    HINGE_LAW_VALUES,
    EvaluationData,
    ModelData,
    WorkData,
    native_library,
    parallel_threshold,
)
from latdyn.assembly.native_links import native_links
from latdyn.model.cables import cable_tolerance
from latdyn.model.model import lock_tolerance

#: The arrays of a state, in the order of the C ``Configuration``.
STATE_FIELDS = ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")


def state_shapes(model) -> dict[str, tuple]:
    """The shape of each of a state's arrays (:data:`STATE_FIELDS`) for ``model``."""
    N, H = len(model.nodes), len(model.hinges)
    return {"x": (N, 3), "T": (N, 3, 3), "v": (N, 3), "w": (N, 3), "a": (N, 3), "alpha": (N, 3),
            "theta": (H,), "theta_dot": (H,), "theta_ddot": (H,)}

_TIME_LAWS = ctypes.CFUNCTYPE(None, ctypes.c_double, ctypes.POINTER(ctypes.c_double))
_HINGE_LAWS = HINGE_LAW_VALUES
_CONTROLLER_LAWS = ctypes.CFUNCTYPE(None, ctypes.c_int64, ctypes.c_double, ctypes.POINTER(ctypes.c_double),
                                    ctypes.POINTER(ctypes.c_double))


def hinge_coefficients(hinges):
    """(k, c, θ_r) of every hinge as arrays (0 where a law gives them), and the hinges whose force
    needs their laws (a stiffness or damping that varies, a torque in θ or θ̇)."""
    def plain(h):
        torque_of_t = h.torque is None or set(h.torque.depends_on) <= {"t"}
        return h.stiffness.is_constant and h.damping.is_constant and torque_of_t

    flags = [plain(h) for h in hinges]
    k0 = np.array([h.stiffness.constant if f else 0.0 for h, f in zip(hinges, flags)], float)
    c0 = np.array([h.damping.constant if f else 0.0 for h, f in zip(hinges, flags)], float)
    rest = np.array([h.rest_angle for h in hinges], float)
    return k0, c0, rest, [k for k, f in enumerate(flags) if not f]


#: the ``contact`` input of the generated hinge_force for a joint without compliant stops or friction
#: (:func:`joint_contact_rows`): its force is then the laws' alone
NO_CONTACT = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1.0])


def joint_contact_rows(hinges) -> np.ndarray:
    """(n_hinges, 11): the ``contact`` input of the generated hinge_force (codegen/joints.py
    ``joint_contact``) of each joint: lower upper k n c (its compliant stops; zeros without),
    F_c F_s 1/v_s [v_s > 0] c_v v₀ (its friction; zeros with v₀ = 1 without: :data:`NO_CONTACT`)."""
    rows = np.tile(NO_CONTACT, (len(hinges), 1))
    for row, h in zip(rows, hinges):
        if h.contact is not None:
            row[0:5] = (*h.limits, h.contact.stiffness, h.contact.exponent, h.contact.damping)
        f = h.friction
        if f is not None:
            smooth = f.stribeck_rate > 0.0
            row[5:11] = (f.coulomb, f.static, 1.0 / f.stribeck_rate if smooth else 0.0, float(smooth), f.viscous,
                         f.stick_rate)
    return rows


class SceneLaws:
    """The scene's functions of time and hinge laws, numbered as the C code reads them: every
    function of time gives (value, rate, acceleration) at t, hinge law k gives (f, ∂f/∂θ, ∂f/∂θ̇)
    at (θ, θ̇, t). :meth:`addresses` compiles them (once per text, cached) or, when a law does not
    print in C or there is no compiler, returns Python callbacks with the same signature.
    ``inputs``, ``controllers``: the scene's :class:`~latdyn.scene.inputs.Inputs` and
    :class:`~latdyn.scene.inputs.ControllerOutputs`, whose values the laws read (:meth:`bind_inputs`)."""

    def __init__(self, inputs=None, controllers=None):
        from latdyn.scene.inputs import Signals

        self.functions, self.hinge_laws = [], []
        #: continuous controllers and the probes each reads (latdyn.assembly.control.Wiring)
        self.controller_laws: list[tuple] = []
        #: sampled controllers and the probes each reads (Wiring.sampled, sampled_sensor_names)
        self.sampled_laws: list[tuple] = []
        self.inputs = inputs if inputs is not None else Signals()
        self.controllers = controllers if controllers is not None else Signals()
        self.reason = None  # why the laws are Python callbacks, or None when compiled
        self._keep = None
        self._compiled = None

    @property
    def signal_names(self) -> tuple:
        """The names of the scene's inputs and of its controllers."""
        return self.inputs.names, self.controllers.names

    def bind_inputs(self) -> None:
        """Point the compiled laws at this scene's inputs and controller outputs (a library is shared
        by the models with the same laws in a process); nothing to do for Python callbacks, which
        read them."""
        if self._compiled is not None and (len(self.inputs) or len(self.controllers)):
            self._compiled.bind_inputs(self.inputs.values, self.controllers.values)

    def add(self, function) -> int:
        if function is None:
            return -1
        self.functions.append(function)
        return len(self.functions) - 1

    def add_hinge_law(self, law) -> int:
        self.hinge_laws.append(law)
        return len(self.hinge_laws) - 1

    def at(self, t: float) -> np.ndarray:
        out = np.zeros((max(len(self.functions), 1), 3))
        for k, f in enumerate(self.functions):
            if hasattr(f, "rate"):  # a TimeFunction
                out[k] = f.value(t), f.rate(t), f.accel(t)
            else:  # a hinge torque law of t alone
                out[k, 0] = f.value(0.0, 0.0, t)
        return out

    def addresses(self) -> tuple[int, int, int, int]:
        """The addresses of ``time_laws(t, out)``, ``hinge_laws(k, θ, θ̇, t, out)``,
        ``controller_laws(k, t, s, out)`` and ``sampled_laws(k, t, s, out)``."""
        why = unprintable(self.hinge_laws, self.signal_names) if self.hinge_laws else None
        if why is None:
            try:
                compiled = compile_laws(self.functions, self.hinge_laws, self.signal_names, self.controller_laws,
                                        self.sampled_laws)
                self._keep = self._compiled = compiled
                self.bind_inputs()
                return compiled.time_laws, compiled.hinge_laws, compiled.controller_laws, compiled.sampled_laws
            except LawsUnavailable as error:
                why = str(error)
        self.reason = why
        n = max(len(self.functions), 1)

        def time_laws(t, out):
            np.ctypeslib.as_array(out, (n, 3))[:] = self.at(t)

        def hinge_laws(k, theta, rate, t, out):
            law = self.hinge_laws[k]
            out[0], out[1], out[2] = law.value(theta, rate, t), law.d_theta(theta, rate, t), law.d_rate(theta, rate, t)

        controllers = [self._python_controller(c, sensors) for c, sensors in self.controller_laws]
        sampled = [self._python_controller(c, sensors, sampled=True) for c, sensors in self.sampled_laws]

        def laws_of(functions):
            def laws(k, t, s, out):
                function, n = functions[k]
                values = function(t, *(s[i] for i in range(n)))
                for i, value in enumerate(values):
                    out[i] = value
            return laws

        callbacks = (_TIME_LAWS(time_laws), _HINGE_LAWS(hinge_laws), _CONTROLLER_LAWS(laws_of(controllers)),
                     _CONTROLLER_LAWS(laws_of(sampled)))
        self._keep = callbacks
        return tuple(ctypes.cast(c, ctypes.c_void_p).value for c in callbacks)

    def _python_controller(self, controller, sensors, sampled: bool = False):
        """Controller law in Python (where the laws do not print in C): (f(t, *s) -> [y, ∂y/∂s…] of a
        continuous one, [y, rates…] of a sampled one, len(s))."""
        import sympy as sp

        from latdyn.assembly.compiled_laws import controller_law, sampled_law

        law = (sampled_law if sampled else controller_law)(controller, sensors)
        signals = sorted({s for e in law.expressions for s in sp.sympify(e).free_symbols} - set(law.variables),
                         key=lambda s: s.name)
        functions = [sp.lambdify([*law.variables, *signals], e, modules="math") for e in law.expressions]

        def evaluate(t, *s):
            read = [self.inputs[x.name] if x.name in self.inputs else self.controllers[x.name] for x in signals]
            return [float(f(t, *s, *read)) for f in functions]

        return evaluate, len(sensors) + len(controller.states)


def has_gravity_tangent(kernels) -> bool:
    """Whether ``kernels`` (a variant's KernelSet) hold ``beam_gravity_D_q``, the gravity load's exact
    tangent that the static Newton matrix K − λ ∂Q/∂q needs (a variant generated before it has not)."""
    return "beam_gravity_D_q" in (getattr(kernels, "libraries", None) or {})


def _kernel_address(kernels, name: str) -> int:
    return ctypes.cast(getattr(kernels.library(name), name), ctypes.c_void_p).value


class NativeModel:
    """One numbering of a model's coordinates as the C library's structs (module docstring).
    ``inertia_tangent``: with the buffers of the elements' inertia tangent."""

    def __init__(self, assembler, inertia_tangent: bool = False):
        model, kernels = assembler.model, assembler.kernels
        if getattr(kernels, "backend", None) != "c" or not getattr(kernels, "libraries", None):
            raise RuntimeError("the runtime evaluates with the compiled kernels; these are "
                               f"{getattr(kernels, 'backend', type(kernels).__name__)!r}")
        self.library = native_library()
        self.model_key = (model.n_dofs, model.locked.tobytes())
        self.has_inertia_tangent = inertia_tangent
        self._keep = []
        m, a = model, assembler
        arr, ints = self._array, lambda values: self._array(values, np.int64)

        laws = SceneLaws(getattr(m.scene, "inputs", None), getattr(m.scene, "controller_outputs", None))
        prescribed = m.prescribed_nodes()
        translation, angle, axis = [], [], []
        for i in prescribed:
            body = m.scene.bodies[m.nodes[i].body]
            translation.append([laws.add(g) for g in body.translation] if body.translation is not None
                               else [-1, -1, -1])
            angle.append(laws.add(body.rotation_angle))
            axis.append(np.asarray(body.rotation_axis, float) if body.rotation_angle is not None else np.zeros(3))
        hinge_angle = [laws.add(h.angle) for h in m.hinges]
        # hinge forces: constant springs and dampers, with a torque of t among the laws of time; the
        # other hinges' stiffness, damping and torque as hinge laws
        stiffness, damping, rest, with_law = hinge_coefficients(m.hinges)
        H = len(m.hinges)
        stiffness_law, damping_law, torque_hinge_law = [-1] * H, [-1] * H, [-1] * H
        for j in with_law:
            h = m.hinges[j]
            stiffness_law[j], damping_law[j] = laws.add_hinge_law(h.stiffness), laws.add_hinge_law(h.damping)
            if h.torque is not None:
                torque_hinge_law[j] = laws.add_hinge_law(h.torque)
        torque = [-1 if j in with_law else laws.add(h.torque) for j, h in enumerate(m.hinges)]
        force_law = [[laws.add(g) for g in load.force] if load.force else [-1, -1, -1] for load in a.loads]
        moment_law = [[laws.add(g) for g in load.moment] if load.moment else [-1, -1, -1] for load in a.loads]
        frame_node = [-1 if load.frame == "global" else node for load, node in zip(a.loads, a._load_frames)]
        cables = m.cables
        rest_law = [laws.add(f) for f in cables.rest_length] if cables is not None else []
        wired = a.control
        laws.controller_laws = [(c, wired.sensor_names(k)) for k, c in enumerate(wired.controllers)]
        laws.sampled_laws = [(c, wired.sampled_sensor_names(k)) for k, c in enumerate(wired.sampled)]
        time_laws, hinge_laws, controller_laws, sampled_laws = laws.addresses()
        #: the sampled controllers' sensors whose values the caller hands in (sample), (sensor, probe)
        self.provided = wired.provided
        self.laws = laws
        outputs = laws.controllers.values  # the array the compiled laws read, written by the C evaluation

        lock_at = [np.nan if h.lock_at is None else float(h.lock_at) for h in m.hinges]
        lower = [np.nan if h.limits is None else float(h.limits[0]) for h in m.hinges]
        upper = [np.nan if h.limits is None else float(h.limits[1]) for h in m.hinges]
        #: the tolerance of each hinge's lock_at, lower and upper stop, 0 where none (lock_tolerance, once)
        event_tolerance = [[0.0 if np.isnan(at) else lock_tolerance(at) for at in ats] for ats in zip(lock_at, lower, upper)]
        # the hinged_end kernel's input of each element end (e, 2, 16): hinge axis, grid point,
        # element axes at t = 0 (node axes), and the hinge angle, filled in by the C code
        element_ends = np.concatenate([m.element_axes, m.element_offsets, m.element_frames0.reshape(-1, 2, 9),
                                       np.zeros(m.element_axes.shape[:2] + (1,))], axis=2)
        body_section = np.concatenate([m.body_mass[:, None], m.body_com, m.body_inertia.reshape(-1, 9)], axis=1)
        E, B, L, N = len(m.element_nodes), len(m.body_nodes), len(a.loads), len(m.nodes)
        # beam_gravity_D_q: None (C's NULL, the gravity tangent left out) in a variant generated before it
        kernel = {"beam_gravity_D_q": _kernel_address(kernels, "beam_gravity_D_q") if has_gravity_tangent(kernels)
                  else None}
        kernel.update({name: _kernel_address(kernels, name) for name in (
            "beam_internal_force", "beam_internal_force_D_q", "beam_mass_matrix", "beam_quadratic_velocity",
            "beam_quadratic_velocity_D_qdot", "beam_gravity", "beam_strain_energy", "beam_kinetic_energy",
            "joint_body", "point_load", "hinged_end", "hinge_force", "so3_exp", "so3_dexp", "so3_log_increment",
            "cable_force")})
        # compiled on first use (latdyn.model.kernels.ON_DEMAND): only for a model that evaluates the inertia tangent
        kernel["beam_inertia_tangent"] = _kernel_address(kernels, "beam_inertia_tangent") if inertia_tangent else None
        CE = len(cables) if cables is not None else 0
        self.model = ModelData(
            n_nodes=N, n_hinges=H, n_elements=E, n_bodies=B, n_loads=L, n_dofs=m.n_dofs, n_total=m.n_total,
            node_dofs=ints(m.node_dofs), hinge_dofs=ints(m.hinge_dofs),
            n_free_nodes=len(m.free_nodes), n_free_hinges=len(m.free_hinges),
            free_nodes=ints(m.free_nodes), free_hinges=ints(m.free_hinges),
            n_prescribed=len(prescribed), prescribed_nodes=ints(prescribed),
            translation_law=ints(np.array(translation, np.int64).reshape(-1, 3)), angle_law=ints(angle),
            rotation_axis=arr(np.array(axis).reshape(-1, 3)),
            node_x0=arr(np.array([nd.position for nd in m.nodes], float).reshape(-1, 3)),
            hinge_angle_law=ints(hinge_angle), hinge_locked=ints(np.asarray(m.locked, np.int64)),
            element_nodes=ints(m.element_nodes), element_hinges=ints(m.element_hinges),
            element_dofs=ints(m.element_dofs), element_axes=arr(m.element_axes),
            element_frames0=arr(m.element_frames0), element_offsets=arr(m.element_offsets),
            element_sections=arr(m.element_sections),
            body_nodes=ints(m.body_nodes), body_mass=arr(m.body_mass), body_com=arr(m.body_com),
            body_inertia=arr(m.body_inertia),
            hinge_stiffness=arr(stiffness), hinge_damping=arr(damping), hinge_rest_angle=arr(rest),
            hinge_torque_law=ints(torque),
            load_node=ints(a._load_nodes), load_force_law=ints(np.array(force_law, np.int64).reshape(-1, 3)),
            load_moment_law=ints(np.array(moment_law, np.int64).reshape(-1, 3)), load_frame_node=ints(frame_node),
            load_r=arr(a._load_offsets),
            gravity=(ctypes.c_double * 3)(*a.gravity), has_gravity=int(a.has_gravity),
            internal_force=kernel["beam_internal_force"], internal_force_D_q=kernel["beam_internal_force_D_q"],
            mass_matrix=kernel["beam_mass_matrix"], quadratic_velocity=kernel["beam_quadratic_velocity"],
            quadratic_velocity_D_qdot=kernel["beam_quadratic_velocity_D_qdot"], gravity_load=kernel["beam_gravity"],
            strain_energy=kernel["beam_strain_energy"], kinetic_energy=kernel["beam_kinetic_energy"],
            inertia_force_D_q=kernel["beam_inertia_tangent"],
            joint_body=kernel["joint_body"], point_load=kernel["point_load"], body_section=arr(body_section),
            hinged_end=kernel["hinged_end"], element_ends=arr(element_ends), hinge_force=kernel["hinge_force"],
            so3_exp=kernel["so3_exp"], so3_dexp=kernel["so3_dexp"], so3_log_increment=kernel["so3_log_increment"],
            parallel_elements=parallel_threshold(), threads=0,
            time_laws=time_laws, hinge_laws=hinge_laws,
            hinge_stiffness_law=ints(stiffness_law), hinge_damping_law=ints(damping_law),
            hinge_torque_hinge_law=ints(torque_hinge_law),
            hinge_conservative=ints([int(h.conservative_spring) for h in m.hinges]),
            hinge_lock_at=arr(lock_at), hinge_lower_stop=arr(lower), hinge_upper_stop=arr(upper),
            hinge_event_tolerance=arr(np.array(event_tolerance, float).reshape(-1, 3)),
            has_events=int(CE > 0 or any(m.hinges[k].lock_at is not None or m.hinges[k].limits is not None
                                         or m.hinges[k].friction is not None for k in m.free_hinges)),
            section_width=m.element_sections.shape[1],
            n_controllers=wired.n, n_sensors=wired.n_sensors, n_actuators=len(wired.actuator_kind),
            n_couplings=len(wired.coupling_actuator), controller_laws=controller_laws,
            controller_outputs=outputs.ctypes.data, controller_slot=ints(wired.slots),
            controller_limits=arr(wired.limits.reshape(-1, 2)), sensor_start=ints(wired.sensor_start),
            sensor_kind=ints(wired.sensor_kind), sensor_index=ints(wired.sensor_index),
            sensor_origin=arr(wired.sensor_origin), hinge_controller=ints(wired.hinge_controller),
            load_controller=ints(wired.load_controller.reshape(-1, 6)), actuator_kind=ints(wired.actuator_kind),
            actuator_index=ints(wired.actuator_index), actuator_component=ints(wired.actuator_component),
            actuator_controller=ints(wired.actuator_controller), coupling_actuator=ints(wired.coupling_actuator),
            coupling_slot=ints(wired.coupling_slot), coupling_sensor=ints(wired.coupling_sensor),
            coupling_position=ints(np.full(len(wired.coupling_actuator), -1, np.int64)),
            hinge_contact=arr(joint_contact_rows(m.hinges)),
            n_cables=CE, cable_force=kernel["cable_force"], gravity_load_D_q=kernel["beam_gravity_D_q"],
            n_controller_states=len(wired.state_slot), controller_state_start=ints(wired.state_start),
            controller_state_slot=ints(wired.state_slot),
            actuator_gain=arr(wired.actuator_gain), n_law_actuators=int(np.count_nonzero(wired.actuator_gain)),
            n_chained=int(np.count_nonzero(wired.sensor_kind[:wired.n_sensors] == 4)),
            sensor_offset=arr(wired.sensor_offset.reshape(-1, 3)), coupling_column=ints(wired.coupling_column),
            sensor_frame_node=ints(wired.sensor_frame_node), sensor_column_start=ints(wired.sensor_column_start),
            n_sampled=len(wired.sampled), sampled_laws=sampled_laws,
            sampled_sensor_start=ints(wired.sampled_sensor_start), sampled_slot=ints(wired.sampled_slot),
            sampled_state_start=ints(wired.sampled_state_start), sampled_state_slot=ints(wired.sampled_state_slot),
            sampled_limits=arr(wired.sampled_limits.reshape(-1, 2)), sampled_rate=arr(wired.sampled_rate),
            cable_tension=_kernel_address(kernels, "cable_tension") if CABLE_TENSION in wired.sensor_kind else None,
            section_forces_D_q=_kernel_address(kernels, "beam_section_forces_D_q") if SECTION_FORCE in wired.sensor_kind
            else None,
            point_velocity_in_body=(_kernel_address(kernels, "point_velocity_in_body")
                                    if BODY_VELOCITY in wired.sensor_kind else None),
            inertia_matrices=(_kernel_address(kernels, "beam_inertia_matrices")
                              if "beam_inertia_matrices" in (getattr(kernels, "libraries", None) or {}) else None),
        )
        if len(wired.state_slot):  # the runtime's arrays, read and written in place (latdyn.assembly.control)
            states, rates = wired.states.values, wired.state_rates
            self._keep += [states, rates]
            self.model.controller_states, self.model.controller_state_rate = states.ctypes.data, rates.ctypes.data
        elif len(wired.sampled):  # the sampled controllers' states and the states their probes read
            states = m.scene.controller_states.values
            self._keep.append(states)
            self.model.controller_states = states.ctypes.data
        self._keep.append(outputs)
        if CE:
            self.model.cable_nodes, self.model.cable_offsets = ints(cables.nodes), arr(cables.offsets)
            self.model.cable_section = arr(np.column_stack([cables.share, cables.EA, cables.damping]))
            self.model.cable_rest_law = ints(np.asarray(rest_law, np.int64)[cables.cable])
            self.model.cable_tolerance = arr(cable_tolerance(cables.EA))
            self._keep.append(cables.sides)  # the model's own array: the time loop sets it in place
            self.model.cable_side = cables.sides.ctypes.data
        work = {
            "geometry": (E, 36), "rates": (E, 14), "accelerations": (E, 14), "gravity_rows": (E, 3),
            "force": (E, 14), "tangent": (E, 14, 14), "mass": (E, 14, 14), "quadratic": (E, 14),
            "quadratic_D": (E, 14, 14), "gravity_force": (E, 14), "gravity_potential": (E,),
            "first_moment": (E, 3), "body_vector": (B, 6), "body_mass": (B, 6, 6), "body_damping": (B, 6, 6),
            "body_stiffness": (B, 6, 6), "load_blocks": (L, 6, 6), "strain": (E,), "section_forces": (E, 4),
            "kinetic": (E,), "total": (m.n_total + 1,), "laws": (max(len(laws.functions), 1), 3),
            "hinge_d_theta": (H,), "hinge_d_rate": (H,), "matrix": (0,), "rhs": (0,), "cable_work": (CE, 4),
            "joint_forces": (H,),
            "sensor_values": (len(wired.sensor_kind),), "controller_gradient": (len(wired.sensor_kind),),
            "controller_scratch": (wired.law_values,), "controller_state_trial": (len(wired.state_slot),),
            "controller_arguments": (wired.law_arguments,), "controller_solve": (wired.solve_size,),
            "controller_half_step": (1,),
            "sensor_jacobian": (int(wired.sensor_column_start[-1]),),
            "controller_total": (wired.n * wired.n_sensors if np.any(wired.sensor_kind[:wired.n_sensors] == 4) else 0,),
            "sampled_values": (len(wired.sensor_kind),),
            "sampled_arguments": (max([1] + [len(wired.sampled_sensor_names(k)) + len(c.states)
                                             for k, c in enumerate(wired.sampled)]),),
            "sampled_out": (max([1] + [1 + len(c.states) for c in wired.sampled]),),
            "restart_matrix": (0,),
            "coupling_stiffness": (len(wired.coupling_actuator),), "coupling_damping": (len(wired.coupling_actuator),),
            "cable_vector": (CE, 12), "cable_stiffness": (CE, 12, 12), "cable_damping": (CE, 12, 12),
            "cable_state": (CE, 5), "cable_strain": (CE,), "cable_gap": (CE,),
            "hinge_work_torque": (H,), "hinge_damper_torque": (H,),
            "gravity_tangent": (E, 14, 14) if a.has_gravity else (0,),
            "gravity_force_D_q": (E, 14) if a.has_gravity else (0,)}
        tangent = {"inertia_tangent": (E, 14, 14), "inertia_force": (E, 14)}
        work.update({name: shape if inertia_tangent else (0,) for name, shape in tangent.items()})
        #: the rigid links as csrc/links.c reads them (None without): their kinematics, until the
        #: compiled step holds its matrix (hold_links)
        self.links = None
        if m.links is not None:
            self.hold_links(assembler, None)
        self.buffers = {name: np.zeros(shape) for name, shape in work.items()}
        self.buffers["gravity_rows"][:] = a.gravity
        self.buffers["pivots"] = self.buffers["restart_pivots"] = np.zeros(0, np.int32)
        self.work = WorkData()
        for name, buffer in self.buffers.items():
            self.set_buffer(name, buffer)
        self.model_ref, self.work_ref = ctypes.byref(self.model), ctypes.byref(self.work)
        self._control = EvaluationData()
        self._copies = None
        #: (the state's arrays, their C view) of the last :meth:`configuration` whose arrays were the state's own
        self._configured = None
        #: what the compiled step's iteration matrix storage keeps alive (latdyn.step.compiled)
        self.matrix_storage = None
        self._empty = np.zeros(1)
        #: the last few (arrays, C view) of :meth:`_views`, of states whose arrays were their own
        self._viewed: list = []
        #: whether a hinge has a lock_at or stops (else :meth:`hinge_crossings` has none to find)
        self.hinge_events = any(h.lock_at is not None or h.limits is not None for h in m.hinges)
        #: per hinge, 1 where it is revolute (a guide's slide is not periodic: :meth:`far_root`)
        self.revolute = np.array([hinge.kind == "hinge" for hinge in m.hinges], dtype=np.int64)

    def _array(self, values, dtype=np.float64) -> int:
        """The address of a contiguous copy of ``values``, kept alive with this object."""
        array = np.ascontiguousarray(values, dtype=dtype)
        if array.size == 0:
            array = np.zeros(1, dtype)
        self._keep.append(array)
        return array.ctypes.data

    def set_buffer(self, name: str, buffer: np.ndarray) -> None:
        """Point Work's ``name`` at ``buffer`` (kept with this object)."""
        self.buffers[name] = buffer
        setattr(self.work, name, buffer.ctypes.data if buffer.size else self._array(np.zeros(1)))

    def configuration(self, state) -> ConfigurationData:
        """The C view of a state through contiguous float64 arrays: its own, or copies where they are
        not, kept alive until the next call (nothing is attached to the state: it is pickled into
        checkpoints). Where the state's arrays are the very arrays of the last call and were its own (not
        copies), that call's view is returned: it points at the same memory, which the arrays held here keep
        alive (9 arrays' addresses taken anew cost ≈ 5–9 µs a call, several calls a sensitivity step)."""
        own = [getattr(state, name) for name in STATE_FIELDS]
        held = self._configured
        if held is not None and all(a is b for a, b in zip(own, held[0])):
            self._copies = held[0]
            return held[1]
        arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in own]
        self._copies = arrays
        view = ConfigurationData(*(a.ctypes.data if a.size else self._empty.ctypes.data for a in arrays))
        self._configured = (arrays, view) if all(a is b for a, b in zip(arrays, own)) else None
        return view

    def _written_back(self, state) -> None:
        """Copy the arrays of the last :meth:`configuration` into ``state`` where they are copies
        (arrays of the state that are not contiguous float64)."""
        for name, array in zip(STATE_FIELDS, self._copies):
            target = getattr(state, name)
            if array is not target:
                target[...] = array

    def advance_free(self, state, increment: np.ndarray) -> None:
        """q ∘ exp(Δ) on the free coordinates of ``state``, in place (``latdyn_advance_free``):
        ``increment`` is a free-coordinate vector, at least ``n_dofs`` long."""
        increment = np.ascontiguousarray(increment, dtype=np.float64)
        if len(increment) < self.model.n_dofs:
            raise ValueError(f"an increment of {len(increment)} coordinates; the model has {self.model.n_dofs}")
        configuration = self.configuration(state)
        self.library.latdyn_advance_free(self.model_ref, ctypes.byref(configuration),
                                         increment.ctypes.data if increment.size else self._empty.ctypes.data)
        self._written_back(state)

    def hold_links(self, assembler, factorization) -> None:
        """The rigid links laid out for ``factorization``'s storage (the compiled step's iteration
        matrix; None: the kinematics alone), :attr:`links` and the Model's ``links`` (native_links)."""
        self.links = native_links(assembler, factorization,
                                  lambda name: _kernel_address(assembler.kernels, name))
        self.model.links = self.links.address

    def complete_links(self, state) -> None:
        """The dependent nodes of rigid links in ``state`` from the independent nodes and hinges: frames,
        positions, velocities and accelerations, in place (``latdyn_complete_links``: the generated
        kernel rigid_link_edge edge by edge, latdyn.model.links' module docstring)."""
        configuration = self.configuration(state)
        self.library.latdyn_complete_links(self.model_ref, ctypes.byref(configuration))
        self._written_back(state)

    def dependent_rates_tangent(self, state) -> None:
        """∂(v, w, a, alpha)/∂q at fixed independent rates of every slot of the links at ``state`` (its
        dependent nodes completed) into the native links' ``rates_tangent`` (``latdyn_dependent_rates_tangent``)."""
        self.library.latdyn_dependent_rates_tangent(self.model_ref, ctypes.byref(self.configuration(state)))

    def prescribe(self, state, t: float) -> None:
        """The prescribed motion at time ``t`` in ``state``, in place (``latdyn_prescribe``); the
        state's time is the caller's."""
        configuration = self.configuration(state)
        self.laws.bind_inputs()
        self.library.latdyn_prescribe(self.model_ref, self.work_ref, ctypes.byref(configuration), float(t))
        self._written_back(state)

    def evaluate(self, state, matrices: bool, load_factor: float, inertia: bool,
                 inertia_tangent: bool) -> tuple[np.ndarray, float]:
        """``latdyn_evaluate`` at ``state``: a copy of the vector of all coordinates (n_total + 1)
        and the power of loads and hinge torques; the blocks are left in :attr:`buffers`."""
        if inertia_tangent and not self.has_inertia_tangent:
            raise ValueError("this native model was built without the inertia tangent's buffers")
        control = self._control
        control.t, control.load_factor = float(state.t), float(load_factor)
        control.inertia, control.matrices = int(inertia), int(matrices)
        control.inertia_tangent = int(inertia_tangent)
        self.laws.bind_inputs()
        self.library.latdyn_evaluate(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)),
                                     ctypes.byref(control))
        return self.buffers["total"].copy(), float(control.power)

    @contextlib.contextmanager
    def without_element_gravity(self):
        """Within the block this model's evaluations leave the elements' gravity load out — their residual's −λQ and
        the static tangent's −λ ∂Q/∂q (csrc/evaluate.c reads g per element from ``gravity_rows``, zeroed here and put
        back after) —, the joint bodies' weight kept (they read the model's g): the static residual whose tangent is an
        impulse weight's K, which holds the elements' gravity tangent in the inertia tangent, not in K
        (latdyn/analyses/geometry_sensitivities.py ``ReferenceGeometry.add`` at ``weight_factor`` 0). For static
        evaluations: the inertia tangent at a load factor other than 1 writes the rows anew (csrc/evaluate.c
        ``inertia_tangent``)."""
        rows = self.buffers["gravity_rows"]
        held = rows.copy()
        rows[:] = 0.0
        try:
            yield
        finally:
            rows[:] = held

    def hinge_crossings(self, old, new) -> np.ndarray:
        """Per hinge, the events of the step ``old`` → ``new`` as flags (latdyn.timeloop.events: lock_at reached
        or crossed, a stop crossed from inside, a stop met moving into it; 0 for hinges not free)
        (``latdyn_hinge_crossings``, csrc/newton_step.c hinge_crossings, the loop of steps' own test)."""
        flags = np.zeros(self.model.n_hinges, np.int64)
        if self.model.n_free_hinges and self.hinge_events:
            arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in (old.theta, new.theta, new.theta_dot)]
            if any(a.shape != flags.shape for a in arrays):
                raise ValueError(f"hinge angles of shapes {[a.shape for a in arrays]}; the model has {len(flags)} hinges")
            self.library.latdyn_hinge_crossings(self.model_ref, *(a.ctypes.data for a in arrays), flags.ctypes.data)
        return flags

    def may_stick(self, old, new) -> np.ndarray:
        """Per hinge (bool), whether it is tried for sticking at the end of the step ``old`` → ``new`` (friction that
        can hold it, and a rate that reversed, fell into the stick band, or started the run at 0; False for hinges
        not free) (``latdyn_may_stick``, csrc/newton_step.c may_stick, the loop of steps' own)."""
        flags = np.zeros(self.model.n_hinges, np.int64)
        if self.model.n_free_hinges:
            rates = [np.ascontiguousarray(a, dtype=np.float64) for a in (old.theta_dot, new.theta_dot)]
            if any(a.shape != flags.shape for a in rates):
                raise ValueError(f"hinge rates of shapes {[a.shape for a in rates]}; the model has {len(flags)} hinges")
            self.library.latdyn_may_stick(self.model_ref, rates[0].ctypes.data, rates[1].ctypes.data, float(old.t),
                                          flags.ctypes.data)
        return flags.astype(bool)

    def cable_crossed(self, gaps: np.ndarray) -> np.ndarray:
        """Per cable element (bool), whether its gap ``gaps`` lies beyond its tolerance on the other side of zero
        from the side the model's ``cables.sides`` holds it on (``latdyn_cable_crossed``, csrc/newton_step.c
        cable_crossed, the loop of steps' own)."""
        gaps = np.ascontiguousarray(gaps, dtype=np.float64)
        if gaps.shape != (self.model.n_cables,):
            raise ValueError(f"{gaps.shape} cable gaps; the model has {self.model.n_cables} cable elements")
        crossed = np.zeros(self.model.n_cables, np.int64)
        if self.model.n_cables:
            self.library.latdyn_cable_crossed(self.model_ref, gaps.ctypes.data, crossed.ctypes.data)
        return crossed.astype(bool)

    def cable_state(self, state) -> np.ndarray:
        """(ce, 5) [ℓ, ℓ̇, ℓ − L0, N_el, N] of every cable element at ``state`` (N = 0 while slack):
        ``latdyn_cables``, which leaves the last evaluation's rows in Work as they are."""
        self.library.latdyn_cables(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)),
                                   float(state.t))
        return self.buffers["cable_state"].copy()

    def element_inputs(self, state) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Copies of the element kernels' geometry (Eqs. 2, 9, 17), rates and accelerations at ``state``."""
        self.library.latdyn_element_inputs(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)))
        b = self.buffers
        return b["geometry"].copy(), b["rates"].copy(), b["accelerations"].copy()

    def section_parameter_forces(self, state, kernels: tuple, with_inertia: bool, gravity: np.ndarray | None,
                                 uses: tuple, total: np.ndarray) -> None:
        """Add into ``total`` ((n_total + 1, k), C-contiguous float64) the section values' ∂(element force)/∂p at
        ``state`` in one call (``latdyn_section_parameter_forces``, csrc/parameter_forces.c): ``kernels`` the
        addresses of ``beam_internal_force_D_section`` and ``beam_inertia_force_D_section`` (None: without the
        inertia force), ``with_inertia`` its rates and accelerations the state's (else at rest), ``gravity``
        λ g (3,) or None; ``uses`` = (distinct elements, each use's index among them, elements, parameter
        columns, section rows (m, 10)) as int64 / float64 contiguous arrays."""
        on, use, elements, columns, rows = uses
        scratch = self.__dict__.get("_section_scratch")
        size = len(on) * (36 + 14 + 14 + 10 + 3 + 2 * (14 + 126))
        if scratch is None or len(scratch) < size:
            scratch = self._section_scratch = np.empty(max(size, 1))
        self.library.latdyn_section_parameter_forces(
            self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)), kernels[0], kernels[1],
            int(with_inertia), None if gravity is None else gravity.ctypes.data, len(on), on.ctypes.data, len(use),
            use.ctypes.data, elements.ctypes.data, columns.ctypes.data, rows.ctypes.data, total.shape[1],
            total.ctypes.data, scratch.ctypes.data)

    def accept_controller_states(self, state, h: float) -> None:
        """The continuous controllers' states accepted at the end of a step of size ``h`` that ended at
        ``state`` (``latdyn_controller_states_accept``; h = 0: S kept, its rate dS/dt taken at ``state``)."""
        if self.model.n_controller_states:
            self.library.latdyn_controller_states_accept(self.model_ref, self.work_ref,
                                                         ctypes.byref(self.configuration(state)), float(state.t), h)

    def sample_restart(self, state) -> np.ndarray | None:
        """The accelerations after a sample at ``state``, in place, where every direction has inertia:
        v̇ ← v̇ − M⁻¹ r (``latdyn_sample_restart``, csrc/sampling.c sample_restart, the loop of steps'
        own restart); the algorithmic acceleration a_n (n_dofs), or None where M did not factorize. Needs the
        step's storage (latdyn.step.compiled: the restart matrix of a model with sampled controllers)."""
        a_n = np.zeros(self.model.n_dofs)
        view = self.configuration(state)
        if any(a is not getattr(state, name) for a, name in zip(self._copies, STATE_FIELDS)):
            raise ValueError("a state whose arrays are not contiguous float64: the restart writes into them")
        self.laws.bind_inputs()
        failed = self.library.latdyn_sample_restart(self.model_ref, self.work_ref, ctypes.byref(view),
                                                           float(state.t), a_n.ctypes.data)
        return None if failed else a_n

    def sample(self, state, t: float, tolerance: float, provided: dict | None = None) -> int:
        """The sampled controllers' sample at the accepted ``state`` (``latdyn_sample_controllers``,
        csrc/sampling.c): those whose instant ``t`` is, within ``tolerance``; ``provided``: the
        values of the probes they read that no C sensor evaluates (:attr:`provided`), by name. How many
        sampled."""
        if not self.model.n_sampled:
            return 0
        values = self.buffers["sampled_values"]
        for sensor, name in self.provided:
            values[sensor] = provided[name]
        self.laws.bind_inputs()
        return int(self.library.latdyn_sample_controllers(self.model_ref, self.work_ref,
                                                          ctypes.byref(self.configuration(state)),
                                                          ctypes.c_double(float(t)),
                                                          ctypes.c_double(float(tolerance))))

    def momentum(self, state) -> np.ndarray:
        """[P, H] at ``state``: the linear momentum and the angular momentum about the global origin
        (``latdyn_momentum``, csrc/rows.c)."""
        out = np.zeros(6)
        self.library.latdyn_momentum(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)),
                                     out.ctypes.data)
        return out

    def controller_outputs_at(self, state) -> None:
        """The continuous controllers' outputs at the accepted ``state`` into the scene's array of
        controller outputs (``latdyn_controller_outputs_at``, csrc/rows.c: their laws, clipped, at the
        state's sensors and the states as accepted), as the rows recorded in the loop of steps hold them."""
        self.laws.bind_inputs()
        self.library.latdyn_controller_outputs_at(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)),
                                                  float(state.t))

    def joint_forces(self, state, load_factor: float = 1.0) -> np.ndarray:
        """The force each joint (hinge or guide, in model order) applies on its coordinate at ``state``
        (``latdyn_joint_forces``, csrc/rows.c: the rules of
        :meth:`latdyn.results.probes.ProbeSet.joint_forces`), evaluated on a copy of ``state`` at the
        static path's ``load_factor`` (1 in a transient); the evaluation's outputs are left in Work. Where
        every joint is free and no controller runs, only the joints' laws are evaluated (their forces)."""
        out = np.zeros(self.model.n_hinges)
        if len(out):
            held = state.copy()
            self.laws.bind_inputs()
            self.library.latdyn_joint_forces(self.model_ref, self.work_ref, ctypes.byref(self.configuration(held)),
                                             float(state.t), float(load_factor), out.ctypes.data)
        return out

    def _views(self, *states) -> tuple[list, list[ConfigurationData]]:
        """The C views of several states at once (:meth:`configuration` keeps one alive at a time): (the arrays,
        to be held while the views are used; the views). A state whose arrays are the very arrays of one of the
        last few views, their own (contiguous float64), gets that view again (the step's two states are viewed by
        far_root, rate_turns and drive_work in turn: 9 addresses taken anew cost ≈ 10–20 µs)."""
        held, views = [], []
        for state in states:
            own = [getattr(state, name) for name in STATE_FIELDS]
            for arrays, view in self._viewed:
                if all(a is b for a, b in zip(own, arrays)):
                    break
            else:
                arrays = [np.ascontiguousarray(a, dtype=np.float64) for a in own]
                view = ConfigurationData(*(a.ctypes.data if a.size else self._empty.ctypes.data for a in arrays))
                if all(a is b for a, b in zip(arrays, own)):
                    self._viewed = [(arrays, view)] + self._viewed[:3]
            held.append(arrays)
            views.append(view)
        return held, views

    def drive_forces(self, reaction: np.ndarray) -> np.ndarray:
        """The reactions of the prescribed motions by prescribed coordinate from an evaluation's ``reaction`` (on
        the constrained coordinates), 6 per prescribed body's node, then one per hinge or guide
        (``latdyn_drive_forces``, csrc/newton_step.c drive_forces, the loop of steps' own)."""
        reaction = np.ascontiguousarray(reaction, dtype=np.float64)
        if len(reaction) != self.model.n_total - self.model.n_dofs:
            raise ValueError(f"{len(reaction)} reactions; the model has {self.model.n_total - self.model.n_dofs} "
                             "constrained coordinates")
        out = np.zeros(6 * self.model.n_prescribed + self.model.n_hinges)
        if out.size:
            self.library.latdyn_drive_forces(self.model_ref, reaction.ctypes.data if reaction.size
                                             else self._empty.ctypes.data, out.ctypes.data)
        return out

    def increment_size(self, dx: np.ndarray, length: float) -> float:
        """The size of the Newton increment ``dx`` (its first n_dofs entries: the free coordinates) in a scene of
        size ``length`` (``latdyn_increment_size``, csrc/newton_step.c increment_size, the loop of steps' own)."""
        n = self.model.n_dofs
        if len(dx) < n:
            raise ValueError(f"an increment of {len(dx)} entries; the model has {n} free coordinates")
        dx = np.ascontiguousarray(dx[:n], dtype=np.float64)
        return float(self.library.latdyn_increment_size(self.model_ref, dx.ctypes.data, float(length)))

    def drive_work(self, old, new, forces_old: np.ndarray, forces_new: np.ndarray, work: float) -> float:
        """``work`` with the prescribed motions' work over the step ``old`` → ``new`` added, from their reactions
        at its two ends (:meth:`drive_forces`; ``latdyn_drive_work``, csrc/newton_step.c drive_work)."""
        size = 6 * self.model.n_prescribed + self.model.n_hinges
        if size == 0:
            return float(work)
        forces = [np.ascontiguousarray(f, dtype=np.float64) for f in (forces_old, forces_new)]
        if any(f.shape != (size,) for f in forces):
            raise ValueError(f"reactions of shapes {[f.shape for f in forces]}; the drives have {size}")
        held, (before, after) = self._views(old, new)
        return float(self.library.latdyn_drive_work(self.model_ref, ctypes.byref(before), ctypes.byref(after),
                                                    forces[0].ctypes.data, forces[1].ctypes.data, float(work)))

    def far_root(self, old, new, h: float) -> tuple[int, float] | None:
        """The free revolute hinge whose angle at the end of the step ``old`` → ``new`` of size ``h`` lies farthest,
        more than π, from θ_n + h θ̇_n, and that distance; None if none (``latdyn_far_root``, csrc/newton_step.c
        far_root, the loop of steps' own)."""
        if self.model.n_free_hinges == 0:
            return None
        distance = np.zeros(1)
        held, (before, after) = self._views(old, new)
        worst = int(self.library.latdyn_far_root(self.model_ref, ctypes.byref(before), ctypes.byref(after), float(h),
                                                 self.revolute.ctypes.data, distance.ctypes.data))
        return None if worst < 0 else (worst, float(distance[0]))

    def rate_turns(self, old, new, h: float, unresolved_turn: float, kept: np.ndarray) -> None:
        """Each free hinge's largest h |θ̇_{n+1} − θ̇_n| over the step ``old`` → ``new`` of size ``h`` (ending at
        new.t), and the first past ``unresolved_turn``, into ``kept`` (n_hinges, 6), in place
        (``latdyn_rate_turns``, csrc/newton_step.c rate_turns, the loop of steps' own)."""
        if kept.shape != (self.model.n_hinges, 6) or kept.dtype != np.float64 or not kept.flags.c_contiguous:
            raise ValueError(f"kept turns of shape {kept.shape}; the model has {self.model.n_hinges} hinges")
        if self.model.n_free_hinges == 0:
            return
        held, (before, after) = self._views(old, new)
        self.library.latdyn_rate_turns(self.model_ref, ctypes.byref(before), ctypes.byref(after), float(new.t),
                                       float(h), float(unresolved_turn), kept.ctypes.data)

    def energies(self, state) -> tuple[float, float, float]:
        """Kinetic energy, strain energy (hinge springs included, those with a stiffness law by
        quadrature of the compiled law) and gravity potential at ``state`` (``latdyn_energies``)."""
        out = np.zeros(3)
        self.library.latdyn_energies(self.model_ref, self.work_ref, ctypes.byref(self.configuration(state)),
                                     float(state.t), out.ctypes.data)
        return float(out[0]), float(out[1]), float(out[2])
