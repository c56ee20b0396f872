"""Continuation of the amplitude equations (Luongo & Zulli, Sect. 4-5): equilibria, cycles, branch switching.

What it solves. Equilibria of the Cartesian AME (24), y' = g(y; eta, U, sigma), y = (r1, s1, ..., rN, sN),
are the period-1 motions of eq. (21) whose amplitudes Sect. 5 plots (Figs. 3-10); periodic orbits of
(24) are quasi-periodic motions of eq. (21) (the thin min/max lines of Fig. 4). Any autonomous system
given as sympy data (`System`) can be continued the same way; the tests use textbook systems.

How. A BifurcationKit-like design: an immutable `EquilibriumProblem` (what: the system, the fixed
parameter values, the continued parameter and its range, the state scale) and immutable
`ContinuationSettings` (how: steps, tolerances, point budget, collocation mesh) meet in one call:

* `continue_equilibria(problem, settings, start)`: PyCont's EP-C, forward and backward from a start
  point (a separate PyCont curve per direction: ``backward()`` after a "closed curve" raises
  ``KeyError: 'data'`` in PyCont), run in chunks so the range, a closed curve, the point budget and a
  failure are detected as they happen; a failure keeps the points computed before it.
* `continue_cycles(result, "H1", settings)`: PyCont's LC-C (AUTO collocation) from a Hopf point.
* `switch_branch(result, "BP1", settings)`: the other branch through a branch point, both sides.
* `continue_folds(result, "LP1", "eta", (lo, hi))` / `continue_hopf(result, "H1", ...)`: the curve
  of folds (PyCont's LP-C) or of Hopf points (H-C2) through a labelled point, in the plane of the
  source's parameter and a second one. PyCont's steps, with its random test-function borders
  seeded, jumps and turn-backs restarted from the last good point; every point refined on
  autocable's own defining system (f = 0 plus a bordered test function) and checked (det J = 0,
  or a pair on the imaginary axis) with the exact Jacobian; CP, BT, ZH, GH, DH from autocable's
  test functions, compared with PyCont's labels.

PyCont only produces points. Everything reported about them is autocable's own, computed from the
exact sympy Jacobian (numpy): the state is polished by Newton at fixed parameter, stability comes from
the eigenvalues at every point (never PyCont's 'S'/'U'/'N' flag, which uses absolute thresholds of
1e-6 and mislabels slow flows whose rates are that small, like the AME of a lightly damped cable),
and special points are located by autocable's test functions along the branch: sign changes of
det J (LP when the tangent's parameter component also changes sign, BP otherwise), of the
bialternate-product determinant det(2J (.) I) for H (a zero with a real pair lambda, -lambda is a
neutral saddle, not a Hopf point), then refined on the branch by Brent's method with a Newton
corrector. The first Lyapunov coefficient l1 at H is Kuznetsov's (Elements of Applied Bifurcation
Theory, 3rd ed., eq. 3.20) from exact second and third derivatives. The result is compared with
PyCont's list: `SpecialPoint.confirmed_by_pycont` says whether PyCont found the same point, and a
point only PyCont reports is kept with ``origin="pycont"``. For cycles the Floquet multipliers are
computed by integrating the variational equations over one period and cross-checked with AUTO's;
LPC, PD, NS come from them.

Scaling. The AME's amplitudes are ~1e-4..1e-2 and sigma spans ~0.1: PyCont's absolute tolerances
and its pseudo-arclength steps would mix scales badly. The vector field handed to PyCont is written in
scaled coordinates x~ = x / xscale and lam = (p - p0) / pscale (both PyDSTool parameters, so one
compiled library serves every scene). Eigenvalues are unchanged by this scaling.

Cost. EP-C points cost PyCont's few ms each plus autocable's analysis (~0.3 ms); LC-C points AUTO's
collocation plus one variational integration each (~10-50 ms). `bench_continuation` measures both.
"""
from __future__ import annotations

import contextlib
import math
import re
import time
import warnings
from dataclasses import dataclass, field, replace
from functools import cached_property
from types import MappingProxyType
from typing import Any, Callable, Mapping, Sequence

import numpy as np
import sympy as sp

from autocable.codegen import compat
from autocable.codegen.pydstool import VectorField, continuation_system, pydstool_cache_dir
from autocable.results import Branch, EndPoint, SpecialPoint, stability_measure

__all__ = [
    "StartError",
    "System",
    "ame_system",
    "ContinuationSettings",
    "EquilibriumProblem",
    "ContinuationResult",
    "equilibrium_near",
    "settle",
    "continue_equilibria",
    "continue_cycles",
    "switch_branch",
    "continue_folds",
    "continue_hopf",
    "first_lyapunov",
    "bialternate",
    "bench_continuation",
    "auto_state_scale",
]

#: Names the scaled PyCont vector field reserves for itself.
_RESERVED = ("xscale", "lam", "lam2", "tscale")

Progress = Callable[[str], None]


class StartError(ValueError):
    """The start point of a continuation is not an equilibrium (Newton or integration failed)."""


# ================================================================================================
# the system
# ================================================================================================
def _plain(expr):
    """sympy expression with every symbol replaced by a plain ``Symbol(name)`` (no assumptions)."""
    expr = sp.sympify(expr)
    return expr.xreplace({s: sp.Symbol(s.name) for s in expr.free_symbols})


@dataclass(frozen=True, eq=False)
class System:
    """An autonomous vector field x' = f(x; p) as sympy data, with exact numeric derivatives.

    ``amplitudes`` names the measured amplitudes: ``("a1", ("r1", "s1"))`` means
    a1 = sqrt(r1^2 + s1^2) (the peak modal amplitude of the AME, see `autocable.model.ame`); an
    empty tuple of variables gives an identically zero amplitude (a2 of the 1-dof reduction, A2 = 0).
    Numeric functions take ``x`` in ``variables`` order and ``p`` in ``parameter_names`` order.
    """

    name: str
    variables: tuple[str, ...]
    rhs: tuple[Any, ...]
    parameters: tuple[tuple[str, float], ...]
    amplitudes: tuple[tuple[str, tuple[str, ...]], ...] = ()
    description: str = ""

    def __post_init__(self):
        variables = tuple(str(v) for v in self.variables)
        params = self.parameters.items() if isinstance(self.parameters, Mapping) else self.parameters
        params = tuple((str(k), float(v)) for k, v in params)
        rhs = tuple(_plain(e) for e in self.rhs)
        if len(rhs) != len(variables):
            raise ValueError(f"system {self.name!r}: {len(variables)} variables, {len(rhs)} right-hand sides")
        names = set(variables) | {p for p, _ in params}
        for r in _RESERVED:
            if r in names or any(n == f"d_{r}" for n in names):
                raise ValueError(f"system {self.name!r}: the name {r!r} is reserved for continuation")
        for e in rhs:
            extra = {s.name for s in e.free_symbols} - names
            if extra:
                raise ValueError(f"system {self.name!r}: undeclared symbols {sorted(extra)}")
        amps = tuple((str(a), tuple(str(v) for v in vs)) for a, vs in self.amplitudes)
        for a, vs in amps:
            if set(vs) - set(variables):
                raise ValueError(f"amplitude {a!r} uses unknown variables {sorted(set(vs) - set(variables))}")
        object.__setattr__(self, "variables", variables)
        object.__setattr__(self, "parameters", params)
        object.__setattr__(self, "rhs", rhs)
        object.__setattr__(self, "amplitudes", amps)

    # -- names -------------------------------------------------------------------------------
    @property
    def dimension(self) -> int:
        return len(self.variables)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p for p, _ in self.parameters)

    @property
    def amplitude_names(self) -> tuple[str, ...]:
        return tuple(a for a, _ in self.amplitudes)

    def parameter_vector(self, values: Mapping[str, float] | None = None) -> np.ndarray:
        """p in `parameter_names` order: the defaults overridden by ``values``."""
        out = dict(self.parameters)
        for k, v in (values or {}).items():
            if k not in out:
                raise KeyError(f"system {self.name!r} has no parameter {k!r} (it has {list(out)})")
            out[k] = float(v)
        return np.array([out[p] for p in self.parameter_names], dtype=float)

    def parameter_dict(self, p) -> dict[str, float]:
        return {k: float(v) for k, v in zip(self.parameter_names, p)}

    def amplitude_values(self, x) -> tuple[float, ...]:
        """The named amplitudes of state(s) ``x`` (last axis = variables)."""
        x = np.asarray(x, dtype=float)
        idx = {v: i for i, v in enumerate(self.variables)}
        out = []
        for _, vs in self.amplitudes:
            if vs:
                out.append(np.sqrt(sum(x[..., idx[v]] ** 2 for v in vs)))
            else:
                out.append(np.zeros(x.shape[:-1]) if x.ndim > 1 else 0.0)
        return tuple(out)

    # -- numerics ----------------------------------------------------------------------------
    @cached_property
    def _symbols(self):
        return ([sp.Symbol(v) for v in self.variables], [sp.Symbol(p) for p in self.parameter_names])

    @cached_property
    def _numeric(self):
        xs, ps = self._symbols
        F = sp.Matrix(self.rhs)
        f = sp.lambdify((xs, ps), F, modules="numpy", cse=True)
        J = sp.lambdify((xs, ps), F.jacobian(xs), modules="numpy", cse=True)
        Jp = sp.lambdify((xs, ps), F.jacobian(ps), modules="numpy", cse=True)
        return f, J, Jp

    @cached_property
    def _higher(self):
        """Second and third derivative tensors (for the first Lyapunov coefficient)."""
        xs, ps = self._symbols
        d2 = sp.derive_by_array(sp.derive_by_array(list(self.rhs), xs), xs)     # [k][j][i]
        d3 = sp.derive_by_array(d2, xs)                                           # [l][k][j][i]
        f2 = sp.lambdify((xs, ps), d2.tolist(), modules="numpy", cse=True)
        f3 = sp.lambdify((xs, ps), d3.tolist(), modules="numpy", cse=True)
        n = self.dimension
        # derive_by_array puts the derivative index first: reorder to [i, j, k(, l)].
        return (lambda x, p: np.broadcast_to(np.array(f2(x, p), dtype=float), (n,) * 3).transpose(2, 1, 0),
                lambda x, p: np.broadcast_to(np.array(f3(x, p), dtype=float), (n,) * 4).transpose(3, 2, 1, 0))

    def f(self, x, p) -> np.ndarray:
        return np.asarray(self._numeric[0](np.asarray(x, float), np.asarray(p, float)), dtype=float).reshape(-1)

    def jac(self, x, p) -> np.ndarray:
        n = self.dimension
        return np.broadcast_to(np.asarray(self._numeric[1](np.asarray(x, float), np.asarray(p, float)),
                                          dtype=float), (n, n)).copy()

    def jac_p(self, x, p) -> np.ndarray:
        n, m = self.dimension, len(self.parameters)
        return np.broadcast_to(np.asarray(self._numeric[2](np.asarray(x, float), np.asarray(p, float)),
                                          dtype=float), (n, m)).copy()

    def hessian(self, x, p) -> np.ndarray:
        """d2 f_i / dx_j dx_k as an (n, n, n) array."""
        return self._higher[0](np.asarray(x, float), np.asarray(p, float))

    def third(self, x, p) -> np.ndarray:
        """d3 f_i / dx_j dx_k dx_l as an (n, n, n, n) array."""
        return self._higher[1](np.asarray(x, float), np.asarray(p, float))

    # -- the PyCont field --------------------------------------------------------------------
    @cached_property
    def _scaled_field(self) -> VectorField:
        return self._make_scaled_field()

    def scaled_field(self) -> VectorField:
        """The field PyCont continues (built once per system; see `_make_scaled_field`)."""
        return self._scaled_field

    def _make_scaled_field(self) -> VectorField:
        """The field PyCont continues: x~ = x/xscale, p_k = p_k + d_<p_k> * lam (module docstring).

        Every parameter stays a PyDSTool parameter, so one compiled library serves every fixed value,
        every continued parameter and every scale."""
        xs, ps = self._symbols
        xscale, lam = sp.Symbol("xscale"), sp.Symbol("lam")
        sub = {x: xscale * x for x in xs}
        sub.update({p: p + sp.Symbol(f"d_{p.name}") * lam for p in ps})
        rhs = [sp.expand(e.xreplace(sub) / xscale) for e in self.rhs]
        params = list(self.parameters) + [("xscale", 1.0)] + [(f"d_{p}", 0.0) for p in self.parameter_names] \
            + [("lam", 0.0)]
        return VectorField(self.name, self.variables, rhs, params)

    @cached_property
    def _scaled_field_2p(self) -> VectorField:
        """The field of the two-parameter curves (LP-C, H-C2): x~ = x/xscale, time scaled by tscale,
        p_k = p_k + d_<p_k> * lam + d2_<p_k> * lam2 (a second library; the one-parameter field is
        left as it is)."""
        xs, ps = self._symbols
        xscale, tscale = sp.Symbol("xscale"), sp.Symbol("tscale")
        lam, lam2 = sp.Symbol("lam"), sp.Symbol("lam2")
        clash = [p for p in self.parameter_names if p.startswith(("d_", "d2_"))]
        if clash:
            raise ValueError(f"system {self.name!r}: parameter names {clash} clash with the scaled field's")
        sub = {x: xscale * x for x in xs}
        sub.update({p: p + sp.Symbol(f"d_{p.name}") * lam + sp.Symbol(f"d2_{p.name}") * lam2 for p in ps})
        rhs = [sp.expand(tscale * e.xreplace(sub) / xscale) for e in self.rhs]
        params = list(self.parameters) + [("xscale", 1.0), ("tscale", 1.0)] \
            + [(f"d_{p}", 0.0) for p in self.parameter_names] \
            + [(f"d2_{p}", 0.0) for p in self.parameter_names] + [("lam", 0.0), ("lam2", 0.0)]
        return VectorField(f"{self.name}_2p", self.variables, rhs, params)


