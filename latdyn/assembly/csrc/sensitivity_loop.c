/*
 * The transient sensitivities' smooth step inside the loop of steps (latdyn_advance, newton_step.c): after each
 * accepted step that lands on the grid with no event, the derivative of that step for k parameters, as
 * latdyn/analyses/transient_sensitivities.py TransientSensitivities.step takes it from Python
 * (step_columns, then the step size's column times δh = −δt_n): the exponential's R and J per free node,
 * the predicted parts (latdyn_sensitivity_predict), the evaluation with the inertia tangent at the converged
 * state (latdyn_evaluate), the joint bodies' inertia stiffness and the scatter of M, C and the exact K onto the
 * assembler's pattern (latdyn_joint_body_inertia_stiffness, latdyn_exact_matrix_values), ∂r/∂p of the hinge laws
 * (the generated hinge_force), the section values (latdyn_section_parameter_forces), the geometry parameters
 * (latdyn_geometry_parameter_forces), the joint bodies (the generated
 * joint_body, joint_body_D_com), the compliant stops and friction (the generated contact_force_D_law,
 * friction_force_D_law), the load components (the generated point_load) and the cables' parameters
 * (cable_forces.c: the generated cable_force, cable_force_D_rest_length, joint_body), the continuous controllers with
 * states (controller_states.c: their held δS through ∂y/∂S, the matrices with the states condensed from the step's
 * start, δS and δf carried), with the derivative laws'
 * values the caller tabulated per grid point, S's factorization and the k + 1 solves
 * (latdyn_sensitivity_step), the update (latdyn_sensitivity_update); with rigid links or guides M, C and the exact
 * K on the minimum coordinates and ∂r/∂p reduced by Pᵀ (linked_matrices.c, the forward step's reduction).
 * The calls, their inputs and the order of
 * their sums are the Python step's; latdyn/analyses/sensitivities_in_loop.py lays the struct out and says
 * which runs take it.
 *
 * Runtime code, written by hand: it holds no physics. R = exp(skew ψ) and J = dexp(ψ) per free node are the
 * generated so3_exp and so3_dexp (codegen/joints.py), which the Python step calls too.
 */

/* A joint law's derivatives kernel (contact_force_D_law, friction_force_D_law): (n, hinge, contact, out). */
typedef void (*kernel_joint_law)(int64_t, const double *, const double *, double *);

