/*
 * The links' second derivatives in an event's impulse-weight derivative on a model with rigid links or guides
 * (latdyn/analyses/weight_derivative.py, "Rigid links and guides": linked_geometric_derivative along the
 * configuration, linked_geometric_rate_in_time along the prescribed motions in time).
 *
 * links.c geometric_term is G(q) = ∂(Pᵀ y)/∂q at fixed y, composed along the tree of edges from the slots' maps J
 * and the generated wrench kernels' first derivatives; linked_weight.c applies it to a vector w. Here its
 * directional derivative along a move δq of every coordinate (free, or prescribed: q̇_p, the move in time),
 * at fixed y and w,
 *
 *     δ(G w) = d/dε G(q ⊕ ε δq) w |ε=0,
 *
 * the same composition differentiated by the product rule, each factor's move exact:
 *
 *   the slots' configurations  δ_s = (δx_s, δπ_s) = J_s δq (a root's J the identity);
 *   the slots' maps            δJ_c = δ(transfer) J_p + transfer δJ_p, the edge's column δ(joint), edge by edge in
 *                              tree order: δ(transfer) J_p e_j = D(J_p e_j) [δ_p; δθ] and δ(joint) = D(θ̇ = 1) [δ_p; δθ],
 *                              D the edge kind's generated *_rates_D_q (12 × 7) at the parent's rates J_p e_j
 *                              (rates 0 and θ̇ = 1 for the joint's column; the child's rates are linear in them);
 *   a closure (a leaf on pin p) J_pᵀ D J_p on the pin's columns with g = ∂x_cᵀ r joining the pin's wrench:
 *                              δ(J_pᵀ D J_p) = δJ_pᵀ D J_p + J_pᵀ δD J_p + J_pᵀ D δJ_p, δD = ∂D/∂p δx_p
 *                              (*_closure_wrench_D_q_D_q), δg = D δx_p (the pin's wrench moves with it);
 *   a root's rows              (D_root δ_r-columns + D_root,y J_c): D_root is linear in the wrench (f, m) alone,
 *                              so δD_root = D_root(δr) (root_wrench at the wrench's move, 0 but below a closure)
 *                              and δ(D_root,y J_c) = δD_root,y J_c + D_root,y δJ_c;
 *   a hinge's or slide's row   Dh [J_p; J_c]: δDh = H [δ_p; δx_c] + Dh(δr) (H the generated hinge_wrench_D_q_D_q,
 *                              slide_wrench_D_q_D_q; Dh linear in (f, m)), δ(Dh [J_p; J_c]) = δDh [J_p; J_c]
 *                              + Dh [δJ_p; δJ_c].
 *
 * Runtime code, written by hand: it holds no physics (every derivative is a generated kernel's).
 */

/* the generated second derivatives (codegen/joints.py): hinge_wrench_D_q_D_q, slide_wrench_D_q_D_q (parent, edge,
 * wrench → 9 × 9), slider_closure_wrench_D_q_D_q, rod_closure_wrench_D_q_D_q (pin, edge, wrench → 9 × 3) */
typedef void (*kernel_second)(int64_t, const double *, const double *, const double *, double *);

/* the parent input (24) of an edge kernel at c with the rates `rates` (6: v, w; NULL: zero) and no accelerations */
static void second_parent_input(const Configuration *c, int64_t p, const double *rates, double *parent)
{
    memcpy(parent, c->x + 3 * p, 3 * sizeof(double));
    memcpy(parent + 3, c->T + 9 * p, 9 * sizeof(double));
    memset(parent + 12, 0, 12 * sizeof(double));
    if (rates) memcpy(parent + 12, rates, 6 * sizeof(double));
}

/* δJ of every slot along `along` (n_total + 1) at c (J of c in the links' buffers): dJ (n_slots, 6, W) and the slots'
 * moves delta (n_slots, 6), edge by edge in tree order (header). */
