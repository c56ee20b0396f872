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
* `periodic_orbit(system, values, x0)` then `continue_cycles_from_orbit(problem, settings, t, X, T)`:
  a stable periodic orbit found by integration (no Hopf point on its family in range, e.g. Fig. 8's
  P) and its branch, by autocable's compiled collocation.
* `switch_branch(result, "BP1", settings)`: the other branch through a branch point, both sides.
* `continue_folds(result, "LP1", "eta", (lo, hi))` / `continue_hopf(result, "H1", ...)`: the curve
  of folds (PyCont's LP-C) or of Hopf points (H-C2) through a labelled point, in the plane of the
  source's parameter and a second one. PyCont's steps, with its random test-function borders
  seeded, jumps and turn-backs restarted from the last good point; every point refined on
  autocable's own defining system (f = 0 plus a bordered test function) and checked (det J = 0,
  or a pair on the imaginary axis) with the exact Jacobian; CP, BT, ZH, GH, DH from autocable's
  test functions, compared with PyCont's labels.
* `continue_branch_points(result, "BP1", "eta", (lo, hi))`: the curve of symmetry-breaking
  pitchforks through a branch point of a mono-modal branch of a Z2-symmetric system (the AME at
  U = 0: a2 -> -a2), autocable's own pseudo-arclength on f_in(x_in, 0) = 0 plus a bordered test
  function of the out-of-plane Jacobian block (`branch_points`); with wind the symmetry is broken
  and it raises `SymmetryError` (the pitchforks unfold into folds).

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
collocation plus one variational integration each (~10-50 ms). `autocable bench continuation` measures both.

Engines. ``continue_equilibria(..., engine="compiled")`` and ``switch_branch(..., engine="compiled")``
replace PyCont's EP-C by autocable's own C kernel (`compiled_equilibria`, built by
`autocable.codegen.ckernel` from the same sympy field): a Keller pseudo-arclength loop with
PyCont's step control that also evaluates the test functions and counts unstable eigenvalues at
every point, a few microseconds per point; the analysis and the records are the same code as
above (special points then have ``confirmed_by_pycont = None``). The default stays ``"pycont"``.
``continue_cycles(..., engine="compiled")`` replaces PyCont's LC-C by autocable's own collocation
(AUTO's method, `compiled_cycles`) on the same kernel, with the same records (`cycles.cycle_result`).

Where. This package's front (this file) holds no code and loads its modules lazily, so that
importing one light module of the package (e.g. `settings`) does not load PyDSTool. The code lives in
small modules named for what they hold: `settings` (ContinuationSettings, the engine names),
`system` (System, ame_system, auto_state_scale), `problem` (problem, result, StartError), `chart`
(scaled coordinates, corrector, locator, Branch assembly), `events` (every test function: LP, BP, H
and l1 for equilibria, the multiplier crossings PD, NS, LPC for cycles), `curve_chart` (the
two-parameter chart and its codimension-2 test functions), `pycont_driver` (everything that calls
PyCont), `equilibrium_analysis`, `equilibria` (front of both engines) and `compiled_equilibria`,
`cycle_records`, `cycles` (front of both engines) and `compiled_cycles`, `orbits`, `curves`,
`equilibria_at`, `branch_points`. Import from here.
"""

from __future__ import annotations

import importlib

#: public name -> the module of this package that holds it
_WHERE = {
    "StartError": "problem",
    "EquilibriumProblem": "problem",
    "ContinuationResult": "problem",
    "ContinuationSettings": "settings",
    "ENGINES": "settings",
    "CYCLE_ENGINES": "settings",
    "System": "system",
    "ame_system": "system",
    "auto_state_scale": "system",
    "equilibrium_near": "equilibria",
    "settle": "equilibria",
    "continue_equilibria": "equilibria",
    "switch_branch": "equilibria",
    "continue_cycles": "cycles",
    "continue_cycles_from_orbit": "cycles",
    "periodic_orbit": "orbits",
    "continue_folds": "curves",
    "continue_hopf": "curves",
    "continue_branch_points": "branch_points",
    "SymmetryError": "branch_points",
    "first_lyapunov": "events",
    "bialternate": "events",
}

__all__ = sorted(_WHERE)


def __getattr__(name: str):
    if name not in _WHERE:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{_WHERE[name]}"), name)
    globals()[name] = value     # later look-ups skip this hook
    return value


def __dir__():
    return sorted(set(globals()) | set(_WHERE))