/* What the loop of steps needs for the sensitivities' step (latdyn.analyses.sensitivities_in_loop). */
typedef struct SensitivityLoopTag {
    int64_t k;                          /* parameters */
    double *dq, *dv, *dvdot, *da;       /* in/out: the carried δq, δv, δv̇, δa (n × k, row-major) */
    double *dt, *dh;                    /* in/out: δt (k); out: the last step's δh (k) */
    int64_t f;                          /* free nodes with rotation coordinates; 0: R = J = I (a planar model) */
    const int64_t *slots;               /* f × 3: their rotation coordinates (≥ n: not one) */
    double *psi, *turn, *tangent;       /* f × 3, f × 9, f × 9: hΔq on them, R, J */
    const double *blocks;               /* S's J blocks: tangent where f > 0, else the identity's (held) */
    double *increment;                  /* n + 1: hΔq, and a zero */
    double *predicted;                  /* 5 n (k + 1) */
    double *explicit_;                  /* n (k + 1) */
    double *total;                      /* (n_total + 1) × k */
    double *z;                          /* n (k + 1) */
    double *updated;                    /* 4 n (k + 1) */
    /* M, C and the exact K on the pattern (Assembler.exact_matrix_values) */
    int64_t n_segments;
    const int64_t *counts;
    const double *const *first;
    const double *const *second;
    const int64_t *const *indices;
    const int64_t *positions;
    int64_t mck_size;
    double *mck;
    kernel_body_stiffness body_kernel;  /* NULL: no joint bodies */
    const double *body_rows, *body_gravity;
    double *body_scratch, *body_stiffness;
    /* S (ExactStepMatrix) */
    const SensitivityStep *step;
    double *S, *factor;
    int *pivots;
    double *solve_work;                 /* 3 n (k + 1) */
    /* ∂r/∂p of the section values (ParameterDerivatives._native_section_forces); n_uses 0: none */
    kernel_2_2 internal_D_section;
    kernel_5_2 inertia_D_section;
    const double *gravity;
    int64_t n_on;
    const int64_t *on;
    int64_t n_uses;
    const int64_t *use, *elements, *columns;
    const double *rows;
    double *section_scratch;
    /* ∂r/∂p of the load components (ParameterDerivatives._load_pair_forces); n_pairs 0: none */
    int64_t n_pairs;
    const int64_t *pair_node, *pair_frame, *pair_column; /* frame: the node of its body, −1 global */
    const double *pair_offset;          /* n_pairs × 3 */
    const double *pair_values;          /* (grid points) × n_pairs × 6: λ ∂(the load's values)/∂p at each */
    int64_t values_from;                /* the grid index of pair_values' first grid point */
    double *pair_scratch;               /* 76 n_pairs */
    /* ∂r/∂p of the hinge laws (ParameterDerivatives._hinge_force); n_hinge_uses 0: none */
    int64_t n_hinge_uses;
    kernel_hinge_force hinge_kernel;    /* the generated hinge_force (the address the Python path calls) */
    const int64_t *hinge_joint, *hinge_column; /* each (use, column): its hinge and parameter column */
    const int64_t *hinge_slot;          /* the derivative's place among the kernel's 9 law values; −1: the rest angle */
    const double *hinge_at;             /* n_hinge_uses × 4: the kernel's (θ, θ̇, θ_r, λ), θ and θ̇ set here (not
                                         * for the rest angle, whose force is the kernel's at (0, 0, 1, λ)) */
    const double *hinge_values;         /* (grid points) × n_hinge_uses × 2: the derivative law's value, and for the
                                         * rest angle the stiffness law's, at each grid point (from values_from) */
    const double *no_contact;           /* 11: the kernel's contact row without stop or friction (NO_CONTACT) */
    /* ∂r/∂p of the joint bodies' mass, inertia and centre of mass (ParameterDerivatives._body_forces) */
    int64_t n_body_uses;
    kernel_joint_body body_force_kernel;      /* the generated joint_body */
    kernel_body_stiffness body_com_kernel;    /* the generated joint_body_D_com (NULL where no use moves c) */
    const int64_t *body_use_node, *body_use_column;
    const int64_t *body_use_axis;       /* −1: the kernel with the use's block; else ∂f/∂c along ∂c/∂p */
    const double *body_use_gravity;     /* 3: λ g */
    const double *body_values;          /* (grid points) × n_body_uses × 16: the kernel's block (13) and ∂c/∂p (3),
                                         * at each grid point (from values_from) */
    double *body_use_scratch;           /* 150: a node's frame and motion, the kernels' outputs */
    /* ∂r/∂p of the hinges' compliant stops' and friction's laws (ParameterDerivatives._contact_forces) */
    int64_t n_law_uses;
    kernel_joint_law contact_kernel;    /* the generated contact_force_D_law (3 values), NULL where no use */
    kernel_joint_law friction_kernel;   /* the generated friction_force_D_law (5 values), NULL where no use */
    const int64_t *law_joint, *law_column;
    const int64_t *law_kind, *law_slot; /* kind 0: the stop's, 1: the friction's; slot: the law's value among them */
    const double *law_at;               /* n_law_uses × 4: the kernel's (θ, θ̇, θ_r, 1), θ and θ̇ set here */
    const double *law_rows;             /* n_law_uses × 11: the joint's contact row (joint_contact_rows) */
    const double *law_factor;           /* n_law_uses: the slope's factor (−(1/v_s)² for the Stribeck rate), else 1 */
    const double *law_values;           /* (grid points) × n_law_uses: the derivative law's value at each grid point */
    /* out */
    int64_t steps;                      /* steps differentiated here */
    int64_t info;                       /* the factorization's info where S was singular (the loop stopped) */
    double h;                           /* the last step's size */
    /* the rows recorded on the way (rows.c): the carried δq, δv, δv̇ (n × k each) and δt (k) at each row, which
     * TransientSensitivities.record reads (latdyn.analyses.sensitivities_in_loop SensitivityLoop.record_rows);
     * NULL: none */
    double *row_carried;                /* (rows' capacity) × (3 n k + k) */
    /* ∂r/∂p of the geometry parameters (ReferenceGeometry.add, geometry_forces.c); NULL: none */
    const GeometryForces *geometry;
    /* rigid links and guides (linked_matrices.c); linked 0: none. M, C and the exact K on the minimum coordinates
     * (dense, n × n each: mck with S's pattern the full one) and ∂r/∂p reduced by Pᵀ */
    int64_t linked;
    const int64_t *linked_gather;       /* n²: each entry's offset in the iteration matrix's storage (−1: none) */
    double *linked_storage;             /* the iteration matrix's storage size: a buffer of the step's own */
    double *linked_body_D;              /* 36 per joint body: their inertia stiffness */
    /* hinge laws' derivatives of θ, θ̇ or an input (latdyn/analyses/derivative_laws.py): the compiled laws, which
     * the Python path calls too, evaluated at the hinge's (θ, θ̇, t) in place of the tabulated values */
    void (*derivative_laws)(int64_t, double, double, double, double *); /* latdyn_hinge_laws of them; NULL: none */
    const int64_t *hinge_law_index;     /* n_hinge_uses × 2: the derivative law's and (rest angle) the stiffness
                                         * law's number among them; −1: hinge_values' tabulated value */
    /* explicit time dependence beside events (ExplicitTime, latdyn/analyses/transient_sensitivities.py): ∂r/∂t's
     * struct, one column of the hinge laws' and loads' uses with their rates in t, of the reels (its `cables`: each
     * reeled cable's rest-length use with L0′(t)) and of the prescribed motions (its n_motions); NULL: nothing moves
     * in t */
    struct SensitivityLoopTag *time_rates;
    /* continuous controllers' parameters (ControllerTerms.add, latdyn/analyses/sensitivities.py): each use (controller,
     * column) its compiled ∂f/∂p (derivative_laws.py ControllerPartials: law number u), at t and its controller's
     * sensors (hinge angles and rates); each hinge actuator's row less its factor times its controller's slope */
    int64_t n_partials;                 /* 0: none */
    void (*controller_partials)(int64_t, double, const double *, double *);
    const int64_t *partial_controller, *partial_column;
    int64_t n_partial_controllers;      /* the wiring's continuous controllers */
    const int64_t *read_start;          /* n_partial_controllers + 1: each one's sensors in read_kind, read_index */
    const int64_t *read_kind, *read_index; /* 0: the hinge's θ, 1: its θ̇ */
    int64_t n_hinge_actuators;
    const int64_t *actuator_hinge, *actuator_of; /* in the wiring's order: the hinge, its controller */
    const double *actuator_factor;      /* ∂τ/∂y (1 for the controller's name alone) */
    double *controller_slopes;          /* n_partial_controllers × k */
    double *controller_scratch;         /* the law's arguments and outputs */
    const int64_t *output_law;          /* n_partial_controllers: its output's law number (limits); −1: no limits */
    const double *output_limits;        /* n_partial_controllers × 2 */
    /* ∂r/∂p of the cables' parameters (CableSensitivities.residual_derivatives, cable_forces.c); NULL: none. With
     * it, the loop hands a step that ends near a cable element's change to the caller (cable_near_change) */
    const CableForces *cables;
    /* the work accounts' sensitivities carried through the steps (work_accounts.c); NULL: no such probe */
    WorkAccounts *accounts;

    /* S on the sparse LU (step_matrix.py): the band LU with pivoting that stands in at a step whose sparse pivot fails,
     * as the Python step's (latdyn_sensitivity_step_pivoted: Factorization._factor_pivoted); NULL: S not sparse */
    const Factorization *pivoted;
    const int64_t *pivoted_storage;     /* S's entries' offsets in its storage */
    double *pivoted_factor;             /* its storage */
    int *pivoted_pivots;                /* n */
    /* rigid links and guides: the entries linked_gather gathers (n²: the dense n × n; above DENSE_LIMIT coordinates
     * or on a sparse storage the iteration matrix's pattern on the minimum coordinates, S on it: latdyn_linked_exact_values) */
    int64_t linked_count;

    /* ∂r/∂t through the prescribed motions (csrc/prescribed_rates.c, latdyn/analyses/prescribed_rates.py), read in
     * the time_rates struct (n_motions 0: none): 1 on each prescribed coordinate (n_total + 1), each load block's
     * columns (n_loads × 6), the coordinates the motion laws move (n_motions) and their rate, acceleration and
     * jerk at each grid point ((grid points) × 3 × n_motions, from motions_from), the dense rates 3 (n_total + 1)
     * (zero off them) and the result (n_total + 1) */
    const int64_t *prescribed_mask, *load_columns;
    int64_t n_motions;
    const int64_t *motion_coordinates;
    const double *motion_values;
    int64_t motions_from;
    double *motion_rates, *through_prescribed;

    /* controllers' chains and load actuators (ControllerTerms.add). read_kind 2: the probe's value the evaluation at c
     * left in Work (sensor_values: points' positions and velocities), 3: an earlier controller's output (read_index
     * its place), held here as the chain computes it; the compiled output law's derivatives (output_gradient) carry
     * the earlier controllers' slopes; a load actuator adds its factor times its controller's slope to its load's
     * component, each load's nonzero columns then one call of the generated point_load */
    const int64_t *output_limited;      /* n_partial_controllers: 1 with limits */
    double *held_outputs;               /* n_partial_controllers: the outputs after their limits */
    double *output_gradient;            /* the largest controller's reads + 1 */
    int64_t n_load_actuators;           /* 0: none */
    const int64_t *load_actuator_load;  /* its load's place among the actuated loads */
    const int64_t *load_actuator_component, *load_actuator_of;
    const double *load_actuator_factor; /* ∂(the component)/∂y */
    int64_t n_actuated_loads;           /* in their first actuator's order */
    const int64_t *actuated_load_node, *actuated_load_frame; /* frame: the node of its body, −1 global */
    const double *actuated_load_offset; /* n_actuated_loads × 3 */
    double *actuated_load_scratch;      /* 83 k */
    /* sampled controllers (SampledTerms.add): their held δy (controllers × k, set before each call of the loop, which
     * hands every sample instant back to Python: TransientSensitivities.after_sample), NULL: none; their hinge and
     * guide actuators (hinge, controller, ∂τ/∂y) and load actuators (as the continuous ones') */
    const double *sampled_held;
    int64_t n_sampled_hinge_actuators;
    const int64_t *sampled_hinge, *sampled_hinge_of;
    const double *sampled_hinge_gain;
    int64_t n_sampled_load_actuators;
    const int64_t *sampled_load, *sampled_load_component, *sampled_load_of;
    const double *sampled_load_gain;
    int64_t n_sampled_loads;            /* the last of the actuated loads: the sampled controllers' */
    /* prescribed motions on a model with rigid links or guides (linked_prescribed_rates.c), in the time_rates
     * struct: scratch of the prescribed and dependent coordinates' mask (n_total + 1) and δq, δv, δa
     * (3 (n_total + 1)), and ∂r_all/∂t (n_total + 1) */
    int64_t *linked_motion_mask;
    double *linked_motion_moved, *linked_motion_all;
    /* the continuous controllers' coupling rows then columns (2 n_couplings), for a sensor on a coordinate the
     * prescribed motions move (prescribed_rates.c); NULL: none */
    const int64_t *motion_couplings;
    /* controllers that read inputs (SCENE.md ``inputs``: constant in a step, set from outside between advances):
     * read_kind 4, read_index the input's place in the scene's inputs' array (Inputs.values, never reallocated),
     * its value in the law's argument as the Python step passes it (the compiled laws read the bound array itself);
     * with it read_kind 2's read_index is the sensor's place in Work's sensor_values */
    const double *input_values;
    /* continuous controllers with states (ControllerStates; controller_states.c): their carried δS, δf and (S, f) at
     * the step's start, in/out around each call; NULL: none (or the Python path) */
    ControllerStatesLoop *states;
    /* controllers reading a free joint's torque or force whose own laws a parameter moves
     * (ControllerTerms.sensed_force_slopes): each such read's slot among read_kind's and its joint's row in total,
     * whose ∂r/∂p of the hinge laws alone (hinge_parameter_forces, the first in total) is −∂F/∂p, taken into
     * force_slopes (n_force_reads × k) and added to the reader's slope times ∂f/∂s; 0: none */
    int64_t n_force_reads;
    const int64_t *force_read, *force_row;
    double *force_slopes;
    /* controllers reading an element's section force whose section values a parameter moves (their force_row −1):
     * per force read its element (−1: a joint's force), the first of the section forces its sensor weighs and the two
     * weights (the sensor's, evaluate.c sensor_value kind 12); ∂S/∂p by the section uses (n_uses, elements, columns,
     * rows) from the generated beam_section_forces_D_section (section_force_slope, csrc/parameter_forces.c, which
     * ControllerTerms.sensed_force_slopes calls too); NULL: none */
    const int64_t *force_element, *force_first;
    const double *force_weights;
    kernel_2_2 section_forces_D_section;
    /* controllers reading a cable's tension whose EA, damping or rest length a parameter moves: per force read the
     * cable's first element (−1: not a tension), whose ∂N/∂p cable_tension_slope (cable_forces.c) takes from the
     * cables' uses (the cables struct), as CableSensitivities and probe_derivatives._tension_by_parameters form it */
    const int64_t *force_cable_element;
    /* ∂r/∂p of the geometry parameters' turning shifts (ReferenceGeometry._add_shifts, turning_shifts.c), before the
     * reduction; NULL: none */
    const TurningShifts *shifts;
} SensitivityLoop;

