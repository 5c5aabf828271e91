/*
 * Rigid links in the compiled Newton iteration: the dependent nodes completed after every
 * configuration update, and every evaluation reduced onto the minimum coordinates, in C.
 *
 * Runtime code, written by hand, that holds no physics of its own: a dependent node's frame,
 * position and rates from its parent through the edge's hinge or slide, the edge's factors of the
 * map J and of the velocity-quadratic accelerations (kernels rigid_link_edge, prismatic_link_edge),
 * and the generalized force of a wrench on a hinge, a slide or a root with its derivative by the
 * configuration (hinge_wrench, slide_wrench, root_wrench) come from the generated unit generated/joints.c (codegen/joints.py, whose module
 * docstring has the equations), called through function pointers. What is here composes them
 * along the tree and applies the projection P = [I; J] of latdyn/model/links.py:
 *
 *     r_min = Pᵀ r_all,   S_min = Pᵀ (β′M + γ′C + K) P + γ′ Pᵀ M_·dep ∂c/∂v + ∂(Pᵀ)/∂q · r_all
 *                              + Pᵀ (C_·dep ∂(J v)/∂q + M_·dep ∂(J a + c)/∂q)
 *
 * (the last with the inertia tangent, the exact matrix: the dependent nodes' rates move with the
 * coordinates at fixed independent rates, through the edge kernels' rates_D_q factors composed along the
 * tree, dependent_rates_tangent)
 *
 * (the analyses driven from Python call the same reduction: latdyn_linked_matrices and latdyn_linked_reduce_total,
 * csrc/linked_matrices.c, from latdyn/assembly/linked.py).
 *
 * Slots: every dependent node and every root of the link trees has a slot, with its columns: the
 * coordinates its configuration moves with (a root's six; a dependent node's parent's columns, then
 * its edge's hinge), so that a slot's columns begin with its parent's. Per slot, J (6 × width,
 * row-major: the slot node's [δd, δπ] per unit of each column; a root's is the identity) and ∂c/∂v
 * (6 × width: ∂(a, α)/∂ of the columns' rates). Blocks (element, body, load, controller coupling,
 * cable element) that touch a dependent
 * coordinate are reduced through their expansions: per block coordinate, its slot and component (a
 * dependent coordinate) or its column among the block's reduced coordinates (a free one; -1 for a
 * constrained one), and, for a dependent coordinate, the reduced column of each of its slot's
 * columns (-1: constrained). Every matrix position is precomputed by latdyn/step/compiled.py.
 */

/* generated/joints.c (codegen/joints.py) */
typedef void (*kernel_rigid_link_edge)(int64_t, const double *, const double *, double *, double *, double *,
                                       double *, double *, double *);
typedef void (*kernel_hinge_wrench)(int64_t, const double *, const double *, const double *, double *, double *);
typedef void (*kernel_root_wrench)(int64_t, const double *, double *, double *);
typedef void (*kernel_closure_wrench)(int64_t, const double *, const double *, const double *, double *, double *);
typedef void (*kernel_rates_D_q)(int64_t, const double *, const double *, double *);

