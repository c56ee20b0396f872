"""The Multiple Scales reduction of Sect. 4: eq. (21) -> amplitude modulation equations (22)-(24).

The engine is generic: N coupled oscillators

    q_k'' + omega_k^2 q_k + sum_j c_j (eta f)^a_j (eta f')^b_j (eta f'')^d_j M_j(q, q') = 0,

f = sin(Omega t), with quadratic and cubic nonlinearities in displacements and velocities,
self-excitation (coefficients depending on U), external and parametric excitation, in 1:1 internal
resonance (all omega_k close) and 1:1 external resonance (Omega close to them). `from_two_mode_ode`
adapts eq. (21) (`TwoModeODE`) to it; `derive` returns an `AmplitudeEquations` (see ame.py for the
amplitude convention: a_k is the PEAK modal amplitude, A_k = (a_k/2) e^{i Phi_k}, r_k + i s_k = 2 A_k).

Scheme (Sect. 4). q_k = eps q_k1 + eps^2 q_k2 + eps^3 q_k3, time scales T0 = t, T1 = eps t,
T2 = eps^2 t, and the "computationally convenient" detunings omega_k = Omega + eps^2 sigma_k, so the
linear operator at every order is D0^2 + Omega^2 for every mode, q_k1 = A_k(T1, T2) e^{i Omega T0} + c.c.,
and the AME are autonomous. Harmonics e^{i n Omega T0} are a symbol E (E * conj(E) = 1): all algebra is
on Laurent polynomials in E, A_k, Abar_k, eta, Omega and the coefficients' symbols, with exact rational
(or float) complex coefficients; no trigonometric simplification.
  order 1: (D0^2 + Omega^2) q_k1 = 0.
  order 2: (D0^2 + Omega^2) q_k2 = -2 D0 D1 q_k1 - N2_k. N2_k holds only harmonics 0, +-2 (quadratic
           terms of natural order 2), so solvability gives dA_k/dT1 = 0 (checked); q_k2 is the
           particular solution (no homogeneous part).
  order 3: (D0^2 + Omega^2) q_k3 = -2 D0 D2 q_k1 - (omega_k^2 - Omega^2)/eps^2 q_k1 - N3_k; removing the
           e^{i Omega T0} terms gives D2 A_k. With eps = 1 ("reconstitution") dA_k/dt = D2 A_k: eq. (22).

Default ordering (`default_ordering`; a term's natural order is its degree in (q, q') plus its power
of eta, since q = O(eps) and eta = O(eps); a term put at order m > natural gets eps^(m - natural)):
  R0  linear stiffness omega_k^2 q_k: Omega^2 q_k at first order, the rest (omega_k^2 - Omega^2) q_k,
      of order eps^2 (detuning), appears at third order. It is not an entry of the table.
  R1  aerodynamic terms (origin "aerodynamic") of natural order <= 3: third order ("the aerodynamic
      terms ... are ordered so as to appear at the third order": linear x eps^2, quadratic x eps,
      cubic x 1, so zeta8/U q1'^3 saturates galloping). Quadratic ones then contribute nothing to the
      AME (even harmonics at third order): `effects` says so.
  R2  terms of natural order <= 1 (modal/structural damping and any other linear term in q, q' without
      eta; the resonant external forcing eta f, eta f', eta f'' with no state; constants): third order
      (damping O(eps^2); "resonant external ... excitation terms appear at the highest order").
  R3  every other term at its natural order (2 or 3); natural order > 3: dropped (also aerodynamic).
Override with `Ordering.override({label_or_index: 2 | 3 | None})`. Named orderings (`ordering_named`;
docs/model.md, U6):
  "paper"    R1-R3 above (the default);
  "natural"  without R1: aerodynamic terms follow R2-R3 like the others (linear ones third order,
             quadratic ones their natural second order, cubic ones third). A modelling choice a scene
             states (``ordering = "natural"``); see `ordering_named` for why it exists.

Omega. The forcing derivatives (f' = Omega cos, f'' = -Omega^2 sin) and D0 = i Omega bring powers of
Omega into the coefficients, and the solvability 1/(2 i Omega). With omega="exact" (default) these stay
a symbol Omega, to be evaluated at the exact Omega = omega_1 - sigma_1 = omega_1 + sigma, and the
stiffness is split exactly, omega_k^2 - Omega^2 = 2 Omega sigma_k + sigma_k^2 (so a linear forced
oscillator is reproduced exactly; eq. (25) of the paper also keeps Omega). With omega="expanded"
the paper's literal expansion is used: omega_k^2 = Omega^2 + 2 Omega sigma_k, and Omega -> omega_1 in
every coefficient (the classical textbook forms, e.g. the Duffing backbone omega_1 + 3 alpha a^2/(8 omega_1)).
Both agree to the order kept.

Checks (`AmplitudeEquations.checks`; `derive` raises `MultipleScalesError` if one fails):
  first_order_operator  no term at order 1 (the first-order problem is D0^2 + Omega^2 for every mode)
  dA_dT1_zero           the e^{+-i Omega T0} part of the second-order equations vanishes: dA/dT1 = 0
  q2_nonresonant        the particular solutions q_k2 contain no e^{+-i Omega T0} term
  q2_real               q_k2 equals its complex conjugate
  order3_real           the e^{-i Omega T0} part of N3_k is the conjugate of the e^{+i Omega T0} part
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from fractions import Fraction
from types import MappingProxyType
from typing import Sequence

import sympy as sp

from autocable.model.ame import (AmplitudeEquations, HarmonicRow, OrderEntry, Ordering, Row)
from autocable.model.equations import TwoModeODE

ORIGINS = ("linear", "damping", "structural", "inertia", "aerodynamic")
OMEGA_MODES = ("exact", "expanded")

# Names the engine gives a meaning of its own; user symbols may not take them.
_RESERVED_PREFIXES = ("sigma_", "A_", "Abar_", "r_", "s_", "a_", "Phi_")
_RESERVED = frozenset({"eta", "E", "W", "t", "sigma", "rho", "U", "Omega"})
#: Relative tolerance of the float-coefficient consistency checks (exact coefficients compare exactly).
CHECK_RTOL = 1e-11


class MultipleScalesError(ValueError):
    """The derivation is inconsistent (a check failed) or its input is not of the supported form."""


# -- input ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class OscillatorTerm:
    """coefficient * (eta f)^a (eta f')^b (eta f'')^d * prod q_j^q_j prod (q_j')^qdot_j, in equation k.

    `coefficient` is a number or a sympy Laurent polynomial in symbols (integer powers only): U,
    Omega (the forcing frequency) and user symbols; eta enters only through `forcing`."""

    equation: int                        # 1-based
    q: tuple[int, ...]
    qdot: tuple[int, ...]
    forcing: tuple[int, int, int] = (0, 0, 0)
    coefficient: object = 1
    origin: str = "structural"
    label: str = ""

    @property
    def degree(self) -> int:
        return sum(self.q) + sum(self.qdot)

    @property
    def natural_order(self) -> int:
        return self.degree + sum(self.forcing)

    def monomial(self) -> str:
        parts = [f"q{j + 1}" if e == 1 else f"q{j + 1}^{e}" for j, e in enumerate(self.q) if e]
        parts += [f"q{j + 1}dot" if e == 1 else f"q{j + 1}dot^{e}" for j, e in enumerate(self.qdot) if e]
        parts += [f"(eta*{nm})" if e == 1 else f"(eta*{nm})^{e}"
                  for nm, e in zip(("f", "fdot", "fddot"), self.forcing) if e]
        return "*".join(parts) or "1"


@dataclass(frozen=True)
class OscillatorSystem:
    """q_k'' + omega_k^2 q_k + sum(terms of equation k) = 0, k = 1..N (the stiffness is not a term).

    `omegas` are numbers or sympy Symbols."""

    omegas: tuple
    terms: tuple[OscillatorTerm, ...]
    name: str = ""

    def __post_init__(self):
        n = len(self.omegas)
        if n < 1:
            raise MultipleScalesError("an oscillator system needs at least one mode")
        for t in self.terms:
            if not 1 <= t.equation <= n:
                raise MultipleScalesError(f"term {t.monomial()}: equation {t.equation} not in 1..{n}")
            if len(t.q) != n or len(t.qdot) != n or len(t.forcing) != 3:
                raise MultipleScalesError(f"term {t.monomial()}: q and qdot need {n} exponents, forcing 3")
            if min(t.q + t.qdot + tuple(t.forcing)) < 0:
                raise MultipleScalesError(f"term {t.monomial()}: negative exponent")
            if t.origin not in ORIGINS:
                raise MultipleScalesError(f"term {t.monomial()}: origin {t.origin!r} not in {ORIGINS}")

    @property
    def n_modes(self) -> int:
        return len(self.omegas)

    def labels(self) -> tuple[str, ...]:
        return tuple(t.label or f"eq{t.equation}:{t.monomial()}" for t in self.terms)


def from_two_mode_ode(ode: TwoModeODE, *, rtol: float = 1e-9) -> OscillatorSystem:
    """Eq. (21) as an `OscillatorSystem`: the stiffness terms omega_k^2 q_k (origin "linear", q_k in
    equation k) become `omegas` (checked against ode.omega1, ode.omega2), every other term is kept
    with coefficient c * U**u_power."""
    U = sp.Symbol("U", real=True)
    omegas = (ode.omega1, ode.omega2)
    found = [False, False]
    terms = []
    for t in ode.terms:
        k = t.equation
        stiffness = (t.origin == "linear" and not any(t.forcing) and t.u_power == 0
                     and t.powers[:2] == tuple(1 if j == k - 1 else 0 for j in range(2)) and not any(t.powers[2:]))
        if stiffness:
            w2 = omegas[k - 1] ** 2
            if abs(t.coefficient - w2) > rtol * abs(w2):
                raise MultipleScalesError(f"{t.label}: stiffness {t.coefficient!r} is not omega{k}^2 = {w2!r}")
            if found[k - 1]:
                raise MultipleScalesError(f"equation {k} has two stiffness terms")
            found[k - 1] = True
            continue
        coefficient = sp.Float(t.coefficient) * U ** t.u_power if t.u_power else sp.Float(t.coefficient)
        terms.append(OscillatorTerm(equation=k, q=tuple(t.powers[:2]), qdot=tuple(t.powers[2:]),
                                    forcing=tuple(t.forcing), coefficient=coefficient, origin=t.origin,
                                    label=t.label))
    if not all(found):
        raise MultipleScalesError(f"missing stiffness term omega_k^2 q_k in equations "
                                  f"{[k + 1 for k in range(2) if not found[k]]}")
    return OscillatorSystem(omegas=omegas, terms=tuple(terms), name=ode.provenance.get("name", "eq. (21)"))


def _as_system(system) -> OscillatorSystem:
    if isinstance(system, TwoModeODE):
        return from_two_mode_ode(system)
    if isinstance(system, OscillatorSystem):
        return system
    raise TypeError(f"expected an OscillatorSystem or a TwoModeODE, got {type(system).__name__}")


# -- ordering ---------------------------------------------------------------------------------------
RULES = MappingProxyType({
    "R1": "aerodynamic: third order",
    "R1x": "aerodynamic of natural order > 3: dropped",
    "R2": "linear/damping/resonant forcing (natural order <= 1): third order",
    "R3": "natural order",
    "R3x": "natural order > 3: dropped",
})
#: The named orderings (`ordering_named`, a scene's ``ordering`` key): "paper" is R1-R3 (Sect. 4:
#: every aerodynamic term at third order); "natural" drops R1, so aerodynamic terms follow R2-R3
#: like every other term (the quadratic ones at their natural second order, where they feed the
#: third-order solvability through q_k2).
from autocable.model.orderings import ORDERINGS  # noqa: E402  (the light home of the names)


def ordering_named(system, name: str = "paper") -> Ordering:
    """The ordering called ``name`` (`ORDERINGS`) for ``system``.

    Why "natural" exists. Sect. 4 orders the aerodynamic terms "so as to appear at the third order";
    taken for the quadratic ones (eps x their natural eps^2) that leaves them only even harmonics at
    third order, so they never reach the AME (22). With the sample cable the twist-driven quadratic
    aerodynamic coefficients are not small, and on Fig. 4c's island II the paper's ordering is 4.3 %
    (2-dof) to 11.6 % (1-dof) off eq. (21) where the natural one is 0.4 % off
    (tests/test_ordering.py, docs/ordering.md)."""
    if name == "paper":
        return default_ordering(system)
    if name != "natural":
        raise ValueError(f"ordering must be one of {ORDERINGS}, got {name!r}")
    return _ordering(system, aerodynamic_third=False)


def default_ordering(system) -> Ordering:
    """The default term -> order table (rules R1-R3 of the module docstring), for an
    `OscillatorSystem` or a `TwoModeODE` (whose stiffness terms are not entries)."""
    return _ordering(system, aerodynamic_third=True)


def _ordering(system, *, aerodynamic_third: bool) -> Ordering:
    system = _as_system(system)
    entries = []
    for i, (t, label) in enumerate(zip(system.terms, system.labels())):
        n = t.natural_order
        if aerodynamic_third and t.origin == "aerodynamic":
            order, rule = (3, "R1") if n <= 3 else (None, "R1x")
        elif n <= 1:
            order, rule = 3, "R2"
        else:
            order, rule = (n, "R3") if n <= 3 else (None, "R3x")
        entries.append(OrderEntry(i, label, t.equation, t.origin, n, order, f"{rule}: {RULES[rule]}"))
    return Ordering(tuple(entries))


# -- Laurent polynomial algebra ---------------------------------------------------------------------
# A polynomial is {exponent tuple: (re, im)}, numbers Fraction or float. The generators are laid out
# by `_Layout`: E, A_1..A_N, Abar_1..Abar_N, the parameters, W (the "aerodynamic" marker).
def _cmul(a, b):
    return (a[0] * b[0] - a[1] * b[1], a[0] * b[1] + a[1] * b[0])


def _nonzero(c) -> bool:
    return c[0] != 0 or c[1] != 0


def _mul(p: dict, q: dict, keep_e: frozenset | None = None) -> dict:
    """p * q; with keep_e, only the products whose E exponent is in keep_e (the rest is not needed)."""
    out: dict = {}
    for ka, ca in p.items():
        ea = ka[0]
        for kb, cb in q.items():
            if keep_e is not None and ea + kb[0] not in keep_e:
                continue
            k = tuple([x + y for x, y in zip(ka, kb)])
            c = _cmul(ca, cb)
            if k in out:
                o = out[k]
                out[k] = (o[0] + c[0], o[1] + c[1])
            else:
                out[k] = c
    return {k: c for k, c in out.items() if _nonzero(c)}


def _add_into(acc: dict, p: dict, scale=(1, 0)) -> None:
    for k, c in p.items():
        c = _cmul(c, scale)
        if k in acc:
            o = acc[k]
            acc[k] = (o[0] + c[0], o[1] + c[1])
        else:
            acc[k] = c


def _clean(p: dict) -> dict:
    return {k: c for k, c in p.items() if _nonzero(c)}


def _harmonic(p: dict, n: int) -> dict:
    """The coefficient of E^n, as a polynomial with E exponent 0."""
    return {(0,) + k[1:]: c for k, c in p.items() if k[0] == n}


class _Layout:
    """Generator positions of one derivation (not shared between derivations)."""

    def __init__(self, n: int, user: Sequence[str]):
        self.n = n
        self.params = ("eta", "U") + tuple(f"sigma_{k}" for k in range(1, n + 1)) + ("Omega",) + tuple(user)
        self.size = 1 + 2 * n + len(self.params) + 1
        self.p0 = 1 + 2 * n
        self.W = self.size - 1

    def A(self, k):
        return 1 + k

    def B(self, k):
        return 1 + self.n + k

    def P(self, name):
        return self.p0 + self.params.index(name)

    def mono(self, pairs) -> tuple:
        e = [0] * self.size
        for i, v in pairs:
            e[i] += v
        return tuple(e)

    def conj(self, p: dict) -> dict:
        """Complex conjugate: A <-> Abar, E -> 1/E, i -> -i (parameters are real)."""
        out = {}
        n = self.n
        for k, c in p.items():
            e = list(k)
            e[0] = -e[0]
            e[1:1 + n], e[1 + n:1 + 2 * n] = k[1 + n:1 + 2 * n], k[1:1 + n]
            out[tuple(e)] = (c[0], -c[1])
        return out


_HALF = Fraction(1, 2)


def _to_number(x) -> object:
    if x.is_Rational:
        return Fraction(int(x.p), int(x.q))
    if x.is_Float:
        return float(x)
    if x.is_number and x.is_real:
        return float(x)
    raise MultipleScalesError(f"coefficient factor {x} is not a real number")


def _laurent(expr, where: str) -> list[tuple[object, dict[str, int]]]:
    """A coefficient as [(number, {symbol name: integer power})]."""
    if isinstance(expr, (int, Fraction)):
        return [(Fraction(expr), {})]
    if isinstance(expr, float):
        return [(expr, {})]
    expr = sp.expand(sp.sympify(expr))
    out = []
    for term in sp.Add.make_args(expr):
        if term == 0:
            continue
        c, factors = term.as_coeff_mul()
        num = _to_number(c)
        exps: dict[str, int] = {}
        for fac in factors:
            if fac.is_number:
                num = num * _to_number(fac)
                continue
            base, e = fac.as_base_exp()
            if not (base.is_Symbol and e.is_Integer):
                raise MultipleScalesError(
                    f"{where}: coefficient factor {fac} is not symbol**integer; coefficients must be "
                    "Laurent polynomials in symbols (replace other expressions by a symbol)")
            exps[base.name] = exps.get(base.name, 0) + int(e)
        out.append((num, exps))
    return out


def _check_user_name(name: str, where: str) -> None:
    if name in _RESERVED or any(name.startswith(p) for p in _RESERVED_PREFIXES):
        raise MultipleScalesError(f"{where}: symbol name {name!r} is reserved by the engine")


def _omega_spec(w, k):
    """A natural frequency as stored in the AME: a number, or a user symbol's name."""
    if isinstance(w, sp.Basic):
        if w.is_Symbol:
            _check_user_name(w.name, f"omega_{k}")
            return w.name
        if w.is_number:
            return _to_number(w)
        raise MultipleScalesError(f"omega_{k} must be a number or a symbol, got {w}")
    if isinstance(w, (int, Fraction)):
        return Fraction(w)
    return float(w)


