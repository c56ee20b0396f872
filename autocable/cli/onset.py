"""`autocable onset`: where the trivial state of eq. (21) loses stability under wind (m/s, Hz), how
(mechanism, criticality), how hard it gallops, and what damping keeps it stable
(`autocable.studies.onset`)."""
from __future__ import annotations

import contextlib
import csv
import io
import math
import sys
from pathlib import Path

from autocable.cli.checks import check_number, check_out, dumps, refuse, strict
from autocable.cli.derivation import LOAD_HELP, PAIR_HELP, derivation
from autocable.spec import SpecError

#: Points of a damping grid at most: each costs about 2 ms; more is a typing error.
DAMPING_POINTS_LIMIT = 10000
#: The highest ``--modes-below`` frequency [Hz]: far above any rain-wind mode (1-3 Hz); the pairs below
#: it are also capped by `autocable.spec.MODE_PAIR_MAX`.
MODES_BELOW_LIMIT_HZ = 1000.0


def add_onset_parser(sub) -> None:
    o = sub.add_parser("onset", help="where the cable's trivial state loses stability under wind (m/s, Hz), "
                                     "by which mechanism, super- or sub-critically, and what damping stops it")
    o.add_argument("model", help="model spec file (models/*.toml)")
    o.add_argument("--json", action="store_true", help="one JSON object instead of the report")
    o.add_argument("--max-wind", type=float, metavar="M_S",
                   help="scan the wind up to this speed in m/s (default and at most 5 U_c)")
    o.add_argument("--damping", metavar="A:B[:N]",
                   help="U_cr against the damping ratio from A to B (N points, default 50) and against the "
                        "Scruton number; with --out, also the post-critical amplitude for a few damping ratios")
    o.add_argument("--design-wind", type=float, metavar="M_S",
                   help="the least damping ratio keeping the trivial state stable up to this wind speed [m/s]")
    o.add_argument("--set", action="append", default=[], metavar="cable.FIELD=VALUE",
                   help="change a cable field for this study (damping_ratio, horizontal_tension_N, diameter_m, "
                        "mass_per_length_kg_m, length_m); a fitted wind angle is held unless --refit")
    o.add_argument("--refit", action="store_true",
                   help="with --set: fit the calibrated wind angle again (the onset then stays at U_c)")
    o.add_argument("--checks", type=int, default=2, metavar="N",
                   help="eq. (21) integrations per amplitude curve (default 2; 0: none)")
    o.add_argument("--out", metavar="DIR", help="write onset.json, damping.csv, amplitude.csv, onset.png/.pdf")
    o.add_argument("--pair", type=int, metavar="K", help=PAIR_HELP)
    o.add_argument("--load", choices=("cubic", "exact"), help=LOAD_HELP + "; the linear onset is the same on both "
                   "(eq. 21 is the exact load's cubic expansion), the galloping cycles are not")
    o.add_argument("--modes-below", type=float, metavar="HZ",
                   help="one row per mode pair k = 1, 2, ... below this frequency [Hz]: its frequencies, onset, "
                        "mechanism, criticality and (with --design-wind) its least damping (JSON key 'pairs')")
    o.add_argument("--band", action="store_true",
                   help="the onset and (with --design-wind) the least damping over what is not known: the onset "
                        "speed U_c (--uc), both frame-indifferent angle readings, the yaw's sign and every "
                        "admissible calibration root, each as a band [lo, hi] with the inputs setting each end "
                        "(JSON key 'band'; docs/band.md); with --design-wind and curves with a valid range and a "
                        "blend, also the galloping amplitude at the design wind over the band and the curves' "
                        "band and blend (on the exact load unless --load cubic)")
    o.add_argument("--uc", metavar="A:B", help="with --band: the range of onset speeds U_c in m/s (e.g. 7:13; "
                                               "default the model's U_c)")
    o.set_defaults(func=cmd_onset)


