/*
 * The continuous controllers' states carried through the transient sensitivities' step (latdyn/analyses/
 * sensitivities.py ControllerStates), the one C function for the step's p × p algebra of one controller with p
 * states: the per-step Python path calls it (ControllerStates.begin_step, after_step), and the loop of steps is to
 * call it likewise (issue 34, item 2). The step integrates dS/dt = f(t, s, S; p) by the trapezoidal rule condensed
 * into the output, S_{n+1} = S_n + h/2 (f_n + f_{n+1}); with A = I − h/2 ∂f/∂S at the step's end,
 *   held     = A⁻¹ (δS_n + h/2 (δf_n + ∂f/∂p))               (the configuration held),
 *   by_h     = A⁻¹ ½ (f_n + f_{n+1})                          (the states' derivative by the step's size),
 *   δS_{n+1} = held + A⁻¹ (h/2 ∂f/∂s δs_{n+1}) + by_h δh,
 *   δf_{n+1} = ∂f/∂s δs_{n+1} + ∂f/∂S δS_{n+1} + ∂f/∂p.
 *
 * Runtime code, written by hand: the rule's derivative as linear algebra; ∂f/∂s, ∂f/∂S and ∂f/∂p are the compiled
 * laws' (the step's controller law, derivative_laws.ControllerPartials), no physics is written here. A is factorised
 * by Gaussian elimination with partial pivoting (the first largest |pivot| of its column), every sum in index order.
 */

/* A = I − hh ∂f/∂S (p × p, row-major) into `factor`, factorised in place (L below the diagonal, unit; U on and
 * above), rows swapped as `pivots` says. Returns 0, or 1 + the column whose pivot is zero (A singular). */
static int64_t controller_states_factor(int64_t p, double hh, const double *f_S, double *factor, int64_t *pivots)
{
    for (int64_t i = 0; i < p; ++i)
        for (int64_t j = 0; j < p; ++j) factor[i * p + j] = (i == j ? 1.0 : 0.0) - hh * f_S[i * p + j];
    for (int64_t col = 0; col < p; ++col) {
        int64_t best = col;
        for (int64_t i = col + 1; i < p; ++i)
            if (fabs(factor[i * p + col]) > fabs(factor[best * p + col])) best = i;
        pivots[col] = best;
        if (factor[best * p + col] == 0.0) return col + 1;
        if (best != col)
            for (int64_t j = 0; j < p; ++j) {
                const double swap = factor[col * p + j];
                factor[col * p + j] = factor[best * p + j];
                factor[best * p + j] = swap;
            }
        for (int64_t i = col + 1; i < p; ++i) {
            const double l = factor[i * p + col] / factor[col * p + col];
            factor[i * p + col] = l;
            for (int64_t j = col + 1; j < p; ++j) factor[i * p + j] -= l * factor[col * p + j];
        }
    }
    return 0;
}

/* x (p × cols, row-major) ← A⁻¹ x with A's factors (controller_states_factor). */
static void controller_states_solve(int64_t p, const double *factor, const int64_t *pivots, int64_t cols, double *x)
{
    for (int64_t col = 0; col < p; ++col)
        if (pivots[col] != col)
            for (int64_t j = 0; j < cols; ++j) {
                const double swap = x[col * cols + j];
                x[col * cols + j] = x[pivots[col] * cols + j];
                x[pivots[col] * cols + j] = swap;
            }
    for (int64_t i = 1; i < p; ++i)   /* L y = x */
        for (int64_t l = 0; l < i; ++l)
            for (int64_t j = 0; j < cols; ++j) x[i * cols + j] -= factor[i * p + l] * x[l * cols + j];
    for (int64_t i = p - 1; i >= 0; --i) {   /* U x = y */
        for (int64_t l = i + 1; l < p; ++l)
            for (int64_t j = 0; j < cols; ++j) x[i * cols + j] -= factor[i * p + l] * x[l * cols + j];
        for (int64_t j = 0; j < cols; ++j) x[i * cols + j] /= factor[i * p + i];
    }
}

