/*
 * The prescribed motions' drive in the external work's sensitivity (latdyn/analyses/energy_sensitivities.py
 * _drive_reactions and external_work_step): the forward run counts the drive's work over a step as ½(r_n + r_{n+1}) Δq_d
 * over each prescribed coordinate d (newton_step.c drive_work: r the reaction that imposes the motion, Δq_d the
 * prescribed law's, no parameter's), so its sensitivity moves by ½ Σ_d Δq_d (δr_{d,n} + δr_{d,n+1}), with
 *
 *     δr_d = ∂r_d/∂p + K_d· δq + C_d· δv + M_d· δv̇,
 *
 * K, C and M the rows of the prescribed coordinates of one evaluation's blocks (with the inertia tangent in K and the
 * joint bodies' inertia stiffness, as Assembler.exact_rows scatters them), their columns the free coordinates, and
 * ∂r_d/∂p the parameters' columns of the residual on those rows (ParameterDerivatives.residual_derivatives on all
 * coordinates). The per-step Python path and the sensitivities' loop of steps (work_accounts.c work_accounts_step)
 * call these functions: the same bits.
 *
 * Runtime code, written by hand: it holds no physics (the blocks are the generated kernels', summed as products).
 */

/* One block's rows (dofs, r) and columns (cols, c) with K (K2 added; NULL: none), C, M (NULL: none), row-major r × c:
 * for each row that is a prescribed coordinate's (where[row] ≥ 0) its products with the free columns (< n) of dq, dv,
 * dvdot (n × k) added to out's row where[row] (k). */
static void drive_block(const int64_t *rows, int64_t r, const int64_t *cols, int64_t c, const double *K,
                        const double *K2, const double *C, const double *M, const int64_t *where, int64_t n,
                        int64_t k, const double *dq, const double *dv, const double *dvdot, double *out)
{
    for (int64_t p = 0; p < r; ++p) {
        const int64_t at = where[rows[p]];
        if (at < 0) continue;
        double *row = out + at * k;
        for (int64_t q = 0; q < c; ++q) {
            const int64_t col = cols[q];
            if (col >= n) continue;
            double stiffness = K[c * p + q];
            if (K2 != NULL) stiffness += K2[c * p + q];
            const double damping = C != NULL ? C[c * p + q] : 0.0, mass = M != NULL ? M[c * p + q] : 0.0;
            for (int64_t j = 0; j < k; ++j)
                row[j] += stiffness * dq[col * k + j] + damping * dv[col * k + j] + mass * dvdot[col * k + j];
        }
    }
}

/* δr_d (header) into out (d × k, in the order of the prescribed coordinates: where (n_total + 1) each coordinate's
 * row in out, −1 elsewhere), out holding ∂r_d/∂p on entry; the last evaluation's blocks (latdyn_evaluate with
 * matrices and the inertia tangent), body_inertia_stiffness (b, 6, 6) the joint bodies' (NULL: none), load_columns
 * (n_loads, 6) each load block's columns (Assembler._load_columns), couplings (2 m->n_couplings: the continuous
 * controllers' coupling rows, then columns; NULL: none); dq, dv, dvdot the carried δq, δv, δv̇ (n × k). Block by
 * block: elements, joint bodies, loads, cables, couplings (a hinge's law sits on its own coordinate's diagonal, never a
 * prescribed row's free column). */
static void drive_reaction_rates(const Model *m, const Work *w, const int64_t *where, int64_t k,
                                 const double *body_inertia_stiffness, const int64_t *load_columns,
                                 const int64_t *couplings, const double *dq, const double *dv, const double *dvdot,
                                 double *out)
{
    const int64_t n = m->n_dofs;
    for (int64_t e = 0; e < m->n_elements; ++e) {
        const int64_t *dofs = m->element_dofs + 14 * e;
        drive_block(dofs, 14, dofs, 14, w->tangent + 196 * e, w->inertia_tangent + 196 * e, w->quadratic_D + 196 * e,
                    w->mass + 196 * e, where, n, k, dq, dv, dvdot, out);
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        const int64_t *dofs = m->node_dofs + 6 * m->body_nodes[b];
        drive_block(dofs, 6, dofs, 6, w->body_stiffness + 36 * b,
                    body_inertia_stiffness != NULL ? body_inertia_stiffness + 36 * b : NULL, w->body_damping + 36 * b,
                    w->body_mass + 36 * b, where, n, k, dq, dv, dvdot, out);
    }
    for (int64_t l = 0; l < m->n_loads; ++l)
        drive_block(m->node_dofs + 6 * m->load_node[l], 6, load_columns + 6 * l, 6, w->load_blocks + 36 * l, NULL, NULL,
                    NULL, where, n, k, dq, dv, dvdot, out);
    for (int64_t e = 0; e < m->n_cables; ++e) {
        int64_t dofs[12];
        for (int end = 0; end < 2; ++end)
            memcpy(dofs + 6 * end, m->node_dofs + 6 * m->cable_nodes[2 * e + end], 6 * sizeof(int64_t));
        drive_block(dofs, 12, dofs, 12, w->cable_stiffness + 144 * e, NULL, w->cable_damping + 144 * e, NULL, where, n,
                    k, dq, dv, dvdot, out);
    }
    for (int64_t e = 0; couplings != NULL && e < m->n_couplings; ++e)
        drive_block(couplings + e, 1, couplings + m->n_couplings + e, 1, w->coupling_stiffness + e, NULL,
                    w->coupling_damping + e, NULL, where, n, k, dq, dv, dvdot, out);
}

/* The drive's part of the external work's sensitivity over a step (header): work (k) += ½ Σ_i Δq_i (δr_old + δr_new)_i
 * over the d prescribed coordinates (increment: d; dr_old, dr_new: d × k), i in order. */
static void drive_work_sensitivity(int64_t d, int64_t k, const double *increment, const double *dr_old,
                                   const double *dr_new, double *work)
{
    for (int64_t j = 0; j < k; ++j) {
        double s = 0.0;
        for (int64_t i = 0; i < d; ++i) s += increment[i] * (dr_old[i * k + j] + dr_new[i * k + j]);
        work[j] += 0.5 * s;
    }
}

/* drive_reaction_rates for the per-step Python path (energy_sensitivities._drive_reactions), after its evaluation. */
void latdyn_drive_reaction_rates(const Model *m, const Work *w, const int64_t *where, int64_t k,
                                 const double *body_inertia_stiffness, const int64_t *load_columns,
                                 const int64_t *couplings, const double *dq, const double *dv, const double *dvdot,
                                 double *out)
{
    drive_reaction_rates(m, w, where, k, body_inertia_stiffness, load_columns, couplings, dq, dv, dvdot, out);
}

/* drive_work_sensitivity for the per-step Python path (energy_sensitivities.external_work_step). */
void latdyn_drive_work_sensitivity(int64_t d, int64_t k, const double *increment, const double *dr_old,
                                   const double *dr_new, double *work)
{
    drive_work_sensitivity(d, k, increment, dr_old, dr_new, work);
}
