"""The continued vector field as sympy data: `System` (exact numeric derivatives, the scaled fields
PyCont continues) and `ame_system`, the Cartesian AME (24) of Luongo & Zulli as a `System`.

Part of the continuation of `autocable.methods.continuation` (its docstring gives the design and the
scaling of the fields built here)."""
from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Any, Mapping

import numpy as np
import sympy as sp

from autocable._store import (cache_dir, code_fingerprint, content_hash, load_checked_json,
                              store_checked_json_for_code)
from autocable.codegen.coefficients import coefficient_template
from autocable.codegen.pydstool import VectorField
from autocable.methods.lambda_cache import numeric_function, rhs_key, rhs_key_of_srepr
from autocable.model.symbolic import plain_symbols


#: Names the scaled PyCont vector field reserves for itself.
_RESERVED = ("xscale", "lam", "lam2", "tscale")
#: Version of what `ame_system` builds from an AME: bump it when that construction changes, so the
#: right-hand sides cached by earlier code are not used.
AME_SYSTEM_VERSION = 1


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
    #: The AME of eq. (24) (set by `ame_system`): its continuations default to `auto_state_scale`.
    amplitude_equations: bool = False

    def __post_init__(self):
        variables = tuple(str(v) for v in self.variables)
        params = self.parameters.items() if isinstance(self.parameters, Mapping) else self.parameters
        params = tuple((str(k), float(v)) for k, v in params)
        rhs = tuple(plain_symbols(e) for e in self.rhs)
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
    def _rhs_key(self) -> str:
        return rhs_key(self.rhs)

    @cached_property
    def template(self):
        """The right-hand side's structure and numbers (`autocable.codegen.coefficients`): what the
        C kernel, the search's polynomial form and the PyCont field with its numbers as parameters
        (`scaled_field`) are generated from. ValueError if a symbol uses the weights' prefix."""
        return coefficient_template(self.rhs)

    def _numeric_function(self, kind: str):
        # The generated text is cached across processes (`lambda_cache`): the Jacobians of the wind
        # AME cost seconds of sympy per process otherwise. It keeps the numbers in the text (keyed
        # per model): with the numbers passed as data, the rounding-level change of J moved a
        # branch switch at a degenerate pitchfork of a calibration candidate's Fig. 6 onto the
        # other branch.
        return numeric_function(kind, self.variables, self.parameter_names, self.rhs, key=self._rhs_key)

    # One function each, made when first used: a scene on the compiled engine may need F alone (its
    # state scale), and each costs about a second of sympy for a model met for the first time
    # (every candidate of the calibration's bound stage).
    @cached_property
    def _f_fn(self):
        return self._numeric_function("f")

    @cached_property
    def _jac_fn(self):
        return self._numeric_function("jac")

    @cached_property
    def _jac_p_fn(self):
        return self._numeric_function("jac_p")

    @cached_property
    def _higher(self):
        """Second and third derivative tensors (for the first Lyapunov coefficient, eq. 3.20 of
        Kuznetsov, and the fold curves' B). A field polynomial in the state (the Cartesian AME
        (24) is cubic) differentiates its monomials exactly (`monomials.Monomials`, the coefficients
        C(p) the search evaluates): the same tensors as sympy's d2 and d3 up to the order of the
        sums (tests/test_search_monomials.py), without differentiating the AME twice and three
        times in sympy and printing the tensors (1.7 s for the wind AME of a model met the first
        time). Any other field: sympy's derivatives, lambdified and cached like F and J."""
        from autocable.methods.continuation.monomials import Monomials
        mono = Monomials.of(self)
        if mono is not None:
            return mono.hessian, mono.third
        f2 = self._numeric_function("d2")                    # [k][j][i]
        f3 = self._numeric_function("d3")                    # [l][k][j][i]
        n = self.dimension
        # derive_by_array puts the derivative index first: reorder to [i, j, k(, l)].
        return (lambda x, p: np.broadcast_to(np.array(f2(x, p), dtype=float), (n,) * 3).transpose(2, 1, 0),
                lambda x, p: np.broadcast_to(np.array(f3(x, p), dtype=float), (n,) * 4).transpose(3, 2, 1, 0))

    def f(self, x, p) -> np.ndarray:
        return np.asarray(self._f_fn(np.asarray(x, float), np.asarray(p, float)), dtype=float).reshape(-1)

    def jac(self, x, p) -> np.ndarray:
        n = self.dimension
        return np.broadcast_to(np.asarray(self._jac_fn(np.asarray(x, float), np.asarray(p, float)),
                                          dtype=float), (n, n)).copy()

    def f_many(self, X, p) -> np.ndarray:
        """f at every row of ``X`` (N x n) at one parameter vector: an N x n array, in one call of
        the numpy function when its entries broadcast, else row by row."""
        X = np.asarray(X, float)
        n, N = self.dimension, len(X)
        try:
            out = np.asarray(self._f_fn(X.T, np.asarray(p, float)), dtype=float)
            if out.size == n * N:
                return out.reshape(n, N).T.copy()
        except (ValueError, TypeError):
            pass                     # a constant entry does not broadcast: one row at a time
        return np.array([self.f(x, p) for x in X]).reshape(N, n)

    def jac_many(self, X, p) -> np.ndarray:
        """The Jacobian at every row of ``X``: an N x n x n array (as `f_many`)."""
        X = np.asarray(X, float)
        n, N = self.dimension, len(X)
        try:
            out = np.asarray(self._jac_fn(X.T, np.asarray(p, float)), dtype=float)
            if out.size == n * n * N:
                return out.reshape(n, n, N).transpose(2, 0, 1).copy()
        except (ValueError, TypeError):
            pass
        return np.array([self.jac(x, p) for x in X]).reshape(N, n, n)

    def jac_p(self, x, p) -> np.ndarray:
        n, m = self.dimension, len(self.parameters)
        return np.broadcast_to(np.asarray(self._jac_p_fn(np.asarray(x, float), np.asarray(p, float)),
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
        return self._make_scaled_field(False)

    @cached_property
    def _scaled_field_weighted(self) -> VectorField:
        return self._make_scaled_field(True)

    def scaled_field(self, coefficients_as_parameters: bool = False) -> VectorField:
        """The field PyCont continues (built once per system; see `_make_scaled_field`).

        ``coefficients_as_parameters``: the right-hand side's numbers are PyDSTool parameters too
        (`autocable.codegen.coefficients`), so the compiled generator serves every system of one
        structure (every candidate model of the calibration). Equilibrium continuation (EP-C) uses
        it; PyCont's AUTO module, which cycle continuation builds from the same field, takes few
        parameters (AUTO's NPAR), so cycles keep the numbers in the text."""
        return self._scaled_field_weighted if coefficients_as_parameters else self._scaled_field

    def _make_scaled_field(self, coefficients_as_parameters: bool) -> VectorField:
        """The field PyCont continues: x~ = x/xscale, p_k = p_k + d_<p_k> * lam (module docstring).

        Every parameter stays a PyDSTool parameter, so one compiled library serves every fixed value,
        every continued parameter and every scale (and, with ``coefficients_as_parameters``, every
        set of coefficients of the right-hand side's structure: parameters ``ac_k<i>`` that are
        never continued)."""
        xs, ps = self._symbols
        rhs, weights = self.rhs, []
        if coefficients_as_parameters:
            rhs = self.template.rhs
            weights = list(zip(self.template.weight_names, self.template.weights.tolist()))
        xscale, lam = sp.Symbol("xscale"), sp.Symbol("lam")
        sub = {x: xscale * x for x in xs}
        sub.update({p: p + sp.Symbol(f"d_{p.name}") * lam for p in ps})
        rhs = [sp.expand(e.xreplace(sub) / xscale) for e in rhs]
        params = list(self.parameters) + [("xscale", 1.0)] + [(f"d_{p}", 0.0) for p in self.parameter_names] \
            + [("lam", 0.0)] + weights
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


def ame_system(ame, dof: str = "2dof", *, wind: bool = True, name: str | None = None,
               use_cache: bool = True) -> System:
    """The Cartesian AME (24) as a `System` in the scene parameters (sigma, U, eta).

    ``dof="1dof"`` is the reduction A2 = 0 of Sect. 5 (a2 is then identically zero). The detunings
    follow Sect. 4 (docs/model.md, C2): Omega = omega1 + sigma, sigma_k = omega_k - Omega (so
    sigma_1 = -sigma and rho = omega2 - omega1 stays fixed), so one parameter sigma moves the
    detunings and the exact Omega of the coefficients consistently. ``wind=False`` drops the
    aerodynamic rows (their 1/U powers: no wind, no term), as needed at U = 0; with wind the field
    is singular at U = 0.

    The right-hand sides are kept in the cache folder (``systems/``) as ``sympy.srepr`` text under a
    hash of the AME's content, ``dof``, ``wind``, the sympy version and `AME_SYSTEM_VERSION`:
    building the wind AME from its rows costs about half a second of sympy in every scene that
    uses it, reading it back a twentieth of that (``use_cache=False`` always rebuilds).
    """
    if dof not in ("2dof", "1dof"):
        raise ValueError(f"dof must be '2dof' or '1dof', got {dof!r}")
    src = ame.one_dof() if dof == "1dof" else ame
    if src.user_names:
        raise ValueError(f"the AME has unbound user symbols {src.user_names}")
    variables = tuple(v for k in range(1, src.n_modes + 1) for v in (f"r{k}", f"s{k}"))
    amps = [(f"a{k}", (f"r{k}", f"s{k}")) for k in range(1, src.n_modes + 1)]
    if dof == "1dof":
        amps.append(("a2", ()))
    tag = name or f"ame{src.n_modes}{'w' if wind else 'n'}"
    params = (("sigma", 0.0), ("U", 0.0), ("eta", 0.0))
    description = f"Cartesian AME (24), {dof}, {'with' if wind else 'without'} wind terms"
    path = None
    code = code_fingerprint("system")     # the code that builds the rows: no version bump needed
    if use_cache:
        data = {k: v for k, v in ame.to_dict().items() if k != "provenance"}
        key = content_hash({"ame": data, "dof": dof, "wind": wind, "sympy": sp.__version__,
                            "version": AME_SYSTEM_VERSION, "code": code})
        path = cache_dir("systems") / f"ame-system-{key}.json"
        rhs = _cached_rhs(path, len(variables))
        if rhs is not None:
            system = System(tag, variables, rhs[1], params, tuple(amps), description=description,
                            amplitude_equations=True)
            # The stored text is srepr of these very expressions: its hash is `rhs_key`.
            system.__dict__["_rhs_key"] = rhs_key_of_srepr(rhs[0])
            return system
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
    rhs = [plain_symbols(sp.expand(e.xreplace(rel)).xreplace(ren)) for e in exprs]
    system = System(tag, variables, rhs, params, tuple(amps), description=description, amplitude_equations=True)
    if path is not None:
        store_checked_json_for_code("system", code, path, {"format": AME_SYSTEM_VERSION,
                                                           "rhs": [sp.srepr(e) for e in system.rhs]},
                                    f"AME system {path.name}")
    return system


def _cached_rhs(path, n: int) -> tuple[list[str], list[sp.Expr]] | None:
    """The srepr texts `ame_system` stored at ``path`` and their expressions, or None (missing,
    corrupt or foreign: the caller builds them again)."""
    data = load_checked_json(path, f"AME system {path.name}")
    if not (isinstance(data, dict) and data.get("format") == AME_SYSTEM_VERSION):
        return None
    texts = data.get("rhs")
    if not (isinstance(texts, list) and len(texts) == n and all(isinstance(t, str) for t in texts)):
        return None
    try:
        return texts, [_from_srepr(t) for t in texts]
    except Exception:   # noqa: BLE001 - a damaged file is rebuilt, never trusted
        return None


def _from_srepr(text: str) -> sp.Expr:
    """The expression ``sympy.srepr`` printed as ``text`` (our own cache file: evaluated with
    sympy's names only). About ten times faster than rebuilding the wind AME from its rows."""
    namespace = {k: getattr(sp, k) for k in ("Add", "Mul", "Pow", "Symbol", "Float", "Integer", "Rational")}
    return eval(text, {"__builtins__": {}}, namespace)  # noqa: S307 - text autocable wrote itself


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
