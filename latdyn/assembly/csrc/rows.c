/*
 * Rows where the step runs: what the time loop records at a row (latdyn/timeloop/loop.py TimeLoop._record),
 * evaluated inside the loop of steps (newton_step.c latdyn_advance) into preallocated buffers, so that
 * Python sees a block of rows at a time (latdyn/step/compiled.py RowBuffers).
 *
 * A row holds the accepted state (for the probes of kinematics, state.h5 and ParaView), the run's counters
 * and energy accounts at it, the energies of latdyn_energies (evaluate.c), and where the probes ask for them
 * the mid-element section forces (the strain-energy kernel's second output, as latdyn_energies leaves them
 * in Work) and the momenta (latdyn_momentum below, the one evaluation of the momenta: Assembler.momentum
 * calls it too), the force each joint applies on its coordinate (latdyn_joint_forces below, the one
 * evaluation of the joint torque and force probes and of summary.json joint_peaks: ProbeSet.joint_forces
 * calls it too) and the cable elements' [ℓ, ℓ̇, ℓ − L0, N_el, N] (latdyn_cables of evaluate.c, which
 * NativeModel.cable_state calls for the cable probes of a row recorded in Python) and, where a probe reads
 * one, the continuous controllers' states as accepted at the row.
 */

/* The continuous controllers' outputs at the accepted state c, time t: their laws (clipped) at its
 * sensors and their states as accepted (controller_outputs of evaluate.c outside a step), into the
 * scene's array of controller outputs m->controller_outputs, which the next evaluation writes again.
 * The row records them; ProbeSet.values calls it for a row recorded in Python. */
void latdyn_controller_outputs_at(const Model *m, Work *w, const Configuration *c, double t)
{
    if (!m->n_controllers) return;
    for (int64_t i = 0; i < m->n_sensors; ++i)  /* a tension or joint-force sensor reads the laws at t */
        if (m->sensor_kind[i] == 11 || m->sensor_kind[i] == 14) {
            m->time_laws(t, w->laws);
            break;
        }
    double held = 0.0;
    if (m->n_controller_states) {
        held = w->controller_half_step[0];
        w->controller_half_step[0] = 0.0; /* outside a step: S as accepted */
    }
    controller_outputs(m, c, w, t);
    if (m->n_controller_states) w->controller_half_step[0] = held;
}

/* Whether every joint (hinge or guide) has its coordinate (none prescribed, latched, stuck or on a rigid
 * stop) and no continuous controller runs, whose output a joint's force could carry: then a joint's force
 * is its law's alone (latdyn_joint_forces). */
static int joints_all_free(const Model *m)
{
    if (m->n_controllers) return 0;
    for (int64_t j = 0; j < m->n_hinges; ++j)
        if (m->hinge_dofs[j] >= m->n_dofs) return 0;
    return 1;
}

/* The generalized force each joint (hinge or guide, in model order) applies on its coordinate at the
 * state `held` and time t, positive when it drives θ or s up (SCENE.md, the joint probes torque/force;
 * latdyn/results/probes.py ProbeSet.joint_forces has the rules). One evaluation of the equations of
 * motion (reduced onto the minimum coordinates with rigid links): the residual of a joint's coordinate
 * is r = G + f, f its law (spring, damper, compliant stop, friction, applied torque or force, a
 * continuous controller's output: Work.joint_forces) and G all the rest.
 * - A free joint applies its law: −f.
 * - A joint without a coordinate (prescribed, latched, stuck by friction, resting on its rigid stop:
 *   latdyn/timeloop/events.py locks it there) applies the reaction that holds it: r.
 * `held` is the caller's copy of the state: with rigid links its dependent nodes are completed in it.
 * `load_factor`: the static path's λ (the loads, gravity and applied torques it ramps), 1 in a transient.
 * Where every joint is free and no continuous controller drives one, the forces are the laws' alone and
 * only the joints' laws are evaluated (hinge_forces of evaluate.c: the same kernel on the same inputs as
 * in the evaluation, so the same values; a truss's row no longer pays an evaluation of its elements);
 * otherwise Work is left as the evaluation leaves it. */
