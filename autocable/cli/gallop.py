"""`autocable gallop`: the galloping cycles of eq. (21) without support motion, continued in the wind
speed from each Hopf point of the rest state: the lowest wind speed at which galloping exists, the
hysteresis loop, the amplitude and frequency at a design wind (`autocable.studies.gallop`)."""
from __future__ import annotations

import argparse
import csv
import io
import math
import sys
from pathlib import Path

from autocable.cli.checks import check_number, check_out, dumps, refuse, strict
from autocable.cli.derivation import LOAD_HELP, PAIR_HELP, derivation

#: Damping ratios of one call at most: each is a continuation (about a second).
DAMPINGS_LIMIT = 10
#: The columns of branches.csv.
CSV_COLUMNS = ("damping_ratio", "hopf_U_m_s", "kind", "U_m_s", "U_star", "frequency_Hz", "period_star",
               "peak_in_plane_m", "peak_out_of_plane_m", "a1", "a2", "stable", "max_multiplier_modulus",
               "phi_swept_deg", "twist_max_deg", "beyond_valid_range")


def add_gallop_parser(sub) -> None:
    g = sub.add_parser("gallop", help="the galloping cycles of eq. (21) at eta = 0 continued in the wind speed from "
                                      "each Hopf point: the lowest galloping speed, the hysteresis loop, the amplitude "
                                      "and frequency at a design wind")
    g.add_argument("model", help="model spec file (models/*.toml)")
    g.add_argument("--design-wind", type=float, metavar="M_S",
                   help="the wind speed [m/s] at which to report the stable cycle's peak displacements and frequency")
    g.add_argument("--damping", metavar="XI[,XI...]",
                   help="damping ratios to continue the cycles for (default: the cable's own); the first is the one "
                        "of the top-level results and of the direct-integration check")
    g.add_argument("--max-wind", type=float, metavar="M_S",
                   help="follow the cycles up to this wind speed [m/s] (default and at most 5 U_c); Hopf points are "
                        "looked for up to 4 times it")
    g.add_argument("--pair", type=int, metavar="K", help=PAIR_HELP)
    g.add_argument("--load", choices=("cubic", "exact"), help=LOAD_HELP)
    g.add_argument("--sensitivity", action=argparse.BooleanOptionalAction, default=None,
                   help="recompute the amplitude at the design wind and the lowest galloping speed with the curves' "
                        "valid range narrowed and widened by 5 deg at each end and the blend halved and doubled "
                        "(default: on where the curves are blended to the dry cylinder; four more continuations)")
    g.add_argument("--json", action="store_true", help="one JSON object instead of the report")
    g.add_argument("--out", metavar="DIR", help="write gallop.json, branches.csv, gallop.png and gallop.pdf")
    g.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    g.set_defaults(func=cmd_gallop)


def _dampings(text: str | None):
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise refuse("--damping", f"expected damping ratios separated by commas (e.g. 0.001,0.005), "
                                  f"got {text!r}") from None
    if not vals or len(vals) > DAMPINGS_LIMIT:
        raise refuse("--damping", f"expected 1 to {DAMPINGS_LIMIT} damping ratios, got {len(vals)}")
    for v in vals:
        if not (math.isfinite(v) and 0 < v < 1):
            raise refuse("--damping", f"expected damping ratios 0 < XI < 1 (0.004 is 0.4 %), got {text!r}")
    return vals


def cmd_gallop(args) -> int:
    from autocable.model.onset import U_MAX_DEFAULT
    from autocable.model.units import units_of
    from autocable.studies.gallop import gallop_study

    check_out("--out", args.out)
    xis = _dampings(args.damping)
    d = derivation(args.model, args.pair, args.load)
    units = units_of(d.spec, d.statics)
    top = units.wind_m_s(U_MAX_DEFAULT)
    check_number("--max-wind", args.max_wind, 0.0, top, lo_open=True)
    U_max_m_s = top if args.max_wind is None else args.max_wind
    check_number("--design-wind", args.design_wind, 0.0, U_max_m_s, lo_open=True)
    log = None if args.quiet else (lambda s: print(f"autocable gallop: {s}", file=sys.stderr, flush=True))
    if args.out:
        from autocable.run_folder import output_folder
        with output_folder(args.out, "gallop", inputs=[args.model]) as stage:
            study = gallop_study(d, args.design_wind, xis, args.max_wind, log=log, with_sensitivity=args.sensitivity)
            _write(study, stage, d.spec.name)
    else:
        study = gallop_study(d, args.design_wind, xis, args.max_wind, log=log, with_sensitivity=args.sensitivity)
    if args.json:
        print(dumps(study, indent=1))
        return 0
    print("\n".join(gallop_text(study)))
    if args.out:
        print(f"wrote {args.out}/gallop.json, branches.csv, gallop.png, gallop.pdf", file=sys.stderr)
    return 0


