"""`autocable onset`: where a cable's trivial state loses stability under wind, in m/s, Hz and m, and
what damping keeps it stable (`autocable.model.onset` does the eigenvalue and Hopf work).

* **Predict, do not only fit.** With both wind angles given, the onset is a result: its U in m/s does
  not depend on the U_c of eq. (18), which only scales U* (tests/test_onset_study.py). With an angle
  set to "calibrate", U_c is an input and the angle is the fitted answer; `angle_statement` says so.
  A study that changes the cable (`vary`) holds a fitted angle at its fitted value unless asked to
  refit, and a refit says from where to where it moved the angle.
* **Damping.** `damping_curve` (U_cr against the damping ratio and the Scruton number
  Sc = m xi / (rho_a D^2)), `design_damping` (the least damping ratio keeping the trivial state stable
  up to a design wind: the largest real part over U in [0, U_design] maximised, not sampled, and set
  to zero by bisection on the damping), with the wind angles as derived.
* **How hard it gallops.** `ame_galloping`: the galloping cycle of the amplitude equations (24) at
  eta = 0, a relative equilibrium (the AME are invariant under a common phase rotation there): its
  amplitudes, the frequency shift sigma and s1 = 0 solved by Newton, continued in U* from the normal
  form's start at the onset. The AME are derived with the "natural" ordering, which keeps the
  quadratic wind terms (the paper's ordering puts every wind term at third order and drops them,
  which can flip the criticality: the quadratic in-plane velocity load of the out-of-plane equation
  feeds back at third order). `eq21_check` integrates eq. (21) to its own cycle there.
"""
from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from autocable.model.onset import (U_MAX_DEFAULT, first_onset_U, one_mode, one_mode_warnings, stability,
                                   with_damping)
from autocable.model.premises import MAX_AMPLITUDE
from autocable.model.units import PEAK_STATION, units_of
from autocable.spec import SpecError

#: The empirical references drawn beside the damping curve: the stay-cable design recommendations'
#: Scruton criterion for rain-wind vibration (Sc = m xi / (rho_a D^2) >= 10, or >= 5 for a cable with
#: a surface treatment that disrupts the rivulets). A rule of thumb from field experience, not a
#: result of eq. (21).
SCRUTON_RULES = ((10.0, "Sc = 10 (design rule, plain cable)"),
                 (5.0, "Sc = 5 (design rule, rivulet-suppressing surface)"))

#: The cable fields a study may change (`vary`).
VARIABLE_FIELDS = ("damping_ratio", "horizontal_tension_N", "diameter_m", "mass_per_length_kg_m",
                   "length_m")


def angle_statement(d) -> dict:
    """What the wind angles of a derivation are: given (the onset is a prediction) or fitted (U_c is
    the input and the angle the answer)."""
    Uc = d.spec.aero.critical_wind_speed_m_s
    yaw, th0 = math.degrees(d.beta), math.degrees(d.theta0)
    pair = getattr(d, "mode_pair", 1)
    if d.calibrated and pair != 1:
        # the angle is fitted on the first pair (autocable.model.mode_pairs): pair k's onset is its consequence
        name = {"rivulet_angle_deg": "the rivulet angle Theta0", "yaw_deg": "the yaw beta"}[d.calibrated]
        value = th0 if d.calibrated == "rivulet_angle_deg" else yaw
        text = (f"{name} = {value:.4f} deg is fitted on the first mode pair (its onset at the U_c = {Uc:g} m/s "
                f"typed in, aero.{d.calibrated} = \"calibrate\") and held for mode pair {pair}: this pair's onset "
                "is a prediction with that angle")
    elif d.calibrated:
        name = {"rivulet_angle_deg": "the rivulet angle Theta0", "yaw_deg": "the yaw beta"}[d.calibrated]
        value = th0 if d.calibrated == "rivulet_angle_deg" else yaw
        text = (f"U_c = {Uc:g} m/s was typed in (aero.critical_wind_speed_m_s) and {name} = {value:.4f} deg "
                f"is the fitted answer (aero.{d.calibrated} = \"calibrate\"): the onset at U_c is the input, "
                "not a prediction; give the angle as a number to predict the onset")
    else:
        text = (f"both wind angles are given (yaw {yaw:.4f} deg, rivulet {th0:.4f} deg): the onset is a "
                f"prediction; U_c = {Uc:g} m/s only scales U* = U/U_c")
    return {"calibrated": d.calibrated or None, "yaw_deg": yaw, "rivulet_angle_deg": th0,
            "critical_wind_speed_m_s": Uc, "text": text, "fitted_on_mode_pair": 1 if d.calibrated else None}


def held_spec(d):
    """The spec of derivation ``d`` with a fitted angle written in as the number it was fitted to."""
    a = d.spec.aero
    if d.calibrated == "rivulet_angle_deg":
        a = replace(a, rivulet_angle_deg=math.degrees(d.theta0))
    elif d.calibrated == "yaw_deg":
        a = replace(a, yaw_deg=math.degrees(d.beta))
    return replace(d.spec, aero=a)


