"""Where methods fail: maps over (sigma, eta) and (sigma, U) of the 2-dof AME against eq. (21).

Issue "speed against accuracy", item 3. At every grid point (Omega = omega1 + sigma, docs/model.md, C2):

(a) the AME's error: `compare_with_ode21` integrates the Cartesian AME (24) and eq. (21) from the
    same start (rest, q2 = 1e-6) and classifies the pair (same branch, different branch, no AME
    branch, (21) quasi-periodic, AME not at an equilibrium, divergence); the error is the relative
    a1 error |a1_AME - a1_(21)| / a1_(21) (a_k the peak modal amplitude). Nothing of that
    comparison is repeated here.
(b) stability disagreements: where eq. (21) has a period-1 response, its Floquet multipliers
    (`floquet21`, the monodromy over one forcing period from the response) against the eigenvalues
    of the AME equilibrium that response sits on (Newton from its first harmonics,
    `AmeIntegrator.equilibrium_near`); where eq. (21) has no period-1 attractor but the AME settles on
    a stable equilibrium, the period-1 orbit of (21) next to that equilibrium is found by shooting
    (Newton on the stroboscopic map as in `floquet21.shoot_period1`, started from the first-order q
    of the equilibrium at forcing phase 0, abandoned when it wanders far from it)
    and its multipliers decide.
(c) where methods struggle: a coarse EP-C continuation of the AME equilibria in sigma on every row
    (where a branch ends for a reason other than the range: a stall), the steps eq. (21) needs per
    forcing period (scipy's DOP853 against the implicit Radau over one period of the steady response,
    with the exact Jacobian: an explicit method that needs many more steps than an implicit one is
    the sign of stiffness), the compiled integration's wall time per forcing period, and divergence.

`region_statement` turns a map into the sentences of the report: where the AME is within a
tolerance (same branch and relative a1 error <= tol), where it is not, and where eq. (21) diverges
so the AME is unchecked. The report and the figures are written by `autocable.studies.failure_map_report`.
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from autocable.studies.ladder import Tools

#: Statuses of `compare_with_ode21` under which eq. (21) has no bounded response: the AME is not
#: checked there.
UNCHECKED = ("diverged-21", "diverged-both")
#: An explicit method needing this many times the steps of an implicit one over a period: stiff.
STIFF_RATIO = 2.0


@dataclass(frozen=True)
class Plane:
    """A map: sigma against ``axis`` ("eta" or "U") with the other parameter in ``fixed``."""

    name: str
    axis: str
    fixed: dict
    sigmas: tuple
    values: tuple

    def points(self):
        for v in self.values:
            for s in self.sigmas:
                yield self.parameters(v, s)

    def parameters(self, value: float, sigma: float) -> dict:
        p = {"U": 0.0, "eta": 0.0, **self.fixed, "sigma": float(sigma)}
        p[self.axis] = float(value)
        return p


def default_planes(quick: bool = False) -> tuple:
    """The grids: (sigma, eta) at U = 0; (sigma, U) at eta = 4.1e-4 and 1.4e-3 (Figs. 5-10).
    Points with U >= 1 cost ~20 s each (the AME's slow flow does not settle and is integrated to the
    time limit), so the eta = 1.4e-3 plane has the rows of Figs. 6, 9, 10 only.
    ``quick``: a tiny grid (the test's), including the linear limit eta = 1e-6."""
    if quick:
        sig = (-0.02, 0.0, 0.02)
        return (Plane("sigma-eta, U = 0", "eta", {"U": 0.0}, sig, (1e-6, 4.1e-4)),
                Plane("sigma-U, eta = 4.1e-4", "U", {"eta": 4.1e-4}, sig, (0.0, 0.7)))
    sig = tuple(float(s) for s in np.round(np.linspace(-0.05, 0.05, 9), 6))
    return (Plane("sigma-eta, U = 0", "eta", {"U": 0.0}, sig, (8.2e-5, 2e-4, 4.1e-4, 8e-4, 1.4e-3)),
            Plane("sigma-U, eta = 4.1e-4", "U", {"eta": 4.1e-4}, sig, (0.0, 0.35, 0.7, 1.0, 1.3)),
            Plane("sigma-U, eta = 1.4e-3", "U", {"eta": 1.4e-3}, sig, (0.0, 0.7, 1.3)))


# -- (b) stability: Floquet multipliers of eq. (21) against the AME eigenvalues -------------------------
def _floquet(tools: Tools, U, eta, sigma, state, t0=0.0) -> dict:
    from autocable.methods.integration.floquet21 import STABILITY_MARGIN, multipliers_of

    Omega = tools.derivation.ode.omega1 + sigma
    M, yT = tools.variational.monodromy(U, eta, Omega, state, t0=t0)
    mu = multipliers_of(M)
    y0 = np.asarray(state, float)
    top = float(np.abs(mu[0]))
    return {"max_modulus": top, "stable21": bool(top < 1.0 - STABILITY_MARGIN),
            "residual": float(np.linalg.norm(yT - y0) / max(np.linalg.norm(y0), 1e-300))}


def stability_check(tools: Tools, c, *, shoot_iterations: int = 8) -> dict:
    """Eq. (21)'s Floquet verdict against the AME's eigenvalue verdict at one compared point ``c``
    (a `Comparison`). ``verdict``: "agree", "AME unstable, (21) stable", "AME stable, (21)
    unstable", "no AME equilibrium at (21)'s response", "AME stable, no (21) orbit found",
    "agree (neither period-1)" (both amplitude-modulated from this start), or "n/a" (nothing to
    compare: eq. (21) diverges and the AME has no stable equilibrium)."""
    from autocable.methods.integration.floquet21 import STABILITY_MARGIN, multipliers_of

    o, a = c.ode, c.ame
    out = {"verdict": "n/a", "source": "", "max_modulus": None, "stable21": None, "ame_stable": None,
           "ame_max_real": None, "floquet_residual": None, "seconds": 0.0}
    t0 = time.perf_counter()
    if o is not None and math.isfinite(o.a1) and o.periodic:
        # The response itself: the integrator stops on whole forcing periods, but the monodromy is
        # taken from t_end whatever the phase (the forcing is T-periodic, the multipliers are not
        # phase-dependent).
        fl = _floquet(tools, c.U, c.eta, c.sigma, o.final_state, t0=o.t_end)
        out.update(source="(21) response", max_modulus=fl["max_modulus"], stable21=fl["stable21"],
                   floquet_residual=fl["residual"])
        found = c.nearest is not None and math.isfinite(c.rel_a1_nearest)
        if found:
            out.update(ame_stable=c.nearest.stable, ame_max_real=c.nearest.max_real)
            out["verdict"] = ("agree" if c.nearest.stable == fl["stable21"] else
                              "AME unstable, (21) stable" if fl["stable21"] else "AME stable, (21) unstable")
        else:
            out["verdict"] = "no AME equilibrium at (21)'s response"
    elif a.periodic and a.equilibrium is not None:
        # (21) has no period-1 attractor from this start; the AME has a stable equilibrium. Its
        # first-order q at forcing phase 0 (t = 0): q_k = r_k, q_k' = -Omega s_k.
        eq = a.equilibrium
        r1, s1, r2, s2 = eq.y
        Om = a.Omega
        guess = (r1, r2, -Om * s1, -Om * s2)
        out.update(source="shot from the AME equilibrium", ame_stable=eq.stable, ame_max_real=eq.max_real)
        sh, why = _shoot(tools, c.U, c.eta, Om, guess, shoot_iterations)
        near = sh is not None and np.linalg.norm(sh[0] - np.array(guess)) <= 0.5 * np.linalg.norm(guess)
        if near:
            mu = multipliers_of(sh[1])
            top = float(np.abs(mu[0]))
            stable21 = bool(top < 1.0 - STABILITY_MARGIN)
            out.update(max_modulus=top, stable21=stable21, floquet_residual=sh[2],
                       verdict="agree" if stable21 == eq.stable else
                       ("AME stable, (21) unstable" if eq.stable else "AME unstable, (21) stable"))
        else:
            out.update(verdict="AME stable, no (21) orbit found",
                       note=why if sh is None else "shooting converged to a remote orbit")
    elif o is not None and math.isfinite(o.a1) and math.isfinite(a.a1) and not a.periodic:
        # Neither settles on a period-1 state from this start: both amplitude-modulated.
        out.update(verdict="agree (neither period-1)", source="both amplitude-modulated")
    out["seconds"] = time.perf_counter() - t0
    return out


def _shoot(tools: Tools, U, eta, Omega, guess, max_iter: int, *, tol: float = 1e-11, reach: float = 2.0):
    """Newton on the stroboscopic map of eq. (21) from ``guess`` (the method of
    `floquet21.shoot_period1`), abandoned as soon as an iterate leaves a ball of ``reach`` |guess|:
    an orbit that far from the AME's equilibrium is not its counterpart, and integrating the cubic
    model far out costs without bound. Returns ((state0, monodromy, residual) or None, message)."""
    y = np.asarray(guess, dtype=float).copy()
    size = np.linalg.norm(y)
    for _ in range(max_iter):
        M, yT = _guarded_monodromy(tools, U, eta, Omega, y, 5 * reach * size)
        if M is None:
            return None, f"the orbit from a Newton iterate left the ball of {5 * reach:g} x the AME amplitude"
        r = yT - y
        res = float(np.linalg.norm(r) / max(np.linalg.norm(y), 1e-300))
        if not np.all(np.isfinite(r)):
            return None, "the orbit left the finite range"
        if res < tol:
            return (y, M, res), "converged"
        try:
            y = y - np.linalg.solve(M - np.eye(4), r)
        except np.linalg.LinAlgError:
            return None, "a multiplier equals 1 (fold): M - I singular"
        if not np.linalg.norm(y) <= reach * size:
            return None, f"Newton left the ball of {reach:g} x the AME amplitude"
    return None, f"no convergence in {max_iter} Newton steps"


def _guarded_monodromy(tools: Tools, U, eta, Omega, y0, bound: float, rtol: float = 1e-10):
    """`Variational21.monodromy` (same equations, tolerances and start at t = 0) with a terminal
    event when the state leaves |y| < ``bound``: near a finite-time blow-up of the cubic model the
    plain integration crawls with collapsing steps. Returns (None, None) if the event fired."""
    from scipy.integrate import solve_ivp

    v = tools.variational
    p = v.parameters(U, eta, Omega)
    y0 = np.asarray(y0, dtype=float)

    def rhs(t, z):
        return np.concatenate([v.rhs(t, z[:4], p), (v.jacobian(t, z[:4], p) @ z[4:].reshape(4, 4)).ravel()])

    def escape(t, z):
        return bound - np.max(np.abs(z[:4]))
    escape.terminal = True

    scale = max(float(np.max(np.abs(y0))), 1e-12)
    atol = np.concatenate([np.full(4, rtol * scale * 1e-2), np.full(16, rtol * 1e-2)])
    sol = solve_ivp(rhs, (0.0, 2 * math.pi / Omega), np.concatenate([y0, np.eye(4).ravel()]),
                    method="DOP853", rtol=rtol, atol=atol, events=escape)
    if sol.status != 0:
        return None, None
    z = sol.y[:, -1]
    return z[4:].reshape(4, 4), z[:4]


# -- (c) integration effort of eq. (21) ----------------------------------------------------------------
def step_counts(tools: Tools, U, eta, sigma, state, t0: float, *, rtol: float = 1e-10,
                atol: float = 1e-13) -> dict:
    """Accepted steps over one forcing period of eq. (21) from ``state`` at time ``t0`` with an
    explicit (DOP853) and an implicit (Radau, exact Jacobian) method at the integrator's tolerances."""
    from scipy.integrate import solve_ivp

    v = tools.variational
    Omega = tools.derivation.ode.omega1 + sigma
    p = v.parameters(U, eta, Omega)
    span = (t0, t0 + 2 * math.pi / Omega)
    out = {}
    for name, kw in (("DOP853", {}), ("Radau", {"jac": lambda t, y: v.jacobian(t, y, p)})):
        sol = solve_ivp(lambda t, y: v.rhs(t, y, p), span, np.asarray(state, float), method=name,
                        rtol=rtol, atol=atol, **kw)
        out[name] = (len(sol.t) - 1) if sol.success else None
    return {"steps_dop853": out["DOP853"], "steps_radau": out["Radau"]}


# -- one grid point --------------------------------------------------------------------------------
def map_point(tools: Tools, U: float, eta: float, sigma: float, *, max_time: float = 60000.0) -> dict:
    """(a), (b) and the integration part of (c) at one point, as a plain record."""
    from autocable.methods.integration.ame import compare_with_ode21

    t0 = time.perf_counter()
    c = compare_with_ode21(tools.ame_int, tools.ode_int, U, eta, sigma, max_time=max_time)
    o, a = c.ode, c.ame

    def num(x):
        return None if x is None or not math.isfinite(x) else float(x)

    bounded = o is not None and math.isfinite(o.a1)
    row = {"U": U, "eta": eta, "sigma": sigma, "status": c.status,
           "rel_a1": num(c.rel_a1), "rel_a1_nearest": num(c.rel_a1_nearest),
           "a1_ode21": num(o.a1) if o else None, "a1_ame": num(a.a1),
           "ode21_periodic": bool(o.periodic) if bounded else None,
           "ode21_t_end": float(o.t_end) if o else None, "ode21_wall_s": o.wall_seconds if o else None,
           "ode21_error": c.ode_error, "ame_wall_s": a.wall_seconds, "ame_message": a.message}
    period = 2 * math.pi / (tools.derivation.ode.omega1 + sigma)
    row["ode21_ms_per_period"] = (1e3 * o.wall_seconds / (o.t_end / period)
                                  if o is not None and o.t_end > 0 else None)
    row["diverged_at"] = float(o.t_end) if o is not None and not bounded else None
    row["stability"] = stability_check(tools, c)
    row["steps"] = (step_counts(tools, U, eta, sigma, o.final_state, o.t_end) if bounded
                    else {"steps_dop853": None, "steps_radau": None})
    s = row["steps"]
    row["stiff"] = bool(s["steps_dop853"] and s["steps_radau"]
                        and s["steps_dop853"] > STIFF_RATIO * s["steps_radau"])
    row["wall_s"] = time.perf_counter() - t0
    return row


# -- (c) continuation stalls -------------------------------------------------------------------------
def continuation_row(tools: Tools, U: float, eta: float, bounds, *, max_points: int = 400) -> dict:
    """A coarse EP-C of the AME equilibria in sigma over ``bounds`` from the small forced response
    at the lower end (Newton from the trivial state), forward. A stall: the branch ends inside
    the range for a reason other than the range or a closed curve."""
    from autocable.methods.continuation import (ContinuationSettings, EquilibriumProblem, StartError,
                                                auto_state_scale, continue_equilibria)

    t0 = time.perf_counter()
    lo, hi = (float(b) for b in bounds)
    system = tools.system("2dof", U != 0.0)
    values = {"sigma": lo, "U": U, "eta": eta}
    scale = auto_state_scale(system, values)
    problem = EquilibriumProblem(system, "sigma", values, (lo, hi), state_scale=scale)
    settings = ContinuationSettings(step=1e-2, max_step=5e-2, max_points=max_points)
    row = {"U": U, "eta": eta, "bounds": [lo, hi]}
    try:
        res = continue_equilibria(problem, settings, np.zeros(system.dimension), directions="forward",
                                  name="EQ")
    except StartError as exc:
        row.update(points=0, end_reason="start_failed", end_sigma=lo, stalled=True,
                   message=" ".join(str(exc).split()), special=[], wall_s=time.perf_counter() - t0)
        return row
    b = res.branch
    fwd = [e for e in b.ends if e.side == "forward"][0]
    row.update(points=len(b), end_reason=fwd.reason, end_sigma=float(fwd.value),
               stalled=fwd.reason not in ("range", "closed"), message=fwd.message,
               # A fold can send the branch back out through the lower end: "range", but the
               # upper part of the row then needs another start (or branch switching).
               turned_back=fwd.reason == "range" and float(fwd.value) < hi - 1e-9 * (hi - lo),
               special=[{"type": s.type, "sigma": float(s.parameters["sigma"])}
                        for s in b.special_points if s.type in ("LP", "H", "BP")],
               unstable_points=int(np.sum(~np.asarray(b.stable))), wall_s=time.perf_counter() - t0)
    return row


# -- the map ---------------------------------------------------------------------------------------
def run_failure_map(model_path, *, quick: bool = False, planes=None, log=None,
                    max_time: float = 60000.0, wind_continuation: bool | None = None) -> dict:
    """Every plane of ``planes`` (default `default_planes(quick)`): the point records, the
    continuation rows and the 2 % region statement. A point shared by two planes is computed once.

    ``wind_continuation`` (default: not ``quick``): also continue the rows with wind. Building the
    PyCont system of the AME with its aerodynamic rows costs about a minute per process (sympy
    Jacobian and PyDSTool parsing), so the quick map continues the rows without wind only."""
    say = log or (lambda s: None)
    t_start, cpu_start = time.perf_counter(), time.process_time()
    planes = planes or default_planes(quick)
    if wind_continuation is None:
        wind_continuation = not quick
    say("derivation, AME, integrators ...")
    tools = Tools.build(model_path)
    memo, cont_memo, out = {}, {}, []
    for plane in planes:
        rows = []
        n = len(plane.values) * len(plane.sigmas)
        for i, p in enumerate(plane.points()):
            key = (p["U"], p["eta"], p["sigma"])
            if key not in memo:
                memo[key] = map_point(tools, p["U"], p["eta"], p["sigma"], max_time=max_time)
            r = memo[key]
            rows.append(r)
            rel = f"{r['rel_a1']:.2e}" if r["rel_a1"] is not None else "—"
            say(f"  {plane.name}: U = {p['U']:g}, eta = {p['eta']:g}, sigma = {p['sigma']:+.4f} "
                f"({i + 1}/{n}) {r['status']:<20} rel a1 {rel:<9} stability: {r['stability']['verdict']} "
                f"({r['wall_s']:.1f} s)")
        conts = []
        bounds = (min(plane.sigmas), max(plane.sigmas))
        for v in plane.values:
            p = plane.parameters(v, bounds[0])
            key = (p["U"], p["eta"], bounds)
            if key not in cont_memo:
                if p["U"] != 0.0 and not wind_continuation:
                    cont_memo[key] = {"U": p["U"], "eta": p["eta"], "bounds": list(bounds), "points": 0,
                                      "end_reason": "not_run", "end_sigma": bounds[0], "stalled": False,
                                      "message": "rows with wind are not continued in the quick map",
                                      "special": [], "wall_s": 0.0}
                else:
                    cont_memo[key] = continuation_row(tools, p["U"], p["eta"], bounds)
            cr = cont_memo[key]
            conts.append(cr)
            say(f"  continuation U = {p['U']:g}, eta = {p['eta']:g}: {cr['points']} points, ends "
                f"{cr['end_reason']} at sigma = {cr['end_sigma']:+.4f} ({cr['wall_s']:.1f} s)")
        out.append({"name": plane.name, "axis": plane.axis, "fixed": dict(plane.fixed),
                    "sigmas": list(plane.sigmas), "values": list(plane.values), "rows": rows,
                    "continuation": conts})
    result = {"model": tools.derivation.spec.name, "ode_hash": tools.derivation.ode.content_hash(),
              "quick": quick, "planes": out, "tolerance": 0.02, "contour": 0.05,
              "galloping_threshold_U": _threshold(tools.derivation.ode)}
    result["statement"] = region_statement(result, 0.02)
    result["wall_s"] = time.perf_counter() - t_start
    result["cpu_s"] = time.process_time() - cpu_start
    return result


def _threshold(ode) -> float | None:
    """U at which eq. (21)'s linear in-plane damping 2 xi_s omega1 + zeta11 U vanishes."""
    z11 = ode.find(1, (0, 0, 1, 0), u_power=1)
    if not z11:
        return None
    return float(-2 * ode.xi_s * ode.omega1 / z11[0].coefficient)


# -- the 2 % region, in words ------------------------------------------------------------------------
def point_class(row: dict, tol: float) -> str:
    """"within" (same branch, relative a1 error <= tol), "unchecked" (eq. (21) has no bounded
    response) or "outside"."""
    if row["status"] in UNCHECKED:
        return "unchecked"
    if row["status"] == "same-branch" and row["rel_a1"] is not None and row["rel_a1"] <= tol:
        return "within"
    return "outside"


def _runs(sigmas, flags) -> list:
    """Maximal runs of consecutive grid sigmas where ``flags`` is true, as (first, last)."""
    out, start = [], None
    for i, f in enumerate(flags):
        if f and start is None:
            start = i
        if not f and start is not None:
            out.append((sigmas[start], sigmas[i - 1]))
            start = None
    if start is not None:
        out.append((sigmas[start], sigmas[-1]))
    return out


def _intervals(runs) -> str:
    return " and ".join(f"sigma = {a:+.4g}" if a == b else f"sigma in [{a:+.4g}, {b:+.4g}]" for a, b in runs)


def region_statement(result: dict, tol: float = 0.02) -> list:
    """Sentences stating, from the grid alone, where the 2-dof AME is within ``tol`` of eq. (21)
    (relative a1 error on the same branch) and where it is not, plane by plane and row by row."""
    lines = []
    pct = f"{100 * tol:g} %"
    for plane in result["planes"]:
        sig = plane["sigmas"]
        ax = plane["axis"]
        fixed = ", ".join(f"{k} = {v:g}" for k, v in plane["fixed"].items())
        by_row = {}
        for r in plane["rows"]:
            by_row.setdefault(r[ax], {})[r["sigma"]] = point_class(r, tol)
        values = sorted(by_row)
        full = [v for v in values if all(by_row[v].get(s) == "within" for s in sig)]
        # The largest prefix of the row values (from the smallest) over which every point is within.
        prefix = None
        for v in values:
            if v in full:
                prefix = v
            else:
                break
        head = f"At {fixed} (sigma in [{min(sig):+.4g}, {max(sig):+.4g}], {len(sig)} points per row): "
        if prefix is not None:
            head += f"within {pct} at every sigma for {ax} <= {prefix:g}"
        else:
            head += f"no row of the grid is within {pct} at every sigma"
        parts = []
        for v in values:
            if prefix is not None and v <= prefix:
                continue
            cls = [by_row[v].get(s) for s in sig]
            within = _runs(sig, [c == "within" for c in cls])
            outside = _runs(sig, [c == "outside" for c in cls])
            unchecked = _runs(sig, [c == "unchecked" for c in cls])
            bits = []
            if all(c == "within" for c in cls):
                bits.append(f"within {pct} at every sigma")
            elif within:
                bits.append(f"within {pct} only at {_intervals(within)}")
            else:
                bits.append(f"within {pct} at no sigma")
            if outside:
                bits.append(f"not within {pct} at {_intervals(outside)}")
            if unchecked:
                bits.append(f"eq. (21) diverges at {_intervals(unchecked)}, so the AME is unchecked there")
            parts.append(f"for {ax} = {v:g}: " + "; ".join(bits))
        lines.append(head + ("; " + "; ".join(parts) if parts else "") + ".")
    uniq = {(r.get("U"), r.get("eta"), r["sigma"]): point_class(r, tol)
            for plane in result["planes"] for r in plane["rows"]}
    n = {k: sum(v == k for v in uniq.values()) for k in ("within", "outside", "unchecked")}
    lines.append(f"Over all {len(uniq)} distinct grid points: within {pct} at {n['within']}, not within "
                 f"{pct} at {n['outside']}, unchecked (eq. (21) diverges) at {n['unchecked']}.")
    return lines
