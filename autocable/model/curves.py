"""Aerodynamic coefficient curves c_l(phi), c_d(phi) of the cable with its rivulet (eq. 13).

The paper's load (eq. 11) needs lift and drag against the angle phi of eq. (12). It fits them by
cubics (eq. 13), global polynomials in phi. Eq. (21) needs only their value and first three
derivatives at the static angle phi0 (its cubic expansion, eq. 14); the exact quasi-steady load
(`autocable.model.exact_load`) evaluates the curves wherever the motion takes phi, so there the
curves themselves must hold. Three kinds (docs/aero-curves.md):

* `PolynomialCurves` (``kind = "cubic"``): the fits of eq. (13) as printed, global polynomials;
* `BlendedCubic` (``kind = "blend"``): the same fits inside the range of phi they were fitted over,
  blended (C2, a quintic smoothstep over ``blend_deg``) to the dry circular cylinder's coefficients
  (c_l = 0, c_d = ``dry_drag``) outside it: the rivulet has left the position it was tested at;
* `TableCurves` (``kind = "table"``): measured values against phi, interpolated by a cubic spline
  (C2; periodic over 360 degrees where the data say so), held beyond a non-periodic table's ends.

Every kind is plain data with three views:

* ``lift_expr(phi)`` / ``drag_expr(phi)``: sympy expressions in a sympy ``phi`` (the compiled
  right-hand sides are printed from them and differentiated for their Jacobians);
* ``lift(phi)`` / ``drag(phi)``: numpy values at an array of angles (radians);
* ``equivalent_cubic(phi0)``: the coefficients (A0..A3), (B0..B3) of eq. (13) of the cubic with the
  same value and first three derivatives at phi0, so that eq. (21) is the cubic expansion of the
  same curves the exact load uses.

``valid_phi`` is the range of phi (radians, absolute, ``(lo, hi)``) over which the curves hold
(measured or fitted); a motion that takes phi outside it is flagged (`autocable.model.validity`).
``None`` (the paper's fits, whose range the paper does not state) means `default_valid_phi` about
the static angle.
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from autocable.model.aero import ANGLE_SIGNS
from autocable.model.premises import ArgumentError

#: Half-width of the default valid range of the paper's cubic fits about the static angle [deg]
#: (`default_valid_phi`; docs/aero-curves.md gives the reason).
DEFAULT_HALF_WIDTH_DEG = 15.0
#: Width of the blend from a fit to the dry cylinder beyond the fit's range [deg].
DEFAULT_BLEND_DEG = 10.0
#: The dry circular cylinder's drag coefficient: subcritical flow (docs/aero-curves.md).
DEFAULT_DRY_DRAG = 1.2
#: The curve kinds `curves_from_dict` reads.
KINDS = ("cubic", "blend", "table")


def _f(x) -> sp.Float:
    return sp.Float(float(x), 17)


def _cubic(c, phi):
    return c[0] + c[1] * phi + c[2] / 2 * phi**2 + c[3] / 6 * phi**3


def _cubic_derivs(c, phi) -> list:
    """(value, d1, d2, d3) of eq. (13)'s cubic with coefficients ``c`` at phi (numpy)."""
    return [_cubic(c, phi), c[1] + c[2] * phi + c[3] / 2 * phi**2, c[2] + c[3] * phi, c[3] + 0.0 * phi]


