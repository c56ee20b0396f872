"""sympy -> PyDSTool: the one module of autocable that writes PyDSTool spec strings.

It takes plain data (`VectorField`: names, sympy right-hand sides, parameter defaults) and returns
PyDSTool objects: ODE generators (compiled Dopri/Radau or Python Vode), fast sampled integration,
and a PyCont ``ContClass`` ready for continuation. What it guarantees:

* Spec strings never contain powers (``**``, ``^``, ``pow``): PyDSTool rewrites powers with the
  stdlib ``parser`` module, which Python 3.10 removed. Integer powers are written as products,
  ``x**-2`` as ``1/(x*x)``; other powers are an error (``x**(1/2)`` is written ``sqrt(x)``).
  Numbers are written as float literals with ``repr`` (shortest round-trip, <= 17 significant
  digits), so C never sees an integer division such as ``1/2``.
* The explicit Jacobian comes from sympy, in PyDSTool's variable order (Python's ``sorted`` of
  the names: PyDSTool silently assumes it, and continuation fails to converge otherwise). It is
  given as the ``'Jacobian'`` fnspec only; ``Jacobian_pars`` crashes PyCont.
* Build names carry a content hash (`model_name`): a changed model never reuses a stale build,
  an unchanged one reuses it across processes without recompiling.
* Builds happen in ``cache_root()/pydstool`` (never the working directory), silenced; failures
  surface as `PyDSToolError`. Each build's manifest records the sha256 of its library, its Python
  wrapper and its pickled generator; all three are checked before import or unpickling, and a build
  that fails the check is made again (one line on stderr).
"""
from __future__ import annotations

import contextlib
import errno
import functools
import importlib
import importlib.machinery
import keyword
import math
import os
import re
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np
import sympy
from sympy.core.function import AppliedUndef

from autocable import _store as cache
from autocable.codegen.compat import (
    PyDSToolError,
    build_generator_library,
    import_pydstool,
    memoize_name_map,
    pydstool_errors,
    pydstool_session,
    quiet,
)
from autocable.model import derivatives

__all__ = [
    "TIME",
    "CODEGEN_VERSION",
    "GENERATOR_KINDS",
    "AuxFunction",
    "VectorField",
    "OdeGenerator",
    "pydstool_str",
    "jacobian_matrix",
    "jacobian_spec",
    "model_name",
    "pydstool_args",
    "pydstool_cache_dir",
    "make_ode_generator",
    "integrate",
    "continuation_system",
]

#: The independent variable as PyDSTool names it; right-hand sides may contain it.
TIME = sympy.Symbol("t", real=True)
#: Bump when the emitted text changes for the same sympy input: every build name changes with it.
CODEGEN_VERSION = 1
#: Largest output buffer (steps + samples) `integrate` will allocate for one call (~200 MB).
MAX_OUTPUT_POINTS = 5_000_000
#: Generator kinds: PyDSTool class name and the prefix of its compiled library (None: pure Python).
GENERATOR_KINDS = MappingProxyType({"Vode": ("Vode_ODEsystem", None),
                                    "Dopri": ("Dopri_ODEsystem", "dop853"),
                                    "Radau": ("Radau_ODEsystem", "radau5")})

_NAME = re.compile(r"^[A-Za-z][A-Za-z0-9_]*$")
# Names PyDSTool or C give a meaning of their own (math functions, constants, C keywords).
_RESERVED = frozenset(
    "t pi e E inf nan abs fabs sqrt exp log log10 sin cos tan asin acos atan atan2 sinh cosh tanh "
    "pow min max floor ceil mod sign heav signum if initcond getindex getbound globalindepvar "
    "auto break case char const continue default do double else enum extern float for goto int "
    "long register return short signed sizeof static struct switch typedef union unsigned void "
    "volatile while Jacobian Jacobian_pars massMatrix".split())

# sympy function class -> name in PyDSTool specs (valid in both its Python and C targets).
_FUNCTIONS = {
    sympy.sin: "sin", sympy.cos: "cos", sympy.tan: "tan",
    sympy.asin: "asin", sympy.acos: "acos", sympy.atan: "atan", sympy.atan2: "atan2",
    sympy.sinh: "sinh", sympy.cosh: "cosh", sympy.tanh: "tanh",
    sympy.exp: "exp", sympy.log: "log",
}


# --------------------------------------------------------------------------------------------
# the data

@dataclass(frozen=True)
class AuxFunction:
    """A helper function usable in right-hand sides as ``sympy.Function(name)(*args)``."""

    name: str
    args: tuple[str, ...]
    expr: sympy.Expr

    def __post_init__(self):
        object.__setattr__(self, "args", tuple(str(a) for a in self.args))
        object.__setattr__(self, "expr", sympy.sympify(self.expr))
        _check_name(self.name, "auxiliary function")
        for a in self.args:
            _check_name(a, f"argument of auxiliary function {self.name!r}")
        extra = {s.name for s in self.expr.free_symbols} - set(self.args)
        if extra:
            raise ValueError(f"auxiliary function {self.name!r} uses {sorted(extra)} which are not "
                             f"among its arguments {list(self.args)}")


