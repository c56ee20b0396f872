"""`autocable gallop`: the galloping cycles of eq. (21) at eta = 0, where they exist, how large they
are, and what damping keeps every one of them above a design wind.

Why. `autocable onset` gives the Hopf point of the rest state and its criticality. Every real stay
shipped (models/*.toml) is sub-critical: an unstable cycle is born at the onset below it, turns at a
fold of cycles (LPC) and comes back as the large stable galloping cycle. Large-amplitude galloping
therefore exists from the fold's wind speed on, below the onset (hysteresis), and the linear least
damping of `onset --design-wind` (the rest state stable up to the design wind) is not safe: the
fold may still lie below the design wind.

What. For each damping ratio and each Hopf point of the rest state up to U_max
(`autocable.model.onset.stability`: the upward and downward crossings by a complex pair), the branch
of cycles continued in U (`autocable.methods.integration.gallop`), stable and unstable, with its
folds and Floquet multipliers. From it:

* ``lowest_galloping_U_m_s``: the lowest wind speed of any cycle of the branches (for a sub-critical
  onset the fold; for a super-critical one the onset itself); null where a branch is still
  descending in U where it ends (it reaches the scan's lower bound `U_MIN`, or stops before a
  fold), with ``lowest_galloping_U_bound`` ("at most 0.2 m/s"), its number
  ``lowest_galloping_U_at_most_m_s`` and ``lowest_galloping_note`` saying why: the scan's bound is
  not a galloping speed;
* ``hysteresis_m_s``: [fold, Hopf] of a sub-critical onset: between them the rest state and a large
  stable cycle coexist;
* ``amplitude_at_design_wind_m``: the peak displacements at mid-span [in-plane, out-of-plane] of the
  largest stable cycle at the design wind (the bracketing points of the branch interpolated, then
  Newton at the design wind itself), with its frequency in Hz;
* ``check``: at three wind speeds of the stable part, direct integration of eq. (21)
  (`Ode21Integrator.simulate`, compiled engine) from the continued cycle's state and from a larger
  start, which must land on the same cycle (relative amplitude differences reported);
* `least_damping_global`: the least damping ratio for which no cycle of the branches exists up to
  the design wind (regula falsi on the damping ratio, one continuation per step, every step on
  one compiled system, `DampedSystem`; the bisection kept as the independent route);
* ``design_verdict`` and ``missing_ingredient``: whether the design-wind cycle is bounded and inside
  the model's range, and if not which ingredient the model lacks there (`missing_ingredients`: the
  twist, the curves, the load, more modes), judged on that cycle or, without one, on the cycle that
  stands in for it (the branch's last, or the stable one nearest below the design wind);
* ``sensitivity``: the amplitude at the design wind and the lowest galloping speed with the curves'
  valid range narrowed and widened and the blend to the dry cylinder halved and doubled
  (`sensitivity`), where the curves have a band and a blend (docs/aero-curves.md); the cycle's size
  follows them on the exact rung.

What it does not see. Only cycles connected to a Hopf point of the rest state up to U_max: an
isolated branch of cycles (an isola), or one born at a Hopf point above U_max, is not found.
Eq. (21) is cubic: its cycles on real stays are metres large, where the aerodynamic curves and the
slaved twist law are far outside their range (docs/gallop.md); each cycle's validity is reported by
`_validity` beside it.
"""
from __future__ import annotations

import math
import time

import numpy as np

from autocable.errors import ComputationError
from autocable.methods.integration.gallop import CycleContinuation, hopf_start, stability_changes
from autocable.model.onset import U_MAX_DEFAULT, LinearPencil, onset_at, stability, with_damping
from autocable.model.premises import MAX_AMPLITUDE
from autocable.model.units import PEAK_STATION, units_of
from autocable.spec import SpecError

#: The lowest wind speed a branch is followed to (U* units): without wind there is no galloping,
#: and the 1/U terms of eq. (21) grow without bound as U* -> 0.
U_MIN = 0.02
#: Wind speeds of the stable part checked by direct integration.
CHECK_POINTS = 3
#: Stable cycles whose largest non-trivial multiplier exceeds this are not picked for the check:
#: integration approaches them too slowly to settle within its time limit.
CHECK_MAX_MODULUS = 0.98
#: The "large start" of the check: this many times the cycle's own start state (capped so that the
#: start stays within `premises.MAX_AMPLITUDE`, the largest start eq. (21) accepts). Not more: the
#: basin of a stable cycle is bounded by an unstable one outside it (the 190 m stay at 22 m/s: from
#: 1.2 times the cycle eq. (21) lands on it, from 1.3 times it diverges).
LARGE_START = 1.2
#: Hopf points are looked for up to this many times the highest wind speed of the study: a strongly
#: sub-critical branch born above it may fold back far below it (the 190 m stay at 1.56 % damping:
#: Hopf point at U* = 5.0007, fold at U* = 2.085), and is followed from there into the range.
HOPF_SCAN_FACTOR = 4.0
#: Points of that scan (`autocable.model.onset.crossings`).
HOPF_SCAN_POINTS = 4001
#: Relative tolerance of `least_damping_global` on the damping ratio (its bracket's width over its upper end).
GLOBAL_DAMPING_RTOL = 1e-3
#: The largest twist [deg] the slaved twist law is trusted with (a stated bound): the twist enters the
#: angle phi of eq. (12) one for one, so this much twist alone takes phi across most of a fit's range
#: (the paper's fits: phi0 +- 15 deg), and anchored stays restrain the section's rotation.
TWIST_BOUND_DEG = 20.0
#: "More modes": another mode of the cable lies within this fraction of the cycle's frequency, or the
#: cycle's frequency lies this far from both of the pair's (it has left the pair's neighbourhood).
MODES_FRACTION = 0.10
#: Where the branches hold no stable cycle at the design wind, eq. (21) is integrated there for at
#: most this long (t*, about 950 periods of the pair) to say whether the motion stays bounded.
DESIGN_INTEGRATION_TIME = 6000.0
#: The search for a stable cycle at the design wind larger than the branches' largest (`_larger_cycle`):
#: starts at this many factors of that cycle's state, the first this one, the last the largest start
#: eq. (21) accepts; a cycle counts as larger when its peak exceeds the other's by this fraction.
LARGER_START_FACTORS = 3
LARGER_START_FIRST = 2.0
LARGER_RTOL = 1e-3
#: `least_damping_global` looks for a stable cycle off the branches at this fraction of the design
#: wind, at the damping it found (just below the design wind: there the branches hold none).
ISOLATED_PROBE = 0.99
#: Modal amplitudes below this count as (near) the rest state in that integration: 0.2 mm on a
#: 190 m stay, far below any galloping cycle; a motion still growing from rest that slowly is not judged.
REST_AMPLITUDE = 1e-6
#: The samples of that integration's last quarter its validity is measured on, at most.
VALIDITY_SAMPLES = 4000
#: The sensitivity of the amplitude to the curves: each end of their valid range moved out and in by
#: this many degrees (`curves.with_band`), ...
SENSITIVITY_BAND_DEG = 5.0
#: ... and the blend's width multiplied by these factors.
SENSITIVITY_BLEND_FACTORS = (0.5, 2.0)


