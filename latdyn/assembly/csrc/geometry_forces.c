/*
 * ∂r/∂p of the geometry parameters (numbers that place the structure) at a state, in one call: the loop of steps'
 * twin of latdyn/analyses/geometry_sensitivities.py ReferenceGeometry.add. Per element a parameter moves and per
 * parameter column, the held variation of its reference data (node axes, laid out once a run by
 * ReferenceGeometry) is taken to the state by the generated reference_variation_at_state, end by end; the
 * generated beam_internal_force_D_reference and, on the elements with mass, beam_inertia_force_D_reference
 * differentiate the forces along it; the results are added to the elements' coordinates column by column, in
 * the order np.add.at of the Python path adds; then per load at a moved offset (a beam end's) the generated
 * point_load_D_offset along each column's δr, with the load's values the caller tabulated per grid point
 * (ReferenceGeometry._load_arms).
 *
 * Runtime code, written by hand: it holds no physics (every number is a generated kernel's). The kernels are
 * called with the rows the Python path forms, in its order (one row per (column, element)), so the two paths
 * give the same bits.
 */

/* reference_variation_at_state: (n, end_frame, frame0, node_frame, axis_angle, held, variation) */
typedef void (*kernel_reference_variation)(int64_t, const double *, const double *, const double *, const double *,
                                           const double *, double *);
/* beam_inertia_force_D_reference: (n, geometry, velocity, acceleration, section, gravity, reference, force, D) */
typedef void (*kernel_6_2)(int64_t, const double *, const double *, const double *, const double *, const double *,
                           const double *, double *, double *);

/* point_load_D_offset: (n, node_frame, offset_move, values, load_frame, out) */
typedef void (*kernel_point_load_D_offset)(int64_t, const double *, const double *, const double *, const double *,
                                           double *);

/* The reference block's width (latdyn/analyses/geometry_sensitivities.py WIDTH, codegen/conventions.py REFERENCE)
 * and its parts: ψ of end i at 12 + 3i, δo at 6 + 3i, δh at 19 + 3i. */
#define REFERENCE_WIDTH 25

/* What the geometry parameters' ∂r/∂p needs (latdyn/analyses/sensitivities_in_loop.py lays it out). */
typedef struct GeometryForces {
    int64_t m;                              /* elements a geometry parameter moves (ReferenceGeometry.elements) */
    const int64_t *elements;                /* m */
    const double *held;                     /* m × 25 × k: their variations held (ReferenceGeometry.variations) */
    int64_t n_on;                           /* those with mass (their inertia force moves too) */
    const int64_t *on;                      /* n_on: their places among elements */
    kernel_reference_variation variation_kernel;
    kernel_3_2 internal_kernel;             /* the generated beam_internal_force_D_reference */
    kernel_6_2 inertia_kernel;              /* the generated beam_inertia_force_D_reference */
    const double *gravity;                  /* 3: λ g */
    double *scratch;                        /* 148 k m + 130 k n_on */
    /* the loads at a moved offset (ReferenceGeometry.moved_loads); n_arms 0: none */
    int64_t n_arms;
    const int64_t *arm_node, *arm_frame;    /* n_arms: the load's node, the node of its frame (−1: global) */
    const double *arm_moves;                /* n_arms × k × 3: δr of each column */
    const double *arm_values;               /* (grid points) × n_arms × 6: the load's values at each grid point */
    int64_t values_from;                    /* the grid index of arm_values' first grid point */
    kernel_point_load_D_offset arm_kernel;  /* the generated point_load_D_offset */
    double *arm_scratch;                    /* 30 k */
} GeometryForces;

/* Adds into total ((n_total + 1) × k, row-major) the geometry parameters' ∂(internal force + M a + g − λ Q)/∂p at c
 * on grid point `grid` (ReferenceGeometry.add with inertia). */
