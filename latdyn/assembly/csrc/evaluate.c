/*
 * One evaluation of the equations of motion of a model, in C: the runtime's only one.
 *
 * Runtime code, written by hand, that holds no physics of its own: the element, joint-body,
 * point-load, hinge, nodal-frame (Eq. 17) and SO(3) terms come from the generated kernels
 * (generated/beam_<variant>.c, generated/joints.c; codegen/), called through function pointers,
 * and the scene's laws from its compiled laws (codegen/laws.py). What is here gathers their
 * inputs from a configuration, calls them, and sums their outputs into the vector of all
 * coordinates (Eq. 58: r = Σ_e L_eᵀ [F_e + M_e a_e + g_e − λ Q_e^grav] + bodies + hinges − λ loads)
 * with the element, body, hinge and load blocks of K, M and C kept apart, so that every analysis
 * (the time step of newton_step.c, static paths, modes, the explicit method, rigid links through
 * latdyn/assembly/linked.py) reads the same numbers: latdyn_evaluate, called from Python by
 * latdyn/assembly/native_model.py. Also here: the configuration update q ∘ exp(Δ) and the
 * prescribed motion, the only ones (latdyn_advance_free and latdyn_prescribe for the analyses driven
 * from Python, configure for the step), the elements' inertia tangent (the generated kernel
 * beam_inertia_tangent, codegen/derivation.py), and the energies.
 *
 * Storage: node arrays row-major (x: n_nodes×3, T: n_nodes×3×3), coordinate vectors of
 * length n_total + 1 (index n_total is the dummy of clamped ends). The Model and Work structs
 * are mirrored in latdyn/assembly/library.py (tests/test_engine.py checks every offset).
 *
 * Threads: the element part of an evaluation (geometry, Eq. 17, and the generated kernels)
 * is split into contiguous ranges of elements, one per OpenMP thread, when the model has at
 * least `parallel_elements` elements (0: never) and the library was compiled with -fopenmp.
 * Every element writes only its own rows of the Work buffers, and the sums into the vector of
 * all coordinates stay one serial loop in element order, so the result equals the serial
 * evaluation's for any number of threads.
 */
#include <math.h>
#include <stdint.h>
#include <string.h>
#ifdef _OPENMP
#include <omp.h>
#endif

#include "factorization.c" /* the iteration matrix's storage and LU, which the Model points to */
struct Links; /* rigid links in the compiled step: links.c */
typedef void (*kernel_2_1)(int64_t, const double *, const double *, double *);
typedef void (*kernel_2_2)(int64_t, const double *, const double *, double *, double *);
typedef void (*kernel_3_1)(int64_t, const double *, const double *, const double *, double *);
typedef void (*kernel_3_2)(int64_t, const double *, const double *, const double *, double *, double *);
typedef void (*kernel_3_3)(int64_t, const double *, const double *, const double *, double *, double *,
                           double *);
typedef void (*kernel_5_2)(int64_t, const double *, const double *, const double *, const double *, const double *,
                           double *, double *);
typedef void (*kernel_gravity)(int64_t, const double *, const double *, const double *, double *, double *,
                               double *);
/* the generated unit generated/joints.c (codegen/joints.py) */
typedef void (*kernel_joint_body)(int64_t, const double *, const double *, const double *, const double *, double *,
                                  double *, double *, double *);
typedef void (*kernel_point_load)(int64_t, const double *, const double *, const double *, const double *,
                                  const double *, double *, double *, double *, double *);
typedef void (*kernel_hinged_end)(int64_t, const double *, const double *, double *, double *, double *);
typedef void (*kernel_hinge_force)(int64_t, const double *, const double *, const double *, double *, double *,
                                   double *, double *, double *, double *, double *);
typedef void (*kernel_so3_exp)(int64_t, const double *, double *);
typedef void (*kernel_so3_dexp)(int64_t, const double *, double *);
typedef void (*kernel_so3_log_increment)(int64_t, const double *, const double *, double *);

/* A configuration: all nodes and hinges. */
typedef struct {
    double *x, *T, *v, *w, *a, *alpha, *theta, *theta_dot, *theta_ddot;
} Configuration;

