"""Equilibrium continuation by the compiled C kernel (``engine="compiled"``): the same branches,
special points and stability as the PyCont path of `autocable.methods.continuation.equilibria`, at C speed.

What runs where. `autocable.codegen.ckernel` compiles, from the same sympy right-hand side PyCont
continues, F, J_x, J_p, the scaled chart (x~ = x / xscale, lam = (p - p0) / pscale) and a Keller
pseudo-arclength loop with PyCont's step control; per point it returns the polished point, its
tangent, the test functions autocable uses (the tangent's parameter component for LP,
det [DF~; t] for BP, det(2J (.) I) for Hopf), the count of eigenvalues with positive real part
(Routh array; -1 when undecided) and the eigenvalues of J, and it puts an extra point on each
zero of a test function inside a step (as AUTO does). The start (Newton at the start value and
the tangent there) is the kernel's too. Python then does what the PyCont path does with
PyCont's points, with the same code (`_analyse_equilibria` given the kernel's arrays): sign
changes of the test functions, location of each zero (`continuation_chart._locate`'s Brent search
on the chord with `_correct` onto the branch and the same test functions, run in C by
`CKernel.locate`: `_KernelChart.locate_test`), the rank test that tells LP from BP, the Hopf pair
check, l1 at Hopf points (`first_lyapunov`, exact sympy derivatives), and the `Branch` record.

Eigenvalues. The `Branch` keeps every point's eigenvalues: the kernel's (balancing, Hessenberg
reduction, double-shift QR; the same values as LAPACK's to rounding), sorted as the PyCont path
sorts numpy's. Stability is the kernel's Routh count (stable when 0); where the count is
undecided (an eigenvalue or a pair sum within ~1e-9 ||J|| of the imaginary axis) numpy's
(LAPACK's) eigenvalues of that point replace the kernel's and decide, and
``info["kernel_stability_disagreements"]`` counts decided points where the count and the
eigenvalues differ.

No PyCont runs, so every special point has ``confirmed_by_pycont = None``."""
from __future__ import annotations

import time
from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from autocable.codegen.ckernel import CKernel, compiled_kernel
from autocable.methods.continuation.events import _hopf_test
from autocable.methods.continuation.chart import _build_branch, _Chart, _correct, _tangent
from autocable.methods.continuation.equilibrium_analysis import _analyse_equilibria, _relabel, _start_on_chart
from autocable.methods.continuation.problem import (ContinuationResult, ContinuationSettings,
                                                    EquilibriumProblem, Progress, _resolve)
from autocable.results import EndPoint, SpecialPoint


@dataclass(frozen=True, eq=False)
class _KernelChart(_Chart):
    """The chart of `continuation_chart._Chart` with F~ and DF~ evaluated by the C kernel."""

    kernel: Any = None
    cfg: Any = None
    # The corrector asks for F~(Y) then DF~(Y) at the same Y: one C call serves both.
    memo: dict = field(default_factory=dict)

    @classmethod
    def around(cls, chart: _Chart, kernel: CKernel) -> "_KernelChart":
        cfg = kernel.config(chart.base, chart.k, chart.xscale, chart.pscale)
        return cls(chart.system, chart.k, chart.base, chart.xscale, chart.pscale, kernel, cfg)

    def _both(self, Y):
        key = np.asarray(Y, float).tobytes()
        if self.memo.get("key") != key:
            f, df = self.kernel.both(self.cfg, Y)
            self.memo.update(key=key, f=f, df=df)
        return self.memo["f"], self.memo["df"]

    def F(self, Y) -> np.ndarray:
        return self._both(Y)[0].copy()

    def jac(self, x, p) -> np.ndarray:
        return self.kernel.jac(x, p)

    def locate_test(self, kind: str, Ya, Yb, tol: float) -> tuple[np.ndarray, bool]:
        """`chart._locate` with `_analyse_equilibria`'s test function of ``kind`` (LP, BP, H),
        the whole Brent search in one C call (`CKernel.locate`)."""
        return self.kernel.locate(self.cfg, Ya, Yb, _KINDS[kind], tol)

    def lam_tangent(self, Y) -> np.ndarray | None:
        """The unit tangent at Y with a positive parameter component (None when [DF~; e_lam] is
        singular: a fold at Y)."""
        e = np.zeros(len(Y))
        e[-1] = 1.0
        return self.kernel.tangent(self.cfg, Y, e)

    def DF(self, Y) -> np.ndarray:
        return self._both(Y)[1].copy()


