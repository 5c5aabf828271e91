/*
 * Sparse LU of a structurally symmetric matrix in a static, fill-reducing order, without
 * pivoting: supernodal and left-looking, with dense block kernels from BLAS.
 *
 * The symbolic analysis is made once per sparsity pattern, in Python (latdyn/assembly/sparse_lu.py):
 * a minimum-degree order of the node graph, the structure of L (U's is its transpose: the
 * pattern is symmetric), a partition of the columns into supernodes -- consecutive columns
 * with one row structure below their diagonal block -- and the position in the factor
 * storage of every matrix entry, so that the caller assembles the matrix straight into it.
 * Here only the numeric factorization and the substitutions are done.
 *
 * Storage of supernode J with columns c0 <= j < c1 (nc = c1 - c0) and row structure R_J
 * (nr rows below c1, ascending):
 *   lower[J]: the (nc + nr) x nc panel, column-major, leading dimension nc + nr: the diagonal
 *             block (L11 unit lower and U11 upper packed together, as LAPACK's getrf) over L21;
 *   upper[J]: U12 transposed, nr x nc, column-major, leading dimension nr.
 * Before factorize() the same places hold the matrix entries A(rows, cols) (and A(cols, R_J)ᵀ).
 *
 * Method: Davis, Direct Methods for Sparse Linear Systems (SIAM 2006), §4 (elimination tree,
 * row and column structures) and §6 (LU); the supernodal left-looking organisation, with
 * each finished supernode linked into the list of the next supernode it updates, is that of
 * Ng & Peyton (1993) and CHOLMOD (Chen, Davis, Hager, Rajamanickam 2008), applied to L and
 * Uᵀ together.  The diagonal panel is factorized by the recursive LU of Toledo (1997), without
 * row exchanges.
 *
 * Without pivoting the static order's fill is kept; the iteration matrix of generalized-α is
 * dominated by β′M on its diagonal (see latdyn/numerics/linalg.py).  Every pivot is checked against
 * the scale of its row and column in the matrix (largest |A(j, :)|, |A(:, j)|): a pivot not
 * larger than pivot_tolerance times that scale, or not finite, stops the factorization and is
 * reported in failed_column / failed_ratio (the factor is then unusable).
 */
#include <math.h>
#include <stdint.h>
#include <string.h>

typedef void (*blas_gemm)(char *, char *, int *, int *, int *, double *, double *, int *, double *, int *,
                          double *, double *, int *);
typedef void (*blas_trsm)(char *, char *, char *, char *, int *, int *, double *, double *, int *, double *,
                          int *);

typedef struct {
    int64_t n, n_supernodes;
    const int64_t *first;      /* (n_supernodes + 1) first column of each supernode */
    const int64_t *rows_start; /* (n_supernodes + 1) R_J = rows[rows_start[J] : rows_start[J + 1]] */
    const int64_t *rows;       /* the row structures, each ascending */
    const int64_t *lower;      /* (n_supernodes) offset of the L panel in the factor storage */
    const int64_t *upper;      /* (n_supernodes) offset of the U12ᵀ panel */
    const int64_t *supernode;  /* (n) supernode of each column */
    double pivot_tolerance;
    blas_gemm gemm;
    blas_trsm trsm;
    /* scratch: map (n), head, next, cursor (n_supernodes each), update (largest block update),
     * scale (n) */
    int64_t *map, *head, *next, *cursor;
    double *update, *scale;
    /* out, after a failed factorization: the column (factor order) and |pivot| / its scale */
    int64_t failed_column;
    double failed_ratio;
    /* scratch (n): the places in the updated supernode's panel of an update's rows */
    int64_t *relative;
} SparseLU;

