/*
 * The dissipated energy's sensitivity carried through the steps (latdyn/analyses/energy_sensitivities.py
 * _dissipated_step), the one formula both paths call: the per-step Python path through latdyn_damper_torques and
 * latdyn_dissipated_step (with the damping laws' values its law objects give at the state), the loop of steps
 * (sensitivity_loop.c) through work_accounts_step at each step it accepts, with the laws' values the caller
 * tabulated per grid point (laws of t alone: latdyn/analyses/sensitivities_in_loop.py ``_account_refusal``).
 *
 * The quadrature is the forward run's own (newton_step.c hinge_work: ½(f_n + f_{n+1}) Δθ of each damper's torque
 * f = c(θ, θ̇, t) θ̇, the trapezoidal rule in θ), differentiated:
 *   δD_{n+1} = δD_n + Σ_j ½ Δθ_j (δf_{j,n} + δf_{j,n+1}) + Σ_j ½ (f_{j,n} + f_{j,n+1}) (δθ_{j,n+1} − δθ_{j,n}),
 *   δf = θ̇ ∂c/∂θ δθ + (c + θ̇ ∂c/∂θ̇) δθ̇ + θ̇ ∂c/∂p.
 *
 * Runtime code, written by hand: the quadrature of the forward run's account, differentiated; the laws are the
 * scene's law objects' (or their tabulated values), no generated physics is repeated here.
 */

/* The dampers' torques f = c θ̇ of H hinges and their derivatives δf (H × k) along δθ, δθ̇ (H × k each): laws (H × 3)
 * each hinge's (c, ∂c/∂θ, ∂c/∂θ̇) at its (θ, θ̇, t); U uses of a damping parameter, each its hinge, its column and
 * ∂c/∂p's value, added θ̇ ∂c/∂p in their order. */
static void damper_torques(int64_t H, int64_t k, const double *theta_dot, const double *laws, const double *dtheta,
                           const double *dtheta_dot, int64_t U, const int64_t *use_hinge, const int64_t *use_column,
                           const double *use_value, double *torque, double *dtorque)
{
    for (int64_t j = 0; j < H; ++j) {
        const double rate = theta_dot[j], c = laws[3 * j], by_angle = laws[3 * j + 1] * rate;
        const double by_rate = c + laws[3 * j + 2] * rate;
        torque[j] = c * rate;
        for (int64_t col = 0; col < k; ++col)
            dtorque[j * k + col] = by_angle * dtheta[j * k + col] + by_rate * dtheta_dot[j * k + col];
    }
    for (int64_t u = 0; u < U; ++u) {
        const int64_t j = use_hinge[u];
        dtorque[j * k + use_column[u]] += use_value[u] * theta_dot[j];
    }
}

/* The dissipated energy's sensitivity (k) carried over the step θ_old → θ_new (H each) from the dampers' torques and
 * their derivatives at its ends (damper_torques; δθ at each end, H × k). */
static void dissipated_step(int64_t H, int64_t k, const double *theta_old, const double *theta_new,
                            const double *torque_old, const double *dtorque_old, const double *dtheta_old,
                            const double *torque_new, const double *dtorque_new, const double *dtheta_new,
                            double *dissipated)
{
    for (int64_t j = 0; j < H; ++j) {
        const double turned = 0.5 * (theta_new[j] - theta_old[j]), mean = 0.5 * (torque_old[j] + torque_new[j]);
        for (int64_t col = 0; col < k; ++col) {
            const int64_t i = j * k + col;
            dissipated[col] += turned * (dtorque_old[i] + dtorque_new[i]) + mean * (dtheta_new[i] - dtheta_old[i]);
        }
    }
}

/* damper_torques for the per-step Python path (energy_sensitivities._damper_torques). */
void latdyn_damper_torques(int64_t H, int64_t k, const double *theta_dot, const double *laws, const double *dtheta,
                           const double *dtheta_dot, int64_t U, const int64_t *use_hinge, const int64_t *use_column,
                           const double *use_value, double *torque, double *dtorque)
{
    damper_torques(H, k, theta_dot, laws, dtheta, dtheta_dot, U, use_hinge, use_column, use_value, torque, dtorque);
}