# -- the derivation ---------------------------------------------------------------------------------
def derive(system, ordering: Ordering | str | None = None, *, omega: str = "exact") -> AmplitudeEquations:
    """The AME (22) (and from them (23), (24)) of `system` by Multiple Scales to third order (Sect. 4).

    `system` is an `OscillatorSystem` or a `TwoModeODE`; `ordering` is an `Ordering`, the name of
    one (`ORDERINGS`) or None (`default_ordering(system)`, "paper"); `omega` is "exact" or
    "expanded" (module docstring)."""
    t_start = time.perf_counter()
    if omega not in OMEGA_MODES:
        raise ValueError(f"omega must be one of {OMEGA_MODES}, got {omega!r}")
    source = system
    system = _as_system(system)
    if ordering is None:
        ordering = default_ordering(system)
    elif isinstance(ordering, str):
        ordering = ordering_named(system, ordering)
    ordering_name = next((nm for nm in ORDERINGS if ordering_named(system, nm).orders == ordering.orders), "custom")
    labels = system.labels()
    if len(ordering.entries) != len(system.terms) or tuple(e.label for e in ordering.entries) != labels:
        raise MultipleScalesError("the ordering was not made for this system (terms or labels differ)")
    n = system.n_modes

    # Coefficients -> Laurent rows; collect user symbols (and symbolic omegas) by name.
    coeff_rows = []
    user = set()
    for t, label in zip(system.terms, labels):
        rows = _laurent(t.coefficient, label)
        for _, exps in rows:
            for name in exps:
                if name in ("U", "Omega"):
                    continue
                if name == "eta":
                    raise MultipleScalesError(f"{label}: eta enters through `forcing`, not the coefficient")
                _check_user_name(name, label)
                user.add(name)
        coeff_rows.append(rows)
    omegas = tuple(_omega_spec(w, k + 1) for k, w in enumerate(system.omegas))
    user |= {w for w in omegas if isinstance(w, str)}
    L = _Layout(n, sorted(user))
    iE, iEta, iOm = 0, L.P("eta"), L.P("Omega")
    one = (Fraction(1), Fraction(0))

    # First-order solution and its velocity: q_k1 = A_k E + Abar_k / E, D0 q_k1 = i Omega (A_k E - Abar_k / E).
    x1 = []
    for k in range(n):
        x1.append({L.mono([(iE, 1), (L.A(k), 1)]): one, L.mono([(iE, -1), (L.B(k), 1)]): one})
    for k in range(n):
        x1.append({L.mono([(iE, 1), (L.A(k), 1), (iOm, 1)]): (Fraction(0), Fraction(1)),
                   L.mono([(iE, -1), (L.B(k), 1), (iOm, 1)]): (Fraction(0), Fraction(-1))})
    # eta f, eta f', eta f'' with f = sin(Omega T0) = (E - 1/E) / (2i).
    forcing_polys = (
        {L.mono([(iE, 1), (iEta, 1)]): (Fraction(0), -_HALF), L.mono([(iE, -1), (iEta, 1)]): (Fraction(0), _HALF)},
        {L.mono([(iE, 1), (iEta, 1), (iOm, 1)]): (_HALF, Fraction(0)),
         L.mono([(iE, -1), (iEta, 1), (iOm, 1)]): (_HALF, Fraction(0))},
        {L.mono([(iE, 1), (iEta, 1), (iOm, 2)]): (Fraction(0), _HALF),
         L.mono([(iE, -1), (iEta, 1), (iOm, 2)]): (Fraction(0), -_HALF)},
    )

    def base_poly(i: int) -> dict:
        """coefficient * forcing product (* W if aerodynamic) of term i."""
        t = system.terms[i]
        p = {}
        for num, exps in coeff_rows[i]:
            pairs = [(L.P(name), e) for name, e in exps.items()]
            if t.origin == "aerodynamic":
                pairs.append((L.W, 1))
            key = L.mono(pairs)
            c = (num, Fraction(0)) if isinstance(num, Fraction) else (num, 0.0)
            p[key] = (p[key][0] + c[0], p[key][1]) if key in p else c
        for fp, e in zip(forcing_polys, t.forcing):
            for _ in range(e):
                p = _mul(p, fp)
        return _clean(p)

    def state_exponents(t: OscillatorTerm) -> list[int]:
        return list(t.q) + list(t.qdot)

    orders = ordering.orders
    if any(o is not None and o < 2 for o in orders):
        bad = [e.label for e in ordering.entries if e.order is not None and e.order < 2]
        raise MultipleScalesError(f"terms at first order {bad}: the first-order problem must be "
                                  "D0^2 + Omega^2 for every mode (order them at 2 or 3)")
    for e in ordering.entries:
        if e.order is not None and e.order < e.natural_order:
            raise MultipleScalesError(f"{e.label}: order {e.order} below its natural order {e.natural_order}")
    checks: list[tuple[str, bool, str]] = [("first_order_operator", True, "no term at first order")]
    bases = {i: base_poly(i) for i, o in enumerate(orders) if o is not None}

    power_cache: dict = {}

    def x1_power(j: int, e: int) -> dict:
        if (j, e) not in power_cache:
            power_cache[(j, e)] = x1[j] if e == 1 else _mul(x1_power(j, e - 1), x1[j])
        return power_cache[(j, e)]

    def x1_product(exps: Sequence[int]) -> dict:
        p = {L.mono([]): one}
        for j, e in enumerate(exps):
            if e:
                p = _mul(p, x1_power(j, e))
        return p

    # ---- second order: N2_k, solvability, q_k2 --------------------------------------------------
    N2 = [dict() for _ in range(n)]
    for i, o in enumerate(orders):
        if o == 2:
            t = system.terms[i]
            _add_into(N2[t.equation - 1], _mul(bases[i], x1_product(state_exponents(t))))
    N2 = [_clean(p) for p in N2]
    secular2 = {k: _harmonic(N2[k], 1) for k in range(n)}
    if any(secular2.values()):
        bad = [k + 1 for k, p in secular2.items() if p]
        checks.append(("dA_dT1_zero", False, f"resonant terms at second order in equations {bad}"))
        raise MultipleScalesError(
            f"second-order solvability gives dA/dT1 != 0 in equations {bad}: a term of odd natural order "
            "was put at second order (see the ordering)")
    checks.append(("dA_dT1_zero", True, "e^{+-i Omega T0} terms absent at second order: dA_k/dT1 = 0"))

    q2 = []
    for k in range(n):
        p = {}
        for key, c in N2[k].items():
            h = key[0]
            # (D0^2 + Omega^2) X E^h = R E^h  ->  X = R / (Omega^2 (1 - h^2)); R = -N2.
            s = Fraction(-1, 1 - h * h)
            nk = list(key)
            nk[iOm] -= 2
            p[tuple(nk)] = (c[0] * s, c[1] * s)
        q2.append(p)
    resonant = [k + 1 for k in range(n) if _harmonic(q2[k], 1) or _harmonic(q2[k], -1)]
    checks.append(("q2_nonresonant", not resonant, "q_k2 has no e^{+-i Omega T0} term"))
    real_ok = all(_close(L.conj(q2[k]), q2[k]) for k in range(n))
    checks.append(("q2_real", real_ok, "q_k2 = conj(q_k2)"))
    # Velocities at second order: D0 q_k2 (D1 q_k1 = 0 by the solvability above).
    v2 = []
    for k in range(n):
        p = {}
        for key, c in q2[k].items():
            h = key[0]
            if h:
                nk = list(key)
                nk[iOm] += 1
                p[tuple(nk)] = _cmul(c, (Fraction(0), Fraction(h)))
        v2.append(p)
    x2 = q2 + v2

    # ---- third order: e^{+-i Omega T0} parts of N3_k -----------------------------------------------
    keep = frozenset((1, -1))
    N3 = [dict() for _ in range(n)]
    effects = []
    for i, o in enumerate(orders):
        t = system.terms[i]
        if o is None:
            effects.append("dropped")
            continue
        exps = state_exponents(t)
        if o == 3:
            contrib = _mul(bases[i], x1_product(exps), keep)
        else:
            # eps^3 part of a second-order term: one factor at second order, the others at first.
            part = {}
            for j, e in enumerate(exps):
                if not e or not x2[j]:
                    continue
                rest = list(exps)
                rest[j] -= 1
                _add_into(part, _mul(x1_product(rest), x2[j]), (Fraction(e), Fraction(0)))
            contrib = _mul(bases[i], _clean(part), keep) if part else {}
        contrib = _clean(contrib)
        _add_into(N3[t.equation - 1], contrib)
        direct = bool(_harmonic(contrib, 1))
        if o == 2:
            effects.append("order 2: via q2" + (" and directly at order 3" if direct else ""))
        else:
            effects.append("order 3: direct" if direct else "order 3: no resonant part (no effect on the AME)")
    N3 = [_clean(p) for p in N3]
    real3 = all(_close(L.conj(_harmonic(N3[k], 1)), _harmonic(N3[k], -1)) for k in range(n))
    checks.append(("order3_real", real3, "e^{-i Omega T0} part of N3 = conj(e^{+i Omega T0} part)"))

    # ---- solvability at third order: D2 A_k = i (detune_k A_k + C_k) / (2 Omega) ----------------------
    F = []
    half_i = (Fraction(0), _HALF)
    for k in range(n):
        acc = dict(_harmonic(N3[k], 1))
        sk = L.P(f"sigma_{k + 1}")
        _add_into(acc, {L.mono([(L.A(k), 1), (iOm, 1), (sk, 1)]): (Fraction(2), Fraction(0))})
        if omega == "exact":
            _add_into(acc, {L.mono([(L.A(k), 1), (sk, 2)]): one})
        acc = _mul(_clean(acc), {L.mono([(iOm, -1)]): half_i})
        F.append(acc)

    if omega == "expanded":
        F = [_substitute_omega(p, iOm, omegas[0], L) for p in F]
        q2 = [_substitute_omega(p, iOm, omegas[0], L) for p in q2]

    failed = [name for name, ok, _ in checks if not ok]
    if failed:
        raise MultipleScalesError(f"Multiple Scales consistency checks failed: {failed}")

    complex_rows = _rows_from(F, L)
    second = []
    for k in range(n):
        merged: dict = {}
        for key, c in q2[k].items():
            rk = (key[0], key[1:1 + 2 * n], key[L.p0:L.W], key[L.W] > 0)
            merged[rk] = _cadd(merged[rk], c) if rk in merged else c
        second += [HarmonicRow(k, h, s, pr, c, a) for (h, s, pr, a), c in merged.items() if _nonzero(c)]
    second.sort(key=lambda r: (r.mode, r.harmonic, r.state, r.params, r.aero))

    provenance = {"engine": "autocable.model.multiscale", "orders": 3, "omega": omega, "ordering": ordering_name,
                  "system": system.name, "n_terms": len(system.terms),
                  "derivation_seconds": round(time.perf_counter() - t_start, 4)}
    if isinstance(source, TwoModeODE):
        provenance["ode_hash"] = source.content_hash()
    return AmplitudeEquations(n_modes=n, param_names=L.params, omegas=omegas, omega_mode=omega,
                              complex_rows=complex_rows, second_order_rows=tuple(second), ordering=ordering,
                              effects=tuple(effects), check_items=tuple(checks),
                              modes=tuple(range(1, n + 1)), provenance=provenance)


