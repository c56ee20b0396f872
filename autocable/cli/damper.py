"""`autocable damper`: from a damping ratio to a viscous damper near the lower anchorage: the added
damping of each mode up to a frequency (exact taut string, Krenk's asymptotic formula, corrected for
bending and sag), the optimal constant, and with ``--design-wind`` the least constant that keeps the
rest state of eq. (21) stable up to that wind (`autocable.model.damper`, docs/dampers.md)."""
from __future__ import annotations

import math
import sys
from pathlib import Path

from autocable.cli.checks import check_number, check_out, dumps, refuse, strict
from autocable.errors import ComputationError
from autocable.spec import show

#: Modes at most (each is a few milliseconds; more is a typing error in --max-frequency).
MODES_LIMIT = 100
#: The highest --max-frequency accepted [Hz]: far above any wind-excited mode of a stay.
MAX_FREQUENCY_LIMIT = 1000.0


def add_damper_parser(sub) -> None:
    p = sub.add_parser("damper", help="a viscous damper near the lower anchorage: the damping it adds to each "
                                      "mode, its optimal constant, the least constant for a design wind")
    p.add_argument("model", help="model spec file (models/*.toml); its [damper] table gives the defaults")
    p.add_argument("--position", type=float, metavar="M",
                   help="the damper's distance from the lower anchorage [m] (default: [damper] position_m)")
    p.add_argument("--constant", type=float, metavar="C",
                   help="the damper constant [N s/m] (default: [damper] constant_N_s_m)")
    p.add_argument("--max-frequency", type=float, default=None, metavar="HZ",
                   help="the modes of the taut string up to this frequency (default 3 Hz)")
    p.add_argument("--design-wind", type=float, metavar="M_S",
                   help="the least damper constant at the position that keeps the rest state of eq. (21) stable "
                        "up to this wind speed [m/s] (`autocable onset --design-wind`, less the cable's own "
                        "damping_ratio, for the mode eq. (21) models)")
    p.add_argument("--json", action="store_true", help="one JSON object instead of the report")
    p.add_argument("--out", metavar="DIR", help="write damper.json and the universal curve damper.png/.pdf")
    p.set_defaults(func=cmd_damper)


def _choice(args, spec):
    """(position, constant or None, support stiffness or None, source) from the options and the
    model's [damper] table."""
    table = spec.damper
    position = args.position if args.position is not None else (table.position_m if table else None)
    constant = args.constant if args.constant is not None else (table.constant_N_s_m if table else None)
    if position is None:
        raise refuse("--position", f"{args.model} has no [damper] table: give --position M (the damper's distance "
                                   "from the lower anchorage in m) or add [damper] position_m to the model")
    # each value given is checked before a missing one is asked for: the first refusal names what is wrong
    half = spec.cable.length_m / 2
    if not (math.isfinite(position) and 0 < position < half):
        raise refuse("--position", f"expected a distance from the lower anchorage above 0 and below half the "
                                   f"length ({half:g} m), got {show(position)}")
    if constant is not None and not (math.isfinite(constant) and constant > 0):
        raise refuse("--constant", f"expected a positive damper constant in N s/m, got {show(constant)}")
    if constant is None and args.design_wind is None:
        raise refuse("--constant", f"{args.model} has no [damper] constant_N_s_m: give --constant C (N s/m), or "
                                   "--design-wind U for the least constant that suffices")
    source = {"position": "--position" if args.position is not None else "[damper]",
              "constant": None if constant is None else ("--constant" if args.constant is not None else "[damper]")}
    return position, constant, table.support_stiffness_N_m if table else None, source


