/*
 * The discrete adjoint's forward pass inside the loop of steps (latdyn_advance, newton_step.c): after each accepted
 * step, what the reverse pass reads of it (latdyn/analyses/adjoint_sensitivities.py AdjointSensitivities.step):
 * the end state, in the layout of the compiled step's states (latdyn.step.compiled), its time, the step's size
 * and the algorithmic accelerations before and after it. latdyn/analyses/adjoint_in_loop.py lays the blocks out
 * and turns them into the trajectory's entries when the loop returns.
 *
 * Runtime code, written by hand: it holds no physics (copies only).
 */

/* The blocks one loop of steps stores the accepted steps in (latdyn.analyses.adjoint_in_loop). */
typedef struct {
    int64_t capacity;           /* steps the blocks hold (the loop's steps: stop_index − grid_index) */
    int64_t state_size;         /* doubles of one state */
    const int64_t *offsets;     /* 9: x, T, v, w, a, alpha, theta, theta_dot, theta_ddot within a state */
    double *states;             /* capacity × state_size */
    double *times, *sizes;      /* capacity each: the step's end time and its size h */
    double *a_old, *a_new;      /* capacity × n_dofs: the algorithmic accelerations before and after it */
    int64_t stored;             /* out: steps stored */
} Trajectory;

/* The accepted step of size h ending at c at time t (a_old, a_new: its algorithmic accelerations before and
 * after it) stored in the next block; nothing past the capacity (the caller sizes it to the loop's steps). */
static void store_accepted_step(const Model *m, Trajectory *tr, const Configuration *c, double t, double h,
                                const double *a_old, const double *a_new)
{
    if (tr->stored >= tr->capacity) return;
    const int64_t i = tr->stored, n = m->n_dofs, *o = tr->offsets;
    double *at = tr->states + i * tr->state_size;
    Configuration to = {at + o[0], at + o[1], at + o[2], at + o[3], at + o[4], at + o[5], at + o[6], at + o[7],
                        at + o[8]};
    copy_configuration(m, c, &to);
    tr->times[i] = t;
    tr->sizes[i] = h;
    memcpy(tr->a_old + i * n, a_old, sizeof(double) * (size_t)n);
    memcpy(tr->a_new + i * n, a_new, sizeof(double) * (size_t)n);
    tr->stored = i + 1;
}