@dataclass(frozen=True)
class PolynomialCurves:
    """The cubic fits of eq. (13): c_l = A0 + A1 phi + A2 phi^2/2 + A3 phi^3/6, c_d likewise with B."""

    lift_coeffs: tuple
    drag_coeffs: tuple
    valid_phi: tuple | None = None      # (lo, hi) in radians; None: not stated (default_valid_phi)

    kind = "cubic"

    @staticmethod
    def _poly(c, phi):
        return _cubic(c, phi)

    def lift_expr(self, phi):
        return _cubic([_f(x) for x in self.lift_coeffs], phi)

    def drag_expr(self, phi):
        return _cubic([_f(x) for x in self.drag_coeffs], phi)

    def lift(self, phi):
        return _cubic(self.lift_coeffs, np.asarray(phi, dtype=float))

    def drag(self, phi):
        return _cubic(self.drag_coeffs, np.asarray(phi, dtype=float))

    def derivatives(self, phi0: float) -> tuple[tuple, tuple]:
        """(lift, drag) value and first three derivatives at phi0 (radians)."""
        return (tuple(float(v) for v in _cubic_derivs(self.lift_coeffs, float(phi0))),
                tuple(float(v) for v in _cubic_derivs(self.drag_coeffs, float(phi0))))

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


def default_valid_phi(phi0: float) -> tuple[float, float]:
    """The valid range (radians) of curves that do not state theirs (the paper's cubic fits):
    the static angle phi0 +- `DEFAULT_HALF_WIDTH_DEG` (docs/aero-curves.md, the reason)."""
    h = math.radians(DEFAULT_HALF_WIDTH_DEG)
    return (float(phi0) - h, float(phi0) + h)


def static_angle(alpha: float, beta: float, theta0: float, convention: str) -> float:
    """phi0 of eq. (12) at rest (radians): the in-section wind angle gamma of eqs. (9)-(10) with
    the sense of ``convention`` (`aero.ANGLE_SIGNS`), less Theta0; `aero.expand_load_jet`'s
    ``static_angle`` (and `ExactLoad.static_angle`) for the same angles."""
    gamma = math.atan2(-math.sin(alpha) * math.sin(beta), math.cos(alpha))
    return ANGLE_SIGNS[convention] * gamma - theta0


def eq21_fits(aero_spec, alpha: float, beta: float, theta0: float) -> tuple[tuple, tuple]:
    """The cubic lift and drag of eq. (13) that eq. (21) is derived with, at the angles (beta, Theta0):
    the typed-in fits for the paper's curves, else the curves' own cubic at the static angle phi0
    (`equivalent_cubic`: value and three derivatives there). Every consumer of eq. (13)'s cubic (the
    N-mode derivation, the cubic-load error of a scene, the calibrations) goes through this, so a
    table or a blend is never read as a cubic's four numbers."""
    curves = curves_from_spec(aero_spec)
    if curves.kind == "cubic":
        return tuple(aero_spec.lift), tuple(aero_spec.drag)
    return curves.equivalent_cubic(static_angle(alpha, beta, theta0, aero_spec.angle_convention))


# ------------------------------------------------------------------------------------------------
# Piecewise polynomials: the form the compiled right-hand sides evaluate a table or a blend in
# ------------------------------------------------------------------------------------------------
def piecewise_polynomial_value(x, order: int, sizes, data):
    """The ``order``-th derivative at ``x`` (numpy array or number) of the piecewise polynomial of
    m = len(sizes) pieces packed in ``data`` = (edges[m-1], origins[m], coefficients): piece j holds
    on [edges[j-1], edges[j]) (the first and last unbounded) and is sum_i C_j[i] (x - origin_j)^i
    with sizes[j] coefficients C_j, ascending, one piece after the other."""
    m = len(sizes)
    data = [float(v) for v in data]
    edges, origins = np.asarray(data[:m - 1]), data[m - 1:2 * m - 1]
    starts = np.concatenate(([0], np.cumsum(sizes))) + 2 * m - 1
    arr = np.asarray(x, dtype=float)
    j = np.searchsorted(edges, arr, side="right")
    out = np.empty(arr.shape)
    for piece in np.unique(j):
        sel = j == piece
        c = tuple(data[starts[piece]:starts[piece + 1]])
        out[sel] = _horner(_poly_derivative(c, order), arr[sel] - origins[piece])
    return out if out.ndim else float(out)


def _poly_derivative(c: tuple, order: int) -> tuple:
    for _ in range(order):
        c = tuple(k * c[k] for k in range(1, len(c))) or (0.0,)
    return c


