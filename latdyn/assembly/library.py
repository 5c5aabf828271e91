"""The native boundary: the runtime's C library (``csrc/newton_step.c``, which inlines the one
evaluation of ``csrc/evaluate.c`` and the one LU factorization of ``csrc/factorization.c`` with the
sparse LU of ``csrc/sparse_lu.c``), built once into the kernel cache by :mod:`latdyn.native`, the
ctypes mirrors of its C structs (``Model``, ``Links``, ``Work``, ``Configuration``, ``EvaluationControl``,
``Vectors``, ``StepControl``, ``Advance``, ``Rows``, ``Factorization``, ``SparseLU``, ``SensitivityStep``) and the
signatures of its exported functions (``latdyn_factor``, ``latdyn_solve``, ``latdyn_solve_transposed``,
``latdyn_sensitivity_step``, ``latdyn_sensitivity_predict``, ``latdyn_sensitivity_update``,
``latdyn_exact_matrix_values``, ``latdyn_joint_body_inertia_stiffness`` and ``latdyn_section_parameter_forces``
among them;
``latdyn_law_spring_integral``, the quadrature of a law spring's potential, takes a hinge law's function of
type :data:`HINGE_LAW_VALUES`).

Every struct the C side reads is declared here and nowhere else on the Python side;
``tests/test_engine.py`` checks their sizes and offsets against the compiler's.
"""
from __future__ import annotations

import ctypes
import os
from typing import NamedTuple

I64 = ctypes.c_int64


P = ctypes.c_void_p

#: ``hinge_laws(k, θ, θ̇, t, out)`` of csrc/evaluate.c's Model: hinge law k's (f, ∂f/∂θ, ∂f/∂θ̇) into out
#: (a scene's compiled laws, or a Python callback of this type)
HINGE_LAW_VALUES = ctypes.CFUNCTYPE(None, I64, ctypes.c_double, ctypes.c_double, ctypes.c_double,
                                    ctypes.POINTER(ctypes.c_double))

_LIBRARY = None


class SparseLUStructure(ctypes.Structure):
    """``SparseLU`` of csrc/sparse_lu.c."""

    _fields_ = [("n", I64), ("n_supernodes", I64), ("first", P), ("rows_start", P), ("rows", P), ("lower", P),
                ("upper", P), ("supernode", P), ("pivot_tolerance", ctypes.c_double), ("gemm", P), ("trsm", P),
                ("map", P), ("head", P), ("next", P), ("cursor", P), ("update", P), ("scale", P),
                ("failed_column", I64), ("failed_ratio", ctypes.c_double), ("relative", P)]


class FactorizationStructure(ctypes.Structure):
    """``Factorization`` of csrc/factorization.c: the storage of one LU (kind 0 dense, 1 band, 2 sparse)."""

    _fields_ = [("n", I64), ("kind", I64), ("kl", I64), ("ku", I64), ("ldab", I64), ("size", I64),
                ("permutation", P), ("getrf", P), ("getrs", P), ("gbtrf", P), ("gbtrs", P),
                ("sparse_lu", ctypes.POINTER(SparseLUStructure)), ("get_blas_threads", P), ("set_blas_threads", P),
                ("integer_bytes", I64), ("wide_pivots", P)]


class SensitivityStepStructure(ctypes.Structure):
    """``SensitivityStep`` of csrc/sensitivity_step.c: the held pattern of the transient sensitivities'
    step matrix (:class:`latdyn.analyses.step_matrix.ExactStepMatrix`)."""

    _fields_ = [("n", I64), ("nnz", I64), ("size", I64), ("n_plain", I64), ("n_terms", I64), ("indptr", P),
                ("indices", P), ("into", P), ("plain", P), ("term_entry", P), ("term_block", P), ("term_place", P),
                ("storage", P), ("factorization", ctypes.POINTER(FactorizationStructure))]


class ModelData(ctypes.Structure):
    _fields_ = [(name, I64) for name in ("n_nodes", "n_hinges", "n_elements", "n_bodies", "n_loads", "n_dofs",
                                          "n_total")] + [
        ("node_dofs", P), ("hinge_dofs", P), ("n_free_nodes", I64), ("n_free_hinges", I64),
        ("free_nodes", P), ("free_hinges", P),
        ("n_prescribed", I64), ("prescribed_nodes", P), ("translation_law", P), ("angle_law", P),
        ("rotation_axis", P), ("node_x0", P), ("hinge_angle_law", P), ("hinge_locked", P),
        ("element_nodes", P), ("element_hinges", P), ("element_dofs", P),
        ("element_axes", P), ("element_frames0", P), ("element_offsets", P), ("element_sections", P),
        ("body_nodes", P), ("body_mass", P), ("body_com", P), ("body_inertia", P),
        ("hinge_stiffness", P), ("hinge_damping", P), ("hinge_rest_angle", P), ("hinge_torque_law", P),
        ("load_node", P), ("load_force_law", P), ("load_moment_law", P), ("load_frame_node", P), ("load_r", P),
        ("gravity", ctypes.c_double * 3), ("has_gravity", I64),
        ("element_position", P), ("body_position", P), ("hinge_position", P), ("load_position", P),
        ("factorization", ctypes.POINTER(FactorizationStructure)),
        ("internal_force", P), ("internal_force_D_q", P), ("mass_matrix", P), ("quadratic_velocity", P),
        ("quadratic_velocity_D_qdot", P), ("gravity_load", P), ("strain_energy", P), ("kinetic_energy", P),
        ("inertia_force_D_q", P),
        ("joint_body", P), ("point_load", P), ("body_section", P), ("hinged_end", P), ("element_ends", P), ("hinge_force", P), ("so3_exp", P), ("so3_dexp", P),
        ("so3_log_increment", P),
        ("parallel_elements", I64), ("threads", I64),
        ("time_laws", P), ("hinge_laws", P),
        ("hinge_stiffness_law", P), ("hinge_damping_law", P), ("hinge_torque_hinge_law", P), ("hinge_conservative", P),
        ("hinge_lock_at", P), ("hinge_lower_stop", P), ("hinge_upper_stop", P), ("has_events", I64),
        ("section_width", I64), ("links", P),
        ("n_controllers", I64), ("n_sensors", I64), ("n_actuators", I64), ("n_couplings", I64),
        ("controller_laws", P), ("controller_outputs", P), ("controller_slot", P), ("controller_limits", P),
        ("sensor_start", P), ("sensor_kind", P), ("sensor_index", P), ("sensor_origin", P),
        ("hinge_controller", P), ("load_controller", P), ("actuator_kind", P), ("actuator_index", P),
        ("actuator_component", P), ("actuator_controller", P), ("coupling_actuator", P), ("coupling_slot", P),
        ("coupling_sensor", P), ("coupling_position", P),
        ("hinge_contact", P),
        ("n_cables", I64), ("cable_nodes", P), ("cable_offsets", P), ("cable_section", P), ("cable_rest_law", P),
        ("cable_position", P), ("cable_force", P), ("cable_side", P),
        ("gravity_load_D_q", P),
        ("n_controller_states", I64), ("controller_state_start", P), ("controller_state_slot", P),
        ("controller_states", P), ("controller_state_rate", P),
        ("actuator_gain", P), ("n_law_actuators", I64), ("n_chained", I64),
        ("sensor_offset", P), ("coupling_column", P), ("sensor_frame_node", P),
        ("sensor_column_start", P),
        ("n_sampled", I64), ("sampled_laws", P), ("sampled_sensor_start", P), ("sampled_slot", P),
        ("sampled_state_start", P), ("sampled_state_slot", P), ("sampled_limits", P), ("sampled_rate", P),
        ("cable_tension", P), ("section_forces_D_q", P), ("inertia_matrices", P),
        ("hinge_event_tolerance", P), ("cable_tolerance", P), ("point_velocity_in_body", P),
    ]