/* The rigid links of a model, as the C step reads them (mirrored in latdyn/assembly/library.py). */
typedef struct Links {
    int64_t n_edges, n_slots, width, n_assembled;
    /* edges in tree order (parents before children): nodes, hinge (-1 clamped), kind (1: prismatic,
     * a guide's slide, its hinge coordinate the slide s; 0: revolute or clamped; 2, 3: a closure edge,
     * the slider or the rigid rod of a slider-crank, functions of the parent's position, with no
     * coordinate; the closure's child is a leaf), slots, and each edge's kernel input: a[3] o[3] b[3] s
     * (s = 0 on a clamped edge; the hinge's angle, rate and acceleration follow), or a closure edge's
     * o[3] a[3] n[3] l sigma beta0 0 (codegen/joints.py, "Closure edges") */
    const int64_t *edge_parent, *edge_child, *edge_hinge, *edge_kind, *edge_parent_slot, *edge_slot;
    const double *edge_data; /* (n_edges, 13) */
    /* slots: node, root slot, the edge into it (-1: a root), column count and columns (n_slots, width),
     * the matrix positions of (column, column) pairs (n_slots, width, width; -1: constrained) */
    const int64_t *slot_node, *slot_root, *slot_edge, *slot_count, *slot_columns, *slot_position;
    /* blocks that touch a dependent coordinate: the linked block of each element, body, load,
     * continuous controller's coupling entry and cable element (-1: none), its row and column expansion
     * and where its positions (reduced rows × reduced columns, row-major) begin in `positions` */
    const int64_t *element_block, *body_block, *load_block, *coupling_block, *cable_block;
    const int64_t *block_rows, *block_columns, *block_position, *positions;
    /* expansions: coordinates, reduced columns, where their coordinates begin; per coordinate
     * (all expansions one after the other) the slot (-1: not dependent), the component, and the
     * reduced column map (width each) */
    const int64_t *expansion_size, *expansion_reduced, *expansion_start;
    const int64_t *dof_slot, *dof_component, *dof_map;
    kernel_rigid_link_edge rigid_link_edge;
    kernel_hinge_wrench hinge_wrench;
    kernel_root_wrench root_wrench;
    kernel_rigid_link_edge prismatic_link_edge; /* the same signatures: a guide's edge and slide */
    kernel_hinge_wrench slide_wrench;
    kernel_rigid_link_edge slider_closure_edge, rod_closure_edge; /* the same signature: closure edges */
    kernel_closure_wrench slider_closure_wrench, rod_closure_wrench;
    /* buffers: J and ∂c/∂v of every slot (n_slots, 6, width); the dependent nodes' residual rows
     * (n_slots, 6); scratch of the block reduction (6 × max coordinates × max reduced + max reduced²) */
    double *jacobian, *convective, *wrench, *scratch;
    /* each edge kind's factor of the dependent rates' q-dependence (rigid_link_edge_rates_D_q, …:
     * ∂(v, w, a, alpha)_c/∂(δx_p, δπ_p, δθ) at fixed rates), in the order of the edge kinds 0-3 */
    kernel_rates_D_q rates_D_q[4];
    /* ∂(v, w, a, alpha)/∂q of every slot at fixed independent rates (n_slots, 12, width; roots zero) */
    double *rates_tangent;
} Links;

/* The dependent nodes of c from their parents, edge by edge in tree order (frames, positions and
 * rates in place), with J and ∂c/∂v of every slot. */
static void complete_links(const Model *m, Configuration *c)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    for (int64_t k = 0; k < L->n_edges; ++k) {
        const int64_t p = L->edge_parent[k], child = L->edge_child[k], h = L->edge_hinge[k];
        double parent[24], edge[13], transfer[36], joint[6], conv[42], rates[12];
        memcpy(parent, c->x + 3 * p, 3 * sizeof(double));
        memcpy(parent + 3, c->T + 9 * p, 9 * sizeof(double));
        memcpy(parent + 12, c->v + 3 * p, 3 * sizeof(double));
        memcpy(parent + 15, c->w + 3 * p, 3 * sizeof(double));
        memcpy(parent + 18, c->a + 3 * p, 3 * sizeof(double));
        memcpy(parent + 21, c->alpha + 3 * p, 3 * sizeof(double));
        const int64_t kind = L->edge_kind[k];
        memcpy(edge, L->edge_data + 13 * k, 13 * sizeof(double));
        if (kind < 2) {
            edge[10] = h >= 0 ? c->theta[h] : 0.0;
            edge[11] = h >= 0 ? c->theta_dot[h] : 0.0;
            edge[12] = h >= 0 ? c->theta_ddot[h] : 0.0;
        }
        const kernel_rigid_link_edge kernel = kind == 1 ? L->prismatic_link_edge : kind == 2 ? L->slider_closure_edge
                                            : kind == 3 ? L->rod_closure_edge : L->rigid_link_edge;
        kernel(1, parent, edge, c->x + 3 * child, c->T + 9 * child, rates, transfer, joint, conv);
        memcpy(c->v + 3 * child, rates, 3 * sizeof(double));
        memcpy(c->w + 3 * child, rates + 3, 3 * sizeof(double));
        memcpy(c->a + 3 * child, rates + 6, 3 * sizeof(double));
        memcpy(c->alpha + 3 * child, rates + 9, 3 * sizeof(double));
        /* J_c = transfer J_p (+ the joint column); ∂c_c/∂v = transfer ∂c_p/∂v + conv [J_p; e_θ] */
        const int64_t sp = L->edge_parent_slot[k], sc = L->edge_slot[k];
        const int64_t np = L->slot_count[sp], nc = L->slot_count[sc];
        const double *Jp = L->jacobian + 6 * W * sp, *Cp = L->convective + 6 * W * sp;
        double *Jc = L->jacobian + 6 * W * sc, *Cc = L->convective + 6 * W * sc;
        for (int i = 0; i < 6; ++i) {
            for (int64_t j = 0; j < np; ++j) {
                double s = 0.0, t = 0.0;
                for (int q = 0; q < 6; ++q) {
                    s += transfer[6 * i + q] * Jp[W * q + j];
                    t += transfer[6 * i + q] * Cp[W * q + j] + conv[7 * i + q] * Jp[W * q + j];
                }
                Jc[W * i + j] = s;
                Cc[W * i + j] = t;
            }
            if (nc > np) {  /* the edge's hinge: the last column */
                Jc[W * i + np] = joint[i];
                Cc[W * i + np] = conv[7 * i + 6];
            }
        }
    }
}

