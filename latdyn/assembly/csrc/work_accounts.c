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

/* What the loop of steps carries for the dissipated energy's sensitivity (latdyn.analyses.sensitivities_in_loop
 * SensitivityLoop._accounts): the account and its terms at the last step's end, in/out, as the Python path carries
 * them (``dissipated_sensitivity``, ``dissipated_terms``). */
typedef struct WorkAccounts {
    int64_t hinges;                     /* H: every hinge of the model */
    const int64_t *hinge_row;           /* H: its coordinate among the free ones (δθ = δq there), −1: not free */
    const double *laws;                 /* (grid points) × H × 3: each damping law's (c, ∂c/∂θ, ∂c/∂θ̇) */
    int64_t n_uses;                     /* the damping parameters' (hinge, column) uses */
    const int64_t *use_hinge, *use_column;
    const double *use_values;           /* (grid points) × n_uses: ∂c/∂p's value at each grid point */
    int64_t values_from;                /* the grid index of the tables' first grid point */
    double *dissipated;                 /* in/out, k: the carried δD */
    double *theta;                      /* in/out, H: the hinge angles at the last step's end */
    double *torque, *dtorque, *dtheta;  /* in/out: H, H × k, H × k: the terms at the last step's end */
    double *scratch;                    /* H + 3 H k: the terms at the new end, and δθ̇ */
    double *row_accounts;               /* (rows' capacity) × k: δD at each row recorded on the way; NULL: none */
} WorkAccounts;

/* The account carried over the loop's accepted step ending at c on grid point `grid` (dq, dv: the carried δq, δv
 * there, n × k): the terms at c (damper_torques), the step's increment (dissipated_step), the terms and θ kept. */
static void work_accounts_step(const Model *m, const Configuration *c, WorkAccounts *a, int64_t k, const double *dq,
                               const double *dv, int64_t grid)
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
    damper_torques(H, k, c->theta_dot, a->laws + 3 * H * at, dtheta, dtheta_dot, a->n_uses, a->use_hinge,
                   a->use_column, a->use_values + a->n_uses * at, torque, dtorque);
    dissipated_step(H, k, a->theta, c->theta, a->torque, a->dtorque, a->dtheta, torque, dtorque, dtheta,
                    a->dissipated);
    memcpy(a->theta, c->theta, sizeof(double) * (size_t)H);
    memcpy(a->torque, torque, sizeof(double) * (size_t)H);
    memcpy(a->dtorque, dtorque, sizeof(double) * (size_t)hk);
    memcpy(a->dtheta, dtheta, sizeof(double) * (size_t)hk);
}

/* Row r of the rows recorded on the way: the account as the step before it left it. */
static void work_accounts_row(const WorkAccounts *a, int64_t k, int64_t r)
{
    if (a->row_accounts) memcpy(a->row_accounts + k * r, a->dissipated, sizeof(double) * (size_t)k);
}