class LinksData(ctypes.Structure):
    """``Links`` of csrc/links.c: the rigid links of a model in the compiled step
    (:mod:`latdyn.assembly.native_links` fills it)."""

    _fields_ = [(name, I64) for name in ("n_edges", "n_slots", "width", "n_assembled")] + [
        (name, P) for name in (
            "edge_parent", "edge_child", "edge_hinge", "edge_kind", "edge_parent_slot", "edge_slot", "edge_data",
            "slot_node", "slot_root", "slot_edge", "slot_count", "slot_columns", "slot_position",
            "element_block", "body_block", "load_block", "coupling_block", "cable_block", "block_rows", "block_columns", "block_position",
            "positions", "expansion_size", "expansion_reduced", "expansion_start", "dof_slot", "dof_component",
            "dof_map", "rigid_link_edge", "hinge_wrench", "root_wrench", "prismatic_link_edge", "slide_wrench",
            "slider_closure_edge", "rod_closure_edge", "slider_closure_wrench", "rod_closure_wrench",
            "jacobian", "convective", "wrench",
            "scratch")] + [("rates_D_q", P * 4), ("rates_tangent", P)]


class WorkData(ctypes.Structure):
    _fields_ = [(name, P) for name in (
        "geometry", "rates", "accelerations", "gravity_rows", "force", "tangent", "mass", "quadratic",
        "quadratic_D", "gravity_force", "gravity_potential", "first_moment", "body_vector", "body_mass",
        "body_damping", "body_stiffness", "load_blocks", "strain",
        "section_forces", "kinetic", "total",
        "matrix", "pivots", "rhs",
        "inertia_tangent", "inertia_force", "laws", "hinge_d_theta", "hinge_d_rate", "cable_work",
        "joint_forces",
        "sensor_values", "controller_gradient", "controller_scratch", "coupling_stiffness", "coupling_damping",
        "cable_vector", "cable_stiffness", "cable_damping", "cable_state", "cable_strain", "cable_gap",
        "hinge_work_torque", "hinge_damper_torque", "gravity_tangent", "gravity_force_D_q",
        "controller_state_trial", "controller_arguments", "controller_solve", "controller_half_step",
        "controller_total", "sensor_jacobian",
        "sampled_values", "sampled_arguments", "sampled_out", "restart_matrix", "restart_pivots")]


class ConfigurationData(ctypes.Structure):
    _fields_ = [(name, P) for name in ("x", "T", "v", "w", "a", "alpha", "theta", "theta_dot", "theta_ddot")]


class VectorsData(ctypes.Structure):
    _fields_ = [(name, P) for name in ("v_n", "vdot_n", "a_n", "v", "vdot", "dq", "dx", "a_new")]

    @classmethod
    def _fields_and_names(cls):
        return [name for name, _ in cls._fields_]


class ControlData(ctypes.Structure):
    _fields_ = [(name, ctypes.c_double) for name in ("h", "alpha_m", "alpha_f", "gamma", "beta", "tol",
                                                      "length")] + [
        ("max_iterations", I64), ("modified", I64), ("inertia_tangent", I64),
        ("contraction", ctypes.c_double),
        ("factored_h", ctypes.c_double), ("iterations", I64), ("converged", I64), ("factorizations", I64),
        ("power", ctypes.c_double), ("contraction_seen", ctypes.c_double), ("t_new", ctypes.c_double),
        ("estimate_error", I64)]


class EvaluationData(ctypes.Structure):
    """``EvaluationControl`` of csrc/evaluate.c."""

    _fields_ = [("t", ctypes.c_double), ("load_factor", ctypes.c_double), ("inertia", I64), ("matrices", I64),
                ("inertia_tangent", I64), ("power", ctypes.c_double)]


class StaticControlData(ctypes.Structure):
    """``StaticControl`` of csrc/newton_step.c (the static mode of the Newton iteration)."""

    _fields_ = [("load_factor", ctypes.c_double), ("tol", ctypes.c_double), ("length", ctypes.c_double),
                ("max_iterations", I64), ("reference", I64), ("iterations", I64), ("converged", I64),
                ("status", I64), ("size", ctypes.c_double), ("matrix_copy", P)]


class AdvanceData(ctypes.Structure):
    _fields_ = [("dt", ctypes.c_double), ("t_end", ctypes.c_double), ("n_grid", I64), ("grid_index", I64),
                ("stop_index", I64), ("t", ctypes.c_double), ("budget_s", ctypes.c_double),
                ("power", ctypes.c_double), ("external_work", ctypes.c_double),
                ("steps", I64), ("iterations", I64), ("factorizations", I64), ("status", I64), ("last", I64),
                ("pending", I64), ("t_last", ctypes.c_double), ("h_pending", ctypes.c_double),
                ("dissipated", ctypes.c_double), ("hinge_work_torque", P), ("hinge_damper_torque", P),
                ("rows", P), ("cable_work", P),
                ("sample_tolerance", ctypes.c_double), ("native_restart", I64), ("samples", I64),
                ("rate_turns", P), ("unresolved_turn", ctypes.c_double), ("sensitivities", P),
                ("trajectory", P),
                ("drive_force", P)]


