/*
 * One smooth step of the discrete adjoint's reverse pass in one call (latdyn/analyses/adjoint_sensitivities.py,
 * module docstring; AdjointSensitivities._reverse_columns), for a step with no event and a size that does not move
 * with the parameters: at the stored end state c, M, C and the exact K (latdyn_evaluate with the inertia tangent,
 * latdyn_joint_body_inertia_stiffness, latdyn_exact_matrix_values: Assembler.exact_matrix_values), S = β′M + γ′C + K J
 * summed and factorised (latdyn_sensitivity_step with no column: ExactStepMatrix.factor; where the sparse LU's pivot
 * fails, the band LU with pivoting that stands in for it, latdyn_sensitivity_step_pivoted), then for the m output
 * columns
 *
 *     z̄ = Jᵀq̄ + γ′v̄ + β′v̇̄ + (1 − α_f)/(1 − α_m) β′ā,      w = S⁻ᵀ z̄,
 *     q̄⁰ = q̄ − Kᵀw,  v̄⁰ = v̄ − Cᵀw,  ū = Jᵀq̄⁰,  ā⁰ = ā + hγ v̄⁰ + h²β ū,
 *     q̄ ← Rᵀq̄⁰,  v̄ ← v̄⁰ + h ū,  ā ← h(1 − γ) v̄⁰ + h²(½ − β) ū − α_m/(1 − α_m) ā⁰,  v̇̄ ← α_f/(1 − α_m) ā⁰,
 *
 * w returned for the contraction with ∂r/∂p, which the caller takes (AdjointSensitivities.residual_transposed_product);
 * where the caller asks (grid ≥ 0: a model with rigid links or guides whose parameters the forward method's loop
 * differentiates in C), ∂r/∂p at c reduced by Pᵀ left in s->total as the forward step forms it (sensitivity_loop.c
 * parameter_columns, the laws' values at row `grid` of the caller's tables), which the caller contracts with w.
 * The SensitivityLoop struct of sensitivity_loop.c holds the layout (latdyn/analyses/sensitivities_in_loop.py).
 *
 * Runtime code, written by hand: it holds no physics. The sums are taken in the order NumPy and SciPy take them on
 * the Python path (Kᵀw, Cᵀw: SciPy's CSC product of K's CSR storage seen transposed, row by row of K; the scalar
 * factors multiplied first), so a planar model's bars are that path's to the bit; in 3D Jᵀ and Rᵀ apply each
 * 3 × 3 block as a sum over its row in turn, where NumPy's einsum may round otherwise.
 */

/* y (n × m) = Aᵀ x for A (n × n) on the step's pattern (values A, CSR indptr and indices), x (n × m): SciPy's
 * csc_matvecs on A's storage seen transposed (each row r of A scattered in turn). */
static void pattern_transposed_product(const SensitivityStep *s, const double *A, int64_t m, const double *x, double *y)
{
    memset(y, 0, sizeof(double) * s->n * m);
    for (int64_t r = 0; r < s->n; ++r)
        for (int64_t e = s->indptr[r]; e < s->indptr[r + 1]; ++e) {
            const double a = A[e], *from = x + r * m;
            double *to = y + s->indices[e] * m;
            for (int64_t c = 0; c < m; ++c) to[c] += a * from[c];
        }
}

/* The reverse step (see the header) at the stored end state c (time t, size h; scheme: α_m, α_f, γ, β) for m
 * columns q_bar, v_bar, vdot_bar, a_bar (each n × m, row-major, updated in place), with the step's rotation blocks
 * on s's slots: tangent (J, for S), tangent_t and turn_t (Jᵀ, Rᵀ; f = 0: the identity), into w (n × m); work holds
 * 5 n m doubles; grid ≥ 0: ∂r/∂p at c into s->total (see the header), −1: not. Returns 0, or the factorization's
 * info where S is singular (nothing updated). */