def vary(d, changes: dict, refit: bool = False):
    """(derivation, messages) of the cable of ``d`` with the cable fields ``changes`` (name -> value,
    names in `VARIABLE_FIELDS`): a fitted angle is held at its fitted value unless ``refit``; a
    refit says how far it moved the angle."""
    from autocable.model.derive import derive
    for k in changes:
        if k not in VARIABLE_FIELDS:
            raise SpecError("arguments", "--set", f"cannot vary {k!r}; give one of "
                                                  f"{', '.join('cable.' + f for f in VARIABLE_FIELDS)}")
    base = d.spec if refit else held_spec(d)
    spec = replace(base, cable=replace(base.cable, **changes))
    messages = []
    if d.calibrated and not refit:
        value = math.degrees(d.theta0 if d.calibrated == "rivulet_angle_deg" else d.beta)
        messages.append(f"aero.{d.calibrated} held at its fitted {value:.4f} deg (fitted on the spec as "
                        f"written to put the onset at U_c = {d.spec.aero.critical_wind_speed_m_s:g} m/s); "
                        "--refit fits it again")
    try:
        new = derive(spec)
    except SpecError as exc:
        if not (refit and d.calibrated and exc.field in _CALIBRATION_FIELDS):
            raise
        raise _refit_refusal(d, changes, exc) from None
    if refit:
        if not d.calibrated:
            messages.append("--refit: nothing to refit, both wind angles are given")
        else:
            old = math.degrees(d.theta0 if d.calibrated == "rivulet_angle_deg" else d.beta)
            now = math.degrees(new.theta0 if d.calibrated == "rivulet_angle_deg" else new.beta)
            whose = "" if new.mode_pair == 1 else " of the first mode pair (held for this pair)"
            messages.append(f"refit: aero.{d.calibrated} moved from {old:.4f} to {now:.4f} deg so that the "
                            f"onset{whose} stays at the U_c typed in ({d.spec.aero.critical_wind_speed_m_s:g} m/s); "
                            + ("the onset is then an input, not a result" if new.mode_pair == 1
                               else "this pair's onset is a prediction with that angle"))
    return new, messages


#: The fields a failed calibration blames (`autocable.model.calibration.calibrate`).
_CALIBRATION_FIELDS = ("aero.rivulet_angle_deg", "aero.yaw_deg", "aero.critical_wind_speed_m_s", "cable.damping_ratio")


def _refit_refusal(d, changes: dict, exc: SpecError) -> SpecError:
    """``onset --set ... --refit`` whose changed cable admits no fitted angle: the refusal names
    the ``--set`` items as given (the model file as written calibrates: its values are not the
    ones to blame) and the fixes (drop --refit, change less), with the calibration's reason where
    it fits whole within `autocable.spec.MAX_MESSAGE` (a one-line message is never cut)."""
    from autocable.spec import MAX_MESSAGE, number_text
    items = " ".join(f"cable.{k}={number_text(float(v))}" for k, v in changes.items())
    fitted = math.degrees(d.theta0 if d.calibrated == "rivulet_angle_deg" else d.beta)
    reason = str(exc).split(f"{exc.field}: ", 1)[-1]
    evidence, _, own_fix = reason.partition(": give ")     # the calibration's finding, and its fixes
    name = exc.field.split(".", 1)[-1]
    fix = f"drop --refit to hold aero.{d.calibrated} at {fitted:.4g} deg, or change less"
    if name in changes and own_fix:     # the value changed is the one to blame: in the calibration's words
        evidence = evidence.removeprefix(number_text(float(changes[name])) + " ")
        text = (f"{items} (--refit) {evidence}: give {own_fix.split(', or try')[0]}, or drop --refit (keeps "
                f"aero.{d.calibrated} = {fitted:.4g})")
    else:
        text = f"{items} with --refit: {exc.field}: {evidence}; {fix}"
    if len(f"--set: {text}") > MAX_MESSAGE:
        text = f"{items} with --refit leaves no admissible wind angle: {fix}"
    return SpecError("arguments", "--set", text)


def with_damper(d):
    """(derivation, damper) of ``d`` with the model's ``[damper]``: eq. (21)'s modal damping ratio is
    the cable's own ``damping_ratio`` plus what the damper adds to the in-plane mode of eq. (21)
    (`autocable.model.damper.onset_damping`: the exact taut string, corrected for bending and sag),
    every other term (a fitted wind angle too, fitted without the damper) as derived; (d, None)
    without a damper. The ratio is set, not added, so applying it twice changes nothing."""
    from autocable.model.damper import onset_damping
    info = onset_damping(d.spec)
    if info is None:
        return d, None
    return replace(d, ode=with_damping(d.ode, info["total_damping"])), info


