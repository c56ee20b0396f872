"""Derivatives of the amplitude equations' right-hand sides, as sympy builds them, without its
dispatch (the Jacobians of `System`, its Lyapunov tensors and the C kernel's derivatives).

Why. sympy's ``expr.diff(x)`` goes through ``Derivative.__new__`` (argument checks, variable
counting, caches) for every node of the tree, also for the many factors that do not hold ``x``.
The wind AME (24) is an expanded sum of about 180 terms per equation; its Jacobians J_x and J_p
took 2.5 s of sympy per model and its second and third derivative tensors 3.4 s (0.7 s and 0.9 s
here), the largest one-time costs of a cold scene and of every candidate model of the
calibration's bound stage.

`diff` computes the *same expression*: on Add, Mul and Pow with an exponent free of ``x`` it runs
the rule that sympy's ``_eval_derivative`` of that class runs (sympy 1.14: Add differentiates its
terms, Mul multiplies each factor's derivative into the other factors left to right, Pow returns
``self * (dbase * exp / base)``), building each result with the same operations in the same order,
so sympy's automatic simplification sees the same operands; any other node, or a Pow whose
exponent holds ``x``, is handed to sympy's own ``diff``. The results are therefore equal to
sympy's as expressions (``==``), not merely as functions, so the text lambdify prints, and every
number computed from it, is unchanged. tests/test_derivatives.py checks the equality on every
entry of the sample's wind and no-wind AME Jacobians and tensors.
"""
from __future__ import annotations

from functools import reduce

import sympy as sp

S = sp.S


def diff(expr: sp.Expr, x: sp.Symbol, memo: dict | None = None) -> sp.Expr:
    """d expr / d x (one symbol, first order), equal to ``expr.diff(x)``. ``memo`` (optional)
    keeps the derivatives of subexpressions across calls on one symbol set."""
    memo = {} if memo is None else memo
    return _diff(sp.sympify(expr), x, memo)


def _diff(e, x, memo):
    key = (e, x)
    hit = memo.get(key)
    if hit is not None:
        return hit
    if x not in e.free_symbols:
        out = S.Zero
    elif e is x or e == x:
        out = S.One
    elif e.is_Add:
        out = sp.Add(*[_diff(a, x, memo) for a in e.args])
    elif e.is_Mul:
        args = list(e.args)
        terms = []
        for i in range(len(args)):
            d = _diff(args[i], x, memo)
            if d:
                terms.append(reduce(lambda u, v: u * v, (args[:i] + [d] + args[i + 1:]), S.One))
        out = sp.Add.fromiter(terms)
    elif e.is_Pow and x not in e.exp.free_symbols:
        # sympy: self * (dexp * log(base) + dbase * exp / base) with dexp = 0; 0 * log(base) is
        # 0 (base is not zero where a derivative is taken) and Add(0, y) is y
        out = e * (_diff(e.base, x, memo) * e.exp / e.base)
    else:
        out = e.diff(x)
    memo[key] = out
    return out


def jacobian(rhs, xs, memo: dict | None = None) -> sp.Matrix:
    """``sp.Matrix(rhs).jacobian(xs)``, entry by entry with `diff`."""
    memo = {} if memo is None else memo
    rows = [sp.sympify(e) for e in rhs]
    return sp.Matrix([[_diff(f, x, memo) for x in xs] for f in rows])


def derive_by_array(exprs, xs, memo: dict | None = None) -> list:
    """``sympy.derive_by_array(exprs, xs).tolist()`` for a nested list ``exprs``: the derivative
    index first."""
    memo = {} if memo is None else memo

    def walk(e, x):
        if isinstance(e, list):
            return [walk(a, x) for a in e]
        return _diff(sp.sympify(e), x, memo)
    return [walk(exprs, x) for x in xs]