void latdyn_joint_forces(const Model *m, Work *w, Configuration *held, double t, double load_factor, double *out)
{
    const int64_t n = m->n_dofs;
    if (m->n_hinges == 0) return;
    m->time_laws(t, w->laws);
    if (joints_all_free(m)) {
        hinge_forces(m, held, w, w->laws, t, load_factor, NULL);
        for (int64_t j = 0; j < m->n_hinges; ++j) out[j] = 0.0 - w->joint_forces[j]; /* 0.0 − f: no −0.0 */
        return;
    }
    if (m->links) complete_links(m, held);
    evaluate(m, held, w, w->laws, t, 0, 1, load_factor);
    if (m->links) reduce_links(m, w, held, 0.0, 0.0, 0, 0);
    for (int64_t j = 0; j < m->n_hinges; ++j) {
        const int64_t d = m->hinge_dofs[j];
        out[j] = d < n ? 0.0 - w->joint_forces[j] : w->total[d]; /* 0.0 − f: no −0.0 */
    }
}

/* Linear momentum P and angular momentum H about the global origin of the model at c, out = [P, H].
 * An element: P·e_k = q̇ᵀ M q̇_t and H·e_k = q̇ᵀ M q̇_r with M the generated mass matrix (Eq. 45's
 * kernel), q̇_t the rigid translation e_k of both ends and q̇_r the rigid rotation e_k about the origin
 * (ends moving with e_k × x, turning with e_k; the hinge rates 0). A joint body: m v_c and
 * r_c × m v_c + J ω about its centre of mass r_c = x + T c, J = T I Tᵀ. */
static void momentum_of(const Model *m, Work *w, const Configuration *c, int inputs_ready, double *out)
{
    const int64_t E = m->n_elements;
    double P[3] = {0.0, 0.0, 0.0}, H[3] = {0.0, 0.0, 0.0};
    if (E > 0) {
        if (!inputs_ready) element_inputs(m, c, w, 0, E);
        m->mass_matrix(E, w->geometry, m->element_sections, w->mass);
    }
    for (int64_t e = 0; e < E; ++e) {
        const double *M = w->mass + 196 * e, *qdot = w->rates + 14 * e, *g = w->geometry + 36 * e;
        double Mq[14];
        for (int i = 0; i < 14; ++i) {
            double s = 0.0;
            for (int j = 0; j < 14; ++j) s += M[14 * i + j] * qdot[j];
            Mq[i] = s;
        }
        for (int k = 0; k < 3; ++k) {
            /* e_k × x of each end: the rigid rotation's translation of the end's reference point */
            const double *x1 = g, *x2 = g + 3;
            double r1[3] = {0.0, 0.0, 0.0}, r2[3] = {0.0, 0.0, 0.0}, ek[3] = {0.0, 0.0, 0.0};
            ek[k] = 1.0;
            cross(ek, x1, r1);
            cross(ek, x2, r2);
            P[k] += Mq[k] + Mq[7 + k];
            double h = Mq[3 + k] + Mq[10 + k];
            for (int p = 0; p < 3; ++p) h += Mq[p] * r1[p] + Mq[7 + p] * r2[p];
            H[k] += h;
        }
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        int64_t i = m->body_nodes[b];
        const double *T = c->T + 9 * i, *om = c->w + 3 * i;
        double mass = m->body_mass[b], rc[3], wr[3], p[3], TI[9], Tt[9], J[9], Jw[3], r[3], rp[3];
        matvec3(T, m->body_com + 3 * b, rc);
        cross(om, rc, wr);
        for (int q = 0; q < 3; ++q) p[q] = mass * (c->v[3 * i + q] + wr[q]);
        for (int q = 0; q < 3; ++q)
            for (int s = 0; s < 3; ++s) Tt[3 * q + s] = T[3 * s + q];
        matmul3(T, m->body_inertia + 9 * b, TI);
        matmul3(TI, Tt, J);
        matvec3(J, om, Jw);
        for (int q = 0; q < 3; ++q) r[q] = c->x[3 * i + q] + rc[q];
        cross(r, p, rp);
        for (int q = 0; q < 3; ++q) {
            P[q] += p[q];
            H[q] += rp[q] + Jw[q];
        }
    }
    for (int k = 0; k < 3; ++k) {
        out[k] = P[k];
        out[3 + k] = H[k];
    }
}

void latdyn_momentum(const Model *m, Work *w, const Configuration *c, double *out)
{
    momentum_of(m, w, c, 0, out);
}

/* The scalars of a row, in this order (latdyn/step/compiled.py ROW_SCALARS): its time; the steps, Newton
 * iterations and factorizations of the loop call up to it; the external work and the dissipated energy
 * since the start of the run; kinetic, strain and potential energy (latdyn_energies); P and H (with
 * momentum, else 0). */