def onset_report(d, U_max: float = U_MAX_DEFAULT) -> dict:
    """The JSON of `autocable onset` (and the summary of `autocable derive`); a model's
    ``[damper]`` is in the modal damping (`with_damper`, key ``damper``)."""
    d, damper = with_damper(d)
    units = units_of(d.spec, d.statics)
    result = stability(d.ode, U_max)
    om = one_mode(d.ode)
    pair = getattr(d, "mode_pair", 1)
    station = PEAK_STATION if pair == 1 else f"each mode's maximum (mode pair {pair}: not mid-span)"
    return {
        "model": d.spec.name, "mode_pair": pair,
        "frequency_Hz": {"in_plane": units.frequency_hz(d.ode.omega1), "out_of_plane": units.frequency_hz(d.ode.omega2)},
        "wind_angles": angle_statement(d),
        "damping_ratio": d.ode.xi_s, "scruton": units.scruton(d.ode.xi_s),
        "scanned_U_m_s": [0.0, units.wind_m_s(U_max)],
        "onsets": [o.to_dict(units) for o in result.onsets],
        "restabilisations_U_m_s": [units.wind_m_s(U) for U in result.restabilisations],
        "damper": damper,
        "stable_without_wind": result.stable_at_start,
        "one_mode": {"zeta11": om["zeta11"], "zeta8": om["zeta8"],
                     "onset_U_m_s": units.wind_m_s(om["onset_U_star"]),
                     "criticality": om["criticality"],
                     "reading": "eq. (25): in-plane galloping iff zeta11 < 0, super-critical iff zeta8 > 0"},
        "warnings": one_mode_warnings(d.ode, result, units),
        "conventions": {"U_m_s": "U* U_c", "frequency_Hz": "Im(lambda) omega / (2 pi), omega = (pi/l) sqrt(T/m)",
                        "amplitudes": f"a_k l [m] at {station}",
                        "scruton": "Sc = m xi / (rho_a D^2)"},
    }


def onset_text(report: dict) -> list[str]:
    """The readable lines of an `onset_report` (also printed by `autocable derive`)."""
    pair = report.get("mode_pair", 1)
    on = "" if pair == 1 else (f" on mode pair {pair} ({report['frequency_Hz']['in_plane']:.4g} Hz in plane, "
                               f"{report['frequency_Hz']['out_of_plane']:.4g} Hz out of plane)")
    lines = [f"Onset of galloping (eq. 21{on} at eta = 0, trivial state, every linear coupling; "
             f"damping {100 * report['damping_ratio']:.3g} %, Sc = {report['scruton']:.3g}):",
             f"  {report['wind_angles']['text']}"]
    if not report["onsets"]:
        lines.append(f"  stable up to {report['scanned_U_m_s'][1]:.4g} m/s (the scanned range)")
    for o in report["onsets"]:
        ev = o["eigenvector"]
        lines.append(f"  U_cr = {o['U_m_s']:.6g} m/s (U* = {o['U_star']:.10g}), {o['frequency_Hz']:.5g} Hz: "
                     f"{o['mechanism']}, {o['criticality']}")
        phase = ev["phase_deg"]
        lines.append(f"    eigenvector: in-plane {100 * ev['in_plane_share']:.3g} %, out-of-plane "
                     f"{100 * ev['out_of_plane_share']:.3g} %"
                     + (f", phase of q2 on q1 {phase:.4g} deg" if phase is not None and math.isfinite(phase) else ""))
        if o["lyapunov"] is not None:
            s = o["amplitude_slope"]["d_peak_squared_dU_m2_per_m_s"]
            lines.append(f"    first Lyapunov coefficient {o['lyapunov']:.4g}; post-critical d(peak^2)/dU = "
                         f"{s[0]:.4g} m^2/(m/s) in-plane, {s[1]:.4g} out-of-plane "
                         + ("(mid-span)" if pair == 1 else "(at each mode's maximum)"))
    for U in report["restabilisations_U_m_s"]:
        lines.append(f"  the trivial state is stable again above U = {U:.6g} m/s")
    om = report["one_mode"]
    lines.append(f"  one-mode eq. (25): zeta11 = {om['zeta11']:.4g}, zeta8 = {om['zeta8']:.4g} -> "
                 + (f"onset {om['onset_U_m_s']:.4g} m/s, {om['criticality']}"
                    if om["onset_U_m_s"] is not None and math.isfinite(om["onset_U_m_s"])
                    else "no in-plane galloping"))
    dp = report.get("damper")
    if dp:
        lines.append(f"  damper at {dp['position_m']:.4g} m, c = {dp['constant_N_s_m']:.4g} N s/m (model's [damper]): "
                     f"adds {100 * dp['added_damping']:.4g} % to mode {dp['mode']} (taut string "
                     f"{100 * dp['added_damping_taut_string']:.4g} %, corrected for bending and sag); the damping "
                     f"above is {100 * dp['structural_damping']:.4g} % + {100 * dp['added_damping']:.4g} % = "
                     f"{100 * dp['total_damping']:.4g} %"
                     + (" (the fitted wind angle puts the onset of the cable without it at U_c)"
                        if report["wind_angles"].get("calibrated") else ""))
    return lines


# -- damping -----------------------------------------------------------------------------------------
def damping_curve(d, xis, U_max: float = U_MAX_DEFAULT) -> list[dict]:
    """U_cr (m/s) of the first onset against the damping ratio and the Scruton number, angles fixed."""
    from autocable.model.onset import onset_at
    units = units_of(d.spec, d.statics)
    rows = []
    for xi in xis:
        ode = with_damping(d.ode, float(xi))
        U = first_onset_U(ode, U_max)
        o = onset_at(ode, U) if math.isfinite(U) else None
        rows.append({"damping_ratio": float(xi), "scruton": units.scruton(float(xi)),
                     "U_cr_m_s": units.wind_m_s(U), "U_cr_star": U,
                     "frequency_Hz": units.frequency_hz(o.frequency) if o else math.nan,
                     "criticality": o.criticality if o else "stable in the scanned range",
                     "mechanism": o.mechanism if o else ""})
    return rows