def damper_report(spec, position: float, constant: float | None, support, max_frequency: float,
                  design: dict | None = None, curves: bool = False) -> dict:
    """The JSON of `autocable damper` (``curves``: the universal curve of each mode, for the plot)."""
    from autocable.model import damper as dm
    cable = dm.cable_of(spec)
    ks = dm.modes_up_to(cable, max_frequency)
    if not ks:
        raise refuse("--max-frequency", f"{max_frequency:g} Hz is below the first mode's {cable.frequency_hz(1):.4g} Hz; "
                                        "give at least that")
    if len(ks) > MODES_LIMIT:
        raise refuse("--max-frequency", f"{max_frequency:g} Hz takes {len(ks)} modes, more than {MODES_LIMIT}; "
                                        "give a lower frequency")
    k_eq21 = dm.eq21_mode(spec)
    out = {
        "model": spec.name,
        "cable": {"tension_N": cable.tension_N, "mass_kg_m": cable.mass_kg_m, "length_m": cable.length_m,
                  "bending_stiffness_Nm2": cable.bending_stiffness_Nm2, "lambda2": cable.lambda2,
                  "impedance_N_s_m": cable.impedance, "fundamental_Hz": cable.frequency_hz(1),
                  "bending_length_m": (math.sqrt(cable.bending_stiffness_Nm2 / cable.tension_N)
                                       if cable.bending_stiffness_Nm2 > 0 else 0.0),
                  "damping_ratio": spec.cable.damping_ratio},
        "damper": {"position_m": position, "position_ratio": position / cable.length_m, "constant_N_s_m": constant,
                   "support_stiffness_N_m": support},
        "eq21_mode": k_eq21,
        "max_frequency_Hz": max_frequency,
    }
    design_constant = None
    if design is not None:
        design = dict(design)
        target = design["least_damping_ratio"] - spec.cable.damping_ratio
        design.update(mode=k_eq21, structural_damping=spec.cable.damping_ratio, target_added_damping=target,
                      least_constant_N_s_m=None, least_constant_taut_string_N_s_m=None, reason="")
        if target <= 0:
            design["reason"] = (f"the cable's own damping ({100 * spec.cable.damping_ratio:.4g} %) already keeps the "
                                f"rest state stable up to {design['design_wind_m_s']:g} m/s: no damper is needed")
        else:
            c_corr, why = dm.least_constant(cable, position, target, k_eq21, support, corrected=True)
            c_taut, _ = dm.least_constant(cable, position, target, k_eq21, support)
            design.update(least_constant_N_s_m=c_corr, least_constant_taut_string_N_s_m=c_taut, reason=why)
            design_constant = c_corr
        out["design"] = design
    if constant is None:
        # no constant given (only with --design-wind): the modes at the least constant, or at the
        # optimum of the design mode when no constant reaches the target
        constant = design_constant if design_constant is not None else \
            dm.optimum(cable, k_eq21, position, support, corrected=True)["optimal_constant_N_s_m"]
        out["damper"]["constant_N_s_m"] = constant
        out["damper"]["constant_from"] = ("the least constant for the design wind" if design_constant is not None
                                          else f"the optimum of mode {k_eq21} (no constant reaches the design target)")
    modes, notes = [], []
    for k in ks:
        try:
            modes.append(dm.mode_damping(cable, k, position, constant, support).as_dict())
        except ComputationError as exc:
            if k == ks[0]:
                raise
            # a damper far from the anchorage for the higher modes (k x_d / L near 1/2): said, not hidden
            which = f"mode {k} is" if k == ks[-1] else f"modes {k} to {ks[-1]} are"
            notes.append(f"{which} not reported: {str(exc).split(': ', 1)[-1]}")
            break
    if design is not None and design["target_added_damping"] > 0:
        md = next((m for m in modes if m["k"] == k_eq21), None)
        if md is None:
            md = dm.mode_damping(cable, k_eq21, position, constant, support).as_dict()
        design["added_damping_at_constant"] = md["added_damping_corrected"]
        # the least constant itself meets the target to Brent's tolerance, not to the last bit
        design["constant_enough"] = md["added_damping_corrected"] >= design["target_added_damping"] * (1 - 1e-9)
    out["modes"] = modes
    out["notes"] = notes
    out["conventions"] = {
        "added_damping": "exact taut string: the root of sin z + i eta sin(r z) sin((1-r) z) = 0 followed from "
                         "z = k pi (Krenk 2000), zeta = Im z / |z|",
        "added_damping_asymptotic": "Krenk's universal curve zeta / (x_d/L) = kappa / (1 + kappa^2), kappa = "
                                    "c k pi x_d / (L sqrt(T m)); a support spring multiplies the maximum by "
                                    "R_k = nu / (1 + nu), nu = k_s x_d / T",
        "added_damping_corrected": "the exact value times the ratio of the bending- and sag-corrected to the plain "
                                   "asymptotic formula (bending_factor R_f, sag_factor R_s on the maximum); the "
                                   "design value, what `autocable onset` adds for a model's [damper]",
        "frequency_Hz": "undamped taut string k / (2 L) sqrt(T/m); damped_frequency_Hz: Im s / (2 pi) with the damper",
        "residual": "|F(z)| of the frequency equation scaled to unit coefficients at the root",
    }
    if curves:
        out["curves"] = []
        for m in modes:
            k = m["k"]
            rows = dm.universal_curve(cable, k, position, support)
            out["curves"].append({"k": k, "rows": rows,
                                  "optimum": {"kappa": m["optimal_constant_N_s_m"] / cable.impedance * k * math.pi
                                              * position / cable.length_m,
                                              "zeta_over_r": m["max_added_damping"] * cable.length_m / position},
                                  "given": {"kappa": m["kappa"],
                                            "zeta_over_r": m["added_damping"] * cable.length_m / position}})
    return out