/* Row r of the rows recorded on the way: the carried δq, δv, δv̇ and δt as the step before it left them. */
static void sensitivity_loop_row(const Model *m, const SensitivityLoop *s, int64_t r)
{
    if (s->accounts != NULL) work_accounts_row(s->accounts, s->k, r);
    if (s->states != NULL) controller_states_row(s->states, s->k, r); /* a controller probe's δS and S */
    if (!s->row_carried) return;
    const size_t nk = (size_t)m->n_dofs * (size_t)s->k;
    double *out = s->row_carried + (3 * nk + (size_t)s->k) * (size_t)r;
    memcpy(out, s->dq, sizeof(double) * nk);
    memcpy(out + nk, s->dv, sizeof(double) * nk);
    memcpy(out + 2 * nk, s->dvdot, sizeof(double) * nk);
    memcpy(out + 3 * nk, s->dt, sizeof(double) * (size_t)s->k);
}

/* ∂r/∂p of the load components at c into total ((n_total + 1) × k): per (load, parameter) pair the generated
 * point_load with the pair's values at grid point `grid`, added at its node's coordinates in np.add.at's order. */
static void load_parameter_forces(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t grid)
{
    const int64_t P = s->n_pairs, k = s->k;
    if (P == 0) return;
    double *T = s->pair_scratch, *values = T + 9 * P, *frames = values + 6 * P, *velocity = frames + 9 * P;
    double *offsets = velocity + 6 * P, *force = offsets + 3 * P, *power = force + 6 * P;
    double *by_node = power + P, *by_frame = by_node + 18 * P;
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const double *table = s->pair_values + 6 * P * (grid - s->values_from);
    for (int64_t p = 0; p < P; ++p) {
        const int64_t i = s->pair_node[p], frame = s->pair_frame[p];
        memcpy(T + 9 * p, c->T + 9 * i, 9 * sizeof(double));
        memcpy(values + 6 * p, table + 6 * p, 6 * sizeof(double));
        memcpy(frames + 9 * p, frame >= 0 ? c->T + 9 * frame : identity, 9 * sizeof(double));
        memcpy(velocity + 6 * p, c->v + 3 * i, 3 * sizeof(double));
        memcpy(velocity + 6 * p + 3, c->w + 3 * i, 3 * sizeof(double));
        memcpy(offsets + 3 * p, s->pair_offset + 3 * p, 3 * sizeof(double));
    }
    m->point_load(P, T, offsets, values, frames, velocity, force, power, by_node, by_frame);
    for (int64_t p = 0; p < P; ++p) {
        const int64_t *d = m->node_dofs + 6 * s->pair_node[p];
        for (int j = 0; j < 6; ++j) s->total[d[j] * k + s->pair_column[p]] += force[6 * p + j];
    }
}

