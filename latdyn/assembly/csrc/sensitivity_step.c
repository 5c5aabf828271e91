/*
 * The fixed part of a transient sensitivity step in one call: the step's exact iteration matrix
 * S = β′M + γ′C + K J summed on its held pattern, loaded into a factorization's storage and factorised
 * (factorization.c), then, for k + 1 columns, the right-hand sides −(∂r/∂p + K δq⁰ + C δv⁰) formed and
 * back-substituted (latdyn/analyses/transient_sensitivities.py, module docstring; the step matrix's
 * pattern and its products K J: latdyn/analyses/step_matrix.py).
 *
 * Runtime code, written by hand: it holds no physics. M, C and the exact K come from the one evaluation
 * (evaluate.c, through latdyn.assembly.assembler.Assembler.exact_matrix_values) as the values of K's CSR
 * pattern; J's 3 × 3 blocks per free node from the exponential's tangent operator. The sums are taken in
 * the order NumPy and SciPy took them before this call existed (S: β′M + γ′C plus the products summed per
 * entry in the pattern's order; the right-hand side: (∂r/∂p + K δq⁰) + C δv⁰, each product a CSR row sum
 * in K's entry order), so the sensitivities are those of that Python step to the bit.
 */

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

/* Sums S into S (size doubles, kept for a caller that factorises it otherwise), loads it into the factor
 * storage and factorises it (latdyn_factor); with k > 0 then z (n × k, row-major) = S⁻¹ rhs for
 * rhs = −(explicit + K dq0 + C dv0) (each n × k, row-major), work holding 3 n k doubles. Returns
 * latdyn_factor's info (nonzero: singular, or the sparse LU's pivot failed; nothing solved). */
int64_t latdyn_sensitivity_step(const SensitivityStep *s, const double *mck, const double *blocks, double beta_p,
                                double gamma_p, double *S, double *factor, int *pivots, int64_t k,
                                const double *explicit_, const double *dq0, const double *dv0, double *work,
                                double *z)
{
    const Factorization *f = s->factorization;
    sensitivity_matrix_values(s, mck, blocks, beta_p, gamma_p, S);
    memset(factor, 0, sizeof(double) * f->size);
    for (int64_t p = 0; p < s->size; ++p) factor[s->storage[p]] += S[p];
    int64_t info = latdyn_factor(f, factor, pivots);
    if (info != 0 || k <= 0 || s->n == 0) return info;
    const int64_t n = s->n, *permutation = f->permutation;
    double *stiff = work, *damp = work + n * k, *x = work + 2 * n * k;
    pattern_product(s, mck + 2 * s->nnz, k, dq0, stiff);
    pattern_product(s, mck + s->nnz, k, dv0, damp);
    for (int64_t i = 0; i < n; ++i)   /* each right-hand side contiguous, in the factor's order */
        for (int64_t c = 0; c < k; ++c)
            x[c * n + permutation[i]] = -((explicit_[i * k + c] + stiff[i * k + c]) + damp[i * k + c]);
    info = latdyn_solve(f, factor, pivots, k, x);
    for (int64_t i = 0; i < n; ++i)
        for (int64_t c = 0; c < k; ++c) z[i * k + c] = x[c * n + permutation[i]];
    return info;
}