/* The step's held part and the states' derivative by its size (module comment), k parameter columns: A factorised
 * into `factor`, `pivots` (kept for latdyn_controller_states_after), held (p × k) = A⁻¹ (δS_n + hh (δf_n + ∂f/∂p)),
 * by_h (p) = A⁻¹ ½ (f_n + f_{n+1}). f_S p × p, f_p, dS, df p × k, f_n, f_next p. Returns 0, or 1 + the column of a
 * zero pivot (nothing written past the factorization). */
int64_t latdyn_controller_states_begin(int64_t p, int64_t k, double hh, const double *f_S, const double *f_p,
                                       const double *dS, const double *df, const double *f_n, const double *f_next,
                                       double *factor, int64_t *pivots, double *held, double *by_h)
{
    const int64_t info = controller_states_factor(p, hh, f_S, factor, pivots);
    if (info) return info;
    for (int64_t i = 0; i < p * k; ++i) held[i] = dS[i] + hh * (df[i] + f_p[i]);
    for (int64_t i = 0; i < p; ++i) by_h[i] = 0.5 * (f_n[i] + f_next[i]);
    controller_states_solve(p, factor, pivots, k, held);
    controller_states_solve(p, factor, pivots, 1, by_h);
    return 0;
}

/* δS_{n+1} and δf_{n+1} (p × k each) after the step (module comment): ds the sensors' derivatives along δq (m × k),
 * dh the step size's (k; NULL: 0), the factors and held, by_h of latdyn_controller_states_begin; scratch p × k. */
void latdyn_controller_states_after(int64_t p, int64_t m, int64_t k, double hh, const double *factor,
                                    const int64_t *pivots, const double *f_s, const double *f_S, const double *f_p,
                                    const double *held, const double *by_h, const double *ds, const double *dh,
                                    double *scratch, double *dS, double *df)
{
    for (int64_t j = 0; j < p; ++j)   /* ∂f/∂s δs, in the sensors' order, into df */
        for (int64_t col = 0; col < k; ++col) {
            double sum = 0.0;
            for (int64_t i = 0; i < m; ++i) sum += f_s[j * m + i] * ds[i * k + col];
            df[j * k + col] = sum;
        }
    for (int64_t i = 0; i < p * k; ++i) scratch[i] = hh * df[i];
    controller_states_solve(p, factor, pivots, k, scratch);
    for (int64_t j = 0; j < p; ++j)
        for (int64_t col = 0; col < k; ++col) {
            double value = held[j * k + col] + scratch[j * k + col];
            if (dh != NULL) value += by_h[j] * dh[col];
            dS[j * k + col] = value;
        }
    for (int64_t j = 0; j < p; ++j)   /* + ∂f/∂S δS_{n+1} in the states' order, + ∂f/∂p */
        for (int64_t col = 0; col < k; ++col) {
            double sum = df[j * k + col];
            for (int64_t l = 0; l < p; ++l) sum += f_S[j * p + l] * dS[l * k + col];
            df[j * k + col] = sum + f_p[j * k + col];
        }
}

/* ------------------------------------------------------------------ in the loop of steps (sensitivity_loop.c) */

/* The controllers with states in the loop of steps (latdyn/analyses/sensitivities_in_loop.py
 * SensitivityLoop._controller_states): those whose sensors are hinge and guide angles and nodes' positions and
 * displacements and whose actuators hinge torques and guide forces, their
 * carried δS, δf and accepted (S, f) at the step's start, handed to and from the carried sensitivities around each call
 * (ControllerStates's controller_dS, controller_df, controller_S, controller_f). */
