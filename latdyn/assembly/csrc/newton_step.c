/*
 * One Lie-group generalized-α time step, Newton iteration included, in C, and the loop of
 * steps between two recorded rows.
 *
 * Runtime code, written by hand: it holds no physics. Each Newton iteration configures the
 * trial state and evaluates the equations of motion with evaluate.c (the one evaluation every
 * analysis uses), scatters S = β′M + γ′C + K into a preallocated matrix, factorizes and solves it
 * with factorization.c (the LU every analysis uses: dense or banded LAPACK, or the supernodal
 * sparse LU of sparse_lu.c), and tests convergence on the invariant increment. latdyn/step/integrators.py
 * documents the scheme; latdyn/step/compiled.py drives it. latdyn_advance runs the time loop's
 * steps between two recorded rows (timeloop/transient.py) and hands back the first step that
 * the Python loop must handle (a Newton failure, a hinge event); tests/test_compiled_loop.py
 * holds it to the steps taken one by one from Python.
 *
 * The matrix positions of the block entries in the factorization's storage are precomputed by
 * the caller (latdyn/step/compiled.py, latdyn/assembly/factorization.py), for the dense, band or
 * sparse storage alike; -1 marks an entry on a constrained coordinate.
 */
#define _POSIX_C_SOURCE 199309L /* clock_gettime: the wall-time budget of latdyn_advance */
#include <time.h>

#include "evaluate.c" /* the evaluation (inlined into this source by latdyn/assembly/library.py) */
#include "links.c"    /* rigid links: dependent nodes completed, evaluations reduced */
#include "rows.c"     /* rows where the step runs: the recorded rows' buffers, the momenta */
#include "sensitivity_step.c" /* the transient sensitivities' step matrix and solves in one call */
#include "parameter_forces.c" /* ∂r/∂p of the section values that name a parameter, in one call */
#include "geometry_forces.c" /* ∂r/∂p of the geometry parameters, in one call */
#include "linked_matrices.c" /* rigid links: M, C, K and ∂r/∂p on the minimum coordinates for the sensitivities */
#include "turning_shifts.c" /* geometry parameters: the shift of a subtree on a part that turns, its ∂r/∂p */
#include "cable_forces.c" /* ∂r/∂p of the cables' parameters for the sensitivities */
#include "drive_sensitivities.c" /* the prescribed motions' drive in the external work's sensitivity */
#include "work_accounts.c" /* the work accounts' sensitivities carried through the steps */
#include "controller_states.c" /* the controllers' states through the sensitivities' step: the p × p algebra */

#include "prescribed_rates.c" /* ∂r/∂t through the prescribed motions, exactly, for the sensitivities */
#include "linked_prescribed_rates.c" /* the same with rigid links or guides: the dependent nodes moved too */
#include "linked_weight.c" /* the reduction's geometric term times vectors: an event weight's derivative with links */
#include "linked_weight_second.c" /* its move along the configuration or in time: the links' second derivatives */
#include "sensitivity_loop.c" /* the transient sensitivities' smooth step in the loop of steps */
#include "adjoint_trajectory.c" /* the discrete adjoint's forward pass: the accepted steps stored */
#include "adjoint_reverse.c" /* the discrete adjoint's reverse pass: a smooth step in one call */
#include "checksum.c" /* lookup3, the checksum of state.h5's object headers (latdyn/results/hdf5_writer.py) */

/* S = β′M + γ′C + K scattered into the matrix storage (Evaluation.combined). */
static void assemble(const Model *m, Work *w, double beta_p, double gamma_p, int with_inertia_tangent)
{
    memset(w->matrix, 0, sizeof(double) * m->factorization->size);
    for (int64_t e = 0; e < m->n_elements; ++e)
        scatter_block(w->matrix, m->element_position + 196 * e, w->mass + 196 * e, w->quadratic_D + 196 * e,
                      w->tangent + 196 * e, with_inertia_tangent ? w->inertia_tangent + 196 * e : NULL, 196, beta_p,
                      gamma_p);
    for (int64_t b = 0; b < m->n_bodies; ++b)
        scatter_block(w->matrix, m->body_position + 36 * b, w->body_mass + 36 * b, w->body_damping + 36 * b,
                      w->body_stiffness + 36 * b, NULL, 36, beta_p, gamma_p);
    for (int64_t j = 0; j < m->n_hinges; ++j)
        if (m->hinge_position[j] >= 0)
            w->matrix[m->hinge_position[j]] += gamma_p * w->hinge_d_rate[j] + w->hinge_d_theta[j];
    for (int64_t l = 0; l < m->n_loads; ++l)
        scatter_block(w->matrix, m->load_position + 36 * l, NULL, NULL, w->load_blocks + 36 * l, NULL, 36, beta_p,
                      gamma_p);
    /* continuous controllers: the actuators' rows by the sensors' coordinates (evaluate.c) */
    for (int64_t e = 0; e < m->n_couplings; ++e)
        if (m->coupling_position[e] >= 0)
            w->matrix[m->coupling_position[e]] += gamma_p * w->coupling_damping[e] + w->coupling_stiffness[e];
    for (int64_t e = 0; e < m->n_cables; ++e)
        scatter_block(w->matrix, m->cable_position + 144 * e, NULL, w->cable_damping + 144 * e,
                      w->cable_stiffness + 144 * e, NULL, 144, beta_p, gamma_p);
}

/* The iteration matrix S = β′M + γ′C + K of the evaluation left in w (latdyn_evaluate at c, with
 * matrices and inertia), as the Newton iteration forms it before factoring it: with rigid links and
 * guides reduced onto the minimum coordinates (c's dependent nodes completed by latdyn_complete_links;
 * the residual in w->total reduced in place). Into the matrix storage, unfactored; tests compare it with
 * latdyn.assembly.linked's reduction. */
void latdyn_iteration_matrix(const Model *m, Work *w, const Configuration *c, double beta_p, double gamma_p,
                             int64_t with_inertia_tangent)
{
    if (m->links) reduce_links(m, w, c, beta_p, gamma_p, 2, (int)with_inertia_tangent);
    else assemble(m, w, beta_p, gamma_p, (int)with_inertia_tangent);
}

