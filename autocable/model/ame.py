"""The amplitude modulation equations (AME), eqs. (22)-(24) of Luongo & Zulli, Sect. 4, as plain data.

`AmplitudeEquations` is what `autocable.model.multiscale.derive` returns and what the rest of the
pipeline reads: coefficient tables (tuples of rows, numbers only), from which it builds sympy
expressions, a numeric Cartesian right-hand side with its Jacobian, and the reconstruction of q_k(t).
It holds no derivation machinery, so a cached AME loads from JSON without running the engine.

Amplitude convention (docs/model.md, C1; used everywhere in autocable)
    q_k = A_k e^{i Omega t} + c.c. + (second-order terms),   A_k = (a_k / 2) e^{i Phi_k},
    r_k + i s_k = a_k e^{i Phi_k} = 2 A_k,                    a_k = sqrt(r_k^2 + s_k^2),
so a_k is the *peak* modal amplitude and, to first order, q_k = a_k cos(Omega t + Phi_k)
= r_k cos(Omega t) - s_k sin(Omega t). (The paper's own Sect. 4 writes A_k = a_k e^{i Phi_k}; its
eq. (25) and Sect. 5 plot the peak, which is the a_k used here.)

Forms of the AME
    complex  (22): dA_k/dt = F_k(A, Abar; params)                   rows: `complex_rows`
    polar    (23): da_k/dt = p_k,  a_k dPhi_k/dt = p_{N+k}          rows: `polar_rows`
    Cartesian(24): d(r_k, s_k)/dt = (g_{2k-1}, g_{2k})              rows: `cartesian_rows`
    (p_k + i p_{N+k} = 2 e^{-i Phi_k} F_k;  g_{2k-1} + i g_{2k} = 2 F_k.)

Parameters: `param_names` = (eta, U, sigma_1, ..., sigma_N, Omega, user symbols...). The detunings
are those of Sect. 4, omega_k = Omega + sigma_k (eps reabsorbed), hence the paper's
sigma = -sigma_1 (external) and rho = sigma_2 - sigma_1 (internal), and Omega = omega_1 - sigma_1
= omega_1 + sigma. `control` builds a consistent parameter vector from (eta, U, sigma).

Aerodynamic rows carry `aero=True`: they exist only when U != 0 (no wind, no term; their 1/U powers
are not singular at U = 0, they are absent). The numeric right-hand side drops them at U = 0; the
sympy builders take `include_aero`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from fractions import Fraction
from functools import cached_property
from typing import Mapping, NamedTuple, Sequence

import numpy as np
import sympy as sp

#: Format tag written by `AmplitudeEquations.to_dict`.
FORMAT = "autocable.ame/1"


# -- rows -------------------------------------------------------------------------------------------
class Row(NamedTuple):
    """One monomial of a polynomial vector field.

    `coefficient` is an exact `Fraction` or a float; in complex tables it is a pair (re, im).
    `state` and `params` are exponents over the table's state and parameter names (parameter
    exponents may be negative: 1/U, 1/Omega)."""

    equation: int
    state: tuple[int, ...]
    params: tuple[int, ...]
    coefficient: object
    aero: bool


class HarmonicRow(NamedTuple):
    """One monomial of the second-order displacement q_k2 = sum coeff * A^m Abar^n * params * E^harmonic,
    E = e^{i Omega t}; `mode` is 0-based."""

    mode: int
    harmonic: int
    state: tuple[int, ...]
    params: tuple[int, ...]
    coefficient: tuple
    aero: bool


class PolarRow(NamedTuple):
    """One term coeff * prod a_j^amplitudes_j * trig(sum phase_j Phi_j) * params of eq. (23)."""

    equation: int
    amplitudes: tuple[int, ...]
    phase: tuple[int, ...]
    trig: str                      # "cos" or "sin"
    params: tuple[int, ...]
    coefficient: object
    aero: bool


# -- the ordering (data; the rule that fills it lives in multiscale.py) -----------------------------
@dataclass(frozen=True)
class OrderEntry:
    """The Multiple Scales order at which one term of the equations of motion first appears.

    `natural_order` = degree in (q, q') + power of eta (q = O(eps), eta = O(eps)); `order` is where
    the term is put (its coefficient is scaled by eps**(order - natural_order)), None if dropped."""

    index: int
    label: str
    equation: int
    origin: str
    natural_order: int
    order: int | None
    rule: str


@dataclass(frozen=True)
class Ordering:
    """A frozen table term -> order. Build it with `multiscale.default_ordering`, change it with
    `override`; `derive` takes it as given."""

    entries: tuple[OrderEntry, ...]

    @property
    def orders(self) -> tuple[int | None, ...]:
        return tuple(e.order for e in self.entries)

    def as_dict(self) -> dict[str, int | None]:
        return {e.label: e.order for e in self.entries}

    def _index(self, key) -> int:
        if isinstance(key, int):
            if not 0 <= key < len(self.entries):
                raise KeyError(f"no term with index {key} (there are {len(self.entries)})")
            return key
        hits = [e.index for e in self.entries if e.label == key]
        if not hits:
            raise KeyError(f"no term labelled {key!r}")
        if len(hits) > 1:
            raise KeyError(f"label {key!r} is ambiguous (terms {hits}): override by index")
        return hits[0]

    def override(self, changes: Mapping[int | str, int | None], rule: str = "override") -> "Ordering":
        """A new ordering with some terms moved: keys are term indices or labels, values 2, 3 or None.

        An order below the natural one would need a coefficient of negative eps power (the term
        could not appear at that order), hence it is refused; order 1 is refused because the
        first-order problem must be the resonant linear operator D0^2 + Omega^2 of every mode."""
        entries = list(self.entries)
        for key, order in changes.items():
            i = self._index(key)
            e = entries[i]
            if order is not None:
                if order not in (2, 3):
                    raise ValueError(f"{e.label}: order must be 2, 3 or None (dropped), got {order!r}")
                if order < e.natural_order:
                    raise ValueError(f"{e.label}: natural order {e.natural_order} cannot be put at "
                                     f"order {order} (it starts at eps^{e.natural_order})")
            entries[i] = OrderEntry(e.index, e.label, e.equation, e.origin, e.natural_order, order, rule)
        return Ordering(tuple(entries))

    def table(self) -> str:
        """The ordering as readable text, one term per line."""
        lines = [f"{'#':>3} {'term':<28} {'origin':<12} {'nat':>3} {'order':>5}  rule"]
        for e in self.entries:
            o = "-" if e.order is None else str(e.order)
            lines.append(f"{e.index:>3} {e.label:<28} {e.origin:<12} {e.natural_order:>3} {o:>5}  {e.rule}")
        return "\n".join(lines)

    def to_dict(self) -> list[dict]:
        return [dict(index=e.index, label=e.label, equation=e.equation, origin=e.origin,
                     natural_order=e.natural_order, order=e.order, rule=e.rule) for e in self.entries]

    @classmethod
    def from_dict(cls, data: Sequence[Mapping]) -> "Ordering":
        return cls(tuple(OrderEntry(int(d["index"]), d["label"], int(d["equation"]), d["origin"],
                                    int(d["natural_order"]),
                                    None if d["order"] is None else int(d["order"]), d["rule"])
                         for d in data))


# -- numbers ----------------------------------------------------------------------------------------
def _enc(x):
    """JSON-safe number: exact fractions as 'p/q' strings, floats as floats (repr round-trips)."""
    if isinstance(x, Fraction):
        return str(x)
    return float(x)


def _dec(x):
    if isinstance(x, str):
        return Fraction(x)
    if isinstance(x, int):
        return Fraction(x)
    return float(x)


def _sym_num(x) -> sp.Expr:
    if isinstance(x, Fraction):
        return sp.Rational(x.numerator, x.denominator)
    if isinstance(x, int):
        return sp.Integer(x)
    return sp.Float(x)


def _sym_complex(c) -> sp.Expr:
    return _sym_num(c[0]) + sp.I * _sym_num(c[1])


def _is_zero(x) -> bool:
    if isinstance(x, tuple):
        return x[0] == 0 and x[1] == 0
    return x == 0


def _cmul(a, b):
    return (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])


def _merge(rows, key, value, add):
    """Sum values of rows that share a key; drop exact zeros."""
    acc: dict = {}
    for r in rows:
        k = key(r)
        v = value(r)
        acc[k] = add(acc[k], v) if k in acc else v
    return [(k, v) for k, v in acc.items() if not _is_zero(v)]


def _cadd(a, b):
    return (a[0] + b[0], a[1] + b[1])


# -- conversions between the three forms ------------------------------------------------------------
def _binomial_expansion(n_modes: int, mode: int, power: int, sign: int) -> dict:
    """((r + sign*i*s)/2)^power for one mode, as {exponents over (r1, s1, ..., rN, sN): (re, im)}."""
    out = {}
    unit = [(Fraction(1), Fraction(0)), (Fraction(0), Fraction(sign)),
            (Fraction(-1), Fraction(0)), (Fraction(0), Fraction(-sign))]
    scale = Fraction(1, 2 ** power)
    for l in range(power + 1):
        e = [0] * (2 * n_modes)
        e[2 * mode] = power - l
        e[2 * mode + 1] = l
        u = unit[l % 4]
        b = math.comb(power, l) * scale
        out[tuple(e)] = (u[0] * b, u[1] * b)
    return out


def _poly_mul(p: dict, q: dict) -> dict:
    out: dict = {}
    for ka, ca in p.items():
        for kb, cb in q.items():
            k = tuple(x + y for x, y in zip(ka, kb))
            c = _cmul(ca, cb)
            out[k] = _cadd(out[k], c) if k in out else c
    return out


def complex_to_cartesian(n_modes: int, rows: Sequence[Row]) -> tuple[Row, ...]:
    """Eq. (24) from eq. (22): g_{2k-1} + i g_{2k} = 2 F_k at A_j = (r_j + i s_j)/2."""
    cache: dict = {}

    def expansion(mode, power, sign):
        key = (mode, power, sign)
        if key not in cache:
            cache[key] = _binomial_expansion(n_modes, mode, power, sign)
        return cache[key]

    out = []
    for r in rows:
        poly = {tuple([0] * (2 * n_modes)): (2 * r.coefficient[0], 2 * r.coefficient[1])}
        for j in range(n_modes):
            m, n = r.state[j], r.state[n_modes + j]
            if m:
                poly = _poly_mul(poly, expansion(j, m, +1))
            if n:
                poly = _poly_mul(poly, expansion(j, n, -1))
        for e, c in poly.items():
            out.append(Row(2 * r.equation, e, r.params, c[0], r.aero))
            out.append(Row(2 * r.equation + 1, e, r.params, c[1], r.aero))
    merged = _merge(out, key=lambda r: (r.equation, r.state, r.params, r.aero),
                    value=lambda r: r.coefficient, add=lambda a, b: a + b)
    return tuple(sorted((Row(k[0], k[1], k[2], v, k[3]) for k, v in merged), key=_row_sort_key))


def complex_to_polar(n_modes: int, rows: Sequence[Row]) -> tuple[PolarRow, ...]:
    """Eq. (23) from eq. (22): p_k + i p_{N+k} = 2 e^{-i Phi_k} F_k at A_j = (a_j/2) e^{i Phi_j}."""
    out = []
    for r in rows:
        m, n = r.state[:n_modes], r.state[n_modes:]
        degree = sum(m) + sum(n)
        scale = Fraction(2, 2 ** degree)
        wr, wi = (c * scale if isinstance(c, Fraction) else c * float(scale) for c in r.coefficient)
        phase = [mj - nj for mj, nj in zip(m, n)]
        phase[r.equation] -= 1
        first = next((x for x in phase if x), 0)
        flip = -1 if first < 0 else 1
        phase = tuple(flip * x for x in phase)
        amps = tuple(mj + nj for mj, nj in zip(m, n))
        # Re(w e^{i theta}) = wr cos - wi sin; Im = wr sin + wi cos; sin(-theta) = -sin(theta).
        terms = [(r.equation, "cos", wr), (r.equation, "sin", -wi * flip),
                 (n_modes + r.equation, "sin", wr * flip), (n_modes + r.equation, "cos", wi)]
        for eq, trig, c in terms:
            if trig == "sin" and not any(phase):
                continue
            out.append(PolarRow(eq, amps, phase, trig, r.params, c, r.aero))
    merged = _merge(out, key=lambda r: (r.equation, r.amplitudes, r.phase, r.trig, r.params, r.aero),
                    value=lambda r: r.coefficient, add=lambda a, b: a + b)
    return tuple(sorted((PolarRow(k[0], k[1], k[2], k[3], k[4], v, k[5]) for k, v in merged),
                        key=lambda r: (r.equation, r.amplitudes, r.phase, r.trig, r.params, r.aero)))


def _row_sort_key(r):
    return (r.equation, r.state, r.params, r.aero)


# -- numeric right-hand side ------------------------------------------------------------------------
def _param_monomials(p: np.ndarray, exponents: np.ndarray, aero: np.ndarray, iU: int) -> np.ndarray:
    with np.errstate(divide="ignore", invalid="ignore"):
        pm = np.prod(p[None, :] ** exponents, axis=1)
    if p[iU] == 0.0:
        # No wind, no aerodynamic term (their 1/U powers are absent, not infinite).
        pm = np.where(aero, 0.0, pm)
    return pm


@dataclass(frozen=True, eq=False)
class CartesianRHS:
    """The Cartesian AME (24) as numpy: `f(y, p)` and `jacobian(y, p)`.

    y = (r_1, s_1, ..., r_N, s_N); p = (eta, U, sigma_1, ..., sigma_N, Omega) in `param_names` order
    (use `AmplitudeEquations.control` to build it). User symbols were bound at construction."""

    state_names: tuple[str, ...]
    param_names: tuple[str, ...]
    equation: np.ndarray
    state_exponents: np.ndarray
    param_exponents: np.ndarray
    coefficients: np.ndarray
    aero: np.ndarray

    def _weights(self, p) -> np.ndarray:
        p = np.asarray(p, dtype=float)
        if p.shape != (len(self.param_names),):
            raise ValueError(f"p must have {len(self.param_names)} entries {self.param_names}, got shape {p.shape}")
        return self.coefficients * _param_monomials(p, self.param_exponents, self.aero, 1)

    def __call__(self, y, p) -> np.ndarray:
        return self.f(y, p)

    def f(self, y, p) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        w = self._weights(p) * np.prod(y[None, :] ** self.state_exponents, axis=1)
        return np.bincount(self.equation, weights=w, minlength=len(self.state_names))

    def jacobian(self, y, p) -> np.ndarray:
        y = np.asarray(y, dtype=float)
        n = len(self.state_names)
        w = self._weights(p)
        J = np.zeros((n, n))
        for j in range(n):
            e = self.state_exponents[:, j]
            lowered = self.state_exponents.copy()
            lowered[:, j] = np.maximum(e - 1, 0)
            d = w * e * np.prod(y[None, :] ** lowered, axis=1)
            J[:, j] = np.bincount(self.equation, weights=d, minlength=n)
        return J


# -- the result -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class AmplitudeEquations:
    """The AME (22)-(24) of an N-mode system in 1:1 internal and external resonance (Sect. 4).

    `complex_rows` are F_k of eq. (22) over the state (A_1..A_N, Abar_1..Abar_N); `second_order_rows`
    give q_k2 for the reconstruction of q_k(t); `ordering` is the term -> order table the derivation
    used, `effects` says per term what it did (see `multiscale.derive`), `check_items` the consistency
    checks of the derivation. `omegas` are the natural frequencies (numbers, or user-symbol names).
    `omega_mode` is "exact" (coefficients are Laurent polynomials in Omega, to be evaluated at the exact
    Omega = omega_1 - sigma_1) or "expanded" (Omega replaced by omega_1 in every coefficient)."""

    n_modes: int
    param_names: tuple[str, ...]
    omegas: tuple
    omega_mode: str
    complex_rows: tuple[Row, ...]
    second_order_rows: tuple[HarmonicRow, ...]
    ordering: Ordering
    effects: tuple[str, ...]
    check_items: tuple[tuple[str, bool, str], ...]
    modes: tuple[int, ...]
    provenance: dict = field(default_factory=dict, compare=False, hash=False)

    # -- names -------------------------------------------------------------------------------------
    @property
    def control_names(self) -> tuple[str, ...]:
        """The free parameters of the numeric functions: (eta, U, sigma_1..N, Omega)."""
        return self.param_names[: 3 + self.n_modes]

    @property
    def user_names(self) -> tuple[str, ...]:
        return self.param_names[3 + self.n_modes:]

    @property
    def complex_state_names(self) -> tuple[str, ...]:
        n = self.n_modes
        return tuple(f"A_{k}" for k in range(1, n + 1)) + tuple(f"Abar_{k}" for k in range(1, n + 1))

    @property
    def cartesian_state_names(self) -> tuple[str, ...]:
        return tuple(x for k in range(1, self.n_modes + 1) for x in (f"r_{k}", f"s_{k}"))

    @property
    def polar_state_names(self) -> tuple[str, ...]:
        n = self.n_modes
        return tuple(f"a_{k}" for k in range(1, n + 1)) + tuple(f"Phi_{k}" for k in range(1, n + 1))

    @property
    def checks(self) -> dict[str, bool]:
        """The consistency checks the derivation performed (all True, or `derive` would have raised)."""
        return {name: ok for name, ok, _ in self.check_items}

    # -- derived tables ----------------------------------------------------------------------------
    @cached_property
    def cartesian_rows(self) -> tuple[Row, ...]:
        """Eq. (24): rows over (r_1, s_1, ..., r_N, s_N), equations g_1..g_2N, real coefficients."""
        return complex_to_cartesian(self.n_modes, self.complex_rows)

    @cached_property
    def polar_rows(self) -> tuple[PolarRow, ...]:
        """Eq. (23): equations 0..N-1 are da_k/dt, N..2N-1 are a_k dPhi_k/dt."""
        return complex_to_polar(self.n_modes, self.complex_rows)

    # -- sympy -------------------------------------------------------------------------------------
    def symbols(self) -> dict[str, sp.Symbol]:
        """Every symbol used by the sympy forms, by name. Parameters, amplitudes and phases are real;
        A_k, Abar_k are independent complex symbols (Abar_k standing for conj(A_k))."""
        names = {}
        for nm in self.param_names:
            names[nm] = sp.Symbol(nm, real=True)
        for nm in self.complex_state_names:
            names[nm] = sp.Symbol(nm)
        for nm in self.cartesian_state_names + self.polar_state_names:
            names[nm] = sp.Symbol(nm, real=True)
        for nm in ("sigma", "rho", "t"):
            names[nm] = sp.Symbol(nm, real=True)
        return names

    def _param_factor(self, exps, syms) -> sp.Expr:
        out = sp.Integer(1)
        for nm, e in zip(self.param_names, exps):
            if e:
                out *= syms[nm] ** e
        return out

    def complex_expressions(self, include_aero: bool = True) -> tuple[sp.Expr, ...]:
        """F_1..F_N of eq. (22) in A_k, Abar_k and the parameters."""
        syms = self.symbols()
        state = [syms[n] for n in self.complex_state_names]
        out = [sp.Integer(0)] * self.n_modes
        for r in self.complex_rows:
            if r.aero and not include_aero:
                continue
            mono = sp.Mul(*[s ** e for s, e in zip(state, r.state) if e])
            out[r.equation] += _sym_complex(r.coefficient) * mono * self._param_factor(r.params, syms)
        return tuple(out)

    def cartesian_expressions(self, include_aero: bool = True) -> tuple[sp.Expr, ...]:
        """g_1..g_2N of eq. (24), d/dt of (r_1, s_1, ..., r_N, s_N)."""
        syms = self.symbols()
        state = [syms[n] for n in self.cartesian_state_names]
        out = [sp.Integer(0)] * (2 * self.n_modes)
        for r in self.cartesian_rows:
            if r.aero and not include_aero:
                continue
            mono = sp.Mul(*[s ** e for s, e in zip(state, r.state) if e])
            out[r.equation] += _sym_num(r.coefficient) * mono * self._param_factor(r.params, syms)
        return tuple(out)

    def polar_expressions(self, include_aero: bool = True) -> tuple[sp.Expr, ...]:
        """p_1..p_2N of eq. (23): da_k/dt = p_k, a_k dPhi_k/dt = p_{N+k}."""
        syms = self.symbols()
        n = self.n_modes
        amps = [syms[f"a_{k}"] for k in range(1, n + 1)]
        phis = [syms[f"Phi_{k}"] for k in range(1, n + 1)]
        out = [sp.Integer(0)] * (2 * n)
        for r in self.polar_rows:
            if r.aero and not include_aero:
                continue
            angle = sum((c * ph for c, ph in zip(r.phase, phis)), sp.Integer(0))
            trig = sp.cos(angle) if r.trig == "cos" else sp.sin(angle)
            mono = sp.Mul(*[a ** e for a, e in zip(amps, r.amplitudes) if e])
            out[r.equation] += _sym_num(r.coefficient) * mono * trig * self._param_factor(r.params, syms)
        return tuple(out)

    def detuning_relations(self) -> dict[sp.Symbol, sp.Expr]:
        """Sect. 4: sigma_1 = -sigma, sigma_2 = rho - sigma (rho = sigma_2 - sigma_1),
        Omega = omega_1 + sigma (exact). Use with `.subs` on the sympy forms."""
        syms = self.symbols()
        rel = {syms["sigma_1"]: -syms["sigma"], syms["Omega"]: self._omega_sym(0) + syms["sigma"]}
        if self.n_modes >= 2:
            rel[syms["sigma_2"]] = syms["rho"] - syms["sigma"]
        for k in range(3, self.n_modes + 1):
            rel[syms[f"sigma_{k}"]] = self._omega_sym(k - 1) - self._omega_sym(0) - syms["sigma"]
        return rel

    def _omega_sym(self, k: int) -> sp.Expr:
        w = self.omegas[k]
        return sp.Symbol(w, real=True) if isinstance(w, str) else _sym_num(w)

    # -- numerics ----------------------------------------------------------------------------------
    def _omega_value(self, k: int, values: Mapping[str, float] | None) -> float:
        w = self.omegas[k]
        if isinstance(w, str):
            if not values or w not in values:
                raise KeyError(f"omega_{k + 1} is the symbol {w!r}: give its value in `values`")
            return float(values[w])
        return float(w)

    def control(self, eta: float = 0.0, U: float = 0.0, sigma: float = 0.0, *, rho: float | None = None,
                values: Mapping[str, float] | None = None) -> np.ndarray:
        """The parameter vector (eta, U, sigma_1..N, Omega) for the paper's controls (Sect. 4;
        docs/model.md, C2): Omega = omega_1 + sigma, sigma_k = omega_k - Omega; `rho` (N = 2 only)
        overrides the internal detuning sigma_2 - sigma_1 given by the frequencies."""
        om = [self._omega_value(k, values) for k in range(self.n_modes)]
        Omega = om[0] + sigma
        sig = [w - Omega for w in om]
        if rho is not None:
            if self.n_modes != 2:
                raise ValueError("rho is the internal detuning of a 2-mode AME")
            sig[1] = sig[0] + rho
        return np.array([eta, U, *sig, Omega], dtype=float)

    def _bind(self, exps, coeffs, values):
        """Fold user-symbol values into the coefficients; return (control exponents, coefficients)."""
        nc = len(self.control_names)
        exps = np.asarray(exps, dtype=int).reshape(len(coeffs), len(self.param_names))
        coeffs = np.asarray(coeffs)
        if self.user_names:
            missing = [n for n in self.user_names if not values or n not in values]
            if missing:
                raise KeyError(f"give values for the user symbols {missing}")
            uv = np.array([float(values[n]) for n in self.user_names])
            coeffs = coeffs * np.prod(uv[None, :] ** exps[:, nc:], axis=1)
        return exps[:, :nc], coeffs

    def cartesian_rhs(self, values: Mapping[str, float] | None = None) -> CartesianRHS:
        """The numeric Cartesian AME (24), with user symbols bound to `values`."""
        rows = self.cartesian_rows
        n = 2 * self.n_modes
        coeffs = np.array([float(r.coefficient) for r in rows], dtype=float)
        pexp, coeffs = self._bind([r.params for r in rows], coeffs, values)
        return CartesianRHS(
            state_names=self.cartesian_state_names,
            param_names=self.control_names,
            equation=np.array([r.equation for r in rows], dtype=int),
            state_exponents=np.array([r.state for r in rows], dtype=int).reshape(len(rows), n),
            param_exponents=pexp,
            coefficients=coeffs,
            aero=np.array([r.aero for r in rows], dtype=bool))

    def complex_rhs(self, A, p, values: Mapping[str, float] | None = None) -> np.ndarray:
        """F_k of eq. (22) evaluated at complex amplitudes A (length N): a slow reference evaluation."""
        A = np.asarray(A, dtype=complex)
        state = np.concatenate([A, np.conj(A)])
        rows = self.complex_rows
        coeffs = np.array([complex(float(r.coefficient[0]), float(r.coefficient[1])) for r in rows])
        pexp, coeffs = self._bind([r.params for r in rows], coeffs, values)
        pm = _param_monomials(np.asarray(p, float), pexp, np.array([r.aero for r in rows]), 1)
        out = np.zeros(self.n_modes, dtype=complex)
        for r, c, m in zip(rows, coeffs, pm):
            out[r.equation] += c * m * np.prod(state ** np.array(r.state))
        return out

    def amplitudes(self, y) -> np.ndarray:
        """Peak modal amplitudes a_k = sqrt(r_k^2 + s_k^2) of Cartesian states y (..., 2N)."""
        y = np.asarray(y, dtype=float)
        return np.hypot(y[..., 0::2], y[..., 1::2])

    def reconstruct(self, y, t, p, *, order: int = 2, values: Mapping[str, float] | None = None):
        """q_k(t) and q_k'(t) from the Cartesian AME state: first order q_k = a_k cos(Omega t + Phi_k)
        = r_k cos(Omega t) - s_k sin(Omega t); with order=2 also q_k2 (and D0 q_k2 in q_k').

        y is one state (2N,) or a trajectory (len(t), 2N); returns two arrays of shape (N, len(t))."""
        if order not in (1, 2):
            raise ValueError("order must be 1 or 2")
        t = np.atleast_1d(np.asarray(t, dtype=float))
        y = np.asarray(y, dtype=float)
        Y = np.broadcast_to(y, (len(t), 2 * self.n_modes)) if y.ndim == 1 else y
        p = np.asarray(p, dtype=float)
        Omega = p[len(self.control_names) - 1]
        E = np.exp(1j * Omega * t)
        A = (Y[:, 0::2] + 1j * Y[:, 1::2]) / 2.0          # (len(t), N)
        q = np.real(2.0 * A.T * E[None, :])
        qd = np.real(2.0j * Omega * A.T * E[None, :])
        if order == 2 and self.second_order_rows:
            rows = self.second_order_rows
            coeffs = np.array([complex(float(r.coefficient[0]), float(r.coefficient[1])) for r in rows])
            pexp, coeffs = self._bind([r.params for r in rows], coeffs, values)
            pm = _param_monomials(p, pexp, np.array([r.aero for r in rows]), 1)
            state = np.concatenate([A, np.conj(A)], axis=1)
            for r, c, m in zip(rows, coeffs, pm):
                if m == 0.0 or c == 0.0:
                    continue
                term = c * m * np.prod(state ** np.array(r.state)[None, :], axis=1) * E ** r.harmonic
                q[r.mode] += np.real(term)
                qd[r.mode] += np.real(1j * r.harmonic * Omega * term)
        return q, qd

    # -- reductions --------------------------------------------------------------------------------
    def reduced(self, keep: Sequence[int]) -> "AmplitudeEquations":
        """The AME restricted to the modes `keep` (1-based, of this object), the others set to zero
        (A_j = 0) and their equations dropped. `reduced((1,))` is the 1-dof model of Sect. 5."""
        keep = tuple(sorted(set(int(k) for k in keep)))
        n = self.n_modes
        if not keep or keep[0] < 1 or keep[-1] > n:
            raise ValueError(f"keep must name modes among 1..{n}")
        idx = [k - 1 for k in keep]
        dropped = [j for j in range(n) if j not in idx]
        new_index = {j: i for i, j in enumerate(idx)}

        def state_ok(state):
            return all(state[j] == 0 and state[n + j] == 0 for j in dropped)

        def new_state(state):
            return tuple(state[j] for j in idx) + tuple(state[n + j] for j in idx)

        # Parameters sigma_j of dropped modes must not appear in what is kept.
        keep_params = [i for i, nm in enumerate(self.param_names)
                       if not (nm.startswith("sigma_") and int(nm[6:]) - 1 in dropped)]
        names = tuple(self.param_names[i] for i in keep_params)
        names = tuple(("sigma_" + str(new_index[int(nm[6:]) - 1] + 1)) if nm.startswith("sigma_") else nm
                      for nm in names)

        def new_params(params):
            for i, e in enumerate(params):
                if e and i not in keep_params:
                    raise ValueError(f"{self.param_names[i]} appears in a kept equation")
            return tuple(params[i] for i in keep_params)

        rows = tuple(Row(new_index[r.equation], new_state(r.state), new_params(r.params), r.coefficient, r.aero)
                     for r in self.complex_rows if r.equation in new_index and state_ok(r.state))
        second = tuple(HarmonicRow(new_index[r.mode], r.harmonic, new_state(r.state), new_params(r.params),
                                   r.coefficient, r.aero)
                       for r in self.second_order_rows if r.mode in new_index and state_ok(r.state))
        prov = dict(self.provenance)
        prov["reduction"] = (f"modes {tuple(self.modes[j] for j in idx)} kept, the others set to zero "
                             "(A_j = 0) and their equations dropped (Sect. 5, last paragraph)")
        return AmplitudeEquations(n_modes=len(idx), param_names=names,
                                  omegas=tuple(self.omegas[j] for j in idx), omega_mode=self.omega_mode,
                                  complex_rows=rows, second_order_rows=second, ordering=self.ordering,
                                  effects=self.effects, check_items=self.check_items,
                                  modes=tuple(self.modes[j] for j in idx), provenance=prov)

    def one_dof(self) -> "AmplitudeEquations":
        """The 1-dof reduction of Sect. 5: A_2 = 0 (all modes but the first), first equation only."""
        return self.reduced((1,))

    # -- persistence -------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        """Plain JSON-able data; `from_dict` restores an equal object without sympy work."""
        return {
            "format": FORMAT,
            "n_modes": self.n_modes,
            "param_names": list(self.param_names),
            "omegas": [{"symbol": w} if isinstance(w, str) else _enc(w) for w in self.omegas],
            "omega_mode": self.omega_mode,
            "complex_rows": [[r.equation, list(r.state), list(r.params),
                              [_enc(r.coefficient[0]), _enc(r.coefficient[1])], r.aero]
                             for r in self.complex_rows],
            "second_order_rows": [[r.mode, r.harmonic, list(r.state), list(r.params),
                                   [_enc(r.coefficient[0]), _enc(r.coefficient[1])], r.aero]
                                  for r in self.second_order_rows],
            "ordering": self.ordering.to_dict(),
            "effects": list(self.effects),
            "checks": [[n, ok, msg] for n, ok, msg in self.check_items],
            "modes": list(self.modes),
            "provenance": dict(self.provenance),
        }

    @classmethod
    def from_dict(cls, data: Mapping) -> "AmplitudeEquations":
        if data.get("format") != FORMAT:
            raise ValueError(f"not an AME dictionary of format {FORMAT!r} (got {data.get('format')!r})")

        def omega(w):
            return w["symbol"] if isinstance(w, dict) else _dec(w)

        return cls(
            n_modes=int(data["n_modes"]),
            param_names=tuple(data["param_names"]),
            omegas=tuple(omega(w) for w in data["omegas"]),
            omega_mode=data["omega_mode"],
            complex_rows=tuple(Row(int(e), tuple(s), tuple(p), (_dec(c[0]), _dec(c[1])), bool(a))
                               for e, s, p, c, a in data["complex_rows"]),
            second_order_rows=tuple(HarmonicRow(int(m), int(h), tuple(s), tuple(p), (_dec(c[0]), _dec(c[1])),
                                                bool(a))
                                    for m, h, s, p, c, a in data["second_order_rows"]),
            ordering=Ordering.from_dict(data["ordering"]),
            effects=tuple(data["effects"]),
            check_items=tuple((n, bool(ok), msg) for n, ok, msg in data["checks"]),
            modes=tuple(int(m) for m in data["modes"]),
            provenance=dict(data.get("provenance", {})))

    def describe(self) -> str:
        """A readable summary: sizes, checks, and the ordering with each term's effect."""
        lines = [f"AME (eqs. 22-24): {self.n_modes} mode(s) {self.modes}, Omega {self.omega_mode}, "
                 f"{len(self.complex_rows)} complex rows, {len(self.cartesian_rows)} Cartesian rows",
                 "checks: " + ", ".join(f"{n}={'ok' if ok else 'FAILED'}" for n, ok, _ in self.check_items)]
        for e, eff in zip(self.ordering.entries, self.effects):
            o = "-" if e.order is None else e.order
            lines.append(f"  {e.label:<28} order {o}  ({e.rule}) -> {eff}")
        return "\n".join(lines)