class DampedSystem:
    """The compiled (y, Phi, s) system of `CycleContinuation` for one eq. (21) with the damping ratio
    xi as a run-time parameter, shared by every damping ratio of that equation.

    Why. The damping enters eq. (21) only through the terms 2 xi omega_k q_k' (Sect. 3;
    `autocable.model.onset.with_damping`), and `CycleContinuation` compiles its system with xi as a
    number: the symbolic preparation (the Jacobian and parameter derivative, the variational
    equations, the coefficient template of `autocable.codegen.coefficients`) is redone for every
    damping ratio. On the exact rung it costs seconds per ratio (measured on the 190 m blended
    stay's pairs 1 and 2, under load: about 6.6 s of the 8.6 s of each step of
    `least_damping_global`'s bisection, whose continuation took the rest). Here it is done once:
    xi is a symbol of the compiled right-hand side, and each damping ratio binds its value
    (`at`). The system is the same expression as `CycleContinuation.system`'s with 2 xi omega_k q_k'
    written with xi symbolic; its numbers differ by round-off (tests/test_gallop_speed.py compares
    the two)."""

    def __init__(self, ode):
        self.ode = ode
        self._ci = None
        self._template = None
        self.build_seconds = 0.0
        self._undamped = _undamped_hash(ode)

    @property
    def built(self) -> bool:
        return self._ci is not None

    def serves(self, ode) -> bool:
        """Whether ``ode`` is this system's equation up to its damping ratio."""
        return _undamped_hash(ode) == self._undamped

    def compiled(self):
        """The compiled integrator of (y, Phi, s), parameters (U, xi)."""
        if self._ci is None:
            import sympy as sp

            from autocable.codegen.cintegrate import compiled_integrator
            from autocable.codegen.coefficients import coefficient_template
            from autocable.methods.integration.gallop import variational_system
            from autocable.model.symbolic import ETA, OMEGA, STATE, U, UINV, WIND, first_order_rhs, plain_symbols
            t0 = time.perf_counter()
            xi = sp.Symbol(DAMPING_SYMBOL)
            ode = self.ode
            omegas = (ode.omega1, ode.omega2)
            damped = [t for t in ode.terms if t.origin == "damping"]
            # the damping terms as `with_damping` writes them (2 xi omega_k times a velocity), xi a symbol
            extra = [sp.Integer(0)] * 4
            for t in damped:
                m = 2 * xi * sp.Float(omegas[t.equation - 1], 17)
                for x, p in zip(STATE, t.powers):
                    m *= x ** p
                extra[1 + t.equation] -= m
            fixed = {ETA: sp.Integer(0), OMEGA: sp.Integer(1), WIND: sp.Integer(1), UINV: 1 / U}
            # with_damping(ode, 0): the damping terms' coefficients 0, so they vanish from the expression
            base = first_order_rhs(with_damping(ode, 0.0))
            rhs = [sp.sympify(e).xreplace(fixed) + x for e, x in zip(base, extra)]
            names, exprs = variational_system(rhs)
            # plain symbols here, so that the build's coefficient template (cached by its expressions)
            # is at hand for `with_curves`
            plain = tuple(plain_symbols(e) for e in exprs)
            self._ci = compiled_integrator(f"gallop_damped_{self._undamped}", names, (U.name, DAMPING_SYMBOL),
                                           plain, None)
            self._template = coefficient_template(plain)
            self.build_seconds = time.perf_counter() - t0
        return self._ci

    def with_curves(self, ode) -> "DampedSystem | None":
        """The system of ``ode``, which is this one's equation on the exact rung with other blended
        curves (`_curves_variant`: the sensitivity's band and blend), by new values of the compiled
        code's run-time weights instead of a new symbolic build (seconds per case on the exact
        rung); None where that is not possible, and the caller builds it.

        Why it holds. The curves enter the exact load only as `curves.PiecewisePolynomial` nodes
        (lift and drag, and their derivatives: the same node with the order raised), whose numbers
        (edges, origins, coefficients) are Floats and so run-time weights of the build
        (`autocable.codegen.coefficients`: one weight per distinct value). A variant with the same
        piece sizes is this build with each weight of a nominal piece value set to the variant's
        value at the same place. Refused: a different structure (piece sizes, rung, equation), two
        places of one weight asking for different values; and checked: the difference of the two
        systems' accelerations at 64 states sweeping phi over every piece must equal the difference
        of the exact loads (`exact_load.forces`, numpy: an independent evaluation) to 1e-9
        relative, so that a weight shared with another term of equal value cannot pass unseen."""
        from dataclasses import replace

        import sympy as sp

        from autocable.model.curves import curves_from_dict
        from autocable.model.exact_load import forces
        ex, ex_new = self.ode.exact_load, getattr(ode, "exact_load", None)
        if ex is None or ex_new is None or replace(ex_new, curves=ex.curves) != ex:
            return None
        if _undamped_hash(replace(ode, exact_load=ex)) != self._undamped:
            return None
        old, new = curves_from_dict(ex.curves), curves_from_dict(ex_new.curves)
        if old.kind != "blend" or new.kind != "blend":
            return None
        self.compiled()
        tpl = self._template
        where = {float(v): i for i, v in enumerate(tpl.weights)}
        weights = np.array(tpl.weights, dtype=float)
        asked: dict = {}
        x = sp.Symbol("x")
        for a, b in ((old.lift_expr(x), new.lift_expr(x)), (old.drag_expr(x), new.drag_expr(x))):
            m = int(a.args[2])
            if a.args[:3 + m] != b.args[:3 + m]:
                return None                           # other piece sizes: another structure
            for va, vb in zip(a.args[3 + m:], b.args[3 + m:]):
                i = where.get(float(va))
                if i is None:
                    return None
                if asked.setdefault(i, float(vb)) != float(vb):
                    return None                       # one weight, two values
        for i, v in asked.items():
            weights[i] = v
        out = DampedSystem(ode)
        out._ci = replace(self._ci, weights=weights)
        out._template = None
        # the independent check: the accelerations' difference is the exact loads' difference
        # velocities from small to large (log-uniform over five decades): phi at the nodes then
        # falls in every piece, the fits, both blends and the dry cylinder beyond
        rng = np.random.default_rng(0)
        n = 64
        U_star = rng.uniform(0.5, 3.0, n)
        states = rng.normal(size=(n, 4)) * 10.0 ** rng.uniform(-5.0, 0.0, (n, 1))
        f_old = np.array(forces(ex, states[:, 1], states[:, 2], states[:, 3], U_star))
        f_new = np.array(forces(ex_new, states[:, 1], states[:, 2], states[:, 3], U_star))
        z = np.zeros(24)
        got = np.empty((2, n))
        for j in range(n):
            z[:4] = states[j]
            got[:, j] = (out._ci.rhs(0.0, z, [U_star[j], 0.0])[2:4] - self._ci.rhs(0.0, z, [U_star[j], 0.0])[2:4])
        want = f_new - f_old
        scale = max(float(np.max(np.abs(f_old))), 1e-300)
        if not float(np.max(np.abs(got - want))) <= 1e-9 * scale:
            return None
        return out

    def at(self, xi: float) -> "_AtDamping":
        """The compiled system with the damping ratio ``xi`` bound: the interface `CycleContinuation`
        calls (``rhs(t, z, [U])``, ``run(z0, grid, [U], ...)``)."""
        return _AtDamping(self.compiled(), float(xi))


#: The damping ratio's name in `DampedSystem`'s compiled code (no symbol of eq. (21) is named so).
DAMPING_SYMBOL = "xi_damping"


def _undamped_hash(ode) -> str:
    return with_damping(ode, 0.0).content_hash()


class _AtDamping:
    """`DampedSystem`'s compiled integrator with xi appended to the parameters it is called with."""

    def __init__(self, ci, xi: float):
        self.ci, self.xi = ci, xi

    def rhs(self, t, y, p):
        return self.ci.rhs(t, y, [*p, self.xi])

    def run(self, y0, grid, p, **kw):
        return self.ci.run(y0, grid, [*p, self.xi], **kw)


class _SharedContinuation(CycleContinuation):
    """`CycleContinuation` of ``ode`` on a `DampedSystem` (built once for every damping ratio)."""

    def __init__(self, ode, shared: DampedSystem):
        super().__init__(ode)
        self._shared = shared
        self._bound = None

    def system(self):
        if self._bound is None:
            built = self._shared.built
            self._bound = self._shared.at(self.ode.xi_s)
            self.build_seconds = 0.0 if built else self._shared.build_seconds
        return self._bound


def _continuation(ode, shared: DampedSystem | None) -> CycleContinuation:
    """The continuation of ``ode``'s cycles, on ``shared``'s compiled system where it serves ``ode``."""
    if shared is not None and shared.serves(ode):
        return _SharedContinuation(ode, shared)
    return CycleContinuation(ode)


def _validity(derivation, states, U_star: float) -> dict:
    """The validity of a motion (its (n, 4) states (q1, q2, q1', q2') at wind U*) as
    `autocable.model.validity.motion_validity` reports it (keys ``phi_swept_deg``,
    ``twist_max_deg``, ``beyond_valid_range``, ...); {} while that module, or a part it needs, is
    not there (an ImportError: the validity machinery is incomplete; any other failure is raised)."""
    try:
        from autocable.model.validity import motion_validity
        return dict(motion_validity(derivation, np.asarray(states, float), float(U_star)))
    except ImportError:
        return {}


def _complex_pairs(values) -> list:
    return [[float(complex(v).real), float(complex(v).imag)] for v in values]


def _row(p, units, derivation) -> dict:
    """One point of a branch in SI and nondimensional units."""
    row = {"kind": p.kind or "cycle", "U_star": p.U, "U_m_s": units.wind_m_s(p.U), "period_star": p.T,
           "frequency_star": p.frequency, "frequency_Hz": units.frequency_hz(p.frequency),
           "a1": p.a1, "a2": p.a2, "peak_in_plane_m": units.peak_m(p.a1),
           "peak_out_of_plane_m": units.peak_m(p.a2),
           "stable": None if p.kind == "H" else bool(p.stable),
           "max_multiplier_modulus": None if p.kind == "H" else p.max_modulus,
           "multipliers": _complex_pairs(p.multipliers),
           "trivial_multiplier": None if p.kind == "H" else _complex_pairs([p.trivial])[0],
           "state0": [float(v) for v in p.state0], "residual": p.residual}
    if p.orbit is not None:
        row.update(_validity(derivation, p.orbit, p.U))
    return row


def open_below(branch) -> bool:
    """Whether ``branch`` is still descending in U where it ends: its lowest cycle is its last one
    (not its Hopf point, not a fold), so that galloping exists there and may exist lower still."""
    pts = branch.points
    return len(pts) > 1 and pts[-1].kind != "H" and pts[-1].U <= min(p.U for p in pts)


