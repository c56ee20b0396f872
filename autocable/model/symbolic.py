"""Eq. (21) as sympy expressions: the first-order system that integrators and code generators use.

State (q1, q2, v1, v2) with v_k = q_k'; parameters U, eta, Omega, and two switches derived from U
that make "no wind" exact: ``wind`` (1 if U != 0 else 0) multiplies every aerodynamic term and
``Uinv`` (1/U, or 0 at U = 0) carries the 1/U powers, so that U = 0 is defined (Figs. 5-6) rather
than singular. `parameter_values` computes them consistently; nothing else should set them.
"""
from __future__ import annotations

import sympy as sp

from autocable.model.equations import TwoModeODE

T = sp.Symbol("t", real=True)
Q1, Q2, V1, V2 = sp.symbols("q1 q2 v1 v2", real=True)
U, ETA, OMEGA, WIND, UINV = sp.symbols("U eta Omega wind Uinv", real=True)
STATE = (Q1, Q2, V1, V2)
PARAMETERS = (U, ETA, OMEGA, WIND, UINV)


def plain_symbols(expr) -> sp.Expr:
    """``expr`` with every symbol that carries assumptions (eq. (21)'s are real) replaced by the
    plain ``Symbol`` of its name: the generated code and the numeric functions know names only.
    ``expr`` itself when it has none (read back from a cache): sympy's xreplace would rebuild the
    whole tree even for a mapping of each symbol to itself (0.1 s for the wind AME)."""
    expr = sp.sympify(expr)
    swap = {s: sp.Symbol(s.name) for s in expr.free_symbols if s != sp.Symbol(s.name)}
    return expr.xreplace(swap) if swap else expr


def parameter_values(U_star: float, eta: float, Omega: float) -> dict[str, float]:
    """Values of every parameter of `first_order_rhs` for wind U*, support amplitude eta*, Omega."""
    wind = 0.0 if U_star == 0.0 else 1.0
    return {"U": float(U_star), "eta": float(eta), "Omega": float(Omega), "wind": wind,
            "Uinv": 0.0 if U_star == 0.0 else 1.0 / U_star}


def first_order_rhs(ode: TwoModeODE) -> tuple[sp.Expr, sp.Expr, sp.Expr, sp.Expr]:
    """(q1', q2', v1', v2') of eq. (21) with f = sin(Omega t) (Sect. 4); with the exact quasi-steady
    load in place of the cubic aerodynamic terms when ``ode.exact_load`` is set (the "exact" rung,
    `autocable.model.exact_load`). Polynomial in the state for the cubic rung, so that code
    generators may expand it; not for the exact one."""
    f = sp.sin(OMEGA * T)
    forcing = (ETA * f, ETA * OMEGA * sp.cos(OMEGA * T), -ETA * OMEGA**2 * f)
    acc = [sp.Integer(0), sp.Integer(0)]
    exact = getattr(ode, "exact_load", None)
    for term in ode.terms:
        if exact is not None and term.origin == "aerodynamic":
            continue
        m = sp.Float(term.coefficient, 17)
        for x, p in zip(STATE, term.powers):
            m *= x**p
        for x, p in zip(forcing, term.forcing):
            m *= x**p
        if term.origin == "aerodynamic":
            m *= WIND * (U**term.u_power if term.u_power >= 0 else UINV ** (-term.u_power))
        elif term.u_power:
            m *= U**term.u_power
        acc[term.equation - 1] -= m
    if exact is None:
        return (V1, V2, sp.expand(acc[0]), sp.expand(acc[1]))
    # The exact load (`autocable.model.exact_load`) is added unexpanded: expanding its quadrature
    # sum of sqrt/atan2 products would multiply its size many times over for nothing.
    from autocable.model.exact_load import force_exprs
    F1, F2 = force_exprs(exact, Q2, V1, V2, U, forcing[1])
    return (V1, V2, sp.expand(acc[0]) + WIND * F1, sp.expand(acc[1]) + WIND * F2)