/* dx = −S⁻¹ r with the factors held in Work (factorization.c), through the factor's order. */
static int solve(const Model *m, Work *w, const double *residual, double *dx)
{
    const int64_t *permutation = m->factorization->permutation;
    for (int64_t i = 0; i < m->n_dofs; ++i) w->rhs[permutation[i]] = -residual[i];
    int info = (int)latdyn_solve(m->factorization, w->matrix, w->pivots, 1, w->rhs);
    for (int64_t i = 0; i < m->n_dofs; ++i) dx[i] = w->rhs[permutation[i]];
    return info;
}

/* The size of a Newton increment dx (n_dofs), dimensionless and invariant under rigid motions: per free node
 * |Δd|/ℓ (ℓ the size of the scene) and |Δπ|, per free hinge |Δθ|; the largest. The one definition: the time step,
 * statics, continuation and steady motion (latdyn/step/integrators.py increment_size, by latdyn_increment_size). */
static double increment_size(const Model *m, const double *dx, double length)
{
    double size = 0.0;
    for (int64_t k = 0; k < m->n_free_nodes; ++k) {
        const int64_t *d = m->node_dofs + 6 * m->free_nodes[k];
        double u[6];
        for (int j = 0; j < 6; ++j) u[j] = free_entry(dx, d[j], m->n_dofs);
        double t = sqrt(u[0] * u[0] + u[1] * u[1] + u[2] * u[2]) / length;
        double r = sqrt(u[3] * u[3] + u[4] * u[4] + u[5] * u[5]);
        if (t > size) size = t;
        if (r > size) size = r;
    }
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        double h = fabs(dx[m->hinge_dofs[m->free_hinges[k]]]);
        if (h > size) size = h;
    }
    return size;
}

/* q_n ∘ exp(h Δq) with the velocities and accelerations of the iteration (configure), the dependent
 * nodes of a model with rigid links completed. */
static void configure_trial(const Model *m, const Configuration *base, Configuration *trial, const double *increment,
                            const double *velocity, const double *acceleration, const double *laws)
{
    configure(m, base, trial, increment, velocity, acceleration, laws);
    if (m->links) complete_links(m, trial);
}

/* Settings and results of one step. */
typedef struct {
    /* in */
    double h, alpha_m, alpha_f, gamma, beta, tol, length;
    int64_t max_iterations;
    int64_t modified;          /* keep the factorization while Newton contracts */
    int64_t inertia_tangent;   /* add the elements' inertia tangent to the matrix (integrators.py) */
    double contraction;        /* rebuild when |Δx_k| > contraction |Δx_{k−1}| */
    /* in/out: the factorization held in Work belongs to this step size (0: none) */
    double factored_h;
    /* out */
    int64_t iterations, converged, factorizations;
    double power;
    double contraction_seen;   /* largest |Δx_k| / |Δx_{k−1}| of the step (StepStats.contraction) */
    /* in: the step's end time (the laws' time when the model has them compiled) */
    double t_new;
    /* in: converge on the error left estimated from the contraction (newton_converged), not |Δx_k| alone,
     * where the model has no events (Model.has_events) */
    int64_t estimate_error;
} StepControl;

/* One step from `base` (velocities v_n, accelerations v̇_n, algorithmic acceleration a_n on the
 * free coordinates) to `trial`; on return v and vdot hold the new velocities and accelerations,
 * w->total the last evaluation (residual and reaction); latdyn/step/integrators.py has the scheme,
 * tests/reference_step.py the NumPy reference it must equal. With rigid links, every configuration
 * is completed and every evaluation reduced onto the minimum coordinates (links.c). */
/* v_n and v̇_n of the free coordinates from a configuration (assembly.free_velocity, free_acceleration). */
static void free_rates(const Model *m, const Configuration *c, double *velocity, double *acceleration)
{
    for (int64_t k = 0; k < m->n_free_nodes; ++k) {
        int64_t i = m->free_nodes[k];
        const int64_t *d = m->node_dofs + 6 * i;
        for (int j = 0; j < 6; ++j) {
            if (d[j] >= m->n_dofs) continue;  /* not a coordinate (planar model) */
            velocity[d[j]] = j < 3 ? c->v[3 * i + j] : c->w[3 * i + j - 3];
            acceleration[d[j]] = j < 3 ? c->a[3 * i + j] : c->alpha[3 * i + j - 3];
        }
    }
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        int64_t j = m->free_hinges[k];
        velocity[m->hinge_dofs[j]] = c->theta_dot[j];
        acceleration[m->hinge_dofs[j]] = c->theta_ddot[j];
    }
}

/* Buffers of one step, each of n_dofs entries. */
typedef struct {
    double *v_n, *vdot_n, *a_n, *v, *vdot, *dq, *dx, *a_new;
} StepVectors;

static int64_t newton_iterations(const Model *m, Work *w, StepControl *s, const Configuration *base,
                                 Configuration *trial, StepVectors *x);

/* Whether Newton has converged after an increment of size |Δx_k| (the one before: |Δx_{k−1}|, INFINITY at
 * the first): with estimate_error, the error left after the last correction estimated from the
 * contraction seen, ρ/(1 − ρ) |Δx_k| with ρ = |Δx_k| / |Δx_{k−1}| (the tail of a linear contraction),
 * ≤ tol; where ρ is not known yet (the first iteration) or ρ ≥ 1, and without estimate_error (the default:
 * docs/performance.md, "Fewer iterations where they buy nothing"), |Δx_k| ≤ tol. */
static int newton_converged(double size, double previous, double tol, int64_t estimate_error)
{
    double rho = size / previous;
    if (!estimate_error || isinf(previous) || !(rho < 1.0)) return size <= tol;
    return size * rho / (1.0 - rho) <= tol;
}

/* The step (newton_iterations), with the states of continuous controllers condensed by the trapezoidal
 * rule of the step's h (evaluate.c controller_states_at): h/2 set for its evaluations only. */
int64_t latdyn_newton_step(const Model *m, Work *w, StepControl *s, const Configuration *base,
                           Configuration *trial, StepVectors *x)
{
    if (m->n_controller_states) w->controller_half_step[0] = 0.5 * s->h;
    int64_t failed = newton_iterations(m, w, s, base, trial, x);
    if (m->n_controller_states) w->controller_half_step[0] = 0.0;
    return failed;
}

