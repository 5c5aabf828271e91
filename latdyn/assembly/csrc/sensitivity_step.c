/*
 * The fixed part of a transient sensitivity step in one call: the step's exact iteration matrix
 * S = β′M + γ′C + K J summed on its held pattern, loaded into a factorization's storage and factorised
 * (factorization.c), then, for k + 1 columns, the right-hand sides −(∂r/∂p + K δq⁰ + C δv⁰) formed and
 * back-substituted (latdyn/analyses/transient_sensitivities.py, module docstring; the step matrix's
 * pattern and its products K J: latdyn/analyses/step_matrix.py); and the step's derivative before that solve
 * (its predicted parts, latdyn_sensitivity_predict) and after it (latdyn_sensitivity_update), with the
 * exponential's R and J per free node.
 *
 * Runtime code, written by hand: it holds no physics. M, C and the exact K come from the one evaluation
 * (evaluate.c, through latdyn.assembly.assembler.Assembler.exact_matrix_values) as the values of K's CSR
 * pattern; J's 3 × 3 blocks per free node from the exponential's tangent operator. The sums are taken in
 * the order NumPy and SciPy took them before this call existed (S: β′M + γ′C plus the products summed per
 * entry in the pattern's order; the right-hand side: (∂r/∂p + K δq⁰) + C δv⁰, each product a CSR row sum
 * in K's entry order), so the sensitivities are those of that Python step to the bit.
 */

/* M, C and K of one evaluation as the values of the assembler's pattern (out: 3 × nnz, M, C, K in turn;
 * latdyn.assembly.assembler.Assembler.exact_matrix_values lays the segments out): segment s takes counts[s] entries,
 * first[s][indices[s][i]] (+ second[s][indices[s][i]] where second[s] is given; 0 where first[s] is NULL), each added
 * at its place positions[p], p running over all segments in turn — the order np.bincount adds its weights in, so
 * the values are the bincount's to the bit. */
void latdyn_exact_matrix_values(int64_t n_segments, const int64_t *counts, const double *const *first,
                                const double *const *second, const int64_t *const *indices, const int64_t *positions,
                                int64_t size, double *out)
{
    memset(out, 0, sizeof(double) * size);
    int64_t p = 0;
    for (int64_t s = 0; s < n_segments; ++s) {
        const double *a = first[s], *b = second[s];
        const int64_t *at = indices[s];
        for (int64_t i = 0; i < counts[s]; ++i, ++p) {
            double value = 0.0;
            if (a != NULL) {
                value = a[at[i]];
                if (b != NULL) value += b[at[i]];
            }
            out[positions[p]] += value;
        }
    }
}

/* The joint bodies' inertia stiffness at c (out: n_bodies × 6 × 6), which the time step's matrix leaves out and the
 * exact K adds to the bodies' blocks: the generated joint_body_inertia_stiffness (codegen/joints.py) called once
 * for every body, on each body node's frame and (ω, a, α), with the bodies' rows ``body`` (n_bodies × 13: m, c, I)
 * and λg rows ``gravity`` (n_bodies × 3) as latdyn.assembly.assembler.Assembler.joint_body_inertia_stiffness
 * holds them; scratch: 18 n_bodies doubles. */
typedef void (*kernel_body_stiffness)(int64_t, const double *, const double *, const double *, const double *,
                                      double *);

void latdyn_joint_body_inertia_stiffness(const Model *m, const Configuration *c, kernel_body_stiffness kernel,
                                         const double *body, const double *gravity, double *scratch, double *out)
{
    const int64_t n = m->n_bodies;
    if (n == 0) return;
    double *frames = scratch, *motion = scratch + 9 * n;
    for (int64_t k = 0; k < n; ++k) {
        const int64_t i = m->body_nodes[k];
        memcpy(frames + 9 * k, c->T + 9 * i, 9 * sizeof(double));
        memcpy(motion + 9 * k, c->w + 3 * i, 3 * sizeof(double));
        memcpy(motion + 9 * k + 3, c->a + 3 * i, 3 * sizeof(double));
        memcpy(motion + 9 * k + 6, c->alpha + 3 * i, 3 * sizeof(double));
    }
    kernel(n, frames, motion, body, gravity, out);
}

