"""`autocable calibrate`: the paper's unknown inputs searched against what Sect. 5 states.

The paper gives neither the yaw beta nor the rivulet angle Theta0 nor the air density, and leaves
open several readings that change the wind terms of eq. (21): the twist end conditions of eq. (20)
(`CableSpec.twist_ends`), the axes of the projection of eq. (14) (`AeroSpec.load_axes`), the sense of
eq. (12) (`AeroSpec.angle_convention`), the load length of eq. (11) (`AeroSpec.load_length`) and the
Multiple Scales ordering of the AME (the scenes' ``ordering``). A search-space file declares the
values to try (`load_space`); Theta0 is either calibrated from beta so that rest loses stability at
U_c through the in-plane mode (`autocable.model.calibration.calibrate`, every valid root kept), or
scanned.

Stage 1, the screen (cheap, the whole space). For each (readings, beta) point: every calibrated
Theta0, eq. (21) by the same Galerkin projection as `autocable derive` (its load expanded by
`aero.expand_load_jet`, equal to the sympy expansion to 1e-12), then the ``[[number]]`` and
``[[screen]]`` targets of the targets file, decided by `autocable.paper.targets`:
  * U_onset, omega1, rho (eq. 21's linear part);
  * zeta8 > 0: the galloping branch (25) exists above U_c (Fig. 3 is super-critical);
  * bounded_fraction: eq. (21) integrated from rest (q2 = 1e-6) for `T_SCREEN` time units at the
    target's (U*, eta*, sigma) stays below |q_k| = 0.1 (`integration.DIVERGED`);
  * ode21_a2_ratio, ame_a2_ratio: the largest a2 reached from rest over the target's sigmas at
    U* = 1.3, eta* = 1.4e-3 (Fig. 10) over the same at U = 0 (Fig. 6), by eq. (21) and by the AME
    (per ordering).
Both integrations use one compiled DOP853 (`autocable.codegen.cintegrate`) whose coefficients are
parameters, built once for the whole search: a point costs no compilation.

Stage 2, the full evaluation (the best few). The candidate's inputs are written as a model file and
every figure scene of ``runs/`` is run on it (`autocable figures`), then all targets are decided from
the output folders by the same code as report.md.

Stage 3, the bound (``--bound``, `autocable.paper.bound`): every candidate, its wind scenes run one at
a time until an upper bound on the statements it can show falls below the targets file's ``[goal]``;
the answer to "can any candidate of the space get there?".

Resumable: each finished (readings, beta) point is one JSON file under ``DIR/screen/``, each fully
evaluated candidate one folder under ``DIR/full/`` (a candidate stopped part-way reuses its finished
scenes); a rerun reads them and recomputes none. A point
that fails prints one line and the search goes on. Parallel: every screen point, every scene of a
full evaluation and every scene of the bound is a task of one executor (`autocable.executor`: a
LocalCluster of ``workers`` processes, or an existing Dask cluster's ``scheduler``); a lost worker
costs its task only.

Output: ``calibration.csv`` (one row per candidate: inputs, each target's value and verdict),
``map_<readings>.png`` (beta-Theta0 plane per reading, coloured by the screen targets met, the
points where eq. (21) stays bounded at U* = 1.3 marked) and ``calibration.md``.
"""
from __future__ import annotations

import csv
import functools
import hashlib
import json
import math
import os
import sys
import time
from dataclasses import asdict, dataclass, replace
from itertools import product
from pathlib import Path

import numpy as np

from autocable._paths import RUNS_DIR
from autocable.errors import EXIT_FAILED
from autocable.paper import targets as tg
from autocable.paper.candidates import (Readings, _drop_run, _failed_start, _finite, _recorded_drops,
                                        candidate_name, scene_complete, scene_on_model, screen_score,
                                        write_candidate_model)
from autocable.spec import ModelSpec, SpecError, load_model, read_toml
from autocable.plotting.style import styled

#: Time units eq. (21) and the AME are integrated from rest in the screen: enough for the in-plane
#: galloping at U* = 1.3 (growth rate ~1e-3 per unit) to saturate from a 1e-7 seed.
T_SCREEN = 20000.0
#: Start of every screen integration: rest with the out-of-plane imperfection the scenes use.
Q0 = (0.0, 0.0, 1e-6, 0.0)    # (q1, q1', q2, q2')
#: The support amplitude and wind of the Fig. 10 / Fig. 6 comparison (Sect. 5).
RATIO_ETA, RATIO_U = 1.4e-3, 1.3
READING_FIELDS = ("twist_ends", "load_axes", "angle_convention", "load_length", "air_density_kg_m3")
ORDERINGS = ("paper", "natural")


# ================================================================================================
# the search space
# ================================================================================================
@dataclass(frozen=True)
class SearchSpace:
    """The declared space: each field a tuple of the values to try (module docstring)."""

    twist_ends: tuple = ("natural", "restrained")
    load_axes: tuple = ("reference", "twisted")
    angle_convention: tuple = ("eq12", "mirrored")
    load_length: tuple = ("diameter",)
    air_density_kg_m3: tuple = (1.25,)
    ordering: tuple = ORDERINGS
    yaw_deg: tuple = tuple(float(x) for x in np.arange(-60.0, 60.01, 5.0))
    rivulet_angle_deg: tuple | str = ("calibrate", "zeta11")
    full: int = 3                     # candidates evaluated on every figure scene

    def readings(self) -> list[Readings]:
        return [Readings(*r) for r in product(self.twist_ends, self.load_axes, self.angle_convention,
                                              self.load_length, self.air_density_kg_m3)]

    def points(self) -> list[tuple[Readings, float]]:
        return [(r, float(b)) for r in self.readings() for b in self.yaw_deg]

    def theta0_values(self) -> list:
        """The rules (`THETA0_RULES`) or angles Theta0 takes at each point."""
        th = self.rivulet_angle_deg
        return [th] if isinstance(th, str) else list(th)


_CHOICES = {"twist_ends": ("natural", "restrained"), "load_axes": ("reference", "twisted"),
            "angle_convention": ("eq12", "mirrored", "reversed"), "load_length": ("diameter", "radius"),
            "ordering": ORDERINGS}


def _angles(value, path, field, lo, hi):
    """A list of angles, or {from, to, step}."""
    if isinstance(value, dict):
        if set(value) != {"from", "to", "step"}:
            raise SpecError(path, field, "expected a list of angles in degrees or {from = , to = , step = }")
        a, b, s = (value[k] for k in ("from", "to", "step"))
        if not all(isinstance(x, (int, float)) and not isinstance(x, bool) for x in (a, b, s)) or not s > 0 or b < a:
            raise SpecError(path, field, f"expected from <= to and step > 0, got {value!r}")
        value = list(np.arange(a, b + 1e-9 * max(1.0, abs(b)), s))
    if not isinstance(value, list) or not value:
        raise SpecError(path, field, "expected a non-empty list of angles in degrees or {from = , to = , step = }")
    out = []
    for x in value:
        if isinstance(x, bool) or not isinstance(x, (int, float, np.floating)) or not lo <= float(x) <= hi:
            raise SpecError(path, field, f"expected angles in degrees in [{lo:g}, {hi:g}], got {x!r}")
        out.append(float(x))
    return tuple(out)


def parse_space(data: dict, path="<space>") -> SearchSpace:
    """Validate a search-space document; one-line `SpecError` naming the file and field."""
    allowed = set(_CHOICES) | {"air_density_kg_m3", "yaw_deg", "rivulet_angle_deg", "full"}
    vals = {}
    for key, value in data.items():
        if key not in allowed:
            raise SpecError(path, key, f"unknown field; allowed: {', '.join(sorted(allowed))}")
        if key in _CHOICES:
            if not isinstance(value, list) or not value or any(v not in _CHOICES[key] for v in value):
                raise SpecError(path, key, f"expected a non-empty list of {', '.join(map(repr, _CHOICES[key]))}, "
                                           f"got {value!r}")
            vals[key] = tuple(dict.fromkeys(value))
        elif key == "air_density_kg_m3":
            # air at any height and temperature a cable meets: 0.5-1.5 kg/m^3; beyond 10 it is not air
            if not isinstance(value, list) or not value or any(
                    isinstance(v, bool) or not isinstance(v, (int, float)) or not 0 < v <= 10 for v in value):
                raise SpecError(path, key, f"expected a non-empty list of densities in (0, 10] kg/m^3, got {value!r}")
            vals[key] = tuple(float(v) for v in value)
        elif key == "yaw_deg":
            vals[key] = _angles(value, path, key, -90.0, 90.0)
        elif key == "rivulet_angle_deg":
            if isinstance(value, str) or (isinstance(value, list) and value and all(isinstance(v, str) for v in value)):
                rules = [value] if isinstance(value, str) else value
                if any(r not in THETA0_RULES for r in rules):
                    raise SpecError(path, key, f"expected a rule {', '.join(map(repr, THETA0_RULES))}, a list of "
                                               f"them, or angles in degrees; got {value!r}")
                vals[key] = rules[0] if len(rules) == 1 else tuple(dict.fromkeys(rules))
            else:
                vals[key] = _angles(value, path, key, -180.0, 180.0)
        elif key == "full":
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise SpecError(path, key, f"expected a number of candidates >= 0, got {value!r}")
            vals[key] = value
    return SearchSpace(**vals)