static int64_t newton_iterations(const Model *m, Work *w, StepControl *s, const Configuration *base,
                                 Configuration *trial, StepVectors *x)
{
    const int64_t n = m->n_dofs;
    const double h = s->h, am = s->alpha_m, af = s->alpha_f, ga = s->gamma, be = s->beta;
    const double beta_p = (1 - am) / (h * h * be * (1 - af)), gamma_p = ga / (h * be);
    const double *v_n = x->v_n, *vdot_n = x->vdot_n, *a_n = x->a_n;
    double *v = x->v, *vdot = x->vdot, *dq = x->dq, *dx = x->dx;
    double previous = INFINITY;
    /* full Newton's error estimate, not where events can happen: latches, stops, friction and cables are
     * placed from the last iterates (docs/performance.md, "Fewer iterations where they buy nothing") */
    const int64_t estimate_error = s->estimate_error && !m->has_events;
    const double *laws = w->laws;
    m->time_laws(s->t_new, w->laws); /* the laws at the step's end time */
    free_rates(m, base, x->v_n, x->vdot_n);
    int rebuild = s->factored_h != h; /* modified Newton: the held factorization is stale */
    s->iterations = 0;
    s->converged = 0;
    s->factorizations = 0;
    s->contraction_seen = 0.0;
    for (int64_t i = 0; i < n; ++i) {
        double a_new = (af * vdot_n[i] + (1 - af) * vdot_n[i] - am * a_n[i]) / (1 - am);
        vdot[i] = vdot_n[i];
        v[i] = v_n[i] + h * (1 - ga) * a_n[i] + h * ga * a_new;
        dq[i] = v_n[i] + h * (0.5 - be) * a_n[i] + h * be * a_new;
    }
    for (int64_t iteration = 1; iteration <= s->max_iterations; ++iteration) {
        for (int64_t i = 0; i < n; ++i) dx[i] = h * dq[i];
        configure_trial(m, base, trial, dx, v, vdot, laws);
        int matrices = !s->modified || rebuild;
        s->power = evaluate(m, trial, w, laws, s->t_new, matrices, 1, 1.0);
        if (n == 0) {  /* nothing free: the reactions of the constrained coordinates, reduced (drive_work) */
            if (m->links) reduce_links(m, w, trial, 0.0, 0.0, 0, 0);
            s->converged = 1;
            return 0;
        }
        if (matrices && s->inertia_tangent) inertia_tangent(m, w, 1.0);
        if (m->links) reduce_links(m, w, trial, beta_p, gamma_p, matrices ? 2 : 0, (int)s->inertia_tangent);
        if (matrices) {
            if (!m->links) assemble(m, w, beta_p, gamma_p, (int)s->inertia_tangent);
            s->factorizations += 1;
            s->factored_h = 0.0;
            if (latdyn_factor(m->factorization, w->matrix, w->pivots) != 0) return 1;
            s->factored_h = h;
            rebuild = 0;
        }
        if (solve(m, w, w->total, dx) != 0) return 1;
        for (int64_t i = 0; i < n; ++i)
            if (!isfinite(dx[i])) return 1;
        for (int64_t i = 0; i < n; ++i) {
            dq[i] += dx[i] / h;
            v[i] += gamma_p * dx[i];
            vdot[i] += beta_p * dx[i];
        }
        s->iterations = iteration;
        double size = increment_size(m, dx, s->length);
        if (iteration > 1 && size / previous > s->contraction_seen) s->contraction_seen = size / previous;
        if (newton_converged(size, previous, s->tol, estimate_error)) {
            s->converged = 1;
            for (int64_t i = 0; i < n; ++i) {
                dx[i] = h * dq[i];
                /* the algorithmic acceleration of the new step (GeneralizedAlpha.a_candidate) */
                x->a_new[i] = (af * vdot_n[i] + (1 - af) * vdot[i] - am * a_n[i]) / (1 - am);
            }
            configure_trial(m, base, trial, dx, v, vdot, laws);
            return 0;
        }
        /* modified Newton: a new matrix when the old one stops contracting */
        if (s->modified && size > s->contraction * previous) rebuild = 1;
        previous = size;
    }
    return 0;
}

/* ------------------------------------------------------------------------- the loop of steps */

/* The hinge events of free hinge j over the step old → new, as the sum of the flags below, which
 * latdyn/timeloop/events.py reads (hinge_flags: lock_events, stop_crossings, stop_hits) and the loop of steps
 * tests (hinge_event):
 * LOCK_REACHED: it started on its lock_at or ends within the tolerance of it; LOCK_CROSSED: else it crossed it;
 * LOWER_CROSSED, UPPER_CROSSED: it crossed a stop from inside, beyond the tolerance on both sides (the onset of a
 * compliant stop's contact too); LOWER_HIT, UPPER_HIT: it ends on or beyond a rigid stop (within the tolerance)
 * moving into it, an impact (a compliant stop, contact stiffness > 0 in hinge_contact, is a force: it has no hit,
 * here, for the loop and for events.py stop_hits alike). The tolerances are the model's (hinge_event_tolerance:
 * latdyn/model/model.py lock_tolerance). */
enum { LOCK_REACHED = 1, LOCK_CROSSED = 2, LOWER_CROSSED = 4, UPPER_CROSSED = 8, LOWER_HIT = 16, UPPER_HIT = 32 };

static int64_t hinge_crossings(const Model *m, int64_t j, const double *theta_old, const double *theta_new,
                               const double *rate_new)
{
    int64_t flags = 0;
    const double lock = m->hinge_lock_at[j], *tolerance = m->hinge_event_tolerance + 3 * j;
    const int rigid = !(m->hinge_contact[11 * j + 2] > 0.0); /* stops without contact stiffness */
    if (!isnan(lock)) {
        const double before = theta_old[j] - lock, after = theta_new[j] - lock;
        if (before == 0.0 || fabs(after) <= tolerance[0])
            flags |= LOCK_REACHED;
        else if (before * after < 0.0)
            flags |= LOCK_CROSSED;
    }
    for (int side = -1; side <= 1; side += 2) {
        const double stop = side < 0 ? m->hinge_lower_stop[j] : m->hinge_upper_stop[j], tol = tolerance[side < 0 ? 1 : 2];
        if (isnan(stop)) continue;
        const double before = side * (theta_old[j] - stop), after = side * (theta_new[j] - stop); /* > 0: beyond */
        if (before < -tol && after > tol) flags |= side < 0 ? LOWER_CROSSED : UPPER_CROSSED;
        if (rigid && after >= -tol && side * rate_new[j] >= 0.0) flags |= side < 0 ? LOWER_HIT : UPPER_HIT;
    }
    return flags;
}

