"""The AME equilibria of continued branches at given parameter values, solved exactly.

Why. The report compares eq. (21)'s steady responses (the empty boxes of Figs. 9-10, and the
overlays of the other response figures) with the amplitude equations (22)-(24) at the same
parameter value. Reading the AME value off ``branches.csv`` by linear interpolation between
continuation points adds a chord error of the order of (step)^2 x curvature: on Fig. 5a's branch
that is 1e-3 relative, as large as the whole AME-vs-(21) error at eta* = 8.2e-5. Here each chord
that brackets the value only seeds Newton at fixed parameters (`equilibria.equilibrium_near`); the
converged point must stay on that chord's stretch of branch, and its stability is autocable's
usual verdict (every Jacobian eigenvalue with negative real part).
"""
from __future__ import annotations

import math
from typing import Iterable, Mapping

import numpy as np

from autocable.methods.continuation.problem import ContinuationResult
from autocable.methods.continuation.equilibria import equilibrium_near

__all__ = ["equilibria_at", "nearest_stable_equilibrium", "COLUMNS"]

#: Columns of the rows `equilibria_at` returns (and of a scene's ``overlay_ame.csv``).
COLUMNS = ("parameter", "value", "branch", "a1", "a2", "stable", "max_real_eigenvalue", "residual")


def equilibria_at(results: Mapping[str, ContinuationResult], parameter: str,
                  values: Iterable[float], *, tol: float = 1e-12) -> list[dict]:
    """Every equilibrium of the equilibrium branches in ``results`` continued in ``parameter`` at
    each of ``values``: one row (see `COLUMNS`) per distinct point, ordered by value then branch.

    A branch contributes one point per chord that brackets the value (several near folds). A
    Newton step that does not converge, or that leaves the chord's neighbourhood (it would have
    found some other branch), contributes nothing."""
    wanted = sorted({float(v) for v in values})
    rows: list[dict] = []
    for name, result in results.items():
        branch, problem = result.branch, result.problem
        if branch.kind != "equilibrium" or branch.parameter != parameter or len(branch) < 2:
            continue
        system = problem.system
        xs = np.column_stack([np.asarray(branch.table[v], float) for v in branch.variables])
        ps = np.asarray(branch.table[parameter], float)
        for value in wanted:
            found: list[np.ndarray] = []
            p = system.parameter_vector({**problem.values, parameter: value})
            for i in range(len(ps) - 1):
                p0, p1 = ps[i], ps[i + 1]
                if p0 == p1 or not min(p0, p1) <= value <= max(p0, p1):
                    continue
                w = (value - p0) / (p1 - p0)
                seed = xs[i] + w * (xs[i + 1] - xs[i])
                x, ok, residual = equilibrium_near(system, seed, p, tol=tol, scale=problem.state_scale)
                reach = np.linalg.norm(xs[i + 1] - xs[i]) + 1e-9 * problem.state_scale
                if not ok or np.linalg.norm(x - seed) > reach:
                    continue
                size = np.linalg.norm(x) + problem.state_scale
                if any(np.linalg.norm(x - y) <= 1e-8 * size for y in found):
                    continue    # the same point from the two chords that share a node
                found.append(x)
                eig = np.linalg.eigvals(system.jac(x, p)) if x.size else np.zeros(0)
                lead = float(np.max(eig.real)) if eig.size else -math.inf
                amps = system.amplitude_values(x)
                rows.append({"parameter": parameter, "value": value, "branch": name,
                             "a1": float(amps[0]), "a2": float(amps[1]) if len(amps) > 1 else 0.0,
                             "stable": bool(lead < 0), "max_real_eigenvalue": lead,
                             "residual": float(residual)})
    rows.sort(key=lambda r: (r["value"], r["branch"]))
    return rows


def nearest_stable_equilibrium(ame, values: Mapping[str, float], a1: float, a2: float = 0.0, *,
                               dof: str = "2dof", phases: int = 12, tol: float = 1e-13):
    """The stable equilibrium of the Cartesian AME (24) nearest the amplitudes (a1, a2) in the
    (a1, a2) plane at ``values`` (U, eta, sigma), or None.

    Why. A response of eq. (21) gives amplitudes but no phases, and the figure's branches need not
    hold the AME variant being compared (docs/ordering.md compares four). So Newton starts from a
    ring of phases (``phases`` for mode 1, a quarter of them for mode 2 relative to it) at those
    amplitudes; a converged point with every eigenvalue in the left half-plane is a candidate.
    ``dof = "1dof"`` is the A2 = 0 reduction (its a2 is 0). Returns ``(a1, a2, state)``."""
    from scipy.optimize import fsolve
    if dof not in ("2dof", "1dof"):
        raise ValueError(f"dof must be '2dof' or '1dof', got {dof!r}")
    src = ame.one_dof() if dof == "1dof" else ame
    rhs = src.cartesian_rhs()
    p = src.control(eta=values.get("eta", 0.0), U=values.get("U", 0.0), sigma=values.get("sigma", 0.0))
    best = None
    second = np.linspace(0.0, 2 * np.pi, max(phases // 4, 1), endpoint=False) if dof == "2dof" else (0.0,)
    for ph in np.linspace(0.0, 2 * np.pi, phases, endpoint=False):
        for dph in second:
            y0 = [a1 * math.cos(ph), a1 * math.sin(ph)]
            if dof == "2dof":
                y0 += [a2 * math.cos(ph + dph), a2 * math.sin(ph + dph)]
            y, _, ier, _ = fsolve(lambda z: rhs.f(z, p), y0, fprime=lambda z: rhs.jacobian(z, p),
                                  full_output=True, xtol=tol)
            if ier != 1 or not np.all(np.isfinite(y)) or np.max(np.linalg.eigvals(rhs.jacobian(y, p)).real) >= 0:
                continue
            amps = src.amplitudes(y)
            got = (float(amps[0]), float(amps[1]) if dof == "2dof" else 0.0)
            dist = math.hypot(got[0] - a1, got[1] - a2)
            if best is None or dist < best[0]:
                best = (dist, got, tuple(float(v) for v in y))
    return None if best is None else (best[1][0], best[1][1], best[2])