def load_space(path) -> SearchSpace:
    data, _ = read_toml(path)
    return parse_space(data, Path(path))


# ================================================================================================
# eq. (21) of one candidate, fast
# ================================================================================================
@functools.lru_cache(maxsize=None)
def _structure(spec: ModelSpec, twist_ends: str):
    """Statics, modes and the closed-form integrator (shared by every candidate of a twist reading)."""
    from autocable.model.modes import linear_modes
    from autocable.model.shapes import ClosedFormIntegrator
    from autocable.model.statics import cable_statics
    st = cable_statics(spec.cable)
    modes = linear_modes(st, twist_ends)
    return st, modes, ClosedFormIntegrator(modes.shapes)


def candidate_spec(spec: ModelSpec, readings: Readings, yaw_deg: float, theta0_deg: float | None) -> ModelSpec:
    """The model spec of one candidate (Theta0 None: to be calibrated)."""
    cable = replace(spec.cable, twist_ends=readings.twist_ends)
    aero = replace(spec.aero, load_axes=readings.load_axes, angle_convention=readings.angle_convention,
                   load_length=readings.load_length, air_density_kg_m3=readings.air_density_kg_m3,
                   yaw_deg=float(yaw_deg), rivulet_angle_deg=theta0_deg)
    return replace(spec, cable=cable, aero=aero)


#: How Theta0 is found from beta: "calibrate" (rest of eq. 21, both modes, loses stability at U_c
#: through the in-plane mode: `autocable.model.calibration.calibrate`, the sample's rule) or
#: "zeta11" (the mono-modal onset of eq. 25 and Fig. 3: zeta11 = -2 xi_s omega1, every root).
THETA0_RULES = ("calibrate", "zeta11")


def zeta11_roots(spec: ModelSpec, step_deg: float = 0.25) -> list[float]:
    """Every Theta0 in [-90, 90] deg with zeta11 = -2 xi_s omega1 (mono-modal onset at U_c)."""
    from scipy.optimize import brentq

    from autocable.model.aero import linear_load
    from autocable.model.curves import eq21_fits
    from autocable.model.galerkin import aero_scales, linear_aero_matrix
    st, modes, integ = _structure(spec, spec.cable.twist_ends)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    target = -2 * spec.cable.damping_ratio * modes.omega1
    a = spec.aero

    def g(th_deg):
        beta, th0 = math.radians(a.yaw_deg), math.radians(th_deg)
        lift, drag = eq21_fits(a, st.alpha, beta, th0)      # a table or a blend: its cubic at phi0
        lin = linear_load(lift, drag, st.alpha, beta, th0, a.angle_convention, a.load_axes)
        return linear_aero_matrix(integ, K, nu, st.m_star, lin)[(1, 2)] - target

    grid = np.arange(-90.0, 90.0 + 1e-9, step_deg)
    vals = [g(x) for x in grid]
    return [float(brentq(g, x0, x1, xtol=1e-12)) for x0, x1, g0, g1 in zip(grid[:-1], grid[1:], vals[:-1], vals[1:])
            if g0 * g1 < 0]


def theta0_roots(spec: ModelSpec, rule: str = "calibrate") -> tuple[list[float], list[tuple[float, str]]]:
    """(valid roots, rejected (root, why)) of the Theta0 calibration of ``spec`` [deg], by ``rule``
    (`THETA0_RULES`)."""
    if rule == "zeta11":
        return zeta11_roots(spec), []
    from autocable.model.calibration import CalibrationError, calibrate
    from autocable.model.galerkin import aero_scales
    st, modes, integ = _structure(spec, spec.cable.twist_ends)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    try:
        cal = calibrate(spec.aero, st, modes, integ, K, nu, spec.cable.damping_ratio)
    except CalibrationError as exc:
        return [], [(math.nan, str(exc))]
    why = dict(cal.rejected)
    return [r for r in cal.roots_deg if r not in why], list(cal.rejected)


def fast_ode(spec: ModelSpec):
    """Eq. (21) of a spec with both angles given, as `derive` computes it (same modes, statics and
    projection; the load expanded by `expand_load_jet`)."""
    from autocable.model.aero import expand_load_jet
    from autocable.model.curves import eq21_fits
    from autocable.model.galerkin import aero_scales, project
    st, modes, integ = _structure(spec, spec.cable.twist_ends)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    beta, th0 = math.radians(spec.aero.yaw_deg), math.radians(spec.aero.rivulet_angle_deg)
    lift, drag = eq21_fits(spec.aero, st.alpha, beta, th0)
    aero = expand_load_jet(lift, drag, st.alpha, beta, th0, spec.aero.angle_convention, spec.aero.load_axes)
    return project(st, modes, aero, K, nu, spec.cable.damping_ratio, integ,
                   provenance={"model": spec.name, "screen": True})


# ================================================================================================
# the no-wind ceiling: what no candidate can show
# ================================================================================================
#: (yaw, Theta0) pairs [deg] at which `no_wind_difference` compares every reading.
NO_WIND_ANGLES = ((0.0, 0.0), (30.0, 45.0), (-45.0, -60.0))


def no_wind_difference(spec: ModelSpec, space: "SearchSpace") -> float:
    """The largest relative difference between the non-aerodynamic terms of eq. (21) (eq. 21 at
    U = 0) over every reading of ``space``, each at the angles `NO_WIND_ANGLES`, and those of the
    first reading at the first angles: round-off when the premise of `no_wind_ceiling` holds (no
    searched input changes the cable without wind); inf when the terms themselves differ."""
    def terms(s):
        return {(t.equation, t.powers, t.forcing, t.u_power): t.coefficient for t in fast_ode(s).terms
                if t.origin != "aerodynamic"}
    ref = terms(candidate_spec(spec, space.readings()[0], *NO_WIND_ANGLES[0]))
    worst = 0.0
    for r in space.readings():
        for yaw, theta0 in NO_WIND_ANGLES:
            got = terms(candidate_spec(spec, r, yaw, theta0))
            if got.keys() != ref.keys():
                return math.inf
            for k, v in ref.items():
                worst = max(worst, abs(got[k] - v) / max(abs(v), 1e-300))
    return worst


def no_wind_ceiling(targets, scenes: dict) -> list[dict]:
    """The statements no candidate of the search space can show, from the no-wind scenes alone.

    A scene whose every row has U* = 0 is the same for every candidate: eq. (21) without wind does
    not depend on any input the search varies (`no_wind_difference`; the full evaluation runs the
    scenes with their own orderings). So a statement of such a scene has its verdict there for
    every candidate, and "wind moves the Hopf points" of Figs. 7-10 cannot be "yes" when the
    no-wind scene it is measured against has no Hopf point (`report.hopf_moved_ceiling`). Returns
    one dict per statement capped below "yes": id, says, best (its best possible verdict), why."""
    from autocable.paper.report import WIND_REFERENCE, hopf_moved_ceiling
    no_wind = {n for n, d in scenes.items() if d.ok and d.fixed().get("U") == 0.0}
    stmts = [t for t in targets if t.kind == "statement"]
    decided = {v.id: v for v in tg.decide_statements([t for t in stmts if t.scene in no_wind], scenes)}
    out = []
    for t in stmts:
        if t.id in decided and decided[t.id].shown != "yes":
            v = decided[t.id]
            out.append({"id": t.id, "says": t.says, "best": v.shown,
                        "why": f"decided by the no-wind scene {t.scene} alone: {v.evidence}"})
        elif t.says.startswith("wind moves the Hopf points") and WIND_REFERENCE.get(t.scene) in no_wind:
            ref = scenes[WIND_REFERENCE[t.scene]]
            best = hopf_moved_ceiling(ref)
            if best != "yes":
                out.append({"id": t.id, "says": t.says, "best": best,
                            "why": f"measured against the no-wind scene {ref.name}, which has no Hopf point: "
                                   f"the wind can create Hopf points there, not move them"})
    return out