/* hinge_crossings of every free hinge into flags (n_hinges; 0 for the others) from the angles at the step's start
 * and end and the rates at its end (n_hinges each), for the steps accepted from Python (latdyn/timeloop/events.py
 * hinge_flags). */
void latdyn_hinge_crossings(const Model *m, const double *theta_old, const double *theta_new, const double *rate_new,
                            int64_t *flags)
{
    for (int64_t j = 0; j < m->n_hinges; ++j) flags[j] = 0;
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        flags[j] = hinge_crossings(m, j, theta_old, theta_new, rate_new);
    }
}

/* Whether free hinge j is tried for sticking at the end of a step from time t_old on which its rate went from
 * `before` to `after`: friction that can hold it (static level > 0, hinge_contact), and a rate that reversed, or
 * fell into the stick band, or a joint that started the run at rest; not a joint just released (rate 0 at the
 * step's start, growing): it slips until it reverses. The one test: the loop of steps' (hinge_event) and
 * latdyn/timeloop/events.py may_stick's (latdyn_may_stick). */
static int may_stick(const Model *m, int64_t j, double before, double after, double t_old)
{
    const double *contact = m->hinge_contact + 11 * j;  /* F_s at 6, the stick band v₀ at 10 */
    const int settling = fabs(after) <= contact[10] && fabs(after) < fabs(before);
    return contact[6] > 0.0 && (before * after < 0.0 || settling || (before == 0.0 && t_old == 0.0));
}

/* may_stick of every hinge into flags (n_hinges, 1 or 0; 0 for hinges not free) from the rates at the step's start
 * and end, the step from t_old, for the steps accepted from Python (latdyn/timeloop/events.py may_stick). */
void latdyn_may_stick(const Model *m, const double *rate_old, const double *rate_new, double t_old, int64_t *flags)
{
    for (int64_t j = 0; j < m->n_hinges; ++j) flags[j] = 0;
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        flags[j] = may_stick(m, j, rate_old[j], rate_new[j], t_old);
    }
}

/* Whether the step old → new holds an event that latdyn/timeloop/events.py handles (and the loop must not
 * accept by itself): a free hinge that reaches or crosses its lock_at (lock_events), crosses a stop from inside
 * (stop_crossings), or ends on or beyond a rigid stop moving into it (stop_hits; a compliant stop is a force, not
 * an impact: only its onset lands), by hinge_crossings; or may stick. */
static int hinge_event(const Model *m, const Configuration *old, const Configuration *new_, double t_old)
{
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        const int64_t flags = hinge_crossings(m, j, old->theta, new_->theta, new_->theta_dot);
        if (flags & (LOCK_REACHED | LOCK_CROSSED | LOWER_CROSSED | UPPER_CROSSED)) return 1;
        if (flags & (LOWER_HIT | UPPER_HIT)) return 1;
        if (may_stick(m, j, old->theta_dot[j], new_->theta_dot[j], t_old)) return 1;
    }
    return 0;
}

/* The free hinge whose angle at the end of the converged step old → new of size h lies farthest from where its
 * rate at the step's start takes it, θ_n + h θ̇_n, where that distance is more than π (a root about a whole turn
 * away, no motion, which the time loop cuts: latdyn/timeloop/progress.py far_root says why); −1 if none. Only the
 * joints with revolute[j] ≠ 0 count (a guide's slide is not periodic); revolute NULL: every free joint, a
 * superset, which the loop of steps hands back for the caller's far_root to decide, as hinge_event's friction
 * check hands back a superset. The distance into *distance (NULL: not wanted); the first of equal ones. */
static int64_t far_root(const Model *m, const Configuration *old, const Configuration *new_, double h,
                        const int64_t *revolute, double *distance)
{
    int64_t worst = -1;
    double farthest = 0.0;
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        const double d = fabs(new_->theta[j] - old->theta[j] - h * old->theta_dot[j]);
        if (d > 3.14159265358979323846 && (!revolute || revolute[j]) && (worst < 0 || d > farthest)) {  /* math.pi */
            worst = j;
            farthest = d;
        }
    }
    if (distance) *distance = farthest;
    return worst;
}

/* far_root for the steps accepted from Python (latdyn/timeloop/progress.py far_root). */
int64_t latdyn_far_root(const Model *m, const Configuration *old, const Configuration *new_, double h,
                        const int64_t *revolute, double *distance)
{
    return far_root(m, old, new_, h, revolute, distance);
}

/* Whether cable element e, at the gap `gap` (min(N_el, N)), lies beyond its tolerance (Model cable_tolerance) on the
 * other side of zero from the side the step held it on (Model cable_side): the step crossed the element's change
 * between slack and taut and is shortened to land on it (latdyn/timeloop/events.py cable_crossings). */
static int cable_crossed(const Model *m, int64_t e, double gap)
{
    const double side = m->cable_side[e], tolerance = m->cable_tolerance[e];
    return (side > 0.0 && gap < -tolerance) || (side < 0.0 && gap > tolerance);
}

/* Whether the step's last evaluation has a cable element that crossed its change (cable_crossed). */
static int cable_event(const Model *m, const Work *w)
{
    for (int64_t e = 0; e < m->n_cables; ++e)
        if (cable_crossed(m, e, w->cable_gap[e])) return 1;
    return 0;
}

/* cable_crossed of every cable element at the gaps `gap` (ce) into crossed (ce, 1 or 0), for the steps accepted
 * from Python (latdyn/timeloop/events.py cable_crossings); the number crossed. */
int64_t latdyn_cable_crossed(const Model *m, const double *gap, int64_t *crossed)
{
    int64_t count = 0;
    for (int64_t e = 0; e < m->n_cables; ++e) count += crossed[e] = cable_crossed(m, e, gap[e]);
    return count;
}

