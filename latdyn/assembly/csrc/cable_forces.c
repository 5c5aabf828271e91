/*
 * ∂r/∂p of the cables' parameters in the sensitivities' loop of steps (sensitivity_loop.c), as the per-step Python
 * path forms them (latdyn/analyses/cable_sensitivities.py CableSensitivities.residual_derivatives), use by use in
 * its order: for a cable's EA or damping the generated cable_force with the derivative law's value in that place
 * (the force is linear in EA and c at a fixed rest length), for its rest length the generated
 * cable_force_D_rest_length times the element's share and the derivative law's value, each element held taut (its
 * side +1, or side 0 and a positive gap, as the evaluation at the state decides: evaluate.c cables) added at its
 * ends' coordinates; for ρA and the rest length of a cable with mass first its lumped point masses' inertia and
 * gravity forces, the generated joint_body with the masses' ∂m (linear in m). The kernels' inputs are evaluate.c's
 * cable_inputs, which the Python path reproduces (CableSensitivities.inputs).
 *
 * Runtime code, written by hand: it holds no physics.
 */

typedef void (*kernel_cable_force)(int64_t, const double *, const double *, const double *, double *, double *,
                                   double *, double *, double *, double *, double *, double *);
typedef void (*kernel_cable_D_rest)(int64_t, const double *, const double *, const double *, double *, double *);

/* What the loop needs for the cables' parameters (latdyn.analyses.sensitivities_in_loop SensitivityLoop._cables). */
typedef struct CableForces {
    int64_t n_uses;
    const int64_t *cable, *column;      /* each use (CableSensitivities.uses): its cable and parameter column */
    const int64_t *value;               /* 0 EA, 1 damping, 2 the rest length, 3 ρA */
    const double *values;               /* (grid points) × n_uses: the derivative law's value at each grid point */
    int64_t values_from;                /* the grid index of values' first grid point */
    const int64_t *element_cable;       /* (ce): each element's cable */
    kernel_cable_force force_kernel;    /* the generated cable_force */
    kernel_cable_D_rest rest_kernel;    /* the generated cable_force_D_rest_length */
    /* the lumped masses (CableSensitivities._mass_forces): per use, its first row among the joint bodies and their
     * count (0: none: no mass, or the use moves none), the kernel's blocks (rows × 13, ∂m and the centre) and λ g
     * per row (rows × 3), from mass_from[use] rows into mass_blocks and mass_gravity */
    const int64_t *mass_row, *mass_rows, *mass_from;
    const double *mass_blocks, *mass_gravity;
    kernel_joint_body body_kernel;      /* the generated joint_body (NULL: no mass use) */
    double *scratch;                    /* 12 + 12 + 4 + 12 + 144 + 144 + 5 + 4, and 162 per row of the largest */
} CableForces;

/* The lumped masses' part of use u into total's column (CableSensitivities._mass_forces). */
static void cable_mass_forces(const Model *m, const Configuration *c, const CableForces *cf, int64_t u, int64_t k,
                              int64_t column, double *total)
{
    const int64_t rows = cf->mass_rows[u], from = cf->mass_from[u];
    double *frames = cf->scratch + 337, *motion = frames + 9 * rows, *force = motion + 9 * rows;
    double *blocks = force + 6 * rows;
    for (int64_t r = 0; r < rows; ++r) {
        const int64_t i = m->body_nodes[cf->mass_row[u] + r];
        memcpy(frames + 9 * r, c->T + 9 * i, 9 * sizeof(double));
        memcpy(motion + 9 * r, c->w + 3 * i, 3 * sizeof(double));
        memcpy(motion + 9 * r + 3, c->a + 3 * i, 3 * sizeof(double));
        memcpy(motion + 9 * r + 6, c->alpha + 3 * i, 3 * sizeof(double));
    }
    cf->body_kernel(rows, frames, motion, cf->mass_blocks + 13 * from, cf->mass_gravity + 3 * from, force, blocks,
                    blocks + 36 * rows, blocks + 72 * rows);
    for (int64_t r = 0; r < rows; ++r) {
        const int64_t *d = m->node_dofs + 6 * m->body_nodes[cf->mass_row[u] + r];
        for (int p = 0; p < 6; ++p) total[(d[p] < 0 ? m->n_total : d[p]) * k + column] += force[6 * r + p];
    }
}

/* ∂r/∂p of the cables' parameters at c into total ((n_total + 1) × k), at grid point `grid`, after the evaluation at
 * c (w->cable_gap decides the elements on side 0). */