/* ∂r/∂p of the hinge laws at c into total ((n_total + 1) × k): per (use, column) the generated hinge_force with
 * the derivative law's value in its law's place at the hinge's (θ, θ̇) (linear in the laws), or for the rest angle
 * the derivative times its force at (0, 0, 1, λ) with the stiffness alone (f = k (θ − θ_r) + …: affine in θ_r),
 * added at the hinge's coordinate in the Python path's order (ParameterDerivatives._hinge_force). */
static void hinge_parameter_forces(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t grid,
                                   double t)
{
    const int64_t U = s->n_hinge_uses, k = s->k;
    const double *table = s->hinge_values + 2 * U * (grid - s->values_from);
    for (int64_t u = 0; u < U; ++u) {
        const int64_t j = s->hinge_joint[u], slot = s->hinge_slot[u];
        double at[4], laws[9] = {0}, f, by_angle, by_rate, spring, applied, damper, energy, value[2], out[3];
        for (int i = 0; i < 2; ++i) {   /* the derivative's and the stiffness's: compiled at (θ, θ̇, t), or tabulated */
            const int64_t law = s->derivative_laws != NULL ? s->hinge_law_index[2 * u + i] : -1;
            if (law >= 0) s->derivative_laws(law, c->theta[j], c->theta_dot[j], t, out);
            value[i] = law >= 0 ? out[0] : table[2 * u + i];
        }
        memcpy(at, s->hinge_at + 4 * u, 4 * sizeof(double));
        if (slot >= 0) {
            at[0] = c->theta[j];
            at[1] = c->theta_dot[j];
            laws[slot] = value[0];
        } else {
            laws[0] = value[1];
        }
        s->hinge_kernel(1, at, laws, s->no_contact, &f, &by_angle, &by_rate, &spring, &applied, &damper, &energy);
        s->total[m->hinge_dofs[j] * k + s->hinge_column[u]] += slot >= 0 ? f : value[0] * f;
    }
}

/* ∂r/∂p of the joint bodies at c into total: per (use, column) the generated joint_body with the use's block (linear in
 * m and I at a fixed c) or joint_body_D_com along c's axis, at the node's frame and (ω, a, α), added at the node's
 * coordinates in the Python path's order (ParameterDerivatives._body_forces). */
static void body_parameter_forces(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t grid)
{
    const int64_t B = s->n_body_uses, k = s->k;
    const double *table = s->body_values + 16 * B * (grid - s->values_from);
    double *frame = s->body_use_scratch, *motion = frame + 9, *force = motion + 9, *blocks = force + 6;
    double *by_com = blocks + 3 * 36;
    for (int64_t u = 0; u < B; ++u) {
        const int64_t i = s->body_use_node[u];
        const double *block = table + 16 * u, *along = block + 13;
        memcpy(frame, c->T + 9 * i, 9 * sizeof(double));
        memcpy(motion, c->w + 3 * i, 3 * sizeof(double));
        memcpy(motion + 3, c->a + 3 * i, 3 * sizeof(double));
        memcpy(motion + 6, c->alpha + 3 * i, 3 * sizeof(double));
        if (s->body_use_axis[u] < 0) {
            s->body_force_kernel(1, frame, motion, block, s->body_use_gravity, force, blocks, blocks + 36, blocks + 72);
        } else {
            s->body_com_kernel(1, frame, motion, block, s->body_use_gravity, by_com);
            for (int r = 0; r < 6; ++r)   /* (6 × 3) @ along: one term nonzero, so any order of the sum is NumPy's */
                force[r] = by_com[3 * r] * along[0] + by_com[3 * r + 1] * along[1] + by_com[3 * r + 2] * along[2];
        }
        const int64_t *d = m->node_dofs + 6 * i;
        for (int r = 0; r < 6; ++r) s->total[d[r] * k + s->body_use_column[u]] += force[r];
    }
}

/* Use u's slope of a hinge's compliant stop's or friction's law at c: the generated contact_force_D_law or
 * friction_force_D_law at the hinge's (θ, θ̇), its slot times the factor (the Stribeck rate's −(1/v_s)²). */
static double joint_law_slope(const Configuration *c, const SensitivityLoop *s, int64_t u)
{
    const int64_t j = s->law_joint[u];
    double at[4], out[5];
    memcpy(at, s->law_at + 4 * u, 4 * sizeof(double));
    at[0] = c->theta[j];
    at[1] = c->theta_dot[j];
    (s->law_kind[u] ? s->friction_kernel : s->contact_kernel)(1, at, s->law_rows + 11 * u, out);
    return out[s->law_slot[u]] * s->law_factor[u];
}

/* ∂r/∂p of the hinges' compliant stops' and friction's laws at c into total: per (use, column) its slope
 * (joint_law_slope) times the derivative law's value, added at the hinge's coordinate in the Python path's order
 * (ParameterDerivatives._contact_forces). */