/* dissipated_step for the per-step Python path (energy_sensitivities._dissipated_step). */
void latdyn_dissipated_step(int64_t H, int64_t k, const double *theta_old, const double *theta_new,
                            const double *torque_old, const double *dtorque_old, const double *dtheta_old,
                            const double *torque_new, const double *dtorque_new, const double *dtheta_new,
                            double *dissipated)
{
    dissipated_step(H, k, theta_old, theta_new, torque_old, dtorque_old, dtheta_old, torque_new, dtorque_new,
                    dtheta_new, dissipated);
}

/* ------------------------------------------------------------------ the external work's sensitivity
 * (energy_sensitivities.external_work_step, its power's terms energy_sensitivities._power): P = Σ_l P_l the point
 * loads' power (the generated point_load's, P_l = −Q_l·u_l), δP = −Σ_l (δQ_l·u_l + Q_l·δu_l) with
 * δQ_l = ∂Q/∂π δπ_node + ∂Q/∂π_frame δπ_frame (the frame's for a follower load) and, per (load, parameter) pair, −∂Q/∂p·u
 * (∂Q/∂p the generated point_load with the values' derivatives); the hinges' applied torques τ (less k s of a spring
 * that is not conservative) and δτ = ∂τ/∂θ δθ + ∂τ/∂θ̇ δθ̇ + ∂τ/∂p; the step
 *   δW_{n+1} = δW_n + ½ h (δP_n + δP_{n+1}) + ½ δh (P_n + P_{n+1}) + Σ_j ½ Δθ_j (δτ_n + δτ_{n+1})_j
 *             + Σ_j ½ (τ_n + τ_{n+1})_j (δθ_{n+1} − δθ_n)_j. */

/* P and δP (k) of L loads from the kernel's outputs at the state (force L × 6, power L, by_node, by_frame L × 18, the
 * load's rates u L × 6), δπ of each load's node and of its frame body (L × 3 × k; frame_of < 0: a global load, no frame
 * term), δu (L × 6 × k); then per pair its ∂Q/∂p (pair_force, pairs × 6) at its load's rates, in its column. */
static double load_power(int64_t L, int64_t k, const double *force, const double *power, const double *u,
                         const double *by_node, const double *by_frame, const int64_t *frame_of,
                         const double *dpi_node, const double *dpi_frame, const double *du, int64_t pairs,
                         const int64_t *pair_load, const int64_t *pair_column, const double *pair_force,
                         double *dpower)
{
    double total = 0.0;
    for (int64_t col = 0; col < k; ++col) dpower[col] = 0.0;
    for (int64_t l = 0; l < L; ++l) {
        total += power[l];
        const double *f = force + 6 * l, *ul = u + 6 * l, *bn = by_node + 18 * l, *bf = by_frame + 18 * l;
        for (int64_t col = 0; col < k; ++col) {
            double moved = 0.0;
            for (int i = 0; i < 6; ++i) {
                double dforce = 0.0;
                for (int j = 0; j < 3; ++j) dforce += bn[3 * i + j] * dpi_node[(3 * l + j) * k + col];
                if (frame_of[l] >= 0)
                    for (int j = 0; j < 3; ++j) dforce += bf[3 * i + j] * dpi_frame[(3 * l + j) * k + col];
                moved += dforce * ul[i] + f[i] * du[(6 * l + i) * k + col];
            }
            dpower[col] -= moved;
        }
    }
    for (int64_t p = 0; p < pairs; ++p) {
        const double *f = pair_force + 6 * p, *ul = u + 6 * pair_load[p];
        double moved = 0.0;
        for (int i = 0; i < 6; ++i) moved += f[i] * ul[i];
        dpower[pair_column[p]] -= moved;
    }
    return total;
}

/* The hinges' applied torques τ (H) and δτ (H × k) at θ (H) along δθ, δθ̇ (H × k): laws (H × 8) each hinge's (τ, ∂τ/∂θ,
 * ∂τ/∂θ̇, 1 where its spring is not conservative else 0, k, ∂k/∂θ, ∂k/∂θ̇, θ_r); U uses of a parameter, each its hinge,
 * column, kind (0 the torque: + ∂τ/∂p; 1 the stiffness: − ∂k/∂p s; 2 the rest angle: + k ∂θ_r/∂p) and value. */