/* The held pattern of S for one numbering (latdyn.analyses.step_matrix.ExactStepMatrix builds it). */
typedef struct {
    int64_t n;                  /* free coordinates */
    int64_t nnz;                /* entries of K's pattern (M's and C's alike) */
    int64_t size;               /* entries of S's pattern */
    int64_t n_plain, n_terms;
    const int64_t *indptr;      /* K's CSR pattern: n + 1 row starts */
    const int64_t *indices;     /* nnz columns */
    const int64_t *into;        /* nnz: the place in S of each entry of K's pattern */
    const int64_t *plain;       /* n_plain: K's entries off the rotation columns */
    const int64_t *term_entry;  /* n_terms: K's entry of each product K[r, s_i] J_f[i, j] */
    const int64_t *term_block;  /* n_terms: J_f[i, j]'s place in the blocks (f, 3, 3) flattened */
    const int64_t *term_place;  /* n_terms: its place in S, ascending */
    const int64_t *storage;     /* size: S's entries' offsets in the factorization's storage */
    const Factorization *factorization;
} SensitivityStep;

/* S's values into S (size) from mck (3 × nnz: M, C, K) and the blocks J_f. */
static void sensitivity_matrix_values(const SensitivityStep *s, const double *mck, const double *blocks,
                                      double beta_p, double gamma_p, double *S)
{
    const double *M = mck, *C = mck + s->nnz, *K = mck + 2 * s->nnz;
    memset(S, 0, sizeof(double) * s->size);
    for (int64_t e = 0; e < s->nnz; ++e) S[s->into[e]] = beta_p * M[e] + gamma_p * C[e];
    for (int64_t t = 0; t < s->n_terms;) {   /* the products of one place summed, then added */
        int64_t place = s->term_place[t];
        double sum = 0.0;
        for (; t < s->n_terms && s->term_place[t] == place; ++t)
            sum += K[s->term_entry[t]] * blocks[s->term_block[t]];
        S[place] += sum;
    }
    for (int64_t i = 0; i < s->n_plain; ++i) {
        int64_t e = s->plain[i];
        S[s->into[e]] += K[e];
    }
}

/* y (n × k, row-major) = A x for A on K's CSR pattern with values A (SciPy's csr_matvecs' order). */
static void pattern_product(const SensitivityStep *s, const double *A, int64_t k, const double *x, double *y)
{
    memset(y, 0, sizeof(double) * s->n * k);
    for (int64_t r = 0; r < s->n; ++r)
        for (int64_t e = s->indptr[r]; e < s->indptr[r + 1]; ++e) {
            const double a = A[e], *from = x + s->indices[e] * k;
            double *to = y + r * k;
            for (int64_t c = 0; c < k; ++c) to[c] += a * from[c];
        }
}

/* z (n × k, row-major) = S⁻¹ rhs for rhs = −(explicit + K dq0 + C dv0) (each n × k, row-major) with S's factors in
 * f's storage (factor, pivots), work holding 3 n k doubles: the products (pattern_product), each right-hand side
 * contiguous in the factor's order, the solves. Returns latdyn_solve's info. */
static int64_t solve_columns(const SensitivityStep *s, const Factorization *f, const double *factor, const int *pivots,
                             const double *mck, int64_t k, const double *explicit_, const double *dq0,
                             const double *dv0, double *work, double *z)
{
    const int64_t n = s->n, *permutation = f->permutation;
    double *stiff = work, *damp = work + n * k, *x = work + 2 * n * k;
    pattern_product(s, mck + 2 * s->nnz, k, dq0, stiff);
    pattern_product(s, mck + s->nnz, k, dv0, damp);
    for (int64_t i = 0; i < n; ++i)   /* each right-hand side contiguous, in the factor's order */
        for (int64_t c = 0; c < k; ++c)
            x[c * n + permutation[i]] = -((explicit_[i * k + c] + stiff[i * k + c]) + damp[i * k + c]);
    int64_t info = latdyn_solve(f, factor, pivots, k, x);
    for (int64_t i = 0; i < n; ++i)
        for (int64_t c = 0; c < k; ++c) z[i * k + c] = x[c * n + permutation[i]];
    return info;
}

