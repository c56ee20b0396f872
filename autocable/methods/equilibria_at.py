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

from autocable.methods.continuation_problem import ContinuationResult
from autocable.methods.equilibria import equilibrium_near

__all__ = ["equilibria_at", "COLUMNS"]

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