def _horner(c, t):
    out = 0.0 * t + c[-1]
    for a in reversed(c[:-1]):
        out = out * t + a
    return out


class PiecewisePolynomial(sp.Function):
    """``PiecewisePolynomial(x, k, m, *sizes, *edges, *origins, *coefficients)``: the k-th derivative
    of a piecewise polynomial of m pieces (`piecewise_polynomial_value`; sizes: the number of
    coefficients of each piece, trailing zeros left out).

    One sympy node per evaluation, whatever the number of pieces: its derivative in x is the same
    node with k + 1 (one chain rule, not one per piece as a sympy Piecewise would take, which made
    the Jacobian of an exact-rung model with a 25-point table cost minutes of sympy). Its numbers
    are Floats, so the compiled code reads them as run-time weights (`autocable.codegen.coefficients`:
    one build per shape of table, not per table). Printed to C as a balanced tree of comparisons
    (log2(m) tests per evaluation) and to Python/numpy (lambdify) as a call of
    `piecewise_polynomial_value`."""

    @classmethod
    def make(cls, x, edges, origins, coeffs, order: int = 0):
        coeffs = [list(c) for c in coeffs]
        for c in coeffs:
            while len(c) > 1 and c[-1] == 0.0:
                c.pop()
        flat = [_f(v) for v in edges] + [_f(v) for v in origins] + [_f(v) for c in coeffs for v in c]
        return cls(x, sp.Integer(order), sp.Integer(len(coeffs)), *(sp.Integer(len(c)) for c in coeffs), *flat)

    def _parts(self):
        x, k, m, *rest = self.args
        k, m = int(k), int(m)
        sizes = tuple(int(v) for v in rest[:m])
        return x, k, sizes, rest[m:]

    @classmethod
    def eval(cls, x, k, m, *rest):
        if x.is_Number and all(v.is_Number for v in rest):
            m = int(m)
            return sp.Float(piecewise_polynomial_value(float(x), int(k), [int(v) for v in rest[:m]],
                                                       [float(v) for v in rest[m:]]), 17)
        return None

    def fdiff(self, argindex=1):
        if argindex != 1:
            raise sp.ArgumentIndexError(self, argindex)
        x, k, *rest = self.args
        return self.func(x, k + 1, *rest)

    def _ccode(self, printer):
        x, k, sizes, data = self._parts()
        m = len(sizes)
        edges, origins = data[:m - 1], data[m - 1:2 * m - 1]
        starts = [2 * m - 1 + sum(sizes[:j]) for j in range(m)]
        xs = printer._print(x)

        def leaf(j):
            terms = []
            for i in range(k, sizes[j]):
                fac = math.perm(i, k)          # d^k t^i / dt^k = i! / (i - k)! t^(i - k)
                c = printer._print(data[starts[j] + i])
                terms.append(c if fac == 1 else f"{float(fac)!r}*{c}")
            if not terms:
                return "0.0"
            t = f"({xs} - {printer._print(origins[j])})"
            out = terms[-1]
            for c in reversed(terms[:-1]):
                out = f"({c} + {t}*{out})"
            return out

        def tree(lo, hi):
            if lo == hi:
                return leaf(lo)
            mid = (lo + hi + 1) // 2
            return f"(({xs} < {printer._print(edges[mid - 1])}) ? {tree(lo, mid - 1)} : {tree(mid, hi)})"
        return tree(0, m - 1)

    def _pythoncode(self, printer):
        x, k, sizes, data = self._parts()
        fn = printer._module_format("autocable.model.curves.piecewise_polynomial_value")
        packed = ", ".join(printer._print(v) for v in data)
        return f"{fn}({printer._print(x)}, {k}, {sizes!r}, ({packed},))"

    _numpycode = _pythoncode