/* Largest |entry| of each row and column of the matrix as assembled into the factor storage. */
static void matrix_scales(SparseLU *s, const double *factor)
{
    for (int64_t j = 0; j < s->n; ++j) s->scale[j] = 0.0;
    for (int64_t J = 0; J < s->n_supernodes; ++J) {
        const int64_t c0 = s->first[J], nc = s->first[J + 1] - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        const double *L = factor + s->lower[J], *Ut = factor + s->upper[J];
        double *scale = s->scale;
        for (int64_t k = 0; k < nc; ++k) {  /* the column's largest in a register: the same maximum */
            const int64_t column = c0 + k;
            const double *Lk = L + k * ld, *Uk = Ut + k * nr;
            double largest = 0.0;
            for (int64_t i = 0; i < nc; ++i) {  /* A(c0 + i, column) */
                const double a = fabs(Lk[i]);
                if (a > largest) largest = a;
                if (a > scale[c0 + i]) scale[c0 + i] = a;
            }
            for (int64_t t = 0; t < nr; ++t) {  /* A(R[t], column) and U12ᵀ(t, k) = A(column, R[t]) */
                const double a = fabs(Lk[nc + t]), b = fabs(Uk[t]);
                if (a > largest) largest = a;
                if (b > largest) largest = b;
                if (a > scale[R[t]]) scale[R[t]] = a;
                if (b > scale[R[t]]) scale[R[t]] = b;
            }
            if (largest > scale[column]) scale[column] = largest;
        }
    }
}

/* Whether pivot p of column j (factor order) is usable; records the failure if not. */
static int pivot_ok(SparseLU *s, int64_t j, double p)
{
    double scale = s->scale[j] > 0.0 ? s->scale[j] : 1.0;
    if (isfinite(p) && fabs(p) > s->pivot_tolerance * scale) return 1;
    s->failed_column = j;
    s->failed_ratio = fabs(p) / scale;
    return 0;
}

/* LU without row exchanges of the m x n panel A (m >= n, leading dimension ld) whose first
 * column is column j0: recursive on the columns (Toledo 1997), unblocked below 16 columns.
 * Returns 0, or -1 at an unusable pivot. */
static int panel_lu(SparseLU *s, double *A, int m, int n, int ld, int64_t j0)
{
    if (n <= 16) {
        for (int k = 0; k < n; ++k) {
            double *ak = A + (int64_t)k * ld;
            if (!pivot_ok(s, j0 + k, ak[k])) return -1;
            double inverse = 1.0 / ak[k];
            for (int i = k + 1; i < m; ++i) ak[i] *= inverse;
            for (int j = k + 1; j < n; ++j) {
                double *aj = A + (int64_t)j * ld, t = aj[k];
                if (t == 0.0) continue;
                for (int i = k + 1; i < m; ++i) aj[i] -= ak[i] * t;
            }
        }
        return 0;
    }
    int n1 = n / 2, n2 = n - n1, m2 = m - n1;
    double one = 1.0, minus_one = -1.0;
    double *A12 = A + (int64_t)n1 * ld, *A21 = A + n1, *A22 = A + n1 + (int64_t)n1 * ld;
    if (panel_lu(s, A, m, n1, ld, j0) != 0) return -1;
    /* A12 <- L11⁻¹ A12, A22 <- A22 − L21 A12 */
    s->trsm("L", "L", "N", "U", &n1, &n2, &one, A, &ld, A12, &ld);
    s->gemm("N", "N", &m2, &n2, &n1, &minus_one, A21, &ld, A12, &ld, &one, A22, &ld);
    return panel_lu(s, A22, m2, n2, ld, j0 + n1);
}

/* The places (map) in the panel of the supernode being updated of the m rows R (ascending), into
 * relative, found once for all the update's columns; returns whether they are consecutive. */
static int relative_places(const SparseLU *s, const int64_t *R, int m, int64_t *relative)
{
    for (int i = 0; i < m; ++i) relative[i] = s->map[R[i]];
    return m > 0 && relative[m - 1] - relative[0] == m - 1;
}

/* column[relative[i]] -= u[i], i < m: the same subtractions, a plain loop where the places are
 * consecutive (a supernode's rows often are). */
static void subtract_at(double *column, const double *u, int m, const int64_t *relative, int consecutive)
{
    if (consecutive) {
        double *c = column + relative[0];
        for (int i = 0; i < m; ++i) c[i] -= u[i];
    } else {
        for (int i = 0; i < m; ++i) column[relative[i]] -= u[i];
    }
}