/* The model, as arrays (latdyn.model.Model and the Assembler's scatter maps). */
typedef struct {
    int64_t n_nodes, n_hinges, n_elements, n_bodies, n_loads, n_dofs, n_total;
    const int64_t *node_dofs;   /* (n_nodes, 6) */
    const int64_t *hinge_dofs;  /* (n_hinges) */
    int64_t n_free_nodes, n_free_hinges;
    const int64_t *free_nodes, *free_hinges;
    /* prescribed bodies: law indices of the translation (n_prescribed, 3; -1: none) and angle (-1: none) */
    int64_t n_prescribed;
    const int64_t *prescribed_nodes, *translation_law, *angle_law;
    const double *rotation_axis; /* (n_prescribed, 3) */
    const double *node_x0;       /* (n_nodes, 3) */
    const int64_t *hinge_angle_law; /* (n_hinges) -1: none */
    const int64_t *hinge_locked;    /* (n_hinges) */
    /* elements */
    const int64_t *element_nodes, *element_hinges, *element_dofs;
    const double *element_axes, *element_frames0, *element_offsets, *element_sections;
    /* joint bodies with inertia */
    const int64_t *body_nodes;
    const double *body_mass, *body_com, *body_inertia;
    /* hinges: f = k (θ − θ_r) + c θ̇ − τ(t) */
    const double *hinge_stiffness, *hinge_damping, *hinge_rest_angle;
    const int64_t *hinge_torque_law;
    /* point loads */
    const int64_t *load_node, *load_force_law, *load_moment_law, *load_frame_node;
    const double *load_r;
    double gravity[3];
    int64_t has_gravity;
    /* matrix positions of the block entries (dense, band or sparse storage), -1: constrained */
    const int64_t *element_position; /* (n_elements, 14, 14) */
    const int64_t *body_position;    /* (n_bodies, 6, 6) */
    const int64_t *hinge_position;   /* (n_hinges) diagonal entry */
    const int64_t *load_position;    /* (n_loads, 6, 6): the node's rows × its rotations, then its frame body's */
    /* the iteration matrix's storage and LU (factorization.c) */
    const Factorization *factorization;
    /* kernels */
    kernel_2_1 internal_force;
    kernel_2_2 internal_force_D_q;
    kernel_2_1 mass_matrix;
    kernel_3_1 quadratic_velocity;
    kernel_3_2 quadratic_velocity_D_qdot;  /* g^e and its q̇-derivative */
    kernel_gravity gravity_load;
    kernel_2_2 strain_energy;
    kernel_3_1 kinetic_energy;
    kernel_5_2 inertia_force_D_q; /* M a + g − Q and its exact ∂/∂q (beam_inertia_tangent) */
    kernel_joint_body joint_body;
    kernel_point_load point_load;
    const double *body_section; /* (n_bodies, 13): m c[3] I[9], the joint_body kernel's input */
    kernel_hinged_end hinged_end;
    const double *element_ends; /* (n_elements, 2, 16): a[3] r[3] E0[9] theta, the hinged_end kernel's input */
    kernel_hinge_force hinge_force;
    kernel_so3_exp so3_exp; /* exp(skew w), the generated kernel (codegen/joints.py) */
    kernel_so3_dexp so3_dexp; /* dexp(w), its tangent operator, the generated kernel (codegen/joints.py) */
    kernel_so3_log_increment so3_log_increment; /* log(T_{n+1} T_nᵀ), the generated kernel (codegen/joints.py) */
    /* threads (see the header): element count from which the element part runs in parallel
     * (0: never), and the number of threads (0: OpenMP's default) */
    int64_t parallel_elements, threads;
    /* the scene's laws, compiled by the code generator (codegen/laws.py, latdyn/assembly/compiled_laws.py),
     * or Python callbacks where a law does not print in C: every function of time at t (3 values
     * each: f, f', f'') into the buffer given, and hinge law k at (θ, θ̇, t) (f, ∂f/∂θ, ∂f/∂θ̇). */
    void (*time_laws)(double, double *);
    void (*hinge_laws)(int64_t, double, double, double, double *);
    /* hinges with laws in θ, θ̇ or t: the hinge law of the stiffness,
     * the damping and the torque (-1: the constant of hinge_stiffness/hinge_damping, no torque
     * law in θ or θ̇), and whether the spring is conservative (else its work is external) */
    const int64_t *hinge_stiffness_law, *hinge_damping_law, *hinge_torque_hinge_law, *hinge_conservative;
    /* events that end a loop of steps (latdyn_advance; latdyn/timeloop/events.py handles them): lock_at and the
     * lower and upper stop of each hinge (NAN: none) */
    const double *hinge_lock_at, *hinge_lower_stop, *hinge_upper_stop;
    int64_t has_events;
    int64_t section_width; /* columns of element_sections (latdyn.model.SECTION_WIDTH) */
    /* models with rigid links (NULL without): their dependent nodes, the edges and the expansions the
     * compiled step completes and reduces each Newton iteration with (links.c, set up by
     * latdyn/step/compiled.py); the analyses driven from Python reduce with latdyn/assembly/linked.py */
    const struct Links *links;
    /* continuous controllers (latdyn/assembly/control.py; n_controllers 0: none): controller k reads
     * sensors sensor_start[k] … sensor_start[k+1]−1 (kind: 0 hinge angle, 1 hinge rate, 2 node
     * position component, 3 node velocity component; index: the hinge, or 3·node + axis; origin
     * subtracted), its generated law (controller_laws: y, ∂y/∂s) gives the output, clipped to
     * controller_limits and written to controller_outputs[controller_slot[k]] (the array the
     * compiled laws read); actuators (kind 0: hinge torque, 1: load component) apply it, and each
     * coupling entry (actuator, row slot, sensor) is ∂r/∂q of the actuator's row by the sensor's
     * coordinate, in K (position sensors) or C (rate sensors), at coupling_position in the matrix. */
    int64_t n_controllers, n_sensors, n_actuators, n_couplings;
    void (*controller_laws)(int64_t, double, const double *, double *);
    double *controller_outputs;
    const int64_t *controller_slot;
    const double *controller_limits;
    const int64_t *sensor_start, *sensor_kind, *sensor_index;
    const double *sensor_origin;
    const int64_t *hinge_controller, *load_controller;
    const int64_t *actuator_kind, *actuator_index, *actuator_component, *actuator_controller;
    const int64_t *coupling_actuator, *coupling_slot, *coupling_sensor, *coupling_position;
    /* (n_hinges, 11): each joint's compliant stop and friction, the hinge_force kernel's `contact`
     * input (codegen/joints.py joint_contact; zeros with stick_rate 1: none) */
    const double *hinge_contact;
    /* cable elements (latdyn/model/cables.py): the node of each end (ce,2), the end points in node
     * axes (ce,2,3), share of the rest length, EA, c (ce,3), the law of the cable's rest length
     * (ce), the positions of their (12,12) blocks in the matrix storage (ce,144; set with it), and
     * the generated taut law (codegen/joints.py cable_force) */
    int64_t n_cables;
    const int64_t *cable_nodes;
    const double *cable_offsets, *cable_section;
    const int64_t *cable_rest_law, *cable_position;
    void (*cable_force)(int64_t, const double *, const double *, const double *, double *, double *, double *,
                        double *, double *, double *, double *, double *);
    /* the side of each cable element (ce) that the time loop holds for a step: +1 taut, −1 slack, 0 the
     * stretch decides (every other analysis); latdyn/timeloop/events.py */
    const double *cable_side;
    /* the gravity load and its exact tangent ∂Q/∂q (the generated kernel beam_gravity_D_q): the
     * static Newton matrix's K − λ ∂Q/∂q; NULL in a variant generated before it (left out) */
    kernel_3_2 gravity_load_D_q;
    /* states of continuous controllers (latdyn/assembly/control.py; n_controller_states 0: none):
     * controller k's states are state_start[k] … state_start[k+1]−1, state i the entry
     * controller_state_slot[i] of controller_states (S at the last accepted state: the runtime's
     * array, scene.controller_states) with its rate dS/dt there in controller_state_rate[i]. A law of
     * a controller with p states and m sensors reads (s, S) and gives (1 + p)(1 + m + p) values:
     * y, ∂y/∂(s, S), then f_j, ∂f_j/∂(s, S) of each state (codegen/laws.py). */
    int64_t n_controller_states;
    const int64_t *controller_state_start, *controller_state_slot;
    double *controller_states, *controller_state_rate;
    /* actuators inside an expression τ = a y + b of a hinge torque, guide force or load component
     * (latdyn/assembly/control.py): actuator_gain[a] = a (0 for the controller's name alone, applied
     * by the hinge_controller / load_controller above); such a law reads the controllers' outputs
     * itself, so with n_law_actuators > 0 the laws of time are taken again after the outputs */
    const double *actuator_gain;
    int64_t n_law_actuators;
    /* sensors of kind 4: the output of an earlier continuous controller (sensor_index its position k;
     * latdyn/assembly/control.py), read after that one is computed; with n_chained > 0 the coupling
     * entries take the total derivative of each controller by the coordinate sensors it reaches
     * (Work controller_total, the chain rule through the outputs it reads) */
    int64_t n_chained;
    /* sensors of kind 5: a global component of the position of a point offset from its node by
     * sensor_offset (n_sensors, 3; node axes), sensor_index 3 node + component: p_c = x_c + (T r)_c;
     * its gradient by the node's six coordinates is the generalized force of a unit force along the
     * component at the point (the generated point_load kernel: Jᵀ e_c), and each coupling entry e
     * names its column among them (coupling_column, 0 for sensors of one coordinate); kind 6: the
     * component of its velocity v + ω × T r, columns the node's six rates then its three rotations */
    const double *sensor_offset;
    const int64_t *coupling_column;
    /* sensors of kind 7: a component of a point's position in the axes of a body: s = b_c · (p − x_b),
     * b_c = T_b e_c the body's axis, p = x_n + T_n r (sensor_index 3 n + c, sensor_offset r, the body's
     * node sensor_frame_node[i]); columns the point node's six coordinates, then the body node's six */
    const int64_t *sensor_frame_node;
    /* sensors of kind 8: a cable's length Σ ℓ_e over its elements sensor_index … (consecutive), ℓ_e the
     * distance of the element's end points (cable_nodes, cable_offsets), its gradient by the two end
     * nodes' coordinates −Jᵀ_a e and Jᵀ_b e (e the unit vector from a to b; point_load); the columns of
     * sensor i's gradient are sensor_column_start[i] … sensor_column_start[i+1]−1 of Work sensor_jacobian
     * (kinds 5, 6, 7: 6, 9 and 12 columns; 12 an element for kind 8; 24 for kind 11, 14 for 12; none for the others) */
    const int64_t *sensor_column_start;
    /* sampled controllers (latdyn/assembly/control.py _wire_sampled, csrc/sampling.c; n_sampled 0: none), in
     * file order: controller k samples at the instants j / sampled_rate[k], reads the sensors
     * sampled_sensor_start[k] … [k+1]−1 (after the continuous controllers' n_sensors; kind 4 any controller's
     * output, sensor_index its entry in controller_outputs; 9 a value handed in, Work sampled_values; 10 a
     * controller's state, sensor_index its entry in controller_states) and its states sampled_state_slot[
     * sampled_state_start[k] …] of controller_states, clips its output to sampled_limits (k, 2) into
     * controller_outputs[sampled_slot[k]]; its generated law (codegen/laws.py latdyn_sampled_laws) gives y
     * and each state's rate */
    int64_t n_sampled;
    void (*sampled_laws)(int64_t, double, const double *, double *);
    const int64_t *sampled_sensor_start, *sampled_slot, *sampled_state_start, *sampled_state_slot;
    const double *sampled_limits, *sampled_rate;
    /* sensors of kind 11: the tension of a cable's first element sensor_index (the probe's), the
     * generated cable_tension (codegen/joints.py: N_el, N and N's exact derivatives by the end nodes'
     * coordinates and rates, 24 columns of sensor_jacobian); 0 while the element is slack (its side
     * cable_side, or side 0 and min(N_el, N) ≤ 0, as cables() decides) */
    void (*cable_tension)(int64_t, const double *, const double *, const double *, double *, double *, double *);
    /* sensors of kind 12: an element's section force w0 S_k + w1 S_(k+1) of its mid-element section forces
     * S = [N, T, M_y', M_z'] (sensor_index 4 e + k, sensor_offset [w0, w1, 0]), by the element's fourteen
     * coordinates (element_dofs), the generated beam_section_forces_D_q (codegen/derivation.py) */
    kernel_2_2 section_forces_D_q;
    /* sensors of kind 13: a component of a point's velocity relative to a body, in its axes (sensor_index
     * 3 n + c, sensor_offset r, the body's node sensor_frame_node[i]): 24 columns, the point node's and the
     * body's coordinates (K), then their rates (C) (sensor_value); kind 14: a free joint's force, sensor_index
     * the joint, its law's value and ∂/∂θ (K), ∂/∂θ̇ (C) (2 columns) */
    /* M^e, g^e and ∂g^e/∂q̇ in one call (the generated beam_inertia_matrices: mass_matrix and
     * quadratic_velocity_D_qdot sharing the element's kinematics), for an evaluation with matrices; NULL
     * in a variant generated before it: the two kernels then */
    kernel_3_3 inertia_matrices;
    /* the events' tolerances, computed once in Python and read by the loop of steps' tests (newton_step.c
     * hinge_event, cable_event): (n_hinges, 3) the tolerance of each hinge's lock_at, lower and upper stop
     * (latdyn/model/model.py lock_tolerance; 0 where none), (ce) that of each cable element's gap
     * (latdyn/model/cables.py cable_tolerance) */
    const double *hinge_event_tolerance, *cable_tolerance;
    /* sensors of kind 13: the generated point_velocity_in_body (codegen/joints.py: the point's velocity relative to
     * the body in its axes with its exact derivatives by the two nodes' coordinates and rates; NULL without such a
     * sensor) */
    void (*point_velocity_in_body)(int64_t, const double *, const double *, double *, double *, double *);
} Model;

/* Scratch buffers, allocated once by the caller. */
typedef struct {
    double *geometry, *rates, *accelerations, *gravity_rows; /* (e,36) (e,14) (e,14) (e,3) */
    double *force, *tangent, *mass, *quadratic, *quadratic_D; /* (e,14) (e,14,14) (e,14,14) (e,14) (e,14,14) */
    double *gravity_force, *gravity_potential, *first_moment;  /* (e,14) (e) (e,3) */
    double *body_vector, *body_mass, *body_damping, *body_stiffness; /* (b,6) (b,6,6)×3 */
    double *load_blocks;                                       /* (l,6,6) */
    double *strain, *section_forces, *kinetic;                 /* (e) (e,4) (e) */
    double *total;                                             /* n_total + 1 */
    double *matrix;                                            /* factorization->size */
    int *pivots;                                               /* n_dofs */
    double *rhs;                                               /* n_dofs */
    /* the inertia tangent: its blocks (e,14,14) and the kernel's M a + g − Q (e,14) */
    double *inertia_tangent, *inertia_force;
    /* the law values at the step's time (n_laws, 3), and the hinge forces' derivatives ∂f/∂θ
     * and ∂f/∂θ̇ of the last evaluation (n_hinges each: diagonal entries of K and C) */
    double *laws, *hinge_d_theta, *hinge_d_rate;
    /* per cable element at the last evaluation (ce,4): [ℓ, L0, ∂U/∂L0, f] its length, its share of the
     * rest length, the rest length's generalized force (a reel's: 0 while slack) and the dissipative
     * force f of its damper (c ℓ̇ taut, −N_el while the damper cancels the elastic tension, 0 slack);
     * the time loop integrates their work over each step's ΔL0 and Δℓ (newton_step.c cable_work) */
    double *cable_work;
    /* each joint's law force f of the last evaluation (n_hinges: hinges and guides), for the joint
     * force probes (latdyn/results/probes.py ProbeSet.joint_forces) */
    double *joint_forces;
    /* continuous controllers: the sensors' values and ∂y/∂s (n_sensors; 0 where saturated), the
     * controller law's output buffer (n_sensors + 1), and the coupling entries of K and C (n_couplings) */
    double *sensor_values, *controller_gradient, *controller_scratch, *coupling_stiffness, *coupling_damping;
    /* cable elements at the last evaluation: residual rows (ce,12), K and C blocks (ce,12,12) (zero
     * while slack), [ℓ, ℓ̇, ℓ − L0, N_el, N] with N = 0 while slack (ce,5), strain energy (ce) */
    double *cable_vector, *cable_stiffness, *cable_damping, *cable_state, *cable_strain;
    /* each element's gap min(N_el, N) (ce): > 0 taut; its sign changes are the events */
    double *cable_gap;
    /* per hinge at the last evaluation (n_hinges each): the torque whose work is external (the applied
     * torque λ τ and a continuous controller's output, less k s of a spring that is not conservative)
     * and the dissipative torque (the damper's c θ̇, a compliant stop's damping and friction); the time
     * loop integrates their work over each step's Δθ (newton_step.c latdyn_advance) */
    double *hinge_work_torque, *hinge_damper_torque;
    /* the static evaluation's gravity tangent ∂Q/∂q (e,14,14) and the kernel's Q beside it (e,14)
     * (only with gravity: length 0 without) */
    double *gravity_tangent, *gravity_force_D_q;
    /* states of continuous controllers: S_{n+1} of the last evaluation (n_controller_states), the
     * law's arguments (s, S) of one controller, the scratch of its states' local solve, and the
     * step's h/2 of the trapezoidal rule (1; 0 outside a step: the states held at S_n) */
    double *controller_state_trial, *controller_arguments, *controller_solve, *controller_half_step;
    /* with chained controllers (Model n_chained): dy_k/ds_i of controller k by every sensor i,
     * (n_controllers, n_sensors), the chain rule dy_k/ds = Σ ∂y_k/∂y_j dy_j/ds + ∂y_k/∂s */
    double *controller_total;
    /* ∂s_i/∂q of a sensor of kind 5 by its node's six coordinates, of kind 6 by its node's six rates
     * and then by its three rotation coordinates, of kind 7 by its point's node's and its body's, of
     * kind 8 by its elements' end nodes' (Model sensor_column_start) */
    double *sensor_jacobian;
    /* sampled controllers (csrc/sampling.c): the values handed in for sensors of kind 9 (all sensors), a
     * law's arguments (s, S) and its values (y, rates); the restart's mass matrix in the iteration
     * matrix's storage and its pivots (apart from `matrix`, which holds modified Newton's factorization) */
    double *sampled_values, *sampled_arguments, *sampled_out, *restart_matrix;
    int *restart_pivots;
} Work;