int64_t latdyn_adjoint_reverse_step(const Model *m, Work *w, SensitivityLoop *s, const Configuration *c, double t,
                                    double h, const double *scheme, int64_t cols, int64_t f, const double *tangent,
                                    const double *tangent_t, const double *turn_t, double *q_bar, double *v_bar,
                                    double *vdot_bar, double *a_bar, double *w_out, double *work, int64_t grid)
{
    const int64_t n = m->n_dofs, size = n * cols;
    const double am = scheme[0], af = scheme[1], gamma = scheme[2], beta = scheme[3];
    const double beta_p = (1 - am) / (h * h * beta * (1 - af)), gamma_p = gamma / (h * beta);
    const SensitivityStep *step = s->step;
    if (s->linked)   /* rigid links or guides: the compiled step's reduction (linked_matrices.c), as the forward step */
        latdyn_linked_exact_values(m, w, c, t, s->body_kernel, s->body_rows, s->body_gravity, s->body_scratch,
                                   s->linked_body_D, s->linked_gather, s->linked_count, s->linked_storage, s->mck);
    else
        exact_matrices(m, w, s, c, t);   /* sensitivity_loop.c */
    if (grid >= 0) parameter_columns(m, w, s, c, t, grid);   /* with the evaluation at c, as the forward step */
    int64_t info = latdyn_sensitivity_step(step, s->mck, tangent, beta_p, gamma_p, s->S, s->factor, s->pivots, 0,
                                           NULL, NULL, NULL, NULL, NULL);
    const Factorization *factorization = step->factorization;
    double *factor = s->factor;
    int *pivots = s->pivots;
    if (info != 0 && s->pivoted != NULL) {   /* the sparse LU's pivot failed: the band LU with pivoting, as in Python */
        factorization = s->pivoted, factor = s->pivoted_factor, pivots = s->pivoted_pivots;
        info = latdyn_sensitivity_step_pivoted(step, factorization, s->pivoted_storage, s->S, s->mck, factor, pivots, 0,
                                               NULL, NULL, NULL, NULL, NULL);
    }
    if (info != 0) return info;
    double *z = work, *x = work + size, *stiff = work + 2 * size, *damp = work + 3 * size, *u = work + 4 * size;
    /* z̄ = ((Jᵀq̄ + γ′v̄) + β′v̇̄) + ((1 − α_f)/(1 − α_m) β′)ā */
    node_rotations(n, cols, f, s->slots, tangent_t, q_bar, z);
    const double rate = (1 - af) / (1 - am) * beta_p;
    for (int64_t at = 0; at < size; ++at)
        z[at] = ((z[at] + gamma_p * v_bar[at]) + beta_p * vdot_bar[at]) + rate * a_bar[at];
    /* w = S⁻ᵀ z̄ in the factor's order (Factorization.solve_transposed) */
    const int64_t *permutation = factorization->permutation;
    for (int64_t i = 0; i < n; ++i)
        for (int64_t col = 0; col < cols; ++col) x[col * n + permutation[i]] = z[i * cols + col];
    if (n) info = latdyn_solve_transposed(factorization, factor, pivots, cols, x);
    if (info != 0) return info;
    for (int64_t i = 0; i < n; ++i)
        for (int64_t col = 0; col < cols; ++col) w_out[i * cols + col] = x[col * n + permutation[i]];
    pattern_transposed_product(step, s->mck + 2 * step->nnz, cols, w_out, stiff);
    pattern_transposed_product(step, s->mck + step->nnz, cols, w_out, damp);
    for (int64_t at = 0; at < size; ++at) {   /* q̄⁰ into q̄'s place, v̄⁰ into v̄'s */
        q_bar[at] = q_bar[at] - stiff[at];
        v_bar[at] = v_bar[at] - damp[at];
    }
    node_rotations(n, cols, f, s->slots, tangent_t, q_bar, u);   /* ū = Jᵀq̄⁰ */
    const double hg = h * gamma, hhb = h * h * beta, h1g = h * (1 - gamma), hhh = h * h * (0.5 - beta);
    const double back = am / (1 - am), ahead = af / (1 - am);
    for (int64_t at = 0; at < size; ++at) {
        const double da0 = (a_bar[at] + hg * v_bar[at]) + hhb * u[at];
        a_bar[at] = (h1g * v_bar[at] + hhh * u[at]) - back * da0;
        vdot_bar[at] = ahead * da0;
        v_bar[at] = v_bar[at] + h * u[at];
    }
    node_rotations(n, cols, f, s->slots, turn_t, q_bar, stiff);   /* q̄ = Rᵀq̄⁰ */
    memcpy(q_bar, stiff, sizeof(double) * size);
    return 0;
}