/* Put supernode K on the list of the supernode that holds its next row to update. */
static void link_supernode(SparseLU *s, int64_t K)
{
    const int64_t *R = s->rows + s->rows_start[K];
    int64_t nr = s->rows_start[K + 1] - s->rows_start[K];
    if (s->cursor[K] >= nr) return;
    int64_t target = s->supernode[R[s->cursor[K]]];
    s->next[K] = s->head[target];
    s->head[target] = K;
}

/* The numeric LU of the matrix assembled into `factor` (see the header), in place.
 * Returns 0, or 1 at an unusable pivot (failed_column, failed_ratio say which). */
int latdyn_sparse_lu_factor(SparseLU *s, double *factor)
{
    double one = 1.0, zero = 0.0;
    s->failed_column = -1;
    s->failed_ratio = 0.0;
    matrix_scales(s, factor);
    for (int64_t J = 0; J < s->n_supernodes; ++J) s->head[J] = -1;
    for (int64_t J = 0; J < s->n_supernodes; ++J) {
        const int64_t c0 = s->first[J], c1 = s->first[J + 1], nc = c1 - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        double *L = factor + s->lower[J], *Ut = factor + s->upper[J];
        for (int64_t k = 0; k < nc; ++k) s->map[c0 + k] = k;
        for (int64_t t = 0; t < nr; ++t) s->map[R[t]] = nc + t;
        /* updates from every finished supernode K with rows in J's columns (Davis §4.7 / CHOLMOD):
         * L(b, a) −= L_K(b, :) U_K(:, a) and U(a, c) −= L_K(a, :) U_K(:, c), a = R_K ∩ [c0, c1),
         * b = R_K ∩ [c0, n), c = R_K ∩ [c1, n) */
        int64_t K = s->head[J];
        while (K >= 0) {
            const int64_t next = s->next[K];
            const int64_t *RK = s->rows + s->rows_start[K];
            const int64_t nrK = s->rows_start[K + 1] - s->rows_start[K];
            const int64_t ncK = s->first[K + 1] - s->first[K];
            const int64_t p1 = s->cursor[K];
            int64_t p2 = p1;
            while (p2 < nrK && RK[p2] < c1) ++p2;
            int na = (int)(p2 - p1), nb = (int)(nrK - p1), nrest = (int)(nrK - p2), k = (int)ncK;
            int ldK = (int)(ncK + nrK), ldU = (int)nrK;
            double *LK = factor + s->lower[K] + ncK + p1, *UK = factor + s->upper[K];
            s->gemm("N", "T", &nb, &na, &k, &one, LK, &ldK, UK + p1, &ldU, &zero, s->update, &nb);
            /* rows b = RK[p1:], of which c = RK[p2:] are the last nrest: their places once */
            const int b_consecutive = relative_places(s, RK + p1, nb, s->relative);
            for (int jj = 0; jj < na; ++jj)
                subtract_at(L + (RK[p1 + jj] - c0) * ld, s->update + (int64_t)jj * nb, nb, s->relative,
                            b_consecutive);
            if (nrest > 0) {
                const int64_t *relative = s->relative + na;
                const int c_consecutive = relative[nrest - 1] - relative[0] == nrest - 1;
                s->gemm("N", "T", &nrest, &na, &k, &one, UK + p2, &ldU, LK, &ldK, &zero, s->update, &nrest);
                for (int jj = 0; jj < na; ++jj)
                    subtract_at(Ut + (RK[p1 + jj] - c0) * nr - nc, s->update + (int64_t)jj * nrest, nrest,
                                relative, c_consecutive);
            }
            s->cursor[K] = p2;
            link_supernode(s, K);
            K = next;
        }
        /* the supernode itself: [L11\U11; L21] by LU of the panel, U12ᵀ = A12ᵀ L11⁻ᵀ */
        if (panel_lu(s, L, (int)ld, (int)nc, (int)ld, c0) != 0) return 1;
        if (nr > 0) {
            int m = (int)nr, n = (int)nc, ldl = (int)ld;
            s->trsm("R", "L", "T", "U", &m, &n, &one, L, &ldl, Ut, &m);
        }
        s->cursor[J] = 0;
        link_supernode(s, J);
    }
    return 0;
}