class SensitivityLoopData(ctypes.Structure):
    """``SensitivityLoop`` of csrc/sensitivity_loop.c: the transient sensitivities carried through the loop of
    steps (latdyn.analyses.sensitivities_in_loop lays it out)."""

    _fields_ = [("k", I64), ("dq", P), ("dv", P), ("dvdot", P), ("da", P), ("dt", P), ("dh", P), ("f", I64),
                ("slots", P), ("psi", P), ("turn", P), ("tangent", P), ("blocks", P), ("increment", P),
                ("predicted", P), ("explicit", P), ("total", P), ("z", P), ("updated", P),
                ("n_segments", I64), ("counts", P), ("first", P), ("second", P), ("indices", P), ("positions", P),
                ("mck_size", I64), ("mck", P), ("body_kernel", P), ("body_rows", P), ("body_gravity", P),
                ("body_scratch", P), ("body_stiffness", P), ("step", P), ("S", P), ("factor", P), ("pivots", P),
                ("solve_work", P), ("internal_D_section", P), ("inertia_D_section", P), ("gravity", P),
                ("n_on", I64), ("on", P), ("n_uses", I64), ("use", P), ("elements", P), ("columns", P), ("rows", P),
                ("section_scratch", P), ("n_pairs", I64), ("pair_node", P), ("pair_frame", P), ("pair_column", P),
                ("pair_offset", P), ("pair_values", P), ("values_from", I64), ("pair_scratch", P),
                ("n_hinge_uses", I64), ("hinge_kernel", P), ("hinge_joint", P), ("hinge_column", P), ("hinge_slot", P),
                ("hinge_at", P), ("hinge_values", P), ("no_contact", P), ("n_body_uses", I64),
                ("body_force_kernel", P), ("body_com_kernel", P), ("body_use_node", P), ("body_use_column", P),
                ("body_use_axis", P), ("body_use_gravity", P), ("body_values", P), ("body_use_scratch", P),
                ("n_law_uses", I64), ("contact_kernel", P), ("friction_kernel", P), ("law_joint", P),
                ("law_column", P), ("law_kind", P), ("law_slot", P), ("law_at", P), ("law_rows", P), ("law_factor", P),
                ("law_values", P),
                ("steps", I64), ("info", I64), ("h", ctypes.c_double),
                # the carried sensitivities at each row recorded on the way (SensitivityLoop.record_rows)
                ("row_carried", P),
                # ∂r/∂p of the geometry parameters (csrc/geometry_forces.c); NULL: none
                ("geometry", P),
                # rigid links and guides (csrc/linked_matrices.c)
                ("linked", I64), ("linked_gather", P), ("linked_storage", P), ("linked_body_D", P),
                # hinge laws' derivatives of θ, θ̇ or an input, compiled (latdyn/analyses/derivative_laws.py)
                ("derivative_laws", P), ("hinge_law_index", P),
                # explicit time dependence beside events: ∂r/∂t's struct of one column (sensitivities_in_loop._TimeRates)
                ("time_rates", P),
                # continuous controllers' parameters (ControllerTerms.add; derivative_laws.ControllerPartials)
                ("n_partials", I64), ("controller_partials", P), ("partial_controller", P), ("partial_column", P),
                ("n_partial_controllers", I64), ("read_start", P), ("read_kind", P), ("read_index", P),
                ("n_hinge_actuators", I64), ("actuator_hinge", P), ("actuator_of", P), ("actuator_factor", P),
                ("controller_slopes", P), ("controller_scratch", P), ("output_law", P), ("output_limits", P),
                # ∂r/∂p of the cables' parameters (csrc/cable_forces.c); NULL: none
                ("cables", P),
                # the work accounts' sensitivities carried through the steps (csrc/work_accounts.c); NULL: none
                ("accounts", P),
                # S on the sparse LU: the band LU with pivoting that stands in where its pivot fails
                # (csrc/sensitivity_step.c latdyn_sensitivity_step_pivoted); NULL: S not sparse
                ("pivoted", P), ("pivoted_storage", P), ("pivoted_factor", P), ("pivoted_pivots", P),
                # rigid links and guides: the entries linked_gather gathers (n², or the reduced pattern's nnz)
                ("linked_count", I64),
                # ∂r/∂t through the prescribed motions, in the time_rates struct (csrc/prescribed_rates.c); 0: none
                ("prescribed_mask", P), ("load_columns", P), ("n_motions", I64), ("motion_coordinates", P),
                ("motion_values", P), ("motions_from", I64), ("motion_rates", P), ("through_prescribed", P),
                # controllers' chains and load actuators (ControllerTerms.add: outputs, the chain rule, point_load)
                ("output_limited", P), ("held_outputs", P), ("output_gradient", P), ("n_load_actuators", I64),
                ("load_actuator_load", P), ("load_actuator_component", P), ("load_actuator_of", P),
                ("load_actuator_factor", P), ("n_actuated_loads", I64), ("actuated_load_node", P),
                ("actuated_load_frame", P), ("actuated_load_offset", P), ("actuated_load_scratch", P),
                # sampled controllers' held outputs (SampledTerms.add)
                ("sampled_held", P), ("n_sampled_hinge_actuators", I64), ("sampled_hinge", P), ("sampled_hinge_of", P),
                ("sampled_hinge_gain", P), ("n_sampled_load_actuators", I64), ("sampled_load", P),
                ("sampled_load_component", P), ("sampled_load_of", P), ("sampled_load_gain", P),
                ("n_sampled_loads", I64),
                # prescribed motions on a model with rigid links or guides (csrc/linked_prescribed_rates.c), in the
                # time_rates struct: scratch of the prescribed and dependent coordinates' mask and δq, δv, δa, and
                # ∂r_all/∂t (n_total + 1, 3 (n_total + 1), n_total + 1)
                ("linked_motion_mask", P), ("linked_motion_moved", P), ("linked_motion_all", P),
                # the continuous controllers' coupling rows then columns (2 n_couplings; NULL: none), for a sensor on
                # a coordinate the prescribed motions move (csrc/prescribed_rates.c)
                ("motion_couplings", P),
                # controllers that read inputs: the scene's inputs' values (read_kind 4)
                ("input_values", P),
                # continuous controllers with states (ControllerStates; csrc/controller_states.c
                # ControllerStatesLoop, ControllerStatesLoopData); NULL: none
                ("states", P),
                # controllers reading a free joint's torque or force whose own laws a parameter moves: each read's
                # slot, its joint's row, their ∂F/∂p (n_force_reads × k; ControllerTerms.sensed_force_slopes)
                ("n_force_reads", I64), ("force_read", P), ("force_row", P), ("force_slopes", P),
                # controllers reading a section force whose section values a parameter moves: each read's element (−1:
                # a joint's), its sensor's first force and two weights, the generated beam_section_forces_D_section
                ("force_element", P), ("force_first", P), ("force_weights", P), ("section_forces_D_section", P),
                # controllers reading a cable's tension whose laws a parameter moves: each read's cable's first
                # element (−1: not a tension), cable_tension_slope
                ("force_cable_element", P),
                # the geometry parameters' turning shifts (csrc/turning_shifts.c TurningShifts); NULL: none
                ("shifts", P)]