def ame_system(ame, dof: str = "2dof", *, wind: bool = True, name: str | None = None) -> System:
    """The Cartesian AME (24) as a `System` in the scene parameters (sigma, U, eta).

    ``dof="1dof"`` is the reduction A2 = 0 of Sect. 5 (a2 is then identically zero). The detunings
    follow Sect. 4 and the ERRATA: Omega = omega1 + sigma, sigma_k = omega_k - Omega (so
    sigma_1 = -sigma and rho = omega2 - omega1 stays fixed), so one parameter sigma moves the
    detunings and the exact Omega of the coefficients consistently. ``wind=False`` drops the
    aerodynamic rows (their 1/U powers: no wind, no term), as needed at U = 0; with wind the field
    is singular at U = 0.
    """
    if dof not in ("2dof", "1dof"):
        raise ValueError(f"dof must be '2dof' or '1dof', got {dof!r}")
    src = ame.one_dof() if dof == "1dof" else ame
    if src.user_names:
        raise ValueError(f"the AME has unbound user symbols {src.user_names}")
    syms = src.symbols()
    exprs = src.cartesian_expressions(include_aero=wind)
    sigma = sp.Symbol("sigma")
    omegas = [sp.Float(float(w), 17) for w in src.omegas]
    Omega = omegas[0] + sigma
    rel = {syms["Omega"]: Omega}
    for k in range(src.n_modes):
        rel[syms[f"sigma_{k + 1}"]] = omegas[k] - Omega
    ren = {}
    for k in range(1, src.n_modes + 1):
        ren[syms[f"r_{k}"]] = sp.Symbol(f"r{k}")
        ren[syms[f"s_{k}"]] = sp.Symbol(f"s{k}")
    ren[syms["eta"]] = sp.Symbol("eta")
    ren[syms["U"]] = sp.Symbol("U")
    rhs = [_plain(sp.expand(e.xreplace(rel)).xreplace(ren)) for e in exprs]
    variables = tuple(v for k in range(1, src.n_modes + 1) for v in (f"r{k}", f"s{k}"))
    amps = [(f"a{k}", (f"r{k}", f"s{k}")) for k in range(1, src.n_modes + 1)]
    if dof == "1dof":
        amps.append(("a2", ()))
    tag = name or f"ame{src.n_modes}{'w' if wind else 'n'}"
    return System(tag, variables, rhs, (("sigma", 0.0), ("U", 0.0), ("eta", 0.0)), tuple(amps),
                  description=f"Cartesian AME (24), {dof}, {'with' if wind else 'without'} wind terms")


# ================================================================================================
# problem and settings
# ================================================================================================
@dataclass(frozen=True)
class ContinuationSettings:
    """How to continue (steps in the scaled coordinates of the module docstring: lam spans 1 over
    the range, x~ is the state over ``state_scale``)."""

    step: float = 5e-3               # initial pseudo-arclength step
    min_step: float = 1e-7
    max_step: float = 2e-2
    max_points: int = 2000           # per direction (equilibria) or per cycle branch
    chunk: int = 25                  # PyCont points per call (range/closure checks in between; a
                                     # call overshoots the range by up to a chunk, so keep it small)
    max_corrector_iters: int = 6
    tol: float = 1e-10               # PyCont's FuncTol and VarTol (scaled units)
    test_tol: float = 1e-8           # PyCont's TestTol
    newton_tol: float = 1e-12        # autocable's polish/refinement: relative Newton step
    locate: tuple[str, ...] = ("LP", "H", "BP")
    # cycles (LC-C)
    ntst: int = 40
    ncol: int = 4
    cycle_step: float = 1e-3
    cycle_max_step: float = 2e-2
    cycle_max_points: int = 150
    max_period_ratio: float = 20.0   # period blow-up: T > ratio * T_Hopf ends the branch
    floquet_rtol: float = 1e-10
    # branch switching
    switch_step: float = 1e-2
    # two-parameter curves (LP-C, H-C2): steps in the scaled coordinates (both ranges span 1)
    curve_step: float = 5e-3
    curve_max_step: float = 2e-2
    curve_max_points: int = 400      # per direction
    curve_check_tol: float = 1e-8    # independent check at every point: sigma_min(J)/sigma_max(J)
                                     # (folds), |Re lambda|/||J||_F of the critical pair (Hopf)

    def __post_init__(self):
        for name in ("step", "min_step", "max_step", "tol", "test_tol", "newton_tol", "cycle_step",
                     "cycle_max_step", "switch_step", "curve_step", "curve_max_step", "curve_check_tol"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and v > 0 and math.isfinite(v)):
                raise ValueError(f"{name} must be a positive number, got {v!r}")
        if not self.min_step <= self.step <= self.max_step:
            raise ValueError(f"need min_step <= step <= max_step, got {self.min_step}, {self.step}, {self.max_step}")
        if not self.min_step <= self.curve_step <= self.curve_max_step:
            raise ValueError(f"need min_step <= curve_step <= curve_max_step, got {self.min_step}, "
                             f"{self.curve_step}, {self.curve_max_step}")
        for name in ("max_points", "chunk", "cycle_max_points", "ntst", "ncol", "max_corrector_iters",
                     "curve_max_points"):
            if int(getattr(self, name)) < 1:
                raise ValueError(f"{name} must be a positive integer")
        bad = set(self.locate) - {"LP", "H", "BP"}
        if bad:
            raise ValueError(f"locate: unknown special points {sorted(bad)}; use LP, H, BP")


@dataclass(frozen=True)
class EquilibriumProblem:
    """What to continue: ``system`` with ``values`` (every parameter; the continued one at its start
    value), ``parameter`` over ``bounds``, states measured on ``state_scale``."""

    system: System
    parameter: str
    values: Mapping[str, float]
    bounds: tuple[float, float]
    state_scale: float = 1.0

    def __post_init__(self):
        if self.parameter not in self.system.parameter_names:
            raise ValueError(f"{self.parameter!r} is not a parameter of {self.system.name!r} "
                             f"(it has {list(self.system.parameter_names)})")
        values = dict(zip(self.system.parameter_names, self.system.parameter_vector(self.values)))
        lo, hi = (float(b) for b in self.bounds)
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            raise ValueError(f"range of {self.parameter} must be two finite numbers lo < hi, got {self.bounds}")
        if not lo <= values[self.parameter] <= hi:
            raise ValueError(f"start value {self.parameter} = {values[self.parameter]:g} is outside "
                             f"the range [{lo:g}, {hi:g}]")
        if not (self.state_scale > 0 and math.isfinite(self.state_scale)):
            raise ValueError(f"state_scale must be positive, got {self.state_scale}")
        object.__setattr__(self, "values", MappingProxyType(values))
        object.__setattr__(self, "bounds", (lo, hi))

    @property
    def span(self) -> float:
        return self.bounds[1] - self.bounds[0]

    def at(self, **values) -> "EquilibriumProblem":
        """The same problem with some parameter values changed."""
        return replace(self, values={**self.values, **values})


@dataclass(frozen=True, eq=False)
class ContinuationResult:
    """A branch together with the problem and settings that produced it (so branch switching and
    cycle continuation start from its labelled points, not from PyCont strings)."""

    branch: Branch
    problem: EquilibriumProblem
    settings: ContinuationSettings
    timings: Mapping[str, float] = field(default_factory=dict)

    def special(self, label: str) -> SpecialPoint:
        return self.branch.special(label)


# ================================================================================================
# chart: physical <-> scaled coordinates
# ================================================================================================
@dataclass(frozen=True, eq=False)
class _Chart:
    """Y = (x / xscale, (p_k - base_k) / pscale): the coordinates PyCont sees."""

    system: System
    k: int                   # index of the continued parameter
    base: np.ndarray         # physical parameter vector at lam = 0
    xscale: float
    pscale: float

    @classmethod
    def of(cls, problem: EquilibriumProblem, base_value: float | None = None) -> "_Chart":
        sysm = problem.system
        k = sysm.parameter_names.index(problem.parameter)
        base = sysm.parameter_vector(problem.values)
        if base_value is not None:
            base[k] = base_value
        return cls(sysm, k, base, float(problem.state_scale), float(problem.span))

    def p(self, lam: float) -> np.ndarray:
        p = self.base.copy()
        p[self.k] += self.pscale * lam
        return p

    def value(self, lam: float) -> float:
        return float(self.base[self.k] + self.pscale * lam)

    def lam(self, value: float) -> float:
        return (float(value) - self.base[self.k]) / self.pscale

    def to_phys(self, Y) -> tuple[np.ndarray, np.ndarray]:
        Y = np.asarray(Y, float)
        return Y[:-1] * self.xscale, self.p(Y[-1])

    def to_chart(self, x, value) -> np.ndarray:
        return np.append(np.asarray(x, float) / self.xscale, self.lam(value))

    def F(self, Y) -> np.ndarray:
        x, p = self.to_phys(Y)
        return self.system.f(x, p) / self.xscale

    def DF(self, Y) -> np.ndarray:
        """n x (n+1): [J_x, dF/dlam] in chart units."""
        x, p = self.to_phys(Y)
        J = self.system.jac(x, p)
        Jl = self.system.jac_p(x, p)[:, self.k] * self.pscale / self.xscale
        return np.column_stack([J, Jl])

    def pycont_pars(self, lam0: float = 0.0) -> dict[str, float]:
        pars = self.system.parameter_dict(self.base)
        pars["xscale"] = self.xscale
        for i, name in enumerate(self.system.parameter_names):
            pars[f"d_{name}"] = self.pscale if i == self.k else 0.0
        pars["lam"] = float(lam0)
        return pars

    def point_dict(self, Y) -> dict[str, float]:
        d = {v: float(y) for v, y in zip(self.system.variables, Y[:-1])}
        d["lam"] = float(Y[-1])
        return d


def _tangent(DF: np.ndarray) -> np.ndarray:
    """Unit null vector of the n x (n+1) matrix DF (the branch tangent)."""
    _, _, vt = np.linalg.svd(DF)
    return vt[-1]


def _correct(chart: _Chart, target: np.ndarray, normal: np.ndarray, tol: float, maxiter: int = 25):
    """Newton on F(Y) = 0, normal . (Y - target) = 0, from ``target``. Returns (Y, converged)."""
    Y = np.array(target, dtype=float)
    normal = np.asarray(normal, float)
    for _ in range(maxiter):
        G = np.append(chart.F(Y), normal @ (Y - target))
        A = np.vstack([chart.DF(Y), normal])
        try:
            step = np.linalg.solve(A, G)
        except np.linalg.LinAlgError:
            return Y, False
        Y = Y - step
        if not np.all(np.isfinite(Y)):
            return target, False
        if np.linalg.norm(step) <= tol * (1.0 + np.linalg.norm(Y)):
            return Y, True
    return Y, False


def equilibrium_near(system: System, x0, p, *, tol: float = 1e-12, scale: float = 1.0,
                     maxiter: int = 50) -> tuple[np.ndarray, bool, float]:
    """Newton at fixed parameters from ``x0``: (x, converged, max|f|). The step criterion is relative
    to |x| + ``scale`` (so the trivial solution x = 0 converges too)."""
    x = np.array(x0, dtype=float)
    p = np.asarray(p, float)
    converged = False
    for _ in range(maxiter):
        fx = system.f(x, p)
        try:
            step = np.linalg.solve(system.jac(x, p), fx)
        except np.linalg.LinAlgError:
            break
        x = x - step
        if not np.all(np.isfinite(x)):
            return np.array(x0, float), False, math.inf
        if np.linalg.norm(step) <= tol * (np.linalg.norm(x) + scale):
            converged = True
            break
    res = float(np.max(np.abs(system.f(x, p)))) if x.size else 0.0
    return x, converged, res


def settle(system: System, values: Mapping[str, float], x0, *, scale: float = 1.0,
           chunks: int = 40, patience: int = 4, rtol: float = 1e-9) -> np.ndarray:
    """The stable equilibrium reached by integrating x' = f(x; p) from ``x0``, refined by Newton.

    Integrates (scipy LSODA with the exact Jacobian) in chunks of 25 / (mean damping rate) until the
    Newton step from the current state is below 1e-6 of |x| + ``scale`` and every eigenvalue has a
    negative real part. Raises `StartError` when the orbit leaves a ball of 1e6 (|x0| + ``scale``),
    when the Newton step has not halved for ``patience`` chunks in a row (the orbit is going round
    a cycle, or creeping along a family of equilibria), or after ``chunks`` chunks."""
    from scipy.integrate import solve_ivp

    p = system.parameter_vector(values)
    y = np.array(x0, dtype=float)
    rate = abs(np.trace(system.jac(y, p))) / max(system.dimension, 1)
    if not rate > 0:
        rate = 1.0
    chunk = 25.0 / rate
    bound = 1e6 * (np.linalg.norm(y) + scale)
    t, best, stale = 0.0, math.inf, 0
    start = np.round(np.asarray(x0, float), 12).tolist()
    for _ in range(int(chunks)):
        sol = solve_ivp(lambda _t, z: system.f(z, p), (t, t + chunk), y, method="LSODA",
                        jac=lambda _t, z: system.jac(z, p), rtol=rtol, atol=rtol * scale * 1e-3)
        if sol.status < 0 or not np.all(np.isfinite(sol.y)):
            raise StartError(f"integrating from {start} failed at t = {t:g}: {sol.message}")
        y, t = sol.y[:, -1].copy(), float(sol.t[-1])
        if np.linalg.norm(y) > bound:
            raise StartError(f"integrating from {start}: the orbit diverges "
                             f"(|x| = {np.linalg.norm(y):.3g} at t = {t:g}); start elsewhere")
        J = system.jac(y, p)
        try:
            step = float(np.linalg.norm(np.linalg.solve(J, system.f(y, p))))
        except np.linalg.LinAlgError:
            step = math.inf
        if np.max(np.linalg.eigvals(J).real) < 0 and step <= 1e-6 * (np.linalg.norm(y) + scale):
            x, ok, res = equilibrium_near(system, y, p, scale=scale)
            if ok:
                return x
        if step < 0.5 * best:
            best, stale = step, 0
        else:
            stale += 1
            if stale >= patience:
                break
    a = system.amplitude_values(y)
    raise StartError(f"integrating from {start} did not settle on an equilibrium by "
                     f"t = {t:.6g} (amplitudes now {', '.join(f'{v:.4g}' for v in a)}): the motion may "
                     f"be periodic; start from other amplitudes or from a labelled point")


# ================================================================================================
# test functions
# ================================================================================================
def bialternate(A: np.ndarray) -> np.ndarray:
    """The bialternate product 2A (.) I, of order n(n-1)/2, whose eigenvalues are lambda_i + lambda_j
    (i < j) (Kuznetsov, Sect. 10.2.2; Govaerts, Numerical Methods for Bifurcations, Sect. 4.4.4). Its
    determinant vanishes at Hopf points and neutral saddles."""
    n = A.shape[0]
    pairs = [(p, q) for p in range(1, n) for q in range(p)]
    m = len(pairs)
    B = np.zeros((m, m))
    for a, (p, q) in enumerate(pairs):
        for b, (r, s) in enumerate(pairs):
            if r == q:
                B[a, b] = -A[p, s]
            elif r != p and s == q:
                B[a, b] = A[p, r]
            elif r == p and s == q:
                B[a, b] = A[p, p] + A[q, q]
            elif r == p and s != q:
                B[a, b] = A[q, s]
            elif s == p:
                B[a, b] = -A[q, r]
    return B


def _hopf_test(J: np.ndarray) -> float:
    return float(np.linalg.det(bialternate(J))) if J.shape[0] >= 2 else 1.0