static void applied_torques(int64_t H, int64_t k, const double *theta, const double *laws, const double *dtheta,
                            const double *dtheta_dot, int64_t U, const int64_t *use_hinge, const int64_t *use_column,
                            const int64_t *use_kind, const double *use_value, double *torque, double *dtorque)
{
    for (int64_t j = 0; j < H; ++j) {
        const double *l = laws + 8 * j;
        torque[j] = l[0];
        for (int64_t col = 0; col < k; ++col)
            dtorque[j * k + col] = l[1] * dtheta[j * k + col] + l[2] * dtheta_dot[j * k + col];
        if (l[3] != 0.0) {   /* its spring's work is external: τ − k s */
            const double spring = theta[j] - l[7], by_angle = l[5] * spring + l[4], by_rate = l[6] * spring;
            torque[j] -= l[4] * spring;
            for (int64_t col = 0; col < k; ++col)
                dtorque[j * k + col] -= by_angle * dtheta[j * k + col] + by_rate * dtheta_dot[j * k + col];
        }
    }
    for (int64_t u = 0; u < U; ++u) {
        const int64_t j = use_hinge[u];
        const double *l = laws + 8 * j, value = use_value[u];
        double *at = dtorque + j * k + use_column[u];
        if (use_kind[u] == 0) *at += value;
        else if (use_kind[u] == 1) *at -= value * (theta[j] - l[7]);
        else *at += l[4] * value;
    }
}

/* The external work's sensitivity (k) carried over the step of size h (δh: dh, k) from its ends' terms: P, δP (k) of
 * the loads, τ, δτ, δθ of the H hinges (applied_torques), θ at each end. */
static void external_work_increment(int64_t k, int64_t H, double h, const double *dh, double power_old,
                                    const double *dpower_old, double power_new, const double *dpower_new,
                                    const double *theta_old, const double *theta_new, const double *torque_old,
                                    const double *dtorque_old, const double *dtheta_old, const double *torque_new,
                                    const double *dtorque_new, const double *dtheta_new, double *work)
{
    const double half_h = 0.5 * h, powers = 0.5 * (power_old + power_new);
    for (int64_t col = 0; col < k; ++col)
        work[col] += half_h * (dpower_old[col] + dpower_new[col]) + dh[col] * powers;
    dissipated_step(H, k, theta_old, theta_new, torque_old, dtorque_old, dtheta_old, torque_new, dtorque_new,
                    dtheta_new, work);
}

/* load_power, applied_torques and external_work_increment for the per-step Python path (energy_sensitivities._power
 * and external_work_step). */
double latdyn_load_power(int64_t L, int64_t k, const double *force, const double *power, const double *u,
                         const double *by_node, const double *by_frame, const int64_t *frame_of,
                         const double *dpi_node, const double *dpi_frame, const double *du, int64_t pairs,
                         const int64_t *pair_load, const int64_t *pair_column, const double *pair_force,
                         double *dpower)
{
    return load_power(L, k, force, power, u, by_node, by_frame, frame_of, dpi_node, dpi_frame, du, pairs, pair_load,
                      pair_column, pair_force, dpower);
}

void latdyn_applied_torques(int64_t H, int64_t k, const double *theta, const double *laws, const double *dtheta,
                            const double *dtheta_dot, int64_t U, const int64_t *use_hinge, const int64_t *use_column,
                            const int64_t *use_kind, const double *use_value, double *torque, double *dtorque)
{
    applied_torques(H, k, theta, laws, dtheta, dtheta_dot, U, use_hinge, use_column, use_kind, use_value, torque,
                    dtorque);
}

void latdyn_external_work_increment(int64_t k, int64_t H, double h, const double *dh, double power_old,
                                    const double *dpower_old, double power_new, const double *dpower_new,
                                    const double *theta_old, const double *theta_new, const double *torque_old,
                                    const double *dtorque_old, const double *dtheta_old, const double *torque_new,
                                    const double *dtorque_new, const double *dtheta_new, double *work)
{
    external_work_increment(k, H, h, dh, power_old, dpower_old, power_new, dpower_new, theta_old, theta_new,
                            torque_old, dtorque_old, dtheta_old, torque_new, dtorque_new, dtheta_new, work);
}