def _m_s(x) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.5g} m/s"


def _from(lo, hp: dict) -> str:
    """The hysteresis loop's lower end: a number, or where it is not known the branch's bound."""
    if lo is not None:
        return f"{lo:.5g}"
    return f"{hp.get('lowest_U_reached_m_s', math.nan):.5g} or lower"


def gallop_text(study: dict) -> list[str]:
    """The readable report: one block per damping ratio and Hopf point."""
    lines = [f"Galloping cycles of eq. (21) at eta = 0 (no support motion), {study['model']}; wind from "
             f"{study['scanned_U_m_s'][0]:.3g} to {study['scanned_U_m_s'][1]:.4g} m/s; peak displacements at mid-span "
             "[in-plane, out-of-plane]"]
    design = study.get("design_wind_m_s")
    for case in study["cases"]:
        lines.append(f"damping {100 * case['damping_ratio']:.4g} % (Sc = {case['scruton']:.4g}):")
        if not case["hopf_points"]:
            lines.append(f"  {case.get('note', 'no branch of cycles')}")
        for hp in case["hopf_points"]:
            lines.append(f"  Hopf point at {hp['hopf_U_m_s']:.6g} m/s, {hp['hopf_frequency_Hz']:.5g} Hz: "
                         f"{hp['criticality']} ({hp['mechanism']})")
            low = hp["lowest_galloping_U_m_s"]
            lines.append("    lowest galloping speed   "
                         + (_m_s(low) if low is not None else f"not known: {hp.get('lowest_galloping_U_bound')}")
                         + (" (a fold of cycles)" if low is not None and any(abs(f["U_m_s"] - low) < 1e-9
                                                                             for f in hp["folds"]) else "")
                         + (" (every cycle of the branch unstable: the edge of the rest state's basin, no stable "
                            "galloping cycle)" if hp.get("stable_cycles") == 0 else ""))
            if hp.get("lowest_galloping_note"):
                lines.append(f"      ({hp['lowest_galloping_note']})")
            if hp["hysteresis_m_s"] and hp.get("stable_cycles") == 0:
                lo, hi = hp["hysteresis_m_s"]
                lines.append(f"    unstable cycles          {_from(lo, hp)} to {hi:.5g} m/s: a large enough gust "
                             "leaves the rest state, towards a motion this branch does not hold")
            elif hp["hysteresis_m_s"]:
                lo, hi = hp["hysteresis_m_s"]
                lines.append(f"    hysteresis loop          {_from(lo, hp)} to {hi:.5g} m/s: the rest state and a "
                             "large galloping cycle coexist (a large enough gust starts galloping)")
                if hp.get("hysteresis_note"):
                    lines.append(f"      note: {hp['hysteresis_note']}")
            for f in hp["folds"]:
                lines.append(f"    fold of cycles           {f['U_m_s']:.8g} m/s: peak [{f['peak_in_plane_m']:.4g}, "
                             f"{f['peak_out_of_plane_m']:.4g}] m, {f['frequency_Hz']:.5g} Hz")
            for c in hp["stability_changes"]:
                a, b = c["U_between_m_s"]
                lines.append(f"    stability {'gained' if c['gains_stability'] else 'lost':6s}        between "
                             f"{a:.6g} and {b:.6g} m/s, multiplier {c['kind']}")
            lines.append(f"    branch ended             {hp['end']} ({hp['points']} cycles, {hp['seconds']:.2g} s)")
        for hp in case.get("hopf_points_beyond_range", []):
            lines.append(f"  Hopf point at {hp['hopf_U_m_s']:.6g} m/s ({hp['criticality']}): its cycles stay above the "
                         f"range (lowest {hp['lowest_galloping_U_m_s']:.5g} m/s)")
        if design is not None:
            amp = case.get("amplitude_at_design_wind_m")
            if amp:
                dc = case.get("design_cycle", {})
                lines.append(f"  design wind {design:g} m/s: stable cycle, peak {amp[0]:.4g} m in-plane, "
                             f"{amp[1]:.4g} m "
                             f"out-of-plane, {case['frequency_at_design_wind_Hz']:.5g} Hz (largest multiplier "
                             f"{dc.get('max_multiplier_modulus', math.nan):.3g})")
                if "phi_swept_deg" in dc:
                    from autocable.model.validity import validity_line
                    lines.append(f"    {validity_line(dc)}")
                off = case.get("off_branch_cycle")
                probes = dc.get("larger_cycle_search") or []
                if off:
                    a = off["largest_on_branches_peak_m"]
                    lines.append(f"    OFF THE BRANCHES: the largest stable cycle of the branches from the Hopf points "
                                 f"is [{a[0]:.4g}, {a[1]:.4g}] m; this larger one was reached by integration from a "
                                 f"larger start and solved by Newton; it persists down to "
                                 + (f"{off['lowest_U_m_s']:.5g} m/s" if off["lowest_U_m_s"] is not None
                                    else "the lowest speed followed")
                                 + " (the case's lowest galloping speed takes it into account)")
                elif probes:
                    lines.append(f"    no larger stable cycle: integration from {len(probes)} larger starts "
                                 f"({probes[0]['start_peak_m']:.3g} to {probes[-1]['start_peak_m']:.3g} m in-plane) "
                                 "ends on " + ", ".join(p["landed"] if p["peak_m"] is None else
                                                        f"[{p['peak_m'][0]:.3g}, {p['peak_m'][1]:.3g}] m" for p in probes))
                for o in case.get("other_stable_cycles") or []:
                    lines.append(f"    another stable cycle     peak [{o['peak_m'][0]:.4g}, {o['peak_m'][1]:.4g}] m, "
                                 f"{o['frequency_Hz']:.5g} Hz, {'on a branch' if o['on_branch'] else 'off the branches'}"
                                 + (f", phi swept +-{o['phi_swept_deg']:.3g} deg"
                                    + (" (BEYOND the valid range)" if o.get("beyond_valid_range") else "")
                                    if o.get("phi_swept_deg") is not None else ""))
                env = case.get("envelope_at_design_wind_m")
                if env and env != amp:
                    lines.append(f"    envelope of the stable cycles at {design:g} m/s: {env[0]:.4g} m in-plane, "
                                 f"{env[1]:.4g} m out-of-plane (which one the stay takes depends on how it is started)")
            else:
                lines.append(f"  design wind {design:g} m/s: {case.get('design_note', 'no stable cycle found')}")
                run = case.get("design_integration")
                if run and run["bounded"]:
                    lines.append(f"    direct integration there (from {run['from']}, to t* = {run['t_end']:.5g}): "
                                 f"bounded, peak [{run['peak_m'][0]:.3g}, {run['peak_m'][1]:.3g}] m, "
                                 + ("periodic" if run["periodic"] else "steady" if run["steady"] else "not steady")
                                 + (f", {run['frequency_Hz']:.5g} Hz" if run.get("frequency_Hz") else ""))
                    if run.get("validity"):
                        from autocable.model.validity import validity_line
                        lines.append(f"      {validity_line(run['validity'])}")
                jc = case.get("judged_cycle")
                if jc and "phi_swept_deg" in jc and case.get("judged_on") != "direct integration":
                    from autocable.model.validity import validity_line
                    lines.append(f"    {jc['what']} ({jc['U_m_s']:.5g} m/s, peak [{jc['peak_m'][0]:.3g}, "
                                 f"{jc['peak_m'][1]:.3g}] m): {validity_line(jc)}")
            line = missing_line(case)
            if line:
                lines.append(f"    {line}")
    lines.extend(sensitivity_lines(study))
    for c in study.get("check", []):
        parts = []
        for name, text in (("from_cycle", "from the cycle"), ("from_large_start", "from a larger start")):
            r = c[name]
            if r["relative_difference"] is None:
                parts.append(f"{text} (x{r['start_factor']:.3g}): {r['message'].split(':')[0]}")
            else:
                parts.append(f"{text} (x{r['start_factor']:.3g}): {r['relative_difference']:.1e}")
        lines.append(f"check, eq. (21) integrated at {c['U_m_s']:.5g} m/s (relative amplitude difference to the "
                     f"continued cycle): " + "; ".join(parts))
    if study.get("cases") and any(hp.get("rows") and "phi_swept_deg" not in hp["rows"][-1]
                                  for case in study["cases"] for hp in case["hopf_points"]):
        lines.append("validity: not measured (autocable.model.validity not available)")
    return lines