def first_lyapunov(system: System, x, p) -> tuple[float, float]:
    """(l1, omega) at a Hopf point: Kuznetsov's l1 (eq. 3.20, <p, q> = 1, <q, q> = 1), from exact
    derivatives. l1 < 0: supercritical (stable cycles born), l1 > 0: subcritical."""
    x, p = np.asarray(x, float), np.asarray(p, float)
    A = system.jac(x, p)
    n = A.shape[0]
    ev, right = np.linalg.eig(A)
    upper = [j for j in range(n) if ev[j].imag > 0]
    if not upper:
        raise ValueError("no complex eigenvalue pair: not a Hopf point")
    i = min(upper, key=lambda j: abs(ev[j].real))
    w = float(ev[i].imag)
    q = right[:, i] / np.linalg.norm(right[:, i])
    evt, left = np.linalg.eig(A.T)
    pv = left[:, int(np.argmin(np.abs(evt + 1j * w)))]
    pv = pv / np.conj(np.vdot(pv, q))
    H = system.hessian(x, p)
    T = system.third(x, p)

    def B(u, v):
        return np.einsum("ijk,j,k->i", H, u, v)

    def C(u, v, z):
        return np.einsum("ijkl,j,k,l->i", T, u, v, z)

    g = (C(q, q, q.conj()) - 2 * B(q, np.linalg.solve(A, B(q, q.conj())))
         + B(q.conj(), np.linalg.solve(2j * w * np.eye(n) - A, B(q, q))))
    return float(np.real(np.vdot(pv, g)) / (2 * w)), w


# ================================================================================================
# PyCont driving: equilibria
# ================================================================================================
@dataclass
class _Side:
    """Raw output of one PyCont direction (mutable scratch, never returned to users)."""

    points: list
    pycont_special: list          # (type, Y)
    pycont_stab: list             # 'S'/'U'/'N' per point (None when unknown)
    reason: str = "max_points"
    message: str = ""


def _point_Y(chart: _Chart, pt) -> np.ndarray:
    return np.array([float(pt[v]) for v in chart.system.variables] + [float(pt["lam"])])


def _raw_Y(chart: _Chart, curve, row) -> np.ndarray:
    """A row of PyCont's work array (its own variable order: sorted names) in chart order."""
    values = dict(zip(curve.varslist, np.asarray(row)[curve.coords]))
    return np.array([float(values[v]) for v in chart.system.variables] + [float(row[curve.params[0]])])


_CLOSED = re.compile(r"closed curve", re.I)


def _contclass(chart: _Chart, Y0: np.ndarray):
    """A PyCont ContClass on the scaled field at the chart's parameters (None and a message on failure).

    One per continuation call: every direction is its own curve in it."""
    try:
        return continuation_system(chart.system.scaled_field(), "Dopri", ics=chart.point_dict(Y0),
                                   pars=chart.pycont_pars(0.0)), ""
    except Exception as exc:  # noqa: BLE001 - reported in one line
        return None, f"PyCont could not be set up: {_one_line(exc)}"


def _pycont_equilibria(cont, chart: _Chart, problem: EquilibriumProblem, settings: ContinuationSettings,
                       Y0: np.ndarray, direction: np.ndarray, name: str, side_name: str,
                       progress: Progress | None) -> _Side:
    """Continue from Y0 along ``direction`` (a unit vector in chart coordinates) with PyCont EP-C,
    in chunks, until the range ends, the curve closes, the budget is spent or PyCont fails."""
    dst = compat.import_pydstool()
    side = _Side([Y0.copy()], [], [None])
    if cont is None:
        side.reason, side.message = "error", "PyCont is not available for this system"
        return side
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    locate = [t for t in settings.locate if not (t == "H" and chart.system.dimension < 2)]
    cname = f"{name}_{side_name}"
    try:
        with _silent():
            cont.newCurve(dst.args(
                name=cname, type="EP-C", freepars=["lam"], initpoint=chart.point_dict(Y0),
                initdirec={k: float(v) for k, v in zip(list(chart.system.variables) + ["lam"], direction)},
                StepSize=settings.step, MinStepSize=settings.min_step, MaxStepSize=settings.max_step,
                MaxNumPoints=settings.chunk + 1, MaxCorrIters=settings.max_corrector_iters,
                LocBifPoints=locate, SaveEigen=True, verbosity=0, FuncTol=settings.tol,
                VarTol=settings.tol, TestTol=settings.test_tol))
    except Exception as exc:  # noqa: BLE001 - PyCont raises anything; we report it in one line
        side.reason, side.message = "error", f"PyCont could not start: {_one_line(exc)}"
        return side
    curve = cont[cname]
    span_seen = 0.0
    first_call = True
    reported = 0
    while True:
        try:
            with _silent() as chatter:
                curve.forward()
            closed = bool(_CLOSED.search(chatter.text))
            # The first call returns the start point too; later calls only the new points.
            new = list(curve.new_sol_segment)[(1 if first_call else 0):]
            failure = None
        except Exception as exc:  # noqa: BLE001
            closed = False
            # PyCont loses the chunk on failure; its work arrays still hold the converged points.
            raw = np.asarray(getattr(curve, "curve", np.zeros((0, 0))))
            loc = int(getattr(curve, "loc", 0))
            new = [_raw_Y(chart, curve, raw[i]) for i in range(1, max(loc, 1))] \
                if raw.ndim == 2 and raw.shape[1] == Y0.size else []
            failure = exc
        first_call = False
        for pt in new:
            if isinstance(pt, np.ndarray):
                Y, labels, stab = pt, {}, None
            else:
                Y, labels = _point_Y(chart, pt), pt.labels
                stab = labels.get("EP", {}).get("stab") if "EP" in labels else None
            with np.errstate(all="ignore"):
                finite = np.all(np.isfinite(Y)) and np.all(np.isfinite(chart.F(Y)))
            if not finite:
                side.reason = "no_convergence"
                side.message = (f"the equations are not finite beyond {problem.parameter} = "
                                f"{chart.value(side.points[-1][-1]):.6g} (PyCont stepped outside "
                                f"their domain): the branch ends there")
                return side
            for t in ("LP", "H", "BP"):
                if t in labels:
                    side.pycont_special.append((t, Y.copy()))
            side.points.append(Y)
            side.pycont_stab.append(stab)
            span_seen = max(span_seen, float(np.linalg.norm(Y - Y0)))
            # The range: stop at the boundary, put exactly on it by a Newton correction.
            if not lo - 1e-12 <= Y[-1] <= hi + 1e-12:
                prev = side.points[-2]
                bound = hi if Y[-1] > hi else lo
                if abs(prev[-1] - bound) <= 1e-12:
                    side.points.pop()  # the previous point already sits on the boundary
                    side.pycont_stab.pop()
                else:
                    s = (bound - prev[-1]) / (Y[-1] - prev[-1])
                    guess = prev + s * (Y - prev)
                    e = np.zeros_like(Y)
                    e[-1] = 1.0
                    Yb, ok = _correct(chart, guess, e, settings.newton_tol)
                    side.points[-1] = Yb if ok else guess
                    side.pycont_stab[-1] = None
                side.reason = "range"
                side.message = f"{problem.parameter} reached {chart.value(bound):g}"
                return side
            # Closed curve: back at the start after having gone away.
            if len(side.points) > 8 and span_seen > 4 * settings.max_step and \
                    np.linalg.norm(Y - Y0) < 1.5 * settings.max_step:
                side.points.append(Y0.copy())
                side.pycont_stab.append(None)
                side.reason, side.message = "closed", "the branch returned to its start point"
                return side
        if progress and len(side.points) // 100 != reported:
            reported = len(side.points) // 100
            progress(f"{name} ({side_name}): {problem.parameter} = {chart.value(side.points[-1][-1]):.6g}, "
                     f"{len(side.points)} points")
        where = f"{problem.parameter} = {chart.value(side.points[-1][-1]):.6g}"
        if _pycont_end(side, curve, failure, closed, new, where, settings.min_step,
                       settings.max_points, "max_points"):
            return side


@contextlib.contextmanager
def _silent():
    """`compat.quiet` plus no Python warnings: PyCont's numerics warn (ill-conditioned solves at the
    very points it locates) and users should see none of it."""
    with compat.quiet() as chatter, warnings.catch_warnings():
        warnings.simplefilter("ignore")
        yield chatter



def _pycont_end(side, curve, failure, closed, new, where: str, min_step: float, max_points: int,
                max_points_name: str) -> bool:
    """Set ``side.reason``/``side.message`` and return True if PyCont's last call ended the side
    (a failure, a closed curve, an MX point, the point budget, or no progress)."""
    if failure is not None:
        text = _one_line(failure)
        if "converge" in text.lower():
            side.reason = "step_collapse"
            side.message = (f"PyCont's corrector failed near {where} with the minimum step "
                            f"{min_step:g}: {text}")
        else:
            side.reason, side.message = "error", f"PyCont failed: {text}"
        return True
    if closed:
        side.reason, side.message = "closed", "PyCont detected a closed curve"
        return True
    last = curve.sol[-1] if curve.sol is not None and len(curve.sol) else None
    if last is not None and "MX" in last.labels:
        side.reason, side.message = "no_convergence", "PyCont's corrector stopped (MX point)"
        return True
    if len(side.points) >= max_points:
        side.reason = "max_points"
        side.message = f"{len(side.points)} points computed; raise {max_points_name} to go further"
        return True
    if not new:
        side.reason, side.message = "no_convergence", "PyCont returned no new point"
        return True
    return False