/* x <- (LU)⁻¹ x, x in the factor's order. */
void latdyn_sparse_lu_solve(const SparseLU *s, const double *factor, double *x)
{
    for (int64_t J = 0; J < s->n_supernodes; ++J) {  /* L y = x */
        const int64_t c0 = s->first[J], nc = s->first[J + 1] - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        const double *L = factor + s->lower[J];
        for (int64_t k = 0; k < nc; ++k) {
            const double *column = L + k * ld, xk = x[c0 + k];
            if (xk == 0.0) continue;
            for (int64_t i = k + 1; i < nc; ++i) x[c0 + i] -= column[i] * xk;
            for (int64_t t = 0; t < nr; ++t) x[R[t]] -= column[nc + t] * xk;
        }
    }
    for (int64_t J = s->n_supernodes - 1; J >= 0; --J) {  /* U x = y */
        const int64_t c0 = s->first[J], nc = s->first[J + 1] - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        const double *U = factor + s->lower[J], *Ut = factor + s->upper[J];
        for (int64_t k = 0; k < nc; ++k) {
            const double *column = Ut + k * nr;
            double sum = 0.0;
            for (int64_t t = 0; t < nr; ++t) sum += column[t] * x[R[t]];
            x[c0 + k] -= sum;
        }
        for (int64_t k = nc - 1; k >= 0; --k) {
            const double *column = U + k * ld;
            double xk = x[c0 + k] / column[k];
            x[c0 + k] = xk;
            for (int64_t i = 0; i < k; ++i) x[c0 + i] -= column[i] * xk;
        }
    }
}

/* x <- (LU)⁻ᵀ x = U⁻ᵀ L⁻ᵀ x, x in the factor's order: the same factors read the other way
 * (the adjoint's solves, latdyn/analyses/adjoint_sensitivities.py). */
void latdyn_sparse_lu_solve_transposed(const SparseLU *s, const double *factor, double *x)
{
    for (int64_t J = 0; J < s->n_supernodes; ++J) {  /* Uᵀ y = x: U11ᵀ, then U12ᵀ's rows scattered */
        const int64_t c0 = s->first[J], nc = s->first[J + 1] - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        const double *U = factor + s->lower[J], *Ut = factor + s->upper[J];
        for (int64_t k = 0; k < nc; ++k) {
            const double *column = U + k * ld;
            double sum = 0.0;
            for (int64_t i = 0; i < k; ++i) sum += column[i] * x[c0 + i];
            x[c0 + k] = (x[c0 + k] - sum) / column[k];
        }
        for (int64_t k = 0; k < nc; ++k) {
            const double *column = Ut + k * nr, xk = x[c0 + k];
            if (xk == 0.0) continue;
            for (int64_t t = 0; t < nr; ++t) x[R[t]] -= column[t] * xk;
        }
    }
    for (int64_t J = s->n_supernodes - 1; J >= 0; --J) {  /* Lᵀ x = y: L21ᵀ gathered, then L11ᵀ (unit) */
        const int64_t c0 = s->first[J], nc = s->first[J + 1] - c0;
        const int64_t *R = s->rows + s->rows_start[J];
        const int64_t nr = s->rows_start[J + 1] - s->rows_start[J], ld = nc + nr;
        const double *L = factor + s->lower[J];
        for (int64_t k = 0; k < nc; ++k) {
            const double *column = L + k * ld + nc;
            double sum = 0.0;
            for (int64_t t = 0; t < nr; ++t) sum += column[t] * x[R[t]];
            x[c0 + k] -= sum;
        }
        for (int64_t k = nc - 1; k >= 0; --k) {
            const double *column = L + k * ld;
            double sum = 0.0;
            for (int64_t i = k + 1; i < nc; ++i) sum += column[i] * x[c0 + i];
            x[c0 + k] -= sum;
        }
    }
}