def _cadd(a, b):
    return (a[0] + b[0], a[1] + b[1])


def _rows_from(F: Sequence[dict], L: _Layout) -> tuple[Row, ...]:
    n = L.n
    out = []
    for k, p in enumerate(F):
        merged: dict = {}
        for key, c in p.items():
            if key[0] != 0:
                raise MultipleScalesError("internal: the AME contains a harmonic E (not autonomous)")
            rk = (key[1:1 + 2 * n], key[L.p0:L.W], key[L.W] > 0)
            merged[rk] = _cadd(merged[rk], c) if rk in merged else c
        out += [Row(k, s, pr, c, a) for (s, pr, a), c in merged.items() if _nonzero(c)]
    out.sort(key=lambda r: (r.equation, r.state, r.params, r.aero))
    return tuple(out)


def _substitute_omega(p: dict, iOm: int, omega_ref, L: _Layout) -> dict:
    """Omega -> omega_ref (a number, or a user symbol's name) in every coefficient."""
    out: dict = {}
    for key, c in p.items():
        e = key[iOm]
        nk = list(key)
        nk[iOm] = 0
        if e:
            if isinstance(omega_ref, str):
                nk[L.P(omega_ref)] += e
            else:
                f = omega_ref ** e
                c = (c[0] * f, c[1] * f)
        nk = tuple(nk)
        out[nk] = _cadd(out[nk], c) if nk in out else c
    return _clean(out)


def _close(p: dict, q: dict) -> bool:
    """p == q, exactly for exact coefficients, to CHECK_RTOL of the largest coefficient for floats."""
    keys = set(p) | set(q)
    if not keys:
        return True
    zero = (0, 0)
    scale = max(abs(complex(float(c[0]), float(c[1]))) for c in list(p.values()) + list(q.values()))
    for k in keys:
        a, b = p.get(k, zero), q.get(k, zero)
        d = complex(float(a[0] - b[0]), float(a[1] - b[1]))
        exact = all(isinstance(x, (Fraction, int)) for x in (a[0], a[1], b[0], b[1]))
        if exact and d != 0:
            return False
        if abs(d) > CHECK_RTOL * scale:
            return False
    return True