def no_wind_signature(scenes: dict) -> str:
    """The no-wind scenes' statements and special points, as text: equal for two candidates when
    their no-wind scenes gave the same results (rounded to 8 digits)."""
    parts = []
    for n in sorted(scenes):
        d = scenes[n]
        if not (d.ok and d.fixed().get("U") == 0.0):
            continue
        feats = [(f[0], f[1]) for f in tg.scene_statements(d, scenes)]
        sps = sorted((s.get("branch", ""), s.get("label", ""), f"{float(s.get(s.get('parameter', 'sigma'), 'nan')):.8g}")
                     for s in d.specials)
        parts.append(f"{n}: {feats} {sps}")
    return "\n".join(parts)


# ================================================================================================
# generic compiled integrators: coefficients are parameters, one build for the whole search
# ================================================================================================
def _monomials(nvars: int, max_degree: int, min_degree: int = 0):
    return [m for m in product(range(max_degree + 1), repeat=nvars) if min_degree <= sum(m) <= max_degree]


#: eq. (21): every monomial of (q1, q2, q1', q2', eta f, eta f', eta f'') of degree 1 to 3.
ODE_KEYS = tuple(_monomials(7, 3, 1))
#: AME (24): every monomial of (r1, s1, r2, s2) of degree 0 to 3, per equation.
AME_KEYS = tuple(_monomials(4, 3, 0))


@functools.lru_cache(maxsize=1)
def _ode_integrator():
    import sympy as sp

    from autocable.codegen.cintegrate import compiled_integrator
    t = sp.Symbol("t")
    q = sp.symbols("q1 q2 v1 v2")
    eta, Om = sp.symbols("eta Omega")
    c = sp.symbols(f"c0:{2 * len(ODE_KEYS)}")
    f = (eta * sp.sin(Om * t), eta * Om * sp.cos(Om * t), -eta * Om**2 * sp.sin(Om * t))
    x = (q[0], q[1], q[2], q[3]) + f
    acc = []
    for k in range(2):
        acc.append(-sum(c[k * len(ODE_KEYS) + i] * sp.Mul(*[v**p for v, p in zip(x, m) if p])
                        for i, m in enumerate(ODE_KEYS)))
    names = ["eta", "Omega"] + [s.name for s in c]
    return compiled_integrator("calib_eq21_generic", ("q1", "q2", "v1", "v2"), tuple(names),
                               (q[2], q[3], acc[0], acc[1]), "t")


def ode_parameters(ode, U: float, eta: float, Omega: float) -> np.ndarray:
    """The generic integrator's parameters for eq. (21) at (U*, eta*, Omega): each coefficient
    times U^u (aerodynamic terms absent at U = 0), summed per monomial; eta enters the monomials."""
    index = {m: i for i, m in enumerate(ODE_KEYS)}
    p = np.zeros(2 + 2 * len(ODE_KEYS))
    p[0], p[1] = eta, Omega
    for t in ode.terms:
        if t.origin == "aerodynamic" and U == 0.0:
            continue
        key = tuple(t.powers) + tuple(t.forcing)
        if key not in index:
            raise ValueError(f"eq. (21) term {t.label} is outside the screen's compiled table")
        p[2 + (t.equation - 1) * len(ODE_KEYS) + index[key]] += t.coefficient * U ** t.u_power
    return p


def integrate_ode(ode, U: float, eta: float, sigma: float, t_end: float = T_SCREEN) -> dict:
    """Eq. (21) from `Q0` over [0, t_end]: bounded (below `DIVERGED`), and the half ranges of q1,
    q2 over the last 20 forcing periods (the amplitude convention of `Ode21Integrator`)."""
    from autocable.methods.integration.ode21 import DIVERGED
    ci = _ode_integrator()
    Omega = ode.omega1 + sigma
    period = 2 * math.pi / Omega
    n = int(t_end / period)
    t_end = n * period
    window = np.linspace(t_end - 20 * period, t_end, 20 * 32 + 1)
    grid = np.concatenate([[0.0], window])
    y0 = (Q0[0], Q0[2], Q0[1], Q0[3])
    r = ci.run(y0, grid, ode_parameters(ode, U, eta, Omega), rtol=1e-9, atol=1e-13, max_step=1.0,
               max_steps=int(400 * t_end) + 10000, bound=DIVERGED, n_bound=2)
    if not r.ok:
        return {"bounded": False, "a1": math.inf, "a2": math.inf, "t": r.t_reached, "status": r.status}
    w = r.y[1:]
    return {"bounded": True, "a1": 0.5 * float(np.ptp(w[:, 0])), "a2": 0.5 * float(np.ptp(w[:, 1])),
            "t": t_end, "status": r.status}


@functools.lru_cache(maxsize=1)
def _ame_integrator():
    import sympy as sp

    from autocable.codegen.cintegrate import compiled_integrator
    y = sp.symbols("r1 s1 r2 s2")
    w = sp.symbols(f"w0:{4 * len(AME_KEYS)}")
    rhs = tuple(sum(w[k * len(AME_KEYS) + i] * sp.Mul(*[v**p for v, p in zip(y, m) if p])
                    for i, m in enumerate(AME_KEYS)) for k in range(4))
    return compiled_integrator("calib_ame_generic", tuple(s.name for s in y), tuple(s.name for s in w), rhs, None)


def ame_parameters(rhs, p) -> np.ndarray:
    """The generic AME integrator's weights from a `CartesianRHS` at its parameter vector p."""
    index = {m: i for i, m in enumerate(AME_KEYS)}
    out = np.zeros(4 * len(AME_KEYS))
    weights = rhs._weights(p)
    for eq, exps, wv in zip(rhs.equation, rhs.state_exponents, weights):
        key = tuple(int(e) for e in exps)
        if key not in index:
            raise ValueError(f"AME row with state exponents {key} is outside the screen's compiled table")
        out[int(eq) * len(AME_KEYS) + index[key]] += wv
    return out


def integrate_ame(ame, U: float, eta: float, sigma: float, t_end: float = T_SCREEN) -> dict:
    """The Cartesian AME (24) from the amplitudes of `Q0` over [0, t_end]: bounded (|y| < 1), and
    the largest a1, a2 over the last fifth of the run (an equilibrium's amplitudes, or the top of a
    periodic slow flow's)."""
    from autocable.methods.integration.ame import initial_amplitudes
    ci = _ame_integrator()
    rhs = ame.cartesian_rhs()
    p = ame.control(eta=eta, U=U, sigma=sigma)
    y0 = initial_amplitudes(Q0, float(p[-1]))
    grid = np.concatenate([[0.0], np.linspace(0.8 * t_end, t_end, 401)])
    r = ci.run(y0, grid, ame_parameters(rhs, p), rtol=1e-9, atol=1e-14, max_step=50.0,
               max_steps=200000, bound=1.0, n_bound=4)
    if not r.ok:
        return {"bounded": False, "a1": math.inf, "a2": math.inf, "status": r.status}
    a = ame.amplitudes(r.y[1:])
    return {"bounded": True, "a1": float(a[:, 0].max()), "a2": float(a[:, 1].max()), "status": r.status}


# ================================================================================================
# the screen of one point
# ================================================================================================
@functools.lru_cache(maxsize=8)
def _no_wind_reference(spec: ModelSpec, sigmas: tuple, ordering: str) -> tuple[float, float]:
    """(largest a2 of eq. 21, largest a2 of the AME) from rest at U = 0, eta* = 1.4e-3 over the
    sigmas: Fig. 6. Eq. (21) at U = 0 is the same for every reading (tests/test_calibration.py)."""
    from autocable.model import multiscale
    ode = fast_ode(candidate_spec(spec, Readings("natural", "reference", "eq12", "diameter", 1.25), 0.0, 0.0))
    ame = multiscale.derive(ode, ordering, omega="exact")
    a21 = max(integrate_ode(ode, 0.0, RATIO_ETA, s)["a2"] for s in sigmas)
    aam = max(integrate_ame(ame, 0.0, RATIO_ETA, s)["a2"] for s in sigmas)
    return a21, aam