@dataclass(frozen=True)
class VectorField:
    """An ODE system x' = f(t, x; p) as plain sympy data.

    ``variables`` fixes the order used everywhere in autocable (states in `integrate`, rows of
    `jacobian_matrix`); PyDSTool's own alphabetical order stays inside this module. ``rhs`` gives
    one sympy expression per variable (a sequence in that order, or a mapping by name); they may
    contain the parameters, the time symbol `TIME` (``t``) and calls of ``auxiliary`` functions.
    ``parameters`` maps each parameter name to its default value (order kept).
    """

    name: str
    variables: tuple[str, ...]
    rhs: tuple[sympy.Expr, ...]
    parameters: tuple[tuple[str, float], ...] = ()
    auxiliary: tuple[AuxFunction, ...] = ()

    def __post_init__(self):
        _check_name(self.name, "model")
        variables = tuple(str(v) for v in self.variables)
        if len(set(variables)) != len(variables) or not variables:
            raise ValueError(f"model {self.name!r}: variables must be distinct and non-empty, got {variables}")
        rhs = self.rhs
        if isinstance(rhs, Mapping):
            missing = set(variables) ^ {str(k) for k in rhs}
            if missing:
                raise ValueError(f"model {self.name!r}: rhs keys must match the variables; differing: {sorted(missing)}")
            rhs = [rhs[k] for k in _keys_in_order(rhs, variables)]
        rhs = tuple(sympy.sympify(e) for e in rhs)
        if len(rhs) != len(variables):
            raise ValueError(f"model {self.name!r}: {len(variables)} variables but {len(rhs)} right-hand sides")
        params = self.parameters
        params = tuple((str(k), float(v)) for k, v in (params.items() if isinstance(params, Mapping) else params))
        aux = self.auxiliary
        if isinstance(aux, Mapping):
            aux = [AuxFunction(k, *v) for k, v in aux.items()]
        aux = tuple(a if isinstance(a, AuxFunction) else AuxFunction(*a) for a in aux)
        object.__setattr__(self, "variables", variables)
        object.__setattr__(self, "rhs", rhs)
        object.__setattr__(self, "parameters", params)
        object.__setattr__(self, "auxiliary", aux)

        names = list(variables) + [p for p, _ in params] + [a.name for a in aux]
        for n in names:
            _check_name(n, f"name in model {self.name!r}")
        if len(set(names)) != len(names):
            raise ValueError(f"model {self.name!r}: variable, parameter and function names must be distinct")
        for p, v in params:
            if not math.isfinite(v):
                raise ValueError(f"model {self.name!r}: parameter {p!r} has non-finite default {v}")
        allowed = set(variables) | {p for p, _ in params} | {TIME.name}
        known_fns = {a.name: len(a.args) for a in aux}
        for var, expr in zip(variables, rhs):
            unknown = {s.name for s in expr.free_symbols} - allowed
            if unknown:
                raise ValueError(f"model {self.name!r}: rhs of {var!r} uses undeclared symbols {sorted(unknown)}")
            for call in expr.atoms(AppliedUndef):
                fname = type(call).__name__
                if known_fns.get(fname) != len(call.args):
                    raise ValueError(f"model {self.name!r}: rhs of {var!r} calls {fname} with "
                                     f"{len(call.args)} arguments, which is not a declared auxiliary function")

    @property
    def parameter_defaults(self) -> dict[str, float]:
        """Parameter name -> default value."""
        return dict(self.parameters)

    @property
    def time_dependent(self) -> bool:
        """True if some right-hand side contains ``t`` (directly or through an aux function)."""
        return any(s.name == TIME.name for e in self.inlined_rhs() for s in e.free_symbols)

    @property
    def pydstool_order(self) -> tuple[str, ...]:
        """The variables in PyDSTool's internal order (``sorted``)."""
        return tuple(sorted(self.variables))

    def inlined_rhs(self) -> tuple[sympy.Expr, ...]:
        """The right-hand sides with auxiliary function calls replaced by their bodies."""
        if not self.auxiliary:
            return tuple(_unify_symbols(e) for e in self.rhs)
        lambdas = {a.name: sympy.Lambda(tuple(sympy.Symbol(n) for n in a.args), a.expr)
                   for a in self.auxiliary}

        def inline(expr):
            for _ in range(len(lambdas) + 1):  # aux functions may call each other (no cycles)
                calls = {c: lambdas[type(c).__name__](*c.args) for c in expr.atoms(AppliedUndef)
                         if type(c).__name__ in lambdas}
                if not calls:
                    return _unify_symbols(expr)
                expr = expr.xreplace(calls)
            raise ValueError(f"model {self.name!r}: auxiliary functions call each other in a cycle")

        return tuple(inline(e) for e in self.rhs)


def _keys_in_order(mapping, variables):
    by_name = {str(k): k for k in mapping}
    return [by_name[v] for v in variables]


def _check_name(name: str, what: str) -> None:
    if not isinstance(name, str) or not _NAME.match(name) or keyword.iskeyword(name) or name in _RESERVED:
        raise ValueError(f"{what} {name!r} is not usable in PyDSTool: use letters, digits and '_' "
                         f"(starting with a letter), not a reserved word like 't', 'pi' or 'sin'")


def _unify_symbols(expr: sympy.Expr) -> sympy.Expr:
    """Replace symbols by plain ``Symbol(name)`` so ``t`` with or without assumptions is one symbol."""
    return expr.xreplace({s: sympy.Symbol(s.name) for s in expr.free_symbols})


# --------------------------------------------------------------------------------------------
# the printer

def _number(value) -> str:
    x = float(value)
    if not math.isfinite(x):
        raise ValueError(f"cannot write the non-finite number {value} into a PyDSTool spec")
    text = repr(x)
    return f"({text})" if x < 0 else text