typedef struct ControllerStatesLoopTag {
    int64_t n;                          /* controllers with states, in the wiring's order */
    const int64_t *place;               /* n: each one's place in the wiring (its step law's and read_start's index) */
    const int64_t *first;               /* n + 1: its states' rows among the P carried */
    const int64_t *sensor_dof;          /* the wiring's sensors: the angle's or node coordinate's row in δq, −1: 0 */
    int64_t n_rate_uses;                /* the states' rates' ∂f/∂p (ControllerPartials.rate_uses) */
    const int64_t *rate_use;            /* n_rate_uses × 4: controller (here), state, column, the law's number */
    double *dS, *df;                    /* in/out: P × k */
    double *S_n, *f_n;                  /* in/out: P, the accepted states and rates at the step's start */
    double *S_next, *f_next;            /* P: those at its end, kept while the matrices take (S_n, f_n) */
    double *f_s, *f_S, *f_p;            /* per controller, its rows: P × (widest sensors), P × (widest p), P × k */
    double *factor, *by_h, *held;       /* P × (widest p), P, P × k */
    int64_t *pivots;                    /* P */
    double *ds, *scratch;               /* (widest sensors) × k, P × k */
    double *law_args, *law_out;         /* the widest controller's arguments (m + p) and its law's (1 + p)(1 + m + p) */
    double *by_step;                    /* n_total + 1: ∂r/∂h through the states (ControllerStates.by_step_size) */
    int64_t width_s, width_S;           /* the widest sensors' and states' counts (the rows' strides) */
    double half_kept;                   /* the half step the evaluation held before the condensed one */
    /* the rows recorded on the way (controller probes: TransientSensitivities.record reads δS and S at a row): per
     * row the carried δS (P × k) then the accepted S (P), SensitivityLoop.record_rows; NULL: no row wanted */
    double *row_states;
    /* sensors of points offset from their node or in a body's axes (kinds 5 and 7, control.py OFFSET_POSITION and
     * BODY_FRAME): each column of the wiring's sensor gradients (Model sensor_column_start) its coordinate's row in δq
     * (the free nodes' within the free coordinates), −1: 0; their δs the gradient the evaluation's sensor_value leaves
     * in Work times δq (controller_state_sensed), the C the per-step path's ControllerStates._sensed calls too */
    const int64_t *column_dof;
} ControllerStatesLoop;

/* Sensor i of the wiring at c (time t), as the evaluation reads it (evaluate.c sensor_value), less its origin: a
 * joint's angle or a node's coordinate (kinds 0 and 2), a joint's rate or a node's velocity component (kinds 1 and 3:
 * sensor_value itself), or a point offset from its node or in a body's axes (kinds 5
 * and 7: sensor_value itself, which leaves its gradient in Work) — the kinds _states_refusal lets a controller with
 * states read. */
static double controller_state_sensor(const Model *m, Work *w, const Configuration *c, int64_t i, double t)
{
    const int64_t index = m->sensor_index[i], kind = m->sensor_kind[i];
    if (kind == 1 || kind == 3 || kind == 5 || kind == 7) return sensor_value(m, c, w, i, t);   /* a rate, a point */
    return (kind == 0 ? c->theta[index] : c->x[index]) - m->sensor_origin[i];
}

/* δs (k) of sensor i of the wiring along δq (n × k) and δv (n × k, NULL: 0) at c (time t): a joint's angle or a
 * node's coordinate (kinds 0 and 2) its row of δq (sensor_dof[i], −1: 0), a joint's rate or a node's velocity
 * component (kinds 1 and 3) its row of δv (δs = D_v δv: ControllerStates._sensed's rates), a point offset from its node or in a body's axes (kinds 5 and 7) its
 * gradient at c (sensor_value's, Jᵀ e_c from the generated point_load: by the node's and the body's coordinates)
 * times δq on those coordinates' rows (column_dof, −1: 0), summed in the gradient's column order. */
