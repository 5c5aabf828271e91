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
 * The LAPACK routines are those latdyn/assembly/factorization.py chooses: SciPy's
 * (library.lapack_address: cython_lapack function pointers, 32-bit integers) or, for the band LU
 * where NumPy's own ILP64 OpenBLAS is loaded (library.numpy_lapack), NumPy's, by their Fortran symbols with a
 * character argument's hidden length (a 32-bit OpenBLAS of NumPy's is not taken: the 32-bit path passes no
 * hidden length, as SciPy's cython_lapack takes none): `integer_bytes` says which width the routines take, and with 8 the pivots pass through `wide_pivots` (n
 * int64), the caller's pivots staying n ints either way. The BLAS kernels of the sparse LU are
 * SciPy's. Around every call, the OpenBLAS behind the routines is held to one thread and the
 * caller's setting restored (latdyn/numerics/linalg.py: on a shared machine a second thread
 * costs far more than it gains).
 */
#include <stddef.h> /* size_t: a Fortran character argument's hidden length */
#include "sparse_lu.c"

typedef void (*lapack_getrf)(int *, int *, double *, int *, int *, int *);
typedef void (*lapack_getrs)(char *, int *, int *, double *, int *, int *, double *, int *, int *);
typedef void (*lapack_gbtrf)(int *, int *, int *, int *, double *, int *, int *, int *);
typedef void (*lapack_gbtrs)(char *, int *, int *, int *, int *, double *, int *, int *, double *, int *, int *);
/* the same routines of an ILP64 LAPACK (every integer 64 bits), called by their Fortran symbols: a
 * character argument's hidden length (gfortran's size_t after the others) is passed */
typedef void (*lapack64_getrf)(int64_t *, int64_t *, double *, int64_t *, int64_t *, int64_t *);
typedef void (*lapack64_getrs)(char *, int64_t *, int64_t *, double *, int64_t *, int64_t *, double *, int64_t *,
                               int64_t *, size_t);
typedef void (*lapack64_gbtrf)(int64_t *, int64_t *, int64_t *, int64_t *, double *, int64_t *, int64_t *, int64_t *);
typedef void (*lapack64_gbtrs)(char *, int64_t *, int64_t *, int64_t *, int64_t *, double *, int64_t *, int64_t *,
                               double *, int64_t *, int64_t *, size_t);

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
    int64_t integer_bytes; /* the LAPACK routines' integer width: 4, or 8 (ILP64) */
    int64_t *wide_pivots;  /* n int64: the pivots of an ILP64 LAPACK (integer_bytes 8 only) */
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
    } else if (f->integer_bytes == 8) {
        int64_t n64 = f->n, kl = f->kl, ku = f->ku, ldab = f->ldab, info64 = 0;
        if (f->kind == FACTOR_BAND)
            ((lapack64_gbtrf)f->gbtrf)(&n64, &n64, &kl, &ku, factor, &ldab, f->wide_pivots, &info64);
        else
            ((lapack64_getrf)f->getrf)(&n64, &n64, factor, &n64, f->wide_pivots, &info64);
        for (int64_t i = 0; i < n64; ++i) pivots[i] = (int)f->wide_pivots[i];
        info = (int)info64; /* a pivot's index or an argument's: below n */
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
    } else if (f->integer_bytes == 8) {
        int64_t n64 = f->n, nrhs64 = n_rhs, kl = f->kl, ku = f->ku, ldab = f->ldab, info64 = 0;
        for (int64_t i = 0; i < n64; ++i) f->wide_pivots[i] = pivots[i];
        if (f->kind == FACTOR_BAND)
            ((lapack64_gbtrs)f->gbtrs)(&trans, &n64, &kl, &ku, &nrhs64, (double *)factor, &ldab, f->wide_pivots, x, &n64,
                                       &info64, (size_t)1);
        else
            ((lapack64_getrs)f->getrs)(&trans, &n64, &nrhs64, (double *)factor, &n64, f->wide_pivots, x, &n64, &info64,
                                       (size_t)1);
        info = (int)info64;
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
