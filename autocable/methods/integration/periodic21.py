"""Periodic orbits of the forced eq. (21) continued in the detuning sigma (a rung of the method ladder).

What it solves. The period-1 responses of eq. (21) itself, q(t + T) = q(t) with T = 2 pi / Omega,
Omega = omega1 + sigma (Sect. 4, docs/model.md, C2), as a branch in sigma at fixed U*, eta*: the reference
the amplitude equations (24) approximate (Figs. 5-6).

How. Eq. (21) is made autonomous by appending a forcing oscillator, as AUTO and MatCont users do:

    x' = x + Omega y - x (x^2 + y^2),     y' = -Omega x + y - y (x^2 + y^2),

whose attracting circle is x = sin(Omega t), y = cos(Omega t); f, f', f'' of eq. (21) become x,
Omega y, -Omega^2 x. The 6-D system is handed to PyCont's LC-C (AUTO's orthogonal collocation,
``ntst`` mesh intervals of ``ncol`` points, period free) in scaled coordinates q = ascale * Q and
sigma = start + span * lam, starting from the period-1 response that `Ode21Integrator` reaches at
``start_sigma`` (polished by Newton shooting, `floquet21.shoot_period1`, and sampled over one
forcing period). Both directions are separate PyCont curves.

PyCont only produces the collocation profiles. Everything reported is autocable's own: the
amplitudes a_k (half peak-to-peak of q_k over the orbit, as `Ode21Integrator` defines them) are the
extremes of AUTO's piecewise collocation polynomials (exact extremes of the polynomial of degree
``ncol`` in each mesh interval, not of samples); stability is from the Floquet multipliers of (21)
(`floquet21`: variational equations over one forcing period from the orbit's state at forcing phase
0; the oscillator's trivial multipliers 1 and exp(-2T) do not arise), cross-checked with AUTO's
multipliers with those two dropped; special points are sign changes along the branch (LPC: sigma
turns, a real multiplier crosses +1; PD: a real one crosses -1; NS: a complex pair crosses |mu| = 1).

Accuracy. Collocation with ``ncol`` Gauss points per interval has error O(h^(ncol+1)) uniformly and
O(h^(2 ncol)) at mesh points (de Boor & Swartz); the extremes are taken on the polynomials, so the
amplitude error is O(ntst^-(ncol+1)) (declared in `METHOD_INFO`, measured in the tests). The state at
forcing phase 0 (``states``) is read off the polynomial too; ``closure`` (how far one period of (21)
from it lands from it) therefore measures the collocation error of the orbit.

Cost. One AUTO build per model (cached); AUTO's collocation step, run in chunks of ``chunk``
points (PyCont's per-point cost grows with the length of a curve); one variational integration of
(21) per orbit for the multipliers, which is the larger part (~0.05 s against AUTO's 0.02-0.1 s).
A branch that comes back to its start (the bi-modal loops of Fig. 6) ends as "closed loop".
"""
from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field

import numpy as np
import sympy as sp

from autocable.methods.integration.floquet21 import STABILITY_MARGIN, Variational21, multipliers_of, shoot_period1
from autocable.model.symbolic import ETA, OMEGA, STATE, T, U, UINV, WIND, first_order_rhs, parameter_values

METHOD_INFO = {
    "name": "periodic21",
    "solves": "period-1 responses of the forced eq. (21) (period 2 pi / Omega) continued in sigma at "
              "fixed U*, eta*, with Floquet stability of (21) and LPC/PD/NS from multiplier crossings",
    "engine": "PyCont LC-C (AUTO orthogonal collocation) on (21) + a forcing oscillator",
    "accuracy": "amplitude error O(ntst^-(ncol+1)) (collocation polynomial of degree ncol per mesh "
                "interval; O(ntst^-2 ncol) at mesh points); at the peak of a near-sinusoid the odd "
                "derivatives vanish and even ncol shows ncol+2 (measured 5.5 for ncol = 4 on a linear "
                "oscillator); Floquet multipliers to ~1e-9 (rtol 1e-10)",
    "declared_order": "ncol + 1 in ntst",
    "cost_drivers": "one AUTO build per model (seconds, cached); per point AUTO's Newton on "
                    "6 * ntst * ncol unknowns plus one variational integration of (21) over a period "
                    "(scipy, ~10-30 ms); points ~ sigma range / step",
}