/* Sums S into S (size doubles, kept for a caller that factorises it otherwise); with k < 0 that is all
 * (returns 0). Else loads it into the factor storage and factorises it (latdyn_factor); with k > 0 then
 * z (n × k, row-major) = S⁻¹ rhs for rhs = −(explicit + K dq0 + C dv0) (each n × k, row-major), work holding
 * 3 n k doubles. Returns latdyn_factor's info (nonzero: singular, or the sparse LU's pivot failed; nothing
 * solved). */
int64_t latdyn_sensitivity_step(const SensitivityStep *s, const double *mck, const double *blocks, double beta_p,
                                double gamma_p, double *S, double *factor, int *pivots, int64_t k,
                                const double *explicit_, const double *dq0, const double *dv0, double *work,
                                double *z)
{
    const Factorization *f = s->factorization;
    sensitivity_matrix_values(s, mck, blocks, beta_p, gamma_p, S);
    if (k < 0) return 0;   /* the sum alone (ExactStepMatrix.values) */
    memset(factor, 0, sizeof(double) * f->size);
    for (int64_t p = 0; p < s->size; ++p) factor[s->storage[p]] += S[p];
    int64_t info = latdyn_factor(f, factor, pivots);
    if (info != 0 || k <= 0 || s->n == 0) return info;
    return solve_columns(s, f, factor, pivots, mck, k, explicit_, dq0, dv0, work, z);
}

/* Where the sparse LU's pivot failed in latdyn_sensitivity_step (its info nonzero), the band LU with LAPACK's
 * partial pivoting that stands in for it (latdyn.assembly.factorization.Factorization._factor_pivoted, on S's pattern
 * in reverse Cuthill–McKee order): S (as summed there) loaded at its entries' offsets `storage` in the band's storage
 * `factor`, factorised, and the same k columns formed and solved (ExactStepMatrix.solve_step's fallback: the band's
 * Factorization.solve of −(explicit + K dq0 + C dv0), the products SciPy's order). Returns latdyn_factor's info
 * (nonzero: singular with pivoting too). */
int64_t latdyn_sensitivity_step_pivoted(const SensitivityStep *s, const Factorization *band, const int64_t *storage,
                                        const double *S, const double *mck, double *factor, int *pivots, int64_t k,
                                        const double *explicit_, const double *dq0, const double *dv0, double *work,
                                        double *z)
{
    memset(factor, 0, sizeof(double) * band->size);
    for (int64_t p = 0; p < s->size; ++p) factor[storage[p]] += S[p];
    int64_t info = latdyn_factor(band, factor, pivots);
    if (info != 0 || k <= 0 || s->n == 0) return info;
    return solve_columns(s, band, factor, pivots, mck, k, explicit_, dq0, dv0, work, z);
}

/* ------------------------------------------------------------- the step's derivative before and after */

/* out (n × m, row-major) = B x on the free nodes' rotation coordinates (B: R or J, f 3 × 3 blocks on
 * slots f × 3, a slot ≥ n not a coordinate), x elsewhere; f = 0: the identity (a planar model's maps). */
static void node_rotations(int64_t n, int64_t m, int64_t f, const int64_t *slots, const double *blocks,
                           const double *x, double *out)
{
    memcpy(out, x, sizeof(double) * n * m);
    for (int64_t node = 0; node < f; ++node) {
        const int64_t *s = slots + 3 * node;
        const double *B = blocks + 9 * node;
        for (int i = 0; i < 3; ++i) {
            if (s[i] >= n) continue;
            double *to = out + s[i] * m;
            for (int64_t c = 0; c < m; ++c) {
                double sum = 0.0;
                for (int j = 0; j < 3; ++j)
                    if (s[j] < n) sum += B[3 * i + j] * x[s[j] * m + c];
                to[c] = sum;
            }
        }
    }
}

/* The predicted parts (those of y = δv̇_{n+1} = 0) of the generalized-α step's derivative
 * (latdyn/analyses/transient_sensitivities.py, module docstring), k parameter columns and one of a unit
 * change of the step size h (column k): from the carried dq, dv, dvdot, da (n × k, row-major) and
 * step = (h, α_m, α_f, γ, β), with v_n, a_n, a_{n+1} (n) for the step size's column, R = exp(skew hΔq) and
 * J = dexp(hΔq) (f blocks on slots; f = 0: the identity), into out: da0, dq0, dv0 (each n × (k + 1)),
 * then 2 n (k + 1) doubles of scratch (δ(hΔq)⁰ and J δ(hΔq)⁰).
 *   δa⁰ = (α_f δv̇ − α_m δa)/(1 − α_m),   δ(hΔq)⁰ = h(δv + h(½ − β)δa + hβ δa⁰),
 *   δq⁰ = R δq + J δ(hΔq)⁰,             δv⁰ = δv + h(1 − γ)δa + hγ δa⁰,
 * column k adding ∂(hΔq)/∂h = v_n + 2h(½ − β)a_n + 2hβ a_{n+1} and ∂v_{n+1}/∂h = (1 − γ)a_n + γ a_{n+1}. */