def _one_line(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()
    return f"{type(exc).__name__}: {text[0][:200]}" if text else type(exc).__name__


# ================================================================================================
# analysis of a branch of equilibria
# ================================================================================================
def _sign(v: float) -> int:
    return 0 if v == 0 or not math.isfinite(v) else (1 if v > 0 else -1)


def _sign_changes(values: Sequence[float]) -> list[int]:
    """Indices i such that the sign changes between point i and the next point with a nonzero value
    (exact zeros are skipped, so a zero at a point does not count twice)."""
    out = []
    last_i, last_s = None, 0
    for i, v in enumerate(values):
        s = _sign(v)
        if s == 0:
            continue
        if last_s and s != last_s:
            out.append(last_i)
        last_i, last_s = i, s
    return out


def _oriented_tangents(chart: _Chart, Ys: Sequence[np.ndarray]) -> np.ndarray:
    """Branch tangents at every point, oriented along the direction of travel."""
    n = len(Ys)
    T = np.zeros((n, Ys[0].size))
    for i, Y in enumerate(Ys):
        _, sv, vt = np.linalg.svd(chart.DF(Y))
        a, b = max(i - 1, 0), min(i + 1, n - 1)
        chord = Ys[b] - Ys[a]
        v = vt[-1]
        if sv[-1] <= 1e-8 * sv[0] and np.linalg.norm(chord) > 0:
            v = chord / np.linalg.norm(chord)  # on a BP the kernel is 2-D: follow the branch itself
        if i > 0 and abs(v @ chord) <= 1e-3 * np.linalg.norm(chord):
            chord = T[i - 1]  # a chord across a sharp turn or of zero length: follow the last tangent
        T[i] = v if v @ chord >= 0 else -v
    return T


def _locate(chart: _Chart, Ya, Yb, tau: Callable[[np.ndarray], float], tol: float):
    """Zero of ``tau`` on the branch between Ya and Yb: Brent in the chord parameter, each trial point
    corrected onto the branch orthogonally to the chord. Returns (Y, converged)."""
    from scipy.optimize import brentq

    d = Yb - Ya
    cache: dict[float, np.ndarray] = {}

    def point(s: float) -> np.ndarray:
        if s not in cache:
            Y, ok = _correct(chart, Ya + s * d, d, tol)
            cache[s] = Y if ok else Ya + s * d
        return cache[s]

    def g(s: float) -> float:
        return tau(point(s))

    ga, gb = g(0.0), g(1.0)
    if np.isfinite(ga) and np.isfinite(gb) and _sign(ga) * _sign(gb) > 0:
        # PyCont may have put a point on the zero already (its own located point): accept an end
        # whose test value is negligible against the other's.
        small, big, s0 = (abs(ga), abs(gb), 0.0) if abs(ga) <= abs(gb) else (abs(gb), abs(ga), 1.0)
        if small <= 1e-9 * big:
            return point(s0), True
    if not (np.isfinite(ga) and np.isfinite(gb)) or _sign(ga) * _sign(gb) > 0:
        s = 0.5 if ga == gb else min(max(ga / (ga - gb), 0.0), 1.0)
        return point(s), False
    if ga == 0:
        return point(0.0), True
    if gb == 0:
        return point(1.0), True
    s = brentq(g, 0.0, 1.0, xtol=1e-14, rtol=1e-15, maxiter=100)
    return point(s), True


@dataclass(frozen=True)
class _Analysis:
    Ys: tuple
    x: np.ndarray
    p: np.ndarray
    eigen: np.ndarray
    stable: np.ndarray
    special: tuple
    info: dict


def _analyse_equilibria(chart: _Chart, Ys: list[np.ndarray], settings: ContinuationSettings,
                        branch_name: str, pycont_special: Sequence, pycont_stab: Sequence,
                        skip: Sequence[int] = ()) -> _Analysis:
    sysm = chart.system
    n = sysm.dimension
    polished, moved = [], 0
    for Y in Ys:
        x, p = chart.to_phys(Y)
        xp, ok, _ = equilibrium_near(sysm, x, p, tol=settings.newton_tol, scale=chart.xscale, maxiter=8)
        # Keep the point PyCont gave when Newton at fixed parameter wanders (next to a fold).
        if ok and np.linalg.norm(xp - x) <= 1e-6 * (np.linalg.norm(x) + chart.xscale):
            polished.append(chart.to_chart(xp, chart.value(Y[-1])))
        else:
            polished.append(np.asarray(Y, float).copy())
            moved += 1
    Ys = polished
    X = np.array([chart.to_phys(Y)[0] for Y in Ys])
    P = np.array([chart.to_phys(Y)[1] for Y in Ys])
    eig = np.zeros((len(Ys), n), dtype=complex)
    detJ = np.zeros(len(Ys))
    hopf = np.zeros(len(Ys))
    for i in range(len(Ys)):
        J = sysm.jac(X[i], P[i])
        ev = np.linalg.eigvals(J)
        eig[i] = ev[np.lexsort((-ev.imag, -ev.real))]
        detJ[i] = np.linalg.det(J)
        hopf[i] = _hopf_test(J)
    stable = np.max(eig.real, axis=1) < 0 if n else np.ones(len(Ys), bool)
    T = _oriented_tangents(chart, Ys) if len(Ys) > 1 else np.zeros((len(Ys), n + 1))
    vp = T[:, -1]
    # The branch-point test function det([J_x, J_p; v]) changes sign at simple BPs, not at folds.
    bdet = np.array([np.linalg.det(np.vstack([chart.DF(Y), t])) for Y, t in zip(Ys, T)]) \
        if len(Ys) > 1 else np.zeros(len(Ys))
    tests = {"LP": vp, "BP": bdet, "H": hopf}
    skip = set(skip)
    candidates = []
    if "LP" in settings.locate or "BP" in settings.locate:
        candidates += [("LP", i) for i in _sign_changes(vp)]
        candidates += [("BP", i) for i in _sign_changes(bdet)]
    if "H" in settings.locate and n >= 2:
        candidates += [("H", i) for i in _sign_changes(hopf)]
    # A pitchfork's new branch turns in the parameter at the BP it passes through: its vp zero is
    # that BP, not a fold.
    bp_segments = {i for t, i in candidates if t == "BP"}
    candidates = [(t, i) for t, i in candidates if not (t == "LP" and i in bp_segments)]
    found = []
    neutral, rejected = [], []
    for kind, i in sorted(candidates, key=lambda c: c[1]):
        j = i + 1
        while j < len(Ys) - 1 and _sign(tests[kind][j]) == 0:
            j += 1
        if i in skip or j in skip:
            continue
        Ya, Yb = Ys[i], Ys[j]
        ref = Yb - Ya
        if kind == "LP":
            def tau(Y, ref=ref):
                v = _tangent(chart.DF(Y))
                return float(v[-1] if v @ ref >= 0 else -v[-1])
        elif kind == "BP":
            def tau(Y, ref=ref):
                return float(np.linalg.det(np.vstack([chart.DF(Y), ref / np.linalg.norm(ref)])))
        else:
            def tau(Y):
                x, p = chart.to_phys(Y)
                return _hopf_test(sysm.jac(x, p))
        Y, ok = _locate(chart, Ya, Yb, tau, settings.newton_tol)
        x, p = chart.to_phys(Y)
        J = sysm.jac(x, p)
        ev = np.linalg.eigvals(J)
        extra: dict[str, Any] = {"eigenvalues": [complex(e) for e in ev]}
        message = ""
        if kind in ("LP", "BP"):
            # Fold or branch point is decided by the rank of [J_x, J_p]: full at a fold, deficient at
            # a BP (where a pitchfork's new branch also turns in the parameter: vp changes sign there).
            sv = np.linalg.svd(chart.DF(Y), compute_uv=False)
            deficient = sv[-1] <= 1e-7 * sv[0]
            if kind == "BP" and not deficient:
                rejected.append(("BP", chart.value(Y[-1])))
                continue
            kind = "BP" if deficient else "LP"
            extra["rank_test"] = float(sv[-1] / sv[0])
        if kind == "H":
            # Which pair sums to ~0: a complex pair is a Hopf point, a real pair a neutral saddle.
            best, pair = math.inf, None
            for a in range(n):
                for b in range(a + 1, n):
                    s_ = abs(ev[a] + ev[b])
                    if s_ < best:
                        best, pair = s_, (ev[a], ev[b])
            scale_ev = max(np.max(np.abs(ev)), 1e-300)
            if pair is None or abs(pair[0].imag) <= 1e-8 * scale_ev:
                neutral.append(chart.value(Y[-1]))
                continue
            try:
                l1, w = first_lyapunov(sysm, x, p)
                extra.update(l1=l1, omega=w, period=2 * math.pi / w,
                             criticality="supercritical" if l1 < 0 else "subcritical")
            except (np.linalg.LinAlgError, ValueError) as exc:
                extra.update(omega=abs(pair[0].imag), period=2 * math.pi / abs(pair[0].imag))
                message = f"l1 not computed: {exc}"
        if kind == "LP":
            extra["tangent"] = [float(v) for v in _tangent(chart.DF(Y))]
        elif kind == "BP":
            # At a BP the kernel is 2-D: the old branch's direction is the chord across it.
            extra["tangent"] = [float(v) for v in ref / np.linalg.norm(ref)]
        if any(f[0] == kind and np.linalg.norm(f[2] - Y) <= 1e-6 * (1 + np.linalg.norm(Y)) for f in found):
            continue  # the same point seen by two test functions
        if not ok:
            message = (message + "; " if message else "") + "refinement did not bracket a zero: location interpolated"
        found.append((kind, i, Y, ok, extra, message))
    # A pitchfork's new branch turns in the parameter at the BP it crosses; when the vp zero and
    # the BP fall in neighbouring segments the LP found there is that BP again.
    bps = [(f[1], f[2]) for f in found if f[0] == "BP"]
    merged = [f for f in found if f[0] == "LP" and any(abs(f[1] - i) <= 2 or np.linalg.norm(f[2] - b) <= 1e-3
                                                      for i, b in bps)]
    found = [f for f in found if not any(f is m for m in merged)]
    # PyCont's list against ours.
    specials = []
    counters: dict[str, int] = {}
    pyc = [(t, np.asarray(Y, float)) for t, Y in pycont_special]
    used = set()

    def near(i_seg: int, Y, Yp) -> bool:
        a, b = max(i_seg - 1, 0), min(i_seg + 2, len(Ys) - 1)
        scale_ = max(np.linalg.norm(Ys[b] - Ys[a]), 10 * settings.test_tol)
        return np.linalg.norm(Y - Yp) <= scale_

    entries = []
    for kind, i, Y, ok, extra, message in found:
        match = None
        for m, (t, Yp) in enumerate(pyc):
            if m not in used and t == kind and near(i, Y, Yp):
                match = m
                break
        if match is not None:
            used.add(match)
        entries.append((i, kind, Y, ok, match is not None, "autocable", extra,
                        message if match is not None else
                        (message + "; " if message else "") + "not in PyCont's list (PyCont missed it)"))
    for m, (t, Yp) in enumerate(pyc):
        if m in used:
            continue
        i = int(np.argmin([np.linalg.norm(Y - Yp) for Y in Ys]))
        entries.append((i, t, Yp, False, True, "pycont", {},
                        f"PyCont reports {t} here; autocable's test functions change sign nowhere "
                        f"near it: not confirmed (PyCont's point may be spurious)"))
    for i, kind, Y, ok, confirmed, origin, extra, message in sorted(entries, key=lambda e: (e[0], e[1])):
        counters[kind] = counters.get(kind, 0) + 1
        x, p = chart.to_phys(Y)
        amps = sysm.amplitude_values(x)
        specials.append(SpecialPoint(
            branch=branch_name, type=kind, label=f"{kind}{counters[kind]}",
            parameter=sysm.parameter_names[chart.k], value=chart.value(Y[-1]),
            a1=float(amps[0]) if amps else math.nan, a2=float(amps[1]) if len(amps) > 1 else math.nan,
            state=tuple(x), parameters=sysm.parameter_dict(p), index=int(i), converged=bool(ok),
            confirmed_by_pycont=bool(confirmed), origin=origin, message=message, extra=extra))
    disagree = [i for i, s in enumerate(pycont_stab) if s is not None and (s == "S") != bool(stable[i])]
    info = {"pycont_stability_disagreements": len(disagree),
            "pycont_stability_disagreement_points": disagree[:50],
            "pycont_stability_checked": sum(s is not None for s in pycont_stab),
            "neutral_saddles": neutral, "rejected_candidates": rejected,
            "lp_merged_into_bp": [chart.value(f[2][-1]) for f in merged], "points_kept_unpolished": moved}
    return _Analysis(tuple(Ys), X, P, eig, stable, tuple(specials), info)


def _relabel(points: Sequence[SpecialPoint]) -> tuple[SpecialPoint, ...]:
    """Number the labels of each type in branch order (BP0, the switching junction, keeps its name)."""
    counters: dict[str, int] = {}
    out = []
    for s_ in points:
        if s_.label.endswith("0") and s_.label[:-1] == s_.type:
            out.append(s_)
            continue
        counters[s_.type] = counters.get(s_.type, 0) + 1
        out.append(replace(s_, label=f"{s_.type}{counters[s_.type]}"))
    return tuple(out)


def _build_branch(name: str, kind: str, chart: _Chart, X, P, stable, eig, specials, ends, info,
                  extra_columns: Mapping[str, Sequence[float]] | None = None) -> Branch:
    sysm = chart.system
    table: dict[str, Any] = {}
    P = np.asarray(P, float).reshape(len(X), -1)
    for j, pname in enumerate(sysm.parameter_names):
        table[pname] = P[:, j]
    amps = sysm.amplitude_values(np.asarray(X, float).reshape(len(X), -1)) if len(X) else \
        tuple(np.zeros(0) for _ in sysm.amplitudes)
    for a, v in zip(sysm.amplitude_names, amps):
        table[a] = np.asarray(v, float) * np.ones(len(X))
    X = np.asarray(X, float).reshape(len(X), sysm.dimension)
    for j, v in enumerate(sysm.variables):
        table[v] = X[:, j]
    if extra_columns:
        table.update({k: np.asarray(v, float) for k, v in extra_columns.items()})
    return Branch(name=name, kind=kind, parameter=sysm.parameter_names[chart.k],
                  parameter_names=sysm.parameter_names, variables=sysm.variables,
                  amplitude_names=sysm.amplitude_names, table=table, stable=stable,
                  eigenvalues=eig, special_points=specials, ends=ends, info=info)


# ================================================================================================
# public: equilibria
# ================================================================================================
def continue_equilibria(problem: EquilibriumProblem, settings: ContinuationSettings = ContinuationSettings(),
                        start=None, *, name: str = "EQ", directions: str = "both",
                        progress: Progress | None = None) -> ContinuationResult:
    """EP-C of ``problem`` from ``start`` (a state vector, default the zero state), both directions.

    ``start`` is refined by Newton at the start parameter value; a start that does not converge
    raises `StartError`. ``directions`` is ``"both"``, ``"forward"`` (increasing parameter) or
    ``"backward"``. The branch runs from the backward end through the start to the forward end.
    """
    t0 = time.perf_counter()
    sysm = problem.system
    chart = _Chart.of(problem)
    x0 = np.zeros(sysm.dimension) if start is None else np.asarray(start, float)
    if x0.shape != (sysm.dimension,):
        raise StartError(f"start state must have {sysm.dimension} entries {sysm.variables}, got {x0.shape}")
    x, ok, res = equilibrium_near(sysm, x0, chart.p(0.0), tol=settings.newton_tol, scale=chart.xscale)
    if not ok:
        raise StartError(f"Newton from the start state did not converge to an equilibrium at "
                         f"{problem.parameter} = {chart.value(0.0):g} (residual {res:.3g}); start by "
                         f"integration or from a labelled point")
    Y0 = chart.to_chart(x, chart.value(0.0))
    v0 = _tangent(chart.DF(Y0))
    if abs(v0[-1]) > 1e-12:
        v0 = v0 * np.sign(v0[-1])
    sides = {}
    wanted = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]
    cont, why = _contclass(chart, Y0)
    t_setup = time.perf_counter()
    for side in wanted:
        if any(sd.reason == "closed" for sd in sides.values()):
            # The other direction went all the way round: this one would retrace it.
            sides[side] = _Side([Y0], [], [None], "closed", "the branch is a closed curve, "
                                                            "traversed in the other direction")
            continue
        d = v0 if side == "forward" else -v0
        sides[side] = _pycont_equilibria(cont, chart, problem, settings, Y0, d, name, side, progress)
        if cont is None:
            sides[side].message = why
    t1 = time.perf_counter()
    back = sides.get("backward", _Side([Y0], [], [None], "not_run", ""))
    fwd = sides.get("forward", _Side([Y0], [], [None], "not_run", ""))
    Ys = list(reversed(back.points[1:])) + fwd.points
    stab = list(reversed(back.pycont_stab[1:])) + fwd.pycont_stab
    an = _analyse_equilibria(chart, Ys, settings, name, back.pycont_special + fwd.pycont_special, stab)
    ends = (EndPoint("backward", back.reason, chart.value(Ys[0][-1]), len(back.points) - 1, back.message),
            EndPoint("forward", fwd.reason, chart.value(Ys[-1][-1]), len(fwd.points) - 1, fwd.message))
    info = dict(an.info, start_index=len(back.points) - 1, state_scale=chart.xscale)
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem, settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup, "analysis_s": t2 - t1,
                               "points": len(Ys)})


def _resolve(source, label: str | SpecialPoint) -> tuple[SpecialPoint, EquilibriumProblem, ContinuationSettings]:
    if isinstance(label, SpecialPoint):
        sp_ = label
    else:
        sp_ = source.special(label)
    return sp_, source.problem, source.settings


def switch_branch(source: ContinuationResult, bp: str | SpecialPoint,
                  settings: ContinuationSettings | None = None, *, name: str | None = None,
                  progress: Progress | None = None) -> ContinuationResult:
    """The branch crossing ``source`` at its branch point ``bp``, continued on both sides of it.

    At a BP the kernel of [J_x, J_p] is two-dimensional: it holds the old branch's tangent and the
    new one's. The start points are the BP shifted by +-h along the kernel vector orthogonal to the
    old tangent, corrected onto the new branch (Newton on the hyperplane through them, which is
    parallel to the old branch and so cannot fall back on it); each side is then continued away
    from the BP, and the two are joined through the BP."""
    bp, problem, base_settings = _resolve(source, bp)
    settings = settings or base_settings
    if bp.type != "BP":
        raise ValueError(f"{bp.name} is a {bp.type} point, not a branch point")
    name = name or f"{source.branch.name}_{bp.label}"
    t0 = time.perf_counter()
    sysm = problem.system
    chart = _Chart(sysm, sysm.parameter_names.index(problem.parameter),
                   sysm.parameter_vector(bp.parameters), problem.state_scale, problem.span)
    Yb = chart.to_chart(bp.state, bp.value)
    _, s, vt = np.linalg.svd(chart.DF(Yb))
    kernel = vt[-2:]
    old = np.asarray(bp.extra.get("tangent", kernel[0]), float)
    old = kernel.T @ (kernel @ old)
    old /= np.linalg.norm(old)
    w = kernel[0] - (kernel[0] @ old) * old
    if np.linalg.norm(w) < 1e-8:
        w = kernel[1] - (kernel[1] @ old) * old
    w /= np.linalg.norm(w)
    sides = {}
    cont, why = _contclass(chart, Yb)
    t_setup = time.perf_counter()
    for sign, side in ((1, "+"), (-1, "-")):
        if any(sd.reason == "closed" for sd in sides.values()):
            sides[side] = _Side([Yb], [], [None], "closed", "the new branch is a closed curve through "
                                                            f"{bp.name}, traversed from the other side")
            continue
        target = Yb + sign * settings.switch_step * w
        Ys, ok = _correct(chart, target, w, settings.newton_tol)
        if not ok or np.linalg.norm(Ys - Yb) > 10 * settings.switch_step:
            sides[side] = _Side([Yb], [], [None], "no_convergence",
                                f"no branch found at distance {settings.switch_step:g} from {bp.name}: "
                                f"try another switch_step")
            continue
        v = _tangent(chart.DF(Ys))
        v = v if v @ (Ys - Yb) >= 0 else -v
        lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
        if not lo <= Ys[-1] <= hi:
            sides[side] = _Side([Yb], [], [None], "range", "the new branch leaves the range at once")
            continue
        sd = _pycont_equilibria(cont, chart, problem, settings, Ys, v, name, "plus" if sign > 0 else "minus",
                                progress)
        if cont is None:
            sd.message = why
        sd.points.insert(0, Yb.copy())
        sd.pycont_stab.insert(0, None)
        sides[side] = sd
    t1 = time.perf_counter()
    minus, plus = sides["-"], sides["+"]
    Ys = list(reversed(minus.points[1:])) + plus.points
    stab = list(reversed(minus.pycont_stab[1:])) + plus.pycont_stab
    ib = len(minus.points) - 1
    # The junction is the BP itself: the parameter turns there on a pitchfork's new branch, which is
    # not a fold; it is recorded as the branch point below.
    an = _analyse_equilibria(chart, Ys, settings, name, minus.pycont_special + plus.pycont_special, stab,
                             skip=(ib,))
    junction = SpecialPoint(
        branch=name, type="BP", label="BP0", parameter=bp.parameter, value=bp.value, a1=bp.a1, a2=bp.a2,
        state=bp.state, parameters=bp.parameters, index=ib, converged=bp.converged,
        confirmed_by_pycont=None, origin="autocable", message=f"the branch point {bp.name} this branch was switched from",
        extra={"switched_from": bp.name})
    Ys_, junction_Y = an.Ys, Yb
    # The junction BP may be seen again by the test functions (and by PyCont): it is BP0.
    others = tuple(s_ for s_ in an.special if not (
        s_.type in ("BP", "LP")
        and np.linalg.norm(chart.to_chart(s_.state, s_.value) - junction_Y) <= 0.5 * settings.switch_step))
    an = replace(an, special=_relabel(tuple(sorted((junction,) + others, key=lambda s_: s_.index))))
    ends = (EndPoint("-", minus.reason, chart.value(Ys[0][-1]), len(minus.points) - 1, minus.message),
            EndPoint("+", plus.reason, chart.value(Ys[-1][-1]), len(plus.points) - 1, plus.message))
    info = dict(an.info, switched_from=bp.name, bp_index=ib, state_scale=chart.xscale)
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    prob = problem.at(**{problem.parameter: bp.value})
    return ContinuationResult(branch, prob, settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup,
                               "analysis_s": time.perf_counter() - t1, "points": len(Ys)})


