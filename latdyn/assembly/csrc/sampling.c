/*
 * The sampled controllers' cycle (SCENE.md controllers.NAME.rate; latdyn/timeloop/sampling.py), in C:
 * the sample at an accepted state and the restart of the accelerations after it, which the loop of
 * steps (newton_step.c latdyn_advance) takes on every sample instant without returning to Python, and
 * which the time loop calls for a state it accepted itself (latdyn_sample_controllers).
 *
 * Runtime code: the controllers' laws are generated (codegen/laws.py latdyn_sampled_laws, compiled with
 * the scene's other laws), their sensors are the probe evaluation of the continuous controllers
 * (evaluate.c sensor_value), the restart's mass matrix is the evaluation's blocks in the iteration
 * matrix's storage (reduced onto the minimum coordinates with rigid links and guides, links.c),
 * factorized and solved by factorization.c.
 */

/* Whether t is a sample instant j / rate (within `tolerance`); the instant itself in *instant. */
static int sample_due(double t, double rate, double tolerance, double *instant)
{
    *instant = round(t * rate) / rate;
    return fabs(*instant - t) <= tolerance;
}

/* Whether t is a sample instant of any sampled controller (within `tolerance`). */
static int any_sample_due(const Model *m, double t, double tolerance)
{
    double instant;
    for (int64_t k = 0; k < m->n_sampled; ++k)
        if (sample_due(t, m->sampled_rate[k], tolerance, &instant)) return 1;
    return 0;
}

/* The strain and gravity potential energy at c under the laws as they are now (latdyn_energies): a
 * sample that moves a law a stored energy depends on (a cable's rest length, a hinge spring's stiffness)
 * changes it at the fixed configuration, and that change is the work the sample did on the structure
 * (latdyn/timeloop/loop.py TimeLoop._add_jump_work, docs/energy.md "Jumps of the laws"). */
static double stored_energy(const Model *m, Work *w, const Configuration *c, double t)
{
    double energies[3];
    latdyn_energies(m, w, c, t, energies);
    return energies[1] + energies[2];
}

/* The sample at the accepted state c, time t: every sampled controller whose instant t is (within
 * `tolerance`), in file order,
 *     y_k = clip(output(t_k, s, S_k)),   S_{k+1} = S_k + EXPR(t_k, s, S_k) / rate,
 * y_k held in m->controller_outputs (the zero-order hold: the laws that name the controller read it
 * there until the next sample), S in m->controller_states. The sensors s at c; the continuous
 * controllers' outputs evaluated at c first (latdyn_controller_outputs_at), so that a sampled controller
 * reads them there, and an earlier sampled controller's new value. Returns how many sampled. */
int64_t latdyn_sample_controllers(const Model *m, Work *w, const Configuration *c, double t, double tolerance)
{
    int64_t sampled = 0;
    for (int64_t k = 0; k < m->n_sampled; ++k) {
        const double rate = m->sampled_rate[k];
        double instant;
        if (!sample_due(t, rate, tolerance, &instant)) continue;
        if (sampled == 0) latdyn_controller_outputs_at(m, w, c, t);
        const int64_t first = m->sampled_sensor_start[k], count = m->sampled_sensor_start[k + 1] - first;
        const int64_t states = m->sampled_state_start[k], p = m->sampled_state_start[k + 1] - states;
        double *args = w->sampled_arguments, *out = w->sampled_out;
        for (int64_t i = 0; i < count; ++i) {
            const int64_t sensor = first + i, kind = m->sensor_kind[sensor];
            args[i] = kind == 4 ? m->controller_outputs[m->sensor_index[sensor]]
                    : kind == 9 ? w->sampled_values[sensor]
                    : kind == 10 ? m->controller_states[m->sensor_index[sensor]]
                    : sensor_value(m, c, w, sensor, t);
        }
        for (int64_t j = 0; j < p; ++j) args[count + j] = m->controller_states[m->sampled_state_slot[states + j]];
        m->sampled_laws(k, instant, args, out);
        const double y = out[0], lo = m->sampled_limits[2 * k], hi = m->sampled_limits[2 * k + 1];
        m->controller_outputs[m->sampled_slot[k]] = y < lo ? lo : (y > hi ? hi : y);
        for (int64_t j = 0; j < p; ++j)
            m->controller_states[m->sampled_state_slot[states + j]] = args[count + j] + out[1 + j] / rate;
        sampled += 1;
    }
    return sampled;
}