enum { ROW_SCALARS = 15 };

/* The rows one call of latdyn_advance records (NULL in Advance: none). */
typedef struct {
    int64_t capacity;          /* rows the buffers hold */
    int64_t planned;           /* rows to record (≤ capacity), at these grid points, rising: */
    const int64_t *grid_point; /* (capacity) a row after the step that lands on grid point grid_point[r] */
    int64_t momentum, sections; /* whether each row holds the momenta, and the section forces */
    int64_t recorded;          /* out: rows recorded */
    double *scalars;           /* (capacity, ROW_SCALARS) */
    double *section_forces;    /* (capacity, n_elements, 4) with sections */
    Configuration *states;     /* (capacity): each row's state, copied */
    /* with joints: each row's latdyn_joint_forces (capacity, n_hinges), evaluated on the scratch
     * configuration `held`; the last evaluation's outputs the loop hands back (Work.total, the hinges'
     * work and damper torques: n_total + 1 + 2 n_hinges) kept in `saved` meanwhile; the cables' work rows
     * are those of the same state) */
    int64_t joints;
    double *joint_forces;
    Configuration *held;
    double *saved;
    /* with cables: each row's cable elements [ℓ, ℓ̇, ℓ − L0, N_el, N] (capacity, n_cables, 5) */
    int64_t cables;
    double *cable_states;
    /* with a probe of a continuous controller's state: each row's copy of the controllers' states
     * (capacity, controller_values), the runtime's array m->controller_states as accepted at the row */
    int64_t controller_values;
    double *controller_states;
    /* with a probe of a controller's output: each row's copy of the scene's array of controller outputs
     * (capacity, output_values), the continuous ones evaluated at the row (latdyn_controller_outputs_at) */
    int64_t output_values;
    double *controller_outputs;
} Rows;

/* Record the row of the accepted state c at time t (the loop's counters and accounts in `counters`:
 * steps, iterations, factorizations, external work, dissipated energy). */
static void record_row(const Model *m, Work *w, Rows *rows, const Configuration *c, double t,
                       const double counters[5])
{
    const int64_t r = rows->recorded;
    double *out = rows->scalars + ROW_SCALARS * r;
    copy_configuration(m, c, rows->states + r);
    out[0] = t;
    for (int k = 0; k < 5; ++k) out[1 + k] = counters[k];
    latdyn_energies(m, w, c, t, out + 6);
    if (rows->sections)
        memcpy(rows->section_forces + 4 * m->n_elements * r, w->section_forces, sizeof(double) * 4 * (size_t)m->n_elements);
    if (rows->momentum) momentum_of(m, w, c, 1, out + 9); /* the element inputs latdyn_energies left in Work */
    else for (int k = 0; k < 6; ++k) out[9 + k] = 0.0;
    if (rows->cables) {
        latdyn_cables(m, w, c, t); /* their states at c (and w->cable_work at c, as the step left it) */
        memcpy(rows->cable_states + 5 * m->n_cables * r, w->cable_state, sizeof(double) * 5 * (size_t)m->n_cables);
    }
    if (rows->output_values > 0) {
        latdyn_controller_outputs_at(m, w, c, t);
        memcpy(rows->controller_outputs + rows->output_values * r, m->controller_outputs,
               sizeof(double) * (size_t)rows->output_values);
    }
    if (rows->controller_values > 0)
        memcpy(rows->controller_states + rows->controller_values * r, m->controller_states,
               sizeof(double) * (size_t)rows->controller_values);
    if (rows->joints) {
        const size_t T = (size_t)m->n_total + 1, H = (size_t)m->n_hinges;
        double *saved = rows->saved;
        memcpy(saved, w->total, sizeof(double) * T);
        memcpy(saved + T, w->hinge_work_torque, sizeof(double) * H);
        memcpy(saved + T + H, w->hinge_damper_torque, sizeof(double) * H);
        copy_configuration(m, c, rows->held);
        latdyn_joint_forces(m, w, rows->held, t, 1.0, rows->joint_forces + H * r);
        memcpy(w->total, saved, sizeof(double) * T);
        memcpy(w->hinge_work_torque, saved + T, sizeof(double) * H);
        memcpy(w->hinge_damper_torque, saved + T + H, sizeof(double) * H);
    }
    rows->recorded = r + 1;
}
