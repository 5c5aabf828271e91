/*
 * The reduction's part of an event's impulse-weight derivative on a model with rigid links or guides
 * (latdyn/analyses/weight_derivative.py, "Rigid links and guides"; transient_sensitivities.py
 * _linked_weight_derivative).
 *
 * The reduced weight's product W_red w = Pᵀ W_all P w (+ the geometric term) moves along δq by
 * (∂Pᵀ/∂q[δq]) y with y = W_all P w among its exact terms: the geometric term of y, ∂(Pᵀ y)/∂q at fixed y, the
 * forward step's own (links.c geometric_term, from the generated hinge_wrench, slide_wrench, root_wrench and the
 * closures' wrenches), here applied to vectors δq instead of scattered into the matrix.
 *
 * Runtime code, written by hand: it holds no physics.
 */

/* out (n_total + 1, zeroed here) rows below n_dofs: ∂(Pᵀ y)/∂q at fixed y, times `vector` (n_total + 1) on the
 * columns marked in `columns` (n_total + 1), at c (its dependent nodes completed by latdyn_complete_links: J of c
 * in the links' buffers); y's dependent nodes' rows from `y` (n_total + 1, every coordinate's row before the
 * reduction). Nothing without rigid links. */
void latdyn_linked_geometric_product(const Model *m, const Configuration *c, const double *y, const int64_t *columns,
                                     const double *vector, double *out)
{
    memset(out, 0, sizeof(double) * (size_t)(m->n_total + 1));
    if (!m->links) return;
    const Links *L = m->links;
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* the wrenches anew: geometric_term's closures change them */
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = y[d[k]];
    }
    const GeometricProduct product = {columns, vector, m->n_dofs, out};
    geometric_term(m, c, NULL, &product);
}