/* ∂(v, w, a, alpha)/∂q at fixed independent rates of every slot at c (L->rates_tangent; c's dependent nodes
 * completed, J and ∂c/∂v of c in the buffers), edge by edge in tree order:
 *     R_c = D [J_p; e_θ] + [[transfer, 0], [∂(a, alpha)_c/∂(v, w)_p, transfer]] R_p,   R_root = 0,
 * D the edge kind's rates_D_q (12 × 7), transfer and ∂(a, alpha)_c/∂(v, w)_p the edge kernel's. */
static void dependent_rates_tangent(const Model *m, const Configuration *c)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    for (int64_t k = 0; k < L->n_edges; ++k) {
        const int64_t p = L->edge_parent[k], h = L->edge_hinge[k], kind = L->edge_kind[k];
        double parent[24], edge[13], x[3], T[9], rates[12], transfer[36], joint[6], conv[42], D[84];
        memcpy(parent, c->x + 3 * p, 3 * sizeof(double));
        memcpy(parent + 3, c->T + 9 * p, 9 * sizeof(double));
        memcpy(parent + 12, c->v + 3 * p, 3 * sizeof(double));
        memcpy(parent + 15, c->w + 3 * p, 3 * sizeof(double));
        memcpy(parent + 18, c->a + 3 * p, 3 * sizeof(double));
        memcpy(parent + 21, c->alpha + 3 * p, 3 * sizeof(double));
        memcpy(edge, L->edge_data + 13 * k, 13 * sizeof(double));
        if (kind < 2) {
            edge[10] = h >= 0 ? c->theta[h] : 0.0;
            edge[11] = h >= 0 ? c->theta_dot[h] : 0.0;
            edge[12] = h >= 0 ? c->theta_ddot[h] : 0.0;
        }
        const kernel_rigid_link_edge kernel = kind == 1 ? L->prismatic_link_edge : kind == 2 ? L->slider_closure_edge
                                            : kind == 3 ? L->rod_closure_edge : L->rigid_link_edge;
        kernel(1, parent, edge, x, T, rates, transfer, joint, conv);
        L->rates_D_q[kind](1, parent, edge, D);
        const int64_t sp = L->edge_parent_slot[k], sc = L->edge_slot[k];
        const int64_t np = L->slot_count[sp], nc = L->slot_count[sc];
        const double *Jp = L->jacobian + 6 * W * sp, *Rp = L->rates_tangent + 12 * W * sp;
        double *Rc = L->rates_tangent + 12 * W * sc;
        for (int i = 0; i < 12; ++i) {
            for (int64_t j = 0; j < nc; ++j) {
                double s = j == np ? D[7 * i + 6] : 0.0; /* the edge's coordinate: the last column */
                if (j < np) {
                    for (int q = 0; q < 6; ++q) s += D[7 * i + q] * Jp[W * q + j];
                    for (int q = 0; q < 6; ++q) { /* the parent's rates' own dependence */
                        const double by_rate = i < 6 ? transfer[6 * i + q] : conv[7 * (i - 6) + q];
                        s += by_rate * Rp[W * q + j];
                        if (i >= 6) s += transfer[6 * (i - 6) + q] * Rp[W * (6 + q) + j];
                    }
                }
                Rc[W * i + j] = s;
            }
        }
    }
}

/* The dependent nodes of c completed from the independent ones, in place (NativeModel.complete_links:
 * probes, energies and the analyses driven from Python); nothing without rigid links. */
void latdyn_complete_links(const Model *m, Configuration *c)
{
    if (m->links) complete_links(m, c);
}