static void joint_law_parameter_forces(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t grid)
{
    const int64_t U = s->n_law_uses, k = s->k;
    const double *table = s->law_values + U * (grid - s->values_from);
    for (int64_t u = 0; u < U; ++u)
        s->total[m->hinge_dofs[s->law_joint[u]] * k + s->law_column[u]] += table[u] * joint_law_slope(c, s, u);
}

/* The compliant stops' and friction's part of a read joint's ∂f/∂p (ControllerTerms.sensed_force_slopes: its row of
 * ParameterDerivatives._contact_forces after the hinge laws'): per (use, column) of a joint a controller reads, in
 * joint_law_parameter_forces's order, the same product added to that read's force_slopes. */
static void joint_law_force_slopes(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t grid)
{
    const int64_t U = s->n_law_uses, k = s->k;
    const double *table = s->law_values + U * (grid - s->values_from);
    for (int64_t u = 0; u < U; ++u) {
        const int64_t row = m->hinge_dofs[s->law_joint[u]];
        double slope = 0.0;
        int read = 0;
        for (int64_t f = 0; f < s->n_force_reads; ++f) {
            if (s->force_row[f] != row) continue;
            if (!read++) slope = joint_law_slope(c, s, u);
            s->force_slopes[f * k + s->law_column[u]] += table[u] * slope;
        }
    }
}

/* The read section forces' ∂S/∂p at c into their force_slopes (ControllerTerms.sensed_force_slopes): the elements'
 * inputs at c, then section_force_slope per read of an element. */
static void section_force_slopes(const Model *m, Work *w, const Configuration *c, const SensitivityLoop *s)
{
    element_inputs(m, c, w, 0, m->n_elements);
    for (int64_t f = 0; f < s->n_force_reads; ++f)
        if (s->force_element[f] >= 0)
            section_force_slope(m, w, s->section_forces_D_section, s->force_element[f], s->force_first[f],
                                s->force_weights + 2 * f, s->n_uses, s->elements, s->columns, s->rows, s->k,
                                s->force_slopes + f * s->k);
}

/* The load actuators' part of ControllerTerms.add (and of SampledTerms.add): per actuated load (in its first
 * actuator's order) its six components' derivatives (each actuator's factor times its controller's slope, summed in
 * the order of the actuators), then one call of the generated point_load for the columns where any is nonzero, added at
 * its node's coordinates. `a`: the actuators' load places, components, controllers and factors (n of them); their
 * loads' places first … last − 1 among the actuated loads (the continuous controllers' then the sampled ones'). */
static void actuated_load_forces(const Model *m, const Configuration *c, const SensitivityLoop *s, int64_t n,
                                 const int64_t *const a[3], const double *factors, const double *slopes,
                                 int64_t first, int64_t last)
{
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    const int64_t k = s->k;
    double *moved = s->actuated_load_scratch, *T = moved + 6 * k, *values = T + 9 * k, *frames = values + 6 * k;
    double *velocity = frames + 9 * k, *offsets = velocity + 6 * k, *force = offsets + 3 * k, *power = force + 6 * k;
    double *by_node = power + k, *by_frame = by_node + 18 * k;
    int64_t columns[k > 0 ? k : 1];
    for (int64_t load = first; load < last; ++load) {
        memset(moved, 0, sizeof(double) * (size_t)(6 * k));
        for (int64_t i = 0; i < n; ++i) {
            if (a[0][i] != load) continue;
            const double factor = factors[i], *slope = slopes + a[2][i] * k;
            double *row = moved + a[1][i] * k;
            for (int64_t col = 0; col < k; ++col) row[col] += factor * slope[col];
        }
        const int64_t node = s->actuated_load_node[load], frame = s->actuated_load_frame[load];
        int64_t P = 0;
        for (int64_t col = 0; col < k; ++col) {
            int any = 0;
            for (int j = 0; j < 6; ++j) any |= moved[j * k + col] != 0.0;
            if (!any) continue;
            columns[P] = col;
            memcpy(T + 9 * P, c->T + 9 * node, 9 * sizeof(double));
            for (int j = 0; j < 6; ++j) values[6 * P + j] = moved[j * k + col];
            memcpy(frames + 9 * P, frame >= 0 ? c->T + 9 * frame : identity, 9 * sizeof(double));
            memcpy(velocity + 6 * P, c->v + 3 * node, 3 * sizeof(double));
            memcpy(velocity + 6 * P + 3, c->w + 3 * node, 3 * sizeof(double));
            memcpy(offsets + 3 * P, s->actuated_load_offset + 3 * load, 3 * sizeof(double));
            ++P;
        }
        if (!P) continue;
        m->point_load(P, T, offsets, values, frames, velocity, force, power, by_node, by_frame);
        const int64_t *d = m->node_dofs + 6 * node;
        for (int64_t p = 0; p < P; ++p)
            for (int j = 0; j < 6; ++j) s->total[d[j] * k + columns[p]] += force[6 * p + j];
    }
}

/* The load actuators' part of the step size's column through the states (ControllerStates.by_step_size: the
 * loads of ControllerTerms.add in one column): actuated_load_forces with the slopes ∂y/∂S by_h
 * (controller_states_step_size_column left them in controller_slopes) into the states' by_step. */
static void controller_states_load_step_size(const Model *m, const Configuration *c, const SensitivityLoop *s)
{
    SensitivityLoop one = *s;
    one.k = 1;
    one.total = s->states->by_step;
    const int64_t *const loads[3] = {s->load_actuator_load, s->load_actuator_component, s->load_actuator_of};
    actuated_load_forces(m, c, &one, s->n_load_actuators, loads, s->load_actuator_factor, s->controller_slopes, 0,
                         s->n_actuated_loads - s->n_sampled_loads);
}

/* The sampled controllers' held outputs' ∂r/∂p (SampledTerms.add, before the continuous controllers'): each hinge or
 * guide actuator's row less its gain times its controller's held δy where that is nonzero, then the loads'. */
static void sampled_parameter_forces(const Model *m, const Configuration *c, const SensitivityLoop *s)
{
    const int64_t k = s->k;
    for (int64_t a = 0; a < s->n_sampled_hinge_actuators; ++a) {
        const double *held = s->sampled_held + s->sampled_hinge_of[a] * k, gain = s->sampled_hinge_gain[a];
        int any = 0;
        for (int64_t col = 0; col < k; ++col) any |= gain * held[col] != 0.0;
        if (!any) continue;
        double *row = s->total + m->hinge_dofs[s->sampled_hinge[a]] * k;
        for (int64_t col = 0; col < k; ++col) row[col] -= gain * held[col];
    }
    const int64_t *const loads[3] = {s->sampled_load, s->sampled_load_component, s->sampled_load_of};
    if (s->n_sampled_load_actuators)
        actuated_load_forces(m, c, s, s->n_sampled_load_actuators, loads, s->sampled_load_gain, s->sampled_held,
                             s->n_actuated_loads - s->n_sampled_loads, s->n_actuated_loads);
}