static void controller_state_sensed(const Model *m, Work *w, const Configuration *c, double t, int64_t i,
                                    const int64_t *sensor_dof, const int64_t *column_dof, int64_t k, const double *dq,
                                    const double *dv, double *ds)
{
    const int64_t kind = m->sensor_kind[i];
    if (kind == 1 || kind == 3) {
        const int64_t dof = sensor_dof[i];
        for (int64_t col = 0; col < k; ++col) ds[col] = dof >= 0 && dv != NULL ? dv[dof * k + col] : 0.0;
        return;
    }
    if (kind != 5 && kind != 7) {
        const int64_t dof = sensor_dof[i];
        for (int64_t col = 0; col < k; ++col) ds[col] = dof >= 0 ? dq[dof * k + col] : 0.0;
        return;
    }
    sensor_value(m, c, w, i, t);
    const int64_t start = m->sensor_column_start[i], end = m->sensor_column_start[i + 1];
    const double *gradient = w->sensor_jacobian + start;
    for (int64_t col = 0; col < k; ++col) {
        double sum = 0.0;
        for (int64_t j = 0; j < end - start; ++j) {
            const int64_t dof = column_dof[start + j];
            if (dof >= 0) sum += gradient[j] * dq[dof * k + col];
        }
        ds[col] = sum;
    }
}

/* The per-step Python path's δs (count × k) of the wiring's sensors first … first + count − 1 along δq (n × k) and δv
 * (NULL: 0) at c
 * (time t): controller_state_sensed, the loop's own (ControllerStates._sensed, for a controller with states reading a
 * point offset from its node or in a body's axes). */
void latdyn_controller_states_sensed(const Model *m, Work *w, const Configuration *c, double t, int64_t first,
                                     int64_t count, const int64_t *sensor_dof, const int64_t *column_dof, int64_t k,
                                     const double *dq, const double *dv, double *ds)
{
    for (int64_t r = 0; r < count; ++r)
        controller_state_sensed(m, w, c, t, first + r, sensor_dof, column_dof, k, dq, dv, ds + r * k);
}

/* The index of the wiring's controller `ctl` among the controllers with states, −1 for one without. */
static int64_t controller_with_states(const ControllerStatesLoop *st, int64_t ctl)
{
    for (int64_t i = 0; i < st->n; ++i)
        if (st->place[i] == ctl) return i;
    return -1;
}

/* The step law of the wiring's controller `ctl` at t and its arguments args (sensors, then states) into st->law_out. */
static const double *controller_step_law(const Model *m, const ControllerStatesLoop *st, int64_t ctl, double t,
                                         const double *args)
{
    m->controller_laws(ctl, t, args, st->law_out);
    return st->law_out;
}

/* Append controller `ctl`'s accepted states S_{n+1} to its arguments args[count …]; returns the new count. */
static int64_t controller_state_arguments(const Model *m, int64_t ctl, double *args, int64_t count)
{
    const int64_t first = m->controller_state_start[ctl], p = m->controller_state_start[ctl + 1] - first;
    for (int64_t j = 0; j < p; ++j) args[count + j] = m->controller_states[m->controller_state_slot[first + j]];
    return count + p;
}

/* ∂y/∂S held (ControllerTerms.add: the states at the configuration held) added to controller `ctl`'s slope (k), its
 * arguments args (m sensors, then its states): the step law's ∂y/∂S_l times held's row l, in the states' order. */
static void controller_states_held_slope(const Model *m, const ControllerStatesLoop *st, int64_t ctl, double t,
                                         const double *args, int64_t count, const double *held, int64_t k,
                                         double *slope)
{
    const int64_t p = m->controller_state_start[ctl + 1] - m->controller_state_start[ctl], sensors = count - p;
    const double *out = controller_step_law(m, st, ctl, t, args);
    for (int64_t l = 0; l < p; ++l) {
        const double g = out[1 + sensors + l];
        for (int64_t col = 0; col < k; ++col) slope[col] += g * held[l * k + col];
    }
}

/* ControllerStates.begin_step in the loop at c (time t, step size h), the states S_{n+1}, f_{n+1} accepted: each
 * controller's ∂f/∂s, ∂f/∂S (its step law) and ∂f/∂p (the compiled partials) at its sensors and S_{n+1}, then held
 * and by_h (latdyn_controller_states_begin). Returns 0, or 1 + the column of a zero pivot. */