def lowest_bound(branch, units) -> dict:
    """For a branch that ends still descending (`open_below`): the lowest galloping speed is not
    known, only that galloping exists at the branch's last cycle, so the speed is at most there.
    ``lowest_galloping_U_bound`` says so in words ("at most 0.2 m/s"), ``lowest_galloping_U_at_most_m_s``
    in numbers, ``lowest_galloping_note`` why (the scan's lower bound reached, or the branch's end)."""
    last = branch.points[-1].U
    where = units.wind_m_s(last)
    if branch.end_code == "U_min":
        why = (f"the branch reaches the scan's lower bound {where:.3g} m/s (U* = {last:g}) without a fold: "
               "galloping exists down to at least there")
    else:
        why = (f"the branch ended at {where:.5g} m/s before a fold ({branch.end}): galloping exists there and "
               "may exist lower still")
    return {"lowest_galloping_U_at_most_m_s": where, "lowest_galloping_U_bound": f"at most {where:.3g} m/s",
            "lowest_galloping_note": why}


def _branch_summary(branch, onset, units, derivation) -> dict:
    """A branch from one Hopf point: its rows, folds, stability changes, lowest speed, hysteresis.
    The lowest galloping speed is a number only where the branch turns (a fold, or the Hopf point
    itself); a branch still descending where it ends gives null and a bound (`lowest_bound`)."""
    rows = [_row(p, units, derivation) for p in branch.points]
    lowest = branch.lowest_U
    is_open = open_below(branch)
    folds = [{"U_star": f.U, "U_m_s": units.wind_m_s(f.U), "U_change_star": f.U_change,
              "refinements": f.refinements, "multiplier_nearest_one": _complex_pairs([f.multiplier_nearest_one])[0],
              "peak_in_plane_m": units.peak_m(f.point.a1), "peak_out_of_plane_m": units.peak_m(f.point.a2),
              "frequency_Hz": units.frequency_hz(f.point.frequency)} for f in branch.folds]
    changes = [{"U_between_m_s": [units.wind_m_s(c["U_between"][0]), units.wind_m_s(c["U_between"][1])],
                "gains_stability": c["gains"], "multiplier": _complex_pairs([c["multiplier"]])[0], "kind": c["kind"]}
               for c in stability_changes(branch.points)]
    out = {"hopf_U_m_s": units.wind_m_s(onset.U_star), "hopf_U_star": onset.U_star,
           "hopf_frequency_Hz": units.frequency_hz(onset.frequency), "criticality": onset.criticality,
           "lyapunov": onset.lyapunov, "mechanism": onset.mechanism,
           "lowest_galloping_U_m_s": None if is_open else units.wind_m_s(lowest),
           "lowest_galloping_U_star": None if is_open else lowest,
           "lowest_U_reached_m_s": units.wind_m_s(lowest), "lowest_U_reached_star": lowest,
           "lowest_galloping_U_at_most_m_s": None, "lowest_galloping_U_bound": None,
           "folds": folds, "stability_changes": changes, "end": branch.end, "end_code": branch.end_code,
           "points": len(branch.points), "stable_cycles": sum(1 for r in rows if r["stable"]),
           "corrected_steps": branch.steps, "seconds": branch.seconds,
           "rows": rows, "hysteresis_m_s": None}
    if is_open:
        out.update(lowest_bound(branch, units))
    if onset.criticality == "subcritical":
        # an open branch's loop has no known lower end: null there, as the lowest speed
        out["hysteresis_m_s"] = [None if is_open else units.wind_m_s(lowest), units.wind_m_s(onset.U_star)]
        if is_open:
            out["hysteresis_note"] = (f"the branch ended ({branch.end}) before a fold: the loop's lower end is not "
                                      f"known; it is {out['lowest_galloping_U_bound']}")
    return out


def _hopf_points(ode, U_max: float) -> list:
    """Every crossing of the rest state's spectral abscissa by a complex pair over
    (0, `HOPF_SCAN_FACTOR` U_max], and the `Stability` of that scan."""
    st = stability(ode, HOPF_SCAN_FACTOR * U_max, n=HOPF_SCAN_POINTS)
    found = list(st.onsets) + [onset_at(ode, U) for U in st.restabilisations]
    return [o for o in found if o.lyapunov is not None and o.frequency > 0], st


def _stable_cycles_at(cont, branch, U_star: float) -> list:
    """The stable cycles of ``branch`` at U*: every pair of neighbouring stable points that
    brackets it, interpolated and solved by Newton at U* itself."""
    out = []
    pts = [p for p in branch.points if p.kind != "H"]
    for a, b in zip(pts[:-1], pts[1:]):
        if not (a.stable and b.stable) or not min(a.U, b.U) <= U_star <= max(a.U, b.U) or a.U == b.U:
            continue
        w = (U_star - a.U) / (b.U - a.U)
        p = cont.cycle_at(U_star, a.state0 + w * (b.state0 - a.state0), a.T + w * (b.T - a.T), branch.hopf)
        if p is not None:
            out.append((p, {"a1": a.a1 + w * (b.a1 - a.a1), "a2": a.a2 + w * (b.a2 - a.a2)}))
    return out


def _more_modes(derivation, frequency_star: float) -> str:
    """Why a cycle of angular frequency ``frequency_star`` (eq. 17 units) needs more modes than the
    pair (`MODES_FRACTION`), or "": another in-plane or out-of-plane mode of the cable (up to k + 2 of
    each plane, `modes_n.mode_set`) lies that close to it, or it has left both of the pair's. Only
    the fundamental is compared: a taut cable's modes lie near every harmonic of its first."""
    from autocable.model.modes_n import mode_set
    from autocable.model.units import units_of
    d, w = derivation, float(frequency_star)
    k = d.mode_pair
    ms = mode_set(d.statics, k + 2, k + 2)
    own = {ms.in_plane[k - 1].name, ms.out_of_plane[k - 1].name}
    hz = units_of(d.spec, d.statics).frequency_hz
    gap = min(abs(w - om) / om for om in (d.ode.omega1, d.ode.omega2))
    if gap > MODES_FRACTION:
        return (f"the cycle runs at {hz(w):.4g} Hz, {100 * gap:.0f} % from the pair's {hz(d.ode.omega1):.4g} and "
                f"{hz(d.ode.omega2):.4g} Hz (bound {100 * MODES_FRACTION:g} %): more modes (--pair, "
                "docs/mode-pairs.md)")
    near = [(m, abs(w - m.omega) / w) for m in ms.modes if m.name not in own and abs(w - m.omega) <= MODES_FRACTION * w]
    if near:
        m, g = min(near, key=lambda c: c[1])
        return (f"the {m.plane} mode {m.name} at {hz(m.omega):.4g} Hz lies {100 * g:.1f} % from the cycle's "
                f"{hz(w):.4g} Hz (bound {100 * MODES_FRACTION:g} %): more modes")
    return ""


def missing_ingredients(derivation, validity: dict, frequency_star: float | None = None) -> list[dict]:
    """What the model lacks for a motion whose validity (`autocable.model.validity.motion_validity`)
    is ``validity``, decided from it: ``[{"ingredient", "reason"}, ...]``, empty when nothing is
    missing. The ingredients (docs/gallop.md):

    * "the twist": the slaved twist of eq. (20) beyond `TWIST_BOUND_DEG` (with natural ends: a
      restrained twist is needed, ``cable.twist_ends = "restrained"``);
    * "the curves": phi beyond the curves' valid range (curves measured over a wider range);
    * "the load": on the cubic rung, the cubic load of eq. (14) more than `aero.CUBIC_RTOL` off the
      exact load (``--load exact``);
    * "more modes": the cycle's frequency near another mode's or away from the pair's (`_more_modes`).
    """
    from autocable.model.aero import CUBIC_RTOL
    from autocable.model.curves import curves_from_spec
    if not validity:
        return []
    out = []
    twist = validity.get("twist_max_deg")
    if twist is not None and twist > TWIST_BOUND_DEG:
        if derivation.spec.cable.twist_ends == "natural":
            why = (f"the slaved twist reaches {twist:.0f} deg (bound {TWIST_BOUND_DEG:g} deg) with natural ends: "
                   "a restrained twist is needed (cable.twist_ends = \"restrained\")")
        else:
            why = (f"the slaved twist reaches {twist:.0f} deg (bound {TWIST_BOUND_DEG:g} deg) even with restrained "
                   "ends: the linear twist law of eq. (20) is beyond its range")
        out.append({"ingredient": "the twist", "reason": why})
    rng, valid = validity.get("phi_range_deg"), validity.get("valid_phi_deg")
    if rng and valid:
        lo = -math.inf if valid[0] is None else valid[0]
        hi = math.inf if valid[1] is None else valid[1]
        if rng[0] < lo or rng[1] > hi:
            blend = curves_from_spec(derivation.spec.aero).kind == "blend"
            out.append({"ingredient": "the curves",
                        "reason": f"phi reached {rng[0]:.0f} to {rng[1]:.0f} deg, beyond the curves' valid range "
                                  f"{lo:.1f} to {hi:.1f} deg"
                                  + (" (the blend to the dry cylinder stands in beyond it)" if blend else "")
                                  + ": curves measured over a wider range are needed (aero.table)"})
    err = validity.get("cubic_load_error")
    if validity.get("load") == "cubic" and err is not None and err > CUBIC_RTOL:
        out.append({"ingredient": "the load",
                    "reason": f"the cubic load of eq. (14) is {100 * err:.0f} % off the exact load "
                              f"(bound {100 * CUBIC_RTOL:g} %): --load exact"})
    if frequency_star is not None and math.isfinite(frequency_star):
        more = _more_modes(derivation, frequency_star)
        if more:
            out.append({"ingredient": "more modes", "reason": more})
    return out