/* The entry of `reaction` (an evaluation's on the constrained coordinates, reaction[d − n_dofs] that of coordinate d)
 * on coordinate d where d is constrained (n_dofs ≤ d < n_total), else 0. */
static double constrained_entry(const Model *m, const double *reaction, int64_t d)
{
    return d >= m->n_dofs && d < m->n_total ? reaction[d - m->n_dofs] : 0.0;
}

/* The reactions of the prescribed motions by prescribed coordinate (docs/energy.md, "The work of a prescribed
 * motion"): from `reaction` (an evaluation's, on the constrained coordinates n_dofs … n_total−1: Work's total +
 * n_dofs) the 6 of each prescribed body's node, in the model's order of nodes, then one per hinge or guide (0 unless
 * its angle or slide is prescribed), into force (6 n_prescribed + n_hinges). A layout the numbering's changes at
 * events (a latch, a stick) leave alone, so that the reactions at a step's start and end pair up (drive_work). */
static void drive_forces(const Model *m, const double *reaction, double *force)
{
    for (int64_t k = 0; k < m->n_prescribed; ++k) {
        const int64_t *d = m->node_dofs + 6 * m->prescribed_nodes[k];
        for (int j = 0; j < 6; ++j) force[6 * k + j] = constrained_entry(m, reaction, d[j]);
    }
    for (int64_t j = 0; j < m->n_hinges; ++j)
        force[6 * m->n_prescribed + j] = m->hinge_angle_law[j] >= 0 ? constrained_entry(m, reaction, m->hinge_dofs[j]) : 0.0;
}

/* drive_forces for Python (latdyn/timeloop/progress.py drive_forces). */
void latdyn_drive_forces(const Model *m, const double *reaction, double *force)
{
    drive_forces(m, reaction, force);
}

/* `work` with the work of the prescribed motions over the step old → new added (docs/energy.md, "The work of a
 * prescribed motion"): ½(r_n + r_{n+1}) Δq over each prescribed coordinate in drive_forces' order, r_n, r_{n+1}
 * its reactions at the step's two ends (force_old, force_new) and Δq the coordinate's change, Δx of a prescribed
 * body's point, the spatial rotation vector of T_{n+1} T_nᵀ (the generated so3_log_increment) and Δθ (Δs) of a
 * prescribed hinge (guide). The trapezoidal rule in q as hinge_work's in θ: the work the discrete step received,
 * where the time trapezoid ½h(r_n·q̇_n + r_{n+1}·q̇_{n+1}) of the power is not (a crank brought to 2 rad/s in one
 * step, carrying a free rod, counted 0.014 J of the 1.17 J the rod received, and the run ended `unbounded`). */
static double drive_work(const Model *m, const Configuration *old, const Configuration *new_, const double *force_old,
                         const double *force_new, double work)
{
    const int64_t P = m->n_prescribed;
    for (int64_t k = 0; k < P; ++k) {
        const int64_t i = m->prescribed_nodes[k];
        double increment[6];
        for (int j = 0; j < 3; ++j) increment[j] = new_->x[3 * i + j] - old->x[3 * i + j];
        m->so3_log_increment(1, old->T + 9 * i, new_->T + 9 * i, increment + 3);
        for (int j = 0; j < 6; ++j) work += 0.5 * (force_old[6 * k + j] + force_new[6 * k + j]) * increment[j];
    }
    for (int64_t j = 0; j < m->n_hinges; ++j)
        work += 0.5 * (force_old[6 * P + j] + force_new[6 * P + j]) * (new_->theta[j] - old->theta[j]);
    return work;
}

/* increment_size for Python (latdyn/step/integrators.py increment_size). */
double latdyn_increment_size(const Model *m, const double *dx, double length)
{
    return increment_size(m, dx, length);
}

/* drive_work for Python (latdyn/timeloop/progress.py drive_work). */
double latdyn_drive_work(const Model *m, const Configuration *old, const Configuration *new_, const double *force_old,
                         const double *force_new, double work)
{
    return drive_work(m, old, new_, force_old, force_new, work);
}

/* A loop of steps on the time grid (timeloop.loop's TimeLoop, for the steps it would accept as
 * they come). */
typedef struct {
    /* in: the grid t_k = k dt (t_{n_grid} = t_end), the steps to take (grid_index → stop_index),
     * the start time, and the wall time after which the loop returns (≤ 0: none) */
    double dt, t_end;
    int64_t n_grid, grid_index, stop_index;
    double t, budget_s;
    /* in/out: the power of the point loads at the last accepted state, and the work done since the
     * start of the run (theirs by the trapezoidal rule in time, the hinges' by hinge_work, the
     * prescribed motions' by drive_work) */
    double power, external_work;
    /* out: steps accepted, their Newton iterations and factorizations; why the loop returned
     * (0 at stop_index, 1 a step did not converge, 2 a step holds an event, 3 the budget, 4 a sample
     * whose restart the caller takes: the accepted state that sampled is the last);
     * the last accepted state's time (the state itself is copied to `last`); with status 1 or
     * 2, the scratch configuration that holds the step not accepted (its counters stay in the
     * StepControl) and that step's size */
    int64_t steps, iterations, factorizations, status, last, pending;
    double t_last, h_pending;
    /* in/out: the energy dissipated since the start of the run (the hinges' by hinge_work, the
     * cables' by cable_work) */
    double dissipated;
    /* in/out (n_hinges each): each hinge's torque that does external work and its damper's torque
     * at the last accepted state (Work.hinge_work_torque, hinge_damper_torque) */
    double *hinge_work_torque, *hinge_damper_torque;
    /* in/out: the rows to record on the way (rows.c; NULL: none, the caller records the row at stop_index) */
    Rows *rows;
    /* in/out (n_cables, 4): each cable element's [ℓ, L0, ∂U/∂L0, f] at the last accepted state
     * (Work.cable_work) */
    double *cable_work;
    /* in: the sampled controllers sampled in the loop (sampling.c) at each accepted step's end within
     * this tolerance of an instant (0: not, the caller stops the loop on the instants), and whether the
     * restart after a sample is taken here too (restart_after_sample), else the loop returns after the
     * sample (status 4) for the caller to restart; out: the samples taken */
    double sample_tolerance;
    int64_t native_restart, samples;
    /* in/out (n_hinges, 6; NULL: not kept): per hinge the largest h |θ̇_{n+1} − θ̇_n| of an accepted step,
     * with that step's end time and size h, then the first past unresolved_turn, its time and size
     * (rate_turns) */
    double *rate_turns;
    double unresolved_turn;
    /* in/out: the transient sensitivities carried through each accepted step (sensitivity_loop.c; NULL: none);
     * status 5: S was singular at the last accepted step (its sensitivities not carried on) */
    SensitivityLoop *sensitivities;
    /* in/out: the discrete adjoint's forward pass, each accepted step stored (adjoint_trajectory.c; NULL: none) */
    Trajectory *trajectory;
    /* in/out (6 n_prescribed + n_hinges): the reactions of the prescribed motions at the last accepted
     * state, by prescribed coordinate (drive_forces) */
    double *drive_force;
} Advance;