/* ------------------------------------------------------------------ in the loop of steps
 * What the loop of steps carries for the work accounts' sensitivities (latdyn.analyses.sensitivities_in_loop
 * SensitivityLoop._accounts): each account and its terms at the last step's end, in/out, as the Python path carries
 * them (``dissipated_sensitivity``, ``dissipated_terms``; ``external_work_sensitivity``, ``external_work_terms``). */
typedef struct WorkAccounts {
    int64_t hinges;                     /* H: every hinge of the model */
    const int64_t *hinge_row;           /* H: its coordinate among the free ones (δθ = δq there), −1: not free */
    int64_t values_from;                /* the grid index of the tables' first grid point */
    double *theta;                      /* in/out, H: the hinge angles at the last step's end */
    double *row_accounts;               /* (rows' capacity) × 2k: δD and δW at each row recorded on the way; NULL: none */
    /* the dissipated energy; dissipated NULL: not carried */
    const double *laws;                 /* (grid points) × H × 3: each damping law's (c, ∂c/∂θ, ∂c/∂θ̇) */
    int64_t n_uses;                     /* the damping parameters' (hinge, column) uses */
    const int64_t *use_hinge, *use_column;
    const double *use_values;           /* (grid points) × n_uses: ∂c/∂p's value at each grid point */
    double *dissipated;                 /* in/out, k: the carried δD */
    double *torque, *dtorque, *dtheta;  /* in/out: H, H × k, H × k: the terms at the last step's end */
    double *scratch;                    /* H + 3 H k: the terms at the new end, and δθ̇ */
    /* the external work; work NULL: not carried */
    double *work;                       /* in/out, k: the carried δW */
    double *power;                      /* in/out, 1 + k: P and δP at the last step's end */
    double *work_torque, *work_dtorque, *work_dtheta; /* in/out: H, H × k, H × k: τ, δτ, δθ there */
    int64_t loads;                      /* L: every load */
    const int64_t *load_node, *load_frame; /* L: its node; its frame body's node, −1: global */
    const double *load_offset;          /* L × 3 */
    const int64_t *node_rows, *frame_rows; /* L × 6, L × 3: the free coordinates of its node (x, π), of its frame's π; −1 */
    const double *load_values;          /* (grid points) × L × 6: its values at each grid point */
    int64_t pairs;                      /* the (load, parameter) pairs of ∂Q/∂p */
    const int64_t *pair_load, *pair_column;
    const double *pair_values;          /* (grid points) × pairs × 6: λ ∂(the load's values)/∂p */
    const double *torque_laws;          /* (grid points) × H × 8: applied_torques' laws */
    int64_t n_torque_uses;
    const int64_t *torque_use_hinge, *torque_use_column, *torque_use_kind;
    const double *torque_use_values;    /* (grid points) × n_torque_uses */
    double *work_scratch;               /* 1 + k + H + H k + L (73 + 12 k) + 76 pairs */
    /* the accounts' laws of θ, θ̇ or an input (energy_sensitivities.account_laws): compiled as the step's hinge laws
     * (latdyn_hinge_laws: f, ∂f/∂θ, ∂f/∂θ̇), the C the Python path calls too, evaluated at each hinge's (θ, θ̇, t) in
     * place of the tabulated values (state_laws_at); state_laws NULL: every law tabulated */
    void (*state_laws)(int64_t, double, double, double, double *);
    const int64_t *damping_law;         /* H: each hinge's damping law's number among them, −1: tabulated */
    const int64_t *use_law;             /* n_uses: each damping parameter's derivative law's, −1: tabulated */
    const int64_t *torque_law;          /* H × 2: each hinge's applied torque's and stiffness's, −1: tabulated */
    const int64_t *torque_use_law;      /* n_torque_uses: each applied torque's parameter's derivative law's */
    double *law_scratch;                /* 3 H + n_uses + 8 H + n_torque_uses: the tables' rows with them in */
    /* the prescribed motions' drive in the external work (drive_sensitivities.c; energy_sensitivities._drive_reactions):
     * ½ Σ_d Δq_d (δr_d,n + δr_d,n+1) over the prescribed coordinates d; drive_rows 0: none */
    int64_t drive_rows;                 /* d */
    const int64_t *drive_coordinates;   /* d: the prescribed coordinates, in model.prescribed_coordinates' order */
    const int64_t *drive_where;         /* n_total + 1: each coordinate's place among them, −1 */
    const int64_t *drive_slot;          /* d: each one's place among the increments (drive_work's order: 6 per
                                         * prescribed node, then one per hinge) */
    double *drive_dr;                   /* in/out, d × k: δr_d at the last step's end */
    double *drive_x, *drive_T;          /* in/out, P × 3, P × 9: the prescribed nodes' x and T there */
    const double *drive_total;          /* the loop's ∂r/∂p on every coordinate at the step's end ((n_total + 1) × k) */
    const double *drive_body_stiffness; /* the loop's joint bodies' inertia stiffness at the step's end; NULL: none */
    const int64_t *drive_load_columns;  /* n_loads × 6: each load block's columns */
    const int64_t *drive_couplings;     /* 2 n_couplings: the controllers' coupling rows, then columns; NULL: none */
    double *drive_scratch;              /* d k + 6 P + H + d */
    /* loads on nodes that follow rigid links (dependent_node_motion); linked_loads 0: none */
    int64_t linked_loads;
    const int64_t *load_slot, *frame_slot; /* L each: the links' slot of its node, of its frame's node; −1: free, none */
    double *linked_scratch;             /* 12 k */
} WorkAccounts;

