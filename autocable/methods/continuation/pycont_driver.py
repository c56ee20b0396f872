"""The parts that talk to PyCont: building its ContClass on the scaled field, and the chunked runs
of EP-C (equilibria) and LP-C/H-C2 (two-parameter curves) that stop at the range, a closed curve,
the point budget or a failure, keeping the points computed before it.

PyCont only produces points here (raw, in chart coordinates, with its own labels); everything
reported about them is computed by autocable elsewhere (`autocable.methods.continuation.equilibria`,
`autocable.methods.continuation.curves`)."""
from __future__ import annotations

import contextlib
import math
import re
import warnings
from dataclasses import dataclass, field

import numpy as np

from autocable.codegen import compat
from autocable.codegen.pydstool import continuation_system
from autocable.errors import CacheError, ComputationError
from autocable.methods.continuation.events import _hopf_check
from autocable.methods.continuation.chart import _Chart, _correct, _locate
from autocable.methods.continuation.problem import ContinuationSettings, EquilibriumProblem, Progress
from autocable.methods.continuation.curve_chart import _CURVES, _CurveChart, _kappa_direction


@dataclass
class _Side:
    """Raw output of one PyCont direction (mutable scratch, never returned to users)."""

    points: list
    pycont_special: list          # (type, Y)
    pycont_stab: list             # 'S'/'U'/'N' per point (None when unknown)
    reason: str = "max_points"
    message: str = ""
    # PyCont special points it detected but could not locate (continued past; autocable's test
    # functions locate them): one dict per such point, for the branch info
    unlocated: list = field(default_factory=list)


def _point_Y(chart: _Chart, pt) -> np.ndarray:
    return np.array([float(pt[v]) for v in chart.system.variables] + [float(pt["lam"])])


def _raw_Y(chart: _Chart, curve, row) -> np.ndarray:
    """A row of PyCont's work array (its own variable order: sorted names) in chart order."""
    values = dict(zip(curve.varslist, np.asarray(row)[curve.coords]))
    return np.array([float(values[v]) for v in chart.system.variables] + [float(row[curve.params[0]])])


_CLOSED = re.compile(r"closed curve", re.I)


def _contclass(chart: _Chart, Y0: np.ndarray, name: str):
    """A PyCont ContClass on the scaled field at the chart's parameters.

    One per continuation call: every direction is its own curve in it. Without it there is no
    engine and no branch: `ComputationError` (a failed run: the scene keeps its other runs and
    exits 3), never a branch that ends at its start with the command's success."""
    try:
        # the numbers as parameters: one generator per structure (`System.scaled_field`)
        return continuation_system(chart.system.scaled_field(True), "Dopri", ics=chart.point_dict(Y0),
                                   pars=chart.pycont_pars(0.0))
    except CacheError:
        raise       # an unwritable or full cache: the command's one-line error, not a branch's end
    except Exception as exc:  # noqa: BLE001 - reported in one line
        raise ComputationError(f"{name}: PyCont could not be set up: {_one_line(exc)}") from None