/* ∂r/∂p through the continuous controllers at c (time t) into total (ControllerTerms.add: no states): in the wiring's
 * order each controller's slope dy/dp = ∂f/∂p by the compiled partials at its sensors (0 while its output, by its
 * compiled law, is clipped) plus, through a chain, ∂f/∂y_j dy_j/dp by its compiled output's derivatives; then each
 * hinge actuator's row less its factor times its controller's slope, and each actuated load's point_load. */
static void controller_parameter_forces(const Model *m, const Work *w, const Configuration *c,
                                        const SensitivityLoop *s, double t)
{
    const int64_t k = s->k;
    double *slopes = s->controller_slopes, *args = s->controller_scratch, *gradient = s->output_gradient;
    if (s->sampled_held != NULL) sampled_parameter_forces(m, c, s);
    if (!s->n_partials && s->states == NULL && !s->n_force_reads) return;
    memset(slopes, 0, sizeof(double) * (size_t)(s->n_partial_controllers * k));
    for (int64_t ctl = 0; ctl < s->n_partial_controllers; ++ctl) {
        const int64_t output = s->output_law[ctl], first = s->read_start[ctl];
        int64_t uses = 0, count = 0, chained = 0;
        for (int64_t u = 0; u < s->n_partials; ++u) uses += s->partial_controller[u] == ctl;
        const int64_t stated = s->states != NULL ? controller_with_states(s->states, ctl) : -1;
        if (!uses && output < 0 && stated < 0) continue;
        for (int64_t i = first; i < s->read_start[ctl + 1]; ++i) {
            const int64_t kind = s->read_kind[i], index = s->read_index[i];
            args[count++] = kind == 0 ? c->theta[index] : kind == 1 ? c->theta_dot[index] :
                            kind == 2 ? w->sensor_values[index] : kind == 4 ? s->input_values[index] :
                            s->held_outputs[index];
            chained += kind == 3;
        }
        if (stated >= 0) count = controller_state_arguments(m, ctl, args, count);   /* then its states S_{n+1} */
        double *out = args + count;
        if (output >= 0) {   /* f by its compiled law: its limits, the output a later controller reads, ∂f/∂s */
            s->controller_partials(output, t, args, out);
            const double raw = out[0], lo = s->output_limits[2 * ctl], hi = s->output_limits[2 * ctl + 1];
            memcpy(gradient, out + 1, sizeof(double) * (size_t)count);
            s->held_outputs[ctl] = !s->output_limited[ctl] ? raw : fmin(fmax(raw, lo), hi);
            if (s->output_limited[ctl] && !(lo < raw && raw < hi)) continue;   /* clipped: no derivative */
        }
        double *slope = slopes + ctl * k;
        for (int64_t u = 0; u < s->n_partials; ++u) {
            if (s->partial_controller[u] != ctl) continue;
            s->controller_partials(u, t, args, out);
            slope[s->partial_column[u]] += out[0];
        }
        for (int64_t f = 0; f < s->n_force_reads; ++f) {   /* ∂f/∂s ∂F/∂p of the forces whose laws p moves */
            const int64_t i = s->force_read[f];
            if (i < first || i >= s->read_start[ctl + 1]) continue;
            const double g = gradient[i - first], *by_p = s->force_slopes + f * k;
            for (int64_t col = 0; col < k; ++col) slope[col] += g * by_p[col];
        }
        for (int64_t i = first; chained && i < s->read_start[ctl + 1]; ++i) {   /* the chain rule, in its reads' order */
            if (s->read_kind[i] != 3) continue;
            const double g = gradient[i - first], *earlier = slopes + s->read_index[i] * k;
            for (int64_t col = 0; col < k; ++col) slope[col] += g * earlier[col];
        }
        if (stated >= 0)   /* ∂y/∂S times the held δS_{n+1} (ControllerTerms.add) */
            controller_states_held_slope(m, s->states, ctl, t, args, count,
                                         s->states->held + s->states->first[stated] * k, k, slope);
    }
    for (int64_t a = 0; a < s->n_hinge_actuators; ++a) {
        const double *slope = slopes + s->actuator_of[a] * k, factor = s->actuator_factor[a];
        double *row = s->total + m->hinge_dofs[s->actuator_hinge[a]] * k;
        for (int64_t col = 0; col < k; ++col) row[col] -= factor * slope[col];
    }
    const int64_t *const loads[3] = {s->load_actuator_load, s->load_actuator_component, s->load_actuator_of};
    if (s->n_load_actuators)
        actuated_load_forces(m, c, s, s->n_load_actuators, loads, s->load_actuator_factor, slopes, 0,
                             s->n_actuated_loads - s->n_sampled_loads);
}

/* ∂r/∂t through the prescribed motions at c into r->through_prescribed (ExplicitTime.through_prescribed,
 * PrescribedRates.__call__): the evaluation with the inertia tangent at c, the joint bodies' inertia stiffness
 * (exact_matrices left it in s->body_stiffness at c), the motion laws' rates at grid point `grid` made dense, then
 * latdyn_prescribed_time_rate (csrc/prescribed_rates.c), as the Python path calls them. */