/* δq (δx, δπ) and δv (δv, δω) (6 × k each) of the node of the links' slot s from the carried free δq, δv (n × k): its
 * J and ∂(J v)/∂q at fixed free rates (the links' buffers at the state: complete_links, dependent_rates_tangent),
 * δq_dep = J δq, δv_dep = J δv + ∂(J v)/∂q δq over the slot's columns that are free (energy_sensitivities._power
 * calls it too, through latdyn_dependent_node_motion). */
static void dependent_node_motion(const Model *m, int64_t s, int64_t k, const double *dq, const double *dv, double *mq,
                                  double *mv)
{
    const Links *L = m->links;
    const int64_t W = L->width, n = m->n_dofs, *columns = L->slot_columns + W * s;
    const double *J = L->jacobian + 6 * W * s, *R = L->rates_tangent + 12 * W * s;
    for (int i = 0; i < 6; ++i)
        for (int64_t col = 0; col < k; ++col) {
            double q = 0.0, v = 0.0;
            for (int64_t j = 0; j < L->slot_count[s]; ++j) {
                const int64_t p = columns[j];
                if (p >= n) continue;
                q += J[W * i + j] * dq[p * k + col];
                v += J[W * i + j] * dv[p * k + col] + R[W * i + j] * dq[p * k + col];
            }
            mq[i * k + col] = q;
            mv[i * k + col] = v;
        }
}

/* dependent_node_motion for the per-step Python path, at c (its links completed and their rates' tangent taken
 * here). */
void latdyn_dependent_node_motion(const Model *m, Configuration *c, int64_t s, int64_t k, const double *dq,
                                  const double *dv, double *mq, double *mv)
{
    complete_links(m, c);
    dependent_rates_tangent(m, c);
    dependent_node_motion(m, s, k, dq, dv, mq, mv);
}

/* Into `into` (a table's row copied there: `count` laws, each `width` wide): each law whose number law[i * stride] is
 * not −1 evaluated by the compiled laws at its hinge's (θ, θ̇, t) (hinge_of[i]; NULL: hinge i), its f (width 1) or its
 * f, ∂f/∂θ, ∂f/∂θ̇ at `offset`, in place of the tabulated value (energy_sensitivities._law_values, the same C). */
static void state_laws_into(const WorkAccounts *a, const Configuration *c, double t, int64_t count, int64_t width,
                            int64_t offset, const int64_t *law, int64_t stride, const int64_t *hinge_of, double *into)
{
    for (int64_t i = 0; i < count; ++i) {
        const int64_t number = law[i * stride], j = hinge_of != NULL ? hinge_of[i] : i;
        if (number < 0) continue;
        double out[3];
        a->state_laws(number, c->theta[j], c->theta_dot[j], t, out);
        if (width == 1) into[i] = out[0];
        else for (int q = 0; q < 3; ++q) into[i * width + offset + q] = out[q];
    }
}

