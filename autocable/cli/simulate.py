"""`autocable simulate`: the steady response of eq. (21) (or of its amplitude equations, or of the
N-mode model, or by shooting) at one (U*, eta*, sigma)."""
from __future__ import annotations

import math
import re
import sys
from pathlib import Path

from autocable.cli.checks import (MAX_TIME_LIMIT, MODES_LIMIT, check_file_target, check_number, check_out,
                                  dumps, refuse, response_status, typed_number)
from autocable.cli.derivation import derivation
from autocable.model.premises import MAX_AMPLITUDE
from autocable.spec import SpecError

#: Rows of ``simulate --csv`` at most when neither --every nor --samples is given: the history is
#: thinned evenly (every k-th sample) to this many rows (about 5 MB; 64 samples per forcing period
#: over the default --max-time would be 620,000 rows, 50 MB). ``--every 1`` keeps every sample.
DEFAULT_CSV_SAMPLES = 50_000
#: A response that has not settled with U* within this of the galloping threshold U* = 1 gets the
#: hint to raise --max-time (growth and decay rates vanish at a threshold: transients are long).
NEAR_THRESHOLD = 0.1

def si_fields(d, out: dict) -> dict:
    """``out`` with its nondimensional U*, eta*, Omega and amplitudes also in SI (eqs. 17-18,
    `autocable.model.units`): U_m_s, eta_m, Omega_Hz and peak_m = [a1 l, a2 l] (in-plane,
    out-of-plane; null where the amplitude is not finite) at the station stated in peak_station."""
    from autocable.model.units import PEAK_STATION, units_of
    u = units_of(d.spec, d.statics)

    def peak(a):
        return u.peak_m(a) if a is not None and math.isfinite(a) else None

    out.update({"U_m_s": u.wind_m_s(out["U"]), "eta_m": u.support_m(out["eta"]),
                "Omega_Hz": u.frequency_hz(out["Omega"]), "peak_m": [peak(out["a1"]), peak(out["a2"])],
                "peak_station": PEAK_STATION})
    if d.mode_pair != 1:
        # pair k's modes peak off mid-span (sin(k pi s) at s = 1/(2k), ...): the peak is still a_k l
        out.update({"mode_pair": d.mode_pair, "omega1": d.ode.omega1, "omega2": d.ode.omega2,
                    "peak_station": f"each mode's maximum (mode pair {d.mode_pair}: not mid-span)"})
    if out.get("autonomous") and out.get("period"):
        # a self-excited cycle has its own frequency: 2 pi / period in units of omega (eq. 17)
        out["response_frequency_Hz"] = u.frequency_hz(2 * math.pi / out["period"])
    return out


def _si_line(out: dict) -> str:
    peaks = ", ".join("-" if p is None else f"{p:.4g} m" for p in out["peak_m"])
    return (f"SI: U = {out['U_m_s']:.4g} m/s, support amplitude {out['eta_m']:.4g} m, forcing "
            f"{out['Omega_Hz']:.5g} Hz; peak displacements (in-plane, out-of-plane) {peaks} at "
            + ("mid-span" if out.get("mode_pair", 1) == 1 else f"each mode's maximum (mode pair {out['mode_pair']})"))


#: The SI options of `simulate` (m/s, m, Hz): parameter -> (attribute, option). Each converts
#: through `autocable.model.units` (eqs. 17-18): U* = U/U_c, eta* = eta/l, sigma = 2 pi f/omega - omega1.
SI_OPTIONS = {"U": ("wind", "--wind"), "eta": ("deck_amplitude", "--deck-amplitude"),
              "sigma": ("deck_frequency", "--deck-frequency")}
_STAR_OPTIONS = {"U": "--U", "eta": "--eta", "sigma": "--sigma"}