def _is_negative_term(expr) -> bool:
    if expr.is_Number:
        return bool(expr < 0)
    if expr.is_Mul:
        coeff, _ = expr.as_coeff_Mul()
        return bool(coeff.is_Number and coeff < 0)
    return False


def _factor(expr) -> str:
    """``expr`` printed so it can stand as one factor of a product or a denominator."""
    text = _print(expr)
    # Powers print as atoms already (x, (x*x), sqrt(x), (1.0/x)); negative numbers carry parentheses.
    return f"({text})" if expr.is_Add or expr.is_Mul else text


def _repeat(base, n: int) -> str:
    """base**n (n >= 1) as an explicit product, parenthesised when n > 1."""
    b = _factor(base)
    return b if n == 1 else "(" + "*".join([b] * n) + ")"


def _print_pow(expr) -> str:
    base, exp = expr.base, expr.exp
    if exp == sympy.S.Half:
        return f"sqrt({_print(base)})"
    if exp == -sympy.S.Half:
        return f"(1.0/sqrt({_print(base)}))"
    if base == sympy.E:
        return f"exp({_print(exp)})"
    if not exp.is_Integer:
        raise ValueError(f"cannot write the power {expr} into a PyDSTool spec: only integer exponents "
                         f"(written as products) and square roots are supported")
    n = int(exp)
    if n > 0:
        return _repeat(base, n)
    return f"(1.0/{_repeat(base, -n) if -n > 1 else _factor(base)})"


def _print_mul(expr) -> str:
    coeff, rest = expr.as_coeff_Mul()
    if coeff.is_Number and coeff < 0:
        return "-" + _factor(-expr) if -expr != 1 else "-1.0"
    numer, denom = [], []
    for f in sympy.Mul.make_args(expr):
        if f.is_Pow and f.exp.is_Integer and f.exp < 0:
            denom.append(_repeat(f.base, -int(f.exp)) if -f.exp > 1 else _factor(f.base))
        elif f.is_Rational and not f.is_Integer and f.p == 1:
            denom.append(_number(f.q))
        else:
            numer.append(_factor(f))
    text = "*".join(numer) if numer else "1.0"
    if denom:
        text += "/" + (denom[0] if len(denom) == 1 else "(" + "*".join(denom) + ")")
    return text


def _print(expr) -> str:
    if expr.is_Symbol:
        return expr.name
    if expr.is_Number or expr.is_NumberSymbol:
        return _number(expr.evalf(17) if expr.is_NumberSymbol else expr)
    if expr.is_Add:
        terms = sympy.Add.make_args(expr)
        # A fixed order keeps the text (and so the build hash) stable; positive terms first.
        ordered = sorted(terms, key=lambda term: (_is_negative_term(term), sympy.default_sort_key(term)))
        out = _print(ordered[0])
        for term in ordered[1:]:
            out += " - " + _factor_or_plain(-term) if _is_negative_term(term) else " + " + _print(term)
        return out
    if expr.is_Mul:
        return _print_mul(expr)
    if expr.is_Pow:
        return _print_pow(expr)
    if isinstance(expr, AppliedUndef):
        return f"{type(expr).__name__}({', '.join(_print(a) for a in expr.args)})"
    func = _FUNCTIONS.get(type(expr))
    if func is not None:
        if isinstance(expr, sympy.log) and len(expr.args) != 1:
            raise ValueError(f"cannot write {expr}: only the natural logarithm is supported")
        return f"{func}({', '.join(_print(a) for a in expr.args)})"
    raise ValueError(f"cannot write {type(expr).__name__} ({expr}) into a PyDSTool spec: "
                     f"supported are + - * /, integer powers, sqrt, {sorted(_FUNCTIONS.values())} "
                     f"and declared auxiliary functions")


def _factor_or_plain(term) -> str:
    """The positive part of a negated Add term: a product needs no parentheses after ' - '."""
    text = _print(term)
    return f"({text})" if term.is_Add else text


def pydstool_str(expr) -> str:
    """``expr`` as a PyDSTool spec string, valid in its Python and C targets, without powers.

    >>> x, y = sympy.symbols("x y")
    >>> pydstool_str(x**3 - y/(2*x**2))
    '(x*x*x) - y/(2.0*(x*x))'
    """
    return _print(sympy.sympify(expr))


# --------------------------------------------------------------------------------------------
# Jacobian, names, specs

def jacobian_matrix(vf: VectorField, order: Sequence[str] | None = None) -> sympy.Matrix:
    """d rhs_i / d x_j from sympy, rows and columns in ``order`` (default: ``vf.variables``)."""
    order = tuple(order) if order is not None else vf.variables
    if sorted(order) != sorted(vf.variables):
        raise ValueError(f"order {order} is not a permutation of {vf.variables}")
    rhs = dict(zip(vf.variables, vf.inlined_rhs()))
    # Differentiate with real symbols (so sympy writes no re()/im() parts), then hand
    # back plain symbols so callers can substitute by name.
    names = set(vf.variables) | {s.name for e in rhs.values() for s in e.free_symbols}
    real = {sympy.Symbol(n): sympy.Symbol(n, real=True) for n in names}
    plain = {r: p for p, r in real.items()}
    memo: dict = {}
    rows = [[derivatives.diff(rhs[vi].xreplace(real), real[sympy.Symbol(xj)], memo).xreplace(plain)
             for xj in order] for vi in order]
    return sympy.Matrix(rows)