/* P, δP (power: 1 + k) of the loads at c on grid point row `at` (load_power on the generated point_load's outputs). */
static void loads_power_at(const Model *m, const Configuration *c, const WorkAccounts *a, int64_t k, const double *dq,
                           const double *dv, int64_t at, double *power, double *scratch)
{
    const int64_t L = a->loads, P = a->pairs, n = m->n_dofs;
    double *T = scratch, *values = T + 9 * L, *frames = values + 6 * L, *u = frames + 9 * L, *force = u + 6 * L;
    double *load_power_ = force + 6 * L, *by_node = load_power_ + L, *by_frame = by_node + 18 * L;
    double *dpi_node = by_frame + 18 * L, *dpi_frame = dpi_node + 3 * L * k, *du = dpi_frame + 3 * L * k;
    double *pT = du + 6 * L * k, *poff = pT + 9 * P, *pframes = poff + 3 * P, *pu = pframes + 9 * P;
    double *pvalues = pu + 6 * P, *pforce = pvalues + 6 * P, *ppower = pforce + 6 * P, *pby = ppower + P;
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    for (int64_t l = 0; l < L; ++l) {
        const int64_t i = a->load_node[l], frame = a->load_frame[l];
        memcpy(T + 9 * l, c->T + 9 * i, 9 * sizeof(double));
        memcpy(values + 6 * l, a->load_values + 6 * (L * at + l), 6 * sizeof(double));
        memcpy(frames + 9 * l, frame >= 0 ? c->T + 9 * frame : identity, 9 * sizeof(double));
        memcpy(u + 6 * l, c->v + 3 * i, 3 * sizeof(double));
        memcpy(u + 6 * l + 3, c->w + 3 * i, 3 * sizeof(double));
        for (int j = 0; j < 6; ++j) {
            const int64_t row = a->node_rows[6 * l + j];
            for (int64_t col = 0; col < k; ++col) {
                du[(6 * l + j) * k + col] = row >= 0 && row < n ? dv[row * k + col] : 0.0;
                if (j >= 3) dpi_node[(3 * l + j - 3) * k + col] = row >= 0 && row < n ? dq[row * k + col] : 0.0;
            }
        }
        for (int j = 0; j < 3; ++j) {
            const int64_t row = a->frame_rows[3 * l + j];
            for (int64_t col = 0; col < k; ++col)
                dpi_frame[(3 * l + j) * k + col] = frame >= 0 && row >= 0 && row < n ? dq[row * k + col] : 0.0;
        }
    }
    for (int64_t l = 0; a->linked_loads && l < L; ++l) {   /* a node or frame that follows rigid links */
        double *mq = a->linked_scratch, *mv = mq + 6 * k;
        if (a->load_slot[l] >= 0) {
            dependent_node_motion(m, a->load_slot[l], k, dq, dv, mq, mv);
            memcpy(du + 6 * l * k, mv, sizeof(double) * (size_t)(6 * k));
            memcpy(dpi_node + 3 * l * k, mq + 3 * k, sizeof(double) * (size_t)(3 * k));
        }
        if (a->frame_slot[l] >= 0) {
            dependent_node_motion(m, a->frame_slot[l], k, dq, dv, mq, mv);
            memcpy(dpi_frame + 3 * l * k, mq + 3 * k, sizeof(double) * (size_t)(3 * k));
        }
    }
    if (L) m->point_load(L, T, a->load_offset, values, frames, u, force, load_power_, by_node, by_frame);
    for (int64_t p = 0; p < P; ++p) {   /* ∂Q/∂p: the kernel with the values' derivatives (_load_forces) */
        const int64_t l = a->pair_load[p];
        memcpy(pT + 9 * p, T + 9 * l, 9 * sizeof(double));
        memcpy(poff + 3 * p, a->load_offset + 3 * l, 3 * sizeof(double));
        memcpy(pframes + 9 * p, frames + 9 * l, 9 * sizeof(double));
        memcpy(pu + 6 * p, u + 6 * l, 6 * sizeof(double));
        memcpy(pvalues + 6 * p, a->pair_values + 6 * (P * at + p), 6 * sizeof(double));
    }
    if (P) m->point_load(P, pT, poff, pvalues, pframes, pu, pforce, ppower, pby, pby + 18 * P);
    power[0] = load_power(L, k, force, load_power_, u, by_node, by_frame, a->load_frame, dpi_node, dpi_frame, du, P,
                          a->pair_load, a->pair_column, pforce, power + 1);
}

