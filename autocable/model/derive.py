"""From a model spec to eq. (21): statics -> modes -> calibration -> aerodynamics -> Galerkin.

`derive(spec)` (a spec or a model file) runs the whole chain and returns a `Derivation` (plain frozen data). The result is
cached in the autocable cache folder under a hash of the spec's physical content and of the code that
derives it (the sha256 of the files of ``autocable/model`` and ``spec.py``, `autocable._store.code_fingerprint`;
`DERIVATION_VERSION` is kept beside it as a label), never under the model's name, so a second call with
the same spec and code costs only a JSON read; the file carries the sha256 of its content and is derived
again if it fails that check. A derivation during which that code changed is not stored.
"""
from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field, replace

from autocable._store import (cache_dir, code_fingerprint, content_hash, load_checked_json,
                              store_checked_json_for_code)
from autocable.model.aero import expand_load_jet
from autocable.model.calibration import CalibrationError, calibrate
from autocable.model.curves import curves_from_spec, eq21_fits
from autocable.model.equations import TwoModeODE
from autocable.model.exact_load import exact_load_of
from autocable.model.galerkin import aero_scales, project
from autocable.model.mode_pairs import pair_modes, pair_premises
from autocable.model.modes import Modes, linear_modes
from autocable.model.premises import check_model
from autocable.model.shapes import ClosedFormIntegrator, QuadratureIntegrator
from autocable.model.statics import CableStatics, cable_statics, regime_warnings
from autocable.spec import ModelSpec, SpecError, load_model

#: Bump when a change in the physics changes the numbers, so stale cached derivations are not used.
#: v3: the load of eq. (14) expanded by truncated Taylor arithmetic (`aero.expand_load_jet`, equal
#: to sympy's `aero.expand_load` to 1e-12 relative) instead of sympy: milliseconds instead of seconds.
DERIVATION_VERSION = "eq21-v3"


@dataclass(frozen=True)
class Derivation:
    """Everything `autocable derive` reports: eq. (21) and the quantities it rests on."""

    spec: ModelSpec
    statics: CableStatics
    ode: TwoModeODE
    beta: float                 # yaw [rad] (given or calibrated)
    theta0: float               # rivulet angle [rad] (given or calibrated)
    calibrated: str             # which field was calibrated ("" if none)
    static_angle: float         # phi0 = gamma - Theta0 [rad]
    aero_scale: float           # K = rho_a L U_c^2 l / (2 EA)
    velocity_ratio: float       # nu = omega l / U_c
    twist: tuple                # (B, C, k) of the slaved twist theta2
    calibration_roots: tuple = ()   # ((angle_deg, "" or why it was rejected), ...) of the scan
    twist_D: float = 0.0        # + D sinh(k (s - 1/2)) in the twist of an even pair (`mode_pairs`)
    warnings: tuple = ()
    timings: dict = field(default_factory=dict, compare=False)
    from_cache: bool = False

    @property
    def critical_wind_speed_m_s(self) -> float:
        return self.spec.aero.critical_wind_speed_m_s

    # The spec and the reports give angles in degrees; the radians above are what the equations use.
    @property
    def beta_deg(self) -> float:
        """The yaw beta in degrees (the spec's ``yaw_deg``; `beta` is the same in radians)."""
        return math.degrees(self.beta)

    @property
    def theta0_deg(self) -> float:
        """The rivulet angle Theta0 in degrees (the spec's ``rivulet_angle_deg``; `theta0` in radians)."""
        return math.degrees(self.theta0)

    @property
    def static_angle_deg(self) -> float:
        """The static angle phi0 = gamma - Theta0 of eq. (12) in degrees (`static_angle` in radians)."""
        return math.degrees(self.static_angle)

    @property
    def mode_pair(self) -> int:
        """k of the pair eq. (21) is projected on (1: the paper's; `autocable.model.mode_pairs`)."""
        return self.spec.cable.mode_pair

    @property
    def omega1(self) -> float:
        """The in-plane frequency of eq. (21) (in units of omega, eq. 17)."""
        return self.ode.omega1

    @property
    def omega2(self) -> float:
        """The out-of-plane frequency of eq. (21) (in units of omega, eq. 17)."""
        return self.ode.omega2

    def summary(self) -> str:
        """A few lines: the cable, its frequencies, the wind angles in degrees (which was
        calibrated) and the scales of eqs. (17)-(18); `autocable derive` prints the whole report."""
        st, c = self.statics, self.spec.cable
        cal = f" ({self.calibrated} calibrated)" if self.calibrated else ""
        pair = f" on mode pair {self.mode_pair}" if self.mode_pair != 1 else ""
        lines = [
            f"eq. (21){pair} of model {self.spec.name!r}: l = {c.length_m:g} m, alpha = {c.chord_slope_deg:g} deg, "
            f"Irvine lambda^2 = {st.lambda2:.4g}",
            f"  omega = {st.omega_ref:.6g} rad/s ({st.frequency_hz:.4g} Hz): omega1 = {self.ode.omega1:.6f}, "
            f"omega2 = {self.ode.omega2:.6f} (rho = {self.ode.omega2 - self.ode.omega1:.4g}), "
            f"xi_s = {self.ode.xi_s:g}",
            f"  wind: U_c = {self.critical_wind_speed_m_s:g} m/s, yaw beta = {self.beta_deg:.4f} deg, "
            f"rivulet Theta0 = {self.theta0_deg:.4f} deg{cal}, phi0 = {self.static_angle_deg:.4f} deg "
            f"({self.spec.aero.angle_convention})",
            f"  K = {self.aero_scale:.4g}, nu = omega l / U_c = {self.velocity_ratio:.4g}",
        ]
        lines += [f"  warning: {w}" for w in self.warnings]
        return "\n".join(lines)

    def __repr__(self) -> str:
        cal = f", {self.calibrated} calibrated" if self.calibrated else ""
        return (f"Derivation(model={self.spec.name!r}, omega1={self.ode.omega1:.6f}, omega2={self.ode.omega2:.6f}, "
                f"beta_deg={self.beta_deg:.4f}, theta0_deg={self.theta0_deg:.4f}{cal})")