static void slot_maps_moved(const Model *m, const Configuration *c, const double *along, double *dJ, double *delta)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    memset(dJ, 0, sizeof(double) * (size_t)(6 * W * L->n_slots));
    for (int64_t s = 0; s < L->n_slots; ++s)
        for (int k = 0; k < 6; ++k) {
            double v = 0.0;
            for (int64_t j = 0; j < L->slot_count[s]; ++j)
                v += L->jacobian[6 * W * s + W * k + j] * along[L->slot_columns[W * s + j]];
            delta[6 * s + k] = v;
        }
    for (int64_t k = 0; k < L->n_edges; ++k) {
        const int64_t p = L->edge_parent[k], h = L->edge_hinge[k], kind = L->edge_kind[k];
        const int64_t sp = L->edge_parent_slot[k], sc = L->edge_slot[k];
        const int64_t np = L->slot_count[sp], nc = L->slot_count[sc];
        double parent[24], edge[13], x[3], T[9], rates[12], transfer[36], joint[6], conv[42], D[84], move[7], column[6];
        memcpy(edge, L->edge_data + 13 * k, 13 * sizeof(double));
        if (kind < 2) {
            edge[10] = h >= 0 ? c->theta[h] : 0.0;
            edge[11] = 0.0;
            edge[12] = 0.0;
        }
        const kernel_rigid_link_edge kernel = kind == 1 ? L->prismatic_link_edge : kind == 2 ? L->slider_closure_edge
                                            : kind == 3 ? L->rod_closure_edge : L->rigid_link_edge;
        second_parent_input(c, p, NULL, parent);
        kernel(1, parent, edge, x, T, rates, transfer, joint, conv);
        memcpy(move, delta + 6 * sp, 6 * sizeof(double));
        move[6] = nc > np ? along[L->slot_columns[W * sc + np]] : 0.0;
        const double *Jp = L->jacobian + 6 * W * sp, *dJp = dJ + 6 * W * sp;
        double *dJc = dJ + 6 * W * sc;
        for (int64_t j = 0; j < nc; ++j) {
            if (j < np) {
                for (int q = 0; q < 6; ++q) column[q] = Jp[W * q + j];
                second_parent_input(c, p, column, parent);
            } else {   /* the edge's own column: its joint, the child's rates at θ̇ = 1 */
                second_parent_input(c, p, NULL, parent);
                edge[11] = 1.0;
            }
            L->rates_D_q[kind](1, parent, edge, D);
            if (kind < 2) edge[11] = 0.0;
            for (int i = 0; i < 6; ++i) {
                double v = 0.0;
                for (int q = 0; q < 7; ++q) v += D[7 * i + q] * move[q];
                if (j < np)
                    for (int q = 0; q < 6; ++q) v += transfer[6 * i + q] * dJp[W * q + j];
                dJc[W * i + j] = v;
            }
        }
    }
}

/* geometric_term's product (GeometricProduct) moved along `along` at fixed wrenches (header): δ(G w) into g_sink's
 * out. The wrenches of the dependent slots in L->wrench, set anew by the caller; second[4]: the kernels above;
 * scratch: (6 width + 12) n_slots doubles (the slots' δJ, moves and wrenches' moves). */