static int64_t controller_states_begin_loop(const Model *m, Work *w, const Configuration *c, ControllerStatesLoop *st,
                                            void (*partials)(int64_t, double, const double *, double *),
                                            const int64_t *read_start, int64_t k,
                                            double t, double h)
{
    const double hh = 0.5 * h;
    for (int64_t i = 0; i < st->n; ++i) {
        const int64_t ctl = st->place[i], first = st->first[i], p = st->first[i + 1] - first;
        const int64_t sensors = read_start[ctl + 1] - read_start[ctl];
        double *args = st->law_args;
        for (int64_t r = 0; r < sensors; ++r) args[r] = controller_state_sensor(m, w, c, read_start[ctl] + r, t);
        controller_state_arguments(m, ctl, args, sensors);
        const double *out = controller_step_law(m, st, ctl, t, args);
        const int64_t width = 1 + sensors + p;
        double *f_s = st->f_s + first * st->width_s, *f_S = st->f_S + first * st->width_S, *f_p = st->f_p + first * k;
        for (int64_t j = 0; j < p; ++j) {
            for (int64_t r = 0; r < sensors; ++r) f_s[j * sensors + r] = out[width * (1 + j) + 1 + r];
            for (int64_t l = 0; l < p; ++l) f_S[j * p + l] = out[width * (1 + j) + 1 + sensors + l];
        }
        memset(f_p, 0, sizeof(double) * (size_t)(p * k));
        for (int64_t u = 0; u < st->n_rate_uses; ++u) {
            const int64_t *use = st->rate_use + 4 * u;
            if (use[0] != i) continue;
            double value;
            partials(use[3], t, args, &value);
            f_p[use[1] * k + use[2]] = value;
        }
        for (int64_t j = 0; j < p; ++j) {
            st->S_next[first + j] = m->controller_states[m->controller_state_slot[m->controller_state_start[ctl] + j]];
            st->f_next[first + j] = m->controller_state_rate[m->controller_state_start[ctl] + j];
        }
        const int64_t info = latdyn_controller_states_begin(
            p, k, hh, f_S, f_p, st->dS + first * k, st->df + first * k, st->f_n + first, st->f_next + first,
            st->factor + first * st->width_S, st->pivots + first, st->held + first * k, st->by_h + first);
        if (info) return info;
    }
    return 0;
}

/* Swap the controllers' accepted states and rates with those at the step's start (ControllerStates.condensed: the
 * evaluation condenses the states from (S_n, f_n) with h/2, as inside the step), `on` 1, and back, `on` 0. */
static void controller_states_condensed(const Model *m, Work *w, ControllerStatesLoop *st, double h, int on)
{
    if (on) st->half_kept = w->controller_half_step[0];
    for (int64_t i = 0; i < st->n; ++i) {
        const int64_t ctl = st->place[i], first = st->first[i], p = st->first[i + 1] - first;
        const int64_t start = m->controller_state_start[ctl];
        for (int64_t j = 0; j < p; ++j) {
            m->controller_states[m->controller_state_slot[start + j]] = on ? st->S_n[first + j] : st->S_next[first + j];
            m->controller_state_rate[start + j] = on ? st->f_n[first + j] : st->f_next[first + j];
        }
    }
    w->controller_half_step[0] = on ? 0.5 * h : st->half_kept;
}

/* ∂r/∂h through the states (ControllerStates.by_step_size, ControllerTerms.add with the held δS its by_h) into
 * st->by_step (n_total + 1): each controller with states' slope ∂y/∂S by_h into slopes (the wiring's controllers, 0
 * for the others and while its output, by its compiled output law, is clipped), each hinge actuator's row less its
 * factor times it. Its load actuators' part: controller_states_load_step_size (csrc/sensitivity_loop.c), then the
 * column: controller_states_step_size_add. */