# ================================================================================================
# public: cycles
# ================================================================================================
def _monodromy(system: System, x0, p, T: float, rtol: float, samples: int = 400):
    """Integrate x' = f, Phi' = J Phi over one period: (Phi(T), x(T), dense samples of x)."""
    from scipy.integrate import solve_ivp

    n = system.dimension

    def rhs(_t, z):
        x = z[:n]
        Phi = z[n:].reshape(n, n)
        return np.concatenate([system.f(x, p), (system.jac(x, p) @ Phi).ravel()])

    if T <= 0 or not np.any(np.asarray(x0) != 0) and not np.any(system.f(x0, p)):
        # A degenerate cycle (the Hopf point itself): the monodromy of an equilibrium is exp(J T).
        from scipy.linalg import expm
        x0 = np.asarray(x0, float)
        return expm(system.jac(x0, p) * T), x0.copy(), np.tile(x0, (samples + 1, 1))
    z0 = np.concatenate([np.asarray(x0, float), np.eye(n).ravel()])
    ts = np.linspace(0.0, T, samples + 1)
    sol = solve_ivp(rhs, (0.0, T), z0, method="DOP853", t_eval=ts, rtol=rtol,
                    atol=rtol * (np.max(np.abs(x0)) + 1e-300) * 1e-2)
    if sol.status < 0 or sol.y.shape[1] != len(ts):
        raise RuntimeError(sol.message)
    return sol.y[n:, -1].reshape(n, n), sol.y[:n, -1], sol.y[:n].T


def _crossing_distance(mults: np.ndarray, kind: str) -> float:
    """Signed distance to the unit circle of the non-trivial multiplier that crosses it at an
    LPC (real, through +1), PD (real, through -1) or NS (complex pair)."""
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    real = np.abs(rest.imag) < 1e-7
    if kind == "LPC":
        d = rest[real].real - 1.0
    elif kind == "PD":
        d = -rest[real].real - 1.0
    else:
        d = np.abs(rest[~real]) - 1.0
    return float(d[np.argmin(np.abs(d))]) if d.size else 1.0


def _cycle_counts(mults: np.ndarray) -> tuple[int, int, int]:
    """(real > 1, real < -1, complex outside) counts of the non-trivial multipliers."""
    if mults.size == 0 or not np.all(np.isfinite(mults)):
        return (-1, -1, -1)
    rest = np.delete(mults, int(np.argmin(np.abs(mults - 1.0))))
    tol = 1e-7
    real = np.abs(rest.imag) <= tol * np.maximum(np.abs(rest), 1.0)
    return (int(np.sum(real & (rest.real > 1))), int(np.sum(real & (rest.real < -1))),
            int(np.sum(~real & (np.abs(rest) > 1))))


def continue_cycles(source: ContinuationResult, hopf: str | SpecialPoint,
                    settings: ContinuationSettings | None = None, *, name: str | None = None,
                    progress: Progress | None = None) -> ContinuationResult:
    """Periodic orbits born at the Hopf point ``hopf`` of ``source`` (PyCont LC-C, AUTO collocation
    with ``ntst`` intervals of ``ncol`` points), in the continued parameter's range.

    Per cycle: the period, the min/max of every amplitude over the cycle (from a dense integration of
    one period started on AUTO's profile), the Floquet multipliers from the variational equations
    over that period (cross-checked with AUTO's: ``info["auto_multiplier_max_diff"]``), stability
    (every non-trivial multiplier inside the unit circle), and LPC/PD/NS from multiplier crossings.
    The branch ends at the range, at ``cycle_max_points``, when AUTO fails (NaNs) or when the period
    exceeds ``max_period_ratio`` times the Hopf period (a homoclinic approach, Sect. 5)."""
    hp, problem, base_settings = _resolve(source, hopf)
    settings = settings or base_settings
    if hp.type != "H":
        raise ValueError(f"{hp.name} is a {hp.type} point, not a Hopf point")
    name = name or f"{source.branch.name}_{hp.label}_cycles"
    sysm = problem.system
    t0 = time.perf_counter()
    chart = _Chart(sysm, sysm.parameter_names.index(problem.parameter),
                   sysm.parameter_vector(hp.parameters), problem.state_scale, problem.span)
    YH = chart.to_chart(hp.state, hp.value)
    T_H = float(hp.extra.get("period", math.nan))
    dst = compat.import_pydstool()
    vf = sysm.scaled_field()
    reason, message = "max_points", ""
    pts = []
    try:
        cont = continuation_system(vf, "Dopri", ics=chart.point_dict(YH), pars=chart.pycont_pars(0.0), auto=True)
        with compat.pydstool_session(f"continuing cycles from {hp.name}", pydstool_cache_dir()), \
                warnings.catch_warnings():
            warnings.simplefilter("ignore")
            cont.newCurve(dst.args(
                name="LC", type="LC-C", initpoint=chart.point_dict(YH), freepars=["lam"],
                StepSize=settings.cycle_step, MinStepSize=settings.min_step,
                MaxStepSize=settings.cycle_max_step, MaxNumPoints=settings.cycle_max_points,
                NumIntervals=settings.ntst, NumCollocation=settings.ncol, NumSPOut=1,
                SolutionMeasures=["max", "min"], SaveEigen=True, LocBifPoints=["LPC", "PD", "NS"],
                verbosity=0, FuncTol=settings.tol, VarTol=settings.tol, TestTol=settings.test_tol))
            cont["LC"].forward()
        pts = list(cont["LC"].sol)
    except Exception as exc:  # noqa: BLE001
        reason, message = "error", f"AUTO's cycle continuation failed: {_one_line(exc)}"
    t1 = time.perf_counter()
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    rows, auto_labels = [], []
    for i, pt in enumerate(pts):
        lam, T = float(pt["lam"]), float(pt["_T"])
        cyc = next((v["cycle"] for v in pt.labels.values() if isinstance(v, dict) and "cycle" in v), None)
        if "MX" in pt.labels or not (math.isfinite(lam) and math.isfinite(T)):
            reason, message = "no_convergence", "AUTO stopped with NaNs (MX point)"
            break
        if not lo - 1e-12 <= lam <= hi + 1e-12:
            reason, message = "range", f"{problem.parameter} left the range"
            break
        if math.isfinite(T_H) and T > settings.max_period_ratio * T_H:
            reason = "period_blowup"
            message = (f"the period reached {T:.4g} (> {settings.max_period_ratio:g} x the Hopf period "
                       f"{T_H:.4g}) at {problem.parameter} = {chart.value(lam):.6g}: a homoclinic orbit "
                       f"is near; lower cycle_max_step to approach it more closely")
            break
        auto_ev = None
        lc = pt.labels.get("LC", {})
        if isinstance(lc, dict) and "data" in lc and "evals" in lc["data"]:
            auto_ev = np.asarray(lc["data"].evals, dtype=complex)
        for t in ("LPC", "PD", "NS"):
            if t in pt.labels:
                auto_labels.append((t, len(rows)))
        rows.append((lam, T, cyc, auto_ev))
        if progress and i % 10 == 0:
            progress(f"{name}: {problem.parameter} = {chart.value(lam):.6g}, period {T:.4g}, {len(rows)} cycles")
    n = sysm.dimension
    X, P, mults, stable, cols = [], [], [], [], {c: [] for c in ("period", "a1_min", "a1_max", "a2_min", "a2_max")}
    auto_diff, closure = [], []
    for lam, T, cyc, auto_ev in rows:
        p = chart.p(lam)
        if cyc is not None:
            prof = np.column_stack([np.asarray(cyc[v], float) for v in sysm.variables]) * chart.xscale
        else:
            prof = np.array([chart.to_phys(YH)[0]])
        x0 = prof[0]
        try:
            Phi, xT, dense = _monodromy(sysm, x0, p, T, settings.floquet_rtol)
            mu = np.linalg.eigvals(Phi)
            size = np.max(np.ptp(prof, axis=0)) if len(prof) > 1 else 0.0
            err = float(np.linalg.norm(xT - x0) / max(size, 1e-300 + chart.xscale * 1e-12))
            samples = np.vstack([dense, prof]) if err < 1e-3 else prof
        except (RuntimeError, ValueError, np.linalg.LinAlgError):
            mu = auto_ev if auto_ev is not None else np.full(n, np.nan + 0j)
            err, samples = math.inf, prof
        closure.append(err)
        mu = mu[np.argsort(-np.abs(mu))]
        if auto_ev is not None and auto_ev.size == mu.size and np.all(np.isfinite(auto_ev)):
            a = np.sort_complex(auto_ev)
            b = np.sort_complex(mu)
            auto_diff.append(float(np.max(np.abs(a - b))))
        amps = sysm.amplitude_values(samples)
        for k, a in enumerate(amps[:2]):
            a = np.asarray(a) * np.ones(len(samples))
            cols[f"a{k + 1}_min"].append(float(np.min(a)))
            cols[f"a{k + 1}_max"].append(float(np.max(a)))
        for k in range(len(amps), 2):
            cols[f"a{k + 1}_min"].append(math.nan)
            cols[f"a{k + 1}_max"].append(math.nan)
        cols["period"].append(T)
        X.append(x0)
        P.append(p)
        mults.append(mu)
        m = stability_measure("cycle", mu)
        stable.append(bool(math.isfinite(m) and m < 1.0))
    # Bifurcations of cycles from multiplier crossings, compared with AUTO's labels.
    specials = []
    counts = [_cycle_counts(m) for m in mults]
    counters: dict[str, int] = {}
    used = set()
    for i in range(len(rows) - 1):
        c0, c1 = counts[i], counts[i + 1]
        if -1 in c0 or -1 in c1 or i == 0:
            continue  # the first point is the Hopf point itself (a degenerate cycle)
        for slot, kind in enumerate(("LPC", "PD", "NS")):
            if c0[slot] == c1[slot]:
                continue
            match = next((m for m, (t, j) in enumerate(auto_labels)
                          if m not in used and t == kind and abs(j - (i + 0.5)) <= 2), None)
            if match is not None:
                used.add(match)
            counters[kind] = counters.get(kind, 0) + 1
            # Linear interpolation in the distance of the crossing multiplier to the unit circle.
            d0, d1 = _crossing_distance(mults[i], kind), _crossing_distance(mults[i + 1], kind)
            s = d0 / (d0 - d1) if d0 != d1 else 0.5
            s = min(max(s, 0.0), 1.0)
            x = (1 - s) * X[i] + s * X[i + 1]
            p = (1 - s) * P[i] + s * P[i + 1]
            amps = [(1 - s) * cols[f"a{k}_max"][i] + s * cols[f"a{k}_max"][i + 1] for k in (1, 2)]
            specials.append(SpecialPoint(
                branch=name, type=kind, label=f"{kind}{counters[kind]}", parameter=problem.parameter,
                value=float(p[chart.k]), a1=amps[0], a2=amps[1], state=tuple(x),
                parameters=sysm.parameter_dict(p), index=i, converged=False,
                confirmed_by_pycont=match is not None, origin="autocable",
                message="located by linear interpolation of the crossing multiplier between two cycles"
                        + ("" if match is not None else "; not in AUTO's list (AUTO missed it)"),
                extra={"period": (1 - s) * cols["period"][i] + s * cols["period"][i + 1],
                       "multipliers": [complex(z) for z in mults[i + 1]]}))
    for m, (t, j) in enumerate(auto_labels):
        if m in used or j >= len(X):
            continue
        counters[t] = counters.get(t, 0) + 1
        specials.append(SpecialPoint(
            branch=name, type=t, label=f"{t}{counters[t]}", parameter=problem.parameter,
            value=float(P[j][chart.k]), a1=cols["a1_max"][j], a2=cols["a2_max"][j], state=tuple(X[j]),
            parameters=sysm.parameter_dict(P[j]), index=j, converged=False, confirmed_by_pycont=True,
            origin="pycont", message=f"AUTO reports {t} here; autocable's multipliers show no crossing"))
    specials.sort(key=lambda s_: s_.index)
    if rows and reason == "max_points" and len(rows) < settings.cycle_max_points:
        reason, message = "no_convergence", "AUTO stopped before the point budget (see AUTO's limits)"
    side = EndPoint("forward", reason, chart.value(rows[-1][0]) if rows else hp.value, len(rows), message)
    info = {"from": hp.name, "hopf_period": T_H, "closure_error_max": max(closure) if closure else None,
            "auto_multiplier_max_diff": max(auto_diff) if auto_diff else None, "ntst": settings.ntst,
            "ncol": settings.ncol}
    X = np.array(X, float).reshape(len(X), n)
    P = np.array(P, float).reshape(len(X), len(sysm.parameters))
    ev = np.array(mults, dtype=complex).reshape(len(X), n) if mults else np.zeros((0, n), complex)
    branch = _build_branch(name, "cycle", chart, X, P, np.array(stable, bool), ev, tuple(specials), (side,),
                           info, extra_columns=cols)
    # For cycles the a1, a2 columns hold the maxima over the cycle (the plotted upper envelope).
    table = dict(branch.table)
    for k in (1, 2):
        if f"a{k}" in table:
            table[f"a{k}"] = np.asarray(cols[f"a{k}_max"], float)
    branch = branch.replace(table=table)
    return ContinuationResult(branch, problem, settings,
                              {"auto_s": t1 - t0, "analysis_s": time.perf_counter() - t1, "points": len(rows)})


