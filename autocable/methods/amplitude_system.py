"""The one-mode amplitude equation of the galloping problem (Fig. 3) as a continuation system.

At eta = 0 the amplitude equations have a rotational symmetry: galloping oscillates at its own
frequency, so in the Cartesian form (24), written in the frame of the (absent) forcing, it is a
circle in (r1, s1), not an equilibrium. The polar form (23) of the A2 = 0 reduction separates:
da1/dt = p1(a1; U) does not involve the phase, and its equilibria are the galloping amplitudes of
eq. (25) (in the form of docs/model.md, M5). This module gives that one equation as a `System` in the scene
parameters (sigma, U, eta), for `ame = "1dof-amplitude"` scenes; it is only defined at eta = 0.
With sigma = 0 the coefficients are evaluated at Omega = omega1.
"""
from __future__ import annotations

import sympy as sp

from autocable.methods.continuation import System


def galloping_amplitude_system(ame, *, name: str | None = None) -> System:
    """da1/dt = p1(a1; U, sigma) of eq. (23) for A2 = 0 and eta = 0 (module docstring)."""
    one = ame.one_dof()
    syms = one.symbols()
    sigma, U = sp.Symbol("sigma"), sp.Symbol("U")
    omega1 = sp.Float(float(one.omegas[0]), 17)
    p1 = one.polar_expressions()[0].subs({syms["eta"]: 0, syms["Omega"]: omega1 + sigma,
                                           syms["sigma_1"]: -sigma})
    a1 = sp.Symbol("a1")
    p1 = sp.expand(p1.subs({syms["a_1"]: a1, syms["U"]: U}))
    if syms["Phi_1"] in p1.free_symbols:
        raise ValueError("the one-mode amplitude equation depends on the phase: it is defined at eta = 0 only")
    extra = {s.name for s in p1.free_symbols} - {"a1", "sigma", "U"}
    if extra:
        raise ValueError(f"unbound symbols {sorted(extra)} in the amplitude equation")
    return System(name=name or "galloping_amplitude", variables=("a1",), rhs=(p1,),
                  parameters=(("sigma", 0.0), ("U", 1.0), ("eta", 0.0)),
                  amplitudes=(("a1", ("a1",)), ("a2", ())),
                  description="eq. (23), A2 = 0, eta = 0: the galloping amplitude equation (Fig. 3)",
                  amplitude_equations=True)