/* L->rates_tangent at c (dependent_rates_tangent; c's dependent nodes completed by latdyn_complete_links):
 * the analyses driven from Python read it (latdyn/assembly/linked.py); nothing without rigid links. */
void latdyn_dependent_rates_tangent(const Model *m, const Configuration *c)
{
    if (m->links) dependent_rates_tangent(m, c);
}

/* P_e (size × reduced) of expansion x from the slots' J, its ∂c/∂v rows and its rows of ∂(v, w)/∂q and
 * ∂(a, alpha)/∂q at fixed rates (L->rates_tangent) (each NULL: not wanted). */
static void expand(const Links *L, int64_t x, double *P, double *C, double *Rv, double *Ra)
{
    const int64_t W = L->width, size = L->expansion_size[x], reduced = L->expansion_reduced[x];
    const int64_t start = L->expansion_start[x];
    memset(P, 0, sizeof(double) * size * reduced);
    if (C) memset(C, 0, sizeof(double) * size * reduced);
    if (Rv) memset(Rv, 0, sizeof(double) * size * reduced);
    if (Ra) memset(Ra, 0, sizeof(double) * size * reduced);
    for (int64_t d = 0; d < size; ++d) {
        const int64_t slot = L->dof_slot[start + d], *map = L->dof_map + W * (start + d);
        if (slot < 0) {
            if (map[0] >= 0) P[reduced * d + map[0]] = 1.0;
            continue;
        }
        const int64_t k = L->dof_component[start + d];
        const double *J = L->jacobian + 6 * W * slot + W * k, *Cv = L->convective + 6 * W * slot + W * k;
        const double *R = L->rates_tangent + 12 * W * slot + W * k;
        for (int64_t j = 0; j < L->slot_count[slot]; ++j) {
            if (map[j] < 0) continue;
            P[reduced * d + map[j]] = J[j];
            if (C) C[reduced * d + map[j]] = Cv[j];
            if (Rv) Rv[reduced * d + map[j]] = R[j];
            if (Ra) Ra[reduced * d + map[j]] = R[6 * W + j];
        }
    }
}

/* Pᵀ_rows (S P_cols + γ′ M ∂c/∂v_cols + Cd ∂(v, w)/∂q_cols + M ∂(a, alpha)/∂q_cols) of linked block b into
 * `matrix` (the matrix storage's layout): S the block's β′M + γ′C + K (rows × columns, row-major), M its
 * mass block or NULL; with `rates` (an evaluation with inertia) the dependent rates' q-dependence at fixed
 * independent rates through the block's damping Cd (or NULL) and mass. */
static void reduce_block(const Links *L, double *matrix, int64_t b, const double *S, const double *M,
                         const double *Cd, double gamma_p, int rates)
{
    const int64_t xr = L->block_rows[b], xc = L->block_columns[b];
    const int64_t nr = L->expansion_size[xr], nc = L->expansion_size[xc];
    const int64_t ur = L->expansion_reduced[xr], uc = L->expansion_reduced[xc];
    double *Pr = L->scratch, *Pc = Pr + nr * ur, *Cc = Pc + nc * uc, *Rv = Cc + nc * uc, *Ra = Rv + nc * uc;
    double *B = Ra + nc * uc;
    const int by_velocity = rates && Cd, by_acceleration = rates && M;
    expand(L, xr, Pr, NULL, NULL, NULL);
    expand(L, xc, Pc, M ? Cc : NULL, by_velocity ? Rv : NULL, by_acceleration ? Ra : NULL);
    for (int64_t i = 0; i < nr; ++i)
        for (int64_t j = 0; j < uc; ++j) {
            double s = 0.0;
            for (int64_t q = 0; q < nc; ++q) {
                s += S[nc * i + q] * Pc[uc * q + j];
                if (M) s += gamma_p * M[nc * i + q] * Cc[uc * q + j];
                if (by_velocity) s += Cd[nc * i + q] * Rv[uc * q + j];
                if (by_acceleration) s += M[nc * i + q] * Ra[uc * q + j];
            }
            B[uc * i + j] = s;
        }
    const int64_t *position = L->positions + L->block_position[b];
    for (int64_t i = 0; i < ur; ++i)
        for (int64_t j = 0; j < uc; ++j) {
            if (position[uc * i + j] < 0) continue;
            double s = 0.0;
            for (int64_t q = 0; q < nr; ++q) s += Pr[ur * q + i] * B[uc * q + j];
            matrix[position[uc * i + j]] += s;
        }
}