void latdyn_sensitivity_predict(int64_t n, int64_t k, const double *step, int64_t f, const int64_t *slots,
                                const double *turn, const double *tangent, const double *v_old, const double *a_old,
                                const double *a_new, const double *dq, const double *dv, const double *dvdot,
                                const double *da, double *out)
{
    const double h = step[0], am = step[1], af = step[2], gamma = step[3], beta = step[4];
    const int64_t m = k + 1, size = n * m;
    double *da0 = out, *dq0 = out + size, *dv0 = out + 2 * size, *du0 = out + 3 * size;
    double *turned = dv0;   /* R δq, before δv⁰ is written there */
    double *carried_q = du0;
    for (int64_t i = 0; i < n; ++i) {   /* δq with the step size's column 0, for R */
        for (int64_t c = 0; c < k; ++c) carried_q[i * m + c] = dq[i * k + c];
        carried_q[i * m + k] = 0.0;
    }
    node_rotations(n, m, f, slots, turn, carried_q, turned);
    memcpy(dq0, turned, sizeof(double) * size);
    const double half = h * (0.5 - beta), hb = h * beta, hg = h * (1 - gamma), hgg = h * gamma;
    for (int64_t i = 0; i < n; ++i)
        for (int64_t c = 0; c < m; ++c) {
            const int64_t at = i * m + c;
            double vdot_c = 0.0, a_c = 0.0, v_c = 0.0;
            if (c < k) vdot_c = dvdot[i * k + c], a_c = da[i * k + c], v_c = dv[i * k + c];
            da0[at] = (af * vdot_c - am * a_c) / (1 - am);
            du0[at] = h * (v_c + half * a_c + hb * da0[at]);
            dv0[at] = v_c + hg * a_c + hgg * da0[at];
        }
    for (int64_t i = 0; i < n; ++i) {   /* the step size's column */
        du0[i * m + k] += v_old[i] + 2 * h * (0.5 - beta) * a_old[i] + 2 * h * beta * a_new[i];
        dv0[i * m + k] += (1 - gamma) * a_old[i] + gamma * a_new[i];
    }
    double *moved = out + 4 * size;   /* J δ(hΔq)⁰ */
    node_rotations(n, m, f, slots, tangent, du0, moved);
    for (int64_t at = 0; at < size; ++at) dq0[at] += moved[at];
}

/* The step's derivative after the solve z (n × (k + 1)) of the step matrix (latdyn_sensitivity_step):
 * δq = δq⁰ + J z, δv = δv⁰ + γ′z, δv̇ = β′z, δa = δa⁰ + (1 − α_f)/(1 − α_m) δv̇, from predicted (da0, dq0,
 * dv0 of latdyn_sensitivity_predict) into out (dq, dv, dvdot, da, each n × (k + 1)). */
void latdyn_sensitivity_update(int64_t n, int64_t k, const double *step, double beta_p, double gamma_p, int64_t f,
                               const int64_t *slots, const double *tangent, const double *z, const double *predicted,
                               double *out)
{
    const double am = step[1], af = step[2];
    const int64_t size = n * (k + 1);
    const double *da0 = predicted, *dq0 = predicted + size, *dv0 = predicted + 2 * size;
    double *dq = out, *dv = out + size, *dvdot = out + 2 * size, *da = out + 3 * size;
    node_rotations(n, k + 1, f, slots, tangent, z, dq);
    const double rate = (1 - af) / (1 - am);
    for (int64_t at = 0; at < size; ++at) {
        dq[at] = dq0[at] + dq[at];
        dv[at] = dv0[at] + gamma_p * z[at];
        dvdot[at] = beta_p * z[at];
        da[at] = da0[at] + rate * dvdot[at];
    }
}