/* The angle by which a free hinge's rate change over the accepted step old → new turns it over the step,
 * h |θ̇_{n+1} − θ̇_n| (≈ h² |θ̈|, the size of the step's quadratic term: a step that does not resolve the
 * hinge's motion turns it by a sizeable fraction of a radian so; docs/energy.md, "Steps that do not resolve a
 * hinge"), kept per hinge in kept (n_hinges, 6): the largest as [turn, t, h], and the first past unresolved_turn
 * as [turn, t, h] after it; t the step's end. Prescribed hinges have no coordinate and are not counted. */
static void rate_turns(const Model *m, const Configuration *old, const Configuration *new_, double t, double h,
                       double unresolved_turn, double *kept_turns)
{
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        const double turn = h * fabs(new_->theta_dot[j] - old->theta_dot[j]);
        double *kept = kept_turns + 6 * j;
        if (turn > kept[0]) {
            kept[0] = turn;
            kept[1] = t;
            kept[2] = h;
        }
        if (turn > unresolved_turn && kept[3] == 0.0) {
            kept[3] = turn;
            kept[4] = t;
            kept[5] = h;
        }
    }
}

/* rate_turns for the steps accepted from Python (latdyn/timeloop/progress.py TransientProgress.note_rate_turns). */
void latdyn_rate_turns(const Model *m, const Configuration *old, const Configuration *new_, double t, double h,
                       double unresolved_turn, double *kept)
{
    rate_turns(m, old, new_, t, h, unresolved_turn, kept);
}

/* The work of the prescribed motions over the accepted step old → new (drive_work) into the external work, from the
 * reactions carried in adv->drive_force and those of the new state (the last evaluation's in Work), which are
 * carried to the next step. */
static void accept_drive_work(const Model *m, const Work *w, const Configuration *old, const Configuration *new_,
                              Advance *adv)
{
    const int64_t size = 6 * m->n_prescribed + m->n_hinges;
    if (size == 0) return;
    double force_new[size];
    drive_forces(m, w->total + m->n_dofs, force_new);
    adv->external_work = drive_work(m, old, new_, adv->drive_force, force_new, adv->external_work);
    memcpy(adv->drive_force, force_new, sizeof(double) * (size_t)size);
}

/* The work of the hinges' torques over a step from the angles theta_old to theta_new (docs/energy.md): ∑ ½(τ_n +
 * τ_{n+1}) Δθ of each torque that does external work (work_old, work_new: Work.hinge_work_torque at the step's two
 * ends) into *external_work, and ∑ ½(f_n + f_{n+1}) Δθ of the dissipative torques f (the dampers' c θ̇, a compliant
 * stop's damping, friction: Work.hinge_damper_torque; damper_old, damper_new), their dissipation, into
 * *dissipated, hinge by hinge. The trapezoidal rule in θ, not in time: the work ∫ τ dθ the discrete step received
 * whatever the integrator's Δθ is (with generalized-α, Δθ ≠ h (θ̇_n + θ̇_{n+1})/2, and the trapezoid of the power
 * τ θ̇ in time is not that work); for Newmark's average acceleration and a linear hinge it closes the balance to
 * round-off. */
static void hinge_work(int64_t n_hinges, const double *theta_old, const double *theta_new, const double *work_old,
                       const double *damper_old, const double *work_new, const double *damper_new,
                       double *external_work, double *dissipated)
{
    for (int64_t j = 0; j < n_hinges; ++j) {
        const double increment = theta_new[j] - theta_old[j];
        *external_work += 0.5 * (work_old[j] + work_new[j]) * increment;
        *dissipated += 0.5 * (damper_old[j] + damper_new[j]) * increment;
    }
}

/* hinge_work for the steps accepted from Python (latdyn/timeloop/progress.py hinge_work). */
void latdyn_hinge_work(int64_t n_hinges, const double *theta_old, const double *theta_new, const double *work_old,
                       const double *damper_old, const double *work_new, const double *damper_new,
                       double *external_work, double *dissipated)
{
    hinge_work(n_hinges, theta_old, theta_new, work_old, damper_old, work_new, damper_new, external_work, dissipated);
}

/* The work of the cable elements over a step from [ℓ, L0, ∂U/∂L0, f] of each element at its start (old) to its end
 * (new_), (n_cables, 4) each (Work.cable_work): of the rest length's generalized force r = ∂U/∂L0 over ΔL0,
 * ½(r_n + r_{n+1}) ΔL0 (a reel's work, external: U the strain energy) into *external_work, and of each damper's
 * dissipative force f (c ℓ̇ taut, −N_el while the damper cancels the elastic tension, 0 slack) over Δℓ,
 * ½(f_n + f_{n+1}) Δℓ, into *dissipated, element by element. The trapezoidal rule in L0 and ℓ as hinge_work's in
 * θ: the work the discrete step received, which the time trapezoid of the powers r L̇0 and f ℓ̇ is not
 * (docs/cables.md measures the two). */
static void cable_work(int64_t n_cables, const double *old, const double *new_, double *external_work,
                       double *dissipated)
{
    for (int64_t e = 0; e < n_cables; ++e) {
        const double *a = old + 4 * e, *b = new_ + 4 * e;
        *external_work += 0.5 * (a[2] + b[2]) * (b[1] - a[1]);
        *dissipated += 0.5 * (a[3] + b[3]) * (b[0] - a[0]);
    }
}