/* A block's β′M + γ′C + (K + D) added into the matrix storage at its positions `pos` (−1: not a free
 * coordinate's entry); M, C, D may be NULL (assemble and assemble_linked scatter every block by it). */
static void scatter_block(double *matrix, const int64_t *pos, const double *M, const double *C, const double *K,
                          const double *D, int64_t size, double beta_p, double gamma_p)
{
    for (int64_t p = 0; p < size; ++p)
        if (pos[p] >= 0)
            matrix[pos[p]] += (M ? beta_p * M[p] : 0.0) + (C ? gamma_p * C[p] : 0.0) + (K[p] + (D ? D[p] : 0.0));
}

/* A block's S = β′M + γ′C + K (+ D, the inertia tangent), row-major, into `out`; M, C, D may be NULL. */
static void combined_block(const double *M, const double *C, const double *K, const double *D, int64_t size,
                           double beta_p, double gamma_p, double *out)
{
    for (int64_t p = 0; p < size; ++p)
        out[p] = (M ? beta_p * M[p] : 0.0) + (C ? gamma_p * C[p] : 0.0) + K[p] + (D ? D[p] : 0.0);
}

/* Where geometric_term puts its entries: with `matrix` at their positions in the matrix storage, else (matrix
 * NULL) times a vector: out[row] += entry · rate[column] for a free row and a column marked in `columns` (the
 * prescribed coordinates' ∂(Pᵀ)/∂q_p · r_all q̇_p, linked_prescribed_rates.c). */
typedef struct {
    const int64_t *columns;   /* (n_total + 1): 1 on the columns taken */
    const double *rate;       /* (n_total + 1): the vector */
    int64_t n;                /* the free coordinates (rows below n) */
    double *out;              /* (n_total + 1) */
} GeometricProduct;

/* One entry of ∂(Pᵀ)/∂q · r_all: row i, column j of slot s's columns, at `position` in the matrix storage (−1:
 * not a free coordinates' entry), into `matrix` or, without it, into the product (GeometricProduct). */
static inline void geometric_entry(const Links *L, double *matrix, int64_t position, int64_t s, int64_t i, int64_t j,
                                   double value, const GeometricProduct *product)
{
    if (matrix != NULL) {
        if (position >= 0) matrix[position] += value;
        return;
    }
    const int64_t row = L->slot_columns[L->width * s + i], column = L->slot_columns[L->width * s + j];
    if (row < product->n && product->columns[column]) product->out[row] += value * product->rate[column];
}

/* The inputs of edge k's hinge_wrench or slide_wrench at c for the wrench r (6) of dependent node `node`: the edge
 * parent's position and frame (12), the edge's axis, point and sign (7), the node's position and r (9). */
static void hinge_wrench_inputs(const Links *L, const Configuration *c, int64_t k, int64_t node, const double *r,
                                double *parent, double *data, double *wrench)
{
    const int64_t p = L->edge_parent[k];
    memcpy(parent, c->x + 3 * p, 3 * sizeof(double));
    memcpy(parent + 3, c->T + 9 * p, 9 * sizeof(double));
    memcpy(data, L->edge_data + 13 * k, 6 * sizeof(double));
    data[6] = L->edge_data[13 * k + 9];
    memcpy(wrench, c->x + 3 * node, 3 * sizeof(double));
    memcpy(wrench + 3, r, 6 * sizeof(double));
}

/* ∂(Pᵀ)/∂q · r_all, the geometric stiffness, from the dependent nodes' residual rows in L->wrench (which the closures
 * change: set them anew before each call) at c, into `matrix` (the matrix storage) or, with matrix NULL, times the
 * vector of `g_sink` (geometric_entry). */
