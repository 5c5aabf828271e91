/*
 * A model with rigid links or guides on its minimum coordinates for the transient sensitivities' step: M, C and
 * the exact K apart (dense), and the parameters' columns ∂r/∂p reduced, by the reduction the forward step uses
 * (links.c: assemble_linked_into, the residual's Pᵀ of reduce_links), so that the step from Python
 * (latdyn/analyses/transient_sensitivities.py, TransientSensitivities._step_system) and the loop of steps
 * (sensitivity_loop.c) make the same matrices from the same calls.
 *
 * Runtime code, written by hand: it holds no physics. The blocks are the evaluation's (latdyn_evaluate with the
 * inertia tangent), the joint bodies' inertia stiffness the generated joint_body_inertia_stiffness's
 * (latdyn_joint_body_inertia_stiffness), the reduction links.c's.
 */

/* M, C and the exact K at c, time t (load factor 1, with inertia and the inertia tangent, the joint bodies' inertia
 * stiffness added to their K blocks where body_kernel is not NULL, the dependent rates' q-dependence in K) on the
 * minimum coordinates: each n × n, row-major, one after the other in `out` (3 n²). c's dependent nodes completed
 * (latdyn_complete_links). `storage`: the iteration matrix's storage size (m->factorization), a buffer other than
 * w->matrix (modified Newton's factors); `gather` (n², row-major): each entry's offset in that storage (−1: none).
 * The evaluation is left in w. */
void latdyn_linked_exact_matrices(const Model *m, Work *w, const Configuration *c, double t,
                                  kernel_body_stiffness body_kernel, const double *body_rows,
                                  const double *body_gravity, double *body_scratch, double *body_D,
                                  const int64_t *gather, double *storage, double *out)
{
    const Links *L = m->links;
    const int64_t n = m->n_dofs;
    EvaluationControl e = {t, 1.0, 1, 1, 1, 0.0};
    latdyn_evaluate(m, w, c, &e);
    if (body_kernel != NULL)
        latdyn_joint_body_inertia_stiffness(m, c, body_kernel, body_rows, body_gravity, body_scratch, body_D);
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* the dependent rows of r_all, for the geometric term */
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = w->total[d[k]];
    }
    const double coefficients[3][2] = {{1.0, 0.0}, {0.0, 1.0}, {0.0, 0.0}};
    for (int part = 0; part < 3; ++part) {
        assemble_linked_into(m, w, c, coefficients[part][0], coefficients[part][1], part == 2, 1, part == 2,
                             body_kernel != NULL ? body_D : NULL, storage);
        double *to = out + part * n * n;
        for (int64_t p = 0; p < n * n; ++p) to[p] = gather[p] >= 0 ? storage[gather[p]] : 0.0;
    }
}

/* Pᵀ total: the k columns `total` ((n_total + 1) × k, row-major: all coordinates) on the minimum coordinates into
 * `out` (n × k): the free rows, then each dependent node's rows carried onto the free coordinates its slot moves
 * with (Jᵀ r_dep, reduce_links's order); `out` may be `total` (its rows < n replaced). The links' J is that of the
 * configuration last completed. */
void latdyn_linked_reduce_columns(const Model *m, const double *total, int64_t k, double *out)
{
    const Links *L = m->links;
    const int64_t n = m->n_dofs, W = L->width;
    if (out != total) memcpy(out, total, sizeof(double) * (size_t)(n * k));
    for (int64_t s = 0; s < L->n_slots; ++s) {
        if (L->slot_edge[s] < 0) continue;
        const double *J = L->jacobian + 6 * W * s;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s], *columns = L->slot_columns + W * s;
        for (int64_t j = 0; j < L->slot_count[s]; ++j) {
            if (columns[j] >= n) continue;
            for (int64_t col = 0; col < k; ++col) {
                double f = 0.0;
                for (int q = 0; q < 6; ++q) f += J[W * q + j] * total[d[q] * k + col];
                out[columns[j] * k + col] += f;
            }
        }
    }
}
