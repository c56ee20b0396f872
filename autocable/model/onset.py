"""Where the trivial state of eq. (21) loses stability under wind, how, and how hard it gallops.

At eta = 0 the trivial state q = 0 of eq. (21) is an equilibrium for every wind speed; its stability
is that of the 4x4 first-order linear system in (q1, q2, q1', q2') with every linear term: the
structural stiffness and damping and the aerodynamic terms (velocity terms ~ U, the twist's
aerodynamic stiffness ~ U^2: `TwoModeODE.linear_matrix`), both modes and their cross couplings. A
loss of stability is a zero crossing, upwards, of the spectral abscissa max Re lambda(U*), located by
Brent's method to 1e-12 in U* from a scan.

At a crossing by a complex pair (a Hopf point) the criticality comes from the first Lyapunov
coefficient (`autocable.model.hopf`, Kuznetsov's formula) of eq. (21)'s own vector field at that U*,
with its quadratic and cubic terms (the 1/U velocity terms evaluated at the fixed U*): super-critical
(l1 < 0) is a small stable galloping cycle growing like sqrt(U - U_cr); sub-critical (l1 > 0) an
unstable cycle below U_cr, hence large-amplitude galloping below the onset (hysteresis). The
post-critical slopes d(a_k^2)/dU* follow from the normal form (`HopfPoint.amplitude_slopes`).

The one-mode reduction eq. (25) (q'' + (2 xi_s omega1 + zeta11 U) q' + omega1^2 q + (zeta8/U) q'^3 = 0,
docs/model.md M5) predicts in-plane galloping iff zeta11 < 0, at U* = -2 xi_s omega1 / zeta11, and a
super-critical one iff zeta8 > 0; `one_mode_warnings` says where this disagrees with eq. (21).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace

import numpy as np
from scipy.optimize import brentq

from autocable.model.equations import TwoModeODE
from autocable.model.hopf import HopfPoint, first_lyapunov

#: The largest U* scanned by default: `autocable.model.premises.PARAMETER_RANGES`' bound on U*.
U_MAX_DEFAULT = 5.0
#: In-plane share of the critical eigenvector (|q1|^2 / (|q1|^2 + |q2|^2)) above which an onset is
#: called in-plane, below 1 minus which out-of-plane; between, coupled.
MONO_MODAL_SHARE = 0.9


def with_damping(ode: TwoModeODE, xi: float) -> TwoModeODE:
    """Eq. (21) with the modal damping ratio ``xi`` (terms 2 xi omega_k q_k', Sect. 3) and every other
    term unchanged: the wind angles stay as derived (fitted or given)."""
    omegas = (ode.omega1, ode.omega2)
    terms = tuple(replace(t, coefficient=2 * xi * omegas[t.equation - 1]) if t.origin == "damping" else t
                  for t in ode.terms)
    return replace(ode, terms=terms, xi_s=float(xi))


def matrix_derivative(ode: TwoModeODE, U: float) -> np.ndarray:
    """d A / d U* of `TwoModeODE.linear_matrix`, term by term (coefficient u U^(u-1))."""
    dA = np.zeros((4, 4))
    for t in ode.terms:
        if t.eta_power or sum(t.powers) != 1 or t.origin != "aerodynamic" or t.u_power == 0:
            continue
        j = t.powers.index(1)
        dA[1 + t.equation, j] -= t.coefficient * t.u_power * U ** (t.u_power - 1)
    return dA


class _Forms:
    """The quadratic and cubic parts of eq. (21)'s first-order vector field at eta = 0 and fixed U*, as
    the symmetric multilinear forms B, C (second and third derivatives at the trivial state)."""

    def __init__(self, ode: TwoModeODE, U: float):
        self.quad, self.cubic = [], []
        for t in ode.terms:
            d = sum(t.powers)
            if t.eta_power or d < 2:
                continue
            c = -t.factor(U, 0.0, 0.0, 0.0, 0.0)    # accelerations are minus the left-hand side
            if c == 0.0:
                continue
            if d > 3:
                raise ValueError(f"a term of degree {d} in eq. (21): the Hopf formula takes up to cubic")
            idx = tuple(i for i, p in enumerate(t.powers) for _ in range(p))
            (self.quad if d == 2 else self.cubic).append((1 + t.equation, idx, c))

    def B(self, u, v):
        out = np.zeros(4, dtype=complex)
        for row, (a, b), c in self.quad:
            out[row] += c * (u[a] * v[b] + u[b] * v[a])
        return out

    def C(self, u, v, w):
        out = np.zeros(4, dtype=complex)
        for row, (a, b, d), c in self.cubic:
            out[row] += c * (u[a] * v[b] * w[d] + u[a] * v[d] * w[b] + u[b] * v[a] * w[d]
                             + u[b] * v[d] * w[a] + u[d] * v[a] * w[b] + u[d] * v[b] * w[a])
        return out


def hopf_point(ode: TwoModeODE, U: float) -> HopfPoint:
    """Kuznetsov's first Lyapunov coefficient of eq. (21) at the trivial state, eta = 0, wind U*."""
    forms = _Forms(ode, U)
    return first_lyapunov(ode.linear_matrix(U), forms.B, forms.C)


@dataclass(frozen=True)
class Onset:
    """One loss of stability of the trivial state (nondimensional: eq. 17-18 units; SI in `to_dict`)."""

    U_star: float
    frequency: float             # Im lambda at the crossing (units of omega); 0 for a real crossing
    growth_slope: float          # d Re lambda / d U* (> 0: the pair crosses into the right half plane)
    eigenvector: tuple           # (q1, q2, q1', q2') complex, |.| = 1
    in_plane_share: float
    phase_deg: float             # arg(q2 / q1): the out-of-plane motion's lead (nan if one share is < 1e-12)
    mechanism: str
    couplings: tuple             # (name, size) of the linear cross terms, largest first
    lyapunov: float | None       # l1 (|q| = 1), None at a real crossing
    criticality: str             # "supercritical", "subcritical" or "static (not a Hopf point)"
    amplitude_slopes: tuple      # d(a1^2)/dU*, d(a2^2)/dU* from the normal form (None: real crossing)

    def to_dict(self, units) -> dict:
        """The onset in SI (units: `autocable.model.units.Units`) and nondimensional."""
        q = self.eigenvector
        slopes = self.amplitude_slopes
        si = None if slopes is None else [units.peak_squared_slope(s) for s in slopes]
        return {
            "U_m_s": units.wind_m_s(self.U_star), "U_star": self.U_star,
            "frequency_Hz": units.frequency_hz(self.frequency), "frequency_star": self.frequency,
            "mechanism": self.mechanism, "criticality": self.criticality, "lyapunov": self.lyapunov,
            "lyapunov_normalisation": "|q| = 1 over (q1, q2, q1', q2'); only its sign is invariant",
            "growth_slope_per_U_star": self.growth_slope,
            "amplitude_slope": None if slopes is None else {
                "d_a_squared_dU_star": list(slopes), "d_peak_squared_dU_m2_per_m_s": si,
                "order": "[in-plane a1, out-of-plane a2]; a_k = peak displacement / l at mid-span; "
                         "negative: the cycle lies below U_cr (sub-critical)"},
            "eigenvector": {
                "in_plane_share": self.in_plane_share, "out_of_plane_share": 1 - self.in_plane_share,
                "phase_deg": self.phase_deg,
                "q1": [q[0].real, q[0].imag], "q2": [q[1].real, q[1].imag],
                "shares": "|q1|^2 / (|q1|^2 + |q2|^2) and its complement; phase = arg(q2/q1)"},
            "couplings": [{"term": n, "size": s} for n, s in self.couplings],
        }


def _couplings(ode: TwoModeODE, U: float, q) -> tuple:
    """The linear cross terms (q2, q2' in the in-plane equation, q1, q1' in the out-of-plane one), each
    with its size |coefficient U^u q_j| at the critical eigenvector, largest first."""
    out = []
    for t in ode.terms:
        if t.eta_power or sum(t.powers) != 1:
            continue
        j = t.powers.index(1)
        if (j % 2) == (t.equation - 1):     # a mode's own displacement or velocity
            continue
        size = abs(t.factor(U, 0.0, 0.0, 0.0, 0.0) * q[j])
        if size > 0:
            out.append((t.label, float(size)))
    return tuple(sorted(out, key=lambda x: -x[1]))


def _mechanism(share: float, couplings) -> str:
    if share >= MONO_MODAL_SHARE:
        return "in-plane galloping"
    if share <= 1 - MONO_MODAL_SHARE:
        return "out-of-plane instability"
    names = ", ".join(n for n, _ in couplings[:3])
    twist = any(n in ("k21", "h14") for n, _ in couplings[:3])
    how = "the twist's aerodynamic stiffness and the linear cross terms" if twist else "the linear cross terms"
    return f"coupled in-plane/out-of-plane galloping, through {how} ({names})"


def onset_at(ode: TwoModeODE, U: float) -> Onset:
    """Describe the crossing at U* (the spectral abscissa is zero there)."""
    A = ode.linear_matrix(U)
    lam, V = np.linalg.eig(A)
    i = int(np.argmax(lam.real - 1e-9 * (lam.imag < 0)))    # of a pair, the one with Im > 0
    if abs(lam[i].imag) < 1e-9:
        q = V[:, i] / np.linalg.norm(V[:, i])
        mu, W = np.linalg.eig(A.T)
        w = W[:, int(np.argmin(np.abs(mu - lam[i])))]
        slope = float((w @ matrix_derivative(ode, U) @ q).real / (w @ q).real)
        hp, crit, l1, slopes, freq = None, "static (not a Hopf point)", None, None, 0.0
    else:
        hp = hopf_point(ode, U)
        q = hp.q
        slope = hp.growth_slope(matrix_derivative(ode, U))
        l1, freq = hp.l1, hp.omega
        crit = "supercritical" if l1 < 0 else "subcritical"
        slopes = tuple(float(s) for s in hp.amplitude_slopes(slope)[:2])
    n1, n2 = abs(q[0]) ** 2, abs(q[1]) ** 2
    share = float(n1 / (n1 + n2))
    # a phase between a mode and a vanishing one is round-off
    phase = math.degrees(np.angle(q[1] / q[0])) if min(n1, n2) > 1e-12 * (n1 + n2) else float("nan")
    couplings = _couplings(ode, U, q)
    return Onset(U_star=float(U), frequency=float(freq), growth_slope=slope,
                 eigenvector=tuple(complex(x) for x in q), in_plane_share=share, phase_deg=float(phase),
                 mechanism=_mechanism(share, couplings), couplings=couplings, lyapunov=l1,
                 criticality=crit, amplitude_slopes=slopes)


@dataclass(frozen=True)
class Stability:
    """Every crossing of the trivial state's spectral abscissa over (0, U_max]."""

    onsets: tuple                 # `Onset`s where stability is lost (upward crossings)
    restabilisations: tuple = ()  # U* where the spectral abscissa falls back below zero
    U_max: float = U_MAX_DEFAULT
    stable_at_start: bool = True
    notes: tuple = field(default=())

    @property
    def first(self) -> Onset | None:
        return self.onsets[0] if self.onsets else None


class LinearPencil:
    """The trivial state's matrix as a polynomial in U*, A(U) = sum_u U^u M_u (`linear_matrix` term by
    term: the aerodynamic linear terms carry U or U^2 and vanish at U = 0), evaluated for a whole
    grid of U at once: the scans of damping studies cost one batched eigenvalue call."""

    def __init__(self, ode: TwoModeODE):
        self.mats: dict[int, np.ndarray] = {}
        for t in ode.terms:
            if t.eta_power or sum(t.powers) != 1:
                continue
            if t.origin == "aerodynamic" and t.u_power <= 0:
                raise ValueError(f"a linear wind term {t.label} with U^{t.u_power}: not a polynomial in U")
            M = self.mats.setdefault(t.u_power, np.zeros((4, 4)))
            M[1 + t.equation, t.powers.index(1)] -= t.coefficient
        M0 = self.mats.setdefault(0, np.zeros((4, 4)))
        M0[0, 2] = M0[1, 3] = 1.0

    def matrices(self, U) -> np.ndarray:
        U = np.atleast_1d(np.asarray(U, dtype=float))
        return sum(U[:, None, None] ** u * M for u, M in self.mats.items())

    def abscissa(self, U) -> np.ndarray:
        """max Re lambda at each U of the array ``U``."""
        return np.max(np.linalg.eigvals(self.matrices(U)).real, axis=-1)


def crossings(ode: TwoModeODE, U_max: float = U_MAX_DEFAULT, n: int = 1001, xtol: float = 1e-12,
              first_only: bool = False) -> tuple[list[float], list[float], bool]:
    """(upward crossings, downward crossings, stable at the first grid point) of the spectral
    abscissa over (0, U_max], from a scan of ``n`` points refined by Brent's method to ``xtol``."""
    pencil = LinearPencil(ode)
    grid = np.linspace(0.0, U_max, n)
    g = pencil.abscissa(grid)
    ups, downs = [], []
    for a, b, ga, gb in zip(grid[:-1], grid[1:], g[:-1], g[1:]):
        if ga < 0 <= gb or ga >= 0 > gb:
            r = b if gb == 0 else brentq(lambda U: float(pencil.abscissa(U)[0]), a, b, xtol=xtol,
                                         rtol=4 * np.finfo(float).eps, maxiter=200)
            (ups if ga < 0 else downs).append(float(r))
            if first_only and ups:
                break
    return ups, downs, bool(g[0] < 0)


def stability(ode: TwoModeODE, U_max: float = U_MAX_DEFAULT, n: int = 1001) -> Stability:
    """Every loss of stability of the trivial state of eq. (21) at eta = 0 over U* in (0, U_max]."""
    ups, downs, stable = crossings(ode, U_max, n)
    notes = () if stable else ("the trivial state is unstable already without wind",)
    return Stability(onsets=tuple(onset_at(ode, U) for U in ups), restabilisations=tuple(downs),
                     U_max=U_max, stable_at_start=stable, notes=notes)


def first_onset_U(ode: TwoModeODE, U_max: float = U_MAX_DEFAULT, n: int = 401) -> float:
    """U* of the first loss of stability (inf if none up to U_max): the cheap call of damping studies."""
    ups, _, _ = crossings(ode, U_max, n, first_only=True)
    return ups[0] if ups else math.inf


# -- the one-mode reduction, eq. (25) ----------------------------------------------------------------
def one_mode(ode: TwoModeODE) -> dict:
    """zeta11, zeta8 and what eq. (25) alone predicts (module docstring)."""
    z11 = sum(t.coefficient for t in ode.find(1, (0, 0, 1, 0), u_power=1) if t.origin == "aerodynamic")
    z8 = sum(t.coefficient for t in ode.find(1, (0, 0, 3, 0), u_power=-1) if t.origin == "aerodynamic")
    U1 = -2 * ode.xi_s * ode.omega1 / z11 if z11 < 0 else math.inf
    return {"zeta11": z11, "zeta8": z8, "onset_U_star": U1,
            "criticality": "supercritical" if z8 > 0 else "subcritical"}


def one_mode_warnings(ode: TwoModeODE, result: Stability, units) -> list[str]:
    """Where the onset needs a word: sub-critical, coupled, or the one-mode coefficients misleading."""
    out = []
    om = one_mode(ode)
    first = result.first
    if first is None:
        if math.isfinite(om["onset_U_star"]) and om["onset_U_star"] <= result.U_max:
            out.append(f"zeta11 = {om['zeta11']:.4g} < 0: the in-plane mode alone (eq. 25) would gallop at "
                       f"U = {units.wind_m_s(om['onset_U_star']):.4g} m/s, but eq. (21) with both modes stays "
                       f"stable up to {units.wind_m_s(result.U_max):.4g} m/s")
        return out
    U = units.wind_m_s(first.U_star)
    if first.criticality == "subcritical":
        out.append(f"the onset at U = {U:.4g} m/s is sub-critical: an unstable cycle lies below it, so "
                   "large-amplitude galloping can start below the onset from a large enough disturbance "
                   "(hysteresis); the onset speed is not a safe bound")
    if first.mechanism.startswith("coupled"):
        out.append(f"the onset at U = {U:.4g} m/s is coupled (in-plane share "
                   f"{100 * first.in_plane_share:.0f} %): the one-mode eq. (25) does not describe it")
    if first.in_plane_share > 0.5 and om["zeta11"] >= 0:
        out.append(f"zeta11 = {om['zeta11']:.4g} >= 0 says the in-plane mode alone is aerodynamically damped "
                   f"(eq. 25: no galloping), yet eq. (21) loses stability at U = {U:.4g} m/s through "
                   f"{first.mechanism}")
    if first.lyapunov is not None and first.in_plane_share > 0.5 and om["criticality"] != first.criticality:
        out.append(f"zeta8 = {om['zeta8']:.4g} makes eq. (25)'s galloping {om['criticality']}, but the "
                   f"onset of eq. (21) (first Lyapunov coefficient, every coupling) is {first.criticality}")
    return out