class PeriodicAngle(sp.Function):
    """``PeriodicAngle(phi, x0, P)`` = phi - P floor((phi - x0) / P): phi brought into [x0, x0 + P).

    Its derivative in phi is 1 (the jumps by P fall where a periodic curve is continuous with its
    derivatives, so the composite is as smooth as the curve); sympy's own ``floor`` would leave an
    unevaluated derivative in a Jacobian. Printed to C (``floor`` of math.h) and to Python/numpy
    for lambdify."""

    nargs = 3

    @classmethod
    def eval(cls, phi, x0, period):
        if phi.is_Number and x0.is_Number and period.is_Number:
            return phi - period * sp.floor((phi - x0) / period)
        return None

    def fdiff(self, argindex=1):
        phi, x0, period = self.args
        if argindex == 1:
            return sp.Integer(1)
        if argindex == 2:
            return sp.Integer(0)
        return -sp.floor((phi - x0) / period)

    def _ccode(self, printer):
        phi, x0, period = (printer._print(a) for a in self.args)
        return f"({phi} - {period}*floor(({phi} - {x0})/{period}))"

    def _pythoncode(self, printer):
        module = getattr(printer, "_module", None) or "math"
        floor = printer._module_format(f"{module}.floor")
        phi, x0, period = (printer._print(a) for a in self.args)
        return f"({phi} - {period}*{floor}(({phi} - {x0})/{period}))"

    _numpycode = _pythoncode


# ------------------------------------------------------------------------------------------------
# The bounded extension of a cubic fit: the dry cylinder beyond the fit's range
# ------------------------------------------------------------------------------------------------
#: The quintic smoothstep S(u) = 10 u^3 - 15 u^4 + 6 u^5, ascending coefficients.
_SMOOTHSTEP = (0.0, 0.0, 0.0, 10.0, -15.0, 6.0)


def _smoothstep(u, order: int = 0):
    """S(u) on [0, 1] (0 below, 1 above) and its derivatives: S, S' and S'' vanish at both ends
    but for S(1) = 1, so that a blend by S is C2 (its third derivative jumps: 60 at u = 0)."""
    u = np.asarray(u, dtype=float)
    inside = (u > 0.0) & (u < 1.0)
    d = _poly_derivative(_SMOOTHSTEP, order)
    out = np.where(inside, _horner(d, np.clip(u, 0.0, 1.0)), 0.0)
    return np.where(u >= 1.0, 1.0, out) if order == 0 else out