def _pycont_equilibria(cont, chart: _Chart, problem: EquilibriumProblem, settings: ContinuationSettings,
                       Y0: np.ndarray, direction: np.ndarray, name: str, side_name: str,
                       progress: Progress | None) -> _Side:
    """Continue from Y0 along ``direction`` (a unit vector in chart coordinates) with PyCont EP-C,
    in chunks, until the range ends, the curve closes, the budget is spent or PyCont fails."""
    dst = compat.import_pydstool()
    side = _Side([Y0.copy()], [], [None])
    lo, hi = chart.lam(problem.bounds[0]), chart.lam(problem.bounds[1])
    locate = [t for t in settings.locate if not (t == "H" and chart.system.dimension < 2)]

    def start(Y, d, suffix):
        """A new EP-C curve from Y along d; None and a message when PyCont cannot start."""
        cname = f"{name}_{side_name}{suffix}"
        try:
            with _silent():
                cont.newCurve(dst.args(
                    name=cname, type="EP-C", freepars=["lam"], initpoint=chart.point_dict(Y),
                    initdirec={k: float(v) for k, v in zip(list(chart.system.variables) + ["lam"], d)},
                    StepSize=settings.step, MinStepSize=settings.min_step, MaxStepSize=settings.max_step,
                    MaxNumPoints=settings.chunk + 1, MaxCorrIters=settings.max_corrector_iters,
                    LocBifPoints=locate, SaveEigen=True, verbosity=0, FuncTol=settings.tol,
                    VarTol=settings.tol, TestTol=settings.test_tol))
        except Exception as exc:  # noqa: BLE001 - PyCont raises anything; we report it in one line
            return None, f"PyCont could not start: {_one_line(exc)}"
        return cont[cname], ""

    curve, why = start(Y0, direction, "")
    if curve is None:
        side.reason, side.message = "error", why
        return side
    span_seen = 0.0
    first_call = True
    reported = 0
    while True:
        resume = False
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
            usable = raw.ndim == 2 and raw.shape[1] == Y0.size
            unlocated = _unlocated_special_point(exc)
            failure = exc
            if unlocated and usable and 1 <= loc < raw.shape[0] and len(side.unlocated) < MAX_UNLOCATED:
                # PyCont failed to locate a special point after its corrector had converged on
                # point loc, beyond the test function's sign change: that point is kept too, and
                # the continuation goes on from it (the special point is autocable's to locate).
                new = [_raw_Y(chart, curve, raw[i]) for i in range(1, loc + 1)]
                before = new[-2] if len(new) > 1 else side.points[-1]
                side.unlocated.append({"type": unlocated, problem.parameter: [chart.value(before[-1]),
                                                                              chart.value(new[-1][-1])],
                                       "error": _one_line(exc)})
                resume = True
            elif unlocated:
                new = [_raw_Y(chart, curve, raw[i]) for i in range(1, max(loc, 1))] if usable else []
                where = f"{problem.parameter} = {chart.value((new or side.points)[-1][-1]):.6g}"
                failure = PyContLocationError(
                    f"PyCont detected a {unlocated} point just beyond {where} and could not locate it "
                    f"(its location did not converge; {len(side.unlocated)} earlier such points on this side "
                    'were passed); engine = "compiled" continues without PyCont')
            else:
                new = [_raw_Y(chart, curve, raw[i]) for i in range(1, max(loc, 1))] if usable else []
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
        if resume:
            chord = side.points[-1] - side.points[-2]
            curve, why = start(side.points[-1], chord / np.linalg.norm(chord), f"_u{len(side.unlocated)}")
            if curve is None:
                side.reason, side.message = "error", why
                return side
            first_call = True
            continue
        where = f"{problem.parameter} = {chart.value(side.points[-1][-1]):.6g}"
        if _pycont_end(side, curve, failure, closed, new, where, settings.min_step,
                       settings.max_points, "max_points"):
            return side


#: How many special points PyCont may fail to locate on one side of a branch before the side ends.
MAX_UNLOCATED = 5


class PyContLocationError(RuntimeError):
    """PyCont detected a special point and could not locate it, once too often on one side."""


def _unlocated_special_point(exc: BaseException) -> str | None:
    """The type ("BP", "LP", "H") of the PyCont special point whose location or processing raised
    ``exc``, or None when ``exc`` came from elsewhere (the corrector, the set-up).

    PyCont locates a special point by a scipy ``fsolve`` whose convergence it does not check, then
    assumes the point found is one: its BP processing takes the eigenvector of the first eigenvalue
    of [J_x, J_p; v] below 5e-5 and raises IndexError when there is none (the 2-dof AME at U = 0,
    eta = 8e-4: the pitchfork at sigma = 0.00143 was "located" at sigma = 0.00051, where the
    smallest eigenvalue is 2e-4). The points on both sides of it are converged; only PyCont's
    record of the special point is lost, and autocable locates it with its own test functions."""
    tb = exc.__traceback__
    label = None
    while tb is not None:
        code = tb.tb_frame.f_code
        if code.co_name in ("locate", "process") and code.co_filename.endswith("BifPoint.py"):
            label = getattr(tb.tb_frame.f_locals.get("self"), "label", None)
        tb = tb.tb_next
    return label if label in ("BP", "LP", "H") else None


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
        if isinstance(failure, PyContLocationError):
            side.reason, side.message = "error", str(failure)
        elif "converge" in text.lower():
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