/* ------------------------------------------------------------------------- small algebra */

static void skew(const double *w, double *S)
{
    S[0] = 0.0;   S[1] = -w[2]; S[2] = w[1];
    S[3] = w[2];  S[4] = 0.0;   S[5] = -w[0];
    S[6] = -w[1]; S[7] = w[0];  S[8] = 0.0;
}

static void matmul3(const double *A, const double *B, double *C)
{
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            C[3 * i + j] = A[3 * i] * B[j] + A[3 * i + 1] * B[3 + j] + A[3 * i + 2] * B[6 + j];
}

static void matvec3(const double *A, const double *x, double *y)
{
    for (int i = 0; i < 3; ++i) y[i] = A[3 * i] * x[0] + A[3 * i + 1] * x[1] + A[3 * i + 2] * x[2];
}

static void cross(const double *a, const double *b, double *c)
{
    c[0] = a[1] * b[2] - a[2] * b[1];
    c[1] = a[2] * b[0] - a[0] * b[2];
    c[2] = a[0] * b[1] - a[1] * b[0];
}

/* Entry d of a free-coordinate vector of length n; 0 for a node slot that is not a coordinate
 * (d >= n: the out-of-plane slots of a planar model, Model.node_slots). */
static inline double free_entry(const double *vector, int64_t d, int64_t n)
{
    return d < n ? vector[d] : 0.0;
}

/* ------------------------------------------------------------------------- configuration */

/* dst ← src, every node and hinge. */
static void copy_configuration(const Model *m, const Configuration *src, Configuration *dst)
{
    const size_t N = (size_t)m->n_nodes, H = (size_t)m->n_hinges;
    memcpy(dst->x, src->x, sizeof(double) * 3 * N);
    memcpy(dst->T, src->T, sizeof(double) * 9 * N);
    memcpy(dst->v, src->v, sizeof(double) * 3 * N);
    memcpy(dst->w, src->w, sizeof(double) * 3 * N);
    memcpy(dst->a, src->a, sizeof(double) * 3 * N);
    memcpy(dst->alpha, src->alpha, sizeof(double) * 3 * N);
    memcpy(dst->theta, src->theta, sizeof(double) * H);
    memcpy(dst->theta_dot, src->theta_dot, sizeof(double) * H);
    memcpy(dst->theta_ddot, src->theta_ddot, sizeof(double) * H);
}

/* Items (element ends, nodes, bodies) per call of a generated kernel: a multiple of every SIMD width
 * the kernels are compiled for (2, 4 or 8 lanes, codegen/templates/c_source.c.j2), so that each lane
 * of a batch holds its own item. A call for one item computes it in every lane (its sin, cos and
 * sqrt included); a batch gathered on the stack does the kernel's arithmetic once per item, lane by
 * lane the same operations, so the results are the same to the bit. */
#define ITEMS_PER_BATCH 16

/* The items of the batch that starts at `first` of `count` items. */
static inline int64_t batch_size(int64_t first, int64_t count)
{
    return count - first < ITEMS_PER_BATCH ? count - first : ITEMS_PER_BATCH;
}

/* q ∘ exp(Δ) on the free coordinates of c, in place: x += Δd, T ← exp(skew Δπ) T, θ += Δθ, with Δ
 * the free-coordinate vector `increment` (node slots that are not coordinates read 0). Nothing else
 * changes: time, prescribed bodies and rates are the caller's (Assembler.advance, configure). */
void latdyn_advance_free(const Model *m, Configuration *c, const double *increment)
{
    const int64_t n = m->n_dofs;
    double vectors[3 * ITEMS_PER_BATCH], R[9 * ITEMS_PER_BATCH];
    for (int64_t first = 0; first < m->n_free_nodes; first += ITEMS_PER_BATCH) {
        const int64_t count = batch_size(first, m->n_free_nodes);
        for (int64_t k = 0; k < count; ++k) {
            const int64_t i = m->free_nodes[first + k];
            const int64_t *d = m->node_dofs + 6 * i;
            for (int j = 0; j < 3; ++j) {
                c->x[3 * i + j] += free_entry(increment, d[j], n);
                vectors[3 * k + j] = free_entry(increment, d[3 + j], n);
            }
        }
        m->so3_exp(count, vectors, R);
        for (int64_t k = 0; k < count; ++k) {
            const int64_t i = m->free_nodes[first + k];
            double T[9];
            memcpy(T, c->T + 9 * i, sizeof T);
            matmul3(R + 9 * k, T, c->T + 9 * i);
        }
    }
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        int64_t j = m->free_hinges[k];
        c->theta[j] += increment[m->hinge_dofs[j]];
    }
}

/* The prescribed motion in c, in place: prescribed bodies (x = x₀ + translation law, T = exp(skew(axis
 * angle law))) and hinge angles with their rates and accelerations from their laws, at rest where a
 * body has no law; locked hinges at rest. laws: (value, rate, acceleration) of every law at the time. */
static void prescribe(const Model *m, Configuration *c, const double *laws)
{
    for (int64_t k = 0; k < m->n_prescribed; ++k) {
        int64_t i = m->prescribed_nodes[k];
        const int64_t *law = m->translation_law + 3 * k;
        for (int j = 0; j < 3; ++j) {
            if (law[0] >= 0) {
                c->x[3 * i + j] = m->node_x0[3 * i + j] + laws[3 * law[j]];
                c->v[3 * i + j] = laws[3 * law[j] + 1];
                c->a[3 * i + j] = laws[3 * law[j] + 2];
            } else {
                c->x[3 * i + j] = m->node_x0[3 * i + j];
                c->v[3 * i + j] = c->a[3 * i + j] = 0.0;
            }
        }
        const double *axis = m->rotation_axis + 3 * k;
        if (m->angle_law[k] >= 0) {
            const double *g = laws + 3 * m->angle_law[k];
            m->so3_exp(1, (double[3]){axis[0] * g[0], axis[1] * g[0], axis[2] * g[0]}, c->T + 9 * i);
            for (int j = 0; j < 3; ++j) {
                c->w[3 * i + j] = axis[j] * g[1];
                c->alpha[3 * i + j] = axis[j] * g[2];
            }
        } else {
            double *T = c->T + 9 * i;
            for (int j = 0; j < 9; ++j) T[j] = (j % 4 == 0) ? 1.0 : 0.0;
            for (int j = 0; j < 3; ++j) c->w[3 * i + j] = c->alpha[3 * i + j] = 0.0;
        }
    }
    for (int64_t j = 0; j < m->n_hinges; ++j) {
        if (m->hinge_angle_law[j] >= 0) {
            const double *g = laws + 3 * m->hinge_angle_law[j];
            c->theta[j] = g[0];
            c->theta_dot[j] = g[1];
            c->theta_ddot[j] = g[2];
        } else if (m->hinge_locked[j]) {
            c->theta_dot[j] = c->theta_ddot[j] = 0.0;
        }
    }
}

/* The prescribed motion at time t in c, in place (Assembler.apply_prescribed): the laws at t into
 * w->laws, then as prescribe above. */
void latdyn_prescribe(const Model *m, Work *w, Configuration *c, double t)
{
    m->time_laws(t, w->laws);
    prescribe(m, c, w->laws);
}

/* The trial configuration q_n ∘ exp(increment) at the laws' time with velocities v and
 * accelerations v̇ on the free coordinates (the step of newton_step.c; the analyses driven from
 * Python take the same two updates, Assembler.advance and Assembler.apply_prescribed, then
 * unpack_free). laws: (value, rate, acceleration) of every law at that time. */
static void configure(const Model *m, const Configuration *base, Configuration *c, const double *increment,
                      const double *velocity, const double *acceleration, const double *laws)
{
    copy_configuration(m, base, c);
    latdyn_advance_free(m, c, increment);
    prescribe(m, c, laws);
    /* the free coordinates' rates */
    for (int64_t k = 0; k < m->n_free_nodes; ++k) {
        int64_t i = m->free_nodes[k];
        const int64_t *d = m->node_dofs + 6 * i;
        const int64_t n = m->n_dofs;
        for (int j = 0; j < 3; ++j) {
            c->v[3 * i + j] = free_entry(velocity, d[j], n);
            c->w[3 * i + j] = free_entry(velocity, d[3 + j], n);
            c->a[3 * i + j] = free_entry(acceleration, d[j], n);
            c->alpha[3 * i + j] = free_entry(acceleration, d[3 + j], n);
        }
    }
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        int64_t j = m->free_hinges[k];
        c->theta_dot[j] = velocity[m->hinge_dofs[j]];
        c->theta_ddot[j] = acceleration[m->hinge_dofs[j]];
    }
}

/* ------------------------------------------------------------------------- evaluation */

/* Element inputs: x1, x2, offsets T r_g (Eq. 2),
 * nodal frames T_j exp(θ h) E0 (Eq. 17), hinge axes T_j h (Eq. 9); rates and accelerations.
 * The ends go through the generated kernel ITEMS_PER_BATCH at a time, gathered into and scattered
 * from the stack. */