@dataclass(frozen=True)
class BlendedCubic:
    """Eq. (13)'s fits inside the range of phi they hold over, the dry circular cylinder outside.

    Inside ``valid_phi`` = (lo, hi) (closed, radians) lift and drag are the cubics of eq. (13), and
    `equivalent_cubic` returns the fits' own coefficients there, so eq. (21), its Jacobian and the
    onset of a model whose static angle lies inside are those of the fits. Over ``blend_deg`` beyond
    each end they go over to c_l = 0, c_d = ``dry_drag`` by the quintic smoothstep S (C2: value and
    two derivatives continuous at both ends of the blend): c = c_fit + S(u) (c_dry - c_fit) with
    u = (phi - hi) / blend above, (lo - phi) / blend below. Beyond the blend they are the dry
    cylinder's constants: the rivulet has left the position the fits were measured at
    (docs/aero-curves.md, the physics and the sources)."""

    lift_coeffs: tuple
    drag_coeffs: tuple
    valid_phi: tuple                    # (lo, hi) radians: the range the fits hold over
    blend_deg: float = DEFAULT_BLEND_DEG
    dry_drag: float = DEFAULT_DRY_DRAG

    kind = "blend"

    def __post_init__(self):
        lo, hi = self.valid_phi
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ArgumentError("BlendedCubic", "valid_phi", f"expected finite (lo, hi) radians with lo < hi, "
                                                             f"got {self.valid_phi!r}")
        if not (math.isfinite(self.blend_deg) and self.blend_deg > 0):
            raise ArgumentError("BlendedCubic", "blend_deg", f"expected a positive width in degrees, "
                                                             f"got {self.blend_deg!r}")

    def _pieces(self, coeffs, dry: float):
        """(edges, origins, coefficients) of the blended curve (`PiecewisePolynomial`): the dry
        constant, the lower blend (degree 8 in phi - lo), the fit (eq. 13 about phi = 0, its own
        coefficients), the upper blend, the dry constant."""
        P = np.polynomial.polynomial
        lo, hi = self.valid_phi
        b = math.radians(self.blend_deg)

        def zone(x0, sense):
            d = _cubic_derivs(coeffs, x0)
            f = np.array([d[0], d[1], d[2] / 2, d[3] / 6])              # the fit about x0, in t = phi - x0
            s = np.array(_SMOOTHSTEP) * (sense / b) ** np.arange(6)     # S(sense t / b)
            g = P.polyadd(f, P.polymul(s, P.polysub([dry], f)))
            return tuple(float(v) for v in np.pad(g, (0, 9 - len(g))))

        const = (float(dry),) + (0.0,) * 8
        fit = (float(coeffs[0]), float(coeffs[1]), coeffs[2] / 2, coeffs[3] / 6) + (0.0,) * 5
        return ((lo - b, lo, hi, hi + b), (0.0, lo, 0.0, hi, 0.0),
                (const, zone(lo, -1.0), fit, zone(hi, 1.0), const))

    def lift_expr(self, phi):
        return PiecewisePolynomial.make(phi, *self._pieces(self.lift_coeffs, 0.0))

    def drag_expr(self, phi):
        return PiecewisePolynomial.make(phi, *self._pieces(self.drag_coeffs, self.dry_drag))

    def _derivs(self, coeffs, dry: float, phi, order: int):
        """The order-th derivative of the blended curve at the angles ``phi`` (numpy), by Leibniz's
        rule on f + S (dry - f): an evaluation independent of the pieces the compiled code uses."""
        phi = np.asarray(phi, dtype=float)
        lo, hi = self.valid_phi
        b = math.radians(self.blend_deg)
        f = _cubic_derivs(coeffs, phi)
        above = phi > hi
        u = np.where(above, (phi - hi) / b, (lo - phi) / b)
        du = np.where(above, 1.0 / b, -1.0 / b)
        out = f[order] + sum(math.comb(order, k) * _smoothstep(u, k) * du**k
                             * ((dry - f[0]) if order == k else -f[order - k]) for k in range(order + 1))
        out = np.where(u >= 1.0, dry if order == 0 else 0.0, out)      # the dry cylinder's constants exactly
        out = np.where((phi >= lo) & (phi <= hi), f[order], out)
        return out if out.ndim else float(out)

    def lift(self, phi):
        return self._derivs(self.lift_coeffs, 0.0, phi, 0)

    def drag(self, phi):
        return self._derivs(self.drag_coeffs, self.dry_drag, phi, 0)

    def derivatives(self, phi0: float) -> tuple[tuple, tuple]:
        """(lift, drag) value and first three derivatives at phi0 (radians)."""
        return tuple(tuple(float(self._derivs(c, d, phi0, n)) for n in range(4))
                     for c, d in ((self.lift_coeffs, 0.0), (self.drag_coeffs, self.dry_drag)))

    def equivalent_cubic(self, phi0: float) -> tuple[tuple, tuple]:
        """The fits' own coefficients inside the range (eq. 21 unchanged); outside it, the cubic with
        the blended curves' value and first three derivatives at phi0."""
        lo, hi = self.valid_phi
        if lo <= phi0 <= hi:
            return tuple(self.lift_coeffs), tuple(self.drag_coeffs)
        lift, drag = self.derivatives(phi0)
        return cubic_about(lift, phi0), cubic_about(drag, phi0)

    def to_dict(self) -> dict:
        return {"kind": self.kind, "lift": list(self.lift_coeffs), "drag": list(self.drag_coeffs),
                "valid_phi": list(self.valid_phi), "blend_deg": self.blend_deg, "dry_drag": self.dry_drag}