static void geometric_term(const Model *m, const Configuration *c, double *matrix, const GeometricProduct *g_sink)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    /* ∂(Pᵀ)/∂q · r_all: each dependent node's wrench (f, m) at x_c, on its root (root_wrench, by δx_r
     * and δx_c) and on every hinge or slide of its path (hinge_wrench or slide_wrench, by the edge
     * parent's δx, δπ and δx_c) */
    double row[W > 0 ? W : 1];
    /* closure edges (leaves): their wrench r moves the pin as g = transferᵀ r, whose derivative by the pin's
     * position D (slider_closure_wrench, rod_closure_wrench) gives J_pᵀ D J_p on the pin's columns; g joins
     * the pin's wrench (a dependent pin) for the terms of the pin's path below */
    for (int64_t s = 0; s < L->n_slots; ++s) {
        const int64_t edge = L->slot_edge[s];
        if (edge < 0 || L->edge_kind[edge] < 2) continue;
        const double *r = L->wrench + 6 * s;
        if (!(r[0] || r[1] || r[2] || r[3] || r[4] || r[5])) continue;
        const int64_t sp = L->edge_parent_slot[edge], count = L->slot_count[sp];
        const double *Jp = L->jacobian + 6 * W * sp;
        const int64_t *position = L->slot_position + W * W * sp;
        double g[3], D[9];
        (L->edge_kind[edge] == 2 ? L->slider_closure_wrench : L->rod_closure_wrench)(
            1, c->x + 3 * L->edge_parent[edge], L->edge_data + 13 * edge, r, g, D);
        for (int64_t i = 0; i < count; ++i)
            for (int64_t j = 0; j < count; ++j) {
                double value = 0.0;
                for (int a = 0; a < 3; ++a)
                    for (int b = 0; b < 3; ++b) value += Jp[W * a + i] * D[3 * a + b] * Jp[W * b + j];
                geometric_entry(L, matrix, position[W * i + j], sp, i, j, value, g_sink);
            }
        if (L->slot_edge[sp] >= 0)
            for (int a = 0; a < 3; ++a) L->wrench[6 * sp + a] += g[a];
    }
    for (int64_t s = 0; s < L->n_slots; ++s) {
        const int64_t edge = L->slot_edge[s];
        if (edge < 0 || L->edge_kind[edge] >= 2) continue;
        const double *r = L->wrench + 6 * s;
        if (!(r[0] || r[1] || r[2] || r[3] || r[4] || r[5])) continue;
        const int64_t node = L->slot_node[s], count = L->slot_count[s], root = L->slot_root[s];
        const double *Jc = L->jacobian + 6 * W * s;
        const int64_t *position = L->slot_position + W * W * s;
        double input[12], value[6], D[36];
        memcpy(input, c->x + 3 * L->slot_node[root], 3 * sizeof(double));
        memcpy(input + 3, c->x + 3 * node, 3 * sizeof(double));
        memcpy(input + 6, r, 6 * sizeof(double));
        L->root_wrench(1, input, value, D);
        for (int i = 0; i < 6; ++i) {  /* the root's column i: δx_r is the identity on columns 0-2 */
            for (int64_t j = 0; j < count; ++j) {
                double g = j < 3 ? D[6 * i + j] : 0.0;
                for (int q = 0; q < 3; ++q) g += D[6 * i + 3 + q] * Jc[W * q + j];
                row[j] = g;
            }
            for (int64_t j = 0; j < count; ++j)
                geometric_entry(L, matrix, position[W * i + j], s, i, j, row[j], g_sink);
        }
        for (int64_t t = s; L->slot_edge[t] >= 0; t = L->edge_parent_slot[L->slot_edge[t]]) {
            const int64_t k = L->slot_edge[t];
            if (L->edge_hinge[k] < 0) continue;
            const int64_t sp = L->edge_parent_slot[k], column = L->slot_count[t] - 1;
            const double *Jp = L->jacobian + 6 * W * sp;
            double parent[12], data[7], wrench[9], force, Dh[9];
            hinge_wrench_inputs(L, c, k, node, r, parent, data, wrench);
            (L->edge_kind[k] == 1 ? L->slide_wrench : L->hinge_wrench)(1, parent, data, wrench, &force, Dh);
            for (int64_t j = 0; j < count; ++j) {
                double g = 0.0;
                if (j < L->slot_count[sp])
                    for (int q = 0; q < 6; ++q) g += Dh[q] * Jp[W * q + j];
                for (int q = 0; q < 3; ++q) g += Dh[6 + q] * Jc[W * q + j];
                geometric_entry(L, matrix, position[W * column + j], s, column, j, g, g_sink);
            }
        }
    }
}

/* The reduced iteration matrix Pᵀ(β′M + γ′C + K)P + γ′ Pᵀ M_·dep ∂c/∂v + ∂(Pᵀ)/∂q · r_all into the
 * matrix storage (assemble's counterpart for a model with rigid links): the blocks without a
 * dependent coordinate as assemble scatters them, the others through their expansions, then the
 * geometric stiffness from the dependent nodes' residual rows (L->wrench). */
static void assemble_linked_into(const Model *m, Work *w, const Configuration *c, double beta_p, double gamma_p,
                                 int stiffness, int inertia, int with_inertia_tangent, int rates, const double *body_D,
                                 double *matrix);