static void controller_states_step_size_column(const Model *m, Work *w, const Configuration *c,
                                               ControllerStatesLoop *st,
                                               void (*partials)(int64_t, double, const double *, double *),
                                               const int64_t *read_start, const int64_t *output_law,
                                               const int64_t *output_limited, const double *output_limits,
                                               int64_t n_actuators,
                                               const int64_t *actuator_hinge, const int64_t *actuator_of,
                                               const double *actuator_factor, double t, int64_t n_controllers,
                                               double *slopes)
{
    memset(st->by_step, 0, sizeof(double) * (size_t)(m->n_total + 1));
    memset(slopes, 0, sizeof(double) * (size_t)n_controllers);
    for (int64_t i = 0; i < st->n; ++i) {
        const int64_t ctl = st->place[i], sensors = read_start[ctl + 1] - read_start[ctl];
        double *args = st->law_args;
        for (int64_t r = 0; r < sensors; ++r) args[r] = controller_state_sensor(m, w, c, read_start[ctl] + r, t);
        const int64_t count = controller_state_arguments(m, ctl, args, sensors);
        if (output_law[ctl] >= 0 && output_limited[ctl]) {
            double *out = st->law_out;
            partials(output_law[ctl], t, args, out);
            if (!(output_limits[2 * ctl] < out[0] && out[0] < output_limits[2 * ctl + 1])) continue;
        }
        controller_states_held_slope(m, st, ctl, t, args, count, st->by_h + st->first[i], 1, slopes + ctl);
    }
    for (int64_t a = 0; a < n_actuators; ++a) {
        const double slope = slopes[actuator_of[a]];
        if (slope != 0.0) st->by_step[m->hinge_dofs[actuator_hinge[a]]] -= actuator_factor[a] * slope;
    }
}

/* The step size's column of explicit_ (n × cols, column cols − 1) plus st->by_step, on the free coordinates. */
static void controller_states_step_size_add(const Model *m, const ControllerStatesLoop *st, int64_t cols,
                                            double *explicit_)
{
    for (int64_t i = 0; i < m->n_dofs; ++i) explicit_[i * cols + cols - 1] += st->by_step[i];
}

/* ControllerStates.after_step in the loop at c (time t): δs the hinge angles' and the nodes' coordinates' rows of δq
 * and the hinge rates' and nodes' velocities' rows of δv (0 for a joint or node not free), the offset and body-axes points' by their gradients (controller_state_sensed),
 * δS_{n+1}, δf_{n+1}
 * (latdyn_controller_states_after) with the step size's δh, and (S_n, f_n) ← (S_{n+1}, f_{n+1}) for the next step. */
static void controller_states_after_loop(const Model *m, Work *w, const Configuration *c, ControllerStatesLoop *st,
                                         const int64_t *read_start, int64_t k, double t, double h, const double *dq,
                                         const double *dv, const double *dh)
{
    const double hh = 0.5 * h;
    for (int64_t i = 0; i < st->n; ++i) {
        const int64_t ctl = st->place[i], first = st->first[i], p = st->first[i + 1] - first;
        const int64_t sensors = read_start[ctl + 1] - read_start[ctl];
        for (int64_t r = 0; r < sensors; ++r)
            controller_state_sensed(m, w, c, t, read_start[ctl] + r, st->sensor_dof, st->column_dof, k, dq, dv,
                                    st->ds + r * k);
        latdyn_controller_states_after(p, sensors, k, hh, st->factor + first * st->width_S, st->pivots + first,
                                       st->f_s + first * st->width_s, st->f_S + first * st->width_S,
                                       st->f_p + first * k, st->held + first * k, st->by_h + first, st->ds, dh,
                                       st->scratch, st->dS + first * k, st->df + first * k);
        for (int64_t j = 0; j < p; ++j) {
            st->S_n[first + j] = st->S_next[first + j];
            st->f_n[first + j] = st->f_next[first + j];
        }
    }
}

/* Row r of the rows recorded on the way: the carried δS_{n+1} and the accepted S_{n+1} (after
 * controller_states_after_loop), which a controller probe's row reads (controller_probe_sensitivities). */
static void controller_states_row(const ControllerStatesLoop *st, int64_t k, int64_t r)
{
    if (st->row_states == NULL) return;
    const int64_t P = st->first[st->n];
    double *out = st->row_states + (size_t)(P * (k + 1)) * (size_t)r;
    memcpy(out, st->dS, sizeof(double) * (size_t)(P * k));
    memcpy(out + P * k, st->S_n, sizeof(double) * (size_t)P);
}