def worst_growth(ode, U_top: float, n: int = 401) -> tuple[float, float]:
    """(the largest real part of the linearised eq. (21) at eta = 0 over U* in [0, U_top], the U* where
    it is): every local maximum of a coarse grid's abscissa refined by bounded Brent on the bracket of
    its two neighbours, the ends included. The grid only brackets: the value is the refined maximum,
    not a sample, so a peak whose unstable window is narrower than the grid's step is found (two
    peaks within one step of the grid are not told apart: one of them may be missed)."""
    from scipy.optimize import minimize_scalar

    from autocable.model.onset import LinearPencil
    pencil = LinearPencil(ode)
    grid = np.linspace(0.0, U_top, n)
    g = pencil.abscissa(grid)
    best = max((float(g[0]), 0.0), (float(g[-1]), float(U_top)))
    xatol = 1e-12 * max(U_top, 1.0)
    for i in np.flatnonzero((g[1:-1] >= g[:-2]) & (g[1:-1] >= g[2:])) + 1:
        res = minimize_scalar(lambda U: -float(pencil.abscissa(U)[0]), bounds=(grid[i - 1], grid[i + 1]),
                              method="bounded", options={"xatol": xatol, "maxiter": 200})
        best = max(best, (float(g[i]), float(grid[i])), (float(-res.fun), float(res.x)))
    return best


def design_damping(d, U_design_m_s: float, U_max: float = U_MAX_DEFAULT, rtol: float = 1e-10) -> dict:
    """The least damping ratio for which the trivial state is stable for every U <= U_design: the
    damping at which the largest real part of the linearised eq. (21) over U in [0, U_design]
    (`worst_growth`, the worst speed bracketed and refined, not sampled) is zero, by bisection on xi
    to ``rtol`` keeping the stable end (the value returned is never below the least one by more than
    the maximisation's own accuracy). The current damping ratio includes a model's ``[damper]``
    (`with_damper`)."""
    d, _ = with_damper(d)
    units = units_of(d.spec, d.statics)
    U_des = units.wind_star(U_design_m_s)
    if not 0 < U_des <= U_max:
        raise SpecError("arguments", "--design-wind", f"expected a wind speed in (0, {units.wind_m_s(U_max):.4g}] "
                                                      f"m/s (U* <= {U_max:g}), got {U_design_m_s:g}")

    def growth(xi):
        return worst_growth(with_damping(d.ode, xi), U_des)

    # (at xi = 0 exactly the trivial state is only marginally stable without wind: the abscissa at
    # U = 0 is 0, so a damping of 1e-12 stands for "none")
    g0, U_w = growth(1e-12)
    if g0 < 0:
        xi = 0.0
    else:
        lo, hi = 1e-12, 1e-3
        while True:
            g_hi, U_hi = growth(hi)
            if g_hi < 0:
                break
            lo, hi = hi, 2 * hi
            if hi >= 1.0:
                raise SpecError("arguments", "--design-wind", f"no damping ratio below 100 % keeps the trivial "
                                                              f"state stable up to {U_design_m_s:g} m/s")
        U_w = U_hi
        while hi - lo > rtol * hi:
            mid = 0.5 * (lo + hi)
            g_mid, U_mid = growth(mid)
            if g_mid < 0:
                hi, U_w = mid, U_mid
            else:
                lo = mid
        xi = hi
    return {"design_wind_m_s": U_design_m_s, "least_damping_ratio": xi, "scruton": units.scruton(xi),
            "current_damping_ratio": d.ode.xi_s, "current_scruton": units.scruton(d.ode.xi_s),
            "enough": d.ode.xi_s >= xi, "worst_wind_m_s": units.wind_m_s(U_w),
            "search": "max Re lambda over U in [0, U_design] (coarse grid, every local maximum refined by "
                      "bounded Brent) set to zero by bisection on xi"}