def _integrator(kind: str, shapes):
    if kind == "closed-form":
        return ClosedFormIntegrator(shapes)
    if kind == "quadrature":
        return QuadratureIntegrator(shapes)
    raise ValueError(f"unknown integrator {kind!r}; use 'closed-form' or 'quadrature'")


def trial_modes(st: CableStatics, cable) -> Modes:
    """The trial functions of eq. (21) for ``cable``: its pair ``cable.mode_pair`` (1: the paper's
    first pair, `linear_modes`; k > 1: `mode_pairs.pair_modes`)."""
    if cable.mode_pair == 1:
        return linear_modes(st, cable.twist_ends)
    return pair_modes(st, cable.mode_pair, cable.twist_ends)


def _compute(spec: ModelSpec, integrator: str) -> dict:
    timings = {}
    t0 = time.perf_counter()
    st = cable_statics(spec.cable)
    modes = trial_modes(st, spec.cable)
    I = _integrator(integrator, modes.shapes)
    # A calibrated angle puts the FIRST pair's onset at U_c; pair k > 1 keeps that angle (docs/mode-pairs.md).
    first = modes if spec.cable.mode_pair == 1 else linear_modes(st, spec.cable.twist_ends)
    I_first = I if first is modes else _integrator(integrator, first.shapes)
    K, nu = aero_scales(spec.aero, spec.cable, st)
    timings["statics_modes_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    calibrated, roots = "", []
    if spec.aero.yaw_deg is None or spec.aero.rivulet_angle_deg is None:
        try:
            cal = calibrate(spec.aero, st, first, I_first, K, nu, spec.cable.damping_ratio)
        except CalibrationError as exc:    # an input no angle can satisfy: the user's to change
            err = SpecError(spec.path or "<spec>", exc.field, exc.message)
            # the field may be U_c or the damping ratio the calibration blames: callers that tell a
            # failed calibration from another refusal (onset --band) ask this, not the field
            err.calibration = True
            raise err from None
        beta, theta0, calibrated = cal.beta, cal.theta0, cal.solved_for
        why = dict(cal.rejected)
        roots = [[r, why.get(r, "")] for r in cal.roots_deg]
    else:
        beta, theta0 = math.radians(spec.aero.yaw_deg), math.radians(spec.aero.rivulet_angle_deg)
    timings["calibration_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    # The cubic expansion of eq. (14) by truncated Taylor arithmetic: the same coefficients as sympy's
    # differentiation (`expand_load`; tests/test_calibration.py, every angle sense and both axes, to
    # 1e-12 relative) in a millisecond instead of 5-10 s, which every new model (a calibration
    # candidate, a user's cable) paid once.
    # Curves other than eq. (13)'s cubics (a table, a fit bounded by the dry cylinder) enter eq. (21)
    # through their cubic at the static angle: value and three derivatives (docs/aero-curves.md).
    lift, drag = eq21_fits(spec.aero, st.alpha, beta, theta0)
    aero = expand_load_jet(lift, drag, st.alpha, beta, theta0, spec.aero.angle_convention, spec.aero.load_axes)
    timings["aero_expansion_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    ode = project(st, modes, aero, K, nu, spec.cable.damping_ratio, I,
                  provenance={"model": spec.name, "model_hash": spec.content_hash(),
                              "derivation": DERIVATION_VERSION, "mode_pair": spec.cable.mode_pair})
    timings["galerkin_s"] = time.perf_counter() - t0
    return {"ode": ode.to_dict(), "beta": beta, "theta0": theta0, "calibrated": calibrated,
            "static_angle": aero.static_angle, "aero_scale": K, "velocity_ratio": nu,
            "twist": [modes.twist_B, modes.twist_C, modes.twist_k], "timings": timings,
            "calibration_roots": roots, "twist_D": modes.twist_D}


def with_exact_load(ode: TwoModeODE, spec: ModelSpec, st: CableStatics, data: dict) -> TwoModeODE:
    """Eq. (21) on the exact rung: the same terms, with the exact quasi-steady load of the model's
    curves, wind angles and modes attached (`autocable.model.exact_load`); ``data`` is the derived
    record (angles and scales)."""
    modes = trial_modes(st, spec.cable)     # the pair's own shapes: the load is projected on them
    I = ClosedFormIntegrator(modes.shapes)
    exact = exact_load_of(modes.shapes, st.m_star, I(("phi1", "phi1")), I(("phi2", "phi2")),
                          data["aero_scale"], data["velocity_ratio"], st.alpha, data["beta"], data["theta0"],
                          spec.aero.angle_convention, spec.aero.load_axes, curves_from_spec(spec.aero))
    return replace(ode, exact_load=exact, provenance=dict(ode.provenance, load="exact"))


def _curve_warnings(spec: ModelSpec, phi0: float) -> tuple:
    """A static angle outside the range the curves state (``aero.valid_phi_deg``, a table's ends):
    eq. (21) is then the cubic of curves where they were not measured (the calibration rejects such
    a root; an angle typed in is not checked there)."""
    curves = curves_from_spec(spec.aero)
    if curves.valid_phi is None:
        return ()
    lo, hi = curves.valid_phi
    if lo <= phi0 <= hi:
        return ()
    return (f"the static angle phi0 = {math.degrees(phi0):.4g} deg lies outside the curves' valid range "
            f"[{math.degrees(lo):.4g}, {math.degrees(hi):.4g}] deg (aero.valid_phi_deg or the table's ends): "
            "eq. (21) and its onset rest on the curves where they do not hold; move the range or the angles",)


def derive(spec: ModelSpec | str | os.PathLike, integrator: str = "closed-form", use_cache: bool = True) -> Derivation:
    """Eq. (21) for ``spec`` (a `ModelSpec`, or the path of a model file, read by `load_model`);
    cached by content (see module docstring)."""
    if not isinstance(spec, ModelSpec):
        spec = load_model(spec)
    check_model(spec)    # before the root finding an impossible cable would make fail
    if spec.cable.mode_pair > 1:
        pair_premises(spec, cable_statics(spec.cable), spec.cable.mode_pair)
    # (the spec's hash covers cable.mode_pair: every pair has its own entry)
    code = code_fingerprint("derivation")      # the code, not a version label someone must bump
    key = content_hash({"spec": spec.content_hash(), "version": DERIVATION_VERSION, "code": code,
                        "integrator": integrator})
    path = cache_dir("derivations") / f"eq21-{key}.json"
    data = load_checked_json(path, f"derivation {path.name}") if use_cache else None
    from_cache = data is not None
    t0 = time.perf_counter()
    if data is None:
        data = _compute(spec, integrator)
        store_checked_json_for_code("derivation", code, path, data, f"derivation {path.name}")
    st = cable_statics(spec.cable)
    timings = dict(data["timings"]) if not from_cache else {"cache_read_s": time.perf_counter() - t0}
    ode = TwoModeODE.from_dict(data["ode"])
    if spec.aero.load == "exact":
        ode = with_exact_load(ode, spec, st, data)
    return Derivation(spec=spec, statics=st, ode=ode,
                      beta=data["beta"], theta0=data["theta0"], calibrated=data["calibrated"],
                      static_angle=data["static_angle"], aero_scale=data["aero_scale"],
                      velocity_ratio=data["velocity_ratio"], twist=tuple(data["twist"]),
                      calibration_roots=tuple(tuple(r) for r in data.get("calibration_roots", [])),
                      twist_D=float(data.get("twist_D", 0.0)),
                      warnings=tuple(regime_warnings(st)) + _curve_warnings(spec, data["static_angle"]),
                      timings=timings, from_cache=from_cache)