VARIABLES = ("q1", "q2", "v1", "v2", "xf", "yf")
FORMULATION = "p21v1"      # bump when the autonomous system changes (names the compiled library)


@dataclass(frozen=True, eq=False)
class PeriodicBranch21:
    """A branch of period-1 orbits of eq. (21) in sigma (ordered along the branch)."""

    parameter: str
    values: np.ndarray          # sigma
    a1: np.ndarray              # half peak-to-peak of q1 over the orbit
    a2: np.ndarray
    stable: np.ndarray          # bool, from the Floquet multipliers of (21)
    multipliers: np.ndarray     # complex (n, 4), sorted by modulus, largest first
    periods: np.ndarray         # AUTO's period (2 pi / Omega up to the collocation error)
    special: tuple              # dicts: type, sigma, a1, a2, index, multiplier
    end_reason: str
    seconds: float
    settings: dict
    q_min: np.ndarray = field(default=None, repr=False)   # (n, 2): min of q1, q2 over the orbit
    q_max: np.ndarray = field(default=None, repr=False)   # (n, 2)
    states: np.ndarray = field(default=None, repr=False)  # (n, 4): (q1, q2, q1', q2') at phase 0
    closure: np.ndarray = field(default=None, repr=False)  # |phi_T(state) - state| / |state| under (21):
    #                                                          the collocation error of the state
    info: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.values)


# -- the autonomous system -----------------------------------------------------------------------

def autonomous_field(ode):
    """The 6-D autonomous field handed to PyCont: (21) in scaled coordinates plus the oscillator.

    Parameters: lam (continued; sigma = sig0 + sspan * lam), sig0, sspan, ascale (q = ascale * Q),
    and U, eta, wind, Uinv as in `autocable.model.symbolic`."""
    from autocable.codegen.pydstool import VectorField
    rhs = first_order_rhs(ode)
    Q = sp.symbols("q1 q2 v1 v2", real=True)
    X, Y = sp.symbols("xf yf", real=True)
    lam, sig0, sspan, ascale = sp.symbols("lam sig0 sspan ascale", real=True)
    Om = sp.Float(ode.omega1, 17) + sig0 + sspan * lam
    sub_trig = {sp.sin(OMEGA * T): X, sp.cos(OMEGA * T): Y}
    scaled = {s: ascale * q for s, q in zip(STATE, Q)}
    out = []
    for k, e in enumerate(rhs):
        e = sp.expand(e).xreplace(sub_trig)
        if T in e.free_symbols:
            raise ValueError("eq. (21) depends on t other than through sin/cos(Omega t)")
        e = e.xreplace(scaled).xreplace({OMEGA: Om}) / ascale
        out.append(sp.expand(e))
    r2 = X**2 + Y**2
    out += [X + Om * Y - X * r2, -Om * X + Y - Y * r2]
    params = (("lam", 0.0), ("sig0", 0.0), ("sspan", 1.0), ("ascale", 1.0),
              (U.name, 0.0), (ETA.name, 0.0), (WIND.name, 0.0), (UINV.name, 0.0))
    return VectorField(name=f"{FORMULATION}_{ode.content_hash()}", variables=VARIABLES,
                       rhs=tuple(out), parameters=params)


# -- reading AUTO's collocation profile ----------------------------------------------------------