@dataclass
class _KSide:
    """One side computed by the kernel (scratch)."""

    arrays: dict
    reason: str
    message: str


_EMPTY_KEYS = ("Y", "T", "tests", "npos", "J", "E", "polished")
#: The test-function codes of the C locator (`CKernel.locate`).
_KINDS = {"LP": 0, "BP": 1, "H": 2}


def _single(chart: _KernelChart, Y: np.ndarray, t: np.ndarray) -> dict:
    """The kernel's per-point arrays for one point computed in Python (a junction)."""
    x, p = chart.to_phys(Y)
    J = chart.kernel.jac(x, p)
    ev = np.linalg.eigvals(J)
    return {"Y": Y[None, :].copy(), "T": t[None, :].copy(),
            "tests": np.array([[t[-1], np.linalg.det(np.vstack([chart.DF(Y), t])), _hopf_test(J)]]),
            "npos": np.array([int(np.sum(ev.real > 0))]), "J": J[None], "E": -np.sort(-ev)[None],
            "polished": np.zeros(1, bool)}


def _run_side(chart: _KernelChart, problem: EquilibriumProblem, settings: ContinuationSettings,
              Y0: np.ndarray, direction: np.ndarray) -> _KSide:
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    # The last entry: the kernel puts a point on each zero of a test function inside a step (as
    # AUTO does), so `_locate` brackets it between two branch points next to the zero.
    opts = (settings.step, settings.min_step, settings.max_step, settings.tol, settings.max_corrector_iters,
            lo, hi, settings.newton_tol, 1.0)
    out = chart.kernel.continue_side(chart.cfg, Y0, direction, opts, settings.max_points)
    last = chart.value(out["Y"][-1][-1])
    where = f"{problem.parameter} = {last:.6g}"
    reason = out.pop("reason")
    message = {
        "range": f"{problem.parameter} reached {last:g}",
        "closed": "the branch returned to its start point",
        "max_points": f"{len(out['Y'])} points computed; raise max_points to go further",
        "step_collapse": f"the corrector failed near {where} with the minimum step {settings.min_step:g} "
                         f"(a singular or non-finite system, or a step too large for the curvature): "
                         f"lower min_step or step",
    }.get(reason, f"the kernel stopped near {where}")
    return _KSide(out, reason, message)


def _reversed(arr: dict) -> dict:
    """A side's arrays in the opposite order, tangents turned round (vp and det [DF; t] are odd in
    the tangent; det 2J(.)I is not)."""
    out = {k: v[::-1].copy() for k, v in arr.items()}
    out["T"] = -out["T"]
    out["tests"][:, :2] *= -1.0
    return out


def _join(back: dict | None, fwd: dict) -> dict:
    """One branch from the backward side (reversed, without the shared start) and the forward side."""
    parts = [_reversed({k: v[1:] for k, v in back.items()})] if back is not None else []
    parts.append(fwd)
    return {k: np.concatenate([p_[k] for p_ in parts]) for k in _EMPTY_KEYS}


def _analysis_inputs(chart: _KernelChart, arr: dict) -> tuple[dict, dict]:
    """The precomputed arrays of `_analyse_equilibria` and the stability bookkeeping."""
    J = arr["J"]
    Y = arr["Y"]
    P = np.repeat(chart.base[None, :], len(Y), axis=0)
    P[:, chart.k] += chart.pscale * Y[:, -1]
    count = arr["npos"]
    decided = count >= 0
    # The kernel's eigenvalues (each row by decreasing real part, then decreasing imaginary part,
    # as the PyCont path sorts numpy's); numpy's where the Routh count is undecided (an
    # eigenvalue next to the imaginary axis: LAPACK decides its sign) or the kernel's QR failed.
    ev = arr["E"].copy()
    redo = ~decided
    if np.isnan(ev.real.sum()):           # the kernel's QR iteration failed somewhere
        redo |= np.isnan(ev.real).any(axis=1)
    if redo.any():
        ev[redo] = -np.sort(-np.linalg.eigvals(J[redo]), axis=1)
    numpy_count = np.count_nonzero(ev.real > 0, axis=1)
    stable = np.where(decided, count, numpy_count) == 0
    pre = {"X": Y[:, :-1] * chart.xscale, "P": P, "eigen": ev, "stable": stable, "T": arr["T"],
           "hopf": arr["tests"][:, 2], "bdet": arr["tests"][:, 1]}
    info = {"engine": "compiled", "kernel_undecided_stability": int(np.count_nonzero(~decided)),
            "kernel_stability_disagreements": int(np.count_nonzero(decided & (count != numpy_count))),
            "kernel_unstable_counts": count.tolist()}
    return pre, info