# -- post-critical amplitude -------------------------------------------------------------------------
def ame_galloping(ode, U_values, ordering: str = "natural") -> list[dict]:
    """The galloping cycle of the AME (24) at eta = 0 along ``U_values`` (U*, ordered away from the
    onset): a relative equilibrium with s1 = 0, unknowns (r1, r2, s2, sigma) solved by Newton, each
    point started from the previous one, the first from the normal form (module docstring), until
    Newton fails or the amplitude leaves the model's range (`MAX_AMPLITUDE`). Rows
    carry a1, a2, sigma, the Hopf frequency shift, and whether the cycle is stable (every
    eigenvalue of the AME's Jacobian but the phase's zero one in the left half plane)."""
    from scipy.optimize import root

    from autocable.methods.integration.ame import AmeIntegrator
    from autocable.model.ame_cache import derive_ame
    from autocable.model.onset import onset_at

    Uc = first_onset_U(ode)
    if not math.isfinite(Uc):
        return []
    o = onset_at(ode, Uc)
    if o.lyapunov is None:
        return []
    ame = derive_ame(ode, ordering=ordering).ame
    integ = AmeIntegrator(ame)
    f, J = integ.rhs.f, integ.rhs.jacobian
    q = np.asarray(o.eigenvector)
    ratio = q[1] / q[0]
    x, U_prev = None, None
    rows = []
    for U in U_values:
        s = o.amplitude_slopes[0] * (U - Uc)
        if x is None:
            if s <= 0:
                continue          # no small cycle on this side of the onset
            a = math.sqrt(s)
            x = np.array([a, (a * ratio).real, (a * ratio).imag, o.frequency - ode.omega1])
        else:
            # the previous cycle scaled as the normal form scales it: amplitudes ~ sqrt(U - Uc),
            # the frequency shift ~ (U - Uc)
            k = (U - Uc) / (U_prev - Uc)
            x = np.concatenate([x[:3] * math.sqrt(k), [o.frequency - ode.omega1
                                                       + (x[3] - o.frequency + ode.omega1) * k]])

        def g(z, U=U):
            p = integ.parameters(U, 0.0, z[3])
            return f(np.array([z[0], 0.0, z[1], z[2]]), p)

        sol = root(g, x, method="hybr", tol=1e-13)
        # the right-hand side is a1 times rates of order 1e-3: a residual 1e-9 a1 is Newton's floor;
        # a solution more than twice as far as the prediction is another branch, not this one's
        # continuation, and one beyond MAX_AMPLITUDE is outside the model
        ok = (0 < sol.x[0] <= MAX_AMPLITUDE and float(np.max(np.abs(g(sol.x)))) < 1e-9 * sol.x[0]
              and 0.5 * x[0] <= sol.x[0] <= 2 * x[0])
        if not ok:
            if U_prev is None:
                x = None
                continue
            break                 # the branch ends here (a fold, or the model's range)
        x, U_prev = sol.x, U
        y = np.array([x[0], 0.0, x[1], x[2]])
        ev = np.linalg.eigvals(J(y, integ.parameters(U, 0.0, x[3])))
        ev = np.delete(ev, int(np.argmin(np.abs(ev))))          # the phase's zero eigenvalue
        rows.append({"U_star": float(U), "a1": float(x[0]), "a2": float(math.hypot(x[1], x[2])),
                     "sigma": float(x[3]), "stable": bool(np.max(ev.real) < 0), "converged": True})
    return rows