static void element_inputs_to(const Model *m, const Configuration *c, double *geometry, double *rates,
                              double *accelerations, int64_t begin, int64_t end_element)
{
    double frames[9 * ITEMS_PER_BATCH], data[16 * ITEMS_PER_BATCH];
    double end_frame[9 * ITEMS_PER_BATCH], end_offset[3 * ITEMS_PER_BATCH], end_axis[3 * ITEMS_PER_BATCH];
    for (int64_t first = 2 * begin; first < 2 * end_element; first += ITEMS_PER_BATCH) {
        const int64_t ends = batch_size(first, 2 * end_element);
        for (int64_t k = 0; k < ends; ++k) {  /* end k of the batch: end (first + k) % 2 of element (first + k) / 2 */
            int64_t i = m->element_nodes[first + k], hinge = m->element_hinges[first + k];
            memcpy(frames + 9 * k, c->T + 9 * i, 9 * sizeof(double));
            memcpy(data + 16 * k, m->element_ends + 16 * (first + k), 15 * sizeof(double));
            data[16 * k + 15] = hinge >= 0 ? c->theta[hinge] : 0.0;
        }
        /* Eqs. 2, 9, 17: the generated kernel (codegen/joints.py hinged_end) */
        m->hinged_end(ends, frames, data, end_frame, end_offset, end_axis);
        for (int64_t k = 0; k < ends; ++k) {
            const int64_t e = (first + k) / 2, end = (first + k) % 2;
            double *g = geometry + 36 * e;
            memcpy(g + 12 + 9 * end, end_frame + 9 * k, 9 * sizeof(double));
            memcpy(g + 6 + 3 * end, end_offset + 3 * k, 3 * sizeof(double));
            memcpy(g + 30 + 3 * end, end_axis + 3 * k, 3 * sizeof(double));
        }
    }
    for (int64_t e = begin; e < end_element; ++e) {
        double *g = geometry + 36 * e;
        double *r = rates + 14 * e, *acc = accelerations + 14 * e;
        for (int end = 0; end < 2; ++end) {
            int64_t i = m->element_nodes[2 * e + end], hinge = m->element_hinges[2 * e + end];
            for (int j = 0; j < 3; ++j) {
                g[3 * end + j] = c->x[3 * i + j];
                r[7 * end + j] = c->v[3 * i + j];
                r[7 * end + 3 + j] = c->w[3 * i + j];
                acc[7 * end + j] = c->a[3 * i + j];
                acc[7 * end + 3 + j] = c->alpha[3 * i + j];
            }
            r[7 * end + 6] = hinge >= 0 ? c->theta_dot[hinge] : 0.0;
            acc[7 * end + 6] = hinge >= 0 ? c->theta_ddot[hinge] : 0.0;
        }
    }
}

static void element_inputs(const Model *m, const Configuration *c, Work *w, int64_t begin, int64_t end_element)
{
    element_inputs_to(m, c, w->geometry, w->rates, w->accelerations, begin, end_element);
}

/* Joint bodies: the generated kernel codegen/joints.py, a batch of bodies a call, under gravity λg; without
 * inertia (a static residual) at rest, so that only the weight remains. */
static void joint_bodies(const Model *m, const Configuration *c, Work *w, int inertia, double load_factor)
{
    double frames[9 * ITEMS_PER_BATCH], motion[9 * ITEMS_PER_BATCH], gravity[3 * ITEMS_PER_BATCH];
    for (int k = 0; k < ITEMS_PER_BATCH; ++k)
        for (int p = 0; p < 3; ++p) gravity[3 * k + p] = load_factor * m->gravity[p];
    if (!inertia) memset(motion, 0, sizeof motion);
    for (int64_t first = 0; first < m->n_bodies; first += ITEMS_PER_BATCH) {
        const int64_t count = batch_size(first, m->n_bodies);
        for (int64_t k = 0; k < count; ++k) {
            const int64_t i = m->body_nodes[first + k];
            memcpy(frames + 9 * k, c->T + 9 * i, 9 * sizeof(double));
            if (inertia) {
                memcpy(motion + 9 * k, c->w + 3 * i, 3 * sizeof(double));
                memcpy(motion + 9 * k + 3, c->a + 3 * i, 3 * sizeof(double));
                memcpy(motion + 9 * k + 6, c->alpha + 3 * i, 3 * sizeof(double));
            }
        }
        m->joint_body(count, frames, motion, m->body_section + 13 * first, gravity, w->body_vector + 6 * first,
                      w->body_mass + 36 * first, w->body_damping + 36 * first, w->body_stiffness + 36 * first);
    }
}

/* The equations of motion at c : the vector of all coordinates into
 * w->total (residual = total[:n], reaction = total[n:n_total]); with matrices, the blocks.
 * Returns the power of the point loads; each hinge's torque that does external work and its
 * dissipative torque into w->hinge_work_torque and w->hinge_damper_torque; each cable element's
 * length, rest length and the forces whose work the time loop integrates into w->cable_work. */
/* The number of element ranges (= threads) of an evaluation: 1 below the threshold or without OpenMP. */
static int element_ranges(const Model *m)
{
#ifdef _OPENMP
    if (m->parallel_elements > 0 && m->n_elements >= m->parallel_elements) {
        int threads = m->threads > 0 ? (int)m->threads : omp_get_max_threads();
        if (threads > m->n_elements) threads = (int)m->n_elements;
        return threads > 1 ? threads : 1;
    }
#else
    (void)m;
#endif
    return 1;
}

/* Geometry and the generated kernels of elements [begin, end): each element reads and writes
 * only its own rows of the Work buffers (kernel arguments offset to the range). */
static void element_range(const Model *m, const Configuration *c, Work *w, int64_t begin, int64_t end,
                          int matrices, int inertia, double load_factor)
{
    const int64_t n = end - begin;
    if (n <= 0) return;
    element_inputs(m, c, w, begin, end);
    const double *geometry = w->geometry + 36 * begin, *rates = w->rates + 14 * begin;
    const double *section = m->element_sections + m->section_width * begin;
    double *force = w->force + 14 * begin, *tangent = w->tangent + 196 * begin;
    if (matrices)
        m->internal_force_D_q(n, geometry, section, force, tangent);
    else
        m->internal_force(n, geometry, section, force);
    if (inertia && matrices && m->inertia_matrices) {
        m->inertia_matrices(n, geometry, rates, section, w->mass + 196 * begin, w->quadratic + 14 * begin,
                            w->quadratic_D + 196 * begin);
    } else if (inertia) {
        if (matrices)
            m->quadratic_velocity_D_qdot(n, geometry, rates, section, w->quadratic + 14 * begin,
                                         w->quadratic_D + 196 * begin);
        else
            m->quadratic_velocity(n, geometry, rates, section, w->quadratic + 14 * begin);
        m->mass_matrix(n, geometry, section, w->mass + 196 * begin);
    }
    if (m->has_gravity)
        m->gravity_load(n, geometry, section, w->gravity_rows + 3 * begin, w->gravity_force + 14 * begin,
                        w->gravity_potential + begin, w->first_moment + 3 * begin);
    /* the static tangent: K − λ ∂Q/∂q in the element block (with inertia, the elements' inertia
     * tangent carries the gravity load's derivative with the inertia forces': inertia_tangent) */
    if (m->has_gravity && matrices && !inertia && m->gravity_load_D_q) {
        double *dQ = w->gravity_tangent + 196 * begin;
        m->gravity_load_D_q(n, geometry, section, w->gravity_rows + 3 * begin, w->gravity_force_D_q + 14 * begin, dQ);
        for (int64_t k = 0; k < 196 * n; ++k) tangent[k] -= load_factor * dQ[k];
    }
}

/* x ← A⁻¹ x for the p × p matrix A (row-major, overwritten) and `columns` right-hand sides x (p × columns,
 * row-major): Gaussian elimination with partial pivoting (a controller's few states). */
static void solve_small(int64_t p, double *A, double *x, int64_t columns)
{
    for (int64_t k = 0; k < p; ++k) {
        int64_t pivot = k;
        for (int64_t i = k + 1; i < p; ++i)
            if (fabs(A[p * i + k]) > fabs(A[p * pivot + k])) pivot = i;
        if (pivot != k) {
            for (int64_t j = 0; j < p; ++j) { double t = A[p * k + j]; A[p * k + j] = A[p * pivot + j]; A[p * pivot + j] = t; }
            for (int64_t j = 0; j < columns; ++j) { double t = x[columns * k + j]; x[columns * k + j] = x[columns * pivot + j]; x[columns * pivot + j] = t; }
        }
        for (int64_t i = k + 1; i < p; ++i) {
            double f = A[p * i + k] / A[p * k + k];
            for (int64_t j = k; j < p; ++j) A[p * i + j] -= f * A[p * k + j];
            for (int64_t j = 0; j < columns; ++j) x[columns * i + j] -= f * x[columns * k + j];
        }
    }
    for (int64_t k = p - 1; k >= 0; --k)
        for (int64_t j = 0; j < columns; ++j) {
            double v = x[columns * k + j];
            for (int64_t i = k + 1; i < p; ++i) v -= A[p * k + i] * x[columns * i + j];
            x[columns * k + j] = v / A[p * k + k];
        }
}

/* The states S of continuous controller k (first state `first`, p states, m sensors) at the end of the
 * step, the law's arguments (s, S) in `args` and its values there in w->controller_scratch: the
 * trapezoidal rule S = S_n + h/2 (f_n + f(s, S)) with hh = h/2 = w->controller_half_step[0], solved by
 * Newton on S (exact in one iteration for f linear in S) with the law's ∂f/∂S; hh = 0 holds S at S_n.
 * On return `dS` (p × m) holds dS/ds = (I − hh ∂f/∂S)⁻¹ hh ∂f/∂s, the states' exact dependence on the
 * sensors that the condensed step's matrix takes (0 when hh = 0). */
static void controller_states_at(const Model *m, Work *w, int64_t k, double t, int64_t first, int64_t p,
                                 int64_t count, double *args, double *dS)
{
    const double hh = w->controller_half_step[0];
    const int64_t width = 1 + count + p;
    double *out = w->controller_scratch, *A = w->controller_solve;
    for (int64_t j = 0; j < p; ++j) args[count + j] = m->controller_states[m->controller_state_slot[first + j]];
    m->controller_laws(k, t, args, out);
    if (hh > 0.0) {
        for (int iteration = 0; iteration < 50; ++iteration) {
            double change = 0.0, size = 0.0;
            for (int64_t i = 0; i < p; ++i) {
                const double *f = out + width * (1 + i);
                for (int64_t j = 0; j < p; ++j) A[p * i + j] = (i == j ? 1.0 : 0.0) - hh * f[1 + count + j];
                dS[i] = -(args[count + i] - m->controller_states[m->controller_state_slot[first + i]]
                          - hh * (m->controller_state_rate[first + i] + f[0]));
            }
            solve_small(p, A, dS, 1);
            for (int64_t i = 0; i < p; ++i) {
                args[count + i] += dS[i];
                change = fmax(change, fabs(dS[i]));
                size = fmax(size, fabs(args[count + i]));
            }
            m->controller_laws(k, t, args, out);
            if (change <= 1e-15 * fmax(1.0, size)) break;
        }
    }
    for (int64_t i = 0; i < p; ++i) {
        const double *f = out + width * (1 + i);
        for (int64_t j = 0; j < p; ++j) A[p * i + j] = (i == j ? 1.0 : 0.0) - hh * f[1 + count + j];
        for (int64_t j = 0; j < count; ++j) dS[count * i + j] = hh * f[1 + j];
    }
    if (hh > 0.0 && count > 0) solve_small(p, A, dS, count);
    for (int64_t i = 0; i < p; ++i) w->controller_state_trial[first + i] = args[count + i];
}