def add_si_options(s) -> None:
    """The SI options of the `simulate` parser ``s`` beside --U/--eta/--sigma (whose default becomes
    "not given", 0 when neither kind is), and every numeric option keeping the text as typed."""
    s.add_argument("--wind", type=typed_number, metavar="M_S",
                   help="wind speed U [m/s], instead of --U (U* = U/U_c, eq. 18)")
    s.add_argument("--deck-amplitude", type=typed_number, metavar="M",
                   help="amplitude of the support (deck) motion eta [m] at the lower anchorage, instead of "
                        "--eta (eta* = eta/l, eq. 18)")
    s.add_argument("--deck-frequency", type=typed_number, metavar="HZ",
                   help="frequency of the support (deck) motion [Hz], instead of --sigma (sigma = "
                        "2 pi f/omega - omega1, eq. 17: the detuning from the first in-plane frequency)")
    for action in s._actions:
        if action.dest in ("U", "eta", "sigma", "max_time", "q0"):
            action.type = typed_number
    s.set_defaults(U=None, eta=None, sigma=None)
    # "-1e-3" is a number, not an option (argparse's own pattern misses the exponent): --q0 -1e-3 ...
    s._negative_number_matcher = re.compile(r"^-(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?$")


def _si_given(args) -> dict:
    """parameter -> (option, value) of the SI options given; one parameter given in both kinds is
    refused naming both options. Fills a parameter given in neither kind with 0."""
    from autocable.model.premises import NOT_GIVEN, choose_parameter
    given = {}
    for name, (attr, option) in SI_OPTIONS.items():
        star, si = (getattr(args, a, None) for a in (name, attr))       # argparse: None = not given
        kind = choose_parameter("arguments", name, NOT_GIVEN if star is None else star,
                                NOT_GIVEN if si is None else si, _STAR_OPTIONS[name], option)
        if kind is None:
            setattr(args, name, 0.0)
        elif kind[0] == "si":
            given[name] = (option, kind[1])
    return given


def _apply_si(args, d, given: dict) -> None:
    """Set args.U/eta/sigma from the SI options ``given`` on the derived cable ``d`` (refusing a
    value outside eq. (21)'s premises, named by its option), then warn where stretched."""
    from autocable.model.premises import STAR_NAMES, parameter_from_si
    from autocable.model.units import units_of
    u = units_of(d.spec, d.statics)
    for name, (option, value) in given.items():
        setattr(args, name, parameter_from_si("arguments", name, value, u, d.ode.omega1, option))
    _check_parameters(args, {name: f"{STAR_NAMES[name]} (from {option})" for name, (option, _) in given.items()})