def polynomial_extremes(t: np.ndarray, x: np.ndarray, ncol: int) -> tuple[float, float]:
    """(min, max) of the piecewise polynomial of degree ``ncol`` through AUTO's profile: interval j
    holds the samples j*ncol ... (j+1)*ncol. Only the intervals around the sampled extremes are
    searched (the polynomial's extreme lies within one interval of the best sample)."""
    n = len(x)
    nint = (n - 1) // ncol
    if nint * ncol + 1 != n:
        raise ValueError(f"profile of {n} points is not ntst * {ncol} + 1")
    out = []
    for sign in (-1.0, 1.0):
        i = int(np.argmax(sign * x))
        j0 = min(i // ncol, nint - 1)
        cands = {j0, max(j0 - 1, 0), min(j0 + 1, nint - 1)}
        if i % ncol == 0:               # a mesh point: both neighbouring intervals
            cands |= {(i // ncol - 1) % nint}
        best = sign * x[i]
        for j in cands:
            tt = t[j * ncol:(j + 1) * ncol + 1]
            xx = x[j * ncol:(j + 1) * ncol + 1]
            a, b = tt[0], tt[-1]
            s = (tt - a) / (b - a)
            c = np.polyfit(s, xx, ncol)
            roots = np.roots(np.polyder(c)) if ncol > 1 else np.array([])
            roots = roots[np.abs(roots.imag) < 1e-12].real
            roots = roots[(roots >= 0) & (roots <= 1)]
            for r in roots:
                best = max(best, sign * float(np.polyval(c, r)))
        out.append(sign * best)
    return out[0], out[1]


def polynomial_value(t: np.ndarray, X: np.ndarray, ncol: int, tq: float) -> np.ndarray:
    """The piecewise polynomial of degree ``ncol`` through AUTO's profile (rows of ``X``) at ``tq``."""
    nint = (len(t) - 1) // ncol
    j = int(np.clip(np.searchsorted(t[::ncol], tq, side="right") - 1, 0, nint - 1))
    tt = t[j * ncol:(j + 1) * ncol + 1]
    XX = X[j * ncol:(j + 1) * ncol + 1]
    # Lagrange basis at tq on the interval's ncol + 1 points.
    w = np.ones(len(tt))
    for k in range(len(tt)):
        for m in range(len(tt)):
            if m != k:
                w[k] *= (tq - tt[m]) / (tt[k] - tt[m])
    return w @ XX


def _profile(pt):
    # The regular output ('RG') holds AUTO's converged profile; at the start point the 'P' label
    # holds the profile handed in, not the corrected one.
    labels = sorted(pt.labels.items(), key=lambda kv: kv[0] != "RG")
    cyc = next((v["cycle"] for _, v in labels if isinstance(v, dict) and "cycle" in v), None)
    if cyc is None:
        return None
    t = np.asarray(cyc["t"], float)
    X = np.column_stack([np.asarray(cyc[v], float) for v in VARIABLES])
    return t, X


def _auto_multipliers(pt):
    lc = pt.labels.get("LC", {})
    if isinstance(lc, dict) and "data" in lc and hasattr(lc["data"], "evals"):
        ev = np.asarray(lc["data"].evals, dtype=complex)
        if ev.size:
            return ev
    return None


def _drop_trivial(ev: np.ndarray, T: float) -> np.ndarray:
    """AUTO's six multipliers less the oscillator's: the one nearest 1 and the one nearest e^{-2T}."""
    ev = np.delete(ev, int(np.argmin(np.abs(ev - 1.0))))
    return np.delete(ev, int(np.argmin(np.abs(ev - math.exp(-2 * T)))))


def _matched_distance(a: np.ndarray, b: np.ndarray) -> float:
    """max |a_i - b_pi(i)| over the best pairing pi (the sets are small: 4! pairings)."""
    from itertools import permutations
    return float(min(np.max(np.abs(a - b[list(p)])) for p in permutations(range(len(b)))))


# -- special points ------------------------------------------------------------------------------

def _counts(mu: np.ndarray) -> tuple[int, int, int]:
    """(real > 1, real < -1, complex outside |mu| = 1), with the stability margin of floquet21."""
    real = np.abs(mu.imag) <= 1e-7 * np.maximum(np.abs(mu), 1.0)
    out = np.abs(mu) > 1.0 + STABILITY_MARGIN
    return (int(np.sum(real & out & (mu.real > 0))), int(np.sum(real & out & (mu.real < 0))),
            int(np.sum(~real & out)))


def _specials(values, a1, a2, mults, states=None) -> tuple:
    """LPC where sigma turns (and a real multiplier crosses +1), BPC where a real multiplier crosses
    +1 without a turn (or the branch turns into its mirror image q2 -> -q2), PD / NS from the
    multiplier counts;
    located by linear interpolation of the crossing quantity between two neighbouring orbits."""
    out = []
    n = len(values)
    ds = np.diff(values)
    counts = [_counts(m) for m in mults]

    def at(i, s, kind, extra):
        out.append({"type": kind, "sigma": float(values[i] + s * (values[i + 1] - values[i])),
                    "a1": float(a1[i] + s * (a1[i + 1] - a1[i])),
                    "a2": float(a2[i] + s * (a2[i + 1] - a2[i])), "index": i, **extra})

    for i in range(1, n - 1):
        if ds[i - 1] * ds[i] < 0:
            # A turn of sigma between points i-1, i, i+1: the fold is at the vertex of the parabola
            # sigma(s) through them (s the point index).
            s0, s1, s2 = values[i - 1], values[i], values[i + 1]
            den = s0 - 2 * s1 + s2
            u = 0.5 * (s0 - s2) / den if den else 0.0      # offset from i in index units
            j = i if u >= 0 else i - 1
            frac = u if u >= 0 else 1 + u
            confirmed = counts[i - 1][0] != counts[i + 1][0]
            # (q2, q2') at forcing phase 0 flipping sign across the turn: the branch went through
            # a2 = 0 into its mirror image q2 -> -q2, i.e. through a symmetric pitchfork of cycles
            # (the multiplier touches +1 there without crossing), not around a fold.
            mirror = (states is not None
                      and float(np.dot(states[i - 1][[1, 3]], states[i + 1][[1, 3]])) < 0)
            if mirror and not confirmed:
                at(j, frac, "BPC", {"mirror": True})
            else:
                at(j, frac, "LPC", {"confirmed_by_multipliers": bool(confirmed)})
    turns = {d["index"] for d in out} | {d["index"] + 1 for d in out}
    for i in range(n - 1):
        # A real multiplier through +1 where sigma does not turn: a branch point of cycles (in eq.
        # (21), the pitchfork where the planar orbit q2 = 0 loses stability to out-of-plane motion).
        if counts[i][0] != counts[i + 1][0] and i not in turns and i + 1 not in turns:
            d0, d1 = (np.max(m[np.abs(m.imag) < 1e-7].real, initial=0.0) - 1 for m in mults[i:i + 2])
            s = d0 / (d0 - d1) if d0 != d1 else 0.5
            at(i, min(max(s, 0.0), 1.0), "BPC", {})
    for i in range(n - 1):
        for slot, kind in ((1, "PD"), (2, "NS")):
            if counts[i][slot] == counts[i + 1][slot]:
                continue
            if kind == "PD":
                d0, d1 = (-np.min(m[np.abs(m.imag) < 1e-7].real, initial=0.0) - 1 for m in mults[i:i + 2])
            else:
                d0, d1 = (np.max(np.abs(m[np.abs(m.imag) >= 1e-7]), initial=0.0) - 1 for m in mults[i:i + 2])
            s = d0 / (d0 - d1) if d0 != d1 else 0.5
            at(i, min(max(s, 0.0), 1.0), kind, {})
    out.sort(key=lambda d: (d["index"], d["type"]))
    # AUTO may wobble back and forth across a pitchfork (several turns within a few orbits): one
    # passage is reported, at the middle detection of the cluster.
    merged, cluster = [], []
    for d in out + [None]:
        if d is not None and cluster and d["type"] == cluster[-1]["type"] \
                and d["index"] - cluster[-1]["index"] <= 4:
            cluster.append(d)
            continue
        if cluster:
            keep = dict(cluster[len(cluster) // 2])
            if len(cluster) > 1:
                keep["detections"] = len(cluster)
            merged.append(keep)
        cluster = [d] if d is not None else []
    return tuple(merged)


# -- the driver ----------------------------------------------------------------------------------

def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0] if text else ''}"[:300]


def continue_periodic21(derivation, *, U: float, eta: float, sigma_range, start_sigma: float,
                        q0=None, ntst: int = 40, ncol: int = 4, step: float | None = None,
                        max_points: int = 400, progress=None, integrator=None,
                        floquet_rtol: float = 1e-10, tol: float = 1e-8, chunk: int = 40) -> PeriodicBranch21:
    """The branch of period-1 orbits of eq. (21) through the response reached by integration at
    ``start_sigma`` (from ``q0`` = (q1, q1', q2, q2'), `Ode21Integrator`'s default if None),
    continued both ways in sigma over ``sigma_range``. ``step`` bounds AUTO's pseudo-arclength step
    (in sigma / span units plus the orbit scaled by its start amplitude; default 1/20 of the range,
    the orbit usually limits the step first); ``max_points`` bounds each direction, ``chunk`` is the
    length of one PyCont curve, ``tol`` AUTO's Newton tolerance (relative), ``floquet_rtol`` the
    tolerance of the variational integration. Never raises for a numerical failure: the branch
    computed so far is returned with ``end_reason`` saying what happened. Pass ``integrator`` (an
    `Ode21Integrator` of the same ODE) to reuse its compiled generator. Start inside the range:
    from a start on (or a step from) a range end AUTO may take the outward sense on both sides,
    and nothing is left inside the range."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator

    start_clock = time.perf_counter()
    ode = getattr(derivation, "ode", derivation)
    lo, hi = (float(v) for v in sigma_range)
    settings = {"ntst": int(ntst), "ncol": int(ncol), "max_points": int(max_points),
                "U": float(U), "eta": float(eta), "sigma_range": (lo, hi), "start_sigma": float(start_sigma),
                "floquet_rtol": floquet_rtol, "tol": tol, "chunk": chunk}
    if not lo < hi:
        raise ValueError(f"sigma_range must be (low, high) with low < high, got {sigma_range}")
    if not lo <= start_sigma <= hi:
        raise ValueError(f"start_sigma = {start_sigma} lies outside sigma_range {sigma_range}")
    if ntst < 2 or ncol < 2 or ncol > 7:
        raise ValueError(f"ntst >= 2 and 2 <= ncol <= 7 are required (AUTO), got ntst={ntst}, ncol={ncol}")
    span = hi - lo
    step = float(step) if step else span / 20
    settings["step"] = step
    timings = {}

    def failed(reason: str, **info) -> PeriodicBranch21:
        z = np.zeros(0)
        return PeriodicBranch21("sigma", z, z, z, np.zeros(0, bool), np.zeros((0, 4), complex), z, (),
                                reason, time.perf_counter() - start_clock, settings,
                                np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 4)), z,
                                {"timings": timings, **info})

    # 1. The start: integration to the steady response, then Newton shooting to polish it.
    t0 = time.perf_counter()
    integ = integrator if integrator is not None else Ode21Integrator(ode)
    resp = integ.simulate(U, eta, start_sigma, DEFAULT_Q0 if q0 is None else q0)
    timings["start_integration_s"] = time.perf_counter() - t0
    if not (resp.steady and resp.periodic):
        return failed(f"no period-1 start at sigma = {start_sigma:g}: {resp.message}"
                      + ("" if resp.periodic else " (the response is not period-1)"))
    system = Variational21(ode)
    Om0 = ode.omega1 + start_sigma
    shot = shoot_period1(system, U, eta, Om0, resp.final_state, rtol=floquet_rtol)
    if not shot.converged:
        return failed(f"Newton shooting from the integrated response failed: {shot.message}")
    y0 = shot.state0
    ascale = max(float(np.max(np.abs(y0[:2]))), 1e-12)
    if resp.a1 + resp.a2 < 1e-14:
        return failed("the start response is the rest state (eta = 0?): no forced orbit to continue")

    # 2. The start cycle sampled over one forcing period, in scaled coordinates.
    from scipy.integrate import solve_ivp
    Tf = 2 * math.pi / Om0
    p0 = system.parameters(U, eta, Om0)
    ts = np.linspace(0.0, Tf, ntst * ncol + 1)
    sol = solve_ivp(lambda t, y: system.rhs(t, y, p0), (0.0, Tf), y0, method="DOP853", t_eval=ts,
                    rtol=1e-11, atol=1e-14 * ascale)
    prof = np.vstack([sol.y / ascale, np.sin(Om0 * ts), np.cos(Om0 * ts)])
    timings["start_shooting_s"] = time.perf_counter() - t0 - timings["start_integration_s"]

    # 3. PyCont LC-C both ways.
    from autocable.codegen import compat
    from autocable.codegen.pydstool import continuation_system, pydstool_cache_dir
    vf = autonomous_field(ode)
    pv = parameter_values(U, eta, Om0)
    pars = {"lam": 0.0, "sig0": float(start_sigma), "sspan": span, "ascale": ascale,
            "U": pv["U"], "eta": pv["eta"], "wind": pv["wind"], "Uinv": pv["Uinv"]}
    ics = dict(zip(VARIABLES, prof[:, 0]))
    t0 = time.perf_counter()
    try:
        cont = continuation_system(vf, "Dopri", ics=ics, pars=pars, auto=True)
    except Exception as exc:  # noqa: BLE001 - a failure is a result
        return failed(f"PyCont could not be set up: {_one_line(exc)}")
    timings["build_s"] = time.perf_counter() - t0
    dst = compat.import_pydstool()
    cycle = dst.Pointset({"coordarray": prof.copy(), "coordnames": list(VARIABLES),
                          "indepvararray": ts.copy(), "indepvarname": "t"})
    sides, reasons = {}, {}
    lam_lo, lam_hi = (lo - start_sigma) / span, (hi - start_sigma) / span
    edge = 1e-3 * step / span
    curve_args = dict(freepars=["lam"], StepSize=0.2 * step / span, MinStepSize=1e-9,
                      MaxStepSize=step / span, NumIntervals=int(ntst), NumCollocation=int(ncol),
                      NumSPOut=1, LocBifPoints=["LPC", "PD", "NS"], SolutionMeasures=["max", "min"],
                      SaveEigen=True, verbosity=0, FuncTol=tol, VarTol=tol, TestTol=1e-6)
    t0 = time.perf_counter()
    counter = [0]

    def run_chunk(init, how, n):
        """One PyCont curve of n points from ``init``, in travel order."""
        counter[0] += 1
        name = f"P21_{counter[0]}"
        start_args = ({"initpoint": dict(ics, lam=0.0), "initcycle": cycle} if init is None
                      else {"initpoint": init})
        with compat.pydstool_session(f"continuing periodic orbits of eq. (21) ({how})",
                                     pydstool_cache_dir()), warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cont.newCurve(dst.args(name=name, type="LC-C", MaxNumPoints=int(n), **start_args,
                                   **curve_args))
            getattr(cont[name], how)()
        pts = list(cont[name].sol)
        # Travel order starts at the point handed in. PyCont stores some curves far end first
        # (not tied to forward/backward, as once assumed): orient by which end is the start.
        ref = 0.0 if init is None else float(init["lam"])
        if len(pts) > 1 and abs(float(pts[-1]["lam"]) - ref) < abs(float(pts[0]["lam"]) - ref):
            pts = pts[::-1]
        return pts


    def measure(pt):
        # The profile's first point (the orbit at AUTO's phase origin) keep the sign of q2, so
        # an orbit and its mirror image q2 -> -q2 differ here (their max/min may not).
        got = _profile(pt)
        return None if got is None else np.concatenate([[float(pt["lam"])], got[1][0]])

    def closed_loop(kept, pt):
        """Back at the side's start (within two steps) after having gone more than ten away."""
        m0, m, last = measure(kept[0]), measure(pt), measure(kept[-1])
        if m0 is None or m is None or last is None:
            return False
        here = np.linalg.norm(m - m0)
        stepn = np.linalg.norm(m - last)
        far = max((np.linalg.norm(mk - m0) for mk in map(measure, kept[-5:]) if mk is not None),
                  default=0.0)
        travelled[0] = max(travelled[0], far)
        return travelled[0] > 10 * stepn and here < 2 * stepn

    # From the initial cycle PyCont's backward() may travel the same way as forward() (seen on
    # Fig. 5a): AUTO picks the sense from its own tangent, and neither the call nor the sign of
    # the parametrisation changes it (both tried). See the restart below.
    first_travel = 0.0
    for direction in ("forward", "backward"):
        if direction == "backward" and reasons.get("forward", "").startswith("closed"):
            sides["backward"], reasons["backward"] = [], "not needed (closed loop)"
            break
        kept, reason, init, how = [], "max_points", None, direction
        travelled = [0.0]
        try:
            while len(kept) < max_points:
                n = min(chunk, max_points - len(kept) + (1 if kept else 0))
                pts = run_chunk(init, how, n)
                travel = (float(pts[-1]["lam"]) - float(pts[0]["lam"])) if len(pts) > 1 else 0.0
                if init is None and direction == "forward":
                    first_travel = travel
                if (direction == "backward" and init is None and travel * first_travel > 0
                        and len(sides["forward"]) > 1):
                    # From the initial cycle AUTO chose the forward side's sense again: restart
                    # from the forward side's first corrected orbit, which carries AUTO's tangent
                    # so that the sense can be chosen, and keep the sense that travels away.
                    f1 = sides["forward"][1]
                    for how in ("backward", "forward"):
                        pts = run_chunk(f1, how, n)
                        if len(pts) > 1 and (float(pts[-1]["lam"]) - float(pts[0]["lam"])) * first_travel < 0:
                            break
                    else:
                        reason = "AUTO did not continue against the forward side"
                        break
                    pts = [sides["forward"][0]] + pts[1:]     # the side starts at the start orbit
                if kept:
                    # A restart carries AUTO's tangent; make sure it kept the direction of travel.
                    ms = [measure(p_) for p_ in (kept[-2] if len(kept) > 1 else None, kept[-1])
                          if p_ is not None] + [measure(p_) for p_ in pts[:2]]
                    if len(ms) == 4 and all(m_ is not None for m_ in ms) and \
                            np.dot(ms[3] - ms[2], ms[1] - ms[0]) < 0:
                        how = "backward" if how == "forward" else "forward"
                        pts = run_chunk(init, how, n)
                    pts = pts[1:]           # the restart point itself
                stop = False
                for pt in pts:
                    if len(kept) > 2 and closed_loop(kept, pt):
                        reason, stop = "closed loop (the branch came back to its start)", True
                        break
                    lam, per = float(pt["lam"]), float(pt["_T"])
                    if "MX" in pt.labels or not (math.isfinite(lam) and math.isfinite(per)):
                        reason, stop = "AUTO stopped (no convergence, MX point)", True
                        break
                    # AUTO corrects the start with lam free: a start on the range's end may
                    # land a hair outside it, which must not end the branch at its first point.
                    if not lam_lo - edge <= lam <= lam_hi + edge:
                        reason, stop = "range", True
                        break
                    kept.append(pt)
                if stop:
                    break
                if len(pts) < n - (1 if init is not None else 0):
                    reason = "AUTO stopped before the point budget"
                    break
                init = kept[-1]
                if progress:
                    progress(f"periodic21 {direction}: {len(kept)} orbits, sigma = "
                             f"{start_sigma + span * float(kept[-1]['lam']):.6g}")
        except Exception as exc:  # noqa: BLE001 - a failure is a result; the points so far stay
            reason = f"AUTO failed: {_one_line(exc)}"
        sides[direction], reasons[direction] = kept, reason
        if progress:
            progress(f"periodic21 {direction}: {len(kept)} orbits, {reason}")
    timings["auto_s"] = time.perf_counter() - t0

    # 4. autocable's analysis of every orbit.
    t0 = time.perf_counter()
    # The start point itself is dropped: AUTO reports it as handed in (its profile re-interpolated
    # to AUTO's mesh, not corrected), so it is not a collocation solution; its neighbours are.
    ordered = list(reversed(sides["backward"][1:])) + sides["forward"][1:]
    if not ordered:
        return failed("; ".join(f"{k}: {v}" for k, v in reasons.items()))
    rows = {k: [] for k in ("sigma", "a1", "a2", "qmin", "qmax", "T", "mu", "stable", "state", "closure")}
    auto_diff, auto_labels, skipped = [], [], 0
    for pt in ordered:
        lam, per = float(pt["lam"]), float(pt["_T"])
        sigma = start_sigma + span * lam
        Om = ode.omega1 + sigma
        for kind in pt.labels:
            if kind not in ("RG", "LC", "P"):
                auto_labels.append({"type": kind, "sigma": sigma})
        got = _profile(pt)
        if got is None:         # AUTO saves no profile at some of its own special points
            skipped += 1
            continue
        t, X = got
        t = t * per if t[-1] <= 1.0 + 1e-9 else t
        q = X[:, :4] * ascale
        ext = [polynomial_extremes(t, q[:, k], ncol) for k in (0, 1)]
        # The orbit at forcing phase 0 (x = sin 0, y = cos 0), read off the collocation polynomial:
        # AUTO's profile starts at whatever phase its phase condition chose.
        phase = math.atan2(X[0, 4], X[0, 5]) % (2 * math.pi)
        t_zero = ((2 * math.pi - phase) / Om) % per
        y_zero = polynomial_value(t, q, ncol, t_zero)
        try:
            M, yT = system.monodromy(U, eta, Om, y_zero, rtol=floquet_rtol)
            mu = multipliers_of(M)
            clos = float(np.linalg.norm(yT - y_zero) / max(np.linalg.norm(y_zero), 1e-300))
        except RuntimeError:
            mu, clos = np.full(4, np.nan + 0j), math.inf
        ev = _auto_multipliers(pt)
        if ev is not None and ev.size == 6 and np.all(np.isfinite(ev)):
            auto_diff.append(_matched_distance(_drop_trivial(ev, per), mu))
        else:
            auto_diff.append(math.nan)
        rows["sigma"].append(sigma)
        rows["qmin"].append([e[0] for e in ext])
        rows["qmax"].append([e[1] for e in ext])
        rows["a1"].append(0.5 * (ext[0][1] - ext[0][0]))
        rows["a2"].append(0.5 * (ext[1][1] - ext[1][0]))
        rows["T"].append(per)
        rows["mu"].append(mu)
        rows["stable"].append(bool(np.all(np.isfinite(mu)) and np.abs(mu[0]) < 1 - STABILITY_MARGIN))
        rows["state"].append(y_zero)
        rows["closure"].append(clos)
    timings["analysis_s"] = time.perf_counter() - t0
    values, a1, a2 = (np.array(rows[k], float) for k in ("sigma", "a1", "a2"))
    mults = np.array(rows["mu"], complex).reshape(len(values), 4)
    states = np.array(rows["state"], float).reshape(len(values), 4)
    special = _specials(values, a1, a2, list(mults), states)
    periods = np.array(rows["T"], float)
    n = len(values)
    info = {"timings": timings, "points": n, "build_seconds": timings.get("build_s", 0.0),
            "auto_seconds_per_point": timings["auto_s"] / max(len(sides["forward"]) + len(sides["backward"]), 1),
            "analysis_seconds_per_point": timings["analysis_s"] / n,
            "auto_multiplier_diff": np.array(auto_diff, float),
            "auto_labels": auto_labels, "skipped_without_profile": skipped,
            "period_max_rel_error": float(np.max(np.abs(periods * (ode.omega1 + values) / (2 * math.pi) - 1))),
            "closure_max": float(np.max(rows["closure"])), "ascale": ascale,
            "start": {"a1": resp.a1, "a2": resp.a2, "shooting_residual": shot.residual}}
    end = "; ".join(f"{k}: {v}" for k, v in reasons.items())
    return PeriodicBranch21("sigma", values, a1, a2, np.array(rows["stable"], bool), mults, periods,
                            special, end, time.perf_counter() - start_clock, settings,
                            np.array(rows["qmin"], float), np.array(rows["qmax"], float),
                            np.array(rows["state"], float), np.array(rows["closure"], float), info)