def eq21_check(ode, U: float, a1_ame: float, q_ratio: complex, t_end: float = 3e5) -> dict:
    """Eq. (21) at eta = 0, U* from half the AME's cycle (in the eigenvector's proportions) to its own
    cycle: the last period's half peak-to-peak a1, a2 against the AME's, and whether it settled."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    integ = Ode21Integrator(ode, engine="compiled")
    a0 = 0.5 * a1_ame
    y0 = (a0, (a0 * q_ratio).real, 0.0, -(a0 * q_ratio).imag * ode.omega1)
    t, a1, a2, msg = integ.envelope(U, 0.0, 0.0, y0, t_end, Omega=ode.omega1, keep_failed=True)
    if len(a1) < 400 or "bounded" not in msg:
        return {"U_star": U, "a1_eq21": math.nan, "a2_eq21": math.nan, "settled": False, "message": msg}
    drift = abs(a1[-1] - a1[-200]) / max(a1[-1], 1e-300)
    return {"U_star": U, "a1_eq21": float(a1[-1]), "a2_eq21": float(a2[-1]), "settled": drift < 1e-3,
            "drift_last_200_periods": float(drift), "t_end": float(t[-1]), "message": msg}


def amplitude_curve(d, xi: float, U_top: float | None = None, n: int = 30, checks: int = 2) -> dict:
    """The post-critical amplitude (m at mid-span) against U (m/s) at damping ratio ``xi``: the AME's
    galloping cycle (`ame_galloping`) from the onset to ``U_top`` (U*; 1.5 U_cr if not above 1.05 U_cr)
    on a super-critical onset (the stable branch), or down to half the onset on a sub-critical one (the unstable branch), with
    ``checks`` points of the stable branch integrated by eq. (21) (`eq21_check`)."""
    from autocable.model.onset import onset_at
    units = units_of(d.spec, d.statics)
    ode = with_damping(d.ode, xi)
    Uc = first_onset_U(ode)
    out = {"damping_ratio": xi, "scruton": units.scruton(xi), "U_cr_m_s": units.wind_m_s(Uc), "rows": [],
           "eq21_checks": []}
    if not math.isfinite(Uc):
        out["note"] = "no onset in the scanned range"
        return out
    o = onset_at(ode, Uc)
    out["criticality"] = o.criticality
    if o.lyapunov is None:
        out["note"] = "a static (non-oscillatory) loss of stability: no galloping cycle"
        return out
    if o.criticality == "supercritical":
        end = U_top if U_top is not None and U_top > 1.05 * Uc else 1.5 * Uc
    else:
        end = 0.5 * Uc
    s = np.linspace(0.0, 1.0, n + 1)[1:] ** 2          # dense near the onset, where a ~ sqrt(U - U_cr)
    U_values = Uc + (end - Uc) * s
    rows = ame_galloping(ode, U_values)
    for r in rows:
        r.update({"U_m_s": units.wind_m_s(r["U_star"]), "peak_in_plane_m": units.peak_m(r["a1"]),
                  "peak_out_of_plane_m": units.peak_m(r["a2"])})
    out["rows"] = rows
    if checks and o.criticality == "subcritical" and rows:
        q = np.asarray(o.eigenvector)
        picks = [rows[int(round(k))] for k in np.linspace(len(rows) // 4, len(rows) - 1, checks)]
        out["hysteresis_checks"] = [dict(hysteresis_check(ode, r["U_star"], r["a1"], q[1] / q[0]),
                                         U_m_s=units.wind_m_s(r["U_star"])) for r in picks]
    stable = [r for r in rows if r["stable"]]
    if checks and stable:
        q = np.asarray(o.eigenvector)
        picks = [stable[int(round(k))] for k in np.linspace(len(stable) // 4, len(stable) - 1, checks)]
        for r in picks:
            c = eq21_check(ode, r["U_star"], r["a1"], q[1] / q[0])
            c.update({"U_m_s": units.wind_m_s(r["U_star"]), "a1_ame": r["a1"], "a2_ame": r["a2"],
                      "peak_in_plane_m_eq21": units.peak_m(c["a1_eq21"]),
                      "relative_difference_a1": abs(c["a1_eq21"] - r["a1"]) / r["a1"]})
            out["eq21_checks"].append(c)
    return out


def damping_study(d, xis, design_wind_m_s: float | None = None, amplitude_xis=(), checks: int = 2,
                  U_max: float = U_MAX_DEFAULT) -> dict:
    """Everything `autocable onset --damping` writes: the onset report, U_cr against damping and
    Scruton number, the design damping, and the amplitude curves."""
    report = onset_report(d, U_max)
    report["damping"] = damping_curve(d, xis, U_max)
    report["scruton_rules"] = [list(r) for r in SCRUTON_RULES]
    if design_wind_m_s is not None:
        report["design"] = design_damping(d, design_wind_m_s, U_max)
    U_top = None if design_wind_m_s is None else min(U_max, units_of(d.spec, d.statics).wind_star(design_wind_m_s))
    report["amplitude"] = [amplitude_curve(d, float(xi), U_top, checks=checks) for xi in amplitude_xis]
    report["length_m"] = d.spec.cable.length_m
    return report


def hysteresis_check(ode, U: float, a1_cycle: float, q_ratio: complex, t_end: float = 1e5) -> dict:
    """Below a sub-critical onset: eq. (21) from 0.6 and 1.5 times the AME's unstable cycle (in the
    eigenvector's proportions): the first should decay, the second grow (hysteresis: a large enough
    disturbance gallops below the onset)."""
    from autocable.methods.integration.ode21 import Ode21Integrator
    integ = Ode21Integrator(ode, engine="compiled")
    out = {"U_star": U, "a1_unstable_cycle": a1_cycle}
    for name, f in (("from_0.6", 0.6), ("from_1.5", 1.5)):
        a0 = f * a1_cycle
        y0 = (a0, (a0 * q_ratio).real, 0.0, -(a0 * q_ratio).imag * ode.omega1)
        t, a1, a2, msg = integ.envelope(U, 0.0, 0.0, y0, t_end, Omega=ode.omega1, keep_failed=True)
        grew = "diverges" in msg or (len(a1) > 0 and a1.max() > 1.3 * a0)
        decayed = "bounded" in msg and len(a1) > 0 and a1[-1] < 0.5 * a0
        out[name] = "grows" if grew else ("decays" if decayed else "undecided")
        if msg.startswith("eq. (21) could not be integrated"):
            out[name + "_note"] = msg
    out["hysteresis"] = out["from_0.6"] == "decays" and out["from_1.5"] == "grows"
    return out


# -- every mode pair below a frequency (`autocable onset --modes-below F`) ---------------------------
#: Columns each pair row leaves empty (null) for the global least damping and the galloping amplitude
#: at the design wind, which come from another study (`autocable.studies.gallop`), not from this one.
PENDING_COLUMNS = ("least_damping_global", "amplitude_at_design_wind_m")


def pair_spec(spec, k: int):
    """``spec`` with ``cable.mode_pair = k`` (everything else, a fitted or given angle too, as it is)."""
    return replace(spec, cable=replace(spec.cable, mode_pair=int(k)))


def _mechanism_short(o) -> str:
    if o is None:
        return "stable"
    if o.mechanism.startswith("coupled"):
        return f"coupled ({100 * o.in_plane_share:.0f} % in-plane)"
    return o.mechanism


def pair_row(dk, info, units, design_wind_m_s: float | None, U_max: float) -> dict:
    """One row of `pairs_below`: pair k's frequencies, first onset (eq. 21 on the pair, linear
    stability and first Lyapunov coefficient, `autocable.model.onset`), crowding, twist per metre of
    out-of-plane displacement, and with a design wind the least damping ratio keeping the pair's
    trivial state stable up to it (`design_damping`). A model's ``[damper]`` is in the pair's modal
    damping (`with_damper`: what it adds to the pair's in-plane mode)."""
    from autocable.errors import ComputationError
    from autocable.model.mode_pairs import describe_mode, pair_modes, twist_peak_per_unit
    try:
        dk, damper = with_damper(dk)
    except ComputationError as exc:
        # the damper's added damping in this pair's mode has no value (e.g. k x_d/L near 1/2): the
        # pair's onset with the damper is not known, so the row says why instead of an onset
        return _pair_row_without_damper(dk, info, units, str(exc))
    result = stability(dk.ode, U_max)
    o = result.first
    l = dk.spec.cable.length_m
    twist = twist_peak_per_unit(pair_modes(dk.statics, info.k, dk.spec.cable.twist_ends))
    row = {
        "k": info.k,
        "in_plane_mode": info.describe_in_plane(),
        "in_plane_symmetry": info.in_plane.symmetry, "in_plane_index": info.in_plane.k,
        "frequency_Hz": {"in_plane": units.frequency_hz(info.omega1), "out_of_plane": units.frequency_hz(info.omega2)},
        "omega": {"in_plane": info.omega1, "out_of_plane": info.omega2},
        "onset_U_m_s": units.wind_m_s(o.U_star) if o else None,
        "onset_U_star": o.U_star if o else None,
        "onset_frequency_Hz": units.frequency_hz(o.frequency) if o else None,
        "mechanism": o.mechanism if o else f"stable up to {units.wind_m_s(U_max):.4g} m/s (the scanned range)",
        "mechanism_short": _mechanism_short(o),
        "in_plane_share": o.in_plane_share if o else None,
        "criticality": o.criticality if o else None,
        "lyapunov": o.lyapunov if o else None,
        "stable_without_wind": result.stable_at_start,
        "crowded_with": [{"mode": describe_mode(p, s, i), "frequency_Hz": units.frequency_hz(om),
                          "gap_percent": 100 * g} for p, s, i, om, g in info.crowded_with],
        "bending_frequency_shift": info.bending_shift,
        "twist_rad_per_m": twist / l,
        "least_damping_linear": None, "least_damping_linear_scruton": None,
        "damper_added_damping": damper["added_damping"] if damper else None,
    }
    if design_wind_m_s is not None:
        try:
            ds = design_damping(dk, design_wind_m_s, U_max)
        except SpecError as exc:        # no damping ratio below 100 % stops it: said in the row
            row["least_damping_linear_note"] = str(exc).split(": ", 2)[-1]
        else:
            row["least_damping_linear"] = ds["least_damping_ratio"]
            row["least_damping_linear_scruton"] = ds["scruton"]
            row["damping_enough"] = ds["enough"]
    row.update({c: None for c in PENDING_COLUMNS})
    return row


def _pair_row_without_damper(dk, info, units, reason: str) -> dict:
    """The row of pair k when the model's ``[damper]`` cannot be evaluated in its mode: what does
    not depend on the damping (frequencies, crowding, twist), every onset and damping column null
    and ``damper_note`` saying why, naming the damper's fields to change."""
    from autocable.model.mode_pairs import describe_mode, pair_modes, twist_peak_per_unit
    twist = twist_peak_per_unit(pair_modes(dk.statics, info.k, dk.spec.cable.twist_ends))
    x = dk.spec.damper.position_m
    r = x / dk.spec.cable.length_m
    if "could not be followed" in reason:       # `autocable.model.damper`: the root turned overdamped
        why = (f"k x_d/L = {info.k * r:.3g}: the taut-string root could not be followed from the undamped string; "
               "the damper formulas hold for k x_d/L well below 1/2")
    else:
        why = reason.removeprefix("damper: ")
    note = (f"not computed: the [damper]'s added damping in mode {info.k} could not be found ({why}): move the "
            f"damper nearer the anchorage (damper.position_m = {x:g} m) or give a lower --modes-below")
    return {
        "k": info.k, "in_plane_mode": info.describe_in_plane(),
        "in_plane_symmetry": info.in_plane.symmetry, "in_plane_index": info.in_plane.k,
        "frequency_Hz": {"in_plane": units.frequency_hz(info.omega1), "out_of_plane": units.frequency_hz(info.omega2)},
        "omega": {"in_plane": info.omega1, "out_of_plane": info.omega2},
        "onset_U_m_s": None, "onset_U_star": None, "onset_frequency_Hz": None,
        "mechanism": note, "mechanism_short": "not computed (damper)", "in_plane_share": None,
        "criticality": None, "lyapunov": None, "stable_without_wind": None,
        "crowded_with": [{"mode": describe_mode(p, s, i), "frequency_Hz": units.frequency_hz(om),
                          "gap_percent": 100 * g} for p, s, i, om, g in info.crowded_with],
        "bending_frequency_shift": info.bending_shift,
        "twist_rad_per_m": twist / dk.spec.cable.length_m,
        "least_damping_linear": None, "least_damping_linear_scruton": None,
        "damper_added_damping": None, "damper_note": note, "computed": False,
        **{c: None for c in PENDING_COLUMNS},
    }


def pairs_below(d, below_hz: float, design_wind_m_s: float | None = None, U_max: float = U_MAX_DEFAULT) -> dict:
    """`autocable onset --modes-below F`: one row (`pair_row`) per mode pair k = 1, 2, ... while the
    lower of the pair's two frequencies is below ``below_hz`` [Hz]. Each pair is eq. (21) on its own
    modes (`autocable.model.mode_pairs`) with the wind angles of ``d`` (a calibrated angle fitted on
    the first pair, held). A crowded pair is computed and named in its row (``crowded_with``), not
    refused. The `PENDING_COLUMNS` are null."""
    import warnings

    from autocable.model.derive import derive
    from autocable.model.mode_pairs import CROWDED_FRACTION, bending_ratio, pair_info
    from autocable.model.premises import PremiseWarning
    from autocable.spec import MODE_PAIR_MAX
    units = units_of(d.spec, d.statics)
    ratio = bending_ratio(d.spec.cable, d.statics)
    rows = []
    for k in range(1, MODE_PAIR_MAX + 2):
        info = pair_info(d.statics, k, ratio)
        if min(units.frequency_hz(info.omega1), units.frequency_hz(info.omega2)) >= below_hz:
            break
        if k > MODE_PAIR_MAX:
            raise SpecError("arguments", "--modes-below", f"more than {MODE_PAIR_MAX} mode pairs of this cable lie "
                                                          f"below {below_hz:g} Hz (the first at "
                                                          f"{units.frequency_hz(1.0):.4g} Hz); give a lower frequency")
        if k == d.mode_pair:
            dk = d
        else:
            # the row carries what the premise warnings would say (crowding, bending); the model's own
            # premises were checked and warned about on ``d``
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", PremiseWarning)
                dk = derive(pair_spec(d.spec, k))
        rows.append(pair_row(dk, info, units, design_wind_m_s, U_max))
    return {
        "model": d.spec.name, "below_Hz": below_hz, "wind_angles": angle_statement(d),
        "damping_ratio": d.ode.xi_s, "scruton": units.scruton(d.ode.xi_s),
        "design_wind_m_s": design_wind_m_s, "scanned_U_m_s": [0.0, units.wind_m_s(U_max)],
        "pairs": rows,
        # a pair whose damper damping has no value is listed, not computed: said here too
        "warnings": [f"mode pair {r['k']}: {r['damper_note']}" for r in rows if r.get("damper_note")],
        "pending_columns": {c: "null: filled by the galloping study (autocable.studies.gallop), not by this table"
                            for c in PENDING_COLUMNS},
        "conventions": {
            "k": "mode pair: the k-th in-plane mode (by frequency) and the out-of-plane mode sin(k pi s)",
            "frequency_Hz": "the pair's natural frequencies, omega_k omega / (2 pi), omega = (pi/l) sqrt(T/m)",
            "onset_U_m_s": "the first loss of stability of the pair's trivial state (null: stable over scanned_U_m_s, "
                           "or not computed where the row has a damper_note)",
            "damper_note": "only in a row whose [damper] added damping could not be found (computed: false): why, "
                           "and the damper field to change; that row's onset and damping columns are null",
            "lyapunov": "first Lyapunov coefficient at the onset (|q| = 1); > 0 sub-critical, < 0 super-critical",
            "least_damping_linear": "with --design-wind: the least damping ratio keeping the pair's trivial state "
                                    "stable up to the design wind (linear, eq. 21 on that pair alone)",
            "crowded_with": f"left-out modes within {100 * CROWDED_FRACTION:g} % of the pair's frequencies",
            "twist_rad_per_m": "peak slaved twist per metre of peak out-of-plane displacement",
            "bending_frequency_shift": "sqrt(1 + (k pi)^2 EI/(T l^2)) - 1, left out of the string frequencies",
            "wind_angles": "those of the model: a calibrated angle is fitted on the first pair and held"},
    }


def pairs_text(report: dict) -> list[str]:
    """The readable table of `pairs_below`."""
    des = report["design_wind_m_s"]
    lines = [f"Mode pairs below {report['below_Hz']:g} Hz (eq. 21 on each pair; damping "
             f"{100 * report['damping_ratio']:.3g} %, Sc = {report['scruton']:.3g}; scanned up to "
             f"{report['scanned_U_m_s'][1]:.4g} m/s):",
             f"  {report['wind_angles']['text']}",
             *(["  (the fitted angle is held for every pair: the onsets of pairs k > 1 are predictions with it)"]
               if report["wind_angles"]["calibrated"] else []),
             "   k  in-plane mode     f_in [Hz]  f_out [Hz]  U_cr [m/s]  mechanism                 criticality (l1)"
             + (f"        least xi to {des:g} m/s" if des is not None else "")]
    for r in report["pairs"]:
        kind = f"{r['in_plane_symmetry']} {r['in_plane_index']}"
        U = f"{r['onset_U_m_s']:10.4g}" if r["onset_U_m_s"] is not None else f"{'-':>10}"
        crit = (f"{r['criticality']} ({r['lyapunov']:.4g})" if r["lyapunov"] is not None
                else (r["criticality"] or "-"))
        line = (f"  {r['k']:2d}  {kind:<16}  {r['frequency_Hz']['in_plane']:9.4f}  {r['frequency_Hz']['out_of_plane']:10.4f}"
                f"  {U}  {r['mechanism_short']:<24}  {crit:<24}")
        if des is not None:
            xi = r["least_damping_linear"]
            line += (f"  {100 * xi:.4g} % (Sc = {r['least_damping_linear_scruton']:.3g})" if xi is not None
                     else f"  {r.get('least_damping_linear_note', '-')}")
        if r["crowded_with"]:
            line += "  crowded: " + ", ".join(f"{c['mode']} ({c['gap_percent']:.2g} %)" for c in r["crowded_with"])
        lines.append(line.rstrip())
    lines += [f"  pair {r['k']}: {r['damper_note']}" for r in report["pairs"] if r.get("damper_note")]
    lines.append("  (least_damping_global and amplitude_at_design_wind_m: not computed here, null in --json)")
    return lines
