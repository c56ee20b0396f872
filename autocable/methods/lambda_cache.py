"""Numeric functions of a `System` (f, J_x, J_p and the derivative tensors of the first Lyapunov
coefficient) from sympy, with the generated Python kept in the cache folder.

Why. For the wind AME (24) the Jacobians, the second and third derivative tensors and sympy's common
subexpression elimination take 5-15 s per process, every process, although the text sympy prints
is the same each time: a scene of Figs. 7-10 spent most of its warm run there. The text that
``sympy.lambdify`` generates is therefore stored under ``cache_dir("lambdas")``, named by a content
hash of the right-hand side (``sympy.srepr``), the argument names, the kind of function, the
sympy version and the sha256 of this module's code (`autocable._store.code_fingerprint`; a text
written while that code changed is not kept), and executed on later calls in the namespace lambdify
itself uses: the function is
the one lambdify would have made, without the differentiation and the elimination. The file's first
line holds the sha256 of the rest, checked before it is executed (a file that fails is written again).
"""
from __future__ import annotations

import functools
import hashlib
import inspect
from typing import Callable, Sequence

import sympy as sp

from autocable._store import (atomic_write_text, cache_dir, cache_error, code_fingerprint, code_refusal,
                              content_hash, report_not_stored, report_rebuilt)
from autocable.model import derivatives

#: What `numeric_function` can build from any right-hand side F(x; p).
KINDS = ("f", "jac", "jac_p", "d2", "d3")
#: What it can build from a right-hand side that is a polynomial in x only.
POLYNOMIAL_KINDS = ("poly",)


def _expression(kind: str, rhs: Sequence[sp.Expr], xs, ps):
    """The sympy object lambdify prints for ``kind``; derive_by_array puts the new index first."""
    if kind == "f":
        return sp.Matrix(list(rhs))
    if kind == "jac":
        return derivatives.jacobian(rhs, xs)
    if kind == "jac_p":
        return derivatives.jacobian(rhs, ps)
    if kind == "poly":
        return polynomial_form(rhs, xs)
    d2 = _second_derivatives(tuple(sp.sympify(e) for e in rhs), tuple(xs))
    if kind == "d2":
        return d2
    return derivatives.derive_by_array(d2, xs)


@functools.lru_cache(maxsize=4)
def _second_derivatives(rhs: tuple, xs: tuple) -> list:
    # The first Lyapunov coefficient asks for d2 and then d3 (= d/dx of d2): one differentiation
    # serves both (half a second of sympy for the wind AME).
    return derivatives.derive_by_array(derivatives.derive_by_array(list(rhs), xs), xs)


def polynomial_form(rhs: Sequence[sp.Expr], xs) -> list:
    """F as a polynomial in x: [C, E] with F_i = sum_m C[i][m](p) prod_j x_j^E[m][j], the monomials
    E sorted; `sympy.PolynomialError` when some F_i is not a polynomial in x.

    The terms of the expanded F_i are split into their powers of x and the rest, and the rests
    summed per monomial: what ``sympy.Poly(F_i, *x)`` gives, without building Poly's coefficient
    domain, a field of fractions in every other symbol of F, which for the wind AME (24) with its
    coefficients as symbols (`autocable.codegen.coefficients`: over 300) took 12 s; here 0.3 s."""
    index = {x: j for j, x in enumerate(xs)}
    rows = []
    for e in rhs:
        row: dict = {}
        for term in sp.Add.make_args(sp.expand(sp.sympify(e))):
            exps = [0] * len(xs)
            rest = []
            for f in sp.Mul.make_args(term):
                base, ex = f.as_base_exp()
                if base in index and ex.is_Integer and ex > 0:
                    exps[index[base]] += int(ex)
                elif f.free_symbols & index.keys():
                    raise sp.PolynomialError(f"{f} is not a polynomial in {list(xs)}")
                else:
                    rest.append(f)
            key = tuple(exps)
            row[key] = row.get(key, sp.Integer(0)) + sp.Mul(*rest)
        rows.append(row)
    monoms = sorted(set().union(*rows))
    return [[[row.get(m, sp.Integer(0)) for m in monoms] for row in rows], [list(m) for m in monoms]]