/* cable_work for the steps accepted from Python (latdyn/timeloop/progress.py cable_work). */
void latdyn_cable_work(int64_t n_cables, const double *old, const double *new_, double *external_work,
                       double *dissipated)
{
    cable_work(n_cables, old, new_, external_work, dissipated);
}

/* The hinges' and the cables' work and dissipation over the accepted step old → new into the loop's sums, from the
 * torques and the cables' values carried in adv and those of the new state (the last evaluation's in Work), which
 * are carried to the next step. */
static void accept_joint_work(const Model *m, const Work *w, const Configuration *old, const Configuration *new_,
                              Advance *adv)
{
    hinge_work(m->n_hinges, old->theta, new_->theta, adv->hinge_work_torque, adv->hinge_damper_torque,
               w->hinge_work_torque, w->hinge_damper_torque, &adv->external_work, &adv->dissipated);
    if (m->n_hinges) {
        memcpy(adv->hinge_work_torque, w->hinge_work_torque, sizeof(double) * (size_t)m->n_hinges);
        memcpy(adv->hinge_damper_torque, w->hinge_damper_torque, sizeof(double) * (size_t)m->n_hinges);
    }
}

/* The cables' work and dissipation over the accepted step (cable_work) into the loop's sums, their values at the new
 * state carried to the next step. */
static void accept_cable_work(const Model *m, const Work *w, Advance *adv)
{
    cable_work(m->n_cables, adv->cable_work, w->cable_work, &adv->external_work, &adv->dissipated);
    if (m->n_cables) memcpy(adv->cable_work, w->cable_work, sizeof(double) * 4 * (size_t)m->n_cables);
}

static double seconds_now(void)
{
    struct timespec now;
    clock_gettime(CLOCK_MONOTONIC, &now);
    return (double)now.tv_sec + 1e-9 * (double)now.tv_nsec;
}

#include "sampling.c" /* the sampled controllers' sample and the restart after it */

/* Steps from `start` (at adv->t, on grid point grid_index) through grid point stop_index,
 * each landing on the grid (h = t_{k+1} − t_k) as timeloop.loop takes them at the nominal
 * step: latdyn_newton_step with the compiled laws, then acceptance (the algorithmic
 * acceleration carried, the external work of point loads by the trapezoidal rule in time, the
 * prescribed motions' by drive_work, the hinges' work and dissipation by hinge_work, the cables' by cable_work). It
 * returns at the first
 * step that does not converge or that holds a hinge event, without accepting it, so that the
 * caller's loop handles that step as it always has; it never fails by itself. States alternate
 * between the two scratch configurations; `start` is read only; the last accepted state is
 * copied to `last` (when a step was accepted). */
int64_t latdyn_advance(const Model *m, Work *w, StepControl *s, const Configuration *start,
                       Configuration *scratch, Configuration *last, StepVectors *x, Advance *adv)
{
    const int64_t n = m->n_dofs;
    const double started = adv->budget_s > 0.0 ? seconds_now() : 0.0;
    const Configuration *base = start;
    double t = adv->t;
    adv->steps = adv->iterations = adv->factorizations = adv->samples = 0;
    adv->last = -1;
    adv->pending = -1;
    adv->status = 0;
    for (int64_t k = adv->grid_index; k < adv->stop_index; ++k) {
        const double target = k + 1 >= adv->n_grid ? adv->t_end : (double)(k + 1) * adv->dt;
        const int next = adv->last == 0 ? 1 : 0;
        Configuration *trial = scratch + next;
        s->h = target - t;
        s->t_new = target;
        int64_t failed = latdyn_newton_step(m, w, s, base, trial, x);
        if (failed || !s->converged) {
            adv->status = 1;
        } else if ((m->has_events && (hinge_event(m, base, trial, t) || cable_event(m, w)
                                    || (adv->sensitivities && adv->sensitivities->cables && cable_near_change(m, w)))) || far_root(m, base, trial, s->h, NULL, NULL) >= 0) {
            adv->status = 2;   /* an event, or a root a whole turn away (far_root): the caller takes the step */
        }
        if (adv->status) {
            adv->pending = next;
            adv->h_pending = s->h;
            break;
        }
        /* accepted: GeneralizedAlpha.accept, and the work of loads and prescribed motions (a_n kept for the
         * sensitivities' step, which reads a_n and a_{n+1}) */
        if (adv->sensitivities || adv->trajectory) memcpy(x->dx, x->a_n, sizeof(double) * (size_t)n);
        memcpy(x->a_n, x->a_new, sizeof(double) * (size_t)n);
        adv->external_work += 0.5 * s->h * (adv->power + s->power);
        adv->power = s->power;
        accept_drive_work(m, w, base, trial, adv);
        accept_joint_work(m, w, base, trial, adv);
        if (adv->rate_turns) rate_turns(m, base, trial, target, s->h, adv->unresolved_turn, adv->rate_turns);
        latdyn_controller_states_accept(m, w, trial, target, s->h);  /* continuous controllers' states */
        accept_cable_work(m, w, adv);
        adv->steps += 1;
        if (adv->trajectory) store_accepted_step(m, adv->trajectory, trial, target, s->h, x->dx, x->a_n);
        /* the sensitivities' step after the accepted step's accounts (its evaluation at the converged state
         * replaces the last Newton evaluation's in Work, as the Python step's does) */
        if (adv->sensitivities && sensitivity_loop_step(m, w, adv->sensitivities, &s->alpha_m, trial, target, s->h,
                                                        k + 1, x->v_n, x->dx, x->a_n) != 0) {
            adv->iterations += s->iterations;
            adv->factorizations += s->factorizations;
            adv->status = 5;
            adv->last = next;
            base = trial;
            t = target;
            break;
        }
        adv->iterations += s->iterations;
        adv->factorizations += s->factorizations;
        /* a sample instant: the sample and its work (the change of the stored energy the new held outputs
         * make at the fixed configuration: sampling.c stored_energy), then the restart here (or, status 4,
         * by the caller before the row) */
        if (adv->sample_tolerance > 0.0 && m->n_sampled && any_sample_due(m, target, adv->sample_tolerance)) {
            const double stored = stored_energy(m, w, trial, target);
            latdyn_sample_controllers(m, w, trial, target, adv->sample_tolerance);
            adv->external_work += stored_energy(m, w, trial, target) - stored;
            adv->samples += 1;
            if (!adv->native_restart || restart_after_sample(m, w, trial, target, x->a_n, adv)) {
                adv->status = 4;
                adv->last = next;
                base = trial;
                t = target;
                break;
            }
        }
        Rows *rows = adv->rows;
        if (rows && rows->recorded < rows->planned && k + 1 == rows->grid_point[rows->recorded]) {
            const double counters[5] = {(double)adv->steps, (double)adv->iterations, (double)adv->factorizations,
                                        adv->external_work, adv->dissipated};
            record_row(m, w, rows, trial, target, counters);
            if (adv->sensitivities) sensitivity_loop_row(m, adv->sensitivities, rows->recorded - 1);
        }
        adv->last = next;
        base = trial;
        t = target;
        if (adv->budget_s > 0.0 && seconds_now() - started > adv->budget_s && k + 1 < adv->stop_index) {
            adv->status = 3;
            break;
        }
    }
    adv->t_last = t;
    if (adv->steps) copy_configuration(m, base, last);
    return adv->status;
}