def screen_candidate(spec: ModelSpec, targets, ode, orderings=ORDERINGS) -> list[dict]:
    """The ``[[number]]`` and ``[[screen]]`` verdicts of one eq. (21), one dict per ordering:
    {target id: Verdict}; eq. (21)'s own targets are the same in each."""
    from autocable.model import multiscale
    base = {v.id: v for v in tg.decide_numbers(targets, tg.ode_numbers(ode))}
    zeta8 = sum(t.coefficient for t in ode.terms if t.name == "zeta8")
    runs21: dict = {}
    for t in targets:
        if t.kind != "screen":
            continue
        if t.quantity == "zeta8":
            base[t.id] = tg.decide_screen(t, zeta8)
        elif t.quantity == "onset_error_21":
            base[t.id] = tg.decide_screen(t, tg.onset_error_21(ode))
        elif t.quantity == "bounded_fraction":
            res = [runs21.setdefault(p, integrate_ode(ode, *p)) for p in t.points]
            frac = sum(r["bounded"] for r in res) / len(res)
            base[t.id] = tg.decide_screen(t, frac, "bounded at " + ", ".join(
                f"(U*={p[0]:g}, eta*={p[1]:g}, sigma={p[2]:g}): {'yes' if r['bounded'] else 'no'}"
                for p, r in zip(t.points, res)))
        elif t.quantity == "ode21_a2_ratio":
            a2w = max(runs21.setdefault((RATIO_U, RATIO_ETA, s), integrate_ode(ode, RATIO_U, RATIO_ETA, s))["a2"]
                      for s in t.sigmas)
            a20 = _no_wind_reference(spec, t.sigmas, "paper")[0]
            base[t.id] = tg.decide_screen(t, a2w / a20 if a20 > 0 else math.nan,
                                          f"largest a2 {a2w:.3e} with wind, {a20:.3e} without")
    out = []
    for ordering in orderings:
        row = dict(base)
        ame = None
        for t in targets:
            if t.kind == "screen" and t.quantity == "ame_a2_ratio":
                ame = ame or multiscale.derive(ode, ordering, omega="exact")
                a2w = max(integrate_ame(ame, RATIO_U, RATIO_ETA, s)["a2"] for s in t.sigmas)
                a20 = _no_wind_reference(spec, t.sigmas, ordering)[1]
                row[t.id] = tg.decide_screen(t, a2w / a20 if a20 > 0 else math.nan,
                                             f"largest a2 {a2w:.3e} with wind, {a20:.3e} without")
        out.append(row)
    return out


def compute_signature(targets) -> str:
    """What the screen computes for a targets file: the quantities of its ``[[screen]]`` targets
    with their points and sigmas (not the thresholds, which are applied when the results are read)."""
    return json.dumps(sorted([t.quantity, [list(p) for p in t.points], list(t.sigmas)]
                             for t in targets if t.kind == "screen"))


def point_key(readings: Readings, yaw_deg: float, theta0, signature: str = "", orderings=ORDERINGS) -> str:
    """The file name of one screen point: its inputs and what the screen computes for it
    (`compute_signature`): a changed computation recomputes, a changed threshold does not."""
    text = json.dumps([asdict(readings), round(float(yaw_deg), 9),
                       theta0 if isinstance(theta0, str) else round(float(theta0), 9),
                       hashlib.sha256(signature.encode()).hexdigest(), list(orderings)])
    return hashlib.sha256(text.encode()).hexdigest()[:12]


def redecide(c: dict, targets) -> dict:
    """A screened candidate's verdicts decided again from its stored values with ``targets`` (the
    thresholds of the targets file as it is now)."""
    out = {}
    for t in targets:
        if t.kind not in ("number", "screen"):
            continue
        old = c["verdicts"].get(t.id)
        value = old.get("value") if old else None
        value = math.nan if value is None else value
        v = tg.decide_number(t, value) if t.kind == "number" else tg.decide_screen(t, value)
        if old and t.kind == "screen" and "; " in old.get("evidence", ""):
            v = replace(v, evidence=v.evidence + "; " + old["evidence"].split("; ", 1)[1])
        out[t.id] = asdict(v) if old else asdict(replace(v, evidence="not computed by the screen"))
    return {**c, "verdicts": out}


def screen_point(spec: ModelSpec, targets, readings: Readings, yaw_deg: float, theta0,
                 orderings=ORDERINGS) -> dict:
    """Every candidate of one (readings, beta) point: Theta0 calibrated (each valid root) or given."""
    t0 = time.perf_counter()
    if theta0 in THETA0_RULES:
        roots, rejected = theta0_roots(candidate_spec(spec, readings, yaw_deg, None), theta0)
    else:
        roots, rejected = [float(theta0)], []
    cands = []
    for th in roots:
        cs = candidate_spec(spec, readings, yaw_deg, th)
        ode = fast_ode(cs)
        for ordering, verdicts in zip(orderings, screen_candidate(spec, targets, ode, orderings)):
            twist_mid = float(_structure(spec, readings.twist_ends)[1].shapes["theta2"].evaluate(np.array([0.5]))[0])
            cands.append({"readings": asdict(readings), "yaw_deg": yaw_deg, "rivulet_angle_deg": th,
                          "theta0_rule": theta0 if isinstance(theta0, str) else "given",
                          "ordering": ordering, "zeta8": sum(t.coefficient for t in ode.terms if t.name == "zeta8"),
                          "xi11_bar": sum(t.coefficient for t in ode.terms if t.name == "xi11_bar"),
                          "twist_mid_per_q2": twist_mid,
                          "verdicts": {k: asdict(v) for k, v in verdicts.items()}})
    return {"readings": asdict(readings), "yaw_deg": yaw_deg, "theta0": theta0, "status": "ok",
            "rejected_roots": rejected, "candidates": cands, "seconds": time.perf_counter() - t0}


#: The task starts of the last calibrate call in its folder (`autocable.executor.attempts`).
TASKS_JOURNAL = ".tasks.jsonl"


def _warm_worker() -> None:
    """What every worker loads once before its first task: the compiled generic integrators of the
    screen (built by the caller first: here they are only loaded) and the scene stack."""
    from autocable.paper.figures import _preload
    _ode_integrator()
    _ame_integrator()
    _preload()


def _worker(model_path: str, targets_path: str, readings: dict, yaw_deg: float, theta0, orderings, out_file: str):
    """One screen task on a worker: compute, then write its file atomically."""
    from autocable._store import atomic_write_json
    spec = load_model(model_path)
    targets = tg.load_targets(targets_path)
    try:
        res = screen_point(spec, targets, Readings(**readings), yaw_deg, theta0, tuple(orderings))
    except Exception as exc:  # noqa: BLE001 - one line per failed point, and the search goes on
        res = {"readings": readings, "yaw_deg": yaw_deg, "theta0": theta0, "status": "failed",
               "error": f"{type(exc).__name__}: {' '.join(str(exc).split())[:300]}", "candidates": []}
    res = _finite(res)
    atomic_write_json(Path(out_file), res)
    return res


# ================================================================================================
# scoring, the full evaluation, the outputs
# ================================================================================================
def decision_stamp() -> list:
    """What, besides the scenes, decides a full evaluation's verdicts: the AME-vs-(21) study's
    bounds (`autocable.studies.ame_bounds.STUDY_MAX_ERROR`), which judge every ``<scene>.boxes``."""
    from autocable.studies.ame_bounds import study_stamp
    return study_stamp()


