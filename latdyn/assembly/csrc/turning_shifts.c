/*
 * The turning shifts of the geometry parameters (latdyn/analyses/geometry_sensitivities.py, its module docstring and
 * ReferenceGeometry.turning): an edge's own point o of a rigid link or guide moved by δo on a part A that turns
 * translates the subtree S below the edge by d = T_A δo, fixed in A's axes, so at fixed coordinates and rates its
 * nodes' velocities move by ω_A × d and their accelerations by α_A × d + ω_A × (ω_A × d) (A's rigid field), and
 * ∂r/∂p on the assembled coordinates (before the reduction) gains K d + C δv + M δa (the exact K, C, M) and, on A's
 * rotational rows, d × F_S (F_S the assembled residual's force rows of S summed: the columns of J that reach A move
 * S's points by g × d per unit rate).
 *
 * A rigid link's vector v = B − A moved (its length or direction: a gimbal's ring offset) is such a shift with A the
 * link node L, and its joint body's block (m, c, I) moves with v: latdyn_link_inertia_forces.
 *
 * The one implementation of these lines: ReferenceGeometry.shifts, _add_shifts, _add_link_inertia and moments_turned call
 * latdyn_turning_shifts and latdyn_turning_shift_forces from Python (the per-step path, events, probes), and the loop
 * of steps calls latdyn_turning_shift_forces in its ∂r/∂p (sensitivity_loop.c parameter_columns) on M, C and the
 * exact K scattered onto the assembler's pattern from the evaluation latdyn_linked_exact_values left in Work
 * (latdyn_exact_matrix_values, as Assembler.assembled_exact_values scatters them from Python).
 *
 * Runtime code, written by hand: three cross products of a rigid body's field and a sparse product.
 */

/* The turning shifts of one run (ReferenceGeometry lays it out once). */
typedef struct TurningShifts {
    int64_t n;                      /* the edges of ReferenceGeometry.turning */
    const int64_t *anchor, *column; /* n each: the part A that turns, the parameter's column */
    const double *moved;            /* n × 3: δo in A's axes */
    const int64_t *below_from;      /* n + 1: each edge's subtree in `below` */
    const int64_t *below;           /* the subtrees' nodes (ReferenceGeometry._below) */
    int64_t n_nodes;
    const int64_t *node_dofs;       /* n_nodes × 6 */
    int64_t n_assembled;
    double *shift;                  /* n × 3: d = T_A δo of each edge (out) */
    double *moves;                  /* 3 × n_nodes × 3 × k: d, δv, δa of every node (out) */
    double *assembled;              /* 3 × n_assembled × k: scratch */
    /* the loop of steps (sensitivity_loop.c): M, C and the exact K on the assembler's pattern from the evaluation in
     * Work (Assembler.exact_segments' arguments; the bodies' inertia stiffness copied into `stiffness` from the
     * loop's, n_stiffness doubles), `mck` 3 nnz; n_segments 0: not laid out for the loop */
    int64_t n_segments;
    const int64_t *counts;
    const double *const *first;
    const double *const *second;
    const int64_t *const *indices;
    const int64_t *positions;
    double *stiffness;
    int64_t n_stiffness;
    const int64_t *indptr, *pattern; /* the assembler's pattern (CSR, n_assembled rows) */
    int64_t nnz;
    double *mck;
    /* the rigid links whose vector v = B − A moves (ReferenceGeometry.link_moves): their joint body's row at the link
     * node L's frame and motion by its block moved (the generated joint_body at (δm, c, δI), joint_body_D_com along
     * δc); n_links 0: none */
    int64_t n_links;
    const int64_t *link_node, *link_column;   /* n_links each */
    const double *link_moved_block;           /* n_links × 13: (δm, c, δI) */
    const double *link_block;                 /* n_links × 13: (m, c, I) */
    const double *link_com_move;              /* n_links × 3: δc */
    kernel_joint_body body_kernel;            /* the generated joint_body */
    kernel_body_stiffness com_kernel;         /* the generated joint_body_D_com */
    const double *gravity;                    /* 3: g (the loop of steps' load factor 1) */
} TurningShifts;

/* t->shift and t->moves at the configuration (T: n_nodes × 9, w and alpha: n_nodes × 3) for k columns
 * (ReferenceGeometry.shifts): each edge's d = T_A δo and its subtree's (d, ω_A × d, α_A × d + ω_A × (ω_A × d)). */
void latdyn_turning_shifts(const TurningShifts *t, int64_t k, const double *T, const double *w, const double *alpha)
{
    const int64_t plane = t->n_nodes * 3 * k;
    memset(t->moves, 0, sizeof(double) * (size_t)(3 * plane));
    for (int64_t e = 0; e < t->n; ++e) {
        const int64_t A = t->anchor[e], col = t->column[e];
        const double *R = T + 9 * A, *o = t->moved + 3 * e, *wA = w + 3 * A, *aA = alpha + 3 * A;
        double *d = t->shift + 3 * e, spun[3], turned[3], whirled[3];
        matvec3(R, o, d);   /* d = T_A δo (matvec3 and cross: evaluate.c's, in this translation unit) */
        cross(wA, d, spun);
        cross(aA, d, turned);
        cross(wA, spun, whirled);
        for (int64_t b = t->below_from[e]; b < t->below_from[e + 1]; ++b) {
            const int64_t node = t->below[b];
            for (int i = 0; i < 3; ++i) {
                const int64_t at = (node * 3 + i) * k + col;
                t->moves[at] += d[i];
                t->moves[plane + at] += spun[i];
                t->moves[2 * plane + at] += turned[i] + whirled[i];
            }
        }
    }
}

