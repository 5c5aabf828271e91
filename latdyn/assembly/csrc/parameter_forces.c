/*
 * ∂r/∂p of the section values that name a parameter, in one call: the element kernels' inputs at a state
 * (element_inputs, evaluate.c), the generated derivatives by the section values of the distinct elements the
 * uses name (beam_internal_force_D_section, and beam_inertia_force_D_section where inertia or gravity is on),
 * each use's derivative ∂F/∂s (14 × 9) contracted with its section row's ∂s/∂p, and the result added to the
 * use's element coordinates in its parameter's column (latdyn/analyses/sensitivities.py,
 * ParameterDerivatives._section_element_forces, which lays the uses out once a run).
 *
 * Runtime code, written by hand: it holds no physics (the derivatives are the generator's). The scatter adds
 * in the order np.add.at of the Python path adds (use by use, the element's 14 coordinates in turn); each
 * contraction sums its 9 products in the order of the section values, where NumPy's einsum sums them in an
 * order its vector width sets (SIMD lanes), so the two agree to round-off (docs/performance.md, "Forward
 * sensitivities: where a step goes").
 */

/* Adds into total ((n_total + 1) × k, row-major) the section values' ∂(internal force [+ M a + g − λ Q])/∂p at c.
 * on (n_on): the distinct elements of the uses; use (n_uses): each use's index in on; elements, columns (n_uses):
 * its element and parameter column; rows (n_uses × 10): its section row (L0, then the values' derivatives);
 * with_inertia: the inertia force at the state's rates and accelerations (else at rest, where gravity ≠ 0: the
 * static residual's −λ Q); gravity (3): λ g, NULL for none; inertia_D_section NULL where neither is wanted.
 * scratch: n_on × (36 + 14 + 14 + 10 + 3 + 2 × (14 + 126)) doubles. */
void latdyn_section_parameter_forces(const Model *m, Work *w, const Configuration *c, kernel_2_2 internal_D_section,
                                     kernel_5_2 inertia_D_section, int64_t with_inertia, const double *gravity,
                                     int64_t n_on, const int64_t *on, int64_t n_uses, const int64_t *use,
                                     const int64_t *elements, const int64_t *columns, const double *rows,
                                     int64_t k, double *total, double *scratch)
{
    if (n_on == 0 || n_uses == 0) return;
    element_inputs(m, c, w, 0, m->n_elements);
    double *geometry = scratch, *rates = geometry + 36 * n_on, *accelerations = rates + 14 * n_on;
    double *sections = accelerations + 14 * n_on, *weights = sections + 10 * n_on;
    double *force = weights + 3 * n_on, *by_section = force + 14 * n_on;
    double *inertia_force = by_section + 126 * n_on, *inertia_by_section = inertia_force + 14 * n_on;
    for (int64_t i = 0; i < n_on; ++i) {
        const int64_t e = on[i];
        memcpy(geometry + 36 * i, w->geometry + 36 * e, 36 * sizeof(double));
        memcpy(sections + 10 * i, m->element_sections + m->section_width * e, 10 * sizeof(double));
    }
    internal_D_section(n_on, geometry, sections, force, by_section);
    if (inertia_D_section != NULL) {
        for (int64_t i = 0; i < n_on; ++i) {
            const int64_t e = on[i];
            if (with_inertia) {
                memcpy(rates + 14 * i, w->rates + 14 * e, 14 * sizeof(double));
                memcpy(accelerations + 14 * i, w->accelerations + 14 * e, 14 * sizeof(double));
            } else {
                memset(rates + 14 * i, 0, 14 * sizeof(double));
                memset(accelerations + 14 * i, 0, 14 * sizeof(double));
            }
            for (int j = 0; j < 3; ++j) weights[3 * i + j] = gravity != NULL ? gravity[j] : 0.0;
        }
        inertia_D_section(n_on, geometry, rates, accelerations, sections, weights, inertia_force, inertia_by_section);
        for (int64_t i = 0; i < 126 * n_on; ++i) by_section[i] += inertia_by_section[i];
    }
    for (int64_t u = 0; u < n_uses; ++u) {
        const double *D = by_section + 126 * use[u], *row = rows + 10 * u + 1;
        const int64_t *dofs = m->element_dofs + 14 * elements[u];
        for (int p = 0; p < 14; ++p) {
            double sum = 0.0;
            for (int d = 0; d < 9; ++d) sum += D[9 * p + d] * row[d];
            total[dofs[p] * k + columns[u]] += sum;
        }
    }
}

/* ∂S/∂p (k, into out) of an element's section force w0 S_first + w1 S_first+1 (S = [N, T, M_y', M_z'] at mid-element,
 * the weights a controller's sensor of it holds: evaluate.c sensor_value kind 12) by the section uses whose element is
 * e: the generated beam_section_forces_D_section (∂S by the section values) at the element's inputs the evaluation left
 * in w->geometry, each use's row of ∂(section values)/∂p contracted in index order, weighed, summed in the uses' order
 * (ControllerTerms.sensed_force_slopes on the per-step path, SensitivityLoop's force reads in the loop of steps). */
static void section_force_slope(const Model *m, const Work *w, kernel_2_2 forces_D_section, int64_t e, int64_t first,
                                const double *weights, int64_t n_uses, const int64_t *elements, const int64_t *columns,
                                const double *rows, int64_t k, double *out)
{
    double forces[4], by_section[36];
    memset(out, 0, sizeof(double) * (size_t)k);
    forces_D_section(1, w->geometry + 36 * e, m->element_sections + m->section_width * e, forces, by_section);
    for (int64_t u = 0; u < n_uses; ++u) {
        if (elements[u] != e) continue;
        const double *row = rows + 10 * u + 1;
        double sum[2] = {0.0, 0.0};
        for (int q = 0; q < 2 && first + q < 4; ++q)
            for (int d = 0; d < 9; ++d) sum[q] += by_section[9 * (first + q) + d] * row[d];
        out[columns[u]] += weights[0] * sum[0] + weights[1] * sum[1];
    }
}

/* The per-step path's section_force_slope at c: the elements' inputs at c, then that. */
void latdyn_section_force_slope(const Model *m, Work *w, const Configuration *c, kernel_2_2 forces_D_section, int64_t e,
                                int64_t first, const double *weights, int64_t n_uses, const int64_t *elements,
                                const int64_t *columns, const double *rows, int64_t k, double *out)
{
    element_inputs(m, c, w, 0, m->n_elements);
    section_force_slope(m, w, forces_D_section, e, first, weights, n_uses, elements, columns, rows, k, out);
}