/* The value of sensor i at c and time t (a joint's laws; w->laws at t: a reel's rest length, a joint's applied
 * torque), less its origin (see Model: the kinds 0-3, 5-8 and 11-14; 0 for the others, which the caller
 * reads), with its gradient's columns into w->sensor_jacobian for kinds 5-8, 11-14: the probe evaluation of
 * the controllers, continuous (controller_outputs) and sampled (sampling.c). */
/* Cable element e's inputs of the generated cable kernels at c (codegen/joints.py cable_geometry, cable_velocity,
 * cable_section): the end nodes' reference points and the offsets T_i r_i, the ends' velocities, and [share L0,
 * share L0′, EA, c] with the rest length's law (value, rate) at `laws` (for cables(), a cable sensor, and the
 * sensitivities' cable_forces.c; latdyn/analyses/cable_sensitivities.py CableSensitivities.inputs makes the same). */
static void cable_inputs(const Model *m, const Configuration *c, const double *laws, int64_t e, double *geometry,
                         double *velocity, double *section)
{
    const double *data = m->cable_section + 3 * e, *rest = laws + 3 * m->cable_rest_law[e];
    for (int end = 0; end < 2; ++end) {
        const int64_t i = m->cable_nodes[2 * e + end];
        matvec3(c->T + 9 * i, m->cable_offsets + 6 * e + 3 * end, geometry + 6 + 3 * end);
        memcpy(geometry + 3 * end, c->x + 3 * i, 3 * sizeof(double));
        memcpy(velocity + 6 * end, c->v + 3 * i, 3 * sizeof(double));
        memcpy(velocity + 6 * end + 3, c->w + 3 * i, 3 * sizeof(double));
    }
    section[0] = data[0] * rest[0];
    section[1] = data[0] * rest[1];
    section[2] = data[1];
    section[3] = data[2];
}

static double sensor_value(const Model *m, const Configuration *c, Work *w, int64_t i, double t)
{
    int64_t index = m->sensor_index[i];
    double value = 0.0;
    switch (m->sensor_kind[i]) {
    case 0: value = c->theta[index]; break;
    case 1: value = c->theta_dot[index]; break;
    case 2: value = c->x[index]; break;
    case 3: value = c->v[index]; break;
    case 5: {  /* a point offset from its node: x + T r, and Jᵀ e_c from the point-load kernel */
        static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        const int64_t node = index / 3, component = index % 3;
        const double *T = c->T + 9 * node, *r = m->sensor_offset + 3 * i;
        double unit[6] = {0, 0, 0, 0, 0, 0}, velocity[6] = {0, 0, 0, 0, 0, 0}, power, by_node[18], by_frame[18];
        unit[component] = -1.0;  /* the kernel gives −Jᵀ values (the load's part of the residual): +Jᵀ e_c */
        m->point_load(1, T, r, unit, identity, velocity, w->sensor_jacobian + m->sensor_column_start[i], &power, by_node, by_frame);
        value = c->x[index] + T[3 * component] * r[0] + T[3 * component + 1] * r[1] + T[3 * component + 2] * r[2];
        break;
    }
    case 6: {  /* the velocity of a point offset from its node: v + ω × T r. By the node's rates it is
                * Jᵀ e_c (as the position by the coordinates); by the node's rotation, at fixed rates,
                * e_c·(ω × p) = d·p with d = e_c × ω: the rotation part of Jᵀ d, both from point_load */
        static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        const int64_t node = index / 3, component = index % 3;
        const double *T = c->T + 9 * node, *r = m->sensor_offset + 3 * i, *omega = c->w + 3 * node;
        double unit[6] = {0, 0, 0, 0, 0, 0}, velocity[6] = {0, 0, 0, 0, 0, 0}, power, by_node[18], by_frame[18];
        double p[3], lever[6], *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        for (int q = 0; q < 3; ++q) p[q] = T[3 * q] * r[0] + T[3 * q + 1] * r[1] + T[3 * q + 2] * r[2];
        unit[component] = -1.0;
        m->point_load(1, T, r, unit, identity, velocity, jacobian, &power, by_node, by_frame);
        const int64_t a = (component + 1) % 3, b = (component + 2) % 3;  /* d = e_c × ω */
        double d[6] = {0, 0, 0, 0, 0, 0};
        d[a] = -omega[b];
        d[b] = omega[a];
        for (int q = 0; q < 3; ++q) d[q] = -d[q];
        m->point_load(1, T, r, d, identity, velocity, lever, &power, by_node, by_frame);
        for (int q = 0; q < 3; ++q) jacobian[6 + q] = lever[3 + q];
        value = c->v[index] + omega[a] * p[b] - omega[b] * p[a];
        break;
    }
    case 7: {  /* in a body's axes: by the point's node Jᵀ b_c; by the body's translation −b_c; by its
                * rotation the rotation part of Jᵀ u for the point T_b e_c (u = p − x_b): all from point_load */
        static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        const int64_t node = index / 3, component = index % 3, body = m->sensor_frame_node[i];
        const double *T = c->T + 9 * node, *r = m->sensor_offset + 3 * i, *Tb = c->T + 9 * body;
        double velocity[6] = {0, 0, 0, 0, 0, 0}, power, by_node[18], by_frame[18], *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        double axis[6] = {0, 0, 0, 0, 0, 0}, u[6] = {0, 0, 0, 0, 0, 0}, unit[3] = {0, 0, 0}, lever[6];
        for (int q = 0; q < 3; ++q) {
            axis[q] = -Tb[3 * q + component];  /* −b_c: the kernel gives −Jᵀ values */
            u[q] = -(c->x[3 * node + q] + T[3 * q] * r[0] + T[3 * q + 1] * r[1] + T[3 * q + 2] * r[2] - c->x[3 * body + q]);
        }
        m->point_load(1, T, r, axis, identity, velocity, jacobian, &power, by_node, by_frame);
        unit[component] = 1.0;
        m->point_load(1, Tb, unit, u, identity, velocity, lever, &power, by_node, by_frame);
        value = 0.0;
        for (int q = 0; q < 3; ++q) {
            jacobian[6 + q] = axis[q];  /* −b_c */
            jacobian[9 + q] = lever[3 + q];
            value -= axis[q] * -u[q];  /* b_c · (p − x_b) */
        }
        break;
    }
    case 8: {  /* a cable's length and its gradient, element by element */
        static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
        double velocity[6] = {0, 0, 0, 0, 0, 0}, power, by_node[18], by_frame[18];
        double *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        const int64_t elements = (m->sensor_column_start[i + 1] - m->sensor_column_start[i]) / 12;
        for (int64_t j = 0; j < elements; ++j) {
            const int64_t e = index + j, a = m->cable_nodes[2 * e], b = m->cable_nodes[2 * e + 1];
            const double *ra = m->cable_offsets + 6 * e, *rb = ra + 3;
            double pa[3], pb[3], d[3], toward_a[6] = {0, 0, 0, 0, 0, 0}, toward_b[6] = {0, 0, 0, 0, 0, 0};
            matvec3(c->T + 9 * a, ra, pa);
            matvec3(c->T + 9 * b, rb, pb);
            for (int q = 0; q < 3; ++q) d[q] = c->x[3 * b + q] + pb[q] - c->x[3 * a + q] - pa[q];
            const double length = sqrt(d[0] * d[0] + d[1] * d[1] + d[2] * d[2]);
            value += length;
            for (int q = 0; q < 3 && length > 0.0; ++q) {
                toward_a[q] = d[q] / length;   /* the kernel gives −Jᵀ values: −Jᵀ_a e */
                toward_b[q] = -d[q] / length;  /* +Jᵀ_b e */
            }
            m->point_load(1, c->T + 9 * a, ra, toward_a, identity, velocity, jacobian + 12 * j, &power, by_node, by_frame);
            m->point_load(1, c->T + 9 * b, rb, toward_b, identity, velocity, jacobian + 12 * j + 6, &power, by_node,
                          by_frame);
        }
        break;
    }
    case 11: {  /* a cable's tension: its first element's N (0 slack, as cables() decides), the generated law */
        double geometry[12], velocity[12], section[4], tension[2];
        double *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        cable_inputs(m, c, w->laws, index, geometry, velocity, section);
        m->cable_tension(1, geometry, velocity, section, tension, jacobian, jacobian + 12);
        const double side = m->cable_side[index], gap = fmin(tension[0], tension[1]);
        if (side > 0.0 || (side == 0.0 && gap > 0.0)) {
            value = tension[1];
        } else {  /* slack, or the damper cancels the elastic tension: N clipped at 0 */
            memset(jacobian, 0, 24 * sizeof(double));
        }
        break;
    }
    case 12: {  /* an element's section force: the generated section forces and ∂S/∂q at the element's geometry */
        const int64_t e = index / 4, k = index % 4;
        const double *weight = m->sensor_offset + 3 * i;
        double geometry[36], S[4], by_q[56], *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        for (int end = 0; end < 2; ++end) {  /* the element's inputs as element_inputs_to gives them (Eqs. 2, 9, 17) */
            const int64_t node = m->element_nodes[2 * e + end], hinge = m->element_hinges[2 * e + end];
            double data[16];
            memcpy(data, m->element_ends + 32 * e + 16 * end, 15 * sizeof(double));
            data[15] = hinge >= 0 ? c->theta[hinge] : 0.0;
            m->hinged_end(1, c->T + 9 * node, data, geometry + 12 + 9 * end, geometry + 6 + 3 * end,
                          geometry + 30 + 3 * end);
            memcpy(geometry + 3 * end, c->x + 3 * node, 3 * sizeof(double));
        }
        m->section_forces_D_q(1, geometry, m->element_sections + m->section_width * e, S, by_q);
        /* k ≤ 2; w1 = 0 but for k = 2 (M_y', M_z' of a planar model's turned section) */
        value = weight[0] * S[k] + weight[1] * S[k + 1];
        for (int q = 0; q < 14; ++q) jacobian[q] = weight[0] * by_q[14 * k + q] + weight[1] * by_q[14 * (k + 1) + q];
        break;
    }
    case 13: {  /* a point's velocity relative to a body, in its axes: s = b_c · V, V = ṗ − v_b − ω_b × u,
                 * ṗ = v_n + ω_n × o, o = T_n r, u = x_n + o − x_b, b_c = T_b e_c: the generated
                 * point_velocity_in_body (codegen/joints.py) with ∂s/∂[x_n, π_n, x_b, π_b] (K) and
                 * ∂s/∂[v_n, ω_n, v_b, ω_b] (C) */
        const int64_t node = index / 3, component = index % 3, body = m->sensor_frame_node[i];
        double *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        double geometry[27], velocity[12], s[3], by_q[36], by_rate[36];
        memcpy(geometry, c->x + 3 * node, 3 * sizeof(double));
        memcpy(geometry + 3, c->x + 3 * body, 3 * sizeof(double));
        memcpy(geometry + 6, c->T + 9 * node, 9 * sizeof(double));
        memcpy(geometry + 15, m->sensor_offset + 3 * i, 3 * sizeof(double));
        memcpy(geometry + 18, c->T + 9 * body, 9 * sizeof(double));
        memcpy(velocity, c->v + 3 * node, 3 * sizeof(double));
        memcpy(velocity + 3, c->w + 3 * node, 3 * sizeof(double));
        memcpy(velocity + 6, c->v + 3 * body, 3 * sizeof(double));
        memcpy(velocity + 9, c->w + 3 * body, 3 * sizeof(double));
        m->point_velocity_in_body(1, geometry, velocity, s, by_q, by_rate);
        value = s[component];
        memcpy(jacobian, by_q + 12 * component, 12 * sizeof(double));
        memcpy(jacobian + 12, by_rate + 12 * component, 12 * sizeof(double));
        break;
    }
    case 14: {  /* a free joint's force (the probe's, positive when it drives θ or s up): −f of its law (spring,
                 * damper, applied torque or force of t, θ, θ̇, compliant stops; latdyn/assembly/control.py
                 * refuses the joints where it is a reaction), with −∂f/∂θ (K) and −∂f/∂θ̇ (C) from the
                 * generated hinge_force and the compiled laws, as the hinge loop of evaluate() takes them */
        const int64_t j = index;
        double *jacobian = w->sensor_jacobian + m->sensor_column_start[i];
        double state[4] = {c->theta[j], c->theta_dot[j], m->hinge_rest_angle[j], 1.0};
        double values[9] = {0, 0, 0, 0, 0, 0, 0, 0, 0};
        if (m->hinge_stiffness_law[j] < 0) {
            values[0] = m->hinge_stiffness[j];
            values[3] = m->hinge_damping[j];
            if (m->hinge_torque_law[j] >= 0) values[6] = w->laws[3 * m->hinge_torque_law[j]];
        } else {
            m->hinge_laws(m->hinge_stiffness_law[j], state[0], state[1], t, values);
            m->hinge_laws(m->hinge_damping_law[j], state[0], state[1], t, values + 3);
            if (m->hinge_torque_hinge_law[j] >= 0)
                m->hinge_laws(m->hinge_torque_hinge_law[j], state[0], state[1], t, values + 6);
        }
        double f, by_angle, by_rate, spring, applied, damper, energy;
        m->hinge_force(1, state, values, m->hinge_contact + 11 * j, &f, &by_angle, &by_rate, &spring, &applied, &damper,
                       &energy);
        value = -f;
        jacobian[0] = -by_angle;
        jacobian[1] = -by_rate;
        break;
    }
    default: value = 0.0; break;  /* 4: an earlier controller's output, read by the caller */
    }
    return value - m->sensor_origin[i];
}