class ControllerStatesLoopData(ctypes.Structure):
    """``ControllerStatesLoop`` of csrc/controller_states.c: the continuous controllers' states carried through the loop
    of steps (latdyn.analyses.sensitivities_in_loop SensitivityLoop._controller_states lays it out)."""

    _fields_ = [("n", I64), ("place", P), ("first", P), ("sensor_dof", P), ("n_rate_uses", I64), ("rate_use", P),
                ("dS", P), ("df", P), ("S_n", P), ("f_n", P), ("S_next", P), ("f_next", P), ("f_s", P), ("f_S", P),
                ("f_p", P), ("factor", P), ("by_h", P), ("held", P), ("pivots", P), ("ds", P), ("scratch", P),
                ("law_args", P), ("law_out", P), ("by_step", P), ("width_s", I64), ("width_S", I64),
                ("half_kept", ctypes.c_double),
                # the rows recorded on the way: per row δS (P × k) then S (P); NULL: none (controller probes)
                ("row_states", P),
                # sensors of points offset from their node or in a body's axes: each sensor gradient column's row in
                # δq, −1: 0 (controller_state_sensed; SensitivityLoop._controller_states, ControllerStates._sensed)
                ("column_dof", P)]


class WorkAccountsData(ctypes.Structure):
    """``WorkAccounts`` of csrc/work_accounts.c: the work accounts' sensitivities (the dissipated energy, the external
    work) carried through the loop of steps (latdyn.analyses.sensitivities_in_loop lays it out)."""

    _fields_ = [("hinges", I64), ("hinge_row", P), ("values_from", I64), ("theta", P), ("row_accounts", P),
                # the dissipated energy
                ("laws", P), ("n_uses", I64), ("use_hinge", P), ("use_column", P), ("use_values", P),
                ("dissipated", P), ("torque", P), ("dtorque", P), ("dtheta", P), ("scratch", P),
                # the external work
                ("work", P), ("power", P), ("work_torque", P), ("work_dtorque", P), ("work_dtheta", P),
                ("loads", I64), ("load_node", P), ("load_frame", P), ("load_offset", P), ("node_rows", P),
                ("frame_rows", P), ("load_values", P), ("pairs", I64), ("pair_load", P), ("pair_column", P),
                ("pair_values", P), ("torque_laws", P), ("n_torque_uses", I64), ("torque_use_hinge", P),
                ("torque_use_column", P), ("torque_use_kind", P), ("torque_use_values", P), ("work_scratch", P),
                # the accounts' laws of θ, θ̇ or an input, compiled (energy_sensitivities.account_laws); NULL: none
                ("state_laws", P), ("damping_law", P), ("use_law", P), ("torque_law", P), ("torque_use_law", P),
                ("law_scratch", P),
                # the prescribed motions' drive in the external work (csrc/drive_sensitivities.c); drive_rows 0: none
                ("drive_rows", I64), ("drive_coordinates", P), ("drive_where", P), ("drive_slot", P), ("drive_dr", P),
                ("drive_x", P), ("drive_T", P), ("drive_total", P), ("drive_body_stiffness", P),
                ("drive_load_columns", P), ("drive_couplings", P), ("drive_scratch", P),
                # loads on nodes that follow rigid links (csrc/work_accounts.c dependent_node_motion); 0: none
                ("linked_loads", I64), ("load_slot", P), ("frame_slot", P), ("linked_scratch", P)]


class GeometryForcesData(ctypes.Structure):
    """``GeometryForces`` of csrc/geometry_forces.c: the geometry parameters' ∂r/∂p in the loop of steps
    (latdyn.analyses.sensitivities_in_loop lays it out)."""

    _fields_ = [("m", I64), ("elements", P), ("held", P), ("n_on", I64), ("on", P), ("variation_kernel", P),
                ("internal_kernel", P), ("inertia_kernel", P), ("gravity", P), ("scratch", P), ("n_arms", I64),
                ("arm_node", P), ("arm_frame", P), ("arm_moves", P), ("arm_values", P), ("values_from", I64),
                ("arm_kernel", P), ("arm_scratch", P)]


class TurningShiftsData(ctypes.Structure):
    """``TurningShifts`` of csrc/turning_shifts.c: the geometry parameters' shifts of subtrees on parts that turn
    (latdyn.analyses.geometry_sensitivities.ReferenceGeometry lays it out; the loop of steps' part,
    latdyn.analyses.sensitivities_in_loop)."""

    _fields_ = [("n", I64), ("anchor", P), ("column", P), ("moved", P), ("below_from", P), ("below", P),
                ("n_nodes", I64), ("node_dofs", P), ("n_assembled", I64), ("shift", P), ("moves", P),
                ("assembled", P), ("n_segments", I64), ("counts", P), ("first", P), ("second", P), ("indices", P),
                ("positions", P), ("stiffness", P), ("n_stiffness", I64), ("indptr", P), ("pattern", P),
                ("nnz", I64), ("mck", P), ("n_links", I64), ("link_node", P), ("link_column", P),
                ("link_moved_block", P), ("link_block", P), ("link_com_move", P), ("body_kernel", P),
                ("com_kernel", P), ("gravity", P)]


class CableForcesData(ctypes.Structure):
    """``CableForces`` of csrc/cable_forces.c: the cables' parameters' ∂r/∂p in the loop of steps
    (latdyn.analyses.sensitivities_in_loop lays it out)."""

    _fields_ = [("n_uses", I64), ("cable", P), ("column", P), ("value", P), ("values", P), ("values_from", I64),
                ("element_cable", P), ("force_kernel", P), ("rest_kernel", P), ("mass_row", P), ("mass_rows", P),
                ("mass_from", P), ("mass_blocks", P), ("mass_gravity", P), ("body_kernel", P), ("scratch", P)]


class TrajectoryData(ctypes.Structure):
    """``Trajectory`` of csrc/adjoint_trajectory.c: the accepted steps one loop of steps stores for the discrete
    adjoint's reverse pass (latdyn.analyses.adjoint_in_loop lays it out)."""

    _fields_ = [("capacity", I64), ("state_size", I64), ("offsets", P), ("states", P), ("times", P), ("sizes", P),
                ("a_old", P), ("a_new", P), ("stored", I64)]