def _namespace() -> dict:
    """The globals lambdify gives its numpy functions (``from numpy import *`` and its additions)."""
    return dict(sp.lambdify([], 0, modules="numpy").__globals__)


def rhs_key(rhs: Sequence[sp.Expr]) -> str:
    """A content hash of the right-hand side (``sympy.srepr``: exact, including every Float)."""
    return rhs_key_of_srepr([sp.srepr(e) for e in rhs])


def rhs_key_of_srepr(texts: Sequence[str]) -> str:
    """`rhs_key` of the right-hand side whose ``sympy.srepr`` texts are ``texts``."""
    return content_hash(list(texts))


def function_key(kind: str, variables: Sequence[str], parameters: Sequence[str], key: str,
                 constants: Sequence[str] = (), code: str | None = None) -> str:
    """The content hash that names a cached function; ``key`` is `rhs_key` of the right-hand side,
    ``code`` the fingerprint of this module's code (default: its files now)."""
    # the code that writes the text (this module) by its bytes: an edit here needs no bump of "format"
    payload = {"kind": kind, "variables": list(variables), "parameters": list(parameters),
               "rhs": key, "sympy": sp.__version__, "format": 2, "code": code or code_fingerprint("lambda")}
    if constants:
        payload["constants"] = list(constants)
    return content_hash(payload)


def numeric_function(kind: str, variables: Sequence[str], parameters: Sequence[str],
                     rhs: Sequence[sp.Expr], *, key: str | None = None,
                     use_cache: bool = True, constants: Sequence[str] = ()) -> Callable:
    """``g(x, p)`` for ``kind`` in `KINDS`: f -> F (n x 1), jac -> dF/dx (n x n), jac_p -> dF/dp,
    d2 / d3 -> nested lists of the second / third derivatives (derivative indices first), poly ->
    [C, E], F as a polynomial in x (C[i][m] the coefficient of F_i at the monomial of exponents
    E[m], x unused; `sympy.PolynomialError` when F is not polynomial in x).

    ``rhs`` holds plain symbols named as ``variables`` and ``parameters``; ``key`` is its `rhs_key`
    when the caller has it already (hashing a long right-hand side takes a tenth of a second).
    ``constants`` name more symbols of ``rhs`` that ``p`` holds after the parameters and that
    nothing is differentiated by (the coefficients of `autocable.codegen.coefficients`: the text
    is then the same for every right-hand side of one structure)."""
    if kind not in KINDS + POLYNOMIAL_KINDS:
        raise ValueError(f"unknown numeric function {kind!r}: expected one of {KINDS + POLYNOMIAL_KINDS}")
    xs = [sp.Symbol(v) for v in variables]
    ps = [sp.Symbol(p) for p in parameters]
    args = (xs, ps + [sp.Symbol(c) for c in constants])
    if not use_cache:
        return sp.lambdify(args, _expression(kind, rhs, xs, ps), modules="numpy", cse=True)
    code = code_fingerprint("lambda")
    name = function_key(kind, variables, parameters, key or rhs_key(rhs), constants, code)
    path = cache_dir("lambdas") / f"{kind}-{name}.py"
    source = _checked_source(path) if path.exists() else None
    if source is not None:
        namespace = _namespace()
        exec(compile(source, str(path), "exec"), namespace)  # noqa: S102 - text lambdify wrote
        return namespace["_lambdifygenerated"]
    fn = sp.lambdify(args, _expression(kind, rhs, xs, ps), modules="numpy", cse=True)
    source = inspect.getsource(fn)
    why = code_refusal("lambda", code)
    if why:
        report_not_stored(f"numeric function {path.name}", why)
        return fn
    try:
        atomic_write_text(path, f"{_HEADER}{_sha(source)}\n{source}")
    except OSError as exc:
        raise cache_error(path, exc) from None
    return fn


_HEADER = "# sha256 "


def _sha(text: str) -> str:
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _checked_source(path) -> str | None:
    """The function text stored at ``path`` if its first line is the sha256 of the rest, else None
    (reported: the caller writes it again)."""
    try:
        head, _, source = path.read_text(encoding="utf-8").partition("\n")
    except (OSError, ValueError):
        head, source = "", ""
    if head.startswith(_HEADER) and head[len(_HEADER):] == _sha(source):
        return source
    report_rebuilt(f"numeric function {path.name}")
    return None
