/*
 * ∂r/∂t through the prescribed motions on a model with rigid links or guides, exactly
 * (latdyn/analyses/prescribed_rates.py; transient_sensitivities.py ExplicitTime.through_prescribed).
 *
 * At fixed free coordinates, rates and accelerations the prescribed coordinates move as q_p(t) and carry the
 * dependent nodes that hang from them (latdyn/assembly/linked.py: q_dep(q_f, q_p), v_dep = J v_ind,
 * a_dep = J a_ind + c(q, v)):
 *
 *     δq_dep = J_·p q̇_p,
 *     δv_dep = ∂(J v)/∂q_p q̇_p + J_·p q̈_p,
 *     δa_dep = ∂(J a + c)/∂q_p q̇_p + ∂c/∂v_p q̈_p + J_·p q⃛_p,
 *
 * (J, ∂c/∂v and the dependent rates' ∂/∂q at fixed independent rates the slots' buffers of links.c, the generated
 * edge kernels composed along the tree), so that on all coordinates
 *
 *     ∂r_all/∂t = K δq_all + C δv_all + M δa_all    (csrc/prescribed_rates.c on the prescribed and dependent
 *                                                    coordinates' columns)
 *
 * and on the minimum coordinates r_min = Pᵀ r_all moves as
 *
 *     ∂r_min/∂t = Pᵀ ∂r_all/∂t + ∂(Pᵀ)/∂q_p q̇_p · r_all
 *
 * (latdyn_linked_reduce_columns; the geometric term links.c's geometric_term on the prescribed columns). The
 * per-step Python path and the sensitivities' loop of steps (sensitivity_loop.c) call this one function.
 *
 * Runtime code, written by hand: it holds no physics (the blocks, J, ∂c/∂v, the rates' ∂/∂q and the wrenches'
 * derivatives are the generated kernels').
 */

/* ∂r/∂t through the prescribed motions (header) of the evaluation left in w at c (latdyn_evaluate with matrices,
 * the inertia tangent with `inertia`; c's dependent nodes completed), `prescribed` and `rates` as
 * latdyn_prescribed_time_rate's; `mask` (n_total + 1) and `moved` (3 (n_total + 1)) scratch: the prescribed and
 * dependent coordinates and their δq, δv, δa. Into `all` (n_total + 1): ∂r_all/∂t, every coordinate's row before
 * the reduction; into `out` (n_total + 1): its rows below n_dofs ∂r_min/∂t (the rest scratch). */
void latdyn_linked_prescribed_time_rate(const Model *m, Work *w, const Configuration *c, const int64_t *prescribed,
                                        const double *rates, int64_t inertia, const double *body_inertia_stiffness,
                                        const int64_t *load_columns, const int64_t *couplings, int64_t *mask,
                                        double *moved, double *all, double *out)
{
    const Links *L = m->links;
    const int64_t size = m->n_total + 1, W = L->width;
    dependent_rates_tangent(m, c);
    memcpy(mask, prescribed, sizeof(int64_t) * (size_t)size);
    memcpy(moved, rates, sizeof(double) * (size_t)(3 * size));
    for (int64_t s = 0; s < L->n_slots; ++s) {   /* each dependent node: δq, δv, δa through its prescribed columns */
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s], *columns = L->slot_columns + W * s;
        const double *J = L->jacobian + 6 * W * s, *Cv = L->convective + 6 * W * s;
        const double *R = L->rates_tangent + 12 * W * s;
        for (int k = 0; k < 6; ++k) {
            if (d[k] >= m->n_total) continue;
            double dq = 0.0, dv = 0.0, da = 0.0;
            int any = 0;
            for (int64_t j = 0; j < L->slot_count[s]; ++j) {
                const int64_t p = columns[j];
                if (!prescribed[p]) continue;
                const double rate = rates[p], acceleration = rates[size + p], jerk = rates[2 * size + p];
                dq += J[W * k + j] * rate;
                dv += R[W * k + j] * rate + J[W * k + j] * acceleration;
                da += R[W * (6 + k) + j] * rate + Cv[W * k + j] * acceleration + J[W * k + j] * jerk;
                any = 1;
            }
            if (!any) continue;
            mask[d[k]] = 1;
            moved[d[k]] = dq;
            moved[size + d[k]] = dv;
            moved[2 * size + d[k]] = da;
        }
    }
    latdyn_prescribed_time_rate(m, w, mask, moved, inertia, body_inertia_stiffness, load_columns, couplings, all);
    memcpy(out, all, sizeof(double) * (size_t)size);
    latdyn_linked_reduce_columns(m, all, 1, out);   /* Pᵀ ∂r_all/∂t: rows below n_dofs */
    /* ∂(Pᵀ)/∂q_p q̇_p · r_all: the dependent rows of the residual the evaluation left in w->total */
    for (int64_t s = 0; s < L->n_slots; ++s) {
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = w->total[d[k]];
    }
    const GeometricProduct product = {prescribed, rates, m->n_dofs, out};
    geometric_term(m, c, NULL, &product);
}