def report_lines(rep: dict) -> list[str]:
    c, dmp = rep["cable"], rep["damper"]
    support = ("rigid support" if dmp["support_stiffness_N_m"] is None
               else f"support stiffness {dmp['support_stiffness_N_m']:.4g} N/m")
    lines = [f"{rep['model']}: viscous damper at x_d = {dmp['position_m']:.4g} m (x_d/L = {dmp['position_ratio']:.4g}), "
             f"c = {dmp['constant_N_s_m']:.4g} N s/m, {support}"
             + (f" ({dmp['constant_from']})" if dmp.get("constant_from") else ""),
             f"  taut string: T = {c['tension_N']:.4g} N, m = {c['mass_kg_m']:.4g} kg/m, L = {c['length_m']:.4g} m, "
             f"sqrt(T m) = {c['impedance_N_s_m']:.5g} N s/m, f1 = {c['fundamental_Hz']:.4g} Hz; "
             f"bending length sqrt(EI/T) = {c['bending_length_m']:.3g} m, lambda^2 = {c['lambda2']:.3g}",
             "  k  f [Hz]  c_opt [N s/m]: exact  asympt.  corrected | max added [%]: exact asympt. corr. "
             "| at c [%]: exact asympt. corr.  kappa"]
    for m in rep["modes"]:
        lines.append(f"  {m['k']:<2d} {m['frequency_Hz']:6.4g}  {m['optimal_constant_N_s_m']:11.5g} "
                     f"{m['optimal_constant_asymptotic_N_s_m']:9.5g} {m['optimal_constant_corrected_N_s_m']:9.5g}"
                     f"  | {100 * m['max_added_damping']:6.4g} {100 * m['max_added_damping_asymptotic']:6.4g} "
                     f"{100 * m['max_added_damping_corrected']:6.4g} | {100 * m['added_damping']:6.4g} "
                     f"{100 * m['added_damping_asymptotic']:6.4g} {100 * m['added_damping_corrected']:6.4g} "
                     f"{m['kappa']:6.3g}")
    lines += [f"note: {n}" for n in rep.get("notes", [])]
    ds = rep.get("design")
    if ds:
        head = (f"design wind {ds['design_wind_m_s']:g} m/s: least damping ratio {100 * ds['least_damping_ratio']:.4g} % "
                f"(eq. 21), the cable has {100 * ds['structural_damping']:.4g} %")
        if ds["target_added_damping"] <= 0:
            lines.append(f"{head}: {ds['reason']}")
        elif ds["least_constant_N_s_m"] is None:
            lines.append(f"{head}; the damper must add {100 * ds['target_added_damping']:.4g} % to mode {ds['mode']}: "
                         f"{ds['reason']}")
        else:
            lines.append(f"{head}; the damper must add {100 * ds['target_added_damping']:.4g} % to mode {ds['mode']}: "
                         f"least constant {ds['least_constant_N_s_m']:.5g} N s/m at {rep['damper']['position_m']:.4g} m "
                         f"(taut string alone: {ds['least_constant_taut_string_N_s_m']:.5g} N s/m); the constant above "
                         f"adds {100 * ds['added_damping_at_constant']:.4g} %: "
                         f"{'enough' if ds['constant_enough'] else 'not enough'}")
    return lines


def cmd_damper(args) -> int:
    from autocable.spec import load_model
    check_out("--out", args.out)
    max_f = 3.0 if args.max_frequency is None else args.max_frequency
    check_number("--max-frequency", max_f, 0.0, MAX_FREQUENCY_LIMIT, lo_open=True)
    spec = load_model(args.model)
    position, constant, support, _ = _choice(args, spec)
    design = None
    if args.design_wind is not None:
        from autocable.cli.derivation import derivation
        from autocable.model.onset import U_MAX_DEFAULT
        from autocable.model.units import units_of
        from autocable.studies.onset import design_damping
        d = derivation(args.model)
        units = units_of(d.spec, d.statics)
        check_number("--design-wind", args.design_wind, 0.0, units.wind_m_s(U_MAX_DEFAULT), lo_open=True)
        ds = design_damping(d, args.design_wind, U_MAX_DEFAULT)
        design = {"design_wind_m_s": ds["design_wind_m_s"], "least_damping_ratio": ds["least_damping_ratio"],
                  "scruton": ds["scruton"]}
    rep = damper_report(spec, position, constant, support, max_f, design, curves=bool(args.out))
    if args.out:
        _write(rep, Path(args.out), spec.name)
    if args.json:
        shown = {k: v for k, v in rep.items() if k != "curves"}
        print(dumps(shown, indent=1))
    else:
        print("\n".join(report_lines(rep)))
    if args.out:
        print(f"wrote {args.out}/damper.json, damper.png, damper.pdf", file=sys.stderr)
    return 0


def _write(rep: dict, out: Path, name: str) -> None:
    from autocable._store import atomic_write_json
    from autocable.plotting.damper import plot_damper
    from autocable.run_folder import output_folder
    with output_folder(out, "damper") as stage:
        atomic_write_json(stage / "damper.json", strict(rep))
        plot_damper(strict(rep), stage / "damper", title=f"{name}: viscous damper at x_d = "
                                                          f"{rep['damper']['position_m']:.4g} m")