def _judged(derivation, point, units, what: str) -> dict:
    """The validity of ``point`` (a `CyclePoint`) and the missing ingredients it shows, for a design
    wind the branch has no stable cycle at: ``what`` says which cycle stands in."""
    v = _validity(derivation, point.orbit, point.U) if point.orbit is not None else {}
    cycle = {"what": what, "U_m_s": units.wind_m_s(point.U), "stable": bool(point.stable),
             "peak_m": [units.peak_m(point.a1), units.peak_m(point.a2)],
             "frequency_Hz": units.frequency_hz(point.frequency)}
    return {"_point": point, "judged_cycle": dict(cycle, **v), "judged_on": "judged cycle",
            "missing_ingredient": missing_ingredients(derivation, v, point.frequency)}


def _integrate_at(derivation, ode, U_des: float, start, units) -> dict:
    """Direct integration of eq. (21) at the design wind where the branches hold no stable cycle
    there: from ``start`` (q1, q2, q1', q2'), or from rest with q2 = 1e-6 when None (the rest state
    is unstable there), for at most `DESIGN_INTEGRATION_TIME`. Says whether the motion stays
    bounded (|q_k| <= 0.1, `ode21.DIVERGED`) and, if it does, the validity of its last quarter
    (at most `VALIDITY_SAMPLES` samples of it) and its frequency where it is periodic."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    t0 = time.perf_counter()
    q0 = None if start is None else (start[0], start[2], start[1], start[3])
    kw = {} if q0 is None else {"q0": q0}
    r = Ode21Integrator(ode, engine="compiled").simulate(U_des, 0.0, 0.0, max_time=DESIGN_INTEGRATION_TIME,
                                                        keep_history=True, **kw)
    bounded = bool(math.isfinite(r.a1) and math.isfinite(r.a2))
    out = {"from": "rest (q2 = 1e-6)" if start is None else "the judged cycle's state times up to 1.2",
           "bounded": bounded, "steady": bool(r.steady), "periodic": bool(r.periodic),
           "peak_m": [units.peak_m(r.a1), units.peak_m(r.a2)] if bounded else None, "t_end": r.t_end,
           "frequency_star": 2 * math.pi / r.period if r.periodic and r.period > 0 else None,
           # back at the rest state (a stable rest state below the onset): nothing to judge
           "at_rest": bool(bounded and max(r.a1, r.a2) < REST_AMPLITUDE),
           "message": r.message, "seconds": None}
    if bounded and r.history:
        t, *q = r.history
        keep = np.nonzero(t >= 0.75 * t[-1])[0]
        keep = keep[::max(1, len(keep) // VALIDITY_SAMPLES)]
        out["validity"] = _validity(derivation, np.column_stack([x[keep] for x in q]), U_des)
    out["frequency_Hz"] = None if out["frequency_star"] is None else units.frequency_hz(out["frequency_star"])
    out["seconds"] = time.perf_counter() - t0
    return out


def _design(cont, branches, U_des: float, units, derivation) -> dict:
    """The largest stable cycle at the design wind U_des (U*) over the branches, its validity, the
    verdict (``design_verdict``: "inside", "beyond", "no galloping" or "not known") and the
    ingredients the model lacks there (``missing_ingredient``, `missing_ingredients`)."""
    found = []
    for br in branches:
        found.extend((p, i, br.hopf) for p, i in _stable_cycles_at(cont, br, U_des))
    if not found:
        low = min((br.lowest_U for br in branches), default=math.inf)
        short = [br for br in branches if br.lowest_U <= U_des and max(p.U for p in br.points) < U_des]
        judged = {"missing_ingredient": []}
        if not branches:
            note = ("no galloping cycle at the design wind: no branch of cycles was found (no Hopf point whose "
                    "cycles reach the range)")
            verdict = "no galloping"
        elif low > U_des:
            note = f"no galloping cycle at the design wind: the lowest galloping speed is {units.wind_m_s(low):.5g} m/s"
            verdict = "no galloping"
        elif short:
            note = ("the branch ends below the design wind, so its cycles there are not known: "
                    + "; ".join(br.end for br in short))
            verdict = "not known"
            # the branch's last cycle is the nearest the model got: what it lacks there
            last = next((p for p in reversed(short[0].points) if p.kind != "H"), None)
            if last is not None:
                judged = _judged(derivation, last, units, "the last cycle of the branch")
        else:
            note = "no stable cycle of the branches at the design wind (only unstable ones)"
            verdict = "not known"
            below = [p for br in branches for p in br.points if p.kind != "H" and p.stable and p.U <= U_des]
            if below:
                judged = _judged(derivation, max(below, key=lambda p: p.U), units,
                                 "the stable cycle nearest below the design wind (the motion at the design wind "
                                 "is not a cycle of the branch: autocable simulate)")
        if verdict == "not known":
            # what the cable does there, from rest where the rest state is unstable, else from the judged cycle
            rest_unstable = float(LinearPencil(cont.ode).abscissa(U_des)[0]) > 0.0
            jc = judged.get("_point")
            start = None
            if not rest_unstable and jc is not None:
                y = np.asarray(jc.state0, float)
                start = min(LARGE_START, 0.999 * MAX_AMPLITUDE / max(float(np.abs(y).max()), 1e-300)) * y
            run = _integrate_at(derivation, cont.ode, U_des, start, units)
            judged["design_integration"] = run
            if not run["bounded"]:
                verdict = "unbounded"
                note += "; direct integration at the design wind diverges (|q_k| > 0.1, from " + run["from"] + ")"
            elif run.get("validity") and not run["at_rest"]:
                # the motion the integration settles on is the design wind's: judged instead of a stand-in
                v = run["validity"]
                judged["missing_ingredient"] = missing_ingredients(derivation, v, run["frequency_star"])
                judged["judged_on"] = "direct integration"
                verdict = "beyond" if (v.get("beyond_valid_range") or judged["missing_ingredient"]) else "inside"
                note += "; direct integration at the design wind stays bounded (design_integration), judged on it"
        judged.pop("_point", None)
        return dict({"amplitude_at_design_wind_m": None, "frequency_at_design_wind_Hz": None,
                     "beyond_valid_range": None, "design_note": note, "design_verdict": verdict}, **judged)
    p, interp, hopf = max(found, key=lambda c: max(c[0].a1, c[0].a2))
    larger, probes, reached = _larger_cycle(cont, p, hopf, U_des, units)
    off = None
    if larger is not None:
        low, folds = cont.lowest_U_of(larger, hopf, U_MIN)
        off = {"peak_m": [units.peak_m(larger.a1), units.peak_m(larger.a2)],
               "largest_on_branches_peak_m": [units.peak_m(p.a1), units.peak_m(p.a2)],
               "lowest_U_m_s": units.wind_m_s(low) if folds else None, "lowest_U_star": low if folds else None,
               "note": ("a stable cycle larger than every one on the branches from the Hopf points, reached by "
                        "direct integration from a larger start (larger_cycle_search) and solved by Newton: its "
                        "branch does not join theirs within the range followed; it is the design cycle"
                        + (f"; followed down in the wind it persists to {units.wind_m_s(low):.5g} m/s" if folds
                           else f"; followed down in the wind it persists to the lowest speed followed "
                                f"({units.wind_m_s(U_MIN):.3g} m/s)"))}
        p, interp = larger, {"a1": larger.a1, "a2": larger.a2}
    others = _other_cycles(p, [c[0] for c in found], reached, units, derivation)
    for o in others:
        if not o["on_branch"]:
            # a cycle off the branches gallops down to its own fold, which may lie below theirs
            low, folds = cont.lowest_U_of(o.pop("_point"), hopf, U_MIN)
            o.update(lowest_U_m_s=units.wind_m_s(low) if folds else None, lowest_U_star=low if folds else None)
        o.pop("_point", None)
    out = {"amplitude_at_design_wind_m": [units.peak_m(p.a1), units.peak_m(p.a2)],
           "frequency_at_design_wind_Hz": units.frequency_hz(p.frequency),
           "design_cycle": {"U_star": p.U, "a1": p.a1, "a2": p.a2, "period_star": p.T, "stable": p.stable,
                            "max_multiplier_modulus": p.max_modulus,
                            "interpolated_peak_m": [units.peak_m(interp["a1"]), units.peak_m(interp["a2"])],
                            "stable_cycles_found": len(found), "on_branch": off is None,
                            "larger_cycle_search": probes},
           "beyond_valid_range": None, "design_verdict": "not known", "missing_ingredient": [],
           "judged_on": "design cycle"}
    out["other_stable_cycles"] = others
    out["envelope_at_design_wind_m"] = [max([out["amplitude_at_design_wind_m"][i]] + [o["peak_m"][i] for o in others])
                                        for i in (0, 1)]
    if off is not None:
        out["off_branch_cycle"] = off
        out["design_note"] = off["note"]
    if p.orbit is not None:
        v = _validity(derivation, p.orbit, p.U)
        out["design_cycle"].update(v)
        out["beyond_valid_range"] = v.get("beyond_valid_range")
        out["missing_ingredient"] = missing_ingredients(derivation, v, p.frequency)
        if v:
            out["design_verdict"] = "beyond" if (v.get("beyond_valid_range") or out["missing_ingredient"]) \
                else "inside"
    return out


def _larger_cycle(cont, p, hopf, U_des: float, units) -> tuple:
    """A stable cycle at the design wind U_des larger than ``p``, the largest stable cycle of the
    branches from the Hopf points, or None; and the probes. The branches miss a branch of cycles
    closed on itself or joined to theirs beyond the range followed (found on a band case of the
    190 m stay: the branch holds a 0.49 m cycle at 25 m/s, direct integration from 2 m lands on a
    stable 4.7 m one). The motion is integrated from ``p``'s state scaled by `LARGER_START_FACTORS`
    factors spaced geometrically from `LARGER_START_FIRST` to the largest start eq. (21) accepts
    (`premises.MAX_AMPLITUDE`), each until it settles on a stable cycle, decays or diverges
    (`CycleContinuation.settle`)."""
    y = np.asarray(p.state0, float)
    top = 0.999 * MAX_AMPLITUDE / max(float(np.abs(y).max()), 1e-300)
    if top <= LARGER_START_FIRST:
        factors = [top] if top > 1.05 else []
    else:
        factors = list(np.geomspace(LARGER_START_FIRST, top, LARGER_START_FACTORS))
    best, probes, reached = None, [], []
    a_p = max(p.a1, p.a2)
    for f in factors:
        q, status = cont.settle(f * y, U_des, p.T, hopf, DESIGN_INTEGRATION_TIME)
        probes.append({"start_factor": float(f), "start_peak_m": units.peak_m(f * p.a1), "landed": status,
                       "peak_m": None if q is None else [units.peak_m(q.a1), units.peak_m(q.a2)]})
        if q is None:
            continue
        reached.append(q)
        if max(q.a1, q.a2) > a_p * (1.0 + LARGER_RTOL) and (best is None or max(q.a1, q.a2) > max(best.a1, best.a2)):
            best = q
    return best, probes, reached


def _other_cycles(design, on_branches: list, reached: list, units, derivation) -> list:
    """The stable cycles at the design wind besides the design cycle: those of the branches and
    those the larger starts reached (`_larger_cycle`), each once (peaks equal to `LARGER_RTOL`
    of the larger modal amplitude count as one cycle), with their peaks, frequency, whether a branch
    from a Hopf point holds them, and their validity. A smaller cycle in the plane the design cycle
    moves most can be the larger one in the other plane (the 190 m stay at 25 m/s: 2.09 / 0.42 m on
    the branch, 1.85 / 1.52 m reached from an 18 m start)."""
    ids = {id(c) for c in on_branches}
    kept = [design]
    for q in list(on_branches) + list(reached):
        if not any(abs(q.a1 - r.a1) <= LARGER_RTOL * max(r.a1, r.a2) and
                   abs(q.a2 - r.a2) <= LARGER_RTOL * max(r.a1, r.a2) for r in kept):
            kept.append(q)
    out = []
    for q in kept[1:]:
        row = {"peak_m": [units.peak_m(q.a1), units.peak_m(q.a2)], "frequency_Hz": units.frequency_hz(q.frequency),
               "on_branch": id(q) in ids, "max_multiplier_modulus": q.max_modulus, "_point": q}
        if q.orbit is not None:
            v = _validity(derivation, q.orbit, q.U)
            row.update({k: v[k] for k in ("phi_swept_deg", "twist_max_deg", "beyond_valid_range") if k in v})
        out.append(row)
    return out


def _check(ode, branches, units, picks: int = CHECK_POINTS) -> list:
    """Direct integration of eq. (21) at ``picks`` wind speeds of the stable stretch of the branches
    that reaches lowest in U (module docstring), from the continued cycle's state and from
    `LARGE_START` times it."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    # the stable stretch that reaches lowest in U: the galloping cycle a rising wind meets first, not a
    # short stable window between a period doubling and a fold
    runs, run = [], []
    for br in branches:
        for p in br.points:
            if p.kind == "" and p.stable:
                run.append(p)
            elif run:
                runs, run = runs + [run], []
        if run:
            runs, run = runs + [run], []
    if not runs:
        return []
    first = min(runs, key=lambda r: min(p.U for p in r))
    cands = sorted((p for p in first if p.max_modulus < CHECK_MAX_MODULUS), key=lambda p: p.U)
    if not cands:
        return []
    idx = sorted({int(round(k)) for k in np.linspace(0, len(cands) - 1, picks + 2)[1:-1]}) if len(cands) > picks \
        else list(range(len(cands)))
    integ = Ode21Integrator(ode, engine="compiled")
    out = []
    for p in (cands[i] for i in idx):
        y = p.state0
        big = min(LARGE_START, 0.999 * MAX_AMPLITUDE / max(float(np.abs(y).max()), 1e-300))
        row = {"U_star": p.U, "U_m_s": units.wind_m_s(p.U), "a1_continued": p.a1, "a2_continued": p.a2,
               "peak_in_plane_m": units.peak_m(p.a1), "peak_out_of_plane_m": units.peak_m(p.a2),
               "frequency_Hz_continued": units.frequency_hz(p.frequency)}
        for name, f in (("from_cycle", 1.0), ("from_large_start", big)):
            t0 = time.perf_counter()
            r = integ.simulate(p.U, 0.0, 0.0, q0=(f * y[0], f * y[2], f * y[1], f * y[3]))
            ok = bool(r.steady and r.periodic and math.isfinite(r.a1))
            top = max(p.a1, p.a2)
            d1 = abs(r.a1 - p.a1) if ok else math.nan
            d2 = abs(r.a2 - p.a2) if ok else math.nan
            row[name] = {"start_factor": f, "a1": r.a1, "a2": r.a2, "periodic": ok,
                         "period_star": r.period, "message": r.message, "t_end": r.t_end,
                         "relative_difference": max(d1, d2) / top if ok else None,
                         "relative_difference_a1": d1 / p.a1 if ok and p.a1 > 0 else None,
                         "relative_difference_a2": d2 / p.a2 if ok and p.a2 > 0 else None,
                         "seconds": time.perf_counter() - t0}
        out.append(row)
    return out