def jacobian_spec(vf: VectorField) -> tuple[list[str], str]:
    """The ``'Jacobian'`` fnspec: (``['t', *sorted variables]``, ``"[[...], ...]"``).

    Rows are equations and columns variables, both in PyDSTool's sorted order; a 1-D system
    gets a bare expression (PyDSTool rejects brackets there).
    """
    order = vf.pydstool_order
    jac = jacobian_matrix(vf, order)
    if len(order) == 1:  # PyDSTool rejects brackets in the Jacobian of a 1-D system
        return [TIME.name, *order], pydstool_str(jac[0, 0])
    rows = ["[" + ", ".join(pydstool_str(jac[i, j]) for j in range(len(order))) + "]"
            for i in range(len(order))]
    return [TIME.name, *order], "[" + ",\n ".join(rows) + "]"


def _spec_payload(vf: VectorField, jacobian: bool) -> dict[str, Any]:
    return {
        "codegen": CODEGEN_VERSION,
        # the generator's files by their bytes: an edit that forgets CODEGEN_VERSION still rebuilds
        "code": cache.code_fingerprint("kernel"),
        "jacobian": bool(jacobian),
        "variables": list(vf.variables),
        "rhs": [pydstool_str(e) for e in vf.rhs],
        "parameters": [p for p, _ in vf.parameters],
        "auxiliary": [[a.name, list(a.args), pydstool_str(a.expr)] for a in vf.auxiliary],
    }


def model_name(vf: VectorField, jacobian: bool = True) -> str:
    """``<vf.name>_<12 hex>``: the hash covers the equations, the variable, parameter and
    auxiliary function names, whether the explicit Jacobian is compiled in, `CODEGEN_VERSION` and
    the sha256 of ``autocable/codegen``'s files (`autocable._store.code_fingerprint`).

    Parameter *values* are excluded (they are set at run time without rebuilding).
    """
    return f"{vf.name}_{cache.content_hash(_spec_payload(vf, jacobian))}"


@functools.lru_cache(maxsize=64)
def _spec_strings(vf: VectorField, jacobian: bool):
    """(name, varspecs, fnspecs) of ``vf``: printing and the symbolic Jacobian cost up to seconds
    for the amplitude equations, and continuation asks for the same model many times. A pure
    function of the frozen `VectorField`, so memoising it changes no result."""
    name = model_name(vf, jacobian)
    varspecs = {v: pydstool_str(e) for v, e in zip(vf.variables, vf.rhs)}
    # The symbolic Jacobian of the wind AME takes seconds of sympy in every process; its text is
    # kept next to the libraries, under the model name (a hash of the printed equations).
    path = cache.cache_dir("pydstool", "specs") / f"{name}.json"
    stored = cache.load_checked_json(path, f"PyDSTool spec {path.name}")
    if isinstance(stored, dict) and stored.get("varspecs") == varspecs and isinstance(stored.get("fnspecs"), dict):
        fnspecs = {k: (tuple(v[0]), v[1]) for k, v in stored["fnspecs"].items()}
    else:
        fnspecs = {a.name: (tuple(a.args), pydstool_str(a.expr)) for a in vf.auxiliary}
        if jacobian:
            args, text = jacobian_spec(vf)
            fnspecs["Jacobian"] = (tuple(args), text)
        cache.store_checked_json(path, {"model": name, "varspecs": varspecs,
                                        "fnspecs": _jsonable_fnspecs(fnspecs)})
    return name, MappingProxyType(varspecs), MappingProxyType(fnspecs)


def pydstool_args(vf: VectorField, *, tdata: Sequence[float] = (0.0, 1.0),
                  ics: Mapping[str, float] | Sequence[float] | None = None,
                  pars: Mapping[str, float] | None = None,
                  algparams: Mapping[str, Any] | None = None,
                  jacobian: bool = True) -> dict[str, Any]:
    """The keyword dictionary PyDSTool's generator classes take (``PyDSTool.args`` contents)."""
    name, varspecs, fnspecs = _spec_strings(vf, bool(jacobian))
    values = vf.parameter_defaults
    values.update({str(k): float(v) for k, v in (pars or {}).items()})
    unknown = set(values) - set(vf.parameter_defaults)
    if unknown:
        raise ValueError(f"model {vf.name!r} has no parameters {sorted(unknown)}")
    out = {
        "name": name,
        "varspecs": dict(varspecs),
        "pars": values,
        "fnspecs": {k: (list(v[0]), v[1]) for k, v in fnspecs.items()},
        "tdata": [float(tdata[0]), float(tdata[1])],
        "ics": _state_dict(vf, ics) if ics is not None else {v: 0.0 for v in vf.variables},
        "checklevel": 0,
    }
    if algparams:
        out["algparams"] = dict(algparams)
    return out


def _state_dict(vf: VectorField, state) -> dict[str, float]:
    if isinstance(state, Mapping):
        missing = set(vf.variables) - {str(k) for k in state}
        if missing:
            raise ValueError(f"initial state lacks {sorted(missing)}")
        return {v: float(state[v]) for v in vf.variables}
    values = np.asarray(state, dtype=float).ravel()
    if values.shape != (len(vf.variables),):
        raise ValueError(f"initial state must have {len(vf.variables)} values ({vf.variables}), got {values.shape}")
    return dict(zip(vf.variables, values.tolist()))


# --------------------------------------------------------------------------------------------
# building

def pydstool_cache_dir() -> Path:
    """The folder PyDSTool builds in and imports from: ``cache_root()/pydstool``."""
    return cache.cache_dir("pydstool")