def continue_equilibria_compiled(problem: EquilibriumProblem,
                                 settings: ContinuationSettings = ContinuationSettings(), start=None, *,
                                 name: str = "EQ", directions: str = "both",
                                 progress: Progress | None = None) -> ContinuationResult:
    """`autocable.methods.continuation.equilibria.continue_equilibria` with the compiled kernel (same arguments,
    same result records). Raises `StartError` for a start that does not converge and
    `autocable.codegen.ckernel.KernelBuildError` (one line) when the kernel cannot be built."""

    t0 = time.perf_counter()
    sysm = problem.system
    kernel = compiled_kernel(sysm)
    chart = _KernelChart.around(_Chart.of(problem), kernel)
    # Newton (equilibrium_near's) and the start tangent, both in C.
    Y0, v0 = _start_on_chart(problem, settings, start, chart, kernel, newton=kernel.newton,
                             tangent=chart.lam_tangent)
    wanted = {"both": ("forward", "backward"), "forward": ("forward",), "backward": ("backward",)}[directions]
    t_setup = time.perf_counter()
    sides: dict[str, _KSide] = {}
    for side in wanted:
        if any(sd.reason == "closed" for sd in sides.values()):
            sides[side] = _KSide(None, "closed", "the branch is a closed curve, traversed in the other direction")
            continue
        sides[side] = _run_side(chart, problem, settings, Y0, v0 if side == "forward" else -v0)
        if progress:
            arr = sides[side].arrays
            progress(f"{name} ({side}): {len(arr['Y'])} points, {sides[side].message}")
    t1 = time.perf_counter()
    back = sides.get("backward", _KSide(None, "not_run", ""))
    fwd = sides.get("forward", _KSide(None, "not_run", ""))
    if fwd.arrays is None:
        fwd = replace(fwd, arrays=_single(chart, Y0, v0))
    arr = _join(back.arrays, fwd.arrays)
    pre, kinfo = _analysis_inputs(chart, arr)
    Ys = list(arr["Y"])
    an = _analyse_equilibria(chart, Ys, settings, name, None, [None] * len(Ys), precomputed=pre)
    nb = len(back.arrays["Y"]) - 1 if back.arrays is not None else 0
    ends = (EndPoint("backward", back.reason, chart.value(Ys[0][-1]), nb, back.message),
            EndPoint("forward", fwd.reason, chart.value(Ys[-1][-1]), len(fwd.arrays["Y"]) - 1, fwd.message))
    info = dict(an.info, **kinfo, start_index=nb, state_scale=chart.xscale,
                points_kept_unpolished=int(np.sum(~arr["polished"][1:])) if len(Ys) > 1 else 0)
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    t2 = time.perf_counter()
    return ContinuationResult(branch, problem, settings,
                              {"setup_s": t_setup - t0, "kernel_s": t1 - t_setup, "analysis_s": t2 - t1,
                               "points": len(Ys), **{f"kernel_{k}": v for k, v in kernel.timings}})