static void latdyn_geometry_parameter_forces(const Model *m, Work *w, const Configuration *c, const GeometryForces *g,
                                             int64_t k, int64_t grid, double *total)
{
    const int64_t E = g->m, R = k * E, Ron = k * g->n_on;
    if (E == 0) return;
    element_inputs(m, c, w, 0, m->n_elements);
    double *at = g->scratch, *sections = at + 36 * R, *reference = sections + 10 * R;
    double *frame = reference + REFERENCE_WIDTH * R, *frame0 = frame + 9 * R, *node = frame0 + 9 * R;
    double *hinge = node + 9 * R, *held = hinge + 4 * R, *moved = held + 9 * R;
    double *force = moved + 9 * R, *by_reference = force + 14 * R;
    double *on_at = by_reference + 14 * R, *on_rates = on_at + 36 * Ron, *on_accelerations = on_rates + 14 * Ron;
    double *on_sections = on_accelerations + 14 * Ron, *on_gravity = on_sections + 10 * Ron;
    double *on_reference = on_gravity + 3 * Ron, *on_force = on_reference + REFERENCE_WIDTH * Ron;
    double *on_by_reference = on_force + 14 * Ron;
    /* row col·E + i: element i, column col (ReferenceGeometry.at_state and add: np.tile, transpose(2, 0, 1)) */
    for (int64_t col = 0; col < k; ++col)
        for (int64_t i = 0; i < E; ++i) {
            const int64_t e = g->elements[i], r = col * E + i;
            memcpy(at + 36 * r, w->geometry + 36 * e, 36 * sizeof(double));
            memcpy(sections + 10 * r, m->element_sections + m->section_width * e, 10 * sizeof(double));
            for (int j = 0; j < REFERENCE_WIDTH; ++j) reference[REFERENCE_WIDTH * r + j] = g->held[(i * REFERENCE_WIDTH + j) * k + col];
        }
    for (int end = 0; end < 2; ++end) {
        for (int64_t col = 0; col < k; ++col)
            for (int64_t i = 0; i < E; ++i) {
                const int64_t e = g->elements[i], r = col * E + i, h = m->element_hinges[2 * e + end];
                memcpy(frame + 9 * r, w->geometry + 36 * e + 12 + 9 * end, 9 * sizeof(double));
                memcpy(frame0 + 9 * r, m->element_frames0 + 18 * e + 9 * end, 9 * sizeof(double));
                memcpy(node + 9 * r, c->T + 9 * m->element_nodes[2 * e + end], 9 * sizeof(double));
                memcpy(hinge + 4 * r, m->element_axes + 6 * e + 3 * end, 3 * sizeof(double));
                hinge[4 * r + 3] = h >= 0 ? c->theta[h] : 0.0;
                const double *row = reference + REFERENCE_WIDTH * r;
                memcpy(held + 9 * r, row + 12 + 3 * end, 3 * sizeof(double));
                memcpy(held + 9 * r + 3, row + 6 + 3 * end, 3 * sizeof(double));
                memcpy(held + 9 * r + 6, row + 19 + 3 * end, 3 * sizeof(double));
            }
        g->variation_kernel(R, frame, frame0, node, hinge, held, moved);
        for (int64_t r = 0; r < R; ++r) {
            double *row = reference + REFERENCE_WIDTH * r;
            memcpy(row + 12 + 3 * end, moved + 9 * r, 3 * sizeof(double));
            memcpy(row + 6 + 3 * end, moved + 9 * r + 3, 3 * sizeof(double));
            memcpy(row + 19 + 3 * end, moved + 9 * r + 6, 3 * sizeof(double));
        }
    }
    g->internal_kernel(R, at, sections, reference, force, by_reference);
    if (g->n_on > 0) {
        for (int64_t col = 0; col < k; ++col)
            for (int64_t j = 0; j < g->n_on; ++j) {
                const int64_t i = g->on[j], e = g->elements[i], r = col * g->n_on + j, from = col * E + i;
                memcpy(on_at + 36 * r, w->geometry + 36 * e, 36 * sizeof(double));
                memcpy(on_rates + 14 * r, w->rates + 14 * e, 14 * sizeof(double));
                memcpy(on_accelerations + 14 * r, w->accelerations + 14 * e, 14 * sizeof(double));
                memcpy(on_sections + 10 * r, sections + 10 * from, 10 * sizeof(double));
                memcpy(on_gravity + 3 * r, g->gravity, 3 * sizeof(double));
                memcpy(on_reference + REFERENCE_WIDTH * r, reference + REFERENCE_WIDTH * from,
                       REFERENCE_WIDTH * sizeof(double));
            }
        g->inertia_kernel(Ron, on_at, on_rates, on_accelerations, on_sections, on_gravity, on_reference, on_force,
                          on_by_reference);
        for (int64_t col = 0; col < k; ++col)
            for (int64_t j = 0; j < g->n_on; ++j)
                for (int p = 0; p < 14; ++p)
                    by_reference[14 * (col * E + g->on[j]) + p] += on_by_reference[14 * (col * g->n_on + j) + p];
    }
    for (int64_t col = 0; col < k; ++col)
        for (int64_t i = 0; i < E; ++i) {
            const int64_t *dofs = m->element_dofs + 14 * g->elements[i];
            for (int p = 0; p < 14; ++p) total[dofs[p] * k + col] += by_reference[14 * (col * E + i) + p];
        }
    static const double identity[9] = {1, 0, 0, 0, 1, 0, 0, 0, 1};
    double *T = g->arm_scratch, *values = T + 9 * k, *frames = values + 6 * k, *moves = frames + 9 * k;
    for (int64_t a = 0; a < g->n_arms; ++a) {
        const int64_t node = g->arm_node[a], frame = g->arm_frame[a];
        const double *at_grid = g->arm_values + 6 * (g->n_arms * (grid - g->values_from) + a);
        for (int64_t col = 0; col < k; ++col) {
            memcpy(T + 9 * col, c->T + 9 * node, 9 * sizeof(double));
            memcpy(values + 6 * col, at_grid, 6 * sizeof(double));
            memcpy(frames + 9 * col, frame >= 0 ? c->T + 9 * frame : identity, 9 * sizeof(double));
        }
        g->arm_kernel(k, T, g->arm_moves + 3 * k * a, values, frames, moves);
        const int64_t *d = m->node_dofs + 6 * node;
        for (int j = 0; j < 6; ++j)
            for (int64_t col = 0; col < k; ++col) total[d[j] * k + col] += moves[6 * col + j];
    }
}