@dataclass(frozen=True)
class OdeGenerator:
    """A built PyDSTool generator together with the `VectorField` it came from.

    ``pydstool`` is the PyDSTool generator itself. It is stateful and, for compiled kinds, shared
    by every handle on the same library in this process (see `_LIVE`), so `integrate` sets the
    initial state, all ``parameters`` (overridden per call), the handle's ``algparams`` and the time
    span on every call rather than relying on what an earlier call left. ``reused`` tells whether
    an existing library was loaded instead of compiling; ``build_seconds`` the wall time taken.
    """

    field: VectorField
    kind: str
    name: str
    pydstool: Any
    parameters: Mapping[str, float]
    algparams: Mapping[str, Any]
    reused: bool
    build_seconds: float


# PyDSTool's compiled integrators keep their run state in C globals, one set per library: a second
# generator object on a library already used in this process silently drops the requested sample
# times (measured). So a process holds at most one PyDSTool generator per compiled library, shared
# by all handles. This registry mirrors the C module's own process-wide lifetime; it is the only
# module-level mutable state in autocable.codegen.
_LIVE: dict[str, Any] = {}


def _build_lock(folder: Path, name: str):
    """Serialise builds of one model name across processes (`autocable._store.cache_lock`: recovers
    from a damaged lock, runs unlocked in a read-only cache, where nothing is built)."""
    locks = folder / "locks"
    if not locks.is_dir():
        try:
            locks = cache.cache_dir(*locks.relative_to(cache.cache_root()).parts)
        except cache.CacheError:
            return contextlib.nullcontext()   # read-only: a reader needs no lock
    return cache.cache_lock(locks / f"{name}.lock")


#: Version of the build manifests (`_manifest_ok`); another value rebuilds without a warning.
MANIFEST_FORMAT = "pydstool-build/2"


def _manifest_ok(manifest: Any, files: Mapping[str, Path]) -> bool:
    """Whether ``manifest`` (a build's JSON) records exactly the sha256 of each of ``files``."""
    recorded = manifest.get("sha256") if isinstance(manifest, dict) else None
    return isinstance(recorded, dict) and all(
        recorded.get(role) is not None and recorded.get(role) == cache.file_sha256(path)
        for role, path in files.items())


def _current(manifest: Any) -> bool:
    """A manifest of this format and environment (otherwise a rebuild is expected, not a fault)."""
    return (isinstance(manifest, dict) and manifest.get("format") == MANIFEST_FORMAT
            and manifest.get("environment") == _environment())


def _environment() -> dict[str, str]:
    """What a compiled library depends on besides its source (a mismatch forces a rebuild)."""
    dst = sys.modules.get("PyDSTool")
    return {"python": sys.implementation.cache_tag, "numpy": np.__version__,
            "pydstool": getattr(dst, "__version__", "?")}


def _library_files(folder: Path, modname: str) -> tuple[Path, Path, Path]:
    suffix = importlib.machinery.EXTENSION_SUFFIXES[0]
    return folder / f"_{modname}{suffix}", folder / f"{modname}.py", folder / f"{modname}.json"