def switch_branch_compiled(source: ContinuationResult, bp: str | SpecialPoint,
                           settings: ContinuationSettings | None = None, *, name: str | None = None,
                           progress: Progress | None = None) -> ContinuationResult:
    """`autocable.methods.continuation.equilibria.switch_branch` with the compiled kernel: the same start points
    on the new branch (the BP shifted along the kernel vector orthogonal to the old tangent and
    corrected), each side continued by the kernel, joined through the BP (``BP0``)."""

    bp, problem, base_settings = _resolve(source, bp)
    settings = settings or base_settings
    if bp.type != "BP":
        raise ValueError(f"{bp.name} is a {bp.type} point, not a branch point")
    name = name or f"{source.branch.name}_{bp.label}"
    t0 = time.perf_counter()
    sysm = problem.system
    kernel = compiled_kernel(sysm)
    chart = _KernelChart.around(_Chart(sysm, sysm.parameter_names.index(problem.parameter),
                                       sysm.parameter_vector(bp.parameters), problem.state_scale,
                                       problem.span), kernel)
    Yb = chart.to_chart(bp.state, bp.value)
    _, s, vt = np.linalg.svd(chart.DF(Yb))
    kernel_vecs = vt[-2:]
    old = np.asarray(bp.extra.get("tangent", kernel_vecs[0]), float)
    old = kernel_vecs.T @ (kernel_vecs @ old)
    old /= np.linalg.norm(old)
    w = kernel_vecs[0] - (kernel_vecs[0] @ old) * old
    if np.linalg.norm(w) < 1e-8:
        w = kernel_vecs[1] - (kernel_vecs[1] @ old) * old
    w /= np.linalg.norm(w)
    t_setup = time.perf_counter()
    sides: dict[str, _KSide] = {}
    starts = {}
    for sign, side in ((1, "+"), (-1, "-")):
        if any(sd.reason == "closed" for sd in sides.values()):
            sides[side] = _KSide(None, "closed", f"the new branch is a closed curve through {bp.name}, "
                                                 f"traversed from the other side")
            continue
        Ys_, ok = _correct(chart, Yb + sign * settings.switch_step * w, w, settings.newton_tol)
        if not ok or np.linalg.norm(Ys_ - Yb) > 10 * settings.switch_step:
            sides[side] = _KSide(None, "no_convergence", f"no branch found at distance {settings.switch_step:g} "
                                                         f"from {bp.name}: try another switch_step")
            continue
        v = _tangent(chart.DF(Ys_))
        v = v if v @ (Ys_ - Yb) >= 0 else -v
        lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
        if not lo <= Ys_[-1] <= hi:
            sides[side] = _KSide(None, "range", "the new branch leaves the range at once")
            continue
        starts[side] = Ys_
        sides[side] = _run_side(chart, problem, settings, Ys_, v)
        if progress:
            progress(f"{name} ({side}): {len(sides[side].arrays['Y'])} points, {sides[side].message}")
    t1 = time.perf_counter()
    minus, plus = sides["-"], sides["+"]
    # The junction: the BP itself, its tangent the chord through it (its kernel is 2-D).
    a_ = starts.get("-", Yb)
    b_ = starts.get("+", Yb)
    chord = b_ - a_
    tb = chord / np.linalg.norm(chord) if np.linalg.norm(chord) > 0 else w
    mid = _single(chart, Yb, tb)
    parts = ([_reversed(minus.arrays)] if minus.arrays is not None else []) + [mid] \
        + ([plus.arrays] if plus.arrays is not None else [])
    arr = {k: np.concatenate([p_[k] for p_ in parts]) for k in _EMPTY_KEYS}
    ib = len(minus.arrays["Y"]) if minus.arrays is not None else 0
    pre, kinfo = _analysis_inputs(chart, arr)
    Ys = list(arr["Y"])
    an = _analyse_equilibria(chart, Ys, settings, name, None, [None] * len(Ys), skip=(ib,), precomputed=pre)
    junction = SpecialPoint(
        branch=name, type="BP", label="BP0", parameter=bp.parameter, value=bp.value, a1=bp.a1, a2=bp.a2,
        state=bp.state, parameters=bp.parameters, index=ib, converged=bp.converged,
        confirmed_by_pycont=None, origin="autocable",
        message=f"the branch point {bp.name} this branch was switched from", extra={"switched_from": bp.name})
    others = tuple(s_ for s_ in an.special if not (
        s_.type in ("BP", "LP")
        and np.linalg.norm(chart.to_chart(s_.state, s_.value) - Yb) <= 0.5 * settings.switch_step))
    an = replace(an, special=_relabel(tuple(sorted((junction,) + others, key=lambda s_: s_.index))))
    nm = len(minus.arrays["Y"]) if minus.arrays is not None else 0
    npl = len(plus.arrays["Y"]) if plus.arrays is not None else 0
    ends = (EndPoint("-", minus.reason, chart.value(Ys[0][-1]), nm, minus.message),
            EndPoint("+", plus.reason, chart.value(Ys[-1][-1]), npl, plus.message))
    info = dict(an.info, **kinfo, switched_from=bp.name, bp_index=ib, state_scale=chart.xscale)
    branch = _build_branch(name, "equilibrium", chart, an.x, an.p, an.stable, an.eigen, an.special, ends, info)
    prob = problem.at(**{problem.parameter: bp.value})
    return ContinuationResult(branch, prob, settings,
                              {"setup_s": t_setup - t0, "kernel_s": t1 - t_setup,
                               "analysis_s": time.perf_counter() - t1, "points": len(Ys),
                               **{f"kernel_{k}": v for k, v in kernel.timings}})


__all__ = ["continue_equilibria_compiled", "switch_branch_compiled"]