/* Threads an evaluation above the threshold would use: 0 when compiled without OpenMP. */
int64_t latdyn_threads(void)
{
#ifdef _OPENMP
    return omp_get_max_threads();
#else
    return 0;
#endif
}

/* ------------------------------------------------------------------------- the static mode */

/* Settings and results of the static Newton iteration (latdyn/analyses/continuation.py): the residual
 * r(q, λ) = f_int(q) − λ q_ref(q) at t = 0 without inertia, its tangent K = ∂r/∂q (the iteration matrix
 * of the time step with β′ = γ′ = 0) assembled, factorized and solved by the same code as the step's. */
typedef struct {
    /* in */
    double load_factor, tol, length;
    int64_t max_iterations;
    int64_t reference;         /* latdyn_static_iteration: also q_ref = r(q, λ) − r(q, λ + 1) and K⁻¹ q_ref */
    /* out */
    int64_t iterations, converged;
    int64_t status;            /* 0; 1 K singular (the factorization failed); 2 a solution not finite */
    double size;               /* increment_size of the last Newton increment K⁻¹(−r) */
    /* in: where latdyn_static_iteration copies the matrix storage (factorization->size doubles) before
     * factorizing it, K as assembled (NULL: not copied) */
    double *matrix_copy;
} StaticControl;

/* One static iteration at c (its dependent nodes of rigid links completed first, in place: the reduction
 * takes the links' Jacobian from that completion): into out (6 n_dofs doubles)
 * r, then with s->reference q_ref, then δq_r = −K⁻¹ r and δq_λ = K⁻¹ q_ref (Batoz & Dhatt 1979), the
 * last 2 n_dofs scratch; w->total and the matrix blocks hold the evaluation at λ (reduced with rigid
 * links), the matrix storage the factors of K. s->size is increment_size(δq_r). Returns s->status. */
int64_t latdyn_static_iteration(const Model *m, Work *w, StaticControl *s, Configuration *c, double *out)
{
    const int64_t n = m->n_dofs;
    const int64_t *permutation = m->factorization->permutation;
    double *r = out, *q_ref = out + n, *dq_r = out + 2 * n, *dq_l = out + 3 * n, *x = out + 4 * n;
    const int64_t n_rhs = s->reference ? 2 : 1;
    m->time_laws(0.0, w->laws);
    s->status = 0;
    if (m->links) complete_links(m, c);
    if (s->reference) { /* r(q, λ + 1) first: the evaluation left in w is that at λ */
        evaluate(m, c, w, w->laws, 0.0, 0, 0, s->load_factor + 1.0);
        if (m->links) reduce_links(m, w, c, 0.0, 0.0, 0, 0);
        memcpy(q_ref, w->total, sizeof(double) * (size_t)n);
    }
    evaluate(m, c, w, w->laws, 0.0, 1, 0, s->load_factor);
    if (m->links) reduce_links(m, w, c, 0.0, 0.0, 1, 0);
    else assemble(m, w, 0.0, 0.0, 0);
    memcpy(r, w->total, sizeof(double) * (size_t)n);
    if (s->reference)
        for (int64_t i = 0; i < n; ++i) q_ref[i] = r[i] - q_ref[i];
    if (n == 0) return 0;
    if (s->matrix_copy) memcpy(s->matrix_copy, w->matrix, sizeof(double) * (size_t)m->factorization->size);
    if (latdyn_factor(m->factorization, w->matrix, w->pivots) != 0) return s->status = 1;
    for (int64_t i = 0; i < n; ++i) {
        x[permutation[i]] = -r[i];
        if (s->reference) x[n + permutation[i]] = q_ref[i];
    }
    if (latdyn_solve(m->factorization, w->matrix, w->pivots, n_rhs, x) != 0) return s->status = 1;
    for (int64_t i = 0; i < n; ++i) {
        dq_r[i] = x[permutation[i]];
        dq_l[i] = s->reference ? x[n + permutation[i]] : 0.0;
        if (!isfinite(dq_r[i]) || !isfinite(dq_l[i])) s->status = 2;
    }
    s->size = increment_size(m, dq_r, s->length);
    return s->status;
}

/* Newton at the fixed load factor s->load_factor from c, in place (load control): per iteration
 * latdyn_static_iteration, then q ← q ∘ exp(δq_r) (latdyn_advance_free, the dependent nodes of rigid
 * links completed), converged when increment_size(δq_r) ≤ tol, the time step's test. On return out[0:n]
 * holds the residual of the last evaluation (before its increment). Returns s->status. */
int64_t latdyn_static_newton(const Model *m, Work *w, StaticControl *s, Configuration *c, double *out)
{
    const int64_t n = m->n_dofs;
    s->iterations = s->converged = 0;
    s->reference = 0;
    for (int64_t iteration = 1; iteration <= s->max_iterations; ++iteration) {
        if (latdyn_static_iteration(m, w, s, c, out) != 0) return s->status;
        if (n == 0) {
            s->converged = 1;
            return 0;
        }
        latdyn_advance_free(m, c, out + 2 * n);
        if (m->links) complete_links(m, c);  /* the state handed back complete */
        s->iterations = iteration;
        if (s->size <= s->tol) {
            s->converged = 1;
            return 0;
        }
    }
    return 0;
}