# ------------------------------------------------------------------------------------------------
# Tables: a cubic spline through measured values
# ------------------------------------------------------------------------------------------------
@functools.lru_cache(maxsize=32)
def _table_pieces(phi_deg: tuple, values: tuple, periodic: bool):
    """The curve of a table as polynomial pieces (`piecewise_polynomial_value`): (edges, origins,
    coefficients), 5 coefficients a piece.

    Inside the data: scipy's cubic spline in radians ("not-a-knot" ends, or periodic). Beyond a
    non-periodic table's end: the quartic run-out that takes the end slope and curvature to zero
    over one end interval (value, slope and curvature continuous at both of its ends), then the
    constant it reaches: C2 and bounded (docs/aero-curves.md)."""
    from scipy.interpolate import CubicSpline

    x = np.radians(np.asarray(phi_deg, dtype=float))
    y = np.asarray(values, dtype=float)
    spline = CubicSpline(x, y, bc_type="periodic" if periodic else "not-a-knot")
    segs = tuple((float(spline.c[3, i]), float(spline.c[2, i]), float(spline.c[1, i]), float(spline.c[0, i]), 0.0)
                 for i in range(len(x) - 1))
    knots = tuple(float(v) for v in x)
    if periodic:
        return knots[1:-1], knots[:-1], segs

    def runout(v, s, k, w):
        # r(u) = v + s u + k u^2/2 + a u^3 + b u^4 with r'(w) = r''(w) = 0; r(w) = v + s w/2 + k w^2/12
        a = -(2 * k * w + 3 * s) / (3 * w**2)
        b = (s + k * w / 2) / (2 * w**3)
        return (v, s, k / 2, a, b), v + s * w / 2 + k * w**2 / 12

    w0, wn = knots[1] - knots[0], knots[-1] - knots[-2]
    v0, s0, k0 = (float(spline(x[0], n)) for n in range(3))
    vn, sn, kn = (float(spline(x[-1], n)) for n in range(3))
    lo, held_lo = runout(v0, -s0, k0, w0)      # in u = x0 - phi: odd powers of (phi - x0) change sign
    lo = (lo[0], -lo[1], lo[2], -lo[3], lo[4])
    hi, held_hi = runout(vn, sn, kn, wn)
    edges = (knots[0] - w0,) + knots + (knots[-1] + wn,)
    origins = (0.0, knots[0]) + knots[:-1] + (knots[-1], 0.0)
    coeffs = ((held_lo, 0.0, 0.0, 0.0, 0.0), lo) + segs + (hi, (held_hi, 0.0, 0.0, 0.0, 0.0))
    return edges, origins, coeffs


