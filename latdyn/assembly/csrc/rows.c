/*
 * Rows where the step runs: what the time loop records at a row (latdyn/timeloop/loop.py TimeLoop._record),
 * evaluated inside the loop of steps (newton_step.c latdyn_advance) into preallocated buffers, so that
 * Python sees a block of rows at a time (latdyn/step/compiled.py RowBuffers).
 *
 * A row holds the accepted state (for the probes of kinematics, state.h5 and ParaView), the run's counters
 * and energy accounts at it, the energies of latdyn_energies (evaluate.c), and where the probes ask for them
 * the mid-element section forces (the strain-energy kernel's second output, as latdyn_energies leaves them
 * in Work) and the momenta (latdyn_momentum below, the one evaluation of the momenta: Assembler.momentum
 * calls it too).
 */

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
    rows->recorded = r + 1;
}