def _damping_grid(text: str):
    import numpy as np
    parts = text.split(":")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise refuse("--damping", f"expected A:B or A:B:N (damping ratios, e.g. 0.001:0.02:50), got {text!r}") from None
    if len(vals) not in (2, 3):
        raise refuse("--damping", f"expected A:B or A:B:N (damping ratios, e.g. 0.001:0.02:50), got {text!r}")
    a, b = vals[:2]
    n = vals[2] if len(vals) == 3 else 50
    # A = 0 is refused: without damping the trivial state is only marginally stable at rest, and
    # the onset (U -> 0+ for a negatively damping wind) cannot be told from none by the scan.
    if not (math.isfinite(a) and math.isfinite(b) and 0 < a < b < 1):
        raise refuse("--damping", f"expected damping ratios 0 < A < B < 1 (0.004 is 0.4 %), got {text!r}")
    # n is checked finite before int(n): int(nan) and int(inf) raise, not refuse
    if not math.isfinite(n) or n != int(n) or not 2 <= n <= DAMPING_POINTS_LIMIT:
        raise refuse("--damping", f"N: expected an integer from 2 to {DAMPING_POINTS_LIMIT}, got {parts[2]!r}")
    return np.linspace(a, b, int(n))


def _changes(items) -> dict:
    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        key = key.strip()
        if not sep or not key.startswith("cable."):
            raise refuse("--set", f"expected cable.FIELD=VALUE, got {item!r}")
        from autocable.studies.onset import VARIABLE_FIELDS
        if key[len("cable."):] not in VARIABLE_FIELDS:
            raise refuse("--set", f"cannot vary {key!r}; give one of "
                                  f"{', '.join('cable.' + f for f in VARIABLE_FIELDS)}")
        if key[len("cable."):] in out:
            # two values for one field: keeping the last silently hides a typing error
            raise refuse("--set", f"{key} given twice; give each field once")
        try:
            x = float(value)
        except ValueError:
            raise refuse("--set", f"{key}: expected a number, got {value!r}") from None
        if not math.isfinite(x) or x <= 0 or (key == "cable.damping_ratio" and x >= 1):
            raise refuse("--set", f"{key}: expected a positive number (a damping ratio below 1), got {value!r}")
        out[key[len("cable."):]] = x
    return out


def _csv(rows, columns) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(columns)
    for r in rows:
        w.writerow(["" if (isinstance(r.get(c), float) and not math.isfinite(r[c])) or r.get(c) is None
                    else r[c] for c in columns])
    return buf.getvalue()


#: The files `autocable onset --out` writes (with run.json, which lists those of the last run).
ONSET_FILES = ("onset.json", "damping.csv", "amplitude.csv", "onset.png", "onset.pdf", "band.png", "band.pdf")


@contextlib.contextmanager
def onset_folder(out: Path):
    """The output folder of ``onset --out``, safe to write: locked against a second onset for the
    whole run (an advisory ``flock`` on the folder itself, released by the kernel however the
    process ends), refused (one line naming ``--out``) if it holds files an earlier onset did not
    write (run.json lists those), temporaries of a killed onset removed (the lock proves their writer
    dead); then staged and published by `autocable.run_folder.output_folder` (run.json last). Yields
    the staging folder."""
    import fcntl
    import os

    from autocable._store import read_json
    from autocable.results import RUN_JSON
    from autocable.run_folder import is_leftover, output_folder, temporary_of
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd = os.open(out, os.O_RDONLY | os.O_DIRECTORY)
    except OSError as exc:
        raise refuse("--out", f"cannot use {out}: {exc.strerror or exc}; give a folder that can be written") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise refuse("--out", f"another autocable onset is writing into {out}; wait for it or give another "
                                  "folder") from None
        meta = read_json(out / RUN_JSON)
        ours = isinstance(meta, dict) and meta.get("name") == "onset" and isinstance(meta.get("files"), list)
        listed = {str(f) for f in meta["files"]} if ours else set()
        foreign, temporaries = [], []
        for entry in sorted(out.iterdir()):
            n = entry.name
            if temporary_of(n) in ONSET_FILES + (RUN_JSON,) and entry.is_file():
                temporaries.append(entry)       # a killed onset's half-written file: its writer is dead
            elif is_leftover(n) or (ours and (n == RUN_JSON or n in listed)):
                continue                        # output_folder's: a live run's staging folder is refused there
            else:
                foreign.append(n)
        if foreign:
            shown = ", ".join(foreign[:5]) + (f" and {len(foreign) - 5} more" if len(foreign) > 5 else "")
            raise refuse("--out", f"{out} holds files autocable onset did not write ({shown}); onset replaces only "
                                  "the files its earlier run listed in run.json: give an empty or new folder, or "
                                  "move them away")
        for entry in temporaries:
            entry.unlink(missing_ok=True)
        with output_folder(out, "onset") as staging:
            yield staging
    finally:
        os.close(fd)