@dataclass(frozen=True)
class TableCurves:
    """Lift and drag measured at angles ``phi_deg`` (degrees, increasing), interpolated by a cubic
    spline in radians: C2, exact at the data, not-a-knot ends; ``periodic``: the data span 360
    degrees (the last row repeats the first, 360 degrees on) and the periodic spline holds at every
    angle. Beyond a non-periodic table the curves are held (`_table_pieces`), outside ``valid_phi``
    (default: the table's own range; every angle for a periodic table)."""

    phi_deg: tuple
    lift_values: tuple
    drag_values: tuple
    periodic: bool = False
    valid_phi: tuple | None = None      # radians; None: the table's range (every angle if periodic)

    kind = "table"

    def __post_init__(self):
        n = len(self.phi_deg)
        if n < 4 or len(self.lift_values) != n or len(self.drag_values) != n:
            raise ArgumentError("TableCurves", "phi_deg", f"expected at least 4 angles with as many lift and "
                                                          f"drag values, got {n}, {len(self.lift_values)}, "
                                                          f"{len(self.drag_values)}")
        if any(b <= a for a, b in zip(self.phi_deg, self.phi_deg[1:])):
            raise ArgumentError("TableCurves", "phi_deg", "expected strictly increasing angles")
        if self.periodic:
            if (abs(self.phi_deg[-1] - self.phi_deg[0] - 360.0) > 1e-9
                    or abs(self.lift_values[-1] - self.lift_values[0]) > 1e-9
                    or abs(self.drag_values[-1] - self.drag_values[0]) > 1e-9):
                raise ArgumentError("TableCurves", "periodic", "a periodic table's last row is its first, "
                                                               "360 deg on (within 1e-9)")
            # the same angle: one value (the periodic spline needs them equal to the last bit)
            object.__setattr__(self, "lift_values", tuple(self.lift_values[:-1]) + (self.lift_values[0],))
            object.__setattr__(self, "drag_values", tuple(self.drag_values[:-1]) + (self.drag_values[0],))
        if self.valid_phi is None:
            valid = ((-math.inf, math.inf) if self.periodic
                     else (math.radians(self.phi_deg[0]), math.radians(self.phi_deg[-1])))
            object.__setattr__(self, "valid_phi", valid)

    def _pieces(self, values):
        return _table_pieces(tuple(float(v) for v in self.phi_deg), tuple(float(v) for v in values),
                             bool(self.periodic))

    def _values(self, values, phi, order: int = 0):
        edges, origins, coeffs = self._pieces(values)
        phi = np.asarray(phi, dtype=float)
        if self.periodic:
            x0 = math.radians(self.phi_deg[0])
            phi = x0 + np.mod(phi - x0, 2 * math.pi)
        return piecewise_polynomial_value(phi, order, [len(c) for c in coeffs],
                                          edges + origins + tuple(v for c in coeffs for v in c))

    def _expr(self, values, phi):
        if self.periodic:
            phi = PeriodicAngle(phi, _f(math.radians(self.phi_deg[0])), _f(2 * math.pi))
        return PiecewisePolynomial.make(phi, *self._pieces(values))

    def lift_expr(self, phi):
        return self._expr(self.lift_values, phi)

    def drag_expr(self, phi):
        return self._expr(self.drag_values, phi)

    def lift(self, phi):
        return self._values(self.lift_values, phi)

    def drag(self, phi):
        return self._values(self.drag_values, phi)

    def derivatives(self, phi0: float) -> tuple[tuple, tuple]:
        """(lift, drag) value and first three derivatives at phi0 (radians); at a knot, those of
        the piece that starts there (the spline's third derivative jumps at its knots)."""
        return tuple(tuple(float(self._values(v, float(phi0), n)) for n in range(4))
                     for v in (self.lift_values, self.drag_values))

    def equivalent_cubic(self, phi0: float) -> tuple[tuple, tuple]:
        """The cubic of eq. (13) with the spline's value and first three derivatives at phi0."""
        lift, drag = self.derivatives(phi0)
        return cubic_about(lift, phi0), cubic_about(drag, phi0)

    def to_dict(self) -> dict:
        lo, hi = self.valid_phi
        stated = None if (self.periodic and math.isinf(lo)) else [lo, hi]
        return {"kind": self.kind, "phi_deg": list(self.phi_deg), "lift": list(self.lift_values),
                "drag": list(self.drag_values), "periodic": bool(self.periodic), "valid_phi": stated}


# ------------------------------------------------------------------------------------------------
# Building curves: from a model's [aero] table, from plain data, with another band
# ------------------------------------------------------------------------------------------------
def _radians(pair):
    return None if pair is None else (math.radians(pair[0]), math.radians(pair[1]))


def curves_from_spec(aero):
    """The curve set of a model's [aero] table (`autocable.spec.AeroSpec`): its table, or its cubic
    fits, bounded by the dry cylinder with ``outside = "dry-cylinder"``."""
    valid = _radians(getattr(aero, "valid_phi_deg", None))
    table = getattr(aero, "table", None)
    if table is not None:
        return TableCurves(tuple(table.phi_deg), tuple(table.lift), tuple(table.drag), bool(table.periodic), valid)
    if getattr(aero, "outside", "cubic") == "dry-cylinder":
        blend = DEFAULT_BLEND_DEG if aero.blend_deg is None else float(aero.blend_deg)
        dry = DEFAULT_DRY_DRAG if aero.dry_drag is None else float(aero.dry_drag)
        return BlendedCubic(tuple(aero.lift), tuple(aero.drag), valid, blend, dry)
    return PolynomialCurves(tuple(aero.lift), tuple(aero.drag), valid)