static void geometric_term_moved(const Model *m, const Configuration *c, const double *along,
                                 const kernel_second *second, const GeometricProduct *g_sink, double *scratch)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    double *dJ = scratch, *delta = dJ + 6 * W * L->n_slots, *dwrench = delta + 6 * L->n_slots;
    slot_maps_moved(m, c, along, dJ, delta);
    memset(dwrench, 0, sizeof(double) * (size_t)(6 * L->n_slots));
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* closures (leaves): J_pᵀ D J_p on the pin's columns, g to the pin */
        const int64_t edge = L->slot_edge[s];
        if (edge < 0 || L->edge_kind[edge] < 2) continue;
        const double *r = L->wrench + 6 * s;
        if (!(r[0] || r[1] || r[2] || r[3] || r[4] || r[5])) continue;
        const int64_t sp = L->edge_parent_slot[edge], count = L->slot_count[sp];
        const double *Jp = L->jacobian + 6 * W * sp, *dJp = dJ + 6 * W * sp, *dp = delta + 6 * sp;
        const double *pin = c->x + 3 * L->edge_parent[edge], *data = L->edge_data + 13 * edge;
        double g[3], D[9], D2[27], dD[9];
        const int rod = L->edge_kind[edge] == 3;
        (rod ? L->rod_closure_wrench : L->slider_closure_wrench)(1, pin, data, r, g, D);
        second[rod ? 3 : 2](1, pin, data, r, D2);
        for (int ab = 0; ab < 9; ++ab) dD[ab] = D2[3 * ab] * dp[0] + D2[3 * ab + 1] * dp[1] + D2[3 * ab + 2] * dp[2];
        for (int64_t i = 0; i < count; ++i)
            for (int64_t j = 0; j < count; ++j) {
                double value = 0.0;
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b)
                        value += dJp[W * a + i] * D[3 * a + b] * Jp[W * b + j] + Jp[W * a + i] * dD[3 * a + b] * Jp[W * b + j]
                               + Jp[W * a + i] * D[3 * a + b] * dJp[W * b + j];
                geometric_entry(L, NULL, -1, sp, i, j, value, g_sink);
            }
        if (L->slot_edge[sp] >= 0)
            for (int a = 0; a < 3; ++a) {
                L->wrench[6 * sp + a] += g[a];
                dwrench[6 * sp + a] += D[3 * a] * dp[0] + D[3 * a + 1] * dp[1] + D[3 * a + 2] * dp[2];
            }
    }
    for (int64_t s = 0; s < L->n_slots; ++s) {
        const int64_t edge = L->slot_edge[s];
        if (edge < 0 || L->edge_kind[edge] >= 2) continue;
        const double *r = L->wrench + 6 * s, *dr = dwrench + 6 * s;
        if (!(r[0] || r[1] || r[2] || r[3] || r[4] || r[5] || dr[0] || dr[1] || dr[2] || dr[3] || dr[4] || dr[5]))
            continue;
        const int64_t node = L->slot_node[s], count = L->slot_count[s], root = L->slot_root[s];
        const double *Jc = L->jacobian + 6 * W * s, *dJc = dJ + 6 * W * s, *dc = delta + 6 * s;
        double input[12], value[6], D[36], dD[36];
        memcpy(input, c->x + 3 * L->slot_node[root], 3 * sizeof(double));
        memcpy(input + 3, c->x + 3 * node, 3 * sizeof(double));
        memcpy(input + 6, r, 6 * sizeof(double));
        L->root_wrench(1, input, value, D);
        memcpy(input + 6, dr, 6 * sizeof(double));
        L->root_wrench(1, input, value, dD);   /* D is linear in the wrench: its move at the wrench's move */
        for (int i = 0; i < 6; ++i)
            for (int64_t j = 0; j < count; ++j) {
                double g = j < 3 ? dD[6 * i + j] : 0.0;
                for (int q = 0; q < 3; ++q) g += dD[6 * i + 3 + q] * Jc[W * q + j] + D[6 * i + 3 + q] * dJc[W * q + j];
                geometric_entry(L, NULL, -1, s, i, j, g, g_sink);
            }
        for (int64_t t = s; L->slot_edge[t] >= 0; t = L->edge_parent_slot[L->slot_edge[t]]) {
            const int64_t k = L->slot_edge[t];
            if (L->edge_hinge[k] < 0) continue;
            const int64_t sp = L->edge_parent_slot[k], column = L->slot_count[t] - 1;
            const double *Jp = L->jacobian + 6 * W * sp, *dJp = dJ + 6 * W * sp, *dp = delta + 6 * sp;
            const int slide = L->edge_kind[k] == 1;
            double parent[12], data[7], wrench[9], force, Dh[9], dDh[9], H[81], move[9];
            hinge_wrench_inputs(L, c, k, node, r, parent, data, wrench);
            const kernel_hinge_wrench first = slide ? L->slide_wrench : L->hinge_wrench;
            first(1, parent, data, wrench, &force, Dh);
            second[slide ? 1 : 0](1, parent, data, wrench, H);
            memcpy(wrench + 3, dr, 6 * sizeof(double));
            first(1, parent, data, wrench, &force, dDh);   /* Dh is linear in the wrench */
            memcpy(move, dp, 6 * sizeof(double));
            memcpy(move + 6, dc, 3 * sizeof(double));
            for (int i = 0; i < 9; ++i)
                for (int q = 0; q < 9; ++q) dDh[i] += H[9 * i + q] * move[q];
            for (int64_t j = 0; j < count; ++j) {
                double g = 0.0;
                if (j < L->slot_count[sp])
                    for (int q = 0; q < 6; ++q) g += dDh[q] * Jp[W * q + j] + Dh[q] * dJp[W * q + j];
                for (int q = 0; q < 3; ++q) g += dDh[6 + q] * Jc[W * q + j] + Dh[6 + q] * dJc[W * q + j];
                geometric_entry(L, NULL, -1, s, column, j, g, g_sink);
            }
        }
    }
}

/* out (n_total + 1, zeroed here) rows below n_dofs: the move of ∂(Pᵀ y)/∂q · `vector` (latdyn_linked_geometric_product's
 * product, at fixed y and vector) along `along` (n_total + 1: the free coordinates' δq, or the prescribed ones' q̇_p), at c
 * (its dependent nodes completed: J of c in the links' buffers); `second` the four kernels' addresses (header);
 * scratch (6 width + 12) n_slots doubles. Nothing without rigid links. */
void latdyn_linked_geometric_second(const Model *m, const Configuration *c, const double *y, const int64_t *columns,
                                    const double *vector, const double *along, const kernel_second *second,
                                    double *scratch, double *out)
{
    memset(out, 0, sizeof(double) * (size_t)(m->n_total + 1));
    if (!m->links) return;
    const Links *L = m->links;
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* the wrenches anew: the closures change them */
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = y[d[k]];
    }
    const GeometricProduct product = {columns, vector, m->n_dofs, out};
    geometric_term_moved(m, c, along, second, &product, scratch);
}