def full_evaluation(model_path: Path, targets, c: dict, folder: Path, runs: Path, executor, say) -> dict:
    """Every figure scene on the candidate's model (`autocable.paper.figures.run_figures` on
    ``executor``, an `autocable.executor.Executor` or a worker count), then every target decided
    from the output folders by the report's code. Resumable: ``folder/verdicts.json``, stamped
    with the AME-vs-(21) study's bounds that decided its boxes (`decision_stamp`): a file of other
    bounds is decided again from the finished scenes (its recorded wall time kept)."""
    from autocable._store import atomic_write_json
    from autocable.paper.figures import run_figures
    done = folder / "verdicts.json"
    before = None
    if done.is_file():
        try:
            before = json.loads(done.read_text())
        except ValueError:
            before = None
        if isinstance(before, dict) and before.get("decided_with") == decision_stamp():
            return before
    model = write_candidate_model(model_path, c, folder / "model.toml")
    scene_dir = folder / "runs"
    scene_dir.mkdir(parents=True, exist_ok=True)
    for f in sorted(runs.glob("fig*.toml")):
        # A resumed evaluation keeps the copies it made, with the runs it dropped (below), so that
        # the scenes already computed from them are reused.
        if not (scene_dir / f.name).is_file():
            text = scene_on_model(f.read_text(), model, scene_dir)
            (scene_dir / f.name).write_text(text)
    t0 = time.perf_counter()
    errors: list[str] = []

    def figures(only):
        where = {"executor": executor} if hasattr(executor, "submit") else {"workers": int(executor)}
        outcomes = run_figures([scene_dir / f"{n}.toml" for n in only], folder / "out",
                               say=lambda m: None if m.endswith(".toml)") else say(f"  {m}"), **where)
        errors.extend(f"{o.name}: {o.error}" for o in outcomes if o.status != "ok")
        return {o.name: {"name": o.name, "status": o.status, "error": o.error} for o in outcomes}

    names = [f.stem for f in sorted(scene_dir.glob("fig*.toml"))]
    listed = {n: {"name": n, "status": "ok", "error": ""} for n in names
              if scene_complete(folder / "out" / n, scene_dir / f"{n}.toml")}
    computed = len(listed) < len(names)
    if computed:
        listed.update(figures([n for n in names if n not in listed]))
    # Isolas and disconnected branches start from a search (Newton from a fixed grid), not from a
    # state tuned to the sample; the orbits of Figs. 8 and 10's P still start from amplitudes chosen
    # on the sample, and on another model such a run can fail and take its whole scene with it.
    # Drop the run whose start failed and run the scene again (at most twice), so that the
    # scene's other statements are still decided; the drops are recorded.
    dropped = _recorded_drops(folder)
    for _ in range(2):
        retry = []
        for name, x in listed.items():
            k = _failed_start(x.get("error", ""))
            if x.get("status") != "ok" and k is not None and _drop_run(scene_dir / f"{name}.toml", k):
                dropped.append(f"{name}: run[{k}] ({x['error'].split(': ', 2)[-1][:160]})")
                atomic_write_json(folder / "dropped.json", dropped)
                retry.append(name)
        if not retry:
            break
        computed = True
        listed.update(figures(retry))
    wall = time.perf_counter() - t0
    if not computed and isinstance(before, dict) and isinstance(before.get("wall_s"), (int, float)):
        wall = float(before["wall_s"])      # decided again from the same scenes: their time stands
    from autocable.paper.report import load_scene_data
    scenes = {n: load_scene_data(folder / "out" / n, status=s.get("status"), error=s.get("error", ""))
              for n, s in listed.items()}
    verdicts = tg.decide_statements(targets, scenes) + tg.decide_numbers(targets, tg.scene_numbers(scenes))
    from autocable.paper.report import overlay_summary
    boxes = {}
    for n in ("fig08", "fig10"):
        if n in scenes and scenes[n].ok:
            s = overlay_summary(scenes[n])
            boxes[n] = {"points": s["points"], "within": s["within"], "at_rest": s["at_rest"],
                        "not_steady": s["not_steady"]}
    failed_now = [n for n, x in listed.items() if x.get("status") != "ok"]
    res = {"name": candidate_name(c), "wall_s": wall, "returncode": EXIT_FAILED if failed_now else 0,
           "dropped_runs": dropped, "stderr_tail": "\n".join(errors)[-500:],
           "verdicts": {v.id: asdict(v) for v in verdicts}, "boxes": boxes, "decided_with": decision_stamp()}
    res = _finite(res)
    atomic_write_json(done, res)
    return res


def _beyond_expansion(targets, folder: Path) -> list[str]:
    """The statements a full evaluation decided where the cubic load of eq. (14) leaves its bound
    (`targets.beyond_expansion`), read again from its scene folders."""
    from autocable.paper.report import load_scene_data
    scenes = {d.name: load_scene_data(d) for d in sorted((folder / "out").glob("fig*")) if d.is_dir()}
    return sorted(tg.beyond_expansion(targets, scenes))


def _csv_rows(cands: list[dict], target_ids: list[str]) -> list[dict]:
    rows = []
    for c in cands:
        row = {"candidate": candidate_name(c), **c["readings"], "yaw_deg": c["yaw_deg"],
               "rivulet_angle_deg": c["rivulet_angle_deg"], "theta0_rule": c.get("theta0_rule", ""),
               "ordering": c["ordering"],
               "zeta8": c["zeta8"], "xi11_bar": c["xi11_bar"], "twist_mid_per_q2": c["twist_mid_per_q2"],
               "screen_met": screen_score(c)[0], "stage": "full" if c.get("full") else "screen"}
        v = dict(c["verdicts"])
        v.update((c.get("full") or {}).get("verdicts", {}))
        for tid in target_ids:
            x = v.get(tid)
            row[f"{tid}:value"] = "" if x is None else (x["value"] if not isinstance(x["value"], str) else "")
            row[f"{tid}:shown"] = "" if x is None else x["shown"]
        rows.append(row)
    return rows


@styled()      # the package's one look (autocable.plotting.style)
def _maps(cands: list[dict], out: Path, space: SearchSpace) -> list[Path]:
    """beta-Theta0 plane per reading, coloured by screen targets met, bounded at U* = 1.3 marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    files = []
    n_screen = None
    for r in space.readings():
        mine = [c for c in cands if Readings(**c["readings"]) == r and c["ordering"] == space.ordering[0]]
        fig, ax = plt.subplots(figsize=(6, 4.2))
        if mine:
            n_screen = len(mine[0]["verdicts"])
            b = [c["yaw_deg"] for c in mine]
            th = [c["rivulet_angle_deg"] for c in mine]
            met = [screen_score(c)[0] for c in mine]
            sc = ax.scatter(b, th, c=met, cmap="viridis", vmin=0, vmax=n_screen, s=36)
            fig.colorbar(sc, ax=ax, label=f"screen targets met (of {n_screen}, {space.ordering[0]} ordering)")
            bd = [c for c in mine if c["verdicts"].get("bounded_fig10", {}).get("value") == 1.0]
            ax.scatter([c["yaw_deg"] for c in bd], [c["rivulet_angle_deg"] for c in bd], facecolors="none",
                       edgecolors="red", s=110, label="eq. (21) bounded at all Fig. 10 points (U* = 1.3)")
            if bd:
                ax.legend(loc="best", fontsize=7)
        else:
            ax.text(0.5, 0.5, "no Theta0 puts the onset at U_c", ha="center", transform=ax.transAxes)
        ax.set_xlabel("yaw beta [deg]")
        ax.set_ylabel("calibrated rivulet angle Theta0 [deg]")
        ax.set_title(r.label, fontsize=9)
        f = out / f"map_{r.label}.png"
        fig.tight_layout()
        fig.savefig(f, dpi=110)
        plt.close(fig)
        files.append(f)
    return files


def _ceiling(model_path: Path, targets, space, full: list, out: Path) -> dict:
    """`no_wind_ceiling` from the fully evaluated candidates' no-wind scenes, with its two
    premises measured: eq. (21) without wind equal for every reading (`no_wind_difference`) and
    the no-wind scenes' results equal in every fully evaluated candidate (`no_wind_signature`)."""
    from autocable.paper.report import load_scene_data
    sigs, first = {}, None
    for c in full:
        folder = out / "full" / candidate_name(c) / "out"
        scenes = {f.name: load_scene_data(f) for f in sorted(folder.glob("fig*")) if f.is_dir()}
        sigs.setdefault(no_wind_signature(scenes), []).append(candidate_name(c))
        first = first or scenes
    first = first or {}
    capped = no_wind_ceiling(targets, first)
    n_stmt = sum(1 for t in targets if t.kind == "statement")
    diff = no_wind_difference(load_model(model_path), space)
    holds = len(sigs) == 1 and diff < 1e-10
    return {"capped": capped, "statements": n_stmt, "at_most_yes": n_stmt - len(capped) if holds else None,
            "premises_hold": holds, "no_wind_difference": diff, "same_no_wind_results": len(sigs) == 1,
            "candidates_compared": len(full),
            "no_wind_scenes": sorted(n for n, d in first.items() if d.ok and d.fixed().get("U") == 0.0)}


def _ceiling_lines(ceiling: dict, space) -> list[str]:
    scenes = ", ".join(ceiling["no_wind_scenes"]) or "none"
    lines = ["", "## What no candidate can show (the no-wind ceiling)", "",
             f"Eq. (21) without wind over the {len(space.readings())} readings of the space, each at "
             f"{len(NO_WIND_ANGLES)} (yaw, Theta0) pairs: largest relative difference of its non-aerodynamic "
             f"coefficients {ceiling['no_wind_difference']:.1e}. The full evaluation runs every scene with its own "
             f"ordering; the results of the no-wind scenes ({scenes}) are "
             + ("identical in all " if ceiling["same_no_wind_results"] else "**not identical** in the ")
             + f"{ceiling['candidates_compared']} fully evaluated candidates."]
    if not ceiling["premises_hold"]:
        return lines + ["", "**The premises do not hold: no ceiling follows.**"]
    lines += ["", "So the no-wind scenes are the same for every candidate, and these statements have, for every "
              "candidate of the space, at best the verdict below: no candidate can show more than "
              f"**{ceiling['at_most_yes']} of {ceiling['statements']}** statements.", ""]
    lines += [f"- **{c['id']}** ({c['says']}): at best {c['best']}; {c['why'][:300]}" for c in ceiling["capped"]]
    return lines