def make_ode_generator(vf: VectorField, kind: str = "Dopri", *,
                       tdata: Sequence[float] = (0.0, 1.0),
                       ics: Mapping[str, float] | Sequence[float] | None = None,
                       pars: Mapping[str, float] | None = None,
                       algparams: Mapping[str, Any] | None = None,
                       jacobian: bool = True) -> OdeGenerator:
    """Build (or load) a PyDSTool ODE generator for ``vf``.

    ``kind`` is ``"Dopri"`` (compiled DOP853, the fast default), ``"Radau"`` (compiled Radau5,
    needs a Fortran compiler) or ``"Vode"`` (scipy's VODE with a Python right-hand side: no build).
    ``algparams`` pass through to PyDSTool (for Dopri: ``rtol``, ``atol`` as in scipy,
    ``max_step``, ``max_pts``...). Compiled kinds build in `pydstool_cache_dir` under
    `model_name`; when an earlier process built the same model, its library is loaded without
    compiling. All output is silenced; failures raise `PyDSToolError`.
    """
    if kind not in GENERATOR_KINDS:
        raise ValueError(f"unknown generator kind {kind!r}; choose one of {sorted(GENERATOR_KINDS)}")
    dst = import_pydstool()
    class_name, libname = GENERATOR_KINDS[kind]
    args = pydstool_args(vf, tdata=tdata, ics=ics, pars=pars, algparams=algparams, jacobian=jacobian)
    name = args["name"]
    settings = dict(algparams or {})
    start = time.perf_counter()
    folder = pydstool_cache_dir()
    what = f"building the {kind} integrator for model {vf.name!r}"
    gen_class = getattr(dst.Generator, class_name)

    def handle(gen, reused):
        return OdeGenerator(vf, kind, name, gen, dict(args["pars"]), settings, reused,
                            time.perf_counter() - start)

    if libname is None:
        with quiet() as chatter, pydstool_errors(what, chatter):
            gen = gen_class(dst.args(**args))
            memoize_name_map(gen)
            return handle(gen, False)

    modname = f"{libname}_{name}_vf"
    if modname in _LIVE:
        gen = _LIVE[modname]
        with quiet() as chatter, pydstool_errors(what, chatter):
            unknown = sorted(set(settings) - set(gen.algparams))
            if unknown:
                raise ValueError(f"Invalid keys present in algparams argument: {unknown}")
            # The shared generator must look as if made by this call (PyCont starts from its ics).
            gen.set(ics=args["ics"], pars=args["pars"], tdata=args["tdata"], algparams=settings)
        return handle(gen, True)
    package = f"{libname}_temp"
    so_file, py_file, manifest_file = _library_files(folder / package, modname)
    pickled = folder / package / f"{modname}.generator.pickle"
    rebuilt: list[str] = []     # said after the session, which silences fd 2
    not_kept: list[str] = []    # (the same)
    with _build_lock(folder, modname), pydstool_session(what, folder) as chatter:
        manifest = cache.read_json(manifest_file)
        library = {"library": so_file, "wrapper": py_file}
        reusable = _current(manifest) and _manifest_ok(manifest, library)
        if not reusable and any(f.exists() for f in (so_file, py_file, manifest_file)) \
                and (_current(manifest) or not isinstance(manifest, dict)):
            # e.g. an emptied wrapper or a library cut short by a killed build: importing it would
            # "work" and every integration fail
            rebuilt.append(f"PyDSTool library {modname}")
        # PyDSTool's FuncSpec parsing of the equations takes seconds for the wind AME in every
        # process; the generator as constructed (before any run, no algparams) is kept next to
        # its library and unpickled instead (PyDSTool's own pickling protocol: the C module is
        # re-imported on first use), once its sha256 matches the manifest.
        gen = None
        if reusable and pickled.exists() and manifest["sha256"].get("generator") is not None:
            if _manifest_ok(manifest, {"generator": pickled}):
                gen = _unpickle_generator(pickled, modname)
            if gen is None:
                rebuilt.append(f"pickled generator {pickled.name}")
        from_pickle = gen is not None
        if gen is None:
            # Never let PyDSTool build on its own: its reuse check looks for '_<mod>.so' while
            # Python 3 names extensions '_<mod>.cpython-311-...so' (so it would recompile every
            # time), and its build breaks in folders with a dot in their path (see
            # compat.build_generator_library).
            gen = gen_class(dst.args(**{k: v for k, v in args.items() if k != "algparams"}, nobuild=True))
        # `modname` also creates PyDSTool's build helper, which makes '<lib>_temp' in the *current*
        # directory: touch it here, inside the cache folder.
        if gen.modname != modname:
            raise PyDSToolError(f"{what} failed: PyDSTool named the library {gen.modname!r}, "
                                f"expected {modname!r}", what=what)
        if reusable:
            try:
                importlib.import_module(f"{package}.{modname}")
            except ImportError:  # a library that matches its hash but does not load here
                reusable = False
                rebuilt.append(f"PyDSTool library {modname}")
        if not reusable:
            _remove_stale(so_file, py_file, manifest_file, pickled)
            sys.modules.pop(f"{package}.{modname}", None)
            sys.modules.pop(f"{package}._{modname}", None)
            try:
                build_generator_library(gen)
            except (Exception, SystemExit):
                if os.strerror(errno.ENOSPC) in chatter.tail():
                    # the compiler could not write its output: a full disk under the cache is the
                    # user's to fix (one line naming the cache), not a failure of PyDSTool
                    raise cache.cache_error(folder / package, OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))) \
                        from None
                raise
            if not so_file.exists():
                raise PyDSToolError(f"{what} failed: the compiler produced no library "
                                    f"(see the error's chatter)", what=what, chatter=chatter.tail())
            # Import now, while the cache folder is on sys.path: PyDSTool imports lazily at the
            # first integration, which may happen anywhere.
            importlib.import_module(f"{package}.{modname}")
        if not (reusable and from_pickle):
            pickled_ok = from_pickle or _pickle_generator(gen, pickled)
            files = {**library, **({"generator": pickled} if pickled_ok else {})}
            record = {"format": MANIFEST_FORMAT, "model": name, "kind": kind,
                      "environment": _environment(),
                      "sha256": {role: cache.file_sha256(path) for role, path in files.items()},
                      "spec": {"varspecs": args["varspecs"], "fnspecs": _jsonable_fnspecs(args["fnspecs"]),
                               "pars": sorted(args["pars"])}}
            # The model name (the key) holds the fingerprint of autocable/codegen taken when this
            # process first named the model: a library built after that code changed on disk may
            # not be the code the name says. Used now, not recorded (the next process rebuilds).
            changed = cache.loaded_code_changed("kernel")
            if changed:
                not_kept.append(f"autocable/{changed} changed after this process loaded it")
            elif reusable:
                # Only the pickle was missing: recording it is a speed-up, so a read-only cache
                # (where the pickle could not be written either) goes on without it.
                with contextlib.suppress(cache.CacheError):
                    _write_manifest(manifest_file, record)
            else:
                _write_manifest(manifest_file, record)
        unknown = sorted(set(settings) - set(gen.algparams))
        if unknown:
            raise ValueError(f"Invalid keys present in algparams argument: {unknown}")
        gen.set(ics=args["ics"], pars=args["pars"], tdata=args["tdata"], algparams=settings)
    if rebuilt:
        cache.report_rebuilt(rebuilt[0])
    if not_kept:
        cache.report_not_stored(f"PyDSTool library {modname}", not_kept[0])
    memoize_name_map(gen)           # after pickling: the pickle keeps PyDSTool's own map
    _LIVE[modname] = gen
    return handle(gen, reusable)