static void assemble_linked(const Model *m, Work *w, const Configuration *c, double beta_p, double gamma_p,
                            int with_inertia_tangent, int rates)
{
    assemble_linked_into(m, w, c, beta_p, gamma_p, 1, 1, with_inertia_tangent, rates, NULL, w->matrix);
}

/* assemble_linked's β′M + γ′C + K into `matrix` (the iteration matrix's storage), K's terms (the blocks' K, the
 * hinges' ∂/∂θ, the loads', the geometric term, the dependent rates' term) only with `stiffness` (else zero: M or
 * C alone, latdyn_linked_matrices); without `inertia` (a static evaluation, whose elements' and joint bodies' M and
 * C in w are not its own) those blocks' M and C left out, the hinges', cables' and controllers' damping kept;
 * body_D (NULL: none) 36 per joint body added to its K block, as the elements' inertia tangent D is (the joint
 * bodies' inertia stiffness: the exact K). */
static void assemble_linked_into(const Model *m, Work *w, const Configuration *c, double beta_p, double gamma_p,
                                 int stiffness, int inertia, int with_inertia_tangent, int rates, const double *body_D,
                                 double *matrix)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    static const double zeros[196];
    double S[196];
    rates = rates && stiffness;
    memset(matrix, 0, sizeof(double) * m->factorization->size);
    if (rates) dependent_rates_tangent(m, c);
    for (int64_t e = 0; e < m->n_elements; ++e) {
        const double *K = stiffness ? w->tangent + 196 * e : zeros, *M = inertia ? w->mass + 196 * e : NULL;
        const double *C = inertia ? w->quadratic_D + 196 * e : NULL;
        const double *D = with_inertia_tangent && stiffness ? w->inertia_tangent + 196 * e : NULL;
        if (L->element_block[e] >= 0) {
            combined_block(M, C, K, D, 196, beta_p, gamma_p, S);
            reduce_block(L, matrix, L->element_block[e], S, M, C, gamma_p, rates);
            continue;
        }
        scatter_block(matrix, m->element_position + 196 * e, M, C, K, D, 196, beta_p, gamma_p);
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        const double *M = inertia ? w->body_mass + 36 * b : NULL, *C = inertia ? w->body_damping + 36 * b : NULL;
        const double *K = stiffness ? w->body_stiffness + 36 * b : zeros;
        const double *D = body_D && stiffness ? body_D + 36 * b : NULL;
        if (L->body_block[b] >= 0) {
            combined_block(M, C, K, D, 36, beta_p, gamma_p, S);
            reduce_block(L, matrix, L->body_block[b], S, M, C, gamma_p, rates);
            continue;
        }
        scatter_block(matrix, m->body_position + 36 * b, M, C, K, D, 36, beta_p, gamma_p);
    }
    for (int64_t j = 0; j < m->n_hinges; ++j)
        if (m->hinge_position[j] >= 0)
            matrix[m->hinge_position[j]] += gamma_p * w->hinge_d_rate[j] + (stiffness ? w->hinge_d_theta[j] : 0.0);
    for (int64_t l = 0; l < (stiffness ? m->n_loads : 0); ++l) {
        const double *K = w->load_blocks + 36 * l;
        if (L->load_block[l] >= 0) {
            reduce_block(L, matrix, L->load_block[l], K, NULL, NULL, gamma_p, rates);
            continue;
        }
        scatter_block(matrix, m->load_position + 36 * l, NULL, NULL, K, NULL, 36, beta_p, gamma_p);
    }
    /* continuous controllers: the actuators' rows by the sensors' coordinates (evaluate.c), an entry
     * at a dependent coordinate through its expansions */
    for (int64_t e = 0; e < m->n_couplings; ++e) {
        const double value = gamma_p * w->coupling_damping[e] + (stiffness ? w->coupling_stiffness[e] : 0.0);
        if (L->coupling_block[e] >= 0)
            reduce_block(L, matrix, L->coupling_block[e], &value, NULL, w->coupling_damping + e, gamma_p, rates);
        else if (m->coupling_position[e] >= 0)
            matrix[m->coupling_position[e]] += value;
    }
    /* cable elements: γ′C + K of the generated cable_force (no mass), 12 × 12 on both ends' [d, π] */
    for (int64_t e = 0; e < m->n_cables; ++e) {
        const double *K = stiffness ? w->cable_stiffness + 144 * e : zeros, *C = w->cable_damping + 144 * e;
        if (L->cable_block[e] >= 0) {
            combined_block(NULL, C, K, NULL, 144, beta_p, gamma_p, S);
            reduce_block(L, matrix, L->cable_block[e], S, NULL, C, gamma_p, rates);
            continue;
        }
        scatter_block(matrix, m->cable_position + 144 * e, NULL, C, K, NULL, 144, beta_p, gamma_p);
    }
    if (!stiffness) return;
    geometric_term(m, c, matrix, NULL);
}