def _statement_counts(c: dict, by_id: dict) -> dict[str, int]:
    fv = c["full"]["verdicts"]
    return tg.count_shown([tg.Verdict(k, x["shown"]) for k, x in fv.items()
                           if k in by_id and by_id[k].kind == "statement"])


def _full_ranked(full: list, by_id: dict) -> list:
    """The fully evaluated candidates, most statements shown first (then fewest "no")."""
    return sorted(full, key=lambda c: (_statement_counts(c, by_id)["yes"], -_statement_counts(c, by_id)["no"]),
                  reverse=True)


def _full_lines(full: list, targets, statement_map: Path | None = None) -> list[str]:
    """calibration.md's full-evaluation part: one row per candidate (most statements first), one
    row per statement (how many candidates show it), and for each statement no candidate shows, the
    verdicts' spread and the best candidate's evidence."""
    by_id = {t.id: t for t in targets}
    ranked = _full_ranked(full, by_id)
    stmt_ids = [t.id for t in targets if t.kind == "statement"]
    yes = [_statement_counts(c, by_id)["yes"] for c in ranked]
    with_uc = [c for c in ranked if c["full"]["verdicts"].get("U_c", {}).get("shown") == "yes"]
    hist = {}
    for n in yes:
        hist[n] = hist.get(n, 0) + 1
    lines = ["", "## Full evaluation (every figure scene)", "",
             "Each candidate's inputs written as a model file and every fig*.toml scene run on it "
             "(`autocable figures`, the scenes' own Multiple Scales orderings), then every target "
             "decided from the output folders by the report's code.", "",
             f"**{len(full)} candidates fully evaluated. Most statements shown: {yes[0]} of {len(stmt_ids)}** "
             f"({candidate_name(ranked[0])}); among those that also meet U_c = 36 m/s: "
             + (f"{_statement_counts(with_uc[0], by_id)['yes']} ({candidate_name(with_uc[0])})" if with_uc else "none")
             + ". Statements shown per candidate (count of candidates): "
             + ", ".join(f"{n}: {hist[n]}" for n in sorted(hist, reverse=True)) + "."]
    if statement_map is not None:
        lines += ["", f"![statements shown per candidate]({statement_map.name})"]
    lines += ["", "| candidate | yes | partly | no | numbers (U_c, omega1, rho) | eq. (21) boxes within the bound, "
              "Figs. 8 / 10 | runs dropped (their start, tuned to the sample, failed) | yes decided where the cubic "
              "load of eq. (14) leaves its bound |", "|---|---|---|---|---|---|---|---|"]
    for c in ranked:
        k = _statement_counts(c, by_id)
        fv = c["full"]["verdicts"]
        nums = ", ".join(("yes" if fv.get(t, {}).get("shown") == "yes" else "no") for t in ("U_c", "omega1", "rho"))
        bx = c["full"].get("boxes") or {}
        box = " / ".join(f"{bx[f]['within']} of {bx[f]['points']}" if f in bx else "—" for f in ("fig08", "fig10"))
        dropped = [d.split(" (")[0] for d in c["full"].get("dropped_runs") or []]
        beyond = [i for i in c["full"].get("beyond_expansion") or [] if fv.get(i, {}).get("shown") == "yes"]
        lines.append(f"| {candidate_name(c)} | {k['yes']} | {k['partly']} | {k['no']} | {nums} | {box} | "
                     f"{', '.join(dropped) or '—'} | {len(beyond)} of {k['yes']} |")
    lines += ["", "### Each statement over the fully evaluated candidates", "",
              "| statement | says | yes | partly | no |", "|---|---|---|---|---|"]
    nobody = []
    for tid in stmt_ids:
        got = [c["full"]["verdicts"].get(tid, {}).get("shown", "no") for c in full]
        n = {v: got.count(v) for v in ("yes", "partly", "no")}
        if not n["yes"]:
            nobody.append(tid)
        lines.append(f"| {tid} | {by_id[tid].says} | {n['yes']} | {n['partly']} | {n['no']} |")
    lines += ["", "### Statements no fully evaluated candidate shows", ""]
    for tid in nobody:
        best = next((c for c in ranked if c["full"]["verdicts"].get(tid, {}).get("shown") == "partly"), ranked[0])
        v = best["full"]["verdicts"].get(tid, {})
        ev = " ".join(str(v.get("evidence", "")).split())
        lines.append(f"- **{tid}** ({by_id[tid].says}): best verdict {v.get('shown', 'no')}, e.g. "
                     f"{candidate_name(best)}: {ev[:400]}{'...' if len(ev) > 400 else ''}")
    if not nobody:
        lines.append("None.")
    return lines


@styled()      # the package's one look (autocable.plotting.style)
def _statement_map(full: list, targets, out: Path, ceiling_yes: int | None = None,
                   capped=(), goal: int | None = None) -> Path | None:
    """A picture of the full evaluation: candidates (rows, most statements shown first) against the
    statements of Sect. 5 (columns, by figure), yes / partly / no; beside it, how many candidates
    show how many statements, with the goal (``goal``, the targets file's) and the no-wind ceiling (``ceiling_yes``; the
    statements it caps, ``capped``, marked with a dagger)."""
    if not full:
        return None
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import ListedColormap
    by_id = {t.id: t for t in targets}
    ranked = _full_ranked(full, by_id)
    stmt_ids = [t.id for t in targets if t.kind == "statement"]
    code = {"no": 0, "partly": 1, "yes": 2}
    grid = np.array([[code.get(c["full"]["verdicts"].get(tid, {}).get("shown", "no"), 0) for tid in stmt_ids]
                     for c in ranked])
    yes = [_statement_counts(c, by_id)["yes"] for c in ranked]
    fig, (ax, axh) = plt.subplots(1, 2, figsize=(13, 3 + 0.09 * len(ranked)),
                                  gridspec_kw={"width_ratios": [3.2, 1]})
    ax.imshow(grid, aspect="auto", interpolation="nearest", vmin=0, vmax=2,
              cmap=ListedColormap(["#d7301f", "#fdcc8a", "#31a354"]))
    ax.set_xticks(range(len(stmt_ids)))
    ax.set_xticklabels([tid + (" \u2020" if tid in capped else "") for tid in stmt_ids], rotation=90, fontsize=6)
    ax.set_yticks(range(len(ranked)))
    ax.set_yticklabels([f"{n:2d}  {candidate_name(c)[:58]}" for n, c in zip(yes, ranked)], fontsize=4.5)
    # figure boundaries between the columns
    figs = [tid.split(".")[0] for tid in stmt_ids]
    for j in range(1, len(figs)):
        if figs[j] != figs[j - 1]:
            ax.axvline(j - 0.5, color="k", lw=0.4)
    ax.set_title("Sect. 5 statements per fully evaluated candidate: green yes, amber partly, red no "
                 "(rows: statements shown, most first)"
                 + ("; \u2020 capped for every candidate by the no-wind ceiling" if capped else ""), fontsize=8)
    bins = np.arange(min(yes) - 0.5, len(stmt_ids) + 1.5)
    axh.hist(yes, bins=bins, orientation="horizontal", color="#3182bd")
    if goal is not None:
        axh.axhline(goal, color="k", ls="--", lw=1, label=f"goal: {goal} of {len(stmt_ids)}")
    if ceiling_yes is not None:
        axh.axhline(ceiling_yes, color="#d7301f", ls=":", lw=1.2,
                    label=f"no-wind ceiling: {ceiling_yes} (no candidate above)")
    axh.set_ylim(min(yes) - 1, len(stmt_ids) + 0.5)
    axh.set_xlabel("candidates")
    axh.set_ylabel("statements shown yes")
    axh.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    f = out / "full_statements.png"
    fig.savefig(f, dpi=130)
    plt.close(fig)
    return f