static void prescribed_time_rate(const Model *m, Work *w, const Configuration *c, const SensitivityLoop *s,
                                 SensitivityLoop *r, int64_t grid, double t, double h)
{
    const int64_t size = m->n_total + 1, P = r->n_motions;
    EvaluationControl e = {t, 1.0, 1, 1, 1, 0.0};
    if (s->states != NULL) controller_states_condensed(m, w, s->states, h, 1);   /* as the step: total dy/ds */
    latdyn_evaluate(m, w, c, &e);
    if (s->states != NULL) controller_states_condensed(m, w, s->states, h, 0);
    memset(r->motion_rates, 0, sizeof(double) * (size_t)(3 * size));
    const double *table = r->motion_values + 3 * P * (grid - r->motions_from);
    for (int part = 0; part < 3; ++part)
        for (int64_t q = 0; q < P; ++q) r->motion_rates[part * size + r->motion_coordinates[q]] = table[part * P + q];
    if (s->linked)   /* the dependent nodes moved with the prescribed ones, Pᵀ and the geometric term */
        latdyn_linked_prescribed_time_rate(m, w, c, r->prescribed_mask, r->motion_rates, 1,
                                           s->body_kernel != NULL ? s->linked_body_D : NULL, r->load_columns,
                                           r->motion_couplings, r->linked_motion_mask, r->linked_motion_moved,
                                           r->linked_motion_all, r->through_prescribed);
    else
        latdyn_prescribed_time_rate(m, w, r->prescribed_mask, r->motion_rates, 1,
                                    s->body_kernel != NULL ? s->body_stiffness : NULL, r->load_columns,
                                    r->motion_couplings, r->through_prescribed);
}

/* The explicit time dependence at the step's end (TransientSensitivities._add_time_columns): ∂r/∂t at c (the hinge
 * laws', the continuous controllers' outputs' that name t (their compiled ∂f/∂t through the actuators, as their
 * parameters' ∂f/∂p: transient_sensitivities._controller_time_rates) then the loads' rates in t through the same calls
 * as their parameters', ExplicitTime.of_laws; with rigid
 * links or guides reduced by Pᵀ as ExplicitTime's _on_free_coordinates reduces it) times the
 * carried δt_n added to the parameters' columns of explicit_, and ∂r/∂t itself to the step size's. */
static void explicit_time_columns(const Model *m, Work *w, const Configuration *c, SensitivityLoop *s, int64_t grid,
                                  double t, double h)
{
    SensitivityLoop *r = s->time_rates;
    const int64_t n = m->n_dofs, k = s->k, cols = k + 1;
    memset(r->total, 0, sizeof(double) * (size_t)(m->n_total + 1));
    if (r->n_hinge_uses) hinge_parameter_forces(m, c, r, grid, t);
    if (r->n_partials) controller_parameter_forces(m, w, c, r, t);   /* outputs that name t: their ∂y/∂t */
    load_parameter_forces(m, c, r, grid);
    if (r->cables != NULL) cable_parameter_forces(m, w, c, r->cables, 1, grid, r->total);   /* reels: ExplicitTime.of_laws */
    if (s->linked) latdyn_linked_reduce_columns(m, r->total, 1, r->total);   /* Pᵀ, as the parameters' columns */
    if (r->n_motions) prescribed_time_rate(m, w, c, s, r, grid, t, h);   /* ExplicitTime.through_prescribed, added after */
    for (int64_t i = 0; i < n; ++i) {
        const double rate = r->n_motions ? r->total[i] + r->through_prescribed[i] : r->total[i];
        for (int64_t col = 0; col < k; ++col) s->explicit_[i * cols + col] += rate * s->dt[col];
        s->explicit_[i * cols + k] += rate;
    }
}

/* M, C and the exact K at c and time t into s->mck (Assembler.exact_matrix_values): the evaluation with the inertia
 * tangent, the joint bodies' inertia stiffness, the scatter onto the pattern. */
static void exact_matrices(const Model *m, Work *w, SensitivityLoop *s, const Configuration *c, double t)
{
    EvaluationControl e = {t, 1.0, 1, 1, 1, 0.0};
    latdyn_evaluate(m, w, c, &e);
    if (s->body_kernel != NULL)
        latdyn_joint_body_inertia_stiffness(m, c, s->body_kernel, s->body_rows, s->body_gravity, s->body_scratch,
                                            s->body_stiffness);
    latdyn_exact_matrix_values(s->n_segments, s->counts, s->first, s->second, s->indices, s->positions, s->mck_size,
                               s->mck);
}

/* ∂r/∂p with the inertia forces at c (time t, the laws' tabulated values at grid point `grid`) into s->total
 * ((n_total + 1) × k; with rigid links or guides reduced by Pᵀ in place, rows < n), with Work holding the evaluation
 * at c (ParameterDerivatives.residual_derivatives: the hinges', the sections', the geometry parameters', the joint
 * bodies', the compliant stops' and friction's, then the loads'): the forward step's right-hand side
 * (sensitivity_loop_step) and the discrete adjoint's contraction (∂r/∂p)ᵀw (adjoint_reverse.c). */
static void parameter_columns(const Model *m, Work *w, SensitivityLoop *s, const Configuration *c, double t,
                              int64_t grid)
{
    const int64_t k = s->k;
    memset(s->total, 0, sizeof(double) * (size_t)((m->n_total + 1) * k));
    if (s->n_hinge_uses) hinge_parameter_forces(m, c, s, grid, t);
    for (int64_t f = 0; f < s->n_force_reads; ++f)   /* a read joint's ∂F/∂p: its row of the hinge laws' alone, */
        for (int64_t col = 0; col < k; ++col)
            s->force_slopes[f * k + col] = s->force_row[f] >= 0 ? s->total[s->force_row[f] * k + col] : 0.0;
    if (s->n_law_uses && s->n_force_reads) joint_law_force_slopes(m, c, s, grid);   /* + its stops' and friction's */
    for (int64_t i = 0; i < s->n_force_reads * k; ++i) s->force_slopes[i] = -s->force_slopes[i];   /* −∂f/∂p */
    if (s->force_element != NULL) section_force_slopes(m, w, c, s);   /* a section force's ∂S/∂p */
    for (int64_t f = 0; s->force_cable_element != NULL && f < s->n_force_reads; ++f)   /* a cable's tension's ∂N/∂p */
        if (s->force_cable_element[f] >= 0)
            cable_tension_slope(m, w, c, s->cables, grid, s->force_cable_element[f], k, s->force_slopes + f * k);
    if (s->n_uses)
        latdyn_section_parameter_forces(m, w, c, s->internal_D_section, s->inertia_D_section, 1, s->gravity, s->n_on,
                                        s->on, s->n_uses, s->use, s->elements, s->columns, s->rows, k, s->total,
                                        s->section_scratch);
    if (s->shifts != NULL) turning_shift_columns(c, w, s->shifts, s->linked_body_D, k, s->total);   /* ReferenceGeometry.add's order */
    if (s->geometry != NULL) latdyn_geometry_parameter_forces(m, w, c, s->geometry, k, grid, s->total);
    if (s->n_body_uses) body_parameter_forces(m, c, s, grid);
    if (s->n_law_uses) joint_law_parameter_forces(m, c, s, grid);
    if (s->n_partials || s->sampled_held != NULL || s->states != NULL || s->n_force_reads)
        controller_parameter_forces(m, w, c, s, t);
    load_parameter_forces(m, c, s, grid);
    if (s->cables != NULL) cable_parameter_forces(m, w, c, s->cables, k, grid, s->total);
    if (s->linked) latdyn_linked_reduce_columns(m, s->total, k, s->total);   /* Pᵀ, in place: rows < n */
}

