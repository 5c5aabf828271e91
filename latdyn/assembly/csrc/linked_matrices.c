/*
 * A model with rigid links or guides on its minimum coordinates, for every analysis driven from Python, by the
 * reduction the forward step uses (links.c: assemble_linked_into, reduce_total), so that the reduction is written
 * once:
 *   - latdyn_linked_matrices: M, C and K (and K without the geometric term) of an evaluation, static or with
 *     inertia, at any load factor, as the values of the iteration matrix's pattern (latdyn/assembly/linked.py:
 *     statics and continuation, modes and linearisation, buckling, impulses, events);
 *   - latdyn_linked_reduce_total: the residual and reactions;
 *   - for the transient sensitivities' step, M, C and the exact K apart (dense) and the parameters' columns ∂r/∂p
 *     reduced, so that the step from Python (latdyn/analyses/transient_sensitivities.py,
 *     TransientSensitivities._step_system) and the loop of steps (sensitivity_loop.c) make the same matrices from
 *     the same calls.
 *
 * Runtime code, written by hand: it holds no physics. The blocks are the evaluation's (latdyn_evaluate), the joint
 * bodies' inertia stiffness the generated joint_body_inertia_stiffness's (latdyn_joint_body_inertia_stiffness), the
 * reduction links.c's.
 */

/* Part `part` of the evaluation left in w (at c, its dependent nodes completed) on the minimum coordinates into
 * `storage` (a storage of the iteration matrix's layout other than w->matrix): 0 M, 1 C, 2 K, 3 K without the
 * geometric term ∂(Pᵀ)/∂q · r_all (the material stiffness, latdyn/model/model.py check_held); `inertia` 0 for a
 * static evaluation, `with_inertia_tangent` the elements' inertia tangent in K, `rates` the dependent rates'
 * q-dependence in K, body_D (NULL: none) the joint bodies' inertia stiffness. assemble_linked_into reads the
 * dependent nodes' residual rows from L->wrench (and a closure's pin grows its own there): they are set anew. */
static void linked_part(const Model *m, Work *w, const Configuration *c, int part, int inertia,
                        int with_inertia_tangent, int rates, const double *body_D, double *storage)
{
    const Links *L = m->links;
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* the dependent rows of r_all, for the geometric term */
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = part == 3 ? 0.0 : w->total[d[k]];
    }
    const double coefficients[4][2] = {{1.0, 0.0}, {0.0, 1.0}, {0.0, 0.0}, {0.0, 0.0}};
    assemble_linked_into(m, w, c, coefficients[part][0], coefficients[part][1], part >= 2, inertia,
                         with_inertia_tangent, rates, body_D, storage);
}

/* M, C and the exact K at c, time t (load factor 1, with inertia and the inertia tangent, the joint bodies' inertia
 * stiffness added to their K blocks where body_kernel is not NULL, the dependent rates' q-dependence in K) on the
 * minimum coordinates, `count` entries each, one after the other in `out` (3 count). c's dependent nodes completed
 * (latdyn_complete_links). `storage`: the iteration matrix's storage size (m->factorization), a buffer other than
 * w->matrix (modified Newton's factors); `gather` (count): each entry's offset in that storage (−1: none): n²,
 * row-major, for the dense n × n (latdyn_linked_exact_matrices), or above DENSE_LIMIT coordinates or on a sparse
 * storage the iteration matrix's pattern on the minimum coordinates, row by row (latdyn.assembly.linked.linked_pattern;
 * Assembler.linked_exact_pattern). The evaluation is left in w. */
void latdyn_linked_exact_values(const Model *m, Work *w, const Configuration *c, double t,
                                kernel_body_stiffness body_kernel, const double *body_rows, const double *body_gravity,
                                double *body_scratch, double *body_D, const int64_t *gather, int64_t count,
                                double *storage, double *out)
{
    EvaluationControl e = {t, 1.0, 1, 1, 1, 0.0};
    latdyn_evaluate(m, w, c, &e);
    if (body_kernel != NULL)
        latdyn_joint_body_inertia_stiffness(m, c, body_kernel, body_rows, body_gravity, body_scratch, body_D);
    for (int part = 0; part < 3; ++part) {
        linked_part(m, w, c, part, 1, 1, part == 2, body_kernel != NULL ? body_D : NULL, storage);
        double *to = out + part * count;
        for (int64_t p = 0; p < count; ++p) to[p] = gather[p] >= 0 ? storage[gather[p]] : 0.0;
    }
}

/* latdyn_linked_exact_values on the dense n × n (gather n², out 3 n²). */
void latdyn_linked_exact_matrices(const Model *m, Work *w, const Configuration *c, double t,
                                  kernel_body_stiffness body_kernel, const double *body_rows,
                                  const double *body_gravity, double *body_scratch, double *body_D,
                                  const int64_t *gather, double *storage, double *out)
{
    latdyn_linked_exact_values(m, w, c, t, body_kernel, body_rows, body_gravity, body_scratch, body_D, gather,
                               m->n_dofs * m->n_dofs, storage, out);
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

/* M, C and K (and with `material` K without the geometric term) of the evaluation left in w (latdyn_evaluate at c,
 * with `inertia` or static, with the elements' inertia tangent where `with_inertia_tangent`; c's dependent nodes
 * completed) on the minimum coordinates, by the forward step's reduction (assemble_linked_into; `rates`: the
 * dependent rates' q-dependence in K; body_D: the joint bodies' inertia stiffness, NULL: none): each the `count`
 * values at `offsets` of `storage` (the iteration matrix's storage, not w->matrix: the entries of its pattern), one
 * after the other in `out` ((3 + material) × count). latdyn/assembly/linked.py, for every analysis driven from
 * Python (statics, modes, buckling, impulses, events). */
void latdyn_linked_matrices(const Model *m, Work *w, const Configuration *c, int64_t inertia,
                            int64_t with_inertia_tangent, int64_t rates, int64_t material, const double *body_D,
                            const int64_t *offsets, int64_t count, double *storage, double *out)
{
    for (int part = 0; part < 3 + (material != 0); ++part) {
        linked_part(m, w, c, part, (int)inertia, (int)with_inertia_tangent, part >= 2 && rates, body_D, storage);
        double *to = out + part * count;
        for (int64_t p = 0; p < count; ++p) to[p] = offsets[p] >= 0 ? storage[offsets[p]] : 0.0;
    }
}

/* `total` (n_total + 1: the residual on all coordinates, then the reactions) reduced onto the minimum coordinates in
 * place, as the forward step reduces its evaluation (links.c reduce_total); the links' J is that of the
 * configuration last completed. */
void latdyn_linked_reduce_total(const Model *m, double *total)
{
    reduce_total(m, total);
}