def _markdown(cands, full, target_ids, targets, space, stats, maps, failed, ceiling=None,
              statement_map: Path | None = None) -> str:
    by_id = {t.id: t for t in targets}
    lines = ["# Calibration of the unknown inputs against Sect. 5", "",
             f"Search space: twist_ends {list(space.twist_ends)}, load_axes {list(space.load_axes)}, "
             f"angle_convention {list(space.angle_convention)}, load_length {list(space.load_length)}, "
             f"air density {list(space.air_density_kg_m3)} kg/m^3, ordering {list(space.ordering)}, "
             f"yaw beta {min(space.yaw_deg):g} to {max(space.yaw_deg):g} deg ({len(space.yaw_deg)} values), "
             f"Theta0 {_theta0_text(space)}.", "",
             f"Points (readings x beta): {stats['points']} ({stats['computed']} computed in this run, "
             f"{stats['reused']} read from disk, {len(failed)} failed); candidates (with a valid Theta0, per "
             f"ordering): {len(cands)}; fully evaluated: {len(full)}. Screen wall time in this run "
             f"{stats['screen_s']:.1f} s on {stats['jobs']} processes"
             + (f" ({stats['computed'] / stats['screen_s'] * 60:.1f} points per minute)" if stats["computed"] else "")
             + ".", ""]
    screen_ids = [t.id for t in targets if t.kind in ("number", "screen")]
    lines += ["## Screen: how many candidates meet each target", "", "| target | says | met by |", "|---|---|---|"]
    for tid in screen_ids:
        n = sum(c["verdicts"].get(tid, {}).get("shown") == "yes" for c in cands)
        lines.append(f"| {tid} | {by_id[tid].says} | {n} of {len(cands)} |")
    joint = [c for c in cands if c["verdicts"].get("supercritical", {}).get("shown") == "yes"
             and c["verdicts"].get("bounded_fig10", {}).get("shown") == "yes"
             and c["verdicts"].get("bounded_fig08", {}).get("shown") == "yes"]
    lines += ["", f"Candidates with super-critical galloping and eq. (21) bounded at U* = 1.3 (Figs. 8 and 10): "
              f"**{len(joint)}**; of those with the AME's a2 cut by the wind (Fig. 10 / Fig. 6 < 1): "
              f"**{sum(c['verdicts'].get('a2_ratio_ame', {}).get('shown') == 'yes' for c in joint)}**, "
              f"by eq. (21): **{sum(c['verdicts'].get('a2_ratio_21', {}).get('shown') == 'yes' for c in joint)}**.", ""]
    per = {}
    for c in cands:
        key = Readings(**c["readings"]).label
        s = per.setdefault(key, {"n": 0, "super": 0, "bounded": 0, "both": 0, "cut": 0})
        s["n"] += 1
        sup = c["verdicts"].get("supercritical", {}).get("shown") == "yes"
        bd = c["verdicts"].get("bounded_fig10", {}).get("shown") == "yes"
        s["super"] += sup
        s["bounded"] += bd
        s["both"] += sup and bd
        s["cut"] += sup and bd and c["verdicts"].get("a2_ratio_ame", {}).get("shown") == "yes"
    lines += ["## Per reading", "", "| readings | candidates | zeta8 > 0 | bounded at Fig. 10 | both | both and AME a2 cut |",
              "|---|---|---|---|---|---|"]
    lines += [f"| {k} | {s['n']} | {s['super']} | {s['bounded']} | {s['both']} | {s['cut']} |" for k, s in per.items()]
    lines += ["", "Maps (beta-Theta0 plane per reading): " + ", ".join(f"[{m.name}]({m.name})" for m in maps), ""]
    best = sorted(cands, key=screen_score, reverse=True)[:10]
    lines += ["## Best candidates of the screen", "", "| candidate | met | zeta8 | xi11_bar | AME a2 ratio | eq. (21) a2 ratio |",
              "|---|---|---|---|---|---|"]
    for c in best:
        v = c["verdicts"]
        lines.append(f"| {candidate_name(c)} | {screen_score(c)[0]} of {len(v)} | {c['zeta8']:.4g} | {c['xi11_bar']:.4g} | "
                     f"{_fmt(v.get('a2_ratio_ame', {}).get('value'))} | {_fmt(v.get('a2_ratio_21', {}).get('value'))} |")
    if full:
        lines += _full_lines(full, targets, statement_map)
    if ceiling is not None:
        lines += _ceiling_lines(ceiling, space)
    never = [tid for tid in screen_ids if not any(c["verdicts"].get(tid, {}).get("shown") == "yes" for c in cands)]
    lines += ["", "## Screen targets no candidate meets", ""]
    lines += [f"- **{tid}** ({by_id[tid].says}): best value "
              f"{_fmt(_best_value(cands, tid, by_id[tid]))} over {len(cands)} candidates" for tid in never] or ["None."]
    if failed:
        lines += ["", "## Failed points", ""] + [f"- {f}" for f in failed]
    return "\n".join(lines) + "\n"


def _bound_stage(model_path, targets, goal, cands, full, out, runs, ceiling, executor, say, stats,
                 minutes=None, margin: int = 0, prior: Path | None = None) -> list[str]:
    """`autocable.paper.bound` over every candidate; writes bound.csv and bound.png, returns the
    markdown lines and puts the summary in ``stats``."""
    from autocable.paper import bound as bd
    if not full or not ceiling or not ceiling.get("premises_hold"):
        why = ("no candidate was fully evaluated (--full 1 at least): the no-wind scenes come from one"
               if not full else "the no-wind ceiling's premises do not hold: the no-wind scenes are not shared")
        say(f"bound: not run: {why}")
        stats["bound"] = {"not_run": why}
        return ["", "## Can any candidate reach the goal?", "", f"Not run: {why}."]
    reference = out / "full" / candidate_name(full[0]) / "out"
    capped = {c["id"] for c in ceiling["capped"]}
    t0 = time.perf_counter()
    records = bd.run_bound(model_path, targets, goal, cands, full, out, runs, reference, capped, executor, say,
                           minutes=minutes, margin=margin)
    wall = time.perf_counter() - t0
    if prior is not None:
        records = bd.merge_prior(records, bd.read_csv(prior))
    bd.write_csv(records, out / "bound.csv")
    n_stmt = sum(1 for t in targets if t.kind == "statement")
    pic = bd.draw_map(records, goal, ceiling["at_most_yes"], out / "bound.png") if records else None
    stats["bound"] = {k: v for k, v in bd.summary(records, goal).items() if k not in ("lowered_by", "not_bounded")}
    stats["bound"]["not_bounded"] = sum(r["status"] == bd.NOT_BOUNDED for r in records)
    stats["bound"]["wall_s"] = wall
    stats["bound"]["margin"] = margin
    rule = bd.rule_of([t.id for t in targets if t.kind == "statement"], capped, bd.not_used_to_prune(targets),
                      goal, margin)
    stats["bound"]["prior_other_rule"] = sum(1 for r in records if r.get("prior") and r.get("rule") != rule)
    stats["bound"]["prior_boxes_could_lift"] = [r["name"] for r in records if r.get("prior")
                                                and r.get("rule") != rule and bd.boxes_could_lift(r, goal)]
    return bd.markdown(records, goal, ceiling["at_most_yes"], n_stmt, wall, executor.n_workers, pic, "bound.csv",
                       bd.not_used_to_prune(targets), margin, rule)


def _theta0_text(space: SearchSpace) -> str:
    vals = space.theta0_values()
    if all(isinstance(v, str) for v in vals):
        return "from beta by " + " and ".join(f'"{v}"' for v in vals) + " (every valid root)"
    return f"scanned over {len(vals)} angles"


def _best_value(cands, tid, t):
    vals = [c["verdicts"].get(tid, {}).get("value") for c in cands]
    vals = [v for v in vals if isinstance(v, (int, float)) and math.isfinite(v)]
    if not vals:
        return math.nan
    return min(vals) if t.kind == "screen" and t.op in ("<", "<=") else max(vals)


def _fmt(x) -> str:
    return f"{x:.4g}" if isinstance(x, (int, float)) else "—"