def missing_line(case: dict) -> str:
    """One line: the ingredients the model lacks at the design wind (`studies.gallop.missing_ingredients`)."""
    miss = case.get("missing_ingredient") or []
    if miss:
        return "missing ingredient: " + "; ".join(f"{m['ingredient']} ({m['reason']})" for m in miss)
    if case.get("design_verdict") == "inside":
        return "missing ingredient: none (a bounded motion inside the valid range)"
    if case.get("design_verdict") in ("not known", "unbounded"):
        return "missing ingredient: none identified (the cycle judged lies inside the model's range)" \
            if case.get("judged_cycle") else ""
    return ""


def _span_text(nominal, rng, fmt: str, unit: str) -> str:
    if nominal is None and rng is None:
        return "none in any case"
    nom = "none" if nominal is None else f"{nominal:{fmt}} {unit}"
    return nom + ("" if rng is None else f" ({rng[0]:{fmt}} to {rng[1]:{fmt}})")


def sensitivity_lines(study: dict) -> list[str]:
    """The sensitivity to the curves' band and blend (`studies.gallop.sensitivity`), or why it is
    undefined, in one to a few lines."""
    s = study.get("sensitivity")
    if not s:
        return []
    if not s.get("defined") or s.get("computed") is False:
        return [f"sensitivity: {s['reason']}"]
    amp, low = s["amplitude_at_design_wind_m"], s["lowest_galloping_U_m_s"]
    lo, hi = s["nominal_valid_phi_deg"]
    lines = [f"sensitivity to the curves (valid {lo:.1f} to {hi:.1f} deg narrowed and widened by {s['band_deg']:g} deg "
             f"at each end, blend {s['nominal_blend_deg']:g} deg x" + ", x".join(f"{f:g}" for f in s["blend_factors"])
             + f"; damping {100 * s['damping_ratio']:.3g} %): nominal (range)"]
    low_text = _span_text(low['nominal'], low['range'], '.4g', 'm/s')
    if low["nominal"] is None and study.get("lowest_galloping_U_bound"):
        low_text = f"not known ({study['lowest_galloping_U_bound']})" + low_text.removeprefix("none")
    lines.append(f"  lowest galloping speed   {low_text}")
    if study.get("design_wind_m_s") is not None:
        nom = amp["nominal"] or [None, None]
        rng = amp["range"] or [None, None]
        lines.append(f"  at {study['design_wind_m_s']:g} m/s in-plane  {_span_text(nom[0], rng[0], '.3g', 'm')}; "
                     f"out-of-plane {_span_text(nom[1], rng[1], '.3g', 'm')} (a stable cycle in "
                     f"{amp['cases_with_a_stable_cycle']} of {amp['cases']} cases)")
    for c in s["cases"]:
        if "skipped" in c:
            lines.append(f"  {c['case']}: skipped, {c['skipped']}")
            continue
        a = c.get("amplitude_at_design_wind_m")
        where = f"[{a[0]:.3g}, {a[1]:.3g}] m" if a else (c.get("design_verdict") or "-")
        low_c = c.get("lowest_galloping_U_m_s")
        low_text = _m_s(low_c) if low_c is not None else (c.get("lowest_galloping_U_bound") or "-")
        lines.append(f"  {c['case']:24s} lowest {low_text}, design wind {where}"
                     + (f", missing: {', '.join(c['missing_ingredient'])}" if c.get("missing_ingredient") else ""))
    if s.get("reading"):
        lines.append(f"  ({s['reading']})")
    return lines


def _csv(study: dict) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(CSV_COLUMNS)
    for case in study["cases"]:
        for hp in case["hopf_points"]:
            for r in hp["rows"]:
                row = dict(r, damping_ratio=case["damping_ratio"], hopf_U_m_s=hp["hopf_U_m_s"])
                w.writerow(["" if row.get(c) is None or (isinstance(row.get(c), float) and not math.isfinite(row[c]))
                            else row[c] for c in CSV_COLUMNS])
    return buf.getvalue()


def _write(study: dict, stage: Path, name: str) -> None:
    from autocable._store import atomic_write_json, atomic_write_text
    from autocable.plotting.gallop import plot_gallop
    data = strict(study)
    atomic_write_json(stage / "gallop.json", data)
    atomic_write_text(stage / "branches.csv", _csv(data))
    plot_gallop(data, stage / "gallop", title=f"{name}: galloping cycles of eq. (21) (eta = 0)")