/* sample_restart: the accelerations of the restart after a sample at the accepted state c, time t (restart_after_sample
 * below, and the steps from Python), for a model whose every direction has
 * inertia (the caller knows: latdyn/step/compiled.py restarts_natively): the held outputs jumped, and the
 * accelerations go on from those consistent with the equations of motion under the new ones, as
 * GeneralizedAlpha.start makes them (latdyn/step/integrators.py consistent_acceleration, whose split is
 * then all massive): r is affine in v̇ with slope M, so
 *     v̇ ← v̇ − M⁻¹ r(q, v, v̇),
 * M the evaluation's mass blocks scattered into the iteration matrix's storage (Work restart_matrix,
 * apart from the matrix that holds modified Newton's factorization), factorized and solved with
 * factorization.c; into c and as the algorithmic acceleration a_n. With rigid links and guides the same on
 * the minimum coordinates: the dependent nodes' accelerations P v̇ + c(q, v) (complete_links), so the
 * reduced residual Pᵀ r is affine in the minimum v̇ with slope Pᵀ M P (links.c assemble_linked_mass),
 * the dependent nodes completed again with the new v̇. restart_after_sample then takes the continuous controllers'
 * state rates at c (latdyn_controller_states_accept with h = 0, as the start takes them) and, from an
 * evaluation at the restarted state, the power of the point loads, the prescribed motions' reactions, the hinges'
 * work and damper torques and the cables' accounts that start the next step (the time loop's
 * _torques_from). Each returns 0, or the factorization's failure (the caller then restarts from Python). */
static int64_t sample_restart(const Model *m, Work *w, Configuration *c, double t, double *a_n)
{
    const int64_t n = m->n_dofs;
    const Factorization *f = m->factorization;
    double *M = w->restart_matrix, *vdot = w->rhs;
    m->time_laws(t, w->laws);
    if (m->links) complete_links(m, c);
    evaluate(m, c, w, w->laws, t, 1, 1, 1.0);
    if (m->links) {
        reduce_links(m, w, c, 0.0, 0.0, 0, 0); /* Pᵀ r into w->total; w->matrix (the held factors) untouched */
        assemble_linked_mass(m, w, M);
    } else {
        memset(M, 0, sizeof(double) * (size_t)f->size);
        for (int64_t e = 0; e < m->n_elements; ++e)
            for (int p = 0; p < 196; ++p)
                if (m->element_position[196 * e + p] >= 0) M[m->element_position[196 * e + p]] += w->mass[196 * e + p];
        for (int64_t b = 0; b < m->n_bodies; ++b)
            for (int p = 0; p < 36; ++p)
                if (m->body_position[36 * b + p] >= 0) M[m->body_position[36 * b + p]] += w->body_mass[36 * b + p];
    }
    int64_t failed = latdyn_factor(f, M, w->restart_pivots);
    if (failed) return failed;
    for (int64_t i = 0; i < n; ++i) vdot[f->permutation[i]] = -w->total[i];
    latdyn_solve(f, M, w->restart_pivots, 1, vdot);
    double *correction = w->total;  /* −M⁻¹ r in the coordinates' order (the residual is spent) */
    for (int64_t i = 0; i < n; ++i) correction[i] = vdot[f->permutation[i]];
    free_rates(m, c, w->rhs, a_n);  /* v̇ of c into a_n (its rates into the spent rhs) */
    for (int64_t i = 0; i < n; ++i) a_n[i] += correction[i];
    for (int64_t k = 0; k < m->n_free_nodes; ++k) {
        const int64_t i = m->free_nodes[k], *d = m->node_dofs + 6 * i;
        for (int j = 0; j < 6; ++j) {
            if (d[j] >= n) continue;  /* not a coordinate (planar model) */
            if (j < 3) c->a[3 * i + j] = a_n[d[j]];
            else c->alpha[3 * i + j - 3] = a_n[d[j]];
        }
    }
    for (int64_t k = 0; k < m->n_free_hinges; ++k) {
        const int64_t j = m->free_hinges[k];
        c->theta_ddot[j] = a_n[m->hinge_dofs[j]];
    }
    if (m->links) complete_links(m, c);  /* the dependent nodes' accelerations from the new v̇ */
    return 0;
}

/* sample_restart for the steps from Python (latdyn/timeloop/loop.py _restart_after_sample, where the
 * integrator restarts_natively): the one restart after a sample, in the loop of steps and out of it. */
int64_t latdyn_sample_restart(const Model *m, Work *w, Configuration *c, double t, double *a_n)
{
    return sample_restart(m, w, c, t, a_n);
}

static int64_t restart_after_sample(const Model *m, Work *w, Configuration *c, double t, double *a_n, Advance *adv)
{
    const int64_t failed = sample_restart(m, w, c, t, a_n);
    if (failed) return failed;
    latdyn_controller_states_accept(m, w, c, t, 0.0);
    m->time_laws(t, w->laws);
    const double power = evaluate(m, c, w, w->laws, t, 0, 1, 1.0);
    if (m->links) reduce_links(m, w, c, 0.0, 0.0, 0, 0);  /* the constrained coordinates' reactions */
    adv->power = power;
    drive_forces(m, w->total + m->n_dofs, adv->drive_force);
    for (int64_t j = 0; j < m->n_hinges; ++j) {
        adv->hinge_work_torque[j] = w->hinge_work_torque[j];
        adv->hinge_damper_torque[j] = w->hinge_damper_torque[j];
    }
    if (m->n_cables) memcpy(adv->cable_work, w->cable_work, sizeof(double) * 4 * (size_t)m->n_cables);
    return 0;
}
