"""Aerodynamic coefficient curves c_l(phi), c_d(phi) of the cable with its rivulet (eq. 13).

The paper's load (eq. 11) needs lift and drag against the angle phi of eq. (12). It fits them by
cubics (eq. 13), global polynomials in phi. Eq. (21) needs only their value and first three
derivatives at the static angle phi0 (its cubic expansion, eq. 14); the exact quasi-steady load
(`autocable.model.exact_load`) evaluates the curves wherever the motion takes phi. A curve set is
plain data with three views:

* ``lift_expr(phi)`` / ``drag_expr(phi)``: sympy expressions in a sympy ``phi`` (the compiled
  right-hand sides are printed from them);
* ``lift(phi)`` / ``drag(phi)``: numpy values at an array of angles (radians);
* ``equivalent_cubic(phi0)``: the coefficients (A0..A3), (B0..B3) of eq. (13) of the cubic with the
  same value and first three derivatives at phi0, so that eq. (21) is the cubic expansion of the
  same curves the exact load uses.

``valid_phi`` is the range of phi (radians, absolute, ``(lo, hi)``) over which the curves hold
(measured or fitted); a motion that takes phi outside it is flagged (`autocable.model.validity`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import sympy as sp


@dataclass(frozen=True)
class PolynomialCurves:
    """The cubic fits of eq. (13): c_l = A0 + A1 phi + A2 phi^2/2 + A3 phi^3/6, c_d likewise with B."""

    lift_coeffs: tuple
    drag_coeffs: tuple
    valid_phi: tuple | None = None      # (lo, hi) in radians; None: not stated

    kind = "cubic"

    @staticmethod
    def _poly(c, phi):
        return c[0] + c[1] * phi + c[2] / 2 * phi**2 + c[3] / 6 * phi**3

    def lift_expr(self, phi):
        return self._poly([sp.Float(x, 17) for x in self.lift_coeffs], phi)

    def drag_expr(self, phi):
        return self._poly([sp.Float(x, 17) for x in self.drag_coeffs], phi)

    def lift(self, phi):
        return self._poly(self.lift_coeffs, np.asarray(phi, dtype=float))

    def drag(self, phi):
        return self._poly(self.drag_coeffs, np.asarray(phi, dtype=float))

    def equivalent_cubic(self, phi0: float) -> tuple[tuple, tuple]:
        """Eq. (13)'s own coefficients: a cubic is its own cubic expansion about any angle."""
        return tuple(self.lift_coeffs), tuple(self.drag_coeffs)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "lift": list(self.lift_coeffs), "drag": list(self.drag_coeffs),
                "valid_phi": None if self.valid_phi is None else list(self.valid_phi)}


def cubic_about(values: tuple, phi0: float) -> tuple:
    """Eq. (13)'s (C0..C3) of the cubic c(phi) = sum_n d_n (phi - phi0)^n / n! with ``values`` =
    (d_0, d_1, d_2, d_3) the value and first three derivatives of a curve at phi0."""
    d0, d1, d2, d3 = (float(v) for v in values)
    # expand sum d_n (phi - p)^n / n! in powers of phi, then write it as C0 + C1 phi + C2 phi^2/2 + C3 phi^3/6
    p = phi0
    c0 = d0 - d1 * p + d2 * p**2 / 2 - d3 * p**3 / 6
    c1 = d1 - d2 * p + d3 * p**2 / 2
    c2 = d2 - d3 * p
    c3 = d3
    return (c0, c1, c2, c3)


def curves_from_spec(aero) -> PolynomialCurves:
    """The curve set of a model's [aero] table (`autocable.spec.AeroSpec`)."""
    valid = getattr(aero, "valid_phi_deg", None)
    valid = None if valid is None else (math.radians(valid[0]), math.radians(valid[1]))
    return PolynomialCurves(tuple(aero.lift), tuple(aero.drag), valid)


def curves_from_dict(data: dict) -> PolynomialCurves:
    """The curve set written by ``to_dict`` (plain data, e.g. read back from a cache)."""
    kind = data.get("kind")
    valid = data.get("valid_phi")
    valid = None if valid is None else (float(valid[0]), float(valid[1]))
    if kind == "cubic":
        return PolynomialCurves(tuple(data["lift"]), tuple(data["drag"]), valid)
    raise ValueError(f"unknown kind of aerodynamic curves {kind!r}")