def curves_from_dict(data: dict):
    """The curve set written by ``to_dict`` (plain data, e.g. read back from a cache)."""
    kind = data.get("kind")
    valid = data.get("valid_phi")
    valid = None if valid is None else (float(valid[0]), float(valid[1]))
    if kind == "cubic":
        return PolynomialCurves(tuple(data["lift"]), tuple(data["drag"]), valid)
    if kind == "blend":
        return BlendedCubic(tuple(data["lift"]), tuple(data["drag"]), valid, float(data["blend_deg"]),
                            float(data["dry_drag"]))
    if kind == "table":
        return TableCurves(tuple(data["phi_deg"]), tuple(data["lift"]), tuple(data["drag"]),
                           bool(data["periodic"]), valid)
    raise ValueError(f"unknown kind of aerodynamic curves {kind!r}; expected one of {KINDS}")


def valid_phi(curves_or_spec, phi0: float) -> tuple[float, float]:
    """The range of phi (radians, absolute, (lo, hi)) the curves hold over: the one they state, or
    `default_valid_phi` about the static angle ``phi0`` (radians). ``curves_or_spec``: a curve set,
    its ``to_dict``, an `AeroSpec` or a `ModelSpec`."""
    curves = curves_or_spec
    if isinstance(curves, dict):
        curves = curves_from_dict(curves)
    elif hasattr(curves, "aero"):
        curves = curves_from_spec(curves.aero)
    elif not hasattr(curves, "equivalent_cubic"):
        curves = curves_from_spec(curves)
    return curves.valid_phi if curves.valid_phi is not None else default_valid_phi(phi0)


def with_band(curves, half_width_deg: float = DEFAULT_HALF_WIDTH_DEG, blend_deg: float | None = None,
              phi0: float | None = None, dry_drag: float | None = None) -> BlendedCubic:
    """The cubic fits of ``curves`` held over phi0 +- ``half_width_deg`` and blended to the dry
    cylinder over ``blend_deg`` beyond (`BlendedCubic`): the curves a study recomputes an amplitude
    with to report how it follows the band. ``phi0`` (radians) centres the band; without it, the
    middle of the curves' stated range. A blend keeps its own width and dry drag unless given."""
    fn = "with_band"
    for name, value in (("half_width_deg", half_width_deg), ("blend_deg", blend_deg), ("dry_drag", dry_drag)):
        if value is not None and (isinstance(value, bool) or not isinstance(value, (int, float))
                                  or not math.isfinite(value) or value <= 0):
            raise ArgumentError(fn, name, f"expected a positive number, got {value!r}")
    if isinstance(curves, dict):
        curves = curves_from_dict(curves)
    if curves.kind == "table":
        raise ArgumentError(fn, "curves", "a table holds its measured values over its own range; a band "
                                          "applies to cubic fits (kind 'cubic' or 'blend')")
    if phi0 is None:
        if curves.valid_phi is None:
            raise ArgumentError(fn, "phi0", "the curves state no range; give the static angle phi0 (radians) "
                                            "to centre the band on")
        phi0 = 0.5 * (curves.valid_phi[0] + curves.valid_phi[1])
    h = math.radians(half_width_deg)
    old_blend = curves.blend_deg if curves.kind == "blend" else DEFAULT_BLEND_DEG
    old_dry = curves.dry_drag if curves.kind == "blend" else DEFAULT_DRY_DRAG
    return BlendedCubic(tuple(curves.lift_coeffs), tuple(curves.drag_coeffs), (phi0 - h, phi0 + h),
                        float(blend_deg if blend_deg is not None else old_blend),
                        float(dry_drag if dry_drag is not None else old_dry))

