/*
 * The LU factorization of a square matrix and its solves: the one used by the compiled Newton
 * step (newton_step.c) and by every analysis driven from Python (latdyn/assembly/factorization.py,
 * which chooses the storage and describes it in a Factorization struct).
 *
 * Storage, in a double array of `size` entries, in the factor's order (coordinate i of the
 * caller is row and column permutation[i] of the stored matrix):
 *   dense  (kind 0): n x n column-major, LAPACK getrf / getrs with row pivots (pivots: n ints);
 *   band   (kind 1): LAPACK's (2 kl + ku + 1) x n band storage after a reverse Cuthill-McKee
 *                    order, gbtrf / gbtrs with row pivots (pivots: n ints);
 *   sparse (kind 2): the factor storage of the supernodal LU of sparse_lu.c (no pivots).
 * The LAPACK routines are SciPy's (cython_lapack function pointers), as are the BLAS kernels of
 * the sparse LU. Around every call, OpenBLAS is held to one thread and the caller's setting
 * restored (latdyn/numerics/linalg.py: on a shared machine a second thread costs far more than
 * it gains).
 */
#include "sparse_lu.c"

typedef void (*lapack_getrf)(int *, int *, double *, int *, int *, int *);
typedef void (*lapack_getrs)(char *, int *, int *, double *, int *, int *, double *, int *, int *);
typedef void (*lapack_gbtrf)(int *, int *, int *, int *, double *, int *, int *, int *);
typedef void (*lapack_gbtrs)(char *, int *, int *, int *, int *, double *, int *, int *, double *, int *, int *);

enum { FACTOR_DENSE = 0, FACTOR_BAND = 1, FACTOR_SPARSE = 2 };

/* The storage of one factorization (see the header). */
typedef struct {
    int64_t n, kind, kl, ku, ldab, size;
    const int64_t *permutation; /* the place of each coordinate in the factor's order */
    lapack_getrf getrf;
    lapack_getrs getrs;
    lapack_gbtrf gbtrf;
    lapack_gbtrs gbtrs;
    SparseLU *sparse_lu; /* kind 2 only */
    /* OpenBLAS's thread count of the library behind LAPACK and BLAS (NULL: not pinned) */
    int (*get_blas_threads)(void);
    void (*set_blas_threads)(int);
} Factorization;

static int hold_one_thread(const Factorization *f)
{
    int threads = f->get_blas_threads ? f->get_blas_threads() : 1;
    if (threads != 1) f->set_blas_threads(1);
    return threads;
}

static void release_threads(const Factorization *f, int threads)
{
    if (threads != 1) f->set_blas_threads(threads);
}

/* The LU of the matrix stored in `factor`, in place. Returns 0, or LAPACK's info / the sparse
 * LU's failure (nonzero: singular, or a pivot too small for the sparse LU). */
int64_t latdyn_factor(const Factorization *f, double *factor, int *pivots)
{
    int n = (int)f->n, info = 0;
    int threads = hold_one_thread(f);
    if (f->kind == FACTOR_SPARSE) {
        info = (int)latdyn_sparse_lu_factor(f->sparse_lu, factor);
    } else if (f->kind == FACTOR_BAND) {
        int kl = (int)f->kl, ku = (int)f->ku, ldab = (int)f->ldab;
        f->gbtrf(&n, &n, &kl, &ku, factor, &ldab, pivots, &info);
    } else {
        f->getrf(&n, &n, factor, &n, pivots, &info);
    }
    release_threads(f, threads);
    return info;
}

/* x <- A⁻¹ x (trans 'N') or A⁻ᵀ x (trans 'T') for n_rhs right-hand sides (columns of x, leading
 * dimension n), in place, in the factor's order, with the factors of latdyn_factor: getrs / gbtrs with
 * trans, the sparse LU's factors read forwards or the other way. The order is a symmetric permutation,
 * so Aᵀ's is A's. Returns LAPACK's info (0). */
static int64_t solve_with_factors(const Factorization *f, const double *factor, const int *pivots, int64_t n_rhs,
                                  double *x, char trans)
{
    int n = (int)f->n, nrhs = (int)n_rhs, info = 0;
    int threads = hold_one_thread(f);
    if (f->kind == FACTOR_SPARSE) {
        for (int64_t k = 0; k < n_rhs; ++k) {
            if (trans == 'T')
                latdyn_sparse_lu_solve_transposed(f->sparse_lu, factor, x + k * f->n);
            else
                latdyn_sparse_lu_solve(f->sparse_lu, factor, x + k * f->n);
        }
    } else if (f->kind == FACTOR_BAND) {
        int kl = (int)f->kl, ku = (int)f->ku, ldab = (int)f->ldab;
        f->gbtrs(&trans, &n, &kl, &ku, &nrhs, (double *)factor, &ldab, (int *)pivots, x, &n, &info);
    } else {
        f->getrs(&trans, &n, &nrhs, (double *)factor, &n, (int *)pivots, x, &n, &info);
    }
    release_threads(f, threads);
    return info;
}

/* x <- A⁻¹ x: solve_with_factors, 'N'. */
int64_t latdyn_solve(const Factorization *f, const double *factor, const int *pivots, int64_t n_rhs, double *x)
{
    return solve_with_factors(f, factor, pivots, n_rhs, x, 'N');
}

/* x <- A⁻ᵀ x from the same factors: solve_with_factors, 'T'. */
int64_t latdyn_solve_transposed(const Factorization *f, const double *factor, const int *pivots, int64_t n_rhs,
                                double *x)
{
    return solve_with_factors(f, factor, pivots, n_rhs, x, 'T');
}