def _remove_stale(*paths: Path) -> None:
    """Delete the files of a build about to be made again; this is also the first write of the
    build, so a read-only cache fails here with `CacheError` rather than inside PyDSTool."""
    for path in paths:
        try:
            path.unlink()
        except FileNotFoundError:
            pass
        except OSError as exc:
            raise cache.cache_error(path, exc) from None
    cache.require_writable(paths[0].parent)


def _write_manifest(path: Path, record: dict) -> None:
    try:
        cache.atomic_write_json(path, record)
    except OSError as exc:
        raise cache.cache_error(path, exc) from None


def _pickle_generator(gen: Any, path: Path) -> bool:
    """Keep ``gen`` (constructed, never run) for later processes; False if it could not be kept
    (a failure only costs speed)."""
    import pickle
    try:
        blob = pickle.dumps(gen, protocol=pickle.HIGHEST_PROTOCOL)
    except Exception:   # noqa: BLE001 - an unpicklable generator is simply rebuilt next time
        return False
    try:
        cache.cache_write_bytes(path, blob)
    except cache.CacheError:
        return False
    return True


def _unpickle_generator(path: Path, modname: str) -> Any | None:
    """The generator `_pickle_generator` kept for ``modname``, or None (unreadable or foreign).
    The file sits in the user's own cache folder next to the compiled library it drives, written
    by this module under the same content-hashed name, and its sha256 was checked against the
    build manifest before this is called."""
    import pickle
    try:
        gen = pickle.loads(path.read_bytes())  # noqa: S301 - autocable's own cache file
    except Exception:   # noqa: BLE001 - a truncated or incompatible file: build instead
        return None
    return gen if getattr(gen, "modname", None) == modname else None


def _jsonable_fnspecs(fnspecs):
    return {k: [list(v[0]), v[1]] for k, v in fnspecs.items()}


# --------------------------------------------------------------------------------------------
# integration