def calibrate(model_path, targets_path, out_dir, *, space: SearchSpace | None = None, jobs: int | None = None,
              runs: Path | None = None, quiet: bool = False, bound: bool = False,
              bound_minutes: float | None = None, bound_margin: int = 0, prior_bound: Path | None = None,
              workers: int | None = None, scheduler: str | None = None) -> dict:
    """The whole study (module docstring). Returns counts and the output paths. Every stage's tasks
    run on one executor (`autocable.executor`): ``workers`` LocalCluster processes (``jobs`` is the
    older name; default one per core; 0: this process alone) or the cluster of ``scheduler``. ``bound``: then ask
    of every candidate whether it can reach the targets file's ``[goal]`` (`autocable.paper.bound`),
    starting no scene after ``bound_minutes`` of that stage, stopping a candidate when its bound is
    below the goal by more than ``bound_margin``; ``prior_bound``: an earlier call's bound.csv whose
    records of readings outside this space join the bound's outputs (`bound.merge_prior`)."""
    model_path, targets_path, out = Path(model_path).resolve(), Path(targets_path).resolve(), Path(out_dir)
    load_model(model_path)                  # a bad model file: one line before any work
    targets = tg.load_targets(targets_path)
    goal = tg.load_goal(targets_path)
    if bound and goal is None:
        raise tg.TargetsError(targets_path, "goal", "the bound stage needs a [goal] table "
                                                    "(statements_yes, boxes_share, boxes_scenes)")
    if prior_bound is not None:
        from autocable.paper import bound as bd
        bd.read_csv(prior_bound)            # a bad file: one line before any work
    if bound:
        from autocable.paper.bound import NO_WIND, ORDER, unknown_scenes
        unknown = unknown_scenes(targets)
        if unknown:
            raise tg.TargetsError(targets_path, "statement.scene",
                                  f"{', '.join(unknown)}: not a scene of the bound stage (it runs "
                                  f"{', '.join(ORDER + NO_WIND)})")
    runs = runs or RUNS_DIR
    tg.check_scenes(targets, goal, runs, targets_path)
    space = space or SearchSpace()
    say = (lambda m: None) if quiet else (lambda m: print(m, file=sys.stderr, flush=True))
    (out / "screen").mkdir(parents=True, exist_ok=True)
    t_all = time.perf_counter()
    # build both generic integrators once, before the workers start (they are cached on disk)
    _ode_integrator()
    _ame_integrator()
    from autocable.executor import Executor, attempts
    if workers is None:
        workers = jobs
    executor = Executor(workers, scheduler, warm=_warm_worker, journal=out / TASKS_JOURNAL, strict_priority=True)
    with executor:
        stats = _stages(model_path, targets_path, targets, goal, out, space, runs, executor, say, t_all, bound,
                        bound_minutes, bound_margin, prior_bound)
    # a task started more than once lost its worker (the journal counts starts, not results)
    recomputed = {k: n - 1 for k, n in attempts(out / TASKS_JOURNAL).items() if n > 1}
    stats["recomputed_tasks"] = recomputed
    (out / "calibration.json").write_text(json.dumps(stats, indent=2))
    if recomputed:
        say(f"calibrate: {sum(recomputed.values())} task(s) computed again after a worker was lost")
    return stats


def _workers_said(executor) -> str:
    """The workers a scheduler has now, as the start line says it: none is not "1 workers" (the
    tasks then wait for one, and the run stops after the executor's no-worker time limit)."""
    n = executor.live_workers
    if n == 0:
        return f"no worker yet (the run stops if none joins within {executor.no_worker_timeout:g} s)"
    return f"{n} worker{'s' if n != 1 else ''}"


def _stages(model_path, targets_path, targets, goal, out, space, runs, executor, say, t_all, bound,
            bound_minutes, bound_margin, prior_bound) -> dict:
    """The screen, the full evaluation and the bound on ``executor`` (`calibrate`)."""
    from autocable.executor import time_left
    tasks, results = [], []
    signature = compute_signature(targets)
    for readings, beta in space.points():
        for theta0 in space.theta0_values():
            f = out / "screen" / f"{point_key(readings, beta, theta0, signature, space.ordering)}.json"
            if f.is_file():
                try:
                    results.append(json.loads(f.read_text()))
                    continue
                except ValueError:
                    pass
            tasks.append((str(model_path), str(targets_path), asdict(readings), beta, theta0, list(space.ordering), str(f.resolve())))
    reused = len(results)
    where = executor.where
    say(f"calibrate: {len(tasks) + reused} points ({reused} already on disk), "
        + (f"on the scheduler {where.get('address')}, {_workers_said(executor)}" if where.get("mode") == "scheduler"
           else f"{where.get('workers')} worker processes" if where.get("mode") == "LocalCluster"
           else "in this process"))
    t0 = time.perf_counter()
    failed = []
    for k, t in enumerate(tasks):
        executor.submit(f"screen:{k}", _worker, *t)
    for i, done in enumerate(executor.completed(), 1):
        k = int(done.label.split(":", 1)[1])
        res = done.value if done.ok else {"readings": tasks[k][2], "yaw_deg": tasks[k][3], "theta0": tasks[k][4],
                                          "status": "failed", "error": done.error, "candidates": []}
        results.append(res)
        lab = f"{Readings(**res['readings']).label} beta {res['yaw_deg']:+.2f}"
        left = time_left(i, len(tasks), time.perf_counter() - t0)
        if res["status"] != "ok":
            say(f"[{i}/{len(tasks)}] FAILED {lab}: {res['error']}")
        else:
            best = max((screen_score(c)[0] for c in res["candidates"]), default=0)
            say(f"[{i}/{len(tasks)}] {lab}: {len(res['candidates'])} candidates, best {best} targets met "
                f"({res['seconds']:.1f} s" + (f"; {left}" if left else "") + ")")
    screen_s = time.perf_counter() - t0
    failed = [f"{Readings(**r['readings']).label} beta {r['yaw_deg']:+.2f}: {r['error']}"
              for r in results if r["status"] != "ok"]
    cands = [redecide(c, targets) for r in results if r["status"] == "ok" for c in r["candidates"]]
    # stage 2
    full = []
    ranked = sorted(cands, key=screen_score, reverse=True)
    runs = runs or RUNS_DIR
    # one full evaluation per model: the orderings differ only in the screen's AME (the scenes
    # keep the orderings written in them)
    # keep the screen's best, then the best of every (twist ends, angle sense) family not yet in,
    # so that the statements no candidate meets are tested on unlike models too
    chosen, models, families = [], set(), set()

    def take(c):
        key = (json.dumps(c["readings"], sort_keys=True), c["yaw_deg"], round(c["rivulet_angle_deg"], 9))
        if key in models or len(chosen) >= space.full:
            return
        models.add(key)
        families.add((c["readings"]["twist_ends"], c["readings"]["angle_convention"]))
        chosen.append(c)

    for c in ranked[:1]:
        take(c)
    for c in ranked:
        if (c["readings"]["twist_ends"], c["readings"]["angle_convention"]) not in families:
            take(c)
    for c in ranked:
        take(c)
    for c in chosen:
        say(f"full evaluation of {candidate_name(c)} (every figure scene)")
        try:
            c["full"] = full_evaluation(model_path, targets, c, out / "full" / candidate_name(c), runs, executor, say)
        except Exception as exc:  # noqa: BLE001 - one line per failed candidate, and the study goes on
            say(f"FAILED full evaluation of {candidate_name(c)}: {type(exc).__name__}: {' '.join(str(exc).split())[:300]}")
            continue
        full.append(c)
    for c in full:
        c["full"].setdefault("beyond_expansion", _beyond_expansion(targets, out / "full" / candidate_name(c)))
    ceiling = _ceiling(model_path, targets, space, full, out) if full else None
    target_ids = [t.id for t in targets]
    rows = _csv_rows(cands, target_ids)
    if rows:
        with open(out / "calibration.csv", "w", newline="", encoding="utf-8") as fh:
            w = csv.DictWriter(fh, fieldnames=list(rows[0]))
            w.writeheader()
            w.writerows(rows)
    maps = _maps(cands, out, space)
    stats = {"points": len(results), "computed": len(tasks), "reused": reused, "screen_s": screen_s, "jobs": executor.n_workers,
             "where": {k: v for k, v in executor.where.items() if k != "startup_seconds"},
             "candidates": len(cands), "full": len(full), "wall_s": time.perf_counter() - t_all}
    if ceiling is not None:
        stats["ceiling"] = {k: v for k, v in ceiling.items() if k != "capped"}
        stats["ceiling"]["capped"] = [c["id"] for c in ceiling["capped"]]
    ceiling_yes = ceiling.get("at_most_yes") if ceiling and ceiling.get("premises_hold") else None
    smap = _statement_map(full, targets, out, ceiling_yes,
                          [c["id"] for c in ceiling["capped"]] if ceiling_yes is not None else (),
                          goal.statements_yes if goal else None)
    bound_lines = []
    if bound:
        bound_lines = _bound_stage(model_path, targets, goal, cands, full, out, runs, ceiling, executor, say, stats,
                                   bound_minutes, bound_margin, prior_bound)
    stats["wall_s"] = time.perf_counter() - t_all          # with the bound stage, if it ran
    (out / "calibration.md").write_text(_markdown(cands, full, target_ids, targets, space, stats, maps, failed,
                                                  ceiling, smap) + "\n".join(bound_lines) + ("\n" if bound_lines else ""))
    (out / "calibration.json").write_text(json.dumps(stats, indent=2))
    say(f"calibrate: {stats['candidates']} candidates from {stats['points']} points; {len(full)} fully evaluated; "
        f"{stats['wall_s']:.1f} s; {out / 'calibration.md'}")
    return stats
