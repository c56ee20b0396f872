"""The AME (24) as a polynomial in its state: F(X) = C(p) Phi(X), the coefficients C(p) once per
parameter point and the monomials Phi from a table of powers (`Monomials`). The equilibrium search
evaluates F and its Jacobian at many states at once this way (`autocable.methods.continuation.search`),
and the first Lyapunov coefficient's second and third derivative tensors come from the monomials
differentiated exactly (`System.hessian`, `System.third`). It takes any object with ``template``,
``dimension``, ``variables``, ``parameter_names`` and ``parameter_vector`` (a `System`) and
imports nothing of the continuation engines, which use it."""
from __future__ import annotations

import itertools

import numpy as np

__all__ = ["Monomials"]


class Monomials:
    """f and its Jacobian at many states at once for a right-hand side that is a polynomial in the
    state (the Cartesian AME (24) is cubic in (r_k, s_k): 35 monomials for two modes), as
    F(X) = C(p) Phi(X): the coefficients C once per parameter point, the monomials Phi from a table
    of powers. The same numbers as `System.f_many` / `jac_many` (lambdify's text, which spends a
    numpy operation per term and state column: 180 terms per row for the natural ordering) up to
    the order of the sums (checked to 1e-12 in tests/test_search_monomials.py), several times
    faster on the 1088 starts of the search; the second and third derivative tensors of F at one
    state (`hessian`, `third`). `of` returns None for a field that is not polynomial in the state.
    """

    def __init__(self, system):
        from autocable.methods.lambda_cache import numeric_function
        # The coefficients' expressions are generated for the field's structure, with its numbers
        # as extra parameters (the weights): one generated function serves every model of one
        # structure (each candidate model of the calibration paid 1-1.6 s here).
        t = system.template
        self._w = t.weights
        self._g = numeric_function("poly", system.variables, system.parameter_names, t.rhs, key=t.key,
                                   constants=t.weight_names)
        self.n = system.dimension
        self._p = None
        self._C = None
        with np.errstate(all="ignore"):    # the default parameters may sit at U = 0 (1/U terms)
            got = self._g(np.zeros(self.n), np.concatenate([system.parameter_vector(), self._w]))
        self.E = np.array(got[1], dtype=int).reshape(-1, self.n)
        self._deg = int(self.E.max(initial=0))
        # d/dx_j of x^E: E_j x^(E - e_j), the exponent kept at 0 where E_j = 0 (the factor E_j is 0)
        self._dE = [np.where(np.arange(self.n) == j, np.maximum(self.E - 1, 0), self.E) for j in range(self.n)]

    @classmethod
    def of(cls, system) -> "Monomials | None":
        """The system's `Monomials` (kept on it for the process), or None when its field is not a
        polynomial in the state."""
        got = system.__dict__.get("_search_monomials")
        if got is None:
            import sympy as sp
            try:
                got = cls(system)
            except (sp.PolynomialError, ValueError, TypeError):
                got = False
            system.__dict__["_search_monomials"] = got
        return got or None

    def _coefficients(self, p) -> np.ndarray:
        p = np.asarray(p, float)
        if self._p is None or not np.array_equal(p, self._p):
            self._C = np.array(self._g(np.zeros(self.n), np.concatenate([p, self._w]))[0],
                               dtype=float).reshape(self.n, -1)
            self._p = p.copy()
        return self._C

    def _phi(self, P, E) -> np.ndarray:
        out = P[E[:, 0], :, 0]
        for j in range(1, self.n):
            out = out * P[E[:, j], :, j]
        return out                                   # monomials x rows

    def _powers(self, X) -> np.ndarray:
        X = np.asarray(X, float)
        P = np.empty((self._deg + 1,) + X.shape)
        P[0] = 1.0
        for k in range(1, self._deg + 1):
            P[k] = P[k - 1] * X
        return P

    def f_many(self, X, p) -> np.ndarray:
        C = self._coefficients(p)
        return (C @ self._phi(self._powers(X), self.E)).T

    def jac_many(self, X, p) -> np.ndarray:
        C = self._coefficients(p)
        P = self._powers(X)
        J = np.empty((len(P[0]), self.n, self.n))
        for j in range(self.n):
            J[:, :, j] = (C @ (self.E[:, j, None] * self._phi(P, self._dE[j]))).T
        return J

    def _derivative_tensor(self, x, p, order: int) -> np.ndarray:
        """d^order F_i / dx_j dx_k (dx_l) at one state, [i, j, k(, l)]: each monomial x^E
        differentiated exactly, d/dx_j x^E = E_j x^(E - e_j) applied ``order`` times (a factor 0
        where an exponent runs out)."""
        C = self._coefficients(p)
        P = self._powers(np.asarray(x, float).reshape(1, -1))
        n = self.n
        out = np.zeros((n,) + (n,) * order)
        for idx in itertools.product(range(n), repeat=order):
            E = self.E.copy()
            factor = np.ones(len(E))
            for j in idx:
                factor *= E[:, j]
                E[:, j] = np.maximum(E[:, j] - 1, 0)
            out[(slice(None),) + idx] = C @ (factor * self._phi(P, E)[:, 0])
        return out

    def hessian(self, x, p) -> np.ndarray:
        """d2 F_i / dx_j dx_k at ``x`` as an (n, n, n) array (`System.hessian`)."""
        return self._derivative_tensor(x, p, 2)

    def third(self, x, p) -> np.ndarray:
        """d3 F_i / dx_j dx_k dx_l at ``x`` as an (n, n, n, n) array (`System.third`)."""
        return self._derivative_tensor(x, p, 3)