class RowsData(ctypes.Structure):
    """``Rows`` of csrc/rows.c: the rows one loop of steps records on the way (latdyn.step.compiled.RowBuffers)."""

    _fields_ = [("capacity", I64), ("planned", I64), ("grid_point", P), ("momentum", I64), ("sections", I64),
                ("recorded", I64), ("scalars", P), ("section_forces", P), ("states", P),
                ("joints", I64), ("joint_forces", P), ("held", P), ("saved", P), ("cables", I64), ("cable_states", P),
                ("controller_values", I64), ("controller_states", P), ("output_values", I64),
                ("controller_outputs", P)]


#: Element count from which the element part of an evaluation (geometry and kernels) runs on
#: OpenMP threads (csrc/newton_step.c): measured with benchmarks/step_scaling.py --threads on
#: the 2-core machine (docs/performance.md, "Threads": quiet, 2 threads gained 1.18× at 100
#: elements, 1.31× at 10³, 1.72× at 10⁴; with both cores busy with other work they lost up
#: to 3000 elements). ``LATDYN_PARALLEL_ELEMENTS`` overrides it (0: never); ``OMP_NUM_THREADS``
#: sets the number of threads.
PARALLEL_ELEMENTS = 1_000


#: OpenMP flag tried first; a compiler without it builds the serial library (the same results).
OPENMP_FLAGS = ("-fopenmp",)

#: The runtime library's own flags beyond :data:`latdyn.native.C_FLAGS`: the loops of the sparse LU
#: (the update scatter, the scale pass, the unblocked panel columns) and of the assembly vectorized,
#: with the instruction set of the element kernels (:func:`latdyn.native.vector_flags`). Elementwise
#: vector operations with ``-ffp-contract=off`` and no reassociation: the same arithmetic as the
#: scalar loops, bit for bit (docs/performance.md, "Sixth pass": the sparse LU's own instructions
#: −29 % on the 260-member truss).
LIBRARY_FLAGS = ("-O3",)


def parallel_threshold() -> int:
    """The threshold in force: ``LATDYN_PARALLEL_ELEMENTS`` or :data:`PARALLEL_ELEMENTS`."""
    value = os.environ.get("LATDYN_PARALLEL_ELEMENTS", "").strip()
    try:
        return max(0, int(value)) if value else PARALLEL_ELEMENTS
    except ValueError:
        return PARALLEL_ELEMENTS