# ================================================================================================
# benchmark
# ================================================================================================
def bench_continuation(model: str = "models/luongo_zulli_2012.toml", *, repeats: int = 3,
                       cold: bool = True, progress: Progress | None = None) -> dict:
    """Per-point EP-C cost on the sample AME and the total time of a Fig. 6-sized scene.

    Warm: in this process, after one untimed run (builds loaded). Cold (``cold=True``): the same
    scene in a fresh process with an empty cache folder (derivation, AME, both compiled libraries
    built from scratch). Returns plain numbers (seconds)."""
    import os
    import subprocess
    import sys
    import tempfile

    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.spec import load_model

    def say(msg):
        if progress:
            progress(msg)

    t0 = time.perf_counter()
    ame = derive_ame(derive(load_model(model))).ame
    system = ame_system(ame, "2dof", wind=False)
    t_model = time.perf_counter() - t0
    problem = EquilibriumProblem(system, "sigma", {"sigma": -0.05, "U": 0.0, "eta": 1.4e-3},
                                 (-0.05, 0.05), state_scale=_auto_scale(system, {"sigma": 0.0, "U": 0.0, "eta": 1.4e-3}))
    settings = ContinuationSettings()
    say("bench: EP-C on the sample AME (warm-up)")
    continue_equilibria(problem, settings, name="I", directions="forward")
    per_point, totals = [], []
    for _ in range(repeats):
        r = continue_equilibria(problem, settings, name="I", directions="forward")
        per_point.append(r.timings["pycont_s"] / max(r.timings["points"] - 1, 1))
        analysis = r.timings["analysis_s"] / max(r.timings["points"], 1)
    for _ in range(max(1, repeats - 1)):
        t = time.perf_counter()
        r = continue_equilibria(problem, settings, name="I")
        for bp in r.branch.of_type("BP"):
            switch_branch(r, bp.label)
        totals.append(time.perf_counter() - t)
    out = {"ep_c_seconds_per_point": min(per_point), "analysis_seconds_per_point": analysis,
           "setup_seconds_per_branch": r.timings.get("setup_s"),
           "points": int(r.timings["points"]), "fig6_scene_warm_s": min(totals),
           "model_and_ame_s": t_model, "branch_points": len(r.branch.of_type("BP"))}
    if cold:
        say("bench: Fig. 6-sized scene, cold cache (fresh process, builds from scratch)")
        code = ("import time,sys; t=time.perf_counter();"
                "from autocable.methods.continuation import _bench_scene;"
                f"_bench_scene({model!r}); print(time.perf_counter()-t)")
        with tempfile.TemporaryDirectory(prefix="autocable-bench-") as tmp:
            env = {**os.environ, "AUTOCABLE_CACHE": tmp}
            t = time.perf_counter()
            done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True)
            out["fig6_scene_cold_s"] = time.perf_counter() - t if done.returncode == 0 else math.nan
            if done.returncode != 0:
                out["cold_error"] = done.stderr.strip().splitlines()[-1:] or ["failed"]
    return out


def _bench_scene(model: str) -> None:
    from autocable.model.ame_cache import derive_ame
    from autocable.model.derive import derive
    from autocable.spec import load_model

    ame = derive_ame(derive(load_model(model))).ame
    system = ame_system(ame, "2dof", wind=False)
    vals = {"sigma": -0.05, "U": 0.0, "eta": 1.4e-3}
    problem = EquilibriumProblem(system, "sigma", vals, (-0.05, 0.05),
                                 state_scale=_auto_scale(system, {**vals, "sigma": 0.0}))
    r = continue_equilibria(problem, ContinuationSettings(), name="I")
    for bp in r.branch.of_type("BP"):
        switch_branch(r, bp.label)


def _auto_scale(system: System, values: Mapping[str, float]) -> float:
    """A state scale for the AME: the linear resonance amplitude |forcing| / (mean damping rate) at
    the given parameters (the size of the forced response), else 1e-2."""
    p = system.parameter_vector(values)
    x0 = np.zeros(system.dimension)
    forcing = float(np.linalg.norm(system.f(x0, p)))
    rate = abs(np.trace(system.jac(x0, p))) / max(system.dimension, 1)
    if forcing > 0 and rate > 0:
        return forcing / rate
    return 1e-2


auto_state_scale = _auto_scale


# ================================================================================================
# public: two-parameter curves of folds (LP-C) and of Hopf points (H-C2)
# ================================================================================================
#: PyDSTool generator behind LP-C/H-C2: "Dopri" compiles the scaled field once (cached by content hash).
_CURVE_GENERATOR = "Dopri"
#: PyCont's bordered test functions draw random borders from numpy's global generator: seeded
#: (and the caller's state restored) so that a curve is the same on every run.
_PYCONT_SEED = 1729
#: kind -> (the special-point type it starts from, PyCont's curve type, PyCont's labels on it)
_CURVES = MappingProxyType({"fold": ("LP", "LP-C", ("CP", "BT", "ZH")),
                            "hopf": ("H", "H-C2", ("BT", "ZH", "GH"))})


@dataclass(frozen=True, eq=False)
class _CurveChart:
    """Y = (x / xscale, lam, lam2): p[k1] = base[k1] + s1 lam, p[k2] = base[k2] + s2 lam2, time scaled
    by ``tscale`` (so the Jacobian PyCont sees is O(1) even for a slow flow like the AME).

    The defining system of the curve, autocable's own: F~ = tscale f / xscale = 0 and g = 0, g the
    bordered test function (Govaerts, Numerical Methods for Bifurcations, Sect. 3.4; Kuznetsov,
    Sect. 10.2) of M = tscale J (folds) or of its bialternate product 2M (.) I (Hopf points and
    neutral saddles), with borders fixed at `at`. ``F`` and ``DF`` have the shapes `_correct` and
    `_locate` expect: (n+1) equations in n+2 unknowns."""

    system: System
    kind: str
    k1: int
    k2: int
    base: np.ndarray
    xscale: float
    s1: float
    s2: float
    tscale: float
    border: tuple | None = None

    def p(self, Y) -> np.ndarray:
        p = self.base.copy()
        p[self.k1] += self.s1 * Y[-2]
        p[self.k2] += self.s2 * Y[-1]
        return p

    def to_phys(self, Y) -> tuple[np.ndarray, np.ndarray]:
        Y = np.asarray(Y, float)
        return Y[:-2] * self.xscale, self.p(Y)

    def to_chart(self, x, p) -> np.ndarray:
        return np.concatenate([np.asarray(x, float) / self.xscale,
                               [(p[self.k1] - self.base[self.k1]) / self.s1,
                                (p[self.k2] - self.base[self.k2]) / self.s2]])

    def values(self, Y) -> tuple[float, float]:
        p = self.p(np.asarray(Y, float))
        return float(p[self.k1]), float(p[self.k2])

    def lam(self, which: int, value: float) -> float:
        k, s = (self.k1, self.s1) if which == 1 else (self.k2, self.s2)
        return (float(value) - self.base[k]) / s

    def jac(self, Y) -> np.ndarray:
        return self.system.jac(*self.to_phys(Y))

    def matrix(self, Y) -> np.ndarray:
        A = self.tscale * self.jac(Y)
        return A if self.kind == "fold" else bialternate(A)

    def at(self, Y) -> "_CurveChart":
        """This chart with the borders of the test function taken at Y (singular vectors of the
        smallest singular value of M: the bordered matrix is then regular near Y)."""
        U, _, Vt = np.linalg.svd(self.matrix(Y))
        return replace(self, border=(U[:, -1].copy(), Vt[-1].copy()))

    def g(self, Y) -> float:
        M = self.matrix(Y)
        b, c = self.border
        m = M.shape[0]
        A = np.zeros((m + 1, m + 1))
        A[:m, :m], A[:m, m], A[m, :m] = M, b, c
        rhs = np.zeros(m + 1)
        rhs[m] = 1.0
        return float(np.linalg.solve(A, rhs)[m])

    def F(self, Y) -> np.ndarray:
        if self.border is None:
            return self.at(Y).F(Y)
        x, p = self.to_phys(Y)
        return np.append(self.tscale * self.system.f(x, p) / self.xscale, self.g(Y))

    def DF(self, Y) -> np.ndarray:
        Y = np.asarray(Y, float)
        if self.border is None:
            return self.at(Y).DF(Y)
        x, p = self.to_phys(Y)
        J, Jp = self.system.jac(x, p), self.system.jac_p(x, p)
        top = np.column_stack([self.tscale * J, self.tscale * Jp[:, self.k1] * self.s1 / self.xscale,
                               self.tscale * Jp[:, self.k2] * self.s2 / self.xscale])
        h = 1e-6
        grad = np.zeros(Y.size)
        for j in range(Y.size):
            e = np.zeros(Y.size)
            e[j] = h
            grad[j] = (self.g(Y + e) - self.g(Y - e)) / (2 * h)
        return np.vstack([top, grad])

    def pycont_pars(self) -> dict[str, float]:
        pars = self.system.parameter_dict(self.base)
        pars.update(xscale=self.xscale, tscale=self.tscale, lam=0.0, lam2=0.0)
        for i, name in enumerate(self.system.parameter_names):
            pars[f"d_{name}"] = self.s1 if i == self.k1 else 0.0
            pars[f"d2_{name}"] = self.s2 if i == self.k2 else 0.0
        return pars

    def point_dict(self, Y) -> dict[str, float]:
        d = {v: float(y) for v, y in zip(self.system.variables, Y[:-2])}
        d["lam"], d["lam2"] = float(Y[-2]), float(Y[-1])
        return d


def _critical_pair(ev: np.ndarray) -> tuple[int, int]:
    """The pair of eigenvalues whose sum is nearest to zero (the Hopf pair, or a neutral saddle's)."""
    n = len(ev)
    best, pair = math.inf, (0, min(1, n - 1))
    for a in range(n):
        for b in range(a + 1, n):
            s_ = abs(ev[a] + ev[b])
            if s_ < best:
                best, pair = s_, (a, b)
    return pair


def _pair_sum_product(ev: np.ndarray) -> float:
    """Real part of the product of lambda_i + lambda_j over the pairs of ``ev`` (real for a real
    matrix's spectrum): it changes sign when a pair's sum crosses zero."""
    out = 1.0 + 0j
    for a in range(len(ev)):
        for b in range(a + 1, len(ev)):
            out *= ev[a] + ev[b]
    return float(out.real)


def _hopf_check(ev: np.ndarray, scale: float | None = None) -> tuple[float, float, float]:
    """(kappa, omega, residual) of the critical pair: kappa = lambda_a lambda_b (omega^2 > 0 for a
    Hopf pair, < 0 for a neutral saddle), omega its imaginary part, residual = |Re| / scale (inf
    when the pair is real: not on the imaginary axis). ``scale``: the Jacobian's norm (default
    max |lambda|; near a Bogdanov-Takens point every eigenvalue is small, the norm is not)."""
    a, b = _critical_pair(ev)
    scale = max(float(np.max(np.abs(ev))) if scale is None else float(scale), 1e-300)
    kappa = float((ev[a] * ev[b]).real)
    if abs(ev[a].imag) <= 1e-8 * scale:
        return kappa, 0.0, math.inf
    return kappa, abs(float(ev[a].imag)), abs(float(ev[a].real)) / scale


def _fold_check(J: np.ndarray) -> float:
    """sigma_min / sigma_max of J: 0 exactly where det J = 0 (scale-free)."""
    sv = np.linalg.svd(J, compute_uv=False)
    return float(sv[-1] / sv[0]) if sv[0] > 0 else 0.0


def _oriented_null(J: np.ndarray, ref=None) -> tuple[np.ndarray, np.ndarray]:
    """Right (v) and left (w) singular vectors of J's smallest singular value, signs following ``ref``."""
    U, _, Vt = np.linalg.svd(J)
    v, w = Vt[-1].copy(), U[:, -1].copy()
    if ref is not None:
        if v @ ref[0] < 0:
            v = -v
        if w @ ref[1] < 0:
            w = -w
    return v, w


def _curve_tests(chart: _CurveChart, Y, ref=None) -> tuple[dict[str, float], tuple]:
    """autocable's test functions of codimension-2 points at Y (physical Jacobian and derivatives).

    Folds: CP = w . B(v, v) (the fold's quadratic normal-form coefficient), BT = w . v (zero when the
    zero eigenvalue becomes double), ZH = the pair-sum product of the other eigenvalues (n >= 3).
    Hopf: BT = kappa = lambda_a lambda_b of the critical pair (omega^2; negative beyond BT), GH = the
    first Lyapunov coefficient, ZH = det J, DH = the pair-sum product of the other eigenvalues
    (n >= 4). Returns the values and the oriented null vectors (for the next point's signs)."""
    sysm = chart.system
    x, p = chart.to_phys(Y)
    J = sysm.jac(x, p)
    ev = np.linalg.eigvals(J)
    n = len(ev)
    out: dict[str, float] = {}
    vw = None
    if chart.kind == "fold":
        v, w = _oriented_null(J, ref)
        vw = (v, w)
        B = np.einsum("ijk,j,k->i", sysm.hessian(x, p), v, v)
        out["CP"] = float(w @ B)
        out["BT"] = float(w @ v)
        if n >= 3:
            rest = np.delete(ev, int(np.argmin(np.abs(ev))))
            out["ZH"] = _pair_sum_product(rest)
    else:
        kappa, omega, _ = _hopf_check(ev, np.linalg.norm(J))
        out["BT"] = kappa
        out["ZH"] = float(np.linalg.det(J))
        if omega > 0:
            try:
                out["GH"] = first_lyapunov(sysm, x, p)[0]
            except (np.linalg.LinAlgError, ValueError):
                out["GH"] = math.nan
        else:
            out["GH"] = math.nan
        if n >= 4:
            a, b = _critical_pair(ev)
            out["DH"] = _pair_sum_product(np.delete(ev, [a, b]))
    return out, vw