def cmd_onset(args) -> int:
    # The folder is taken (locked, checked, staged) once the options and the model are read, before
    # the computation: a typing error leaves the folder and an earlier run's files as they were.
    with contextlib.ExitStack() as stack:
        def folder() -> Path | None:
            return stack.enter_context(onset_folder(Path(args.out))) if args.out else None
        return _onset(args, folder)


def _onset(args, folder) -> int:
    from autocable.model.onset import U_MAX_DEFAULT
    from autocable.model.units import units_of
    from autocable.studies.onset import damping_study, design_damping, onset_report, onset_text, vary

    check_out("--out", args.out)
    # checked before --band branches off: an option given is never silently ignored
    check_number("--checks", args.checks, 0, 20, integer=True)
    if getattr(args, "band", False):
        return _band(args, folder)
    if getattr(args, "uc", None) is not None:
        raise refuse("--uc", "sets the range of onset speeds of --band: add --band (a single onset speed is the "
                             "model's aero.critical_wind_speed_m_s)")
    check_number("--checks", args.checks, 0, 20, integer=True)
    # `is not None`: --damping= (empty) is refused, not taken for "not given"
    grid = _damping_grid(args.damping) if args.damping is not None else None
    changes = _changes(args.set)
    if args.refit and not changes:
        raise refuse("--refit", "refits the calibrated angle of a changed cable: give --set cable.FIELD=VALUE")
    below = getattr(args, "modes_below", None)
    pair = getattr(args, "pair", None)
    if below is not None:
        check_number("--modes-below", below, 0.0, MODES_BELOW_LIMIT_HZ, lo_open=True)
        for option, given in (("--pair", pair is not None), ("--damping", grid is not None), ("--out", args.out)):
            if given:
                raise refuse(option, "studies one mode pair; --modes-below tabulates every pair below a frequency: "
                                     f"drop {option} or --modes-below")
    try:
        d = derivation(args.model, pair, getattr(args, "load", None))
    except SpecError as exc:
        if exc.field == "aero.critical_wind_speed_m_s" and "got [" in str(exc):
            # a range of onset speeds is what --band reads: say so where one value is needed
            raise SpecError(args.model, exc.field, "one onset speed in m/s here; a range [lo, hi] is read by "
                                                   "`onset --band` (add --band, or give one value)") from None
        raise
    messages = []
    if changes:
        d, messages = vary(d, changes, refit=args.refit)
    if d.calibrated and (grid is not None or args.design_wind is not None):
        value = math.degrees(d.theta0 if d.calibrated == "rivulet_angle_deg" else d.beta)
        messages.append(f"the damping study holds aero.{d.calibrated} at its fitted {value:.4f} deg: only the "
                        "damping changes (--set cable.damping_ratio=X --refit fits the angle again for one value)")
    units = units_of(d.spec, d.statics)
    U_max = U_MAX_DEFAULT
    if args.max_wind is not None:
        check_number("--max-wind", args.max_wind, 0.0, units.wind_m_s(U_MAX_DEFAULT), lo_open=True)
        U_max = units.wind_star(args.max_wind)
    if args.design_wind is not None:
        check_number("--design-wind", args.design_wind, 0.0, units.wind_m_s(U_max), lo_open=True)
    if below is not None:
        return _pairs(args, d, below, U_max, messages)
    staging = folder()
    if grid is not None or args.out:
        xis = grid if grid is not None else [d.ode.xi_s]
        amp = sorted({d.ode.xi_s, float(xis[0]), float(xis[len(xis) // 2])}) if args.out else []
        if amp and d.ode.exact_load is not None:
            amp = []        # the AME (22)-(24) carry eq. (21)'s cubic load, not the exact one
            messages.append("no post-critical amplitude curves with the exact load: they come from the amplitude "
                            "equations (22)-(24) of the cubic eq. (21); `autocable gallop --load exact` continues "
                            "the exact rung's own cycles")
        if amp and d.mode_pair != 1:
            amp = []        # the galloping cycle comes from the AME (22)-(24): first pair only
            messages.append(f"no post-critical amplitude curves for mode pair {d.mode_pair}: they come from the "
                            "amplitude equations (22)-(24), derived for the first pair only")
        report = damping_study(d, xis, args.design_wind, amplitude_xis=amp, checks=args.checks, U_max=U_max)
    else:
        report = onset_report(d, U_max)
        if args.design_wind is not None:
            report["design"] = design_damping(d, args.design_wind, U_max)
    if "design" in report:
        report["design"].update(_global_damping(d, args.design_wind, units.wind_m_s(U_max)))
    report["study"] = messages
    premise = _premise_warnings(report, args, units)
    report["warnings"] = list(report["warnings"]) + premise
    for w in premise:
        print(f"warning: {w}", file=sys.stderr)
    if args.out:
        _write(report, staging, d.spec.name)
    if args.json:
        print(dumps(report, indent=1))
        return 0
    for m in messages:
        print(m)
    print("\n".join(onset_text(report)))
    for w in report["warnings"]:
        if w not in premise:        # (those went to stderr above)
            print(f"warning: {w}")
    if "design" in report:
        ds = report["design"]
        print(f"design wind {ds['design_wind_m_s']:g} m/s: least damping ratio {100 * ds['least_damping_ratio']:.4g} % "
              f"(Sc = {ds['scruton']:.4g}); the cable has {100 * ds['current_damping_ratio']:.4g} % "
              f"(Sc = {ds['current_scruton']:.4g}): {'enough' if ds['enough'] else 'not enough'}")
        if ds.get("least_damping_global") is not None:
            print(f"  global (no galloping cycle below the design wind, a sub-critical onset's fold included; "
                  f"autocable gallop): least damping ratio {'AT LEAST ' if ds.get('least_damping_global_at_least') else ''}"
                  f"{100 * ds['least_damping_global']:.4g} % "
                  f"(Sc = {ds['scruton_global']:.4g}): {'enough' if ds['enough_global'] else 'not enough'}")
            iso = ds.get("least_damping_global_isolated_cycle")
            if iso:
                print(f"    at that damping a stable cycle off the branches from the Hopf points still gallops at "
                      f"{iso['U_m_s']:.4g} m/s (peak {iso['peak_m'][0]:.3g} m in-plane, reached from a {iso['start_peak_m']:.3g} m "
                      "start): more damping is needed, how much is not computed")
            cyc = ds.get("least_damping_global_setting_cycle")
            if cyc and cyc.get("beyond_valid_range"):
                print(f"    beyond the model's range: the cycle that sets it ({cyc['U_m_s']:.4g} m/s, peak "
                      f"{cyc['peak_in_plane_m']:.3g} m in-plane) sweeps phi by +-{cyc['phi_swept_deg']:.3g} deg, "
                      f"twist up to {cyc['twist_max_deg']:.3g} deg ({'; '.join(cyc.get('reasons', []))}): not a bound "
                      "within validity; `autocable gallop --load exact` with curves bounded beyond their range "
                      "(aero.outside) says how large the stay gallops")
        else:
            print(f"  global least damping: not found ({ds.get('least_damping_global_note')})")
    if "damping" in report and grid is not None:
        print("damping ratio [%]   Sc        U_cr [m/s]   criticality")
        step = max(1, len(report["damping"]) // 10)
        for r in report["damping"][::step]:
            print(f"  {100 * r['damping_ratio']:8.4g}   {r['scruton']:8.4g}   {r['U_cr_m_s']:10.5g}   {r['criticality']}")
    for c in report.get("amplitude", []):
        for k in c["eq21_checks"]:
            head = f"eq. (21) check, xi = {100 * c['damping_ratio']:.3g} %, U = {k['U_m_s']:.4g} m/s: "
            ame = f"AME {units.peak_m(k['a1_ame']):.4g} m"
            if k["settled"]:
                print(head + f"peak {k['peak_in_plane_m_eq21']:.4g} m ({ame}, difference "
                             f"{100 * k['relative_difference_a1']:.2g} %)")
            else:
                print(head + f"{k['message']} ({ame})")
    for c in report.get("amplitude", []):
        for k in c.get("hysteresis_checks", []):
            print(f"eq. (21) below the sub-critical onset, xi = {100 * c['damping_ratio']:.3g} %, U = {k['U_m_s']:.4g} m/s: "
                  f"from 0.6 x the unstable cycle ({units.peak_m(k['a1_unstable_cycle']):.4g} m) it "
                  f"{_outcome(k['from_0.6'])}, from 1.5 x it {_outcome(k['from_1.5'])}"
                  + (" (hysteresis, as the onset's criticality says)" if k["hysteresis"] else ""))
    if args.out:
        print(f"wrote {args.out}/onset.json, damping.csv, amplitude.csv, onset.png, onset.pdf", file=sys.stderr)
    return 0


def _premise_warnings(report: dict, args, units) -> list[str]:
    """Where a wind speed of the study lies past the model's premises (`autocable.model.premises.
    wind_premises`: U* beyond where `simulate` warns, above 100 m/s, Mach > 0.3): the onsets, the
    options --max-wind and --design-wind, and the rows of damping.csv (column ``past_premises``)."""
    from autocable.model.premises import wind_premises, wind_warning
    out = []
    for o in report.get("onsets", []):
        out.append(wind_warning(f"the onset ({o['mechanism'].split(',')[0]}) at", o["U_m_s"], o["U_star"]))
    for option, value in (("--max-wind", args.max_wind), ("--design-wind", args.design_wind)):
        if value is not None:
            out.append(wind_warning(f"{option}:", value, units.wind_star(value)))
    rows = report.get("damping", [])
    past = []
    for r in rows:
        why = wind_premises(r["U_cr_m_s"], r["U_cr_star"])
        r["past_premises"] = "; ".join(why)
        if why:
            past.append(r)
    if past:
        out.append(f"damping.csv: {len(past)} of {len(rows)} rows have U_cr past the model's premises (from damping "
                   f"ratio {past[0]['damping_ratio']:.4g}, U_cr = {past[0]['U_cr_m_s']:.4g} m/s: "
                   f"{past[0]['past_premises']}); column past_premises says why for each")
    return [w for w in out if w]


def _uc_range(text: str | None, spec) -> tuple[float, float]:
    """``--uc A:B`` (or A) as (lo, hi) in m/s, each within the model file's bound on U_c."""
    if text is None:
        u = spec.aero.critical_wind_speed_m_s
        return u, u
    parts = text.split(":")
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise refuse("--uc", f"expected A:B (onset speeds in m/s, e.g. 7:13) or A, got {text!r}") from None
    if len(vals) not in (1, 2) or not all(math.isfinite(v) and 0 < v <= 100 for v in vals) or vals[0] > vals[-1]:
        raise refuse("--uc", f"expected A:B with 0 < A <= B <= 100 (onset speeds in m/s, e.g. 7:13), got {text!r}")
    return vals[0], vals[-1]


def _band(args, folder) -> int:
    """``onset --band``: `autocable.studies.band.band_study` on the model file, its JSON, text and plot."""
    from autocable.spec import load_model
    from autocable.studies.band import AMPLITUDE_LOAD, band_study, band_text, with_amplitude
    for option, given in (("--damping", args.damping is not None), ("--set", args.set), ("--refit", args.refit),
                          ("--pair", getattr(args, "pair", None) is not None),
                          ("--modes-below", getattr(args, "modes_below", None) is not None)):
        if given:
            raise refuse(option, f"studies one cable as written; --band varies what is not known about it: drop "
                                 f"{option} or --band")
    if getattr(args, "load", None) is not None and args.design_wind is None:
        # the load only chooses the equation of the galloping amplitude, which needs a design wind
        raise refuse("--load", "chooses the load of --band's galloping amplitude, computed at a design wind: add "
                               "--design-wind U, or drop --load (the linear band is the same on both loads)")
    spec, file_range = _band_model(args.model)
    uc = _uc_range(args.uc, spec) if args.uc is not None or file_range is None else file_range
    check_number("--max-wind", args.max_wind, 0.0, 500.0, lo_open=True)
    check_number("--design-wind", args.design_wind, 0.0, 500.0, lo_open=True)
    staging = folder()
    band = band_study(spec, uc, args.design_wind, args.max_wind)
    # the galloping amplitude over the band, with the curves' band and blend (seconds to a minute)
    log = (lambda s: print(f"autocable onset --band: {s}", file=sys.stderr, flush=True))
    with_amplitude(band, spec, args.design_wind, args.max_wind, getattr(args, "load", None) or AMPLITUDE_LOAD, log)
    report = {"model": spec.name, "band": band, "warnings": list(band["notes"])}
    premise = _band_premises(band, args, uc)
    report["warnings"] += premise
    for w in premise:
        print(f"warning: {w}", file=sys.stderr)
    if args.out:
        _write_band(report, staging, spec.name)
    if args.json:
        print(dumps(report, indent=1))
    else:
        print("\n".join(band_text(band)))
    if args.out:
        print(f"wrote {args.out}/onset.json, band.png, band.pdf", file=sys.stderr)
    return 0


def _band_model(path):
    """(spec, (lo, hi) or None): the model file of ``--band``, whose ``aero.critical_wind_speed_m_s``
    may be a range [lo, hi] in m/s (read as its lower end; every other command takes one value)."""
    from autocable.spec import SpecError, load_model, parse_model, read_toml
    data, _ = read_toml(path)
    aero = data.get("aero")
    value = aero.get("critical_wind_speed_m_s") if isinstance(aero, dict) else None
    if not isinstance(value, list):
        return load_model(path), None
    field = "aero.critical_wind_speed_m_s"
    if not (len(value) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool) for v in value)
            and all(math.isfinite(v) and 0 < v <= 100 for v in value) and value[0] <= value[1]):
        raise SpecError(path, field, f"a range of onset speeds (onset --band) is [lo, hi] in m/s with "
                                     f"0 < lo <= hi <= 100, e.g. [7, 13]; got {value!r}")
    data = {**data, "aero": {**aero, "critical_wind_speed_m_s": float(value[0])}}
    return parse_model(data, Path(path)), (float(value[0]), float(value[1]))


def _band_premises(band: dict, args, uc: tuple[float, float]) -> list[str]:
    """`_premise_warnings` for a band: every case's onset (key ``past_premises`` of the case), and
    --max-wind, --design-wind at the lowest U_c of the band (the largest U*)."""
    from autocable.model.premises import wind_premises, wind_warning
    out, past = [], []
    for c in band["cases"]:
        if c["status"] == "ok" and c["onset_U_m_s"] is not None:
            why = wind_premises(c["onset_U_m_s"], c["onset_U_m_s"] / c["inputs"]["critical_wind_speed_m_s"])
            c["past_premises"] = "; ".join(why)
            if why:
                past.append(c)
    if past:        # one line for all: the cases' key past_premises says why for each
        c = max(past, key=lambda c: c["onset_U_m_s"])
        out.append(f"the onsets of {len(past)} of {len(band['cases'])} cases lie past the model's premises (the "
                   f"highest, {c['label']}, at U = {c['onset_U_m_s']:.4g} m/s: {c['past_premises']}); each case's "
                   "past_premises says why")
    for option, value in (("--max-wind", args.max_wind), ("--design-wind", args.design_wind)):
        if value is not None:
            out.append(wind_warning(f"{option} (at U_c = {uc[0]:g} m/s):", value, value / uc[0]))
    return [w for w in out if w]


def _write_band(report: dict, out: Path, name: str) -> None:
    from autocable._store import atomic_write_json
    from autocable.plotting.band import plot_band
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "onset.json", strict(report))
    plot_band(strict(report)["band"], out / "band",
              title=f"{name}: onset, least damping (and galloping amplitude) over what is not known")


def _pairs(args, d, below: float, U_max: float, messages: list) -> int:
    """``onset --modes-below F``: the table of every mode pair below F (`studies.onset.pairs_below`)."""
    from autocable.studies.onset import pairs_text
    from autocable.studies.pairs_galloping import galloping_lines, pairs_with_galloping
    report = pairs_with_galloping(d, below, args.design_wind, U_max)
    report["study"] = messages
    # every pair's onset as an onset of `_premise_warnings` (the table has no 'onsets' of its own)
    from autocable.model.units import units_of
    onsets = [{"mechanism": f"mode pair {r['k']}, {r['mechanism_short']}", "U_m_s": r["onset_U_m_s"],
               "U_star": r["onset_U_star"]} for r in report["pairs"] if r.get("onset_U_m_s") is not None]
    premise = _premise_warnings({"onsets": onsets}, args, units_of(d.spec, d.statics))
    report["warnings"] = list(report.get("warnings", [])) + premise
    for w in premise:
        print(f"warning: {w}", file=sys.stderr)
    if args.json:
        print(dumps(report, indent=1))
        return 0
    for m in messages:
        print(m)
    lines = pairs_text(report)
    if args.design_wind is not None:
        lines = [x for x in lines if "not computed here" not in x] + galloping_lines(report)
    print("\n".join(lines))
    return 0


def _global_damping(d, design_wind_m_s: float, U_max_m_s: float) -> dict:
    """The keys `least_damping_global` adds to the ``design`` object: the least damping ratio for which
    no galloping cycle exists below the design wind (`autocable.studies.gallop.least_damping_global`),
    or None with the reason when it cannot be found (the linear least damping stands)."""
    from autocable.errors import ComputationError
    from autocable.spec import SpecError
    from autocable.studies.gallop import least_damping_global
    try:
        g = least_damping_global(d, design_wind_m_s, U_max_m_s)
    except (SpecError, ComputationError) as exc:
        return {"least_damping_global": None, "least_damping_global_note": str(exc)}
    return {"least_damping_global": g["least_damping_ratio_global"], "scruton_global": g["scruton_global"],
            "enough_global": g["enough"], "least_damping_global_tolerance": g["relative_tolerance"],
            "least_damping_global_reading": g["reading"],
            "least_damping_global_beyond_valid_range": g.get("beyond_valid_range"),
            "least_damping_global_setting_cycle": g.get("setting_cycle"),
            "least_damping_global_at_least": g["at_least"], "least_damping_global_isolated_cycle": g["isolated_cycle"]}


def _outcome(word: str) -> str:
    return "neither grows nor decays clearly (t* = 1e5)" if word == "undecided" else word


def _write(report: dict, out: Path, name: str) -> None:
    from autocable._store import atomic_write_json, atomic_write_text
    from autocable.plotting.onset import plot_onset
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_json(out / "onset.json", strict(report))
    atomic_write_text(out / "damping.csv", _csv(report.get("damping", []), [
        "damping_ratio", "scruton", "U_cr_m_s", "U_cr_star", "frequency_Hz", "criticality", "mechanism",
        "past_premises"]))
    rows = []
    for c in report.get("amplitude", []):
        for r in c["rows"]:
            rows.append({"damping_ratio": c["damping_ratio"], "scruton": c["scruton"], "source": "AME (natural ordering)",
                         **r})
        for k in c["eq21_checks"]:
            rows.append({"damping_ratio": c["damping_ratio"], "scruton": c["scruton"], "source": "eq. (21)",
                         "U_m_s": k["U_m_s"], "U_star": k["U_star"], "a1": k["a1_eq21"], "a2": k["a2_eq21"],
                         "peak_in_plane_m": k["peak_in_plane_m_eq21"],
                         "stable": k["settled"], "converged": k["settled"]})
    atomic_write_text(out / "amplitude.csv", _csv(rows, [
        "damping_ratio", "scruton", "source", "U_m_s", "U_star", "a1", "a2", "peak_in_plane_m",
        "peak_out_of_plane_m", "sigma", "stable", "converged"]))
    import warnings
    with warnings.catch_warnings():
        # an empty amplitude panel (a stable cable, a mode pair k > 1 without AME curves) has no legend
        warnings.filterwarnings("ignore", message="No artists with labels found")
        plot_onset(strict(report), out / "onset", title=f"{name}: onset of galloping and damping")