static void cable_parameter_forces(const Model *m, const Work *w, const Configuration *c, const CableForces *cf,
                                   int64_t k, int64_t grid, double *total)
{
    const double *table = cf->values + cf->n_uses * (grid - cf->values_from);
    double *geometry = cf->scratch, *velocity = geometry + 12, *section = velocity + 12, *force = section + 4;
    double *K = force + 12, *C = K + 144, *state = C + 144, *rest = state + 5;
    for (int64_t u = 0; u < cf->n_uses; ++u) {
        const int64_t value = cf->value[u], column = cf->column[u];
        const double derivative = table[u];
        if (cf->mass_rows[u]) cable_mass_forces(m, c, cf, u, k, column, total);
        if (derivative == 0.0 || value == 3) continue;
        for (int64_t e = 0; e < m->n_cables; ++e) {
            const double side = m->cable_side[e];
            if (cf->element_cable[e] != cf->cable[u] || !(side > 0.0 || (side == 0.0 && w->cable_gap[e] > 0.0)))
                continue;
            cable_inputs(m, c, w->laws, e, geometry, velocity, section);
            if (value == 2) {
                cf->rest_kernel(1, geometry, velocity, section, force, state);
                const double share = m->cable_section[3 * e];
                for (int p = 0; p < 12; ++p) force[p] = force[p] * share * derivative;
            } else {
                section[2] = value == 0 ? derivative : 0.0;
                section[3] = value == 0 ? 0.0 : derivative;
                cf->force_kernel(1, geometry, velocity, section, force, K, C, state, rest, rest + 1, rest + 2,
                                 rest + 3);
            }
            for (int end = 0; end < 2; ++end) {
                const int64_t *d = m->node_dofs + 6 * m->cable_nodes[2 * e + end];
                for (int p = 0; p < 6; ++p) total[(d[p] < 0 ? m->n_total : d[p]) * k + column] += force[6 * end + p];
            }
        }
    }
}

/* ∂N/∂p (k, into out) of taut element e's tension N at c, at grid point `grid`, by its cable's EA, damping and rest
 * length uses in their order (latdyn/analyses/probe_derivatives.py _tension_by_parameters, a controller's read of the
 * tension: ControllerTerms.sensed_force_slopes): the generated cable_force's N with the derivative in EA's or c's
 * place, or cable_force_D_rest_length's ∂N/∂L0 times the element's share and the derivative; 0 where the element is
 * slack (as the evaluation at c decides, cable_parameter_forces). */
static void cable_tension_slope(const Model *m, const Work *w, const Configuration *c, const CableForces *cf,
                                int64_t grid, int64_t e, int64_t k, double *out)
{
    const double *table = cf->values + cf->n_uses * (grid - cf->values_from);
    double *geometry = cf->scratch, *velocity = geometry + 12, *section = velocity + 12, *force = section + 4;
    double *K = force + 12, *C = K + 144, *state = C + 144, *rest = state + 5;
    const double side = m->cable_side[e];
    memset(out, 0, sizeof(double) * (size_t)k);
    if (!(side > 0.0 || (side == 0.0 && w->cable_gap[e] > 0.0))) return;
    for (int64_t u = 0; u < cf->n_uses; ++u) {
        const int64_t value = cf->value[u];
        const double derivative = table[u];
        if (cf->element_cable[e] != cf->cable[u] || value == 3 || derivative == 0.0) continue;
        cable_inputs(m, c, w->laws, e, geometry, velocity, section);
        double slope;
        if (value == 2) {
            cf->rest_kernel(1, geometry, velocity, section, force, state);
            slope = state[4] * m->cable_section[3 * e] * derivative;
        } else {
            section[2] = value == 0 ? derivative : 0.0;
            section[3] = value == 0 ? 0.0 : derivative;
            cf->force_kernel(1, geometry, velocity, section, force, K, C, state, rest, rest + 1, rest + 2, rest + 3);
            slope = state[4];
        }
        out[cf->column[u]] += slope;
    }
}

/* Whether the step's last evaluation has a cable element within twice its tolerance of its change (|gap| ≤
 * 2 cable_tolerance), where the Python step may land or turn it over (CableSensitivities.landing, .event): the loop
 * with sensitivities hands that step to the caller, which takes it from Python. */
static int cable_near_change(const Model *m, const Work *w)
{
    for (int64_t e = 0; e < m->n_cables; ++e)
        if (fabs(w->cable_gap[e]) <= 2.0 * m->cable_tolerance[e]) return 1;
    return 0;
}