def _classify_curve_point(chart: _CurveChart, kind: str, Y) -> tuple[bool, str, dict]:
    """Is the zero of test function ``kind`` at Y really that point? The eigenvalues decide.
    Returns (accepted, why-not, extra data)."""
    x, p = chart.to_phys(Y)
    J = chart.system.jac(x, p)
    ev = np.linalg.eigvals(J)
    scale = max(float(np.linalg.norm(J)), 1e-300)
    small = np.sort(np.abs(ev))
    extra: dict[str, Any] = {"eigenvalues": [complex(e) for e in ev]}
    if kind == "BT":
        ok = len(ev) >= 2 and small[1] <= 1e-4 * scale
        return ok, "" if ok else f"no double zero eigenvalue (second smallest |lambda| = {small[1]:.3g})", extra
    if kind == "CP":
        return True, "", extra
    if chart.kind == "fold" and kind == "ZH":
        rest = np.delete(ev, int(np.argmin(np.abs(ev))))
        a, b = _critical_pair(rest)
        if abs(rest[a].imag) <= 1e-8 * scale:
            return False, "the other eigenvalues have a real pair (lambda, -lambda): a neutral saddle, not zero-Hopf", extra
        extra["omega"] = abs(float(rest[a].imag))
        return True, "", extra
    if kind == "GH":
        kappa, omega, _ = _hopf_check(ev, scale)
        extra["omega"] = omega
        return omega > 0, "" if omega > 0 else "the critical pair is real here", extra
    if kind == "ZH":   # on a Hopf curve: a real eigenvalue through zero
        a, b = _critical_pair(ev)
        rest = np.delete(ev, [a, b])
        kappa, omega, _ = _hopf_check(ev, scale)
        ok = omega > 0 and rest.size > 0 and np.min(np.abs(rest)) <= 1e-6 * scale
        extra["omega"] = omega
        return ok, "" if ok else "no simple zero eigenvalue beside the Hopf pair", extra
    if kind == "DH":
        a, b = _critical_pair(ev)
        rest = np.delete(ev, [a, b])
        c, d = _critical_pair(rest)
        ok = abs(rest[c].imag) > 1e-8 * scale
        extra["omega2"] = abs(float(rest[c].imag))
        return ok, "" if ok else "the second pair is real: a Hopf-neutral saddle, not a double Hopf point", extra
    return False, f"unknown point type {kind}", extra


def _kappa_direction(chart: _CurveChart, Y: np.ndarray, t: np.ndarray) -> float:
    """d(omega^2)/ds along the unit tangent t at Y, omega^2 as PyCont's H-C2 sees it (scaled time)."""
    def kap(Z):
        return _hopf_check(np.linalg.eigvals(chart.tscale * chart.jac(Z)))[0]
    h = 1e-6
    return (kap(Y + h * t) - kap(Y - h * t)) / (2 * h)


def _pycont_curve(cont, chart: _CurveChart, settings: ContinuationSettings, Y0: np.ndarray,
                  direction: np.ndarray, lam_bounds, name: str, side_name: str,
                  progress: Progress | None, max_restarts: int = 3) -> _Side:
    """Continue a curve from Y0 along ``direction`` (unit, chart coordinates) with PyCont LP-C/H-C2
    in chunks, until either parameter leaves its range (PyCont's own 'B' stop crashes), a Hopf curve
    turns into neutral saddles (past a Bogdanov-Takens point), the curve closes, the budget is
    spent or PyCont fails.

    PyCont sometimes jumps or turns back: its corrector (or its own location of a CP/BT point, with
    random borders) lands far from the predictor, or restarts with the tangent reversed and retraces
    the curve, e.g. near a cusp. A step longer than twice ``curve_max_step``, or one pointing back
    (negative dot product with the previous step), is dropped and a new PyCont curve starts from
    the last good point along the last good step with half the step sizes; so does a PyCont
    failure (its corrector not converging). At most ``max_restarts`` times; then the side ends with
    "no_convergence" (or the failure's reason)."""
    dst = compat.import_pydstool()
    side = _Side([Y0.copy()], [], [None])
    if cont is None:
        side.reason, side.message = "error", "PyCont is not available for this system"
        return side
    _, ctype, labels = _CURVES[chart.kind]
    sysm = chart.system
    p1, p2 = sysm.parameter_names[chart.k1], sysm.parameter_names[chart.k2]
    names = list(sysm.variables) + ["lam", "lam2"]
    (lo1, hi1), (lo2, hi2) = lam_bounds
    span_seen, reported, restarts = 0.0, 0, 0
    last_dir = np.asarray(direction, float) / np.linalg.norm(direction)
    step, max_step = settings.curve_step, settings.curve_max_step

    def start(Y, t, suffix):
        """A new PyCont curve from Y along t; None and a message when PyCont cannot start."""
        t = t / np.linalg.norm(t)
        initdirec = {k: float(v) for k, v in zip(names, t)}
        if chart.kind == "hopf":
            kd = _kappa_direction(chart, Y, t)
            norm = math.hypot(1.0, kd)
            initdirec = {k: v / norm for k, v in initdirec.items()}
            initdirec["_k"] = kd / norm
        cname = f"{name}_{side_name}{suffix}"
        try:
            with _silent():
                cont.newCurve(dst.args(
                    name=cname, type=ctype, freepars=["lam", "lam2"], initpoint=chart.point_dict(Y),
                    initdirec=initdirec, StepSize=min(step, max_step), MinStepSize=settings.min_step,
                    MaxStepSize=max_step, MaxNumPoints=settings.chunk + 1,
                    MaxCorrIters=settings.max_corrector_iters, LocBifPoints=list(labels), SaveEigen=True,
                    verbosity=0, FuncTol=settings.tol, VarTol=settings.tol, TestTol=settings.test_tol))
        except Exception as exc:  # noqa: BLE001
            return None, f"PyCont could not start the {ctype} curve: {_one_line(exc)}"
        return cont[cname], ""

    curve, why = start(Y0, direction, "")
    if curve is None:
        side.reason, side.message = "error", why
        return side
    first_call = True
    while True:
        try:
            with _silent() as chatter:
                curve.forward()
            closed = bool(_CLOSED.search(chatter.text))
            new = list(curve.new_sol_segment)[(1 if first_call else 0):]
            failure = None
        except Exception as exc:  # noqa: BLE001
            closed = False
            raw = np.asarray(getattr(curve, "curve", np.zeros((0, 0))))
            loc = int(getattr(curve, "loc", 0))
            new = []
            if raw.ndim == 2 and raw.shape[1] >= Y0.size:
                for i in range(1, max(loc, 1)):
                    vals = dict(zip(curve.varslist, raw[i][curve.coords]))
                    new.append(np.array([float(vals[v]) for v in sysm.variables]
                                        + [float(raw[i][curve.params[0]]), float(raw[i][curve.params[1]])]))
            failure = exc
        first_call = False
        jumped = False
        for pt in new:
            if isinstance(pt, np.ndarray):
                Y, plabels = pt, {}
            else:
                Y = np.array([float(pt[v]) for v in sysm.variables] + [float(pt["lam"]), float(pt["lam2"])])
                plabels = pt.labels
            with np.errstate(all="ignore"):
                finite = np.all(np.isfinite(Y)) and np.all(np.isfinite(sysm.f(*chart.to_phys(Y))))
            prev = side.points[-1]
            chord = Y - prev
            length = float(np.linalg.norm(chord)) if finite else math.inf
            if not finite or length > 2.0 * max_step or chord @ last_dir < -1e-3 * length:
                jumped = True
                break
            for t_ in labels:
                if t_ in plabels and not any(t_ == u and np.linalg.norm(Y - Yu) <= 1e-8 * (1.0 + np.linalg.norm(Y))
                                             for u, Yu in side.pycont_special):
                    side.pycont_special.append((t_, Y.copy()))
            if length <= 1e-10 * (1.0 + np.linalg.norm(Y)):
                continue                          # PyCont repeats a point it located: keep one
            if length > 1e-8:
                last_dir = chord / length
            side.points.append(Y)
            side.pycont_stab.append(None)
            span_seen = max(span_seen, float(np.linalg.norm(Y - Y0)))
            # A Hopf curve ends where its pair turns real (a Bogdanov-Takens point).
            if chart.kind == "hopf":
                JY = chart.jac(Y)
                kappa, omega, _ = _hopf_check(np.linalg.eigvals(JY), np.linalg.norm(JY))
                if omega == 0.0 and kappa < 0:
                    def tau(Yt):
                        return _hopf_check(np.linalg.eigvals(chart.jac(Yt)))[0]
                    Yb, ok = _locate(chart.at(prev), prev, Y, tau, settings.newton_tol)
                    side.points[-1] = Yb
                    if len(side.points) > 2 and np.linalg.norm(Yb - prev) <= 1e-9 * (1.0 + np.linalg.norm(Yb)):
                        del side.points[-2]           # PyCont had already put a point on the BT
                        side.pycont_stab.pop()
                    side.reason = "neutral_saddle"
                    side.message = (f"the Hopf pair turns real at ({p1}, {p2}) = "
                                    f"({chart.values(Yb)[0]:.8g}, {chart.values(Yb)[1]:.8g}) (a Bogdanov-"
                                    f"Takens point, BT): beyond it the curve is one of neutral saddles")
                    return side
            # The ranges: stop at the first boundary crossed, put exactly on it by Newton.
            out = [(j, b) for j, (lo, hi, v) in enumerate(((lo1, hi1, Y[-2]), (lo2, hi2, Y[-1])))
                   for b in (lo, hi) if (v < lo - 1e-12 and b == lo) or (v > hi + 1e-12 and b == hi)]
            if out:
                best = None
                for j, b in out:
                    col = Y.size - 2 + j
                    s = (b - prev[col]) / (Y[col] - prev[col]) if Y[col] != prev[col] else 0.0
                    if best is None or s < best[0]:
                        best = (s, j, b)
                s, j, b = best
                col = Y.size - 2 + j
                if abs(prev[col] - b) <= 1e-12:
                    side.points.pop()
                    side.pycont_stab.pop()
                else:
                    guess = prev + s * (Y - prev)
                    e = np.zeros_like(Y)
                    e[col] = 1.0
                    Yb, ok = _correct(chart.at(guess), guess, e, settings.newton_tol)
                    if not ok or np.linalg.norm(Yb - guess) > max_step:
                        side.points.pop()
                        side.pycont_stab.pop()
                        side.reason = "no_convergence"
                        side.message = (f"no {chart.kind} point on the boundary {p1 if j == 0 else p2} = "
                                        f"{chart.values(guess)[j]:g} next to the last point: PyCont's step "
                                        f"left the range across a gap; lower curve_max_step")
                        return side
                    side.points[-1] = Yb
                side.reason = "range"
                side.message = f"{p1 if j == 0 else p2} reached {chart.values(side.points[-1])[j]:g}"
                return side
            if len(side.points) > 8 and span_seen > 4 * max_step and np.linalg.norm(Y - Y0) < 1.5 * max_step:
                side.points.append(Y0.copy())
                side.pycont_stab.append(None)
                side.reason, side.message = "closed", "the curve returned to its start point"
                return side
        if progress and len(side.points) // 50 != reported:
            reported = len(side.points) // 50
            v1, v2 = chart.values(side.points[-1])
            progress(f"{name} ({side_name}): ({p1}, {p2}) = ({v1:.6g}, {v2:.6g}), {len(side.points)} points")
        if jumped or (failure is not None and restarts < max_restarts):
            v1, v2 = chart.values(side.points[-1])
            if jumped and restarts >= max_restarts:
                side.reason = "no_convergence"
                side.message = (f"PyCont jumped away from the curve (or turned back on it) after ({p1}, {p2}) "
                                f"= ({v1:.6g}, {v2:.6g}) {restarts + 1} times; lower curve_max_step")
                return side
            restarts += 1
            side.restarts = restarts          # reported in the branch info
            step, max_step = step / 2, max_step / 2
            curve, why = start(side.points[-1], last_dir, f"_r{restarts}")
            if curve is None:
                side.reason, side.message = "error", why
                return side
            first_call = True
            continue
        v1, v2 = chart.values(side.points[-1])
        where = f"({p1}, {p2}) = ({v1:.6g}, {v2:.6g})"
        if _pycont_end(side, curve, failure, closed, new, where, settings.min_step,
                       settings.curve_max_points, "curve_max_points"):
            return side