def _check_parameters(args, labels: dict | None = None) -> None:
    """U*, eta*, sigma of `simulate` against the premises of eq. (21) (one line each; a stretched
    premise is a one-line warning on stderr). ``labels``: parameter -> the option it came from."""
    import warnings

    from autocable.model.premises import PremiseWarning, check_parameters
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PremiseWarning)
        check_parameters({"U": args.U, "eta": args.eta, "sigma": args.sigma}, "arguments",
                         {**_STAR_OPTIONS, **(labels or {})})
    for w in caught:
        if issubclass(w.category, PremiseWarning):
            print(f"autocable: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _check_simulate(args, si: dict | None = None) -> None:
    """Every numeric option of `simulate`, where it enters, before any work (the SI options ``si``
    once the cable is derived: `_apply_si`)."""
    if not si:
        _check_parameters(args)
    if args.q0:
        for name, v in zip(("Q1", "Q1DOT", "Q2", "Q2DOT"), args.q0):
            if not (math.isfinite(v) and abs(v) <= MAX_AMPLITUDE):
                raise refuse("--q0", f"{name}: expected a finite number with |{name}| <= {MAX_AMPLITUDE:g} "
                                      f"(beyond it the response has already diverged), got {v!r}")
    check_number("--max-time", args.max_time, 0.0, MAX_TIME_LIMIT, lo_open=True)
    check_number("--modes", args.modes, 1, MODES_LIMIT, integer=True)
    check_out("--csv", args.csv)
    if args.csv and Path(args.csv).is_dir():       # found before the integration, not after it
        raise refuse("--csv", f"{args.csv} is a folder; give a file name for the time history")
    check_file_target("--csv", args.csv)
    every, samples = getattr(args, "every", None), getattr(args, "samples", None)
    if every is not None and samples is not None:
        raise refuse("--every", "give --every N or --samples N, not both")
    if every is not None:
        check_number("--every", every, 1, 10**9, integer=True)
    if samples is not None:
        check_number("--samples", samples, 2, 10**9, integer=True)
    if (every is not None or samples is not None) and not args.csv:
        raise refuse("--every" if every is not None else "--samples", "thins the --csv time history; give --csv FILE")
    plot = getattr(args, "plot", None)
    check_out("--plot", plot)
    if plot and (args.method != "ode21" or getattr(args, "modes", None) is not None):
        raise refuse("--plot", "draws the time history of eq. (21) with two modes; use --method ode21 "
                               "without --modes")


def thin_rows(n: int, every: int | None = None, samples: int | None = None) -> range:
    """The indices of the rows of an n-sample history that ``simulate --csv`` writes: every
    ``every``-th sample, or every k-th with k the smallest that leaves at most ``samples`` rows
    (default `DEFAULT_CSV_SAMPLES`); the first sample is always kept."""
    if every is None:
        cap = DEFAULT_CSV_SAMPLES if samples is None else samples
        every = max(1, -(-n // cap))
    return range(0, n, every)


def settle_hint(r, U: float, max_time: float) -> str:
    """The hint printed when a response has not settled by ``max_time`` (empty if it settled or
    diverged): near the threshold U* = 1 the transients are long."""
    if r.steady or not all(math.isfinite(a) for a in (r.a1, r.a2)):
        return ""
    if getattr(r, "decay_rate", math.nan) > 0:
        # on its way to rest at a measured rate: the message says when it gets there
        return ""
    near = f" (U* = {U:g} is near the galloping threshold U* = 1, where transients are long)" \
        if abs(U - 1.0) <= NEAR_THRESHOLD else ""
    return (f"autocable: hint: the response has not settled by t* = {r.t_end:g}{near}; raise --max-time "
            f"(e.g. --max-time {min(4 * max_time, MAX_TIME_LIMIT):g}) for the steady state")


def cmd_simulate(args) -> int:
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator
    si = _si_given(args)
    _check_simulate(args, si)
    pair = getattr(args, "pair", None)
    if pair is not None and getattr(args, "modes", None) is not None:
        raise refuse("--pair", "--modes integrates the first N modes of each plane, every pair up to N; "
                               "drop --pair (or --modes)")
    from autocable.progress import progress_for
    d = derivation(args.model, pair, getattr(args, "load", None))
    if si:
        _apply_si(args, d, si)
    if d.ode.exact_load is not None and (args.method == "ame" or getattr(args, "modes", None) is not None):
        option = "--method" if args.method == "ame" else "--modes"
        raise refuse(option, "the amplitude equations (22)-(24) and the N-mode model carry eq. (21)'s cubic load; "
                             "with the exact load use --method ode21 or shooting (or --load cubic)")
    if d.mode_pair != 1 and getattr(args, "modes", None) is not None:
        raise refuse("--modes", f"integrates the first N modes of each plane; the model's cable.mode_pair = "
                                f"{d.mode_pair} asks for one pair: set mode_pair = 1 for --modes")
    if d.mode_pair != 1 and args.method == "ame":
        raise refuse("--method", f"the amplitude equations (22)-(24) are derived for the first mode pair only, "
                                 f"got pair {d.mode_pair}; use --method ode21 or shooting")
    period = 2 * math.pi / (d.ode.omega1 + args.sigma)
    if args.max_time < period:
        # a shorter run integrates nothing: no amplitude to report (and none is "diverged")
        raise refuse("--max-time", f"expected at least one forcing period, 2 pi/Omega = {period:.6g} at "
                                   f"sigma = {args.sigma:g}, got {args.max_time!r}")
    q0 = tuple(args.q0) if args.q0 else DEFAULT_Q0
    show = not (args.quiet or args.json)
    bar = progress_for("simulate", args.max_time, quiet=not show)

    def progress(t, amps):
        bar.update(t, f"t* = {t:.1f}  a1 = {amps[0]:.6e}  a2 = {amps[1]:.6e}")

    if getattr(args, "modes", None) is not None:
        return _simulate_nmode(args, d, q0, bar, progress)
    if args.method == "ame":
        return _simulate_ame(args, d, q0, bar, progress)
    if args.method == "shooting":
        return _simulate_shooting(args, d, q0)
    plot = getattr(args, "plot", None)
    # the exact load's curves (a table, a blend) are printed by autocable's own C code only
    integ = Ode21Integrator(d.ode, engine="compiled" if d.ode.exact_load is not None else "dopri")
    r = integ.simulate(args.U, args.eta, args.sigma, q0, max_time=args.max_time,
                       keep_history=bool(args.csv or plot), progress=progress)
    bar.close(f"t* = {r.t_end:.1f}: {r.message}")
    if args.csv:
        _write_history(Path(args.csv), r, getattr(args, "every", None), getattr(args, "samples", None))
    if plot:
        _plot_history(args, d, r)
    out = {"status": response_status(r.a1, r.steady, r.decay_rate),
           "a1": r.a1, "a2": r.a2, "steady": r.steady, "periodic": r.periodic, "t_end": r.t_end,
           "U": r.U, "eta": r.eta, "sigma": r.sigma, "Omega": r.Omega,
           "a1_min": r.a1_min, "a1_max": r.a1_max, "a2_min": r.a2_min, "a2_max": r.a2_max,
           "amplitude_convention": "a_k = half the peak-to-peak of q_k over the last 20 forcing "
                                   "periods (peak modal amplitude = peak displacement / l)",
           "message": r.message, "method": "ode21", "wall_seconds": r.wall_seconds}
    if r.autonomous:
        # eta* = 0: a self-excited cycle measured on its own period (ode21, "Autonomous responses")
        out.update(autonomous=True, period=r.period if math.isfinite(r.period) else None,
                   a1_error=r.a1_error, a2_error=r.a2_error,
                   amplitude_convention="a_k = half the peak-to-peak of q_k over each whole cycle of the "
                                        "response's own period (zero crossings), averaged over the last "
                                        "20 forcing periods; a_k_error = their scatter plus the sampling "
                                        "error (peak modal amplitude = peak displacement / l)")
    out = si_fields(d, out)
    period = r.period if r.autonomous and math.isfinite(r.period) else 2 * math.pi / r.Omega
    out.update(_validity(d, integ, out["status"], r.final_state, r.t_end, r.U, r.eta, r.Omega, period))
    _print_simulation(args, r, out)
    return 0


def _validity(d, integ, status, state, t0, U, eta, Omega, period) -> dict:
    """Where the steady response lies against the model's range (`autocable.model.validity`): the
    phi it sweeps, the largest twist and whether it left the curves' valid range or the cubic load's,
    measured on 20 periods of the response sampled 64 times a period from ``state`` at time ``t0``."""
    import numpy as np

    from autocable.model.symbolic import parameter_values
    from autocable.model.validity import motion_validity
    if status == "diverged" or not all(map(math.isfinite, state)) or not math.isfinite(period):
        why = ("the response diverged: it left every model's range" if status == "diverged"
               else "no steady response to measure")
        v = {"phi_swept_deg": None, "twist_max_deg": None, "beyond_valid_range": status == "diverged",
             "reasons": [why]}
        return {"phi_swept_deg": None, "twist_max_deg": None, "beyond_valid_range": v["beyond_valid_range"],
                "validity": v}
    run = integ.run_compiled(state, t0, t0 + 20 * period, period / 64, parameter_values(U, eta, Omega))
    t, y = run.t, run.y
    v = motion_validity(d, y, U, eta * Omega * np.cos(Omega * t))
    if v["beyond_valid_range"]:
        print(f"warning: the response lies beyond the model's range: {'; '.join(v['reasons'])}", file=sys.stderr)
    return {"phi_swept_deg": v["phi_swept_deg"], "twist_max_deg": v["twist_max_deg"],
            "beyond_valid_range": v["beyond_valid_range"], "validity": v}


def _simulate_shooting(args, d, q0) -> int:
    """`autocable simulate --method shooting`: the steady response of eq. (21) by Newton on the
    stroboscopic map, with its Floquet multipliers and class."""
    from autocable.methods.integration.shooting import ShootingSolver, response_json
    if args.csv:
        raise SpecError("--csv", "", "--method shooting computes no time history; use --method ode21 "
                        "for --csv")
    solver = ShootingSolver(d.ode)
    r = solver.steady(args.U, args.eta, args.sigma, q0, max_time=args.max_time)
    out = si_fields(d, {"status": response_status(r.a1, r.steady), **response_json(r)})
    # state0 is the orbit at forcing phase 0 (t = 0 modulo the forcing period)
    period = r.period if math.isfinite(r.period) else 2 * math.pi / r.Omega
    out.update(_validity(d, solver.integrator, out["status"], r.state0, 0.0, r.U, r.eta, r.Omega, period))
    if args.json:
        print(dumps(out, indent=1))
        return 0
    print(f"U* = {r.U:g}  eta* = {r.eta:g}  sigma = {r.sigma:g}  (Omega = {r.Omega:.6g})  method shooting")
    print(f"response: {r.response}   a1 = {r.a1:.9e}   a2 = {r.a2:.9e}   ({r.message})")
    if r.response == "period-2" or r.response == "quasi-periodic":
        print(f"envelope: a1 in [{r.a1_min:.6e}, {r.a1_max:.6e}], a2 in [{r.a2_min:.6e}, {r.a2_max:.6e}]")
    if len(r.multipliers):
        print("Floquet multipliers: " + "  ".join(f"{m.real:+.9f}{m.imag:+.9f}i" for m in r.multipliers)
              + f"   (max |mu| = {r.max_modulus:.9f})")
    print(f"transient {r.transient_periods} forcing periods, {r.newton_iterations} Newton steps, "
          f"{r.wall_seconds * 1e3:.1f} ms")
    print(_si_line(out))
    return 0


def _simulate_ame(args, d, q0, bar, progress) -> int:
    """`autocable simulate --method ame`: the Cartesian AME (24) from the same start as eq. (21)."""
    from autocable.methods.integration.ame import AmeIntegrator
    from autocable.model.ame_cache import derive_ame
    r = AmeIntegrator(derive_ame(d).ame).simulate(args.U, args.eta, args.sigma, q0,
                                                  max_time=args.max_time, keep_history=bool(args.csv),
                                                  progress=progress)
    bar.close(f"t* = {r.t_end:.1f}: {r.message}")
    if args.csv:
        from autocable._store import atomic_write_text
        # A diverged response keeps what was computed up to the divergence (possibly nothing).
        t, r1, s1, r2, s2 = r.history or ((),) * 5
        keep = thin_rows(len(t), getattr(args, "every", None), getattr(args, "samples", None))
        rows = ["t,r1,s1,r2,s2"] + [f"{t[i]:.10g},{r1[i]:.10e},{s1[i]:.10e},{r2[i]:.10e},{s2[i]:.10e}"
                                    for i in keep]
        atomic_write_text(Path(args.csv), "\n".join(rows) + "\n")
    eq = r.equilibrium

    def finite(x):
        return x if math.isfinite(x) else None

    out = {"status": response_status(r.a1, r.steady),
           "a1": finite(r.a1), "a2": finite(r.a2), "steady": r.steady, "periodic": r.periodic,
           "t_end": r.t_end, "U": r.U, "eta": r.eta, "sigma": r.sigma, "Omega": r.Omega,
           "a1_min": finite(r.a1_min), "a1_max": finite(r.a1_max),
           "a2_min": finite(r.a2_min), "a2_max": finite(r.a2_max),
           "amplitude_convention": "a_k = sqrt(r_k^2 + s_k^2) at the AME equilibrium (peak modal "
                                   "amplitude = peak displacement / l, first order); without an "
                                   "equilibrium, half the peak-to-peak of the first-order q_k over "
                                   "the last 20 forcing periods",
           "periodic_meaning": "the AME reached a stable equilibrium (period-1 motion of q)",
           "final_state": {"r1": r.final_state[0], "s1": r.final_state[1],
                           "r2": r.final_state[2], "s2": r.final_state[3]},
           "message": r.message, "method": "ame", "wall_seconds": r.wall_seconds}
    if eq is not None:
        out["equilibrium"] = {"stable": eq.stable, "residual": eq.residual,
                              "max_real_eigenvalue": eq.max_real,
                              "eigenvalues": [[e.real, e.imag] for e in eq.eigenvalues]}
    _print_simulation(args, r, si_fields(d, out))
    return 0


def _simulate_nmode(args, d, q0, bar, progress) -> int:
    """`autocable simulate --modes N`: eq. (21) with N in-plane and N out-of-plane modes."""
    from autocable.methods.integration.nmode import NModeIntegrator
    if args.method != "ode21":
        raise SpecError("--modes", "", "--modes integrates the N-mode equations directly; "
                        f"drop --method {args.method}")
    integ = NModeIntegrator(d, args.modes, args.modes)
    x0 = None
    if args.q0:
        # --q0 sets the first in-plane and out-of-plane modes, as for eq. (21); the others start at rest.
        ode, x = integ.ode, [0.0] * (2 * integ.ode.n)
        x[integ._i1], x[ode.n + integ._i1], x[integ._i2], x[ode.n + integ._i2] = q0
        x0 = tuple(x)
    r = integ.simulate(args.U, args.eta, args.sigma, x0, max_time=args.max_time,
                       keep_history=bool(args.csv), progress=progress)
    bar.close(f"t* = {r.t_end:.1f}: {r.message}")
    if args.csv:
        from autocable._store import atomic_write_text
        t, ys = r.history or ((), ())
        rows = [",".join(("t",) + integ.ode.state_names)]
        rows += [f"{t[i]:.10g}," + ",".join(f"{v:.10e}" for v in ys[i])
                 for i in thin_rows(len(t), getattr(args, "every", None), getattr(args, "samples", None))]
        atomic_write_text(Path(args.csv), "\n".join(rows) + "\n")

    def finite(x):
        return x if math.isfinite(x) else None

    out = {"status": response_status(r.a1, r.steady),
           "a1": finite(r.a1), "a2": finite(r.a2), "amplitudes": {k: finite(v) for k, v in r.amplitudes.items()},
           "omegas": dict(zip(integ.ode.names, integ.ode.omegas)), "steady": r.steady,
           "periodic": r.periodic, "diverged": r.diverged, "t_end": r.t_end, "U": r.U, "eta": r.eta,
           "sigma": r.sigma, "Omega": r.Omega,
           "amplitude_convention": "a_k = half the peak-to-peak of each modal coordinate over the last 20 "
                                   "forcing periods; a1 = first in-plane (v1), a2 = first out-of-plane (w1)",
           "message": r.message, "method": "nmode", "modes_per_plane": args.modes,
           "wall_seconds": r.wall_seconds}
    hint = settle_hint(r, args.U, args.max_time)
    if hint:
        print(hint, file=sys.stderr)
    si_fields(d, out)
    if args.json:
        print(dumps(out, indent=1))
    else:
        print(f"U* = {r.U:g}  eta* = {r.eta:g}  sigma = {r.sigma:g}  (Omega = {r.Omega:.6g})  "
              f"method nmode ({args.modes} in-plane + {args.modes} out-of-plane modes)")
        print(f"a1 = {r.a1:.9e}   a2 = {r.a2:.9e}   ({r.message}; "
              f"{'periodic' if r.periodic else 'not period-1'}; t_end = {r.t_end:.1f})")
        print("modal amplitudes: " + "  ".join(f"{k} = {v:.6e}" for k, v in r.amplitudes.items()))
        print(_si_line(out))
        if "validity" in out:
            from autocable.model.validity import validity_line
            print(validity_line(out["validity"]))
    return 0


def _print_simulation(args, r, out) -> None:
    hint = settle_hint(r, args.U, args.max_time)
    if hint:
        print(hint, file=sys.stderr)
    if args.json:
        print(dumps(out, indent=1))
    else:
        print(f"U* = {r.U:g}  eta* = {r.eta:g}  sigma = {r.sigma:g}  (Omega = {r.Omega:.6g})  "
              f"method {out['method']}")
        if out["status"] == "diverged":
            print(f"diverged: no bounded steady state ({r.message}; t_end = {r.t_end:.6g})")
            return
        print(_si_line(out))
        if "validity" in out:
            from autocable.model.validity import validity_line
            print(validity_line(out["validity"]))
        print(f"a1 = {r.a1:.9e}   a2 = {r.a2:.9e}   ({r.message}; "
              f"{'periodic' if r.periodic else 'not period-1'}; t_end = {r.t_end:.1f})")
        if not r.periodic:
            print(f"envelope: a1 in [{r.a1_min:.6e}, {r.a1_max:.6e}], a2 in [{r.a2_min:.6e}, {r.a2_max:.6e}]")
        if "equilibrium" in out:
            e = out["equilibrium"]
            print(f"AME equilibrium: {'stable' if e['stable'] else 'unstable'}, "
                  f"max Re(eigenvalue) = {e['max_real_eigenvalue']:.6e}, residual {e['residual']:.1e}")


def _write_history(path: Path, r, every: int | None = None, samples: int | None = None) -> None:
    """The time history as CSV, thinned by `thin_rows` (``--every``/``--samples``)."""
    from autocable._store import atomic_write_text
    rows = ["t,q1,q2,q1dot,q2dot"]
    # A diverged response keeps the rows up to the divergence (none when it diverged at once).
    t, q1, q2, v1, v2 = r.history or ((),) * 5
    rows += [f"{t[i]:.10g},{q1[i]:.10e},{q2[i]:.10e},{v1[i]:.10e},{v2[i]:.10e}"
             for i in thin_rows(len(t), every, samples)]
    atomic_write_text(path, "\n".join(rows) + "\n")


def _plot_history(args, d, r) -> None:
    """``--plot STEM``: q1, q2 against time with their envelope, the phase plane and the Poincare
    section (`autocable.plotting.diagrams.plot_simulation`), in STEM.png and STEM.pdf."""
    from autocable.plotting.diagrams import plot_simulation
    from autocable.scene.figure_units import figure_units
    if not r.history or len(r.history[0]) < 2:
        print("autocable: warning: --plot: no time history to draw (the response diverged at once)", file=sys.stderr)
        return
    from autocable.plotting.diagrams import save_figure
    response = "period-1" if r.periodic else ("not settled" if not r.steady else "not period-1")
    Omega, period_name = r.Omega, "forcing period"
    if getattr(r, "autonomous", False) and math.isfinite(getattr(r, "period", math.nan)) and r.period > 0:
        # eta* = 0: no forcing; the response's own cycle is the period that makes a section a point
        Omega, period_name, response = 2 * math.pi / r.period, "cycle's own period", "autonomous"
    fig = plot_simulation(r.history, Omega=Omega, response=response, period_name=period_name,
                          title=f"eq. (21) at U* = {r.U:g}, eta* = {r.eta:g}, sigma = {r.sigma:g}",
                          units=figure_units(getattr(args, "units", None) or "paper", d))
    files = save_figure(fig, args.plot)
    if not (args.quiet or args.json):
        print(f"plot: {', '.join(str(f) for f in files)}", file=sys.stderr)