/* The drive's part of the external work's sensitivity over the loop's accepted step ending at c (time t; dq, dv, dvdot
 * the carried δq, δv, δv̇ there): δr_d at c from ∂r/∂p's rows and one evaluation's blocks (drive_reaction_rates), the
 * increments Δq_d of the prescribed coordinates from the held start (drive_work's: Δx, so3_log_increment, Δθ; θ at the
 * start a->theta), their sum into the carried δW (drive_work_sensitivity), and the end held, as external_work_step. */
static void drive_step(const Model *m, Work *w, const Configuration *c, WorkAccounts *a, int64_t k, const double *dq,
                       const double *dv, const double *dvdot, double t)
{
    const int64_t d = a->drive_rows, P = m->n_prescribed, H = a->hinges;
    double *dr = a->drive_scratch, *all = dr + d * k, *increment = all + 6 * P + H;
    for (int64_t i = 0; i < d; ++i)
        memcpy(dr + i * k, a->drive_total + a->drive_coordinates[i] * k, sizeof(double) * (size_t)k);
    EvaluationControl e = {t, 1.0, 1, 1, 1, 0.0};
    latdyn_evaluate(m, w, c, &e);
    drive_reaction_rates(m, w, a->drive_where, k, a->drive_body_stiffness, a->drive_load_columns, a->drive_couplings,
                         dq, dv, dvdot, dr);
    for (int64_t p = 0; p < P; ++p) {
        const int64_t i = m->prescribed_nodes[p];
        for (int j = 0; j < 3; ++j) all[6 * p + j] = c->x[3 * i + j] - a->drive_x[3 * p + j];
        m->so3_log_increment(1, a->drive_T + 9 * p, c->T + 9 * i, all + 6 * p + 3);
        memcpy(a->drive_x + 3 * p, c->x + 3 * i, 3 * sizeof(double));
        memcpy(a->drive_T + 9 * p, c->T + 9 * i, 9 * sizeof(double));
    }
    for (int64_t j = 0; j < H; ++j) all[6 * P + j] = c->theta[j] - a->theta[j];
    for (int64_t i = 0; i < d; ++i) increment[i] = all[a->drive_slot[i]];
    drive_work_sensitivity(d, k, increment, a->drive_dr, dr, a->work);
    memcpy(a->drive_dr, dr, sizeof(double) * (size_t)(d * k));
}

/* The accounts carried over the loop's accepted step of size h ending at c on grid point `grid` at time t (dq, dv,
 * dvdot: the carried δq, δv, δv̇ there, n × k; dh: the step size's derivative, k; w: the evaluation's work space, for
 * the drive): the terms at c, each account's increment, the terms and θ kept. */