/* Continuous controllers at c (see Model): outputs (clipped) into m->controller_outputs, ∂y/∂s into
 * w->controller_gradient (0 when saturated); with states, S at the step's end (controller_states_at)
 * and ∂y/∂s + ∂y/∂S dS/ds. */
static void controller_outputs(const Model *m, const Configuration *c, Work *w, double t)
{
    for (int64_t i = 0; i < m->n_sensors; ++i) w->sensor_values[i] = sensor_value(m, c, w, i, t);
    for (int64_t k = 0; k < m->n_controllers; ++k) {
        int64_t first = m->sensor_start[k], count = m->sensor_start[k + 1] - first;
        int64_t p = m->n_controller_states ? m->controller_state_start[k + 1] - m->controller_state_start[k] : 0;
        double *dS = w->controller_solve + (p * p > p ? p * p : p);
        for (int64_t i = first; i < first + count; ++i)  /* an earlier controller's output, just computed */
            if (m->sensor_kind[i] == 4)
                w->sensor_values[i] = m->controller_outputs[m->controller_slot[m->sensor_index[i]]];
        if (p) {
            double *args = w->controller_arguments;
            for (int64_t i = 0; i < count; ++i) args[i] = w->sensor_values[first + i];
            controller_states_at(m, w, k, t, m->controller_state_start[k], p, count, args, dS);
        } else {
            m->controller_laws(k, t, w->sensor_values + first, w->controller_scratch);
        }
        double y = w->controller_scratch[0], lo = m->controller_limits[2 * k], hi = m->controller_limits[2 * k + 1];
        int saturated = y < lo || y > hi;
        m->controller_outputs[m->controller_slot[k]] = y < lo ? lo : (y > hi ? hi : y);
        for (int64_t i = 0; i < count; ++i) {
            double gradient = w->controller_scratch[1 + i];
            for (int64_t j = 0; j < p; ++j) gradient += w->controller_scratch[1 + count + j] * dS[count * j + i];
            w->controller_gradient[first + i] = saturated ? 0.0 : gradient;
        }
        if (m->n_chained) {  /* the chain rule: dy_k/ds = ∂y_k/∂s + Σ ∂y_k/∂y_j dy_j/ds */
            double *total = w->controller_total + k * m->n_sensors;
            memset(total, 0, sizeof(double) * m->n_sensors);
            for (int64_t i = first; i < first + count; ++i) {
                const double g = w->controller_gradient[i];
                if (m->sensor_kind[i] != 4) {
                    total[i] += g;
                } else if (g != 0.0) {
                    const double *earlier = w->controller_total + m->sensor_index[i] * m->n_sensors;
                    for (int64_t j = 0; j < m->n_sensors; ++j) total[j] += g * earlier[j];
                }
            }
        }
    }
}

/* The states of the continuous controllers accepted at the end of a step of size h ending at c (time t):
 * S_{n+1} from the trapezoidal rule at c (controller_states_at) into the runtime's array, and their rates
 * f(s, S_{n+1}) there, which the next step starts from. h = 0 keeps S and takes its rate at c: the start
 * (t = 0, a resumed run, a restart of the integrator). */
void latdyn_controller_states_accept(const Model *m, Work *w, const Configuration *c, double t, double h)
{
    if (!m->n_controller_states) return;
    const double held = w->controller_half_step[0];
    w->controller_half_step[0] = 0.5 * h;
    controller_outputs(m, c, w, t);
    for (int64_t k = 0; k < m->n_controllers; ++k) {
        int64_t first = m->controller_state_start[k], p = m->controller_state_start[k + 1] - first;
        if (!p) continue;
        int64_t count = m->sensor_start[k + 1] - m->sensor_start[k];
        double *args = w->controller_arguments, *out = w->controller_scratch;
        for (int64_t i = 0; i < count; ++i) args[i] = w->sensor_values[m->sensor_start[k] + i];
        for (int64_t j = 0; j < p; ++j) {
            args[count + j] = w->controller_state_trial[first + j];
            m->controller_states[m->controller_state_slot[first + j]] = args[count + j];
        }
        m->controller_laws(k, t, args, out);
        for (int64_t j = 0; j < p; ++j) m->controller_state_rate[first + j] = out[(1 + count + p) * (1 + j)];
    }
    w->controller_half_step[0] = held;
}

/* The coupling entries of K and C (see Model): each actuator's generalized force per unit output
 * (−1 on a hinge's coordinate; the point-load kernel's force for a unit component; times λ a for an
 * actuator inside an expression a y + b), times dy/ds of its controller's sensors (the total
 * derivative through earlier controllers with chained ones) and, for a sensor of an offset point,
 * ∂s/∂q of the entry's column. A controller's output named alone is feedback: the load factor λ of a
 * static path does not scale it. */
static void controller_couplings(const Model *m, const Configuration *c, Work *w, double load_factor)
{
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double gains[6];
    int64_t done = -1;
    for (int64_t e = 0; e < m->n_couplings; ++e) {
        int64_t a = m->coupling_actuator[e];
        if (a != done) {
            done = a;
            int64_t i = m->actuator_index[a];
            memset(gains, 0, sizeof gains);
            /* a law a y + b applies λ(a y + b), ramped like any load; the name alone applies y */
            const double gain = m->actuator_gain[a] != 0.0 ? load_factor * m->actuator_gain[a] : 1.0;
            if (m->actuator_kind[a] == 0) {
                gains[0] = -gain;
            } else {
                int64_t node = m->load_node[i], frame = m->load_frame_node[i];
                double values[6] = {0, 0, 0, 0, 0, 0}, velocity[6] = {0, 0, 0, 0, 0, 0};
                double power, by_node[18], by_frame[18];
                values[m->actuator_component[a]] = gain;
                m->point_load(1, c->T + 9 * node, m->load_r + 3 * i, values,
                              frame >= 0 ? c->T + 9 * frame : identity, velocity, gains, &power, by_node, by_frame);
            }
        }
        int64_t sensor = m->coupling_sensor[e], kind = m->sensor_kind[sensor];
        double value = gains[m->coupling_slot[e]] * (m->n_chained ? w->controller_total[m->actuator_controller[a]
                                                                                           * m->n_sensors + sensor]
                                                                    : w->controller_gradient[sensor]);
        const int64_t column = m->coupling_column[e];
        if (kind >= 5) value *= w->sensor_jacobian[m->sensor_column_start[sensor] + column];
        /* kind 6: rates, then rotation; kinds 11, 13: coordinates, then rates; kind 14: angle, rate */
        const int by_rate = kind == 1 || kind == 3 || (kind == 6 && column < 6)
                            || ((kind == 11 || kind == 13) && column >= 12) || (kind == 14 && column == 1);
        w->coupling_stiffness[e] = by_rate ? 0.0 : value;
        w->coupling_damping[e] = by_rate ? value : 0.0;
    }
}

/* Cable elements at c: the generated taut law (codegen/joints.py cable_force) where an element is taut,
 * zero where it is slack: its side −1, or side 0 and the gap min(N_el, N) ≤ 0 (not stretched, or the
 * damper would push). The time loop holds each element's side through a step and lands the step where
 * the gap (w->cable_gap) changes sign, so that Newton sees one smooth law; where the damper cancels the
 * elastic tension of a stretched element (N ≤ 0: the force is clipped at 0 and the damper's
 * dissipative force is −N_el); the rows into w->total (only where it is not NULL), [ℓ, L0, ∂U/∂L0, f]
 * into w->cable_work (the rest length's generalized force and the damper's dissipative force f, zero
 * while slack). The blocks always (the kernel gives them with the force). latdyn/model/cables.py. */