def _case(derivation, ode, xi: float, U_max: float, units, U_des: float | None, log,
          shared: DampedSystem | None = None) -> tuple[dict, list, object]:
    """Every branch of one damping ratio, the summary, and the continuation object (reused by the check);
    on ``shared``'s compiled system where it serves ``ode`` (`DampedSystem`)."""
    t0 = time.perf_counter()
    hopfs, st = _hopf_points(ode, U_max)
    cont = _continuation(ode, shared)
    summaries, branches, above = [], [], []
    for o in hopfs:
        if log:
            log(f"damping {100 * xi:.4g} %: cycles from the Hopf point at {units.wind_m_s(o.U_star):.5g} m/s ...")
        # a branch born above the range is followed within the whole scan, to see whether it folds into it
        br = cont.branch(hopf_start(o), U_min=U_MIN, U_max=U_max if o.U_star <= U_max else HOPF_SCAN_FACTOR * U_max)
        if br.lowest_U > U_max:
            above.append({"hopf_U_m_s": units.wind_m_s(o.U_star), "criticality": o.criticality,
                          "lowest_galloping_U_m_s": units.wind_m_s(br.lowest_U), "end": br.end})
            continue
        branches.append(br)
        summaries.append(_branch_summary(br, o, units, derivation))
    case = {"damping_ratio": xi, "scruton": units.scruton(xi), "hopf_points": summaries,
            "hopf_points_beyond_range": above, "hopf_scan_U_m_s": units.wind_m_s(HOPF_SCAN_FACTOR * U_max),
            "stable_without_wind": st.stable_at_start, "seconds": None}
    if summaries:
        low = min(summaries, key=lambda s: s["lowest_U_reached_star"])
        case["lowest_galloping_U_m_s"] = low["lowest_galloping_U_m_s"]
        case["lowest_galloping_U_star"] = low["lowest_galloping_U_star"]
        case["hysteresis_m_s"] = low["hysteresis_m_s"]
        case.update(lowest_galloping_U_at_most_m_s=None, lowest_galloping_U_bound=None)
        opened = [s for s in summaries if s["lowest_galloping_U_bound"] is not None]
        if opened:
            # a branch still descending where it ended may gallop below every other branch's fold:
            # the lowest speed over the branches is not known, only bounded by the lowest reached
            case.update(lowest_galloping_U_m_s=None, lowest_galloping_U_star=None,
                        lowest_galloping_U_at_most_m_s=low["lowest_U_reached_m_s"],
                        lowest_galloping_U_bound=f"at most {low['lowest_U_reached_m_s']:.3g} m/s",
                        lowest_galloping_note="; ".join(s["lowest_galloping_note"] for s in opened))
    else:
        case.update(lowest_galloping_U_m_s=None, lowest_galloping_U_star=None, hysteresis_m_s=None,
                    lowest_galloping_U_at_most_m_s=None, lowest_galloping_U_bound=None,
                    note=f"no branch of cycles from a Hopf point of the rest state (looked for up to "
                         f"{units.wind_m_s(HOPF_SCAN_FACTOR * U_max):.4g} m/s) reaches below "
                         f"{units.wind_m_s(U_max):.4g} m/s")
    if U_des is not None:
        case.update(_design(cont, branches, U_des, units, derivation))
        offs = ([case["off_branch_cycle"]] if case.get("off_branch_cycle") else []) + \
            [o for o in case.get("other_stable_cycles") or [] if not o["on_branch"]]
        if offs:
            # a stable cycle off the branches gallops down to its own fold, which may lie below theirs
            off = min(offs, key=lambda o: -1.0 if o["lowest_U_star"] is None else o["lowest_U_star"])
            why = (f"set by a stable cycle off the branches (peak [{off['peak_m'][0]:.3g}, {off['peak_m'][1]:.3g}] m at "
                   "the design wind), followed down in the wind")
            if off["lowest_U_star"] is None:
                case.update(lowest_galloping_U_m_s=None, lowest_galloping_U_star=None,
                            lowest_galloping_U_at_most_m_s=units.wind_m_s(U_MIN),
                            lowest_galloping_U_bound=f"at most {units.wind_m_s(U_MIN):.3g} m/s",
                            lowest_galloping_note=why + " to the lowest speed followed")
            elif case.get("lowest_galloping_U_star") is not None and \
                    off["lowest_U_star"] < case["lowest_galloping_U_star"]:
                case.update(lowest_galloping_U_m_s=off["lowest_U_m_s"], lowest_galloping_U_star=off["lowest_U_star"],
                            lowest_galloping_note=why)
    case["seconds"] = time.perf_counter() - t0
    # the compiled system's build (sympy, and the C compiler on a cold cache), inside the first branch
    case["build_seconds"] = cont.build_seconds
    return case, branches, cont