/* The reduced mass matrix Pᵀ M P of the evaluation left in w (with inertia, at c, its dependent nodes
 * completed) into `matrix`, a storage of the iteration matrix's layout other than w->matrix (which holds
 * modified Newton's factorization): assemble_linked's blocks with (α_M, α_C, α_K) = (1, 0, 0), the
 * elements' and joint bodies' mass blocks (scattered, or reduced through their expansions), nothing of
 * the hinges, loads, controllers, cables or the geometric term (stiffness and damping alone). The slope of
 * the reduced residual Pᵀ r(q, v, P v̇ + c) in v̇ (latdyn.assembly.linked LinkedEvaluation.combined(1, 0, 0)):
 * the restart after a sample solves with it (sampling.c). */
static void assemble_linked_mass(const Model *m, const Work *w, double *matrix)
{
    const Links *L = m->links;
    memset(matrix, 0, sizeof(double) * m->factorization->size);
    for (int64_t e = 0; e < m->n_elements; ++e) {
        const double *M = w->mass + 196 * e;
        if (L->element_block[e] >= 0) reduce_block(L, matrix, L->element_block[e], M, NULL, NULL, 0.0, 0);
        else
            for (int p = 0; p < 196; ++p)
                if (m->element_position[196 * e + p] >= 0) matrix[m->element_position[196 * e + p]] += M[p];
    }
    for (int64_t b = 0; b < m->n_bodies; ++b) {
        const double *M = w->body_mass + 36 * b;
        if (L->body_block[b] >= 0) reduce_block(L, matrix, L->body_block[b], M, NULL, NULL, 0.0, 0);
        else
            for (int p = 0; p < 36; ++p)
                if (m->body_position[36 * b + p] >= 0) matrix[m->body_position[36 * b + p]] += M[p];
    }
}

/* The vector of all coordinates `total` (n_total + 1: residual, then reactions) reduced onto the minimum
 * coordinates, in place: r_min = Pᵀ r_all on the free coordinates, Jᵀ r_dep added to the reactions of the
 * constrained ones, the dependent rows cleared (kept in L->wrench for the geometric stiffness). */
static void reduce_total(const Model *m, double *total)
{
    const Links *L = m->links;
    const int64_t W = L->width;
    for (int64_t s = 0; s < L->n_slots; ++s) {
        if (L->slot_edge[s] < 0) continue;
        const int64_t *d = m->node_dofs + 6 * L->slot_node[s];
        for (int k = 0; k < 6; ++k) L->wrench[6 * s + k] = total[d[k]];
    }
    for (int64_t i = m->n_dofs; i < L->n_assembled; ++i) total[i] = 0.0;
    for (int64_t s = 0; s < L->n_slots; ++s) {
        if (L->slot_edge[s] < 0) continue;
        const double *J = L->jacobian + 6 * W * s, *r = L->wrench + 6 * s;
        const int64_t *columns = L->slot_columns + W * s;
        for (int64_t j = 0; j < L->slot_count[s]; ++j) {
            double f = 0.0;
            for (int k = 0; k < 6; ++k) f += J[W * k + j] * r[k];
            total[columns[j]] += f;
        }
    }
}

/* The evaluation in w->total reduced onto the minimum coordinates, in place (reduce_total); with matrices (1: of a static evaluation,
 * 2: of one with inertia), the reduced iteration matrix (assemble_linked; with the inertia tangent and
 * inertia, the dependent rates' term too, as latdyn/assembly/linked.py's with inertia_tangent). The
 * configuration's dependent nodes are those complete_links made. */
static void reduce_links(const Model *m, Work *w, const Configuration *c, double beta_p, double gamma_p,
                         int matrices, int with_inertia_tangent)
{
    reduce_total(m, w->total);
    if (matrices) assemble_linked(m, w, c, beta_p, gamma_p, with_inertia_tangent, matrices == 2 && with_inertia_tangent);
}