def integrate(generator: OdeGenerator, ics: Mapping[str, float] | Sequence[float],
              pars: Mapping[str, float] | None, t0: float, t1: float,
              dt_sample: float, *,
              algparams: Mapping[str, Any] | None = None,
              max_points: int | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Integrate from ``t0`` to ``t1`` and sample every ``dt_sample``.

    Returns ``(t, states)``: ``t`` = t0, t0+dt, ... (t1 included when it falls on the grid),
    ``states[k, i]`` the value of ``generator.field.variables[i]`` at ``t[k]``. ``t`` is absolute
    time, so a long run can be done in chunks, each starting from the last state of the previous.

    For Dopri/Radau the samples come from the compiled integrator's dense output at the requested
    times (PyDSTool's "special times"), read straight from its arrays: no Python per point. For
    Vode they are read from PyDSTool's trajectory on a mesh put on the sample times (slow; for
    cross-checks only).
    ``pars`` and ``algparams`` (e.g. ``{"rtol": 1e-8, "atol": 1e-10}``) override, for this call
    only, the values the generator was made with. ``max_points`` caps the accepted steps plus
    samples of this call (default and upper limit `MAX_OUTPUT_POINTS`): a caller that knows how
    many steps a bounded solution needs gives up on a blow-up that much sooner. Settings made directly on
    ``generator.pydstool`` do not survive: every call re-applies the handle's own.
    """
    vf, gen = generator.field, generator.pydstool
    t0, t1, dt = float(t0), float(t1), float(dt_sample)
    if not (t1 > t0 and dt > 0):
        raise ValueError(f"need t1 > t0 and dt_sample > 0, got t0={t0}, t1={t1}, dt_sample={dt}")
    n = int(math.floor((t1 - t0) / dt * (1 + 1e-12))) + 1
    grid = t0 + dt * np.arange(n)
    if abs(grid[-1] - t1) <= 1e-9 * dt:
        grid[-1] = t1  # e.g. 30 + 300*0.1 = 60.00000000000001 would lie beyond the run's end
    grid = np.minimum(grid, t1)
    state = _state_dict(vf, ics)
    what = f"integrating model {vf.name!r} from t={t0:g} to t={t1:g}"
    params = dict(generator.parameters)
    for key, value in (pars or {}).items():
        if key not in params:
            raise ValueError(f"model {vf.name!r} has no parameters [{key!r}]")
        params[key] = float(value)
    settings = {**generator.algparams, **(algparams or {})}
    unknown = sorted(set(settings) - set(gen.algparams))
    if unknown:
        raise ValueError(f"unknown {generator.kind} algparams {unknown}")
    order = vf.pydstool_order
    column = [order.index(v) for v in vf.variables]

    if generator.kind == "Vode":
        with quiet() as chatter, pydstool_errors(what, chatter):
            gen.set(ics=state, pars=params, tdata=[t0, t1],
                    # Vode reports on an even mesh of about init_step and interpolates linearly
                    # in between: strictdt puts the mesh exactly on the sample times.
                    algparams={**settings, "init_step": dt, "strictdt": True})
            traj = gen.compute("autocable")
            pts = traj(grid.tolist())
            states = np.column_stack([np.asarray(pts[v], dtype=float) for v in vf.variables])
        return grid, states

    # The output buffer holds every accepted step plus the samples; PyDSTool cannot grow it, so a
    # run that needs more steps is repeated with a larger buffer.
    ceiling = MAX_OUTPUT_POINTS if max_points is None else min(int(max_points), MAX_OUTPUT_POINTS)
    max_pts = min(max(int(gen.algparams.get("max_pts", 0)), 2 * n + 10_000), ceiling)
    for attempt in range(6):
        buffer_full = False
        with quiet() as chatter, pydstool_errors(what, chatter):
            gen.set(ics=state, pars=params, tdata=[t0, t1],
                    algparams={**settings, "specialtimes": grid.tolist(),
                               "use_special": 1, "max_pts": max_pts})
            try:
                gen.compute("autocable")
                break
            except Exception as exc:
                reasons = [str(info) for _, info in getattr(gen.diagnostics, "errors", [])]
                buffer_full = any("nmax" in r or "max_pts" in r for r in reasons)
                if not buffer_full:
                    if reasons:
                        raise PyDSToolError(f"{what} failed: {reasons[-1]}", what=what,
                                            chatter=chatter.tail()) from exc
                    raise
        if max_pts >= ceiling or attempt == 5:
            # A solution that needs this many steps is blowing up or far too stiff: growing the
            # buffer further only exhausts memory (8x per retry).
            raise PyDSToolError(f"{what} failed: more than {ceiling:,} integration steps "
                                "(the solution may be blowing up); shorten the interval or check "
                                "the parameters", what=what)
        max_pts = min(8 * max_pts, ceiling)
    solver = gen._solver  # PyDSTool's integrator object; its arrays hold the raw output
    times = np.asarray(solver.times, dtype=float)
    points = np.asarray(solver.points, dtype=float)
    hit = np.searchsorted(times, grid)
    hit = np.minimum(hit, len(times) - 1)
    if not np.array_equal(times[hit], grid):
        raise PyDSToolError(f"{what} failed: the integrator stopped at t={times[-1]:g} before "
                            f"reaching every sample time", what=what)
    return grid, points[:, hit].T[:, column].copy()


# --------------------------------------------------------------------------------------------
# continuation

def continuation_system(vf: VectorField, kind: str = "Dopri", *,
                        ics: Mapping[str, float] | Sequence[float] | None = None,
                        pars: Mapping[str, float] | None = None,
                        jacobian: bool = True, auto: bool = False) -> Any:
    """A PyCont ``ContClass`` for the autonomous system ``vf``, with its generator built.

    ``kind`` is ``"Dopri"`` (compiled right-hand side and Jacobian: fast) or ``"Vode"``. The
    explicit Jacobian (sympy, PyDSTool order) is included unless ``jacobian=False``.

    ``auto=True`` also builds (or reloads from the cache) PyCont's AUTO module, which cycle
    continuation (``LC-C``) needs. AUTO writes ``fort.9`` into the current directory while it runs,
    so run LC-C curves (``newCurve`` and ``forward``/``backward``) inside
    ``compat.pydstool_session("...", pydstool_cache_dir())``; equilibrium and codimension-2 curves
    (EP-C, LP-C, H-C2) need only `compat.quiet` to silence PyCont.
    """
    if kind not in ("Dopri", "Vode"):
        raise ValueError("continuation supports kind 'Dopri' or 'Vode'")
    if vf.time_dependent:
        raise ValueError(f"model {vf.name!r} depends on t: continuation needs an autonomous system")
    generator = make_ode_generator(vf, kind, ics=ics, pars=pars, jacobian=jacobian)
    dst = import_pydstool()
    what = f"setting up continuation for model {vf.name!r}"
    with quiet() as chatter, pydstool_errors(what, chatter):
        cont = dst.ContClass(generator.pydstool)
    if auto:
        _load_auto(cont, generator.name, f"building PyCont's AUTO module for model {vf.name!r}")
    return cont


def _load_auto(cont: Any, name: str, what: str) -> None:
    """Build PyCont's AUTO module for ``cont`` in the cache, or import the one built before.

    PyCont's own reuse check looks for ``_auto_<name>_vf.so`` while Python 3 writes
    ``_auto_<name>_vf.cpython-311-...so``: left alone it re-runs SWIG, gcc and the linker in every
    new process, overwriting a library another process may have loaded.
    """
    folder = pydstool_cache_dir()
    modname = f"auto_{name}_vf"
    so_file, py_file, manifest_file = _library_files(folder, modname)
    rebuilt: list[str] = []     # said after the session, which silences fd 2
    not_kept: list[str] = []    # (the same)
    with _build_lock(folder, modname), pydstool_session(what, folder) as chatter:
        manifest = cache.read_json(manifest_file)
        files = {"library": so_file, "wrapper": py_file}
        if _current(manifest) and _manifest_ok(manifest, files):
            cont.loadAutoMod(nobuild=True)
            cont.importAutoLib()
            return
        if any(f.exists() for f in (so_file, py_file, manifest_file)) \
                and (_current(manifest) or not isinstance(manifest, dict)):
            rebuilt.append(f"PyCont AUTO library {modname}")
        _remove_stale(so_file, py_file, manifest_file)
        cont.loadAutoMod()
        if cont._autoMod is None or not so_file.exists():
            raise PyDSToolError(f"{what} failed: no AUTO library was produced", what=what,
                                chatter=chatter.tail())
        changed = cache.loaded_code_changed("kernel")    # as for the generator's library
        if changed:
            not_kept.append(f"autocable/{changed} changed after this process loaded it")
        else:
            _write_manifest(manifest_file, {"format": MANIFEST_FORMAT, "model": name, "kind": "AUTO",
                                            "environment": _environment(),
                                            "sha256": {role: cache.file_sha256(path)
                                                       for role, path in files.items()}})
    if rebuilt:
        cache.report_rebuilt(rebuilt[0])
    if not_kept:
        cache.report_not_stored(f"PyCont AUTO library {modname}", not_kept[0])