def native_library() -> ctypes.CDLL:
    """Compile (once, into the kernel cache) and load csrc/newton_step.c, with OpenMP where the
    compiler has it (a failed -fopenmp build is remembered in the cache by an empty marker file)."""
    global _LIBRARY
    if _LIBRARY is None:
        from latdyn import native

        using = native.compiler()
        serial = (*native.C_FLAGS, *LIBRARY_FLAGS, *native.vector_flags(using))
        index = _library_index(using, serial)
        path = _indexed_library(index)
        if path is None:
            source = library_source("newton_step.c")
            for flags in ((*serial, *OPENMP_FLAGS), serial):
                failed = native.target("newton_step", source, flags, using).with_suffix(".failed")
                if flags != serial and failed.exists():
                    continue
                try:
                    path = native.build("newton_step", source, flags, using=using)
                except RuntimeError:
                    if flags == serial:
                        raise
                    failed.touch()  # this compiler has no OpenMP: remembered in the cache
                    continue
                break
            if index is not None:
                native._store(index, path.name)
        library = native.load(path)
        library.latdyn_threads.restype = I64
        library.latdyn_threads.argtypes = []
        library.latdyn_cables.restype = None
        library.latdyn_cables.argtypes = [ctypes.POINTER(ModelData), ctypes.POINTER(WorkData),
                                          ctypes.POINTER(ConfigurationData), ctypes.c_double]
        library.latdyn_energies.restype = None
        library.latdyn_energies.argtypes = [ctypes.POINTER(ModelData), ctypes.POINTER(WorkData),
                                            ctypes.POINTER(ConfigurationData), ctypes.c_double, P]
        library.latdyn_law_spring_integral.restype = ctypes.c_double
        library.latdyn_law_spring_integral.argtypes = [HINGE_LAW_VALUES, I64, ctypes.c_double, ctypes.c_double, I64]
        model, work, configuration = (ctypes.POINTER(ModelData), ctypes.POINTER(WorkData),
                                      ctypes.POINTER(ConfigurationData))
        library.latdyn_momentum.restype = None
        library.latdyn_momentum.argtypes = [model, work, configuration, P]
        library.latdyn_joint_forces.restype = None
        library.latdyn_controller_outputs_at.restype = None
        library.latdyn_controller_outputs_at.argtypes = [model, work, configuration, ctypes.c_double]
        library.latdyn_joint_forces.argtypes = [model, work, configuration, ctypes.c_double, ctypes.c_double, P]
        library.latdyn_sample_restart.restype = I64
        library.latdyn_sample_restart.argtypes = [model, work, configuration, ctypes.c_double, P]
        library.latdyn_sample_controllers.restype = I64
        library.latdyn_sample_controllers.argtypes = [model, work, configuration, ctypes.c_double, ctypes.c_double]
        library.latdyn_evaluate.restype = None
        library.latdyn_evaluate.argtypes = [model, work, configuration, ctypes.POINTER(EvaluationData)]
        library.latdyn_element_inputs.restype = None
        library.latdyn_element_inputs.argtypes = [model, work, configuration]
        library.latdyn_advance_free.restype = None
        library.latdyn_advance_free.argtypes = [model, configuration, P]
        library.latdyn_prescribe.restype = None
        library.latdyn_prescribe.argtypes = [model, work, configuration, ctypes.c_double]
        library.latdyn_complete_links.restype = None
        library.latdyn_complete_links.argtypes = [model, configuration]
        library.latdyn_dependent_rates_tangent.restype = None
        library.latdyn_dependent_rates_tangent.argtypes = [model, configuration]
        library.latdyn_iteration_matrix.restype = None
        library.latdyn_iteration_matrix.argtypes = [model, ctypes.POINTER(WorkData), configuration, ctypes.c_double,
                                                    ctypes.c_double, I64]
        factorization = ctypes.POINTER(FactorizationStructure)
        library.latdyn_factor.restype = I64
        library.latdyn_factor.argtypes = [factorization, P, P]
        library.latdyn_solve.restype = I64
        library.latdyn_solve.argtypes = [factorization, P, P, I64, P]
        library.latdyn_solve_transposed.restype = I64
        library.latdyn_solve_transposed.argtypes = [factorization, P, P, I64, P]
        library.latdyn_sensitivity_step.restype = I64
        library.latdyn_sensitivity_step.argtypes = [ctypes.POINTER(SensitivityStepStructure), P, P, ctypes.c_double,
                                                    ctypes.c_double, P, P, P, I64, P, P, P, P, P]
        library.latdyn_sensitivity_predict.restype = None
        library.latdyn_sensitivity_predict.argtypes = [I64, I64, P, I64, P, P, P, P, P, P, P, P, P, P, P]
        library.latdyn_joint_body_inertia_stiffness.restype = None
        library.latdyn_joint_body_inertia_stiffness.argtypes = [model, configuration, P, P, P, P, P]
        library.latdyn_linked_exact_matrices.restype = None
        library.latdyn_linked_exact_matrices.argtypes = [model, work, configuration, ctypes.c_double, P, P, P, P, P, P,
                                                         P, P]
        library.latdyn_linked_exact_values.restype = None
        library.latdyn_linked_exact_values.argtypes = [model, work, configuration, ctypes.c_double, P, P, P, P, P, P,
                                                       I64, P, P]
        library.latdyn_linked_reduce_columns.restype = None
        library.latdyn_linked_reduce_columns.argtypes = [model, P, I64, P]
        library.latdyn_linked_matrices.restype = None
        library.latdyn_linked_matrices.argtypes = [model, work, configuration, I64, I64, I64, I64, P, P, I64, P, P]
        library.latdyn_linked_reduce_total.restype = None
        library.latdyn_linked_reduce_total.argtypes = [model, P]
        library.latdyn_prescribed_time_rate.restype = None
        library.latdyn_prescribed_time_rate.argtypes = [model, work, P, P, I64, P, P, P, P]
        library.latdyn_linked_prescribed_time_rate.restype = None
        library.latdyn_linked_prescribed_time_rate.argtypes = [model, work, configuration, P, P, I64, P, P, P, P, P,
                                                               P, P]
        library.latdyn_linked_geometric_product.restype = None
        library.latdyn_linked_geometric_product.argtypes = [model, configuration, P, P, P, P]
        library.latdyn_linked_geometric_second.restype = None
        library.latdyn_linked_geometric_second.argtypes = [model, configuration, P, P, P, P, P, P, P]
        library.latdyn_exact_matrix_values.restype = None
        library.latdyn_turning_shifts.restype = None
        library.latdyn_turning_shifts.argtypes = [P, I64, P, P, P]
        library.latdyn_turning_shift_forces.restype = None
        library.latdyn_turning_shift_forces.argtypes = [P, I64, I64, P, P, P, P, P, I64, P, P, P]
        library.latdyn_link_inertia_forces.restype = None
        library.latdyn_link_inertia_forces.argtypes = [P, I64, I64, P, P, P, P, P, P]
        library.latdyn_exact_matrix_values.argtypes = [I64, P, P, P, P, P, I64, P]
        library.latdyn_section_parameter_forces.restype = None
        library.latdyn_section_parameter_forces.argtypes = [model, work, configuration, P, P, I64, P, I64, P, I64, P,
                                                            P, P, P, I64, P, P]
        library.latdyn_adjoint_reverse_step.restype = I64
        library.latdyn_adjoint_reverse_step.argtypes = [model, work, P, configuration, ctypes.c_double, ctypes.c_double,
                                                        P, I64, I64, P, P, P, P, P, P, P, P, P, I64]
        library.latdyn_sensitivity_update.restype = None
        library.latdyn_sensitivity_update.argtypes = [I64, I64, P, ctypes.c_double, ctypes.c_double, I64, P, P, P, P,
                                                      P]
        library.latdyn_newton_step.restype = I64
        library.latdyn_newton_step.argtypes = [model, work, ctypes.POINTER(ControlData), configuration,
                                               configuration, ctypes.POINTER(VectorsData)]
        library.latdyn_controller_states_accept.restype = None
        library.latdyn_controller_states_accept.argtypes = [model, work, configuration, ctypes.c_double,
                                                            ctypes.c_double]
        # the accounts of a step accepted from Python, the loop of steps' own (csrc/newton_step.c)
        library.latdyn_drive_forces.restype = None
        library.latdyn_drive_forces.argtypes = [model, P, P]
        library.latdyn_increment_size.restype = ctypes.c_double
        library.latdyn_increment_size.argtypes = [model, P, ctypes.c_double]
        library.latdyn_drive_work.restype = ctypes.c_double
        library.latdyn_drive_work.argtypes = [model, configuration, configuration, P, P, ctypes.c_double]
        library.latdyn_far_root.restype = I64
        library.latdyn_far_root.argtypes = [model, configuration, configuration, ctypes.c_double, P, P]
        library.latdyn_rate_turns.restype = None
        library.latdyn_rate_turns.argtypes = [model, configuration, configuration, ctypes.c_double, ctypes.c_double,
                                              ctypes.c_double, P]
        library.latdyn_hinge_work.restype = None
        library.latdyn_hinge_work.argtypes = [I64, P, P, P, P, P, P, P, P]
        # the dissipated energy's sensitivity over a step accepted from Python, the loop of steps' own
        # (csrc/work_accounts.c)
        # the continuous controllers' states through the sensitivities' step (csrc/controller_states.c)
        library.latdyn_controller_states_begin.restype = I64
        library.latdyn_controller_states_begin.argtypes = [I64, I64, ctypes.c_double, P, P, P, P, P, P, P, P, P, P]
        library.latdyn_section_force_slope.restype = None
        library.latdyn_section_force_slope.argtypes = [model, work, configuration, P, I64, I64, P, I64, P, P, P, I64, P]
        library.latdyn_controller_states_sensed.restype = None
        library.latdyn_controller_states_sensed.argtypes = [model, work, configuration, ctypes.c_double, I64, I64, P, P,
                                                            I64, P, P, P]
        library.latdyn_controller_states_after.restype = None
        library.latdyn_controller_states_after.argtypes = [I64, I64, I64, ctypes.c_double, P, P, P, P, P, P, P, P, P,
                                                           P, P, P]
        library.latdyn_damper_torques.restype = None
        library.latdyn_damper_torques.argtypes = [I64, I64, P, P, P, P, I64, P, P, P, P, P]
        library.latdyn_dissipated_step.restype = None
        library.latdyn_dissipated_step.argtypes = [I64, I64, P, P, P, P, P, P, P, P, P]
        library.latdyn_load_power.restype = ctypes.c_double
        library.latdyn_load_power.argtypes = [I64, I64, P, P, P, P, P, P, P, P, P, I64, P, P, P, P]
        library.latdyn_applied_torques.restype = None
        library.latdyn_applied_torques.argtypes = [I64, I64, P, P, P, P, I64, P, P, P, P, P, P]
        library.latdyn_external_work_increment.restype = None
        library.latdyn_external_work_increment.argtypes = [I64, I64, ctypes.c_double, P, ctypes.c_double, P,
                                                           ctypes.c_double, P, P, P, P, P, P, P, P, P, P]
        library.latdyn_drive_reaction_rates.restype = None   # csrc/drive_sensitivities.c
        library.latdyn_drive_reaction_rates.argtypes = [model, work, P, I64, P, P, P, P, P, P, P]
        library.latdyn_drive_work_sensitivity.restype = None
        library.latdyn_drive_work_sensitivity.argtypes = [I64, I64, P, P, P, P]
        library.latdyn_dependent_node_motion.restype = None   # csrc/work_accounts.c
        library.latdyn_dependent_node_motion.argtypes = [model, configuration, I64, I64, P, P, P, P]
        library.latdyn_cable_work.restype = None
        library.latdyn_cable_work.argtypes = [I64, P, P, P, P]
        library.latdyn_cable_crossed.restype = I64
        library.latdyn_cable_crossed.argtypes = [model, P, P]
        library.latdyn_may_stick.restype = None
        library.latdyn_may_stick.argtypes = [model, P, P, ctypes.c_double, P]
        library.latdyn_hinge_crossings.restype = None
        library.latdyn_hinge_crossings.argtypes = [model, P, P, P, P]
        library.latdyn_advance.restype = I64
        library.latdyn_advance.argtypes = [ctypes.POINTER(ModelData), ctypes.POINTER(WorkData), ctypes.POINTER(ControlData),
                                           ctypes.POINTER(ConfigurationData), ctypes.POINTER(ConfigurationData),
                                           ctypes.POINTER(ConfigurationData), ctypes.POINTER(VectorsData),
                                           ctypes.POINTER(AdvanceData)]
        static = ctypes.POINTER(StaticControlData)
        library.latdyn_static_iteration.restype = I64
        library.latdyn_static_iteration.argtypes = [model, work, static, configuration, P]
        library.latdyn_static_newton.restype = I64
        library.latdyn_static_newton.argtypes = [model, work, static, configuration, P]
        library.latdyn_lookup3.restype = ctypes.c_uint32
        library.latdyn_lookup3.argtypes = [ctypes.c_char_p, I64, ctypes.c_uint32]
        _LIBRARY = library
    return _LIBRARY


