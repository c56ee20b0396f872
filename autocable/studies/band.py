"""`autocable onset --band`: the onset and the least damping over the inputs nobody knows.

A stay's onset speed U_c (eq. 18: the wind at which rain-wind vibration was seen, a range on site),
which of the two frame-indifferent readings of the load's angle applies (``angle_convention``
"eq12", eq. (12) as printed, or "mirrored", the curves read as c(-phi): both satisfy the frame check
of `autocable.model.aero`), the sign of the yaw relative to the chord slope, and which root of the
calibration (`autocable.model.calibration`: every rivulet angle Theta0 that puts the in-plane onset
at U_c) the stay has: none is measured. `band_study` runs the onset (`autocable.studies.onset`:
the linear stability of eq. (21) at eta = 0) and, with a design wind, the least damping
(`design_damping`) for every combination, and reports each quantity as a band [lo, hi] with the
combination that sets each end. A model's ``[damper]`` position turns each least damping into the
least damper constant there (`autocable.model.damper.least_constant`, corrected for bending and sag).

A combination whose calibration has no admissible root is listed with its one-line reason (the
calibration's own message, which names the fix), never dropped.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import replace
from types import SimpleNamespace

import numpy as np

from autocable.model.onset import U_MAX_DEFAULT, stability
from autocable.model.units import units_of
from autocable.spec import SpecError
from autocable.errors import ComputationError
from autocable.studies.gallop import (SENSITIVITY_BAND_DEG, SENSITIVITY_BLEND_FACTORS, DampedSystem, gallop_study,
                                      least_damping_global, sensitivity_undefined)
from autocable.studies.onset import design_damping, with_damper

#: The two frame-indifferent readings of the angle of eq. (12) (the legacy "reversed" is not one).
READINGS = ("eq12", "mirrored")
#: Onset speeds tried over a range: its two ends and this many points in all, evenly spaced.
UC_POINTS = 5


def uc_values(lo: float, hi: float, n: int = UC_POINTS) -> list[float]:
    """The onset speeds of a band: the ends of [lo, hi] and evenly spaced interior points (one value
    if lo == hi)."""
    if hi == lo:
        return [float(lo)]
    return [float(x) for x in np.linspace(lo, hi, n)]


def _inputs(aero, root_kind: str) -> dict:
    return {"critical_wind_speed_m_s": aero.critical_wind_speed_m_s, "angle_convention": aero.angle_convention,
            "yaw_deg": aero.yaw_deg, "rivulet_angle_deg": aero.rivulet_angle_deg, "root": root_kind}


def case_label(inputs: dict) -> str:
    """A short name of one combination (the plot's rows, the text report)."""
    th = inputs.get("rivulet_angle_deg")
    yaw = inputs.get("yaw_deg")
    angle = (f", Theta0 {th:.2f}" if isinstance(th, (int, float)) else "") if inputs["root"] != "given" else ""
    yaw_text = f"yaw {yaw:+g}" if isinstance(yaw, (int, float)) else "yaw calibrated"
    return f"{inputs['angle_convention']}, {yaw_text}, U_c {inputs['critical_wind_speed_m_s']:g}{angle}"


def _case(d, inputs: dict, design_wind_m_s: float | None, U_max_m_s: float | None) -> dict:
    """Onset, least damping and damper constant of one derivation."""
    from autocable.model import damper as dm
    units = units_of(d.spec, d.statics)
    U_max = U_MAX_DEFAULT if U_max_m_s is None else min(U_MAX_DEFAULT, units.wind_star(U_max_m_s))
    dd, damper = with_damper(d)
    first = stability(dd.ode, U_max).first
    out = {"inputs": inputs, "label": case_label(inputs), "status": "ok",
           "onset_U_m_s": units.wind_m_s(first.U_star) if first else None,
           "onset_frequency_Hz": units.frequency_hz(first.frequency) if first else None,
           "mechanism": first.mechanism if first else f"stable up to {units.wind_m_s(U_max):.4g} m/s",
           "criticality": first.criticality if first else None,
           "scanned_U_m_s": units.wind_m_s(U_max), "damping_ratio": dd.ode.xi_s,
           "least_damping": None, "damper_constant_N_s_m": None}
    if design_wind_m_s is not None:
        if units.wind_star(design_wind_m_s) > U_max:
            out["least_damping_note"] = (f"the design wind {design_wind_m_s:g} m/s lies beyond this case's scanned "
                                         f"range ({units.wind_m_s(U_max):.4g} m/s = {U_max:g} U_c)")
        else:
            try:
                ds = design_damping(d, design_wind_m_s, U_max)
            except SpecError as exc:        # no damping below 100 %: said in the case
                out["least_damping_note"] = str(exc).split(": ", 2)[-1]
            else:
                out["least_damping"] = ds["least_damping_ratio"]
                out["least_damping_scruton"] = ds["scruton"]
                out["worst_wind_m_s"] = ds["worst_wind_m_s"]
                if d.spec.damper is not None:
                    target = ds["least_damping_ratio"] - d.spec.cable.damping_ratio
                    if target <= 0:
                        out["damper_constant_N_s_m"] = 0.0
                        out["damper_note"] = "the cable's own damping suffices: no damper needed"
                    else:
                        dmp = d.spec.damper
                        c, why = dm.least_constant(dm.cable_of(d.spec), dmp.position_m, target, dm.eq21_mode(d.spec),
                                                   dmp.support_stiffness_N_m, corrected=True)
                        out["damper_constant_N_s_m"] = c
                        if why:
                            out["damper_note"] = why
    if damper is not None:
        out["damper_added_damping"] = damper["added_damping"]
    return out


def _derive_quiet(spec, notes: list):
    from autocable.model.derive import derive
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        d = derive(spec)
    for w in caught:
        text = " ".join(str(w.message).split())
        if text not in notes:
            notes.append(text)
    return d


def band_study(spec, uc_range: tuple[float, float] | None = None, design_wind_m_s: float | None = None,
               U_max_m_s: float | None = None, n_uc: int = UC_POINTS) -> dict:
    """The ``band`` object of `autocable onset --band` (module docstring): one case per onset speed of
    ``uc_range`` (m/s; default the model's U_c alone), angle reading, sign of the yaw and admissible
    calibration root; ``least_damping`` and ``onset_U_m_s`` as [lo, hi] with ``set_by`` naming the
    inputs of each end, ``damper_constant_N_s_m`` too with a ``[damper]``, and every case (a failed
    calibration with ``status`` "no calibration", any other refusal "failed", each with its ``reason``).
    ``U_max_m_s`` bounds every case's scan (default 5 U_c of the case)."""
    a = spec.aero
    lo, hi = uc_range if uc_range is not None else (a.critical_wind_speed_m_s, a.critical_wind_speed_m_s)
    calibrates = a.yaw_deg is None or a.rivulet_angle_deg is None
    notes, varied = [], []
    if not calibrates:
        # both angles given: the onset is a prediction and U_c only scales U* (eq. 18)
        ucs = [a.critical_wind_speed_m_s]
        notes.append("both wind angles are given: the onset is a prediction, independent of U_c (eq. 18 only "
                     "scales U*), so U_c is not varied")
    else:
        ucs = uc_values(lo, hi, n_uc)
        varied.append("critical_wind_speed_m_s")
    varied.append("angle_convention")
    if a.yaw_deg is not None:
        yaws = [abs(a.yaw_deg), -abs(a.yaw_deg)] if a.yaw_deg != 0 else [0.0]
        varied.append("the yaw's sign")
    else:
        yaws = [None]
        notes.append("the yaw is calibrated: its sign is one of the calibration's roots (every admissible root "
                     "is a case)")
    if calibrates:
        varied.append("the calibration root")
    cases = []
    for conv in READINGS:
        for yaw in yaws:
            for uc in ucs:
                aero = replace(a, angle_convention=conv, critical_wind_speed_m_s=uc,
                               **({} if yaw is None else {"yaw_deg": yaw}))
                s = replace(spec, aero=aero)
                try:
                    d = _derive_quiet(s, notes)
                except SpecError as exc:
                    # the calibration's own message (it names the fix), less the file's path
                    reason = str(exc).removeprefix(f"{exc.path}: ")
                    calibrating = getattr(exc, "calibration", False) or exc.field in ("aero.yaw_deg",
                                                                                     "aero.rivulet_angle_deg")
                    cases.append({"inputs": _inputs(aero, "fitted"), "label": case_label(_inputs(aero, "fitted")),
                                  "status": "no calibration" if calibrating else "failed", "reason": reason})
                    continue
                if not calibrates:
                    cases.append(_case(d, _inputs(aero, "given"), design_wind_m_s, U_max_m_s))
                    continue
                field = d.calibrated
                fitted = math.degrees(d.theta0 if field == "rivulet_angle_deg" else d.beta)
                cases.append(_case(d, _inputs(replace(aero, **{field: fitted}), "fitted (smallest |angle|)"),
                                   design_wind_m_s, U_max_m_s))
                for root, why in d.calibration_roots:
                    if why or abs(root - fitted) < 1e-9:
                        continue
                    other = replace(aero, **{field: float(root)})
                    dk = _derive_quiet(replace(spec, aero=other), notes)
                    cases.append(_case(dk, _inputs(other, "another admissible root"), design_wind_m_s, U_max_m_s))
    band = {"varied": varied, "critical_wind_speed_m_s": [lo, hi], "design_wind_m_s": design_wind_m_s,
            "cases": cases, "notes": notes}
    for key in ("onset_U_m_s", "least_damping", "damper_constant_N_s_m"):
        have = [c for c in cases if c.get(key) is not None]
        if key == "least_damping" and design_wind_m_s is None or key == "damper_constant_N_s_m" and (
                spec.damper is None or design_wind_m_s is None):
            continue
        if not have:
            band[key], band.setdefault("set_by", {})[key] = None, None
            continue
        low, high = min(have, key=lambda c: c[key]), max(have, key=lambda c: c[key])
        band[key] = [low[key], high[key]]
        # ties (the onset of every calibrated case at the same U_c) are counted, the first one named
        ties = {end: sum(abs(c[key] - v) <= 1e-9 * max(abs(v), 1e-300) for c in have) - 1
                for end, v in (("lo", low[key]), ("hi", high[key]))}
        band.setdefault("set_by", {})[key] = {"lo": dict(low["inputs"], label=low["label"], tied_with=ties["lo"]),
                                              "hi": dict(high["inputs"], label=high["label"], tied_with=ties["hi"])}
    band["failed"] = sum(c["status"] != "ok" for c in cases)
    # a case stable over its whole scan has no onset to enter the onset band: counted, not hidden
    band["stable_cases"] = sum(c["status"] == "ok" and c["onset_U_m_s"] is None for c in cases)
    return band


def band_text(band: dict) -> list[str]:
    """The readable lines of a `band_study`."""
    lines = [f"Band over what is not known ({', '.join(band['varied'])}): {len(band['cases'])} cases, "
             f"{band['failed']} without a result (no admissible calibration, or refused: the reason is listed)"]
    for n in band["notes"]:
        lines.append(f"  note: {n}")
    for key, name, fmt in (("onset_U_m_s", "onset", lambda x: f"{x:.4g} m/s"),
                           ("least_damping", f"least damping to {band['design_wind_m_s']} m/s",
                            lambda x: f"{100 * x:.4g} %"),
                           ("damper_constant_N_s_m", "least damper constant", lambda x: f"{x:.4g} N s/m")):
        if key not in band:
            continue
        if band[key] is None:
            lines.append(f"  {name}: no case gives one")
            continue
        by = band["set_by"][key]
        tie = {e: f" and {by[e]['tied_with']} more" if by[e]["tied_with"] else "" for e in ("lo", "hi")}
        lines.append(f"  {name}: [{fmt(band[key][0])}, {fmt(band[key][1])}]  (lo: {by['lo']['label']}{tie['lo']}; "
                     f"hi: {by['hi']['label']}{tie['hi']})")
        if key == "onset_U_m_s" and band["stable_cases"]:
            lines.append(f"    and {band['stable_cases']} cases stable up to their scanned range (no onset: not "
                         "in the band)")
    lines.extend(amplitude_text(band))
    lines.append("  case                                         onset [m/s]  least damping   damper [N s/m]")
    for c in band["cases"]:
        if c["status"] != "ok":
            lines.append(f"  {c['label']:<44} {c['reason']}")
            continue
        on = f"{c['onset_U_m_s']:11.4g}" if c["onset_U_m_s"] is not None else f"{'stable':>11}"
        xi = (f"{100 * c['least_damping']:11.4g} %" if c["least_damping"] is not None
              else f"{c.get('least_damping_note', '-'):>13}")
        dc = f"{c['damper_constant_N_s_m']:14.5g}" if c.get("damper_constant_N_s_m") is not None else ""
        lines.append(f"  {c['label']:<44} {on}  {xi}  {dc}".rstrip())
    return lines


# -- the galloping amplitude at the design wind over the band, with the curves' band and blend -----------
#: Calibrated combinations whose galloping is continued: the model as given and the two that set the
#: ends of the linear least damping band (fewer where they coincide). Each costs one compiled exact
#: load and five continuations (nominal curves and the four variants of `gallop --sensitivity`).
AMPLITUDE_COMBINATIONS = 3
#: The rung the amplitude band is computed on unless told: the exact quasi-steady load, on which the
#: curves' band and blend act (eq. (21) takes the curves only through their cubic expansion at phi0,
#: which a band holding phi0 leaves unchanged).
AMPLITUDE_LOAD = "exact"


def aero_of_case(spec, inputs: dict):
    """The ``[aero]`` of the `band_study` case with ``inputs``, written as `band_study` derived it: the
    reading, U_c and the yaw's sign replaced, a calibrated angle still calibrated for the smallest
    root, given (the root's value) for another admissible root. Derived, it is the case's equation."""
    a = spec.aero
    kw = {"angle_convention": inputs["angle_convention"],
          "critical_wind_speed_m_s": inputs["critical_wind_speed_m_s"]}
    if a.yaw_deg is not None:
        kw["yaw_deg"] = inputs["yaw_deg"]
    if inputs["root"] == "another admissible root":
        field = "rivulet_angle_deg" if a.rivulet_angle_deg is None else "yaw_deg"
        kw[field] = inputs[field]
    return replace(a, **kw)


def _amplitude_combinations(spec, band: dict) -> list[dict]:
    """The model as given, then the cases setting the low and high ends of the least damping band
    (those not already listed), at most `AMPLITUDE_COMBINATIONS`."""
    a = spec.aero
    given = {"critical_wind_speed_m_s": a.critical_wind_speed_m_s, "angle_convention": a.angle_convention,
             "yaw_deg": a.yaw_deg, "rivulet_angle_deg": a.rivulet_angle_deg,
             "root": "fitted (smallest |angle|)" if (a.yaw_deg is None or a.rivulet_angle_deg is None) else "given"}
    combos = [{"aero": a, "inputs": given, "label": "the model as given", "roles": ["the model as given"]}]
    by = (band.get("set_by") or {}).get("least_damping") or {}
    for end, role in (("lo", "sets the least damping's low end"), ("hi", "sets the least damping's high end")):
        if not by.get(end):
            continue
        inputs = {k: by[end][k] for k in ("critical_wind_speed_m_s", "angle_convention", "yaw_deg",
                                          "rivulet_angle_deg", "root")}
        aero = aero_of_case(spec, inputs)
        same = next((c for c in combos if c["aero"] == aero), None)
        if same is not None:
            same["roles"].append(role)
        elif len(combos) < AMPLITUDE_COMBINATIONS:
            combos.append({"aero": aero, "inputs": inputs, "label": by[end]["label"], "roles": [role]})
    return combos


def _amplitude_case(spec, combo: dict, design_wind_m_s: float, U_max_m_s: float | None, load: str,
                    notes: list, log, with_global: bool) -> dict:
    """One combination: `gallop_study` (with the curves' sensitivity) on its equation at ``load``,
    reduced to one row per curve variant (the nominal curves first)."""
    out = {"label": combo["label"], "roles": combo["roles"], "inputs": combo["inputs"], "load": load}
    if log:
        log(f"galloping at {design_wind_m_s:g} m/s on the {load} load: {combo['label']} "
            f"({'; '.join(combo['roles'])}), nominal curves and four variants ...")
    try:
        d = _derive_quiet(replace(spec, aero=replace(combo["aero"], load=load)), notes)
    except SpecError as exc:
        return dict(out, status="failed", reason=str(exc).removeprefix(f"{exc.path}: "))
    if combo["inputs"]["root"] != "given":
        # the calibrated angle as fitted (the given one kept as written)
        field = "yaw_deg" if combo["aero"].yaw_deg is None else "rivulet_angle_deg"
        out["inputs"] = dict(combo["inputs"], **{field: math.degrees(d.beta if field == "yaw_deg" else d.theta0)})
    if combo["label"] == "the model as given":
        out["label"] = f"{case_label(out['inputs'])} (as given)"
    # the curves' valid range is in absolute phi: where this combination's static angle sits in it
    # decides how far its cycles keep to the fits (a variant whose range no longer holds it is skipped)
    out["static_angle_deg"] = math.degrees(d.static_angle)
    units = units_of(d.spec, d.statics)
    # the case's own scan (5 U_c, or --max-wind), as the linear band's
    U_max = units.wind_m_s(U_MAX_DEFAULT) if U_max_m_s is None else min(U_max_m_s, units.wind_m_s(U_MAX_DEFAULT))
    if design_wind_m_s > U_max:
        return dict(out, status="failed", reason=f"the design wind {design_wind_m_s:g} m/s lies beyond this case's "
                                                 f"scanned range ({U_max:.4g} m/s = 5 U_c, or --max-wind)")
    shared = DampedSystem(d.ode)
    try:
        study = gallop_study(d, design_wind_m_s, U_max_m_s=U_max, checks=False, with_sensitivity=True,
                             log=log, shared=shared)
    except (SpecError, ComputationError) as exc:
        return dict(out, status="failed", reason=str(exc))
    sens = study["sensitivity"]
    design = study["cases"][0].get("design_cycle") or {}
    rows = [{"curves": "nominal", "amplitude_at_design_wind_m": study["amplitude_at_design_wind_m"],
             "envelope_at_design_wind_m": study.get("envelope_at_design_wind_m"),
             "other_stable_cycles": study.get("other_stable_cycles") or [],
             "beyond_valid_range": study["beyond_valid_range"], "phi_swept_deg": design.get("phi_swept_deg"),
             "design_verdict": study["design_verdict"],
             "valid_phi_deg": sens.get("nominal_valid_phi_deg"), "blend_deg": sens.get("nominal_blend_deg")}]
    for c in sens.get("cases", []):
        rows.append({"curves": c["case"], "amplitude_at_design_wind_m": c.get("amplitude_at_design_wind_m"),
                     "envelope_at_design_wind_m": c.get("envelope_at_design_wind_m"),
                     "other_stable_cycles": c.get("other_stable_cycles") or [],
                     "beyond_valid_range": c.get("beyond_valid_range"), "phi_swept_deg": c.get("phi_swept_deg"),
                     "design_verdict": c.get("design_verdict"), "valid_phi_deg": c.get("valid_phi_deg"),
                     "blend_deg": c.get("blend_deg"), **({"skipped": c["skipped"]} if "skipped" in c else {})})
    out.update(status="ok", variants=rows, sensitivity_range=sens.get("amplitude_at_design_wind_m", {}).get("range"),
               design_note=study["cases"][0].get("design_note"), seconds=study["seconds"])
    if with_global:
        if log:
            log(f"{combo['label']}: the global least damping ...")
        try:
            g = least_damping_global(d, design_wind_m_s, U_max, shared=shared)
        except (SpecError, ComputationError) as exc:
            out.update(least_damping_global=None, least_damping_global_note=str(exc))
        else:
            out.update(least_damping_global=g["least_damping_ratio_global"],
                       least_damping_global_beyond_valid_range=g["beyond_valid_range"],
                       least_damping_global_at_least=g["at_least"],
                       least_damping_global_seconds=g["seconds"])
    return out


def _validity_of_peak(row: dict, i: int) -> dict:
    """The validity (``beyond_valid_range``, ``phi_swept_deg``) of the cycle whose peak in plane
    ``i`` is the variant ``row``'s envelope there: the design cycle's, or (``another_cycle``) that of
    the other stable cycle at the design wind that reaches further in that plane."""
    env = row.get("envelope_at_design_wind_m") or row["amplitude_at_design_wind_m"]
    if env[i] == row["amplitude_at_design_wind_m"][i]:
        return {"beyond_valid_range": row["beyond_valid_range"], "phi_swept_deg": row["phi_swept_deg"],
                "another_cycle": False}
    o = next((o for o in row.get("other_stable_cycles") or [] if o["peak_m"][i] == env[i]), {})
    return {"beyond_valid_range": o.get("beyond_valid_range"), "phi_swept_deg": o.get("phi_swept_deg"),
            "another_cycle": True}


def amplitude_band(spec, band: dict, design_wind_m_s: float | None, U_max_m_s: float | None = None,
                   load: str = AMPLITUDE_LOAD, log=None, with_global: bool = False) -> dict:
    """The keys the galloping amplitude adds to a `band_study` result ``band`` (issue: "every amplitude
    reports its sensitivity to the band and blend"): ``amplitude_at_design_wind_m`` {"in_plane":
    [lo, hi], "out_of_plane": [lo, hi], "set_by", "cases", "load", "curves_varied"} over the
    combinations of `_amplitude_combinations` (the model as given and those setting the ends of the
    least damping band), each with its nominal curves and the four variants of `gallop --sensitivity`
    (`autocable.studies.gallop.sensitivity`: the valid range of phi narrowed and widened by
    `SENSITIVITY_BAND_DEG`, the blend's width times each of `SENSITIVITY_BLEND_FACTORS`). The peaks are,
    per plane, the largest of the stable galloping cycles found at the design wind (`gallop_study`'s
    ``envelope_at_design_wind_m``: the largest cycle's and any other's, on the branches or off
    them); each end names
    the combination and the curve variant that set it, with that cycle's validity (``beyond_valid_range``,
    ``phi_swept_deg``). With ``with_global``, ``least_damping_global`` [lo, hi] over the same
    combinations (nominal curves; `autocable.studies.gallop.least_damping_global`).

    Where the curves have no band or blend to vary (`sensitivity_undefined`), or without a design
    wind, ``amplitude_at_design_wind_m`` is None and ``amplitude_note`` says why in one line."""
    # it reads only the derivation's spec.aero: the model file's curves, no derivation needed to ask
    why = sensitivity_undefined(SimpleNamespace(spec=spec))
    if why:
        return {"amplitude_at_design_wind_m": None, "amplitude_note": "the curves are not varied: " + why}
    if design_wind_m_s is None:
        return {"amplitude_at_design_wind_m": None,
                "amplitude_note": "the galloping amplitude over the band needs a design wind (--design-wind)"}
    if load not in ("cubic", "exact"):
        raise SpecError("arguments", "--load", f"expected \"cubic\" or \"exact\", got {load!r}")
    notes, cases = [], []
    for combo in _amplitude_combinations(spec, band):
        cases.append(_amplitude_case(spec, combo, design_wind_m_s, U_max_m_s, load, notes, log, with_global))
    amp = {"load": load, "curves_varied": {"band_deg": SENSITIVITY_BAND_DEG,
                                           "blend_factors": list(SENSITIVITY_BLEND_FACTORS)},
           "in_plane": None, "out_of_plane": None, "set_by": None, "cases": cases}
    rows = [(c, r) for c in cases if c["status"] == "ok" for r in c["variants"]
            if r.get("amplitude_at_design_wind_m")]
    amp["with_a_stable_cycle"] = len(rows)
    amp["variants"] = sum(len(c.get("variants", [])) for c in cases)

    def peak(r):        # per plane, the largest of the stable cycles found at the design wind
        return r.get("envelope_at_design_wind_m") or r["amplitude_at_design_wind_m"]
    if rows:
        amp["set_by"] = {}
        for i, key in enumerate(("in_plane", "out_of_plane")):
            lo = min(rows, key=lambda cr: peak(cr[1])[i])
            hi = max(rows, key=lambda cr: peak(cr[1])[i])
            amp[key] = [peak(lo[1])[i], peak(hi[1])[i]]
            amp["set_by"][key] = {end: dict({"combination": c["label"], "inputs": c["inputs"], "curves": r["curves"],
                                             "peak_m": peak(r), "design_cycle_peak_m": r["amplitude_at_design_wind_m"]},
                                            **_validity_of_peak(r, i))
                                  for end, (c, r) in (("lo", lo), ("hi", hi))}
    if load == "cubic":
        amp["reading"] = ("eq. (21) takes the curves only through their cubic expansion at phi0, which the variants "
                          "leave unchanged: on the cubic load only the verdict moves (--load exact, the default, "
                          "shows how the band and the blend move the amplitude)")
    out = {"amplitude_at_design_wind_m": amp}
    if notes:
        out["amplitude_notes"] = notes
    if with_global:
        have = [c for c in cases if c.get("least_damping_global") is not None]
        out["least_damping_global"] = None
        if have:
            ends = {"lo": min(have, key=lambda c: c["least_damping_global"]),
                    "hi": max(have, key=lambda c: c["least_damping_global"])}
            out["least_damping_global"] = [ends["lo"]["least_damping_global"], ends["hi"]["least_damping_global"]]
            out["set_by"] = {"least_damping_global": {
                end: {"combination": c["label"], "inputs": c["inputs"], "curves": "nominal", "load": load,
                      "beyond_valid_range": c.get("least_damping_global_beyond_valid_range")}
                for end, c in ends.items()}}
    return out


def with_amplitude(band: dict, spec, design_wind_m_s: float | None, U_max_m_s: float | None = None,
                   load: str = AMPLITUDE_LOAD, log=None, with_global: bool = True) -> dict:
    """``band`` (a `band_study` result) with `amplitude_band`'s keys added, its ``set_by`` entry merged
    into the band's."""
    extra = amplitude_band(spec, band, design_wind_m_s, U_max_m_s, load, log, with_global)
    set_by = extra.pop("set_by", None)
    band.update(extra)
    if set_by:
        band.setdefault("set_by", {}).update(set_by)
    return band



def _peaks(row: dict) -> str:
    p = row.get("envelope_at_design_wind_m") or row["amplitude_at_design_wind_m"]
    if p:
        return f"{p[0]:.3g} / {p[1]:.3g} m"
    # gallop's verdict says what stands there instead ("unbounded": direct integration diverges)
    return f"no stable cycle ({row['design_verdict']})" if row.get("design_verdict") else "no stable cycle"


def amplitude_text(band: dict) -> list[str]:
    """The readable lines of `amplitude_band`'s keys in a band (none where it was not asked)."""
    if "amplitude_at_design_wind_m" not in band:
        return []
    amp = band["amplitude_at_design_wind_m"]
    if amp is None:
        return [f"  galloping amplitude: {band.get('amplitude_note', 'not computed')}"]
    cv = amp["curves_varied"]
    ok = [c for c in amp["cases"] if c["status"] == "ok"]
    lines = [f"  galloping amplitude at {band['design_wind_m_s']:g} m/s (per plane the largest over the stable cycles found, {amp['load']} load; "
             f"{len(amp['cases'])} combination(s) x the nominal curves, the valid range +-{cv['band_deg']:g} deg and "
             f"the blend x" + ", x".join(f"{f:g}" for f in cv["blend_factors"]) + f"; {amp['with_a_stable_cycle']} "
             f"of {amp['variants']} with a stable cycle):"]
    for key, name in (("in_plane", "in-plane"), ("out_of_plane", "out-of-plane")):
        if amp[key] is None:
            lines.append(f"    {name}: no variant has a stable cycle at the design wind")
            continue
        ends = []
        for end in ("lo", "hi"):
            b = amp["set_by"][key][end]
            valid = ("beyond the curves' valid range" if b["beyond_valid_range"]
                     else "inside the valid range" if b["beyond_valid_range"] is False else "validity not known")
            swept = f"phi swept {b['phi_swept_deg']:.3g} deg, " if b.get("phi_swept_deg") is not None else ""
            other = "another stable cycle than the largest, " if b.get("another_cycle") else ""
            ends.append(f"{end}: {b['combination']}, curves {b['curves']} ({other}{swept}{valid})")
        lines.append(f"    {name}: [{amp[key][0]:.4g} m, {amp[key][1]:.4g} m]  ({'; '.join(ends)})")
    if "least_damping_global" in band:
        g = band["least_damping_global"]
        text = "not found (each combination's least_damping_global_note says why)"
        if g is not None:
            by = band["set_by"]["least_damping_global"]
            flag = {e: " (its setting cycle beyond the curves' valid range)" if by[e]["beyond_valid_range"] else ""
                    for e in ("lo", "hi")}
            text = (f"[{100 * g[0]:.4g} %, {100 * g[1]:.4g} %]  (lo: {by['lo']['combination']}{flag['lo']}; "
                    f"hi: {by['hi']['combination']}{flag['hi']})")
            if any(c.get("least_damping_global_at_least") for c in amp["cases"]):
                text += ("; AT LEAST for the combinations where a stable cycle off the branches still gallops just "
                         "below the design wind at that damping (least_damping_global_at_least)")
        lines.append(f"  global least damping to {band['design_wind_m_s']:g} m/s (no galloping cycle up to it; "
                     f"{amp['load']} load, nominal curves): {text}")
    for c in amp["cases"]:
        if c["status"] != "ok":
            lines.append(f"    {c['label']}: {c['reason']}")
            continue
        parts = [f"{r['curves']} {r['skipped'] if 'skipped' in r else _peaks(r)}"
                 for r in c["variants"]]
        lines.append(f"    {c['label']} ({'; '.join(c['roles'])}; phi0 {c['static_angle_deg']:.1f} deg), "
                     "in-plane / out-of-plane: " + ", ".join(parts))
    if amp.get("reading"):
        lines.append(f"    note: {amp['reading']}")
    return lines