def _check_range(units, design_wind_m_s, U_max_m_s):
    U_max = U_MAX_DEFAULT if U_max_m_s is None else units.wind_star(U_max_m_s)
    top = units.wind_m_s(U_MAX_DEFAULT)
    if not (isinstance(U_max, (int, float)) and math.isfinite(U_max) and U_MIN < U_max <= U_MAX_DEFAULT * (1 + 1e-12)):
        raise SpecError("arguments", "--max-wind", f"expected a wind speed in ({units.wind_m_s(U_MIN):.4g}, {top:.4g}] "
                                                   f"m/s (U* <= {U_MAX_DEFAULT:g}), got {U_max_m_s!r}")
    U_des = None
    if design_wind_m_s is not None:
        U_des = units.wind_star(design_wind_m_s)
        if not (math.isfinite(U_des) and U_MIN < U_des <= U_max):
            raise SpecError("arguments", "--design-wind", f"expected a wind speed in ({units.wind_m_s(U_MIN):.4g}, "
                                                          f"{units.wind_m_s(U_max):.4g}] m/s (up to --max-wind), "
                                                          f"got {design_wind_m_s!r}")
    return min(U_max, U_MAX_DEFAULT), U_des


def _curves_variant(derivation, curves):
    """``derivation`` with its aerodynamic curves replaced by ``curves`` (a `BlendedCubic` whose
    range holds the static angle): the model file's [aero] fields for the validity and the cubic
    rung's exact load, the exact rung's load itself. Eq. (21), the calibrated angle and the onset
    stay those of the model: a range holding phi0 leaves the fits' expansion there unchanged."""
    from dataclasses import replace
    d = derivation
    lo, hi = (math.degrees(x) for x in curves.valid_phi)
    spec = replace(d.spec, aero=replace(d.spec.aero, valid_phi_deg=(lo, hi), outside="dry-cylinder",
                                        blend_deg=curves.blend_deg, dry_drag=curves.dry_drag))
    ode = d.ode
    if ode.exact_load is not None:
        ode = replace(ode, exact_load=replace(ode.exact_load, curves=curves.to_dict()))
    return replace(d, spec=spec, ode=ode)


def sensitivity_undefined(derivation) -> str:
    """Why the curves of ``derivation`` have no band or blend to vary, or "" when they have one (a
    blend of cubic fits to the dry cylinder beyond a stated range)."""
    from autocable.model.curves import curves_from_spec
    curves = curves_from_spec(derivation.spec.aero)
    if curves.kind == "blend":
        return ""
    if curves.kind == "table":
        return ("the sensitivity to the curves' band is undefined: a table holds its measured values over its own "
                "range, with no band or blend to vary")
    if curves.valid_phi is None:
        return ("the sensitivity to the curves' band is undefined: the paper's cubic fits state no range (the "
                "default phi0 +- 15 deg only sets the verdict)")
    return ("the sensitivity to the curves' band is undefined: the fits are used at every angle (aero.outside = "
            "\"cubic\"), their stated range only sets the verdict")


def _span(values) -> list | None:
    vals = [v for v in values if v is not None and math.isfinite(v)]
    return [min(vals), max(vals)] if vals else None


def sensitivity(derivation, xi: float, U_max: float, U_des: float | None, units, band_deg: float = SENSITIVITY_BAND_DEG,
                blend_factors=SENSITIVITY_BLEND_FACTORS, nominal: dict | None = None, log=None,
                shared: DampedSystem | None = None) -> dict:
    """The amplitude at the design wind and the lowest galloping speed at damping ``xi`` recomputed
    with the curves' valid range narrowed and widened by ``band_deg`` at each end and the blend's
    width times each of ``blend_factors`` (`curves.with_band`, one continuation each), beside the
    nominal values (``nominal``: that damping's case of `gallop_study`, computed when None).

    ``range`` is [lo, hi] over the nominal value and every case that has one (in-plane and
    out-of-plane separately for the amplitude). On the cubic rung eq. (21) takes the curves only
    through their expansion at phi0, which a range holding phi0 leaves unchanged: its amplitudes
    and speeds are the same in every case, and only the validity verdict moves. On the exact rung
    each case runs on ``shared`` (the nominal equation's `DampedSystem`, built here when None) with
    the case's curves as new run-time weights (`DampedSystem.with_curves`), not a new build."""
    from autocable.model.curves import curves_from_spec, with_band
    why = sensitivity_undefined(derivation)
    if why:
        return {"defined": False, "reason": why}
    if not (isinstance(band_deg, (int, float)) and math.isfinite(band_deg) and band_deg > 0):
        raise SpecError("arguments", "band_deg", f"expected a positive number of degrees, got {band_deg!r}")
    t0 = time.perf_counter()
    d = derivation
    curves = curves_from_spec(d.spec.aero)
    phi0 = d.static_angle
    half = math.degrees(curves.valid_phi[1] - curves.valid_phi[0]) / 2
    plans = [(f"band narrowed by {band_deg:g} deg", half - band_deg, curves.blend_deg),
             (f"band widened by {band_deg:g} deg", half + band_deg, curves.blend_deg)]
    plans += [(f"blend x{f:g}", half, curves.blend_deg * f) for f in blend_factors]
    shared = DampedSystem(d.ode) if shared is None else shared
    if nominal is None:
        nominal = _case(d, d.ode if xi == d.ode.xi_s else with_damping(d.ode, xi), xi, U_max, units, U_des, None,
                        shared)[0]
    cases = []
    for name, h, blend in plans:
        if h <= 0:
            cases.append({"case": name, "skipped": f"the band would be empty (half-width {h:g} deg)"})
            continue
        c = with_band(curves, h, blend_deg=blend)
        row = {"case": name, "valid_phi_deg": [math.degrees(x) for x in c.valid_phi], "blend_deg": c.blend_deg}
        if not c.valid_phi[0] <= phi0 <= c.valid_phi[1]:
            cases.append(dict(row, skipped=f"the band no longer holds the static angle {math.degrees(phi0):.1f} deg"))
            continue
        if log:
            log(f"sensitivity: {name} (phi {row['valid_phi_deg'][0]:.1f} to {row['valid_phi_deg'][1]:.1f} deg, "
                f"blend {c.blend_deg:g} deg) ...")
        dv = _curves_variant(d, c)
        ode = dv.ode if xi == dv.ode.xi_s else with_damping(dv.ode, xi)
        # the exact rung: the nominal build with the case's curves as weights (None: a build of its own)
        # (the cubic rung: the same equation, the same system)
        own = shared if shared.serves(dv.ode) else shared.with_curves(dv.ode)
        case = _case(dv, ode, xi, U_max, units, U_des, None, own)[0]
        row.update({k: case.get(k) for k in ("lowest_galloping_U_m_s", "lowest_galloping_U_bound",
                                              "amplitude_at_design_wind_m", "envelope_at_design_wind_m",
                                              "other_stable_cycles",
                                              "frequency_at_design_wind_Hz", "beyond_valid_range", "design_verdict",
                                              "design_note")})
        row["missing_ingredient"] = [m["ingredient"] for m in case.get("missing_ingredient", [])]
        row["hopf_U_m_s"] = [h["hopf_U_m_s"] for h in case["hopf_points"]]
        row["seconds"] = case["seconds"]
        row["build_seconds"] = case["build_seconds"]
        dc = case.get("design_cycle") or {}
        row["phi_swept_deg"] = dc.get("phi_swept_deg")
        row["twist_max_deg"] = dc.get("twist_max_deg")
        cases.append(row)
    done = [c for c in cases if "skipped" not in c]
    amp = nominal.get("amplitude_at_design_wind_m")
    amps = [c["amplitude_at_design_wind_m"] for c in done if c.get("amplitude_at_design_wind_m")]
    low = nominal.get("lowest_galloping_U_m_s")
    env = nominal.get("envelope_at_design_wind_m") or amp
    envs = [c.get("envelope_at_design_wind_m") or c["amplitude_at_design_wind_m"] for c in done
            if c.get("amplitude_at_design_wind_m")]
    out = {"defined": True, "band_deg": band_deg, "blend_factors": list(blend_factors), "damping_ratio": xi,
           "nominal_valid_phi_deg": [math.degrees(x) for x in curves.valid_phi], "nominal_blend_deg": curves.blend_deg,
           "load": "exact" if d.ode.exact_load is not None else "cubic",
           "amplitude_at_design_wind_m": {
               "nominal": amp,
               "range": None if U_des is None else [_span(([amp[i]] if amp else []) + [a[i] for a in amps])
                                                   for i in (0, 1)],
               "cases_with_a_stable_cycle": len(amps), "cases": len(done)},
           # per plane, the largest over every stable cycle found at the design wind (the band's measure)
           "envelope_at_design_wind_m": {
               "nominal": env,
               "range": None if U_des is None else [_span(([env[i]] if env else []) + [e[i] for e in envs])
                                                   for i in (0, 1)]},
           "lowest_galloping_U_m_s": {"nominal": low,
                                      "range": _span([low] + [c.get("lowest_galloping_U_m_s") for c in done])},
           "cases": cases, "seconds": time.perf_counter() - t0}
    if out["load"] == "cubic":
        out["reading"] = ("eq. (21) takes the curves only through their cubic expansion at phi0, which these bands "
                          "leave unchanged: the amplitudes and speeds cannot move, only the verdict; --load exact "
                          "shows how the band and the blend move them")
    return out