def loaded_library() -> ctypes.CDLL | None:
    """The library :func:`native_library` loaded, or None before it has (nothing is compiled or loaded
    here: latdyn's HDF5 writer checksums through it where a run has it, in Python otherwise)."""
    return _LIBRARY


def _library_index(using, serial: tuple):
    """The path of the compiled step's index in the kernel cache (a text file naming the library
    :func:`native_library` chose, with OpenMP or without), under a digest of what determines that library
    without reading its sources: the identity (path, size, modification time, inode) of every file of
    csrc/ (:func:`library_source` includes only those), of this module and of :mod:`latdyn.native`, the
    compiler's identity, the flags and the Python version. Reading and digesting the 0.23 MB of source
    took 2.3 ms of every fresh run (docs/performance.md, "Eleventh pass"); an edited file changes its
    identity, so the index is not found and the library is found (or compiled) from the source as before.
    None where the files cannot be listed."""
    import sys

    from latdyn import native

    try:
        folder = native.package_folder("latdyn.assembly") / "csrc"
        paths = sorted(os.path.join(folder, name) for name in os.listdir(folder))
        identities = []
        for path in (*paths, __file__, native.__file__):
            status = os.stat(path)
            identities += [os.path.realpath(path), status.st_size, status.st_mtime_ns, status.st_ino]
    except (OSError, TypeError):
        return None
    digest = native.source_digest("newton_step", sys.version, using.identity(), *serial, *OPENMP_FLAGS, *identities)
    return native.cache_dir() / f"index-newton_step-{digest}.txt"


def _indexed_library(index):
    """The library an index of :func:`_library_index` names, where both are in the cache; else None."""
    from latdyn import native

    if index is None:
        return None
    try:
        path = native.cache_dir() / index.read_text().strip()
    except (OSError, ValueError):
        return None
    return path if path.name.startswith("newton_step-") and native.intact(path) else None


def library_source(name: str) -> bytes:
    """csrc/<name> with its local ``#include "x.c"`` lines replaced by those files, recursively (one
    source file to compile, and the cache digest covers all of it)."""
    from latdyn.native import package_folder

    folder = package_folder("latdyn.assembly") / "csrc"
    lines = []
    for number, line in enumerate((folder / name).read_bytes().splitlines(keepends=True), start=1):
        words = line.split()
        if len(words) >= 2 and words[0] == b"#include" and words[1].startswith(b'"'):
            included = words[1].strip(b'"')
            lines += [b'#line 1 "%s"\n' % included, library_source(included.decode()),
                      b'\n#line %d "%s"\n' % (number + 1, name.encode())]  # compiler messages keep their files
        else:
            lines.append(line)
    return b"".join(lines)


def openmp_threads() -> int:
    """Threads the compiled step uses above the threshold: 0 when it was built without OpenMP."""
    return int(native_library().latdyn_threads())


def cython_address(module, name: str) -> int:
    """The address of a routine from one of SciPy's cython_blas / cython_lapack capsules."""
    capsule = module.__pyx_capi__[name]
    get_name = ctypes.pythonapi.PyCapsule_GetName
    get_name.restype, get_name.argtypes = ctypes.c_char_p, [ctypes.py_object]
    get_pointer = ctypes.pythonapi.PyCapsule_GetPointer
    get_pointer.restype, get_pointer.argtypes = ctypes.c_void_p, [ctypes.py_object, ctypes.c_char_p]
    return get_pointer(capsule, get_name(capsule))