static void cables(const Model *m, const Configuration *c, Work *w, const double *laws, double *total)
{
    for (int64_t e = 0; e < m->n_cables; ++e) {
        double geometry[12], velocity[12], section[4];
        cable_inputs(m, c, laws, e, geometry, velocity, section);
        double *force = w->cable_vector + 12 * e, *K = w->cable_stiffness + 144 * e, *C = w->cable_damping + 144 * e;
        double *state = w->cable_state + 5 * e, *work = w->cable_work + 4 * e, reel, damper, clipped;
        m->cable_force(1, geometry, velocity, section, force, K, C, state, w->cable_strain + e, &reel, &damper,
                       &clipped);
        /* taut while stretched and pulling: the gap min(N_el, N) > 0 (the side the time loop holds, or,
         * side 0, the gap decides) */
        const double side = m->cable_side[e], gap = fmin(state[3], state[4]);
        const int taut = side > 0.0 || (side == 0.0 && gap > 0.0);
        w->cable_gap[e] = gap;
        work[0] = state[0];
        work[1] = section[0];
        work[2] = work[3] = 0.0;
        if (!taut && state[2] <= 0.0) { /* slack */
            memset(force, 0, 12 * sizeof(double));
            memset(K, 0, 144 * sizeof(double));
            memset(C, 0, 144 * sizeof(double));
            state[4] = 0.0;
            w->cable_strain[e] = 0.0;
            continue;
        }
        work[2] = reel;
        if (!taut) { /* stretched, but the damper cancels the elastic tension */
            memset(force, 0, 12 * sizeof(double));
            memset(K, 0, 144 * sizeof(double));
            memset(C, 0, 144 * sizeof(double));
            state[4] = 0.0;
            work[3] = clipped;
            continue;
        }
        work[3] = damper;
        for (int end = 0; total && end < 2; ++end) {
            const int64_t *d = m->node_dofs + 6 * m->cable_nodes[2 * e + end];
            for (int p = 0; p < 6; ++p) total[d[p]] += force[6 * end + p];
        }
    }
}

/* The joints (hinges and guides): each law's force f at (θ, θ̇, t) with its derivatives, a continuous
 * controller's output subtracted, into w->joint_forces, w->hinge_d_theta, w->hinge_d_rate and the
 * work torques; summed into `total` at each joint's coordinate unless `total` is NULL (the joint
 * forces of free joints alone, latdyn_joint_forces of rows.c). `laws`: the time laws at t. */
static void hinge_forces(const Model *m, const Configuration *c, Work *w, const double *laws, double t,
                         double load_factor, double *total)
{
    /* the laws' values and derivatives at (θ, θ̇, t), constants or the scene's compiled laws, into the
     * generated kernel codegen/joints.py hinge_force, a batch a call */
    for (int64_t first = 0; first < m->n_hinges; first += ITEMS_PER_BATCH) {
        const int64_t count = batch_size(first, m->n_hinges);
        double state[4 * ITEMS_PER_BATCH], values[9 * ITEMS_PER_BATCH], control[ITEMS_PER_BATCH];
        double f[ITEMS_PER_BATCH], spring_torque[ITEMS_PER_BATCH], applied_torque[ITEMS_PER_BATCH];
        double contact_energy[ITEMS_PER_BATCH];
        for (int64_t k = 0; k < count; ++k) {
            const int64_t j = first + k;
            double *st = state + 4 * k, *v = values + 9 * k;
            st[0] = c->theta[j];
            st[1] = c->theta_dot[j];
            st[2] = m->hinge_rest_angle[j];
            st[3] = load_factor;
            for (int p = 0; p < 9; ++p) v[p] = 0.0;
            if (m->hinge_stiffness_law[j] < 0) {  /* constant spring and damper, a torque of t alone */
                v[0] = m->hinge_stiffness[j];
                v[3] = m->hinge_damping[j];
                if (m->hinge_torque_law[j] >= 0) v[6] = laws[3 * m->hinge_torque_law[j]];
            } else {
                m->hinge_laws(m->hinge_stiffness_law[j], st[0], st[1], t, v);
                m->hinge_laws(m->hinge_damping_law[j], st[0], st[1], t, v + 3);
                if (m->hinge_torque_hinge_law[j] >= 0)
                    m->hinge_laws(m->hinge_torque_hinge_law[j], st[0], st[1], t, v + 6);
            }
            control[k] = 0.0;  /* a continuous controller's output: feedback, not ramped with the loads (λ) */
            if (m->n_controllers && m->hinge_controller[j] >= 0) {
                control[k] = m->controller_outputs[m->controller_slot[m->hinge_controller[j]]];
                v[6] = v[7] = v[8] = 0.0;
            }
        }
        m->hinge_force(count, state, values, m->hinge_contact + 11 * first, f, w->hinge_d_theta + first,
                       w->hinge_d_rate + first, spring_torque, applied_torque, w->hinge_damper_torque + first,
                       contact_energy);
        for (int64_t k = 0; k < count; ++k) {
            const int64_t j = first + k;
            const double force = f[k] - control[k];
            const double applied = applied_torque[k] + control[k];  /* the controller's output is an applied torque: its work is counted alike */
            w->hinge_work_torque[j] = m->hinge_conservative[j] ? applied : applied - spring_torque[k];
            w->joint_forces[j] = force;
            if (total) total[m->hinge_dofs[j]] += force;
        }
    }
}

static double evaluate(const Model *m, const Configuration *c, Work *w, const double *laws, double t, int matrices,
                       int inertia, double load_factor)
{
    const int64_t E = m->n_elements;
    double power = 0.0;
    const int ranges = element_ranges(m);
    if (ranges > 1) {
#ifdef _OPENMP
#pragma omp parallel for schedule(static) num_threads(ranges)
#endif
        for (int k = 0; k < ranges; ++k)
            element_range(m, c, w, E * k / ranges, E * (k + 1) / ranges, matrices, inertia, load_factor);
    } else {
        element_range(m, c, w, 0, E, matrices, inertia, load_factor);
    }
    memset(w->total, 0, sizeof(double) * (m->n_total + 1));
    /* elements: F + M a + g − λ gravity (Eqs. 55, 58); the static residual F − λ gravity */
    for (int64_t e = 0; e < E; ++e) {
        const double *M = w->mass + 196 * e, *acc = w->accelerations + 14 * e;
        const int64_t *dofs = m->element_dofs + 14 * e;
        for (int p = 0; p < 14; ++p) {
            double s = w->force[14 * e + p];
            if (inertia) {
                s += w->quadratic[14 * e + p];
                for (int q = 0; q < 14; ++q) s += M[14 * p + q] * acc[q];
            }
            if (m->has_gravity) s -= load_factor * w->gravity_force[14 * e + p];
            w->total[dofs[p]] += s;
        }
    }
    joint_bodies(m, c, w, inertia, load_factor);
    if (m->n_controllers) {
        controller_outputs(m, c, w, t);
        if (matrices) controller_couplings(m, c, w, load_factor);
        if (m->n_law_actuators) {  /* laws a y + b of time read the outputs just computed */
            m->time_laws(t, w->laws);
            laws = w->laws;
        }
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        const int64_t *d = m->node_dofs + 6 * m->body_nodes[b];
        for (int p = 0; p < 6; ++p) w->total[d[p]] += w->body_vector[6 * b + p];
    }
    hinge_forces(m, c, w, laws, t, load_factor, w->total);
    /* point loads: the generated kernel codegen/joints.py, load by load */
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int64_t l = 0; l < m->n_loads; ++l) {
        int64_t i = m->load_node[l], frame = m->load_frame_node[l];
        const int64_t *d = m->node_dofs + 6 * i;
        double values[6] = {0, 0, 0, 0, 0, 0}, velocity[6];
        for (int p = 0; p < 3; ++p) {
            int64_t fl = m->load_force_law[3 * l + p], ml = m->load_moment_law[3 * l + p];
            if (fl >= 0) values[p] = load_factor * laws[3 * fl];
            if (ml >= 0) values[3 + p] = load_factor * laws[3 * ml];
        }
        if (m->n_controllers)  /* components a continuous controller drives: feedback, not ramped with λ */
            for (int p = 0; p < 6; ++p)
                if (m->load_controller[6 * l + p] >= 0)
                    values[p] = m->controller_outputs[m->controller_slot[m->load_controller[6 * l + p]]];
        memcpy(velocity, c->v + 3 * i, 3 * sizeof(double));
        memcpy(velocity + 3, c->w + 3 * i, 3 * sizeof(double));
        double force[6], load_power, by_node[18], by_frame[18];
        m->point_load(1, c->T + 9 * i, m->load_r + 3 * l, values, frame >= 0 ? c->T + 9 * frame : identity, velocity,
                      force, &load_power, by_node, by_frame);
        for (int p = 0; p < 6; ++p) w->total[d[p]] += force[p];
        power += load_power;
        if (matrices) {
            double *block = w->load_blocks + 36 * l;
            for (int p = 0; p < 6; ++p)
                for (int q = 0; q < 3; ++q) {
                    block[6 * p + q] = by_node[3 * p + q];
                    block[6 * p + 3 + q] = frame >= 0 ? by_frame[3 * p + q] : 0.0;
                }
        }
    }
    cables(m, c, w, laws, w->total);
    return power;
}

/* ∂(M v̇ + g − λ f_gravity)/∂q of every element at c, at fixed spatial rates and accelerations, into
 * w->inertia_tangent: the term K leaves out (latdyn/step/integrators.py). The generated kernel
 * beam_inertia_tangent (codegen/derivation.py: the exact derivative through the kernels' own
 * intermediates), on the element inputs of the evaluation at c (w->geometry, w->rates,
 * w->accelerations), range by range as the evaluation. Joint bodies are left out: their kernel
 * carries its own inertia. */
static void inertia_tangent_range(const Model *m, Work *w, const double *gravity, int64_t begin, int64_t end)
{
    const int64_t n = end - begin;
    if (n <= 0) return;
    m->inertia_force_D_q(n, w->geometry + 36 * begin, w->rates + 14 * begin, w->accelerations + 14 * begin,
                         m->element_sections + m->section_width * begin, gravity + 3 * begin,
                         w->inertia_force + 14 * begin, w->inertia_tangent + 196 * begin);
}

static void inertia_tangent(const Model *m, Work *w, double load_factor)
{
    const int64_t E = m->n_elements;
    const int ranges = element_ranges(m);
    double *gravity = w->gravity_rows; /* λ g per element (the rows hold g: scaled here, restored below) */
    if (m->has_gravity && load_factor != 1.0)
        for (int64_t e = 0; e < E; ++e)
            for (int k = 0; k < 3; ++k) gravity[3 * e + k] = load_factor * m->gravity[k];
#ifdef _OPENMP
#pragma omp parallel for schedule(static) num_threads(ranges) if (ranges > 1)
#endif
    for (int r = 0; r < ranges; ++r)
        inertia_tangent_range(m, w, gravity, E * r / ranges, E * (r + 1) / ranges);
    if (m->has_gravity && load_factor != 1.0)
        for (int64_t e = 0; e < E; ++e)
            for (int k = 0; k < 3; ++k) gravity[3 * e + k] = m->gravity[k];
}

