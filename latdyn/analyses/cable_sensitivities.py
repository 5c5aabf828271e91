"""The cables' part of the sensitivities: their EA, damping, rest length and ρA through the generated taut
law, their slack and taut changes as events (:class:`CableSensitivities`, used by the transient step in
latdyn/analyses/transient_sensitivities.py and by the cable probes of latdyn/analyses/probe_derivatives.py).
Kept apart from the transient step so that the probes' derivatives, which a static path uses too, can take
the cables' law without importing the step."""
from __future__ import annotations

import numpy as np

from latdyn.analyses.parameter_keys import CABLE_KEY as _CABLE_KEY
from latdyn.errors import SolverError
from latdyn.timeloop.events import cable_events
from latdyn.timeloop.landing import LANDING

__all__ = ["CableSensitivities", "LANDING"]



def _turned(T: np.ndarray, offset: np.ndarray) -> np.ndarray:
    """T r, summed as csrc/evaluate.c ``matvec3`` sums it (its three products left to right), so that the kernels'
    inputs here are the evaluation's to the bit (the loop of steps in C makes them there: csrc/cable_forces.c)."""
    return T[:, 0] * offset[0] + T[:, 1] * offset[1] + T[:, 2] * offset[2]


class CableSensitivities:
    """The cables' part of the transient sensitivities (docs/parameters.md, "Cables"), from the generated
    taut law ``cable_force`` (codegen/joints.py) alone:

    - ∂r/∂p of the elements held taut: the force is linear in (EA, c) at a fixed rest length — the kernel
      with (∂EA/∂p, ∂c/∂p) —, and its derivative by the rest length share L0 is the generated
      ``cable_force_D_rest_length`` (∂F/∂L0 and ∂[ℓ, ℓ̇, ℓ − L0, N_el, N]/∂L0);
    - the slack/taut change is an event: the step lands on the element's gap g = min(N_el, N) = 0
      (:data:`LANDING` · EA, :meth:`TransientSensitivities.land`), and the step's size follows the
      parameters so that g stays zero: ∂g/∂q δq + ∂g/∂v δv + ∂g/∂p + (∂g/∂q q_h + ∂g/∂v v_h) δh = 0,
      with q_h, v_h the step's derivative by its size. The gap's gradients are the kernel's own blocks:
      N = −e·F_1 (F_1 the first end's rows), and e·∂e = 0, so ∂N/∂q = −eᵀ K_1, ∂N/∂v = −eᵀ C_1 (with
      c = 0 for N_el).
    - nothing jumps at the change in the discrete run (the time loop neither restarts the
      accelerations nor jumps the velocities there: latdyn/timeloop/events.py), so the step's
      derivative with δh is the whole derivative; the jump of the continuous solution's sensitivity
      (Hiskens & Pai 2000: δv⁺ − δv⁻ = M⁻¹(F⁻ − F⁺) δt_e for a damped cable's jump of tension c ℓ̇ at
      taut) is what that step and the next, on the other law, carry to first order in h.
    """

    def __init__(self, owner):
        self.owner = owner
        self.model, self.kernels = owner.model, owner.kernels
        self.cables = owner.model.cables
        #: (cable index, its value, column, derivative law) of every cable parameter
        self.uses = []
        for key, laws in owner.derivatives.items():
            match = _CABLE_KEY.match(key)
            if match:
                k = self.cables.names.index(match["cable"])
                self.uses += [(k, match["value"], column, law) for column, law in laws.items()]
        #: each cable's rows of the model's joint bodies: its lumped point masses, the last rows, in the order
        #: latdyn/model/cables.py add_cables appends them (two per element, cables with mass in scene order)
        self.mass_rows, row = {}, len(self.model.body_nodes)
        massive = [(k, c) for k, c in enumerate(owner.scene.cables.values()) if c.rhoA * c.rest_length.value(0.0) > 0]
        row -= sum(2 * c.elements for _, c in massive)
        for k, cable in massive:
            self.mass_rows[k] = np.arange(row, row + 2 * cable.elements)
            row += 2 * cable.elements

    # ------------------------------------------------------------------ the taut law of one element
    def law(self, state, e: int, EA: float | None = None, c: float | None = None, L0: float | None = None):
        """The generated ``cable_force`` outputs (force (12,), K (12, 12), C (12, 12), [ℓ, ℓ̇, ℓ − L0, N_el, N])
        of element ``e`` at ``state``, with its EA, c and rest length share L0 replaced where given."""
        out = self.kernels.cable_force(*(np.ascontiguousarray(a[None]) for a in self.inputs(state, e, EA, c, L0)))
        return (np.asarray(out[0]).reshape(12), np.asarray(out[1]).reshape(12, 12),
                np.asarray(out[2]).reshape(12, 12), np.asarray(out[3]).reshape(5))

    def taut(self, state) -> np.ndarray:
        """(ce,) bool: the elements whose force the evaluation applies at ``state`` (csrc/evaluate.c
        ``cables``: held taut, or, on no side, a positive gap)."""
        sides = self.cables.sides
        out = np.zeros(len(self.cables), bool)
        for e in range(len(self.cables)):
            if sides[e] > 0:
                out[e] = True
            elif sides[e] == 0:
                _, _, _, s = self.law(state, e)
                out[e] = min(s[3], s[4]) > 0.0
        return out

    def _rows(self, e: int) -> np.ndarray:
        """(12,) the coordinates of element ``e``'s end nodes' rows [d1, π1, d2, π2] (n_total: none)."""
        dofs = self.model.node_dofs[self.cables.nodes[e]].reshape(12)
        return np.where(dofs < 0, self.model.n_total, dofs)

    def inputs(self, state, e: int, EA: float | None = None, c: float | None = None,
               L0: float | None = None) -> tuple:
        """(geometry (12,), velocity (12,), section (4,)): element ``e``'s inputs of the generated cable kernels at
        ``state`` (codegen/joints.py ``cable_geometry``, ``cable_velocity``, ``cable_section``), with its EA, c and
        rest length share L0 replaced where given."""
        cables = self.cables
        nodes = cables.nodes[e]
        offsets = [_turned(state.T[nodes[i]], cables.offsets[e, i]) for i in range(2)]
        geometry = np.concatenate([state.x[nodes[0]], state.x[nodes[1]], *offsets])
        velocity = np.concatenate([state.v[nodes[0]], state.w[nodes[0]], state.v[nodes[1]], state.w[nodes[1]]])
        rest = cables.rest_length[cables.cable[e]]
        share = cables.share[e]
        section = np.array([share * rest.value(state.t) if L0 is None else L0, share * rest.rate(state.t),
                            cables.EA[e] if EA is None else EA, cables.damping[e] if c is None else c])
        return geometry, velocity, section

    def _rest_length_derivative(self, state, e: int, which: int):
        """∂(output ``which``: 0 the force, 3 the state [ℓ, ℓ̇, ℓ − L0, N_el, N])/∂L0 of element ``e``: the generated
        ``cable_force_D_rest_length`` (codegen/joints.py)."""
        out = self.kernels.cable_force_D_rest_length(*(np.ascontiguousarray(a[None]) for a in self.inputs(state, e)))
        return np.asarray(out[0]).reshape(12) if which == 0 else np.asarray(out[1]).reshape(5)

    # ------------------------------------------------------------------ ∂r/∂p
    def residual_derivatives(self, state, total: np.ndarray, inertia: bool = False) -> None:
        """Add ∂(the taut elements' forces)/∂p into ``total`` (n_total + 1, k) (class docstring), and with
        ``inertia`` that of the lumped masses (:meth:`_mass_forces`)."""
        if not self.uses:
            return
        taut = self.taut(state)
        for k, value, column, law in self.uses:
            derivative = law.value(0.0, 0.0, state.t)
            if value in ("rhoA", "rest_length") and k in self.mass_rows and inertia:
                self._mass_forces(state, total, k, value, column, law)
            if derivative == 0.0 or value == "rhoA":
                continue
            for e in np.flatnonzero((self.cables.cable == k) & taut):
                if value == "EA":
                    force = self.law(state, e, EA=derivative, c=0.0)[0]
                elif value == "damping":
                    force = self.law(state, e, EA=0.0, c=derivative)[0]
                else:
                    force = self._rest_length_derivative(state, e, 0) * self.cables.share[e] * derivative
                np.add.at(total[:, column], self._rows(e), force)

    def _mass_forces(self, state, total: np.ndarray, k: int, value: str, column: int, law) -> None:
        """Add ∂(the inertia and gravity forces of cable ``k``'s lumped masses)/∂p into ``total``: each point
        mass is ½ ρA L(0)/elements (latdyn/model/cables.py), so ∂m = ½ (∂ρA L(0) + ρA ∂L(0))/elements, and the
        generated ``joint_body`` (a point mass at its offset, no rotary inertia) is linear in m."""
        model = self.model
        rows, block, gravity = self.mass_blocks(k, value, law)
        nodes = model.body_nodes[rows]
        frames = np.ascontiguousarray(state.T[nodes].reshape(-1, 9))
        motion = np.ascontiguousarray(np.concatenate([state.w[nodes], state.a[nodes], state.alpha[nodes]], axis=1))
        forces = np.asarray(self.kernels.joint_body(frames, motion, block, gravity)[0]).reshape(len(rows), 6)
        dofs = model.node_dofs[nodes]
        np.add.at(total[:, column], np.where(dofs < 0, model.n_total, dofs), forces)

    def mass_blocks(self, k: int, value: str, law) -> tuple:
        """(rows (r,), the generated ``joint_body``'s blocks (r, 13), g per row (r, 3)) of cable ``k``'s lumped masses
        moved by its ``value`` ("rhoA" or "rest_length") along the derivative law ``law`` (:meth:`_mass_forces`; the
        loop of steps in C takes the same, latdyn/analyses/sensitivities_in_loop.py)."""
        model, cable = self.model, list(self.owner.scene.cables.values())[k]
        derivative = law.value(0.0, 0.0, 0.0)   # ρA and the rest length at t = 0 (refused in t with events)
        share = 0.5 / cable.elements
        mass = share * (derivative * cable.rest_length.value(0.0) if value == "rhoA" else cable.rhoA * derivative)
        rows = self.mass_rows[k]
        block = np.zeros((len(rows), 13))
        block[:, 0], block[:, 1:4] = mass, model.body_com[rows]
        gravity = np.repeat(np.asarray(self.owner.assembler.gravity, float)[None], len(rows), axis=0)
        return rows, block, gravity

    # ------------------------------------------------------------------ the event
    def event(self, old, new):
        """(element, the cable's change or None) of the cable element the events turn over at the end
        of the step old → new (latdyn.timeloop.events.cable_events), or None; several at once are
        refused (SolverError)."""
        sides = list(self.cables.sides)
        turned, changes = cable_events(self.owner.assembler, sides, old, new)
        flipped = [e for e, (a, b) in enumerate(zip(sides, turned)) if a != b]
        if not flipped:
            return None
        if len(flipped) > 1:
            raise SolverError(f"the sensitivities at t = {new.t:.6g} meet several cable elements changing between "
                              "slack and taut at one instant, whose derivative is not that of one event "
                              "(docs/parameters.md, \"Cables\")")
        e = flipped[0]
        change = [kind for name, kind in changes if name == self.cables.names[self.cables.cable[e]]]
        return e, (change[0] if change else None)

    def step_size_derivative(self, new, e: int, dq: np.ndarray, dv: np.ndarray, k: int,
                             started: np.ndarray | None = None) -> np.ndarray:
        """δh (k,) of a step that ends on element ``e``'s change: its gap stays zero (class docstring);
        ``dq``, ``dv`` the step's columns, the k parameters' and the step size's (column k); ``started``
        δt_n (k,) of the step's start: a reel's rest length L0(t) moves the gap by ∂g/∂L0 L0′(t) δt_{n+1}
        (:meth:`gap_rate`). With the gap's forms (:meth:`gap_forms`), δg = g_qᵀδq + g_vᵀδv + g_p + g_t δt_{n+1} = 0:
        δh = −(g_qᵀδq_p + g_vᵀδv_p + g_p + g_t δt_n) / (g_qᵀδq_h + g_vᵀδv_h + g_t) — a linear functional of the
        step's parameter columns, which the discrete adjoint applies transposed
        (:meth:`latdyn.analyses.adjoint_sensitivities.AdjointSensitivities._step_size_transposed`)."""
        g_q, g_v, g_p, g_t = self.gap_forms(new, e, k)
        along = g_q @ dq + g_v @ dv
        if g_t and started is not None:
            g_p = g_p + g_t * started
        self.refuse_grazing(new, e, along[k] + g_t)
        return -(along[:k] + g_p) / (along[k] + g_t)

    def gap_forms(self, new, e: int, k: int) -> tuple:
        """(g_q, g_v (n,), g_p (k,), g_t): element ``e``'s gap at ``new`` moves by g_qᵀδq + g_vᵀδv + g_p + g_t δt
        (its gradients by the free coordinates and rates, by the k parameters, and by t at fixed coordinates:
        :meth:`gap_rate`)."""
        model, cables = self.model, self.cables
        damped = self._damped(new, e)              # the gap is the tension N (with its damper), else N_el
        c = cables.damping[e] if damped else 0.0
        force, K, C, s = self.law(new, e, c=c)
        # e, the unit vector from the first end point to the second (F_1 = N e)
        nodes = cables.nodes[e]
        points = [new.x[nodes[i]] + new.T[nodes[i]] @ cables.offsets[e, i] for i in range(2)]
        unit = (points[1] - points[0]) / np.linalg.norm(points[1] - points[0])
        g_q, g_v = np.zeros(model.n_total + 1), np.zeros(model.n_total + 1)
        rows = self._rows(e)
        np.add.at(g_q, rows, -unit @ K[0:3])
        np.add.at(g_v, rows, -unit @ C[0:3])
        g_q, g_v = self._on_free_coordinates(new, g_q, g_v)
        g_p = np.zeros(k)
        for cable, value, column, law in self.uses:
            if cable != cables.cable[e]:
                continue
            derivative = law.value(0.0, 0.0, new.t)
            if value == "EA":
                g_p[column] += self.law(new, e, EA=derivative, c=0.0)[3][4]
            elif value == "damping":
                g_p[column] += self.law(new, e, EA=0.0, c=derivative)[3][4] if damped else 0.0
            elif value == "rest_length":   # (rhoA moves no force of the element)
                g_p[column] += self._rest_length_derivative(new, e, 3)[3] * cables.share[e] * derivative
        return g_q, g_v, g_p, self.gap_rate(new, e)

    def refuse_grazing(self, new, e: int, rate: float) -> None:
        """A change at which the gap barely moves: over a whole step dt it moves no more than the tolerance
        to which the step lands on it (:data:`LANDING` · EA), so every instant of the step is on the change,
        the event's time is not determined and its derivative −(∂g/∂p)/ġ is round-off over round-off (a gap
        moving at EA/L · 1e-3 m/s, 1 m cable, dt = 0.01, moves 1e-5 EA over the step, 1e7 times this bound).
        Found by benchmarks/fuzz_sensitivities.py (seed 3 case 17): a cable beside a rigid link between the
        same two bodies keeps its rest length, went taut and slack 18 times at round-off and reported the
        event times' derivatives as −5e-5 … 3e-4 and the tip's 1.3e-8, all exactly 0
        (tests/test_sensitivities_fuzz_finds.py). Ended (SolverError)."""
        dt = float(self.owner.scene.solve.dt)
        tolerance = LANDING * float(self.cables.EA[e])
        if abs(rate) * dt <= tolerance:
            name = self.cables.names[self.cables.cable[e]]
            raise SolverError(f"the sensitivities at t = {new.t:.6g} meet cables.{name} changing side while its gap "
                              f"barely moves (its rate {rate:.3g} moves it {abs(rate) * dt:.3g} in a step dt, within "
                              f"the landing's tolerance {tolerance:.3g}: a grazing change, whose time "
                              "and its derivative are not determined; docs/parameters.md, \"Cables\")")

    def _on_free_coordinates(self, state, g_q: np.ndarray, g_v: np.ndarray) -> tuple:
        """The gap's gradients by all coordinates' configuration and rates (n_total + 1,) on the free ones: their
        first n_dofs entries, or with rigid links or guides (an end on a node that follows them) through the
        reduction, δq_all = P δq and δv_all = P δv + ∂(J v)/∂q δq (the dependent rates at fixed free rates,
        latdyn/assembly/linked.py): g_q ← Pᵀ g_q + (∂(J v)/∂q)ᵀ g_v(dependent rows), g_v ← Pᵀ g_v."""
        model = self.model
        if model.links is None:
            return g_q[:model.n_dofs], g_v[:model.n_dofs]
        from latdyn.assembly.linked import evaluate_linked

        assembler = self.owner.assembler
        ev = evaluate_linked(model.links, assembler, state, True, 1.0, True, inertia_tangent=True, rates_term=True)
        P, n_asm = ev.projection, model.n_assembled
        by_velocity = np.asarray(ev.rates_tangent[0].toarray() if hasattr(ev.rates_tangent[0], "toarray")
                                 else ev.rates_tangent[0])
        free_q = np.asarray(P.T @ g_q[:n_asm]).reshape(-1) + by_velocity.T @ g_v[ev.dependent_rows]
        return free_q, np.asarray(P.T @ g_v[:n_asm]).reshape(-1)

    def gap_rate(self, state, e: int) -> float:
        """∂g/∂t of element ``e``'s gap at fixed free coordinates: through its cable's rest length (a reel,
        ∂g/∂L0 · share · L0′(t); the law reads L0 and the gap never L̇0) and through an end on a prescribed
        body (:meth:`prescribed_rate`); 0 for a constant rest length between free ends."""
        rest = self.cables.rest_length[self.cables.cable[e]]
        rate = self.prescribed_rate(state, e)
        if rest.is_constant:
            return rate
        return rate + float(self._rest_length_derivative(state, e, 3)[4 if self._damped(state, e) else 3]
                            * self.cables.share[e] * rest.rate(state.t))

    def prescribed_rate(self, state, e: int) -> float:
        """∂g/∂t of element ``e``'s gap through its ends on prescribed bodies: the gap's gradients by that end's
        configuration and rates (the kernel's blocks, as :meth:`step_size_derivative` takes them) along the
        prescribed motion's own velocity and acceleration at ``state``'s time (v, ω, v̇, ω̇ of the motion's laws and
        their exact time derivatives, ``latdyn_prescribe``); through its ends on nodes that follow rigid links
        from a prescribed body or hinge angle, along their motion at fixed free coordinates and rates
        (``TransientSensitivities.dependent_motion_in_time``: a cable to a prescribed crank's pin took 0 here,
        its change refused as grazing, and to a free swing on that pin reported its time's derivative 700×
        off, tests/test_fuzz_run_findings7.py); 0 without such an end."""
        from latdyn.model.model import PRESCRIBED

        nodes = self.cables.nodes[e]
        ends = [i for i in range(2) if self.model.nodes[nodes[i]].kind == PRESCRIBED]
        moving, carried = state, []
        if self.model.links is not None and _prescribed_motion(self.model):
            dependent = set(int(n) for n in self.model.links.dependent)
            carried = [i for i in range(2) if int(nodes[i]) in dependent]
        if not ends and not carried:
            return 0.0
        if carried:
            moving = state.copy()
            still, unaccelerated = self.owner.dependent_motion_in_time(state)
            for i in carried:
                node = nodes[i]
                moving.v[node], moving.w[node] = still.v[node], still.w[node]
                moving.a[node], moving.alpha[node] = unaccelerated.a[node], unaccelerated.alpha[node]
        damped = self._damped(state, e)
        _, K, C, _ = self.law(state, e, c=self.cables.damping[e] if damped else 0.0)
        points = [state.x[nodes[i]] + state.T[nodes[i]] @ self.cables.offsets[e, i] for i in range(2)]
        unit = (points[1] - points[0]) / np.linalg.norm(points[1] - points[0])
        g_q, g_v = -unit @ K[0:3], -unit @ C[0:3]
        rate = 0.0
        for i in ends + carried:
            node, block = nodes[i], slice(6 * i, 6 * i + 6)
            rate += g_q[block] @ np.concatenate([moving.v[node], moving.w[node]])
            rate += g_v[block] @ np.concatenate([moving.a[node], moving.alpha[node]])
        return float(rate)

    def _damped(self, state, e: int) -> bool:
        """Whether element ``e``'s gap is its tension N with the damper (N < N_el), else N_el."""
        s = self.law(state, e)[3]
        return bool(s[4] < s[3])

    def reel_forces(self, state, total: np.ndarray) -> None:
        """Add ∂(the taut elements' forces)/∂t at fixed coordinates into ``total`` (n_total + 1,): a reel's
        rest length L0(t) moves them by ∂F/∂L0 · share · L0′(t) (the law reads no L̇0)."""
        taut = None
        for k, rest in enumerate(self.cables.rest_length):
            if rest.is_constant:
                continue
            taut = self.taut(state) if taut is None else taut
            rate = rest.rate(state.t)
            for e in np.flatnonzero((self.cables.cable == k) & taut):
                force = self._rest_length_derivative(state, e, 0) * self.cables.share[e] * rate
                np.add.at(total, self._rows(e), force)

    def record(self, new, e: int, change, dt_event: np.ndarray, names: list) -> dict | None:
        """The ``event_sensitivities`` entry of a whole cable's change (None: an element of a cable that
        stays taut or slack as a whole)."""
        if change is None:
            return None
        return {"joint": self.cables.names[self.cables.cable[e]], "kind": change, "t": float(new.t),
                "dt": {name: float(dt_event[c]) for c, name in enumerate(names)}}


def _prescribed_motion(model) -> bool:
    """Whether a body's motion or a hinge's angle is prescribed (rigid links carry it to their dependent nodes)."""
    from latdyn.model.model import PRESCRIBED

    return any(node.kind == PRESCRIBED for node in model.nodes) or any(h.angle is not None for h in model.hinges)