def scipy_extension(name: str):
    """SciPy's compiled module ``scipy.<name>`` (``"linalg.cython_lapack"``), loaded without the
    package around it: ``import scipy.linalg.cython_lapack`` would run ``scipy/linalg/__init__.py``,
    which imports all of scipy.linalg and scipy.sparse's array machinery (≈0.2 s of CPU, more than
    a short run; docs/performance.md, "First run"), while the capsules need only the extension
    itself (and SciPy's top package, which loads SciPy's OpenBLAS). The module is registered
    under its own name, so a later ``import scipy.linalg`` finds it rather than loading it twice."""
    import importlib.machinery
    import importlib.util
    import sys

    full = f"scipy.{name}"
    if full in sys.modules:
        return sys.modules[full]
    package = importlib.util.find_spec("scipy")  # the top package only: scipy.linalg is not run
    if package is None or not package.submodule_search_locations:
        raise ImportError(f"SciPy is not installed: no {full}")
    folder = os.path.join(package.submodule_search_locations[0], *name.split(".")[:-1])
    for suffix in importlib.machinery.EXTENSION_SUFFIXES:
        path = os.path.join(folder, name.split(".")[-1] + suffix)
        if os.path.exists(path):
            break
    else:  # not a compiled module where this SciPy keeps it: the ordinary import
        return importlib.import_module(full)
    import scipy  # noqa: F401 - the extension's own imports (scipy._cyutility) need the top package

    spec = importlib.util.spec_from_file_location(full, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[full] = module
    try:
        spec.loader.exec_module(module)
    except BaseException:
        del sys.modules[full]
        raise
    return module


def lapack_address(name: str) -> int:
    """The address of a LAPACK routine from SciPy's cython_lapack capsules."""
    return cython_address(scipy_extension("linalg.cython_lapack"), name)


class LapackRoutines(NamedTuple):
    """LAPACK routines of one library: ``addresses`` by name (``"dgbtrf"``), the integer width they
    take (``integer_bytes``: 4, or 8 for an ILP64 build) and the addresses of that library's
    ``openblas_get_num_threads`` / ``openblas_set_num_threads`` (None, None: not pinned)."""

    addresses: dict
    integer_bytes: int
    blas_threads: tuple


_numpy_lapack: "LapackRoutines | None | bool" = False  # found once per process (False: not yet looked)

#: The routines :func:`numpy_lapack` hands (the LUs' and the held check's Cholesky).
NUMPY_LAPACK_ROUTINES = ("dgetrf", "dgetrs", "dgbtrf", "dgbtrs", "dpbtrf")


def numpy_lapack() -> "LapackRoutines | None":
    """``dgetrf``, ``dgetrs``, ``dgbtrf``, ``dgbtrs`` and ``dpbtrf`` of the OpenBLAS that NumPy's wheel carries and has already
    loaded (``numpy.libs/libscipy_openblas64_…``), with the integer width read from the library itself
    (``openblas_get_config``'s ``USE64BITINT``; NumPy 2's wheels are ILP64, symbols ``scipy_dgbtrf_64_``;
    without the configuration, the symbol's ``64`` says it): the band LU and the held check need no
    SciPy then, whose top package and cython_lapack with its own OpenBLAS cost ≈ 15 ms of CPU at a
    run's start (docs/performance.md, "Seventh pass"). None where no such library is found loaded
    (Linux's ``/proc/self/maps``: elsewhere, NumPy built on another BLAS, or routines missing): then
    SciPy's :func:`lapack_address` serves. The factorizations take from it the kinds
    :data:`latdyn.assembly.factorization.NUMPY_LAPACK_KINDS` names (the band LU). Only an ILP64 library's
    (``integer_bytes`` 8): csrc/factorization.c calls those routines by their Fortran symbols with a
    character argument's hidden length, and takes a 32-bit LAPACK as SciPy's cython_lapack hands it
    (without one), so a 32-bit OpenBLAS of NumPy's is left to SciPy's."""
    global _numpy_lapack
    if _numpy_lapack is False:
        _numpy_lapack = _ilp64_only(_find_numpy_lapack())
    return _numpy_lapack


def _ilp64_only(routines: "LapackRoutines | None") -> "LapackRoutines | None":
    """``routines`` where they take 64-bit integers, else None (:func:`numpy_lapack`)."""
    return routines if routines is not None and routines.integer_bytes == 8 else None


def _wheel_openblas():
    """The OpenBLAS that NumPy's wheel carries (the one ``*openblas*`` file of ``numpy.libs`` beside the numpy
    package), opened without loading it again (``RTLD_NOLOAD``: only where this process has loaded it), else
    None (then ``/proc/self/maps`` is read, :func:`latdyn.numerics.linalg.loaded_openblas`). The same library
    the maps show loaded from NumPy's folder, found without reading them (≈ 1 ms of a fresh run;
    docs/performance.md, "Twelfth pass")."""
    import sys

    numpy = sys.modules.get("numpy")
    try:
        folder = os.path.join(os.path.dirname(os.path.dirname(numpy.__file__)), "numpy.libs")
        found = [name for name in os.listdir(folder) if "openblas" in name.lower()]
    except (AttributeError, TypeError, OSError):
        return None
    if len(found) != 1 or not hasattr(os, "RTLD_NOLOAD"):
        return None
    try:
        return ctypes.CDLL(os.path.join(folder, found[0]), mode=os.RTLD_NOLOAD | ctypes.RTLD_LOCAL)
    except OSError:  # not loaded (NumPy on another BLAS)
        return None


def _find_numpy_lapack() -> "LapackRoutines | None":
    from pathlib import PurePath

    from latdyn.numerics.linalg import loaded_openblas

    library = _wheel_openblas()
    if library is None:
        library = loaded_openblas(lambda p: any(part == "numpy" or part.startswith("numpy.")
                                                for part in PurePath(p).parent.parts))
    if library is None:
        return None
    for prefix in ("scipy_", ""):
        for tail in ("_64_", "64_", "_"):
            found = {name: getattr(library, f"{prefix}{name}{tail}", None) for name in NUMPY_LAPACK_ROUTINES}
            if all(found.values()):
                break
        else:
            continue
        break
    else:
        return None
    suffix = "64_" if "64" in tail else ""
    threads = [getattr(library, f"{prefix}openblas_{what}_num_threads{suffix}", None) for what in ("get", "set")]
    config = getattr(library, f"{prefix}openblas_get_config{suffix}", None)
    if config is not None:
        config.restype = ctypes.c_char_p
        integer_bytes = 8 if b"USE64BITINT" in (config() or b"") else 4
    else:
        integer_bytes = 8 if "64" in tail else 4
    address = lambda function: ctypes.cast(function, ctypes.c_void_p).value  # noqa: E731
    return LapackRoutines({name: address(f) for name, f in found.items()}, integer_bytes,
                          (address(threads[0]), address(threads[1])) if all(threads) else (None, None))