/* 16-point Gauss–Legendre nodes and weights on [−1, 1] (numpy.polynomial.legendre.leggauss(16)). */
static const double GAUSS_16_NODES[16] = {
    -0.9894009349916499, -0.9445750230732326, -0.8656312023878318, -0.755404408355003, -0.6178762444026438,
    -0.45801677765722737, -0.2816035507792589, -0.09501250983763744, 0.09501250983763744, 0.2816035507792589,
    0.45801677765722737, 0.6178762444026438, 0.755404408355003, 0.8656312023878318, 0.9445750230732326,
    0.9894009349916499};
static const double GAUSS_16_WEIGHTS[16] = {
    0.027152459411754176, 0.062253523938647456, 0.0951585116824926, 0.12462897125553407, 0.1495959888165767,
    0.16915651939500265, 0.18260341504492364, 0.18945061045506864, 0.18945061045506864, 0.18260341504492364,
    0.16915651939500265, 0.1495959888165767, 0.12462897125553407, 0.0951585116824926, 0.062253523938647456,
    0.027152459411754176};

/* Pieces of the spring potential's quadrature at most: beyond |θ − θ_r| = LAW_SPRING_PIECES / 4 rad (1024 rad)
 * the pieces grow longer than 0.25 rad rather than more numerous, so that the potential of a run whose angle
 * has diverged (an unstable explicit run reaching 1e15 rad) costs at most this many pieces instead of
 * looping for hours before the run's own checks can end it. */
#define LAW_SPRING_PIECES 4096

/* A hinge law's function (Model.hinge_laws): law k at (θ, θ̇, t) into out = (f, ∂f/∂θ, ∂f/∂θ̇). */
typedef void (*hinge_law_values)(int64_t, double, double, double, double *);

/* ∫_{θ_r}^{θ} k(x) (x − θ_r)^moment dx (moment 0 or 1) of hinge law `law` of `laws` at θ̇ = 0, t = 0, by
 * Gauss–Legendre quadrature, 16 points on each of the equal pieces of at most 0.25 rad (exact for
 * polynomials of degree 31 on a piece; at most LAW_SPRING_PIECES pieces). With moment 1 and the spring's
 * stiffness law it is the spring's potential (law_spring_potential); the energies' sensitivities take
 * its derivatives by a parameter p on this same quadrature, ∫ (∂k/∂p)(x)(x − θ_r) dx and ∫ k(x) dx
 * (latdyn/analyses/energy_sensitivities.py, through ctypes with the law as a callback), so that they are
 * the exact derivatives of the recorded value. A non-finite angle gives a non-finite value. */
double latdyn_law_spring_integral(hinge_law_values laws, int64_t law, double rest, double theta, int64_t moment)
{
    const double s = theta - rest;
    if (!isfinite(s))
        return s * s;
    const int64_t pieces = fabs(s) > 0.25 ? (int64_t)fmin(ceil(fabs(s) / 0.25), (double)LAW_SPRING_PIECES) : 1;
    double total = 0.0;
    for (int64_t p = 0; p < pieces; ++p) {
        const double a = rest + s * (double)p / (double)pieces, b = rest + s * (double)(p + 1) / (double)pieces;
        double sum = 0.0;
        for (int i = 0; i < 16; ++i) {
            const double x = 0.5 * (a + b) + 0.5 * (b - a) * GAUSS_16_NODES[i];
            double values[3] = {NAN, NAN, NAN};   /* a callback that fails to write leaves NaN, never a stale value */
            laws(law, x, 0.0, 0.0, values);
            sum += moment ? GAUSS_16_WEIGHTS[i] * values[0] * (x - rest) : GAUSS_16_WEIGHTS[i] * values[0];
        }
        total += 0.5 * (b - a) * sum;
    }
    return total;
}

/* The potential of hinge j's spring whose stiffness is a law k(θ) (the scene's compiled hinge law), at
 * angle θ: ∫_{θ_r}^{θ} k(s)(s − θ_r) ds (latdyn_law_spring_integral, the law at θ̇ = 0, t = 0). */
static double law_spring_potential(const Model *m, int64_t j, double theta)
{
    return latdyn_law_spring_integral(m->hinge_laws, m->hinge_stiffness_law[j], m->hinge_rest_angle[j], theta, 1);
}

/* Kinetic, strain and gravity potential energy of the whole model at c:
 * out = [kinetic, strain, potential]. Hinge springs: ½k(θ − θ_r)², or with a stiffness law (k 0 in
 * hinge_stiffness) and conservative, law_spring_potential. Joint bodies: ½m|v_c|² + ½ωᵀJω
 * about the centre of mass r_c = T c, J = T I Tᵀ, and −m g·(x + r_c). */
void latdyn_energies(const Model *m, Work *w, const Configuration *c, double t, double *out)
{
    const int64_t E = m->n_elements;
    double kinetic = 0.0, strain = 0.0, potential = 0.0;
    element_inputs(m, c, w, 0, E);
    m->strain_energy(E, w->geometry, m->element_sections, w->strain, w->section_forces);
    m->kinetic_energy(E, w->geometry, w->rates, m->element_sections, w->kinetic);
    if (m->has_gravity)
        m->gravity_load(E, w->geometry, m->element_sections, w->gravity_rows, w->gravity_force,
                        w->gravity_potential, w->first_moment);
    for (int64_t e = 0; e < E; ++e) {
        kinetic += w->kinetic[e];
        strain += w->strain[e];
        if (m->has_gravity) potential += w->gravity_potential[e];
    }
    for (int64_t first = 0; first < m->n_hinges; first += ITEMS_PER_BATCH) {
        /* a compliant stop's potential, from the generated hinge_force, a batch a call (its other outputs unused) */
        const int64_t count = batch_size(first, m->n_hinges);
        double state[4 * ITEMS_PER_BATCH], values[9 * ITEMS_PER_BATCH] = {0}, contact_energy[ITEMS_PER_BATCH];
        double f[ITEMS_PER_BATCH], d_theta[ITEMS_PER_BATCH], d_rate[ITEMS_PER_BATCH], spring_torque[ITEMS_PER_BATCH];
        double applied_torque[ITEMS_PER_BATCH], damper_torque[ITEMS_PER_BATCH];
        for (int64_t k = 0; k < count; ++k) {
            const int64_t j = first + k;
            state[4 * k] = c->theta[j];
            state[4 * k + 1] = c->theta_dot[j];
            state[4 * k + 2] = m->hinge_rest_angle[j];
            state[4 * k + 3] = 0.0;
        }
        m->hinge_force(count, state, values, m->hinge_contact + 11 * first, f, d_theta, d_rate, spring_torque,
                       applied_torque, damper_torque, contact_energy);
        for (int64_t k = 0; k < count; ++k) {
            const int64_t j = first + k;
            double s = c->theta[j] - m->hinge_rest_angle[j];
            strain += 0.5 * m->hinge_stiffness[j] * s * s;
            if (m->hinge_stiffness_law[j] >= 0 && m->hinge_conservative[j])
                strain += law_spring_potential(m, j, c->theta[j]);
            strain += contact_energy[k];
        }
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        int64_t i = m->body_nodes[b];
        const double *T = c->T + 9 * i, *om = c->w + 3 * i;
        double mass = m->body_mass[b], rc[3], wr[3], vc[3], TI[9], Tt[9], J[9], Jw[3];
        matvec3(T, m->body_com + 3 * b, rc);
        cross(om, rc, wr);
        for (int p = 0; p < 3; ++p) vc[p] = c->v[3 * i + p] + wr[p];
        for (int p = 0; p < 3; ++p)
            for (int q = 0; q < 3; ++q) Tt[3 * p + q] = T[3 * q + p];
        matmul3(T, m->body_inertia + 9 * b, TI);
        matmul3(TI, Tt, J);
        matvec3(J, om, Jw);
        kinetic += 0.5 * mass * (vc[0] * vc[0] + vc[1] * vc[1] + vc[2] * vc[2])
                 + 0.5 * (om[0] * Jw[0] + om[1] * Jw[1] + om[2] * Jw[2]);
        for (int p = 0; p < 3; ++p) potential -= mass * (c->x[3 * i + p] + rc[p]) * m->gravity[p];
    }
    if (m->n_cables > 0) { /* the cables' strain energy at the rest lengths of time t */
        m->time_laws(t, w->laws);
        cables(m, c, w, w->laws, NULL);
        for (int64_t e = 0; e < m->n_cables; ++e) strain += w->cable_strain[e];
    }
    out[0] = kinetic;
    out[1] = strain;
    out[2] = potential;
}

/* What latdyn_evaluate computes and returns besides the Work buffers. */
typedef struct {
    double t;                /* the laws' time */
    double load_factor;      /* λ: scales point loads, gravity and hinge torques */
    int64_t inertia;         /* 0: the static residual, without inertia forces or M and C blocks */
    int64_t matrices;        /* also the element, body, hinge and load blocks of K (and M, C) */
    int64_t inertia_tangent; /* with matrices and inertia: the elements' inertia tangent too */
    double power;            /* out: the power of the point loads and cable reels (external work) */
} EvaluationControl;

/* One evaluation at c (latdyn/assembly/native_model.py): w->total holds the vector of all
 * coordinates (residual on the free ones, reaction on the constrained ones); with matrices, the
 * blocks are in w->tangent, w->mass, w->quadratic_D (C of the elements), w->body_stiffness,
 * w->body_mass, w->body_damping, w->hinge_d_theta, w->hinge_d_rate, w->load_blocks and, asked
 * for, w->inertia_tangent. */
void latdyn_evaluate(const Model *m, Work *w, const Configuration *c, EvaluationControl *e)
{
    m->time_laws(e->t, w->laws);
    e->power = evaluate(m, c, w, w->laws, e->t, (int)e->matrices, (int)e->inertia, e->load_factor);
    if (e->matrices && e->inertia && e->inertia_tangent)
        inertia_tangent(m, w, e->load_factor);
}

/* The cable elements at c and time t into w->cable_state, w->cable_strain and their blocks, and nothing
 * else of Work but the laws (latdyn/timeloop/events.py reads the stretches between steps, where the
 * last evaluation's rows must stay as they are). */
void latdyn_cables(const Model *m, Work *w, const Configuration *c, double t)
{
    m->time_laws(t, w->laws);
    cables(m, c, w, w->laws, NULL);
}

/* The element kernels' inputs at c (Eqs. 2, 9, 17) into w->geometry, w->rates, w->accelerations. */
void latdyn_element_inputs(const Model *m, Work *w, const Configuration *c)
{
    element_inputs(m, c, w, 0, m->n_elements);
}
