/*
 * ∂r/∂t through the prescribed motions, exactly (latdyn/analyses/prescribed_rates.py; transient_sensitivities.py
 * ExplicitTime): the residual of every coordinate moves with the prescribed coordinates q_p(t), their rates and
 * accelerations, so at fixed free coordinates
 *
 *     ∂r/∂t = K_·p q̇_p + C_·p q̈_p + M_·p q⃛_p,
 *
 * K, C and M the blocks of the last evaluation (latdyn_evaluate with matrices; with `inertia` the inertia tangent
 * in K and the elements' and joint bodies' M and C, as Assembler.exact_rows scatters them), their columns of the
 * prescribed coordinates (a prescribed body's translations and spatial rotations, a prescribed hinge's angle)
 * times the motion laws' exact first, second and third time derivatives (`rates`: 3 (n_total + 1), zero off the
 * prescribed coordinates; a body's rotation about its fixed axis a by g(t): a ġ, a g̈, a g⃛ on its spatial
 * rotations, the tangent space of exp(skew δπ) T in which K's rotation columns are). Block by block, in the order
 * elements, joint bodies, hinges, loads, cables, each row's products summed over the block's prescribed columns in
 * their order, into out (n_total + 1: every coordinate's row, the last slot 0). The per-step Python path and the
 * sensitivities' loop of steps (sensitivity_loop.c) call this one function: the same bits.
 *
 * Runtime code, written by hand: it holds no physics (the blocks are the generated kernels').
 */

/* One block's rows (dofs, r), its columns (cols, c), K, C (NULL: none), M (NULL: none), row-major r × c; K2 added
 * to K (NULL: none). */
static void prescribed_block(const int64_t *rows, int64_t r, const int64_t *cols, int64_t c, const double *K,
                             const double *K2, const double *C, const double *M, const int64_t *prescribed,
                             const double *rates, int64_t size, double *out)
{
    const double *rate = rates, *acceleration = rates + size, *jerk = rates + 2 * size;
    for (int64_t p = 0; p < r; ++p) {
        double s = 0.0;
        int any = 0;
        for (int64_t q = 0; q < c; ++q) {
            const int64_t d = cols[q];
            if (!prescribed[d]) continue;
            double k = K[c * p + q];
            if (K2 != NULL) k += K2[c * p + q];
            s += k * rate[d];
            if (C != NULL) s += C[c * p + q] * acceleration[d];
            if (M != NULL) s += M[c * p + q] * jerk[d];
            any = 1;
        }
        if (any) out[rows[p]] += s;
    }
}

/* ∂r/∂t through the prescribed motions (header) into out (n_total + 1). prescribed: (n_total + 1) 1 on the prescribed
 * coordinates; body_inertia_stiffness: the joint bodies' (b, 6, 6) added to their K with `inertia` (NULL: none);
 * load_columns (n_loads, 6): each load block's columns (Assembler._load_columns); couplings (2 m->n_couplings: the
 * continuous controllers' coupling rows, then their columns, ControlArrays coupling_rows and coupling_cols; NULL:
 * none): a controller's sensor on a prescribed coordinate, its entry of K (a coordinate or a rotation read) or of C
 * (a rate read) times the motion's rate or acceleration, last. */
void latdyn_prescribed_time_rate(const Model *m, const Work *w, const int64_t *prescribed, const double *rates,
                                 int64_t inertia, const double *body_inertia_stiffness, const int64_t *load_columns,
                                 const int64_t *couplings, double *out)
{
    const int64_t size = m->n_total + 1;
    memset(out, 0, sizeof(double) * (size_t)size);
    for (int64_t e = 0; e < m->n_elements; ++e) {
        const int64_t *dofs = m->element_dofs + 14 * e;
        prescribed_block(dofs, 14, dofs, 14, w->tangent + 196 * e, inertia ? w->inertia_tangent + 196 * e : NULL,
                         inertia ? w->quadratic_D + 196 * e : NULL, inertia ? w->mass + 196 * e : NULL, prescribed,
                         rates, size, out);
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        const int64_t *dofs = m->node_dofs + 6 * m->body_nodes[b];
        prescribed_block(dofs, 6, dofs, 6, w->body_stiffness + 36 * b,
                         inertia && body_inertia_stiffness != NULL ? body_inertia_stiffness + 36 * b : NULL,
                         inertia ? w->body_damping + 36 * b : NULL, inertia ? w->body_mass + 36 * b : NULL, prescribed,
                         rates, size, out);
    }
    for (int64_t j = 0; j < m->n_hinges; ++j)   /* a joint's law on its own (prescribed) angle: its reaction's row */
        prescribed_block(m->hinge_dofs + j, 1, m->hinge_dofs + j, 1, w->hinge_d_theta + j, NULL, w->hinge_d_rate + j,
                         NULL, prescribed, rates, size, out);
    for (int64_t l = 0; l < m->n_loads; ++l)
        prescribed_block(m->node_dofs + 6 * m->load_node[l], 6, load_columns + 6 * l, 6, w->load_blocks + 36 * l, NULL,
                         NULL, NULL, prescribed, rates, size, out);
    for (int64_t e = 0; e < m->n_cables; ++e) {
        int64_t dofs[12];
        for (int end = 0; end < 2; ++end)
            memcpy(dofs + 6 * end, m->node_dofs + 6 * m->cable_nodes[2 * e + end], 6 * sizeof(int64_t));
        prescribed_block(dofs, 12, dofs, 12, w->cable_stiffness + 144 * e, NULL, w->cable_damping + 144 * e, NULL,
                         prescribed, rates, size, out);
    }
    for (int64_t e = 0; couplings != NULL && e < m->n_couplings; ++e)
        prescribed_block(couplings + e, 1, couplings + m->n_couplings + e, 1, w->coupling_stiffness + e, NULL,
                         w->coupling_damping + e, NULL, prescribed, rates, size, out);
    out[m->n_total] = 0.0;
}