def gallop_study(derivation, design_wind_m_s: float | None = None, dampings=None, U_max_m_s: float | None = None,
                 checks: bool = True, log=None, with_sensitivity: bool | None = False,
                 band_deg: float = SENSITIVITY_BAND_DEG, shared: DampedSystem | None = None) -> dict:
    """The galloping branches of eq. (21) at eta = 0 (module docstring) as a plain dict.

    ``dampings``: damping ratios (default: the cable's own); the first is the primary one, whose
    values are also the top-level keys (``lowest_galloping_U_m_s``, ``hysteresis_m_s``,
    ``amplitude_at_design_wind_m``, ``frequency_at_design_wind_Hz``, ``beyond_valid_range``,
    ``design_verdict``, ``missing_ingredient``) and which the direct-integration ``check`` and the
    ``sensitivity`` (`sensitivity`) compute. ``U_max_m_s``: the highest wind speed (default and at
    most 5 U_c). ``with_sensitivity``: True or None (`autocable gallop`'s default) compute it where
    the curves have a band and a blend to vary (four more continuations), False (the default here,
    so that studies built on this one do not pay for it) does not; where the curves have none the
    dict says why in one line either way. ``shared``: the compiled system of ``derivation``'s
    eq. (21) for any damping ratio (`DampedSystem`; built here when None), to hand on to
    `least_damping_global` on the same equation."""
    d = derivation
    units = units_of(d.spec, d.statics)
    U_max, U_des = _check_range(units, design_wind_m_s, U_max_m_s)
    xis = [d.ode.xi_s] if dampings is None else [float(x) for x in dampings]
    for x in xis:
        if not (math.isfinite(x) and 0 < x < 1):
            raise SpecError("arguments", "--damping", f"expected damping ratios 0 < xi < 1 (0.004 is 0.4 %), got {x!r}")
    t0 = time.perf_counter()
    shared = DampedSystem(d.ode) if shared is None else shared
    cases, primary_branches, primary_ode = [], None, None
    for k, xi in enumerate(xis):
        ode = d.ode if xi == d.ode.xi_s else with_damping(d.ode, xi)
        case, branches, _ = _case(d, ode, xi, U_max, units, U_des, log, shared)
        cases.append(case)
        if k == 0:
            primary_branches, primary_ode = branches, ode
    if log and checks:
        log("direct integration of eq. (21) on the stable cycles ...")
    check = _check(primary_ode, primary_branches, units) if checks else []
    first = cases[0]
    if with_sensitivity is False and not sensitivity_undefined(d):
        sens = {"defined": True, "computed": False,
                "reason": "not computed (asked off: --no-sensitivity, or with_sensitivity=False)"}
    else:
        sens = sensitivity(d, xis[0], U_max, U_des, units, band_deg, nominal=first, log=log, shared=shared)
    return {
        "model": d.spec.name, "primary_damping_ratio": xis[0], "damping_ratios": xis,
        "scanned_U_m_s": [units.wind_m_s(U_MIN), units.wind_m_s(U_max)], "design_wind_m_s": design_wind_m_s,
        "length_m": d.spec.cable.length_m, "critical_wind_speed_m_s": units.critical_wind_speed_m_s,
        "load": "exact" if d.ode.exact_load is not None else "cubic",
        "lowest_galloping_U_m_s": first["lowest_galloping_U_m_s"], "hysteresis_m_s": first["hysteresis_m_s"],
        # where the lowest speed is not known (a branch still descending where it ends): a bound
        "lowest_galloping_U_bound": first.get("lowest_galloping_U_bound"),
        "lowest_galloping_U_at_most_m_s": first.get("lowest_galloping_U_at_most_m_s"),
        "lowest_galloping_note": first.get("lowest_galloping_note"),
        "amplitude_at_design_wind_m": first.get("amplitude_at_design_wind_m"),
        "envelope_at_design_wind_m": first.get("envelope_at_design_wind_m"),
        "other_stable_cycles": first.get("other_stable_cycles"),
        "off_branch_cycle": first.get("off_branch_cycle"),
        "frequency_at_design_wind_Hz": first.get("frequency_at_design_wind_Hz"),
        "beyond_valid_range": first.get("beyond_valid_range"),
        "design_verdict": first.get("design_verdict"),
        "missing_ingredient": first.get("missing_ingredient", []),
        "sensitivity": sens,
        "cases": cases,
        "branches": {f"{xi:g}": [dict(r, hopf_U_m_s=h["hopf_U_m_s"]) for h in c["hopf_points"] for r in h["rows"]]
                     for xi, c in zip(xis, cases)},
        "check": check,
        "validity_reported": bool(_validity_available()),
        "conventions": {"peak_m": f"a_k l at {PEAK_STATION}; a_k = half the peak-to-peak of q_k over the cycle",
                        "U_m_s": "U* U_c", "frequency_Hz": "2 pi / T times omega / (2 pi), T the cycle's own period",
                        "stable": "every non-trivial Floquet multiplier inside the unit circle",
                        "order": "amplitude pairs are [in-plane, out-of-plane]",
                        "twist_bound_deg": TWIST_BOUND_DEG, "modes_fraction": MODES_FRACTION,
                        "lowest_galloping_U_m_s": "the lowest wind of the branches where it is a turn (a fold, or the "
                                                  "onset); null with lowest_galloping_U_bound (\"at most X m/s\") "
                                                  "where a branch is still descending where it ends"},
        "seconds": time.perf_counter() - t0,
    }


def _validity_available() -> bool:
    try:
        from autocable.model.validity import motion_validity  # noqa: F401
    except ImportError:
        return False
    return True


# -- the global least damping -------------------------------------------------------------------------
def _gallops_below(ode, U_des: float, U_max: float, shared: DampedSystem | None = None,
                   full: bool = False) -> tuple[bool, str, float, object]:
    """(whether a cycle connected to a Hopf point exists at some U* < U_des, how it was decided,
    the lowest U* seen, the first cycle found below U_des (a branch point with its orbit) or None).
    ``full``: every branch followed to its end, so that the lowest U* seen is the branches' lowest
    (their fold below a sub-critical onset) also where it lies below U_des; otherwise the answer
    comes from the first branch that passes below U_des, as soon as it does."""
    hopfs, st = _hopf_points(ode, U_max)
    if st.onsets and st.onsets[0].U_star <= U_des:
        return True, "the rest state is unstable below the design wind", st.onsets[0].U_star, None
    if not st.stable_at_start:
        return True, "the rest state is unstable without wind", 0.0, None
    cont = _continuation(ode, shared)
    lowest, how, first = math.inf, "no Hopf point in the scan", None
    for o in hopfs:
        br = cont.branch(hopf_start(o), U_min=U_MIN, U_max=max(U_max, HOPF_SCAN_FACTOR * U_max),
                         stop_below=None if full else U_des)
        if br.end_code == "failed":
            raise ComputationError(f"the continuation of cycles from the Hopf point at U* = {o.U_star:.8g} failed "
                                   f"({br.end}): the global least damping cannot be decided")
        lowest = min(lowest, br.lowest_U)
        how = f"the lowest cycle is at U* = {lowest:.8g} ({br.end})"
        if br.lowest_U < U_des and first is None:
            below = [p for p in br.points if p.U < U_des and p.orbit is not None]
            first = below[0] if below else None
        if lowest < U_des and not full:
            return True, how, lowest, first
    return lowest < U_des, how, lowest, first


