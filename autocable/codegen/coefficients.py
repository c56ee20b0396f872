"""A right-hand side split into its structure and its numeric coefficients, so that compiled code
is built once per structure and the coefficients are passed at run time.

Why. The candidate models of the calibration (a few structures among hundreds of models: a zero
yaw, for one, removes terms) and cables that differ only in their inputs have the same amplitude
equations (22)-(24) up to the numeric values of their coefficients: the same monomials of the
amplitudes, the same parameter factors and the same denominators (sigma + omega_2 / omega_1 ...).
Code generated with the numbers printed into it (the C kernel of `autocable.codegen.ckernel`, the
DOP853 integrator of `autocable.codegen.cintegrate`, the polynomial form of the equilibrium search,
PyCont's equilibrium-continuation generator) is then a new build for every model. Here every
``sympy.Float`` of the right-hand side becomes a symbol ``ac_k<i>`` (equal values share one symbol,
so a repeated denominator stays one common subexpression), and the generated code reads the values
from an array: the build is keyed by the structure alone.

Canonical numbering. Two right-hand sides with the same structure must give the same template,
whatever their numbers. sympy orders the arguments of a sum or product by comparing them, numbers
included, so the weights are numbered in an order of the tree that does not look at the numbers:
the arguments of every sum and product sorted by a key of their shape (symbols, exact numbers,
operations; a Float is only "a number"), ties between arguments of the same shape broken by their
values (such arguments are interchangeable, so the template is the same either way). A structure
that happens to repeat one value in two places where another model has two values gives another
template and so another build; the results are right either way, because substituting the weights
into the template gives back the right-hand side exactly (tests/test_coefficients.py).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Sequence

import numpy as np
import sympy as sp

from autocable import _store as cache

__all__ = ["WEIGHT_PREFIX", "Template", "coefficient_template"]

#: The weights' symbol names: ``ac_k0``, ``ac_k1``, ... (no model or system name starts so).
WEIGHT_PREFIX = "ac_k"


@dataclass(frozen=True, eq=False)
class Template:
    """``rhs`` with its Floats replaced by the symbols ``weight_names`` (values ``weights``);
    ``key`` is a content hash of the template, the same for every right-hand side of its structure."""

    rhs: tuple
    weight_names: tuple
    weights: np.ndarray
    key: str

    # Equal (and hashed) by structure: the compiled builds of two equal-structure systems are one.
    def __eq__(self, other) -> bool:
        return isinstance(other, Template) and (self.key, self.weight_names) == (other.key, other.weight_names)

    def __hash__(self) -> int:
        return hash((self.key, self.weight_names))

    def restore(self) -> tuple:
        """The right-hand side with the weights put back (as Floats): the original one."""
        sub = {sp.Symbol(n): sp.Float(float(v), 17) for n, v in zip(self.weight_names, self.weights)}
        return tuple(e.xreplace(sub) for e in self.rhs)


def _canon(e, memo: dict):
    """(shape key, node, values): the key ignores every Float's value; the node is the tree with
    the arguments of sums and products in the canonical order; values are the Floats in that order."""
    # by identity: sympy may call Float(2.0) and Integer(2) equal, which must not share an entry
    got = memo.get(id(e))
    if got is not None:
        return got
    if isinstance(e, sp.Float):
        out = (("F", ""), ("F", float(e)), (float(e),))
    elif not isinstance(e, sp.Basic) or not e.args:
        out = (("L", sp.srepr(e)), ("L", e), ())
    else:
        parts = [_canon(a, memo) for a in e.args]
        if isinstance(e, (sp.Add, sp.Mul)):
            parts.sort(key=lambda p: (p[0], p[2]))
        head = type(e).__name__ if not isinstance(e, sp.core.function.AppliedUndef) else f"f:{e.func}"
        out = ((head, tuple(p[0] for p in parts)), ("N", e.func, tuple(p[1] for p in parts)),
               tuple(v for p in parts for v in p[2]))
    memo[id(e)] = out
    return out


def _rebuild(node, index: dict, symbols: list):
    tag = node[0]
    if tag == "F":
        k = index.get(node[1])
        if k is None:
            k = index[node[1]] = len(symbols)
            symbols.append(sp.Symbol(f"{WEIGHT_PREFIX}{k}"))
        return symbols[k]
    if tag == "L":
        return node[1]
    return node[1](*[_rebuild(c, index, symbols) for c in node[2]])


@functools.lru_cache(maxsize=64)
def _template(rhs: tuple) -> Template:
    # the check walks every expression: done once per right-hand side (cached with the template),
    # not on every call (it was 60 % of a compiled continuation call of 65 points)
    clash = sorted({s.name for e in rhs for s in e.free_symbols if s.name.startswith(WEIGHT_PREFIX)})
    if clash:
        raise ValueError(f"symbols {clash} use the prefix {WEIGHT_PREFIX!r} reserved for compiled coefficients")
    memo: dict = {}
    index: dict = {}
    symbols: list = []
    out = tuple(_rebuild(_canon(e, memo)[1], index, symbols) for e in rhs)
    values = np.array(list(index), dtype=float)       # insertion order = weight number
    values.setflags(write=False)                      # shared by every user of the template
    return Template(out, tuple(s.name for s in symbols), values,
                    cache.content_hash([sp.srepr(e) for e in out]))


def coefficient_template(rhs: Sequence) -> Template:
    """The `Template` of the right-hand side ``rhs`` (sympy expressions; module docstring).
    Raises ValueError when a symbol of ``rhs`` already has a weight's name."""
    return _template(tuple(sp.sympify(e) for e in rhs))