/* The sensitivities' step over the accepted step base → c of size h ending on grid point `grid` at time t
 * (scheme: α_m, α_f, γ, β; v_n, a_n, a_{n+1}: the free velocities at its start and the algorithmic accelerations before and after
 * it): s's carried columns replaced by those at c. Returns 0, or the factorization's info where S is
 * singular (nothing carried on). */
static int64_t sensitivity_loop_step(const Model *m, Work *w, SensitivityLoop *s, const double *scheme,
                                     const Configuration *c, double t, double h, int64_t grid, const double *v_n,
                                     const double *a_old, const double *a_new)
{
    const int64_t n = m->n_dofs, k = s->k, cols = k + 1;
    const double am = scheme[0], af = scheme[1], gamma = scheme[2], beta = scheme[3];
    const double beta_p = (1 - am) / (h * h * beta * (1 - af)), gamma_p = gamma / (h * beta);
    const double step[5] = {h, am, af, gamma, beta};
    /* the step's own increment hΔq, its rotations' exp and tangent operator (_rotation_operators) */
    if (s->f > 0) {
        const double half = h * (0.5 - beta), hb = h * beta;
        for (int64_t i = 0; i < n; ++i) s->increment[i] = h * ((v_n[i] + half * a_old[i]) + hb * a_new[i]);
        s->increment[n] = 0.0;
        for (int64_t node = 0; node < s->f; ++node)
            for (int j = 0; j < 3; ++j) {
                const int64_t slot = s->slots[3 * node + j];
                s->psi[3 * node + j] = s->increment[slot < n ? slot : n];
            }
        m->so3_exp(s->f, s->psi, s->turn);
        m->so3_dexp(s->f, s->psi, s->tangent);
    }
    latdyn_sensitivity_predict(n, k, step, s->f, s->slots, s->turn, s->tangent, v_n, a_old, a_new, s->dq, s->dv,
                               s->dvdot, s->da, s->predicted);
    if (s->states != NULL) {   /* ControllerStates.begin_step; the matrices with the states condensed from (S_n, f_n) */
        const int64_t info = controller_states_begin_loop(m, w, c, s->states, s->controller_partials, s->read_start, k,
                                                          t, h);
        if (info) return s->info = info;
        controller_states_condensed(m, w, s->states, h, 1);
    }
    if (s->linked)
        latdyn_linked_exact_values(m, w, c, t, s->body_kernel, s->body_rows, s->body_gravity, s->body_scratch,
                                   s->linked_body_D, s->linked_gather, s->linked_count, s->linked_storage, s->mck);
    else
        exact_matrices(m, w, s, c, t);
    if (s->states != NULL) controller_states_condensed(m, w, s->states, h, 0);
    parameter_columns(m, w, s, c, t, grid);
    for (int64_t i = 0; i < n; ++i) {   /* on the free coordinates, with the step size's column 0 */
        for (int64_t col = 0; col < k; ++col) s->explicit_[i * cols + col] = s->total[i * k + col];
        s->explicit_[i * cols + k] = 0.0;
    }
    if (s->states != NULL) {   /* the states' derivative by the step size (ControllerStates.by_step_size) */
        controller_states_step_size_column(m, w, c, s->states, s->controller_partials, s->read_start, s->output_law,
                                           s->output_limited, s->output_limits, s->n_hinge_actuators,
                                           s->actuator_hinge, s->actuator_of, s->actuator_factor, t,
                                           s->n_partial_controllers, s->controller_slopes);
        if (s->n_load_actuators) controller_states_load_step_size(m, c, s);
        if (s->linked) latdyn_linked_reduce_columns(m, s->states->by_step, 1, s->states->by_step);   /* Pᵀ */
        controller_states_step_size_add(m, s->states, cols, s->explicit_);
    }
    if (s->time_rates != NULL) explicit_time_columns(m, w, c, s, grid, t, h);
    const int64_t size = n * cols;
    const double *da0 = s->predicted, *dq0 = s->predicted + size, *dv0 = s->predicted + 2 * size;
    (void)da0;
    int64_t info = latdyn_sensitivity_step(s->step, s->mck, s->blocks, beta_p, gamma_p, s->S, s->factor, s->pivots,
                                           cols, s->explicit_, dq0, dv0, s->solve_work, s->z);
    if (info != 0 && s->pivoted != NULL)   /* the sparse LU's pivot failed: the band LU with pivoting, as in Python */
        info = latdyn_sensitivity_step_pivoted(s->step, s->pivoted, s->pivoted_storage, s->S, s->mck, s->pivoted_factor,
                                               s->pivoted_pivots, cols, s->explicit_, dq0, dv0, s->solve_work, s->z);
    if (info != 0) {
        s->info = info;
        return info;
    }
    latdyn_sensitivity_update(n, k, step, beta_p, gamma_p, s->f, s->slots, s->tangent, s->z, s->predicted,
                              s->updated);
    /* the step lands on the grid: δh = −δt_n, and each column plus the step size's times δh */
    double *carried[4] = {s->dq, s->dv, s->dvdot, s->da};
    for (int64_t col = 0; col < k; ++col) s->dh[col] = -s->dt[col];
    for (int part = 0; part < 4; ++part) {
        const double *x = s->updated + part * size;
        double *to = carried[part];
        for (int64_t i = 0; i < n; ++i)
            for (int64_t col = 0; col < k; ++col) to[i * k + col] = x[i * cols + col] + x[i * cols + k] * s->dh[col];
    }
    for (int64_t col = 0; col < k; ++col) s->dt[col] = s->dt[col] + s->dh[col];
    if (s->states != NULL) controller_states_after_loop(m, w, c, s->states, s->read_start, k, t, h, s->dq, s->dv,
                                                          s->dh);
    if (s->accounts != NULL) work_accounts_step(m, w, c, s->accounts, k, s->dq, s->dv, s->dvdot, s->dh, h, grid, t);
    s->steps += 1;
    s->h = h;
    return 0;
}