def _illinois(gallops, values: dict, lo: float, hi: float, rtol: float, max_steps: int = 30) -> tuple[float, float]:
    """Narrow the bracket [lo, hi] of `least_damping_global` (``gallops(lo)`` true, ``gallops(hi)``
    false) by the Illinois variant of regula falsi on g(xi) = ``values[xi]`` (the branches' lowest
    U* minus the design wind, filled by ``gallops``), until hi - lo <= rtol hi. Each new point is
    kept at least 0.45 rtol hi inside the bracket, and once the estimate has converged the next is
    put that far across it, so that the bracket closes from both sides (plain regula falsi keeps
    one end); where g is not finite (no branch at all) or flat, the bracket is halved instead.
    The bisection that follows in the caller finishes whatever is left after ``max_steps``."""
    g_lo, g_hi = values[lo], values[hi]
    side = 0
    for _ in range(max_steps):
        width = hi - lo
        if width <= rtol * hi:
            break
        eps = 0.45 * rtol * hi
        if math.isfinite(g_lo) and math.isfinite(g_hi) and g_hi > g_lo:
            x = hi - g_hi * width / (g_hi - g_lo)
            # the same end moved twice: step across the estimate towards the other end, by eps
            x += eps if side < 0 else -eps if side > 0 else 0.0
        else:
            x = 0.5 * (lo + hi)
        x = min(max(x, lo + eps), hi - eps)
        if gallops(x):
            lo, g_lo = x, values[x]
            if side < 0:
                g_hi *= 0.5          # Illinois: the stale end's value halved
            side = -1
        else:
            hi, g_hi = x, values[x]
            if side > 0:
                g_lo *= 0.5
            side = 1
    return lo, hi


def _setting_cycle(derivation, point, units) -> dict | None:
    """Where the global least damping holds: the cycle that still gallops below the design wind at
    the largest damping found to gallop (the bracket's lower end), with its validity
    (`autocable.model.validity.motion_validity`: phi swept, twist, beyond the curves' or the cubic
    load's range). A bound set by a cycle beyond the model's range is no bound within validity."""
    if point is None:
        return None
    v = _validity(derivation, point.orbit, point.U)
    return {"U_m_s": units.wind_m_s(point.U), "peak_in_plane_m": units.peak_m(point.a1),
            "peak_out_of_plane_m": units.peak_m(point.a2), "stable": bool(point.stable), **v}


def least_damping_global(derivation, design_wind_m_s: float, U_max_m_s: float | None = None,
                         rtol: float = GLOBAL_DAMPING_RTOL, shared: DampedSystem | None = None,
                         method: str = "illinois") -> dict:
    """The least damping ratio for which no galloping cycle (of a branch from a Hopf point of the
    rest state up to U_max) exists at any wind speed up to ``design_wind_m_s``, to ``rtol``
    (relative), from the linear least damping (`autocable.studies.onset.design_damping`: the rest
    state stable up to the design wind, which a sub-critical onset's fold undercuts) upwards. The
    bracket [lo, hi] (lo gallops below the design wind, hi does not) is found by doubling from the
    linear least damping, then narrowed until hi - lo <= rtol hi; hi is returned. Two ways of
    narrowing it (``method``):

    * "illinois" (the default): the Illinois variant of regula falsi on the continuous function
      g(xi) = (the branches' lowest U*) - U_design, each branch followed to its end
      (`_gallops_below` with ``full``) so that g is known on both sides: about half the
      continuations of the bisection on the shipped stays (each a little longer);
    * "bisection": halving the bracket, each step one continuation stopped as soon as it passes
      below the design wind (it needs only the sign of g): the independent route
      (tests/test_gallop_speed.py compares the two).

    Assumes the lowest galloping speed rises with the damping (checked at the bracket's ends
    only). Every step runs on one compiled system with the damping
    ratio a run-time parameter (``shared``, a `DampedSystem` of ``derivation``'s eq. (21), built
    here when None)."""
    from autocable.studies.onset import design_damping
    d = derivation
    units = units_of(d.spec, d.statics)
    U_max, U_des = _check_range(units, design_wind_m_s, U_max_m_s)
    if U_des is None:
        raise SpecError("arguments", "--design-wind", "the global least damping needs a design wind speed")
    if not (isinstance(rtol, (int, float)) and 1e-9 <= rtol < 0.5):
        raise SpecError("arguments", "rtol", f"expected a relative tolerance in [1e-9, 0.5), got {rtol!r}")
    if method not in ("illinois", "bisection"):
        raise SpecError("arguments", "method", f"expected \"illinois\" or \"bisection\", got {method!r}")
    full = method == "illinois"
    t0 = time.perf_counter()
    linear = design_damping(d, design_wind_m_s, U_max)["least_damping_ratio"]
    steps = []
    shared = DampedSystem(d.ode) if shared is None else shared

    setting = {}

    values = {}

    def gallops(xi):
        below, how, low, point = _gallops_below(with_damping(d.ode, xi), U_des, U_max, shared, full)
        steps.append({"damping_ratio": xi, "gallops_below_design_wind": below, "lowest_U_m_s": units.wind_m_s(low),
                      "how": how})
        if below and xi >= setting.get("damping_ratio", -1.0):
            setting.update(damping_ratio=xi, point=point)
        values[xi] = low - U_des
        return below

    lo = max(linear, 1e-6)
    if not gallops(lo):
        xi = lo
    else:
        hi = 2 * lo
        while gallops(hi):
            lo, hi = hi, 2 * hi
            if hi >= 1.0:
                raise SpecError("arguments", "--design-wind", f"no damping ratio below 100 % keeps every galloping "
                                                              f"cycle above {design_wind_m_s:g} m/s")
        if full:
            lo, hi = _illinois(gallops, values, lo, hi, rtol)
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if gallops(mid) else (lo, mid)
        xi = hi
    cycle = _setting_cycle(d, setting.get("point"), units)
    if cycle is not None:
        cycle["damping_ratio"] = setting["damping_ratio"]
    off = _isolated_below(d, xi, setting.get("point"), U_des, units, shared)
    return {"design_wind_m_s": design_wind_m_s, "least_damping_ratio_global": xi, "scruton_global": units.scruton(xi),
            "setting_cycle": cycle, "isolated_cycle": off, "at_least": off is not None,
            "beyond_valid_range": None if not cycle or "beyond_valid_range" not in cycle
            else bool(cycle["beyond_valid_range"]),
            "least_damping_ratio_linear": linear, "relative_tolerance": rtol, "method": method,
            "current_damping_ratio": d.ode.xi_s, "enough": d.ode.xi_s >= xi, "steps": steps,
            "seconds": time.perf_counter() - t0,
            "reading": "the least damping ratio for which every cycle of the branches from the rest state's Hopf "
                       f"points (looked for up to {units.wind_m_s(HOPF_SCAN_FACTOR * U_max):.4g} m/s) lies above the "
                       f"design wind ({'regula falsi (Illinois)' if full else 'bisection'} on the damping ratio, "
                       f"relative tolerance {rtol:g}; an isolated branch of cycles, or one "
                       "born beyond the scan, is looked for only by integration from larger starts at "
                       f"{ISOLATED_PROBE:g} times the design wind: isolated_cycle)"
                       + ("; AT LEAST this much: at this damping a stable cycle off the branches still gallops "
                          f"at {off['U_m_s']:.4g} m/s (isolated_cycle), so more damping is needed"
                          if off is not None else "")}


def _isolated_below(d, xi: float, point, U_des: float, units, shared) -> dict | None:
    """A stable cycle at `ISOLATED_PROBE` U_des, damping ``xi`` (the global least damping of the
    branches), that no branch from a Hopf point reaches (`_larger_cycle`'s reason): the motion from
    ``point`` (the cycle that galloped below the design wind at the largest damping that did) scaled
    by `LARGER_START_FACTORS` factors from 1 to the largest start eq. (21) accepts, until it settles
    (`CycleContinuation.settle`). Its peaks and wind speed, or None (none found: the branches'
    answer stands as far as this search sees)."""
    from autocable.methods.integration.gallop import HopfStart
    if point is None or point.orbit is None:
        return None
    cont = _continuation(with_damping(d.ode, xi), shared)
    U = ISOLATED_PROBE * U_des
    hopf = HopfStart(U, 2 * math.pi / point.T, (0j, 0j, 0j, 0j))     # the scales of Newton's unknowns only
    y = np.asarray(point.state0, float)
    top = 0.999 * MAX_AMPLITUDE / max(float(np.abs(y).max()), 1e-300)
    for f in np.geomspace(1.0, max(top, 1.0), LARGER_START_FACTORS):
        q, _ = cont.settle(f * y, U, point.T, hopf, DESIGN_INTEGRATION_TIME)
        if q is not None:
            return {"U_m_s": units.wind_m_s(U), "peak_m": [units.peak_m(q.a1), units.peak_m(q.a2)],
                    "start_peak_m": units.peak_m(f * point.a1), "damping_ratio": xi}
    return None