static void work_accounts_step(const Model *m, Work *w, const Configuration *c, WorkAccounts *a, int64_t k,
                               const double *dq, const double *dv, const double *dvdot, const double *dh, double h,
                               int64_t grid, double t)
{
    const int64_t H = a->hinges, hk = H * k;
    double *torque = a->scratch, *dtorque = torque + H, *dtheta = dtorque + hk, *dtheta_dot = dtheta + hk;
    for (int64_t j = 0; j < H; ++j) {
        const int64_t row = a->hinge_row[j];
        for (int64_t col = 0; col < k; ++col) {
            dtheta[j * k + col] = row >= 0 ? dq[row * k + col] : 0.0;
            dtheta_dot[j * k + col] = row >= 0 ? dv[row * k + col] : 0.0;
        }
    }
    const int64_t at = grid - a->values_from;
    if (a->work != NULL) {
        double *power = a->work_scratch, *work_torque = power + 1 + k, *work_dtorque = work_torque + H;
        const double *torque_laws = a->torque_laws + 8 * H * at;
        const double *torque_use_values = a->torque_use_values + a->n_torque_uses * at;
        if (a->state_laws != NULL) {   /* the laws of the state at the hinges' θ, θ̇, t (account_laws) */
            double *laws = a->law_scratch + 3 * H + a->n_uses, *values = laws + 8 * H;
            memcpy(laws, torque_laws, sizeof(double) * (size_t)(8 * H));
            memcpy(values, torque_use_values, sizeof(double) * (size_t)a->n_torque_uses);
            state_laws_into(a, c, t, H, 8, 0, a->torque_law, 2, NULL, laws);
            state_laws_into(a, c, t, H, 8, 4, a->torque_law + 1, 2, NULL, laws);
            state_laws_into(a, c, t, a->n_torque_uses, 1, 0, a->torque_use_law, 1, a->torque_use_hinge, values);
            torque_laws = laws;
            torque_use_values = values;
        }
        if (a->linked_loads) {   /* the links' J and rates' tangent at c, as latdyn_dependent_node_motion takes them */
            complete_links(m, (Configuration *)c);
            dependent_rates_tangent(m, c);
        }
        loads_power_at(m, c, a, k, dq, dv, at, power, work_dtorque + hk);
        applied_torques(H, k, c->theta, torque_laws, dtheta, dtheta_dot, a->n_torque_uses,
                        a->torque_use_hinge, a->torque_use_column, a->torque_use_kind,
                        torque_use_values, work_torque, work_dtorque);
        external_work_increment(k, H, h, dh, a->power[0], a->power + 1, power[0], power + 1, a->theta, c->theta,
                                a->work_torque, a->work_dtorque, a->work_dtheta, work_torque, work_dtorque, dtheta,
                                a->work);
        if (a->drive_rows) drive_step(m, w, c, a, k, dq, dv, dvdot, t);   /* the prescribed motions' drive */
        memcpy(a->power, power, sizeof(double) * (size_t)(1 + k));
        memcpy(a->work_torque, work_torque, sizeof(double) * (size_t)H);
        memcpy(a->work_dtorque, work_dtorque, sizeof(double) * (size_t)hk);
        memcpy(a->work_dtheta, dtheta, sizeof(double) * (size_t)hk);
    }
    if (a->dissipated != NULL) {
        const double *laws = a->laws + 3 * H * at, *use_values = a->use_values + a->n_uses * at;
        if (a->state_laws != NULL) {   /* the laws of the state at the hinges' θ, θ̇, t (account_laws) */
            double *held = a->law_scratch, *values = held + 3 * H;
            memcpy(held, laws, sizeof(double) * (size_t)(3 * H));
            memcpy(values, use_values, sizeof(double) * (size_t)a->n_uses);
            state_laws_into(a, c, t, H, 3, 0, a->damping_law, 1, NULL, held);
            state_laws_into(a, c, t, a->n_uses, 1, 0, a->use_law, 1, a->use_hinge, values);
            laws = held;
            use_values = values;
        }
        damper_torques(H, k, c->theta_dot, laws, dtheta, dtheta_dot, a->n_uses, a->use_hinge,
                       a->use_column, use_values, torque, dtorque);
        dissipated_step(H, k, a->theta, c->theta, a->torque, a->dtorque, a->dtheta, torque, dtorque, dtheta,
                        a->dissipated);
        memcpy(a->torque, torque, sizeof(double) * (size_t)H);
        memcpy(a->dtorque, dtorque, sizeof(double) * (size_t)hk);
        memcpy(a->dtheta, dtheta, sizeof(double) * (size_t)hk);
    }
    memcpy(a->theta, c->theta, sizeof(double) * (size_t)H);
}

/* Row r of the rows recorded on the way: the accounts (δD, δW) as the step before it left them. */
static void work_accounts_row(const WorkAccounts *a, int64_t k, int64_t r)
{
    if (!a->row_accounts) return;
    double *row = a->row_accounts + 2 * k * r;
    if (a->dissipated) memcpy(row, a->dissipated, sizeof(double) * (size_t)k);
    if (a->work) memcpy(row + k, a->work, sizeof(double) * (size_t)k);
}