def _analyse_curve(chart: _CurveChart, Ys: list[np.ndarray], settings: ContinuationSettings,
                   branch_name: str, pycont_special: Sequence, fixed: Sequence[int] = (),
                   bt_ends: Sequence[int] = (), lam_bounds=None):
    """Polish every point on autocable's defining system, check it independently (det J = 0 for a
    fold, a pair on the imaginary axis for a Hopf point), locate codimension-2 points by sign
    changes of `_curve_tests` and compare them with PyCont's labels. ``fixed`` are indices of
    points already located by autocable (the start, a BT end): not moved. An end on a range
    boundary (``lam_bounds``) is refined on that boundary. ``bt_ends`` are ends of
    a Hopf curve at a Bogdanov-Takens point (omega = 0 there: not checked for an imaginary pair)."""
    sysm = chart.system
    n = sysm.dimension
    fixed = set(fixed)
    polished, moved = [], 0
    for i, Y in enumerate(Ys):
        Y = np.asarray(Y, float)
        if i in fixed or len(Ys) < 2:
            polished.append(Y.copy())
            continue
        a, b = max(i - 1, 0), min(i + 1, len(Ys) - 1)
        t = Ys[b] - Ys[a]
        if lam_bounds is not None and i in (0, len(Ys) - 1):
            for col, (lo, hi) in zip((-2, -1), lam_bounds):
                if min(abs(Y[col] - lo), abs(Y[col] - hi)) <= 1e-12:
                    t = np.zeros_like(Y)
                    t[col] = 1.0          # keep the end on the boundary it was put on
        if not np.linalg.norm(t) > 0:
            polished.append(Y.copy())
            continue
        Yp, ok = _correct(chart.at(Y), Y, t / np.linalg.norm(t), settings.newton_tol, maxiter=8)
        if ok and np.linalg.norm(Yp - Y) <= 1e-6 * (1.0 + np.linalg.norm(Y)):
            polished.append(Yp)
        else:
            polished.append(Y.copy())
            moved += 1
    Ys = polished
    m = len(Ys)
    X = np.array([chart.to_phys(Y)[0] for Y in Ys]).reshape(m, n)
    P = np.array([chart.to_phys(Y)[1] for Y in Ys]).reshape(m, len(sysm.parameters))
    eig = np.zeros((m, n), dtype=complex)
    detJ, omega, check, stable = np.zeros(m), np.full(m, math.nan), np.zeros(m), np.zeros(m, bool)
    tests: dict[str, list[float]] = {}
    ref = None
    refs = []
    for i, Y in enumerate(Ys):
        J = sysm.jac(X[i], P[i])
        ev = np.linalg.eigvals(J)
        eig[i] = ev[np.lexsort((-ev.imag, -ev.real))]
        detJ[i] = np.linalg.det(J)
        if chart.kind == "fold":
            check[i] = _fold_check(J)
            rest = np.delete(ev, int(np.argmin(np.abs(ev))))
        else:
            _, w, check[i] = _hopf_check(ev, np.linalg.norm(J))
            omega[i] = w if w > 0 else math.nan
            rest = np.delete(ev, list(_critical_pair(ev)))
        stable[i] = bool(rest.size == 0 or np.max(rest.real) < 0)
        vals, vw = _curve_tests(chart, Y, ref)
        ref = vw
        refs.append(vw)
        for k, v in vals.items():
            tests.setdefault(k, [math.nan] * m)[i] = v
    failures = [i for i in range(m) if not check[i] <= settings.curve_check_tol and i not in bt_ends]
    # Codimension-2 points: sign changes of autocable's test functions, located on the curve.
    found, rejected = [], []
    for i in bt_ends:
        accepted, why, extra = _classify_curve_point(chart, "BT", Ys[i])
        if accepted:
            found.append((i, "BT", Ys[i], True, dict(extra, end_of_curve=True)))
        else:
            rejected.append(("BT", chart.values(Ys[i]), why))
    for kind in ("CP", "BT", "ZH", "GH", "DH"):
        if kind not in tests:
            continue
        for i in _sign_changes(tests[kind]):
            j = i + 1
            while j < m - 1 and _sign(tests[kind][j]) == 0:
                j += 1
            Ya, Yb = Ys[i], Ys[j]
            if kind == "GH" and not (math.isfinite(tests["GH"][i]) and math.isfinite(tests["GH"][j])):
                continue
            ref_i = refs[i]

            def tau(Y, kind=kind, ref_i=ref_i):
                return _curve_tests(chart, Y, ref_i)[0].get(kind, math.nan)
            Y, ok = _locate(chart.at(Ya), Ya, Yb, tau, settings.newton_tol)
            accepted, why, extra = _classify_curve_point(chart, kind, Y)
            if not accepted:
                rejected.append((kind, chart.values(Y), why))
                continue
            if kind == "CP":
                extra["normal_form_b"] = tau(Ya)
            if kind == "GH":
                extra["l1"] = 0.0
            if any(f[1] == kind and np.linalg.norm(f[2] - Y) <= 1e-6 * (1 + np.linalg.norm(Y)) for f in found):
                continue  # the same point twice (e.g. the BT that ends a Hopf curve)
            found.append((i, kind, Y, ok, extra))
    # At a BT point of a fold curve the w . v test and ZH's pair-sum test may both vanish: the BT wins.
    bts = [f[2] for f in found if f[1] == "BT"]
    found = [f for f in found if not (f[1] == "ZH" and any(np.linalg.norm(f[2] - b) <= 1e-6 * (1 + np.linalg.norm(b))
                                                            for b in bts))]
    pyc = [(t, np.asarray(Y, float)) for t, Y in pycont_special]
    used: set[int] = set()

    def near(i_seg: int, Y, Yp) -> bool:
        a, b = max(i_seg - 1, 0), min(i_seg + 2, m - 1)
        return np.linalg.norm(Y - Yp) <= max(np.linalg.norm(Ys[b] - Ys[a]), 10 * settings.test_tol)

    entries = []
    for i, kind, Y, ok, extra in found:
        match = next((k for k, (t, Yp) in enumerate(pyc) if k not in used and t == kind and near(i, Y, Yp)), None)
        if match is not None:
            used.add(match)
        msg = "" if ok else "refinement did not bracket a zero: location interpolated"
        if match is None:
            msg = (msg + "; " if msg else "") + "not in PyCont's list (PyCont missed it)"
        entries.append((i, kind, Y, ok, match is not None, "autocable", extra, msg))
    for k, (t, Yp) in enumerate(pyc):
        if k in used:
            continue
        i = int(np.argmin([np.linalg.norm(Y - Yp) for Y in Ys])) if Ys else 0
        ev_p = np.linalg.eigvals(chart.jac(Yp))
        entries.append((i, t, Yp, False, True, "pycont", {"eigenvalues": [complex(e) for e in ev_p]},
                        f"PyCont reports {t} here; autocable's test functions change sign nowhere near it "
                        f"(or its eigenvalues say otherwise): not confirmed"))
    p1, p2 = sysm.parameter_names[chart.k1], sysm.parameter_names[chart.k2]
    specials, counters = [], {}
    for i, kind, Y, ok, confirmed, origin, extra, msg in sorted(entries, key=lambda e: (e[0], e[1])):
        counters[kind] = counters.get(kind, 0) + 1
        x, p = chart.to_phys(Y)
        amps = sysm.amplitude_values(x)
        extra = dict(extra, parameter2=p2, value2=float(p[chart.k2]))
        specials.append(SpecialPoint(
            branch=branch_name, type=kind, label=f"{kind}{counters[kind]}", parameter=p1,
            value=float(p[chart.k1]), a1=float(amps[0]) if amps else math.nan,
            a2=float(amps[1]) if len(amps) > 1 else math.nan, state=tuple(x),
            parameters=sysm.parameter_dict(p), index=int(i), converged=bool(ok),
            confirmed_by_pycont=bool(confirmed), origin=origin, message=msg, extra=extra))
    info = {"check": "sigma_min(J)/sigma_max(J)" if chart.kind == "fold" else
                     "|Re lambda| / ||J||_F of the critical pair (inf: the pair is real)",
            "check_tol": settings.curve_check_tol,
            "check_max": float(max((check[i] for i in range(m) if i not in bt_ends), default=math.nan)),
            "check_failures": failures[:50], "check_failure_count": len(failures),
            "rejected_candidates": [[k, list(v), why] for k, v, why in rejected],
            "points_kept_unpolished": moved}
    cols = {"det_J": detJ, "omega": omega, "check_residual": check}
    return Ys, X, P, eig, stable, tuple(specials), info, cols


def _continue_curve(kind: str, source: ContinuationResult, label: str | SpecialPoint, second_parameter: str,
                    bounds: tuple[float, float], settings: ContinuationSettings | None, name: str | None,
                    directions: str, progress: Progress | None) -> ContinuationResult:
    t0 = time.perf_counter()
    sp0, problem, base_settings = _resolve(source, label)
    settings = settings or base_settings
    want, ctype, _ = _CURVES[kind]
    if sp0.type != want:
        raise ValueError(f"{sp0.name} is a {sp0.type} point; a {kind} curve starts from a {want} point")
    if directions not in ("both", "forward", "backward"):
        raise ValueError(f"directions must be 'both', 'forward' or 'backward', got {directions!r}")
    sysm = problem.system
    p1, p2 = problem.parameter, str(second_parameter)
    if p2 not in sysm.parameter_names:
        raise ValueError(f"{p2!r} is not a parameter of {sysm.name!r} (it has {list(sysm.parameter_names)})")
    if p2 == p1:
        raise ValueError(f"the second parameter must differ from the first ({p1!r})")
    lo2, hi2 = (float(b) for b in bounds)
    if not (math.isfinite(lo2) and math.isfinite(hi2) and lo2 < hi2):
        raise ValueError(f"range of {p2} must be two finite numbers lo < hi, got {bounds}")
    name = name or f"{source.branch.name}_{sp0.label}_{kind}"
    base = sysm.parameter_vector(sp0.parameters)
    k1, k2 = sysm.parameter_names.index(p1), sysm.parameter_names.index(p2)
    for pn, k, (lo, hi) in ((p1, k1, problem.bounds), (p2, k2, (lo2, hi2))):
        if not lo <= base[k] <= hi:
            raise StartError(f"{sp0.name} has {pn} = {base[k]:g}, outside the range [{lo:g}, {hi:g}]")
    x0 = np.asarray(sp0.state, float)
    J0 = sysm.jac(x0, base)
    tscale = 1.0 / float(np.linalg.norm(J0)) if np.linalg.norm(J0) > 0 else 1.0
    chart = _CurveChart(sysm, kind, k1, k2, base, float(problem.state_scale), float(problem.span),
                        hi2 - lo2, tscale)
    Y0 = chart.to_chart(x0, base)
    e2 = np.zeros_like(Y0)
    e2[-1] = 1.0
    Y0c, ok = _correct(chart.at(Y0), Y0, e2, settings.newton_tol)
    if not ok:
        raise StartError(f"{sp0.name} could not be refined on the {kind} curve's defining system "
                         f"(Newton did not converge)")
    Y0 = Y0c
    t = _tangent(chart.DF(Y0))
    lead = -1 if abs(t[-1]) > 1e-12 else -2            # forward: increasing p2 (else p1)
    t = t if t[lead] >= 0 else -t
    lam_bounds = ((chart.lam(1, problem.bounds[0]), chart.lam(1, problem.bounds[1])),
                  (chart.lam(2, lo2), chart.lam(2, hi2)))
    try:
        cont, why = continuation_system(sysm._scaled_field_2p, _CURVE_GENERATOR,
                                        ics={v: float(y) for v, y in zip(sysm.variables, Y0[:-2])},
                                        pars=chart.pycont_pars()), ""
    except Exception as exc:  # noqa: BLE001
        cont, why = None, f"PyCont could not be set up: {_one_line(exc)}"
    t_setup = time.perf_counter()
    wanted = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]
    sides = {}
    rng_state = np.random.get_state()
    try:
        for side in wanted:
            if any(sd.reason == "closed" for sd in sides.values()):
                sides[side] = _Side([Y0], [], [None], "closed", "the curve is closed, traversed in the other direction")
                continue
            np.random.seed(_PYCONT_SEED)
            sgn = 1.0 if side == "forward" else -1.0
            sides[side] = _pycont_curve(cont, chart, settings, Y0, sgn * t, lam_bounds, name, side, progress)
            if cont is None:
                sides[side].message = why
    finally:
        np.random.set_state(rng_state)
    t1 = time.perf_counter()
    back = sides.get("backward", _Side([Y0], [], [None], "not_run", ""))
    fwd = sides.get("forward", _Side([Y0], [], [None], "not_run", ""))
    Ys = list(reversed(back.points[1:])) + fwd.points
    fixed = [len(back.points) - 1]                       # the start, refined above
    if back.reason == "neutral_saddle" and len(back.points) > 1:
        fixed.append(0)
    if fwd.reason == "neutral_saddle" and len(fwd.points) > 1:
        fixed.append(len(Ys) - 1)
    bt_ends = ([0] if back.reason == "neutral_saddle" and len(back.points) > 1 else []) \
        + ([len(Ys) - 1] if fwd.reason == "neutral_saddle" and len(fwd.points) > 1 else [])
    Ys, X, P, eig, stable, specials, info, cols = _analyse_curve(
        chart, Ys, settings, name, back.pycont_special + fwd.pycont_special, fixed, bt_ends, lam_bounds)
    start_index = len(back.points) - 1
    v1, v2 = chart.values(Ys[0]), chart.values(Ys[-1])
    where = "; the curve ends at ({}, {}) = ({:.8g}, {:.8g})"
    ends = (EndPoint("backward", back.reason, v1[0], len(back.points) - 1,
                     back.message + (where.format(p1, p2, *v1) if back.reason != "not_run" else "")),
            EndPoint("forward", fwd.reason, v2[0], len(fwd.points) - 1,
                     fwd.message + (where.format(p1, p2, *v2) if fwd.reason != "not_run" else "")))
    info = dict(info, start_index=start_index, started_from=sp0.name, second_parameter=p2,
                second_bounds=[lo2, hi2], state_scale=chart.xscale, time_scale=tscale, pycont_curve=ctype,
                pycont_restarts={k: getattr(sd, "restarts", 0) for k, sd in sides.items()})
    ch1 = _Chart(sysm, k1, base, chart.xscale, chart.s1)
    branch = _build_branch(name, "equilibrium", ch1, X, P, stable, eig, specials, ends, info,
                           extra_columns=cols).replace(kind=kind, parameter2=p2)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem.at(**{p1: float(base[k1])}), settings,
                              {"setup_s": t_setup - t0, "pycont_s": t1 - t_setup, "analysis_s": t2 - t1,
                               "points": len(Ys)})


def continue_folds(source: ContinuationResult, fold: str | SpecialPoint, second_parameter: str,
                   bounds: tuple[float, float], settings: ContinuationSettings | None = None, *,
                   name: str | None = None, directions: str = "both",
                   progress: Progress | None = None) -> ContinuationResult:
    """The curve of folds through the fold ``fold`` (e.g. "LP1") of ``source``, in the plane of the
    source's parameter (over its range) and ``second_parameter`` (over ``bounds``): PyCont's LP-C.

    Returns a branch of kind "fold" (columns: both parameters, the state, a1, a2, det_J,
    check_residual; ``parameter2`` names the second parameter). Every point is refined on
    autocable's own defining system (f = 0 and a bordered test function of J) and checked: the
    ``check_residual`` sigma_min(J)/sigma_max(J) of the exact Jacobian must be <= ``curve_check_tol``
    (failures listed in ``info["check_failures"]``). Cusps (CP), Bogdanov-Takens (BT) and zero-Hopf
    (ZH) points come from autocable's test functions (`_curve_tests`), confirmed by the eigenvalues
    and compared with PyCont's labels (PyCont-only labels kept with ``origin="pycont"``).
    ``directions``: "both", "forward" (increasing second parameter at the start) or "backward".
    The curve stops at either range (itself: PyCont's 'B' stop crashes), at ``curve_max_points``
    per direction, or when PyCont fails (the points before the failure are kept)."""
    return _continue_curve("fold", source, fold, second_parameter, bounds, settings, name, directions, progress)


def continue_hopf(source: ContinuationResult, hopf: str | SpecialPoint, second_parameter: str,
                  bounds: tuple[float, float], settings: ContinuationSettings | None = None, *,
                  name: str | None = None, directions: str = "both",
                  progress: Progress | None = None) -> ContinuationResult:
    """The curve of Hopf points through ``hopf`` (e.g. "H1") of ``source`` in the plane of the
    source's parameter and ``second_parameter``: PyCont's H-C2 (J^2 + omega^2 I singular).

    A branch of kind "hopf" (columns as `continue_folds`, plus the frequency ``omega``). Checked at
    every point: a pair of eigenvalues of the exact Jacobian on the imaginary axis,
    |Re lambda| / ||J||_F <= ``curve_check_tol``. Where the pair turns real (a Bogdanov-Takens
    point, beyond which H-C2 follows neutral saddles) the curve ends with reason "neutral_saddle"
    at the located BT point. Generalized Hopf (GH: l1 = 0, Kuznetsov's l1 from exact derivatives),
    zero-Hopf (ZH: det J = 0) and, for n >= 4, double Hopf (DH) points come from autocable's test
    functions, compared with PyCont's labels."""
    return _continue_curve("hopf", source, hopf, second_parameter, bounds, settings, name, directions, progress)