/* Adds ∂r/∂p of the turning shifts into total ((n_total + 1) × k, row-major) at the configuration (T, w, alpha):
 * K d + C δv + M δa (with `inertia`; else K d) on the assembled rows, M, C and K the values `mck` (3 × nnz, in turn) of
 * the CSR pattern (indptr, pattern) on the n_assembled coordinates, then d × F_S on each anchor's rotational rows,
 * F_S from r_all (the assembled residual, n_assembled). ReferenceGeometry._add_shifts. */
void latdyn_turning_shift_forces(const TurningShifts *t, int64_t k, int64_t inertia, const double *T, const double *w,
                                 const double *alpha, const int64_t *indptr, const int64_t *pattern, int64_t nnz,
                                 const double *mck, const double *r_all, double *total)
{
    latdyn_turning_shifts(t, k, T, w, alpha);
    const int64_t plane = t->n_nodes * 3 * k, n_asm = t->n_assembled, size = n_asm * k;
    double *on = t->assembled;   /* d, δv, δa on the assembled coordinates: a node's translations, its first three */
    memset(on, 0, sizeof(double) * (size_t)(3 * size));
    for (int64_t node = 0; node < t->n_nodes; ++node)
        for (int i = 0; i < 3; ++i) {
            const int64_t dof = t->node_dofs[6 * node + i];
            if (dof >= n_asm) continue;
            for (int part = 0; part < 3; ++part)
                memcpy(on + part * size + dof * k, t->moves + part * plane + (node * 3 + i) * k, sizeof(double) * (size_t)k);
        }
    const double *parts[3] = {mck + 2 * nnz, mck + nnz, mck};   /* K d, C δv, M δa */
    for (int64_t row = 0; row < n_asm; ++row)
        for (int64_t col = 0; col < k; ++col) {
            double change = 0.0;
            for (int part = 0; part < (inertia ? 3 : 1); ++part) {
                const double *values = parts[part], *x = on + part * size + col;
                for (int64_t p = indptr[row]; p < indptr[row + 1]; ++p) change += values[p] * x[pattern[p] * k];
            }
            total[row * k + col] += change;
        }
    for (int64_t e = 0; e < t->n; ++e) {   /* d × F_S on A's rotational rows */
        double force[3] = {0.0, 0.0, 0.0}, moment[3];
        for (int64_t b = t->below_from[e]; b < t->below_from[e + 1]; ++b)
            for (int i = 0; i < 3; ++i) force[i] += r_all[t->node_dofs[6 * t->below[b] + i]];
        cross(t->shift + 3 * e, force, moment);
        const int64_t *rotation = t->node_dofs + 6 * t->anchor[e] + 3;
        for (int i = 0; i < 3; ++i) total[rotation[i] * k + t->column[e]] += moment[i];
    }
}

/* Adds into total ((n_total + 1) × k) ∂r/∂p of the rigid links whose vector moves (ReferenceGeometry._add_link_inertia):
 * each link's joint body row (Eqs. 2, 59) at its node's frame T and motion (ω, a, α; zero where not `inertia`) under
 * `gravity` (λ g), by its block moved: linear in (m, I) at a fixed c, so joint_body at (δm, c, δI), and by c
 * joint_body_D_com (of degree two in c) times δc. */
void latdyn_link_inertia_forces(const TurningShifts *t, int64_t k, int64_t inertia, const double *gravity,
                                const double *T, const double *w, const double *a, const double *alpha, double *total)
{
    for (int64_t l = 0; l < t->n_links; ++l) {
        const int64_t node = t->link_node[l];
        double motion[9] = {0.0}, force[6], blocks[108], by_com[18];
        if (inertia) {
            memcpy(motion, w + 3 * node, 3 * sizeof(double));
            memcpy(motion + 3, a + 3 * node, 3 * sizeof(double));
            memcpy(motion + 6, alpha + 3 * node, 3 * sizeof(double));
        }
        t->body_kernel(1, T + 9 * node, motion, t->link_moved_block + 13 * l, gravity, force, blocks, blocks + 36,
                       blocks + 72);
        t->com_kernel(1, T + 9 * node, motion, t->link_block + 13 * l, gravity, by_com);
        const double *dc = t->link_com_move + 3 * l;
        const int64_t *dofs = t->node_dofs + 6 * node;
        for (int j = 0; j < 6; ++j)
            total[dofs[j] * k + t->link_column[l]] += force[j] + (by_com[3 * j] * dc[0] + by_com[3 * j + 1] * dc[1]
                                                                  + by_com[3 * j + 2] * dc[2]);
    }
}

/* The loop of steps' ∂r/∂p of the turning shifts (sensitivity_loop.c parameter_columns, before the reduction) at c,
 * with Work holding the evaluation at c with the inertia tangent and body_D the joint bodies' inertia stiffness there
 * (latdyn_linked_exact_values): M, C and the exact K scattered onto the assembler's pattern, then
 * latdyn_turning_shift_forces on them and the evaluation's r_all; then the moved links' rows. */
static void turning_shift_columns(const Configuration *c, Work *w, const TurningShifts *t, const double *body_D,
                                  int64_t k, double *total)
{
    if (t->n > 0) {   /* (a link's vector moved on a link node that never turns: its rows alone) */
        if (t->n_stiffness) memcpy(t->stiffness, body_D, sizeof(double) * (size_t)t->n_stiffness);
        latdyn_exact_matrix_values(t->n_segments, t->counts, t->first, t->second, t->indices, t->positions,
                                   3 * t->nnz, t->mck);
        latdyn_turning_shift_forces(t, k, 1, c->T, c->w, c->alpha, t->indptr, t->pattern, t->nnz, t->mck, w->total,
                                    total);
    }
    latdyn_link_inertia_forces(t, k, 1, t->gravity, c->T, c->w, c->a, c->alpha, total);   /* ReferenceGeometry.add's order */
}
