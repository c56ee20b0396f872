"""The `autocable` command: derive, simulate, run, bench.

Errors a user can fix (a bad spec, a bad option, a failed build or run) are printed as one line
naming the file and field, with exit status 2; no traceback. ``AUTOCABLE_DEBUG=1`` shows tracebacks.
"""
from __future__ import annotations

import argparse
import json
import math
import os
import sys
from pathlib import Path

from autocable._paths import SAMPLE_MODEL
from autocable._version import __version__
from autocable.paper.figures import add_figures_parser
from autocable.scene.schema import ENGINES, RESOLUTIONS, load_scene
from autocable.errors import EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED, CacheError, ComputationError
from autocable.spec import SpecError, load_model


#: Accepted ranges of the numeric options that premises.check_parameters does not cover.
#: |q0| beyond `ode21.DIVERGED` (a tenth of the cable length) is already a diverged response.
Q0_LIMIT = 0.1
#: Time limit of `simulate` (t* units): the default 60000 reaches every steady state of the
#: sample cable; a million is about half an hour of integration.
MAX_TIME_LIMIT = 1e6
#: Modes per plane of `simulate --modes`: the symbolic N-mode derivation grows as N^4.
MODES_LIMIT = 6


def _refuse(option: str, message: str):
    """The one-line input error for a command-line option (exit 2)."""
    return SpecError("arguments", option, message)


def _check_number(option: str, value, lo: float, hi: float, *, integer: bool = False,
                  lo_open: bool = False) -> None:
    """Refuse a non-finite ``value`` or one outside [lo, hi] ((lo, hi] with ``lo_open``)."""
    kind = "an integer" if integer else "a number"
    span = f"{'(' if lo_open else '['}{lo:g}, {hi:g}]"
    if value is None:
        return
    if not math.isfinite(value) or not (lo < value if lo_open else lo <= value) or not value <= hi:
        raise _refuse(option, f"expected {kind} in {span}, got {value!r}")


def _check_out(option: str, value) -> None:
    """An output path given as "" would fall back to the default folder: refuse it."""
    if value is not None and not str(value).strip():
        raise _refuse(option, "an empty path; give a file or folder name (or leave the option out)")


def _check_parameters(args) -> None:
    """U*, eta*, sigma of `simulate` against the premises of eq. (21) (one line each; a stretched
    premise is a one-line warning on stderr)."""
    import warnings

    from autocable.model.premises import PremiseWarning, check_parameters
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", PremiseWarning)
        check_parameters({"U": args.U, "eta": args.eta, "sigma": args.sigma}, "arguments",
                         {"U": "--U", "eta": "--eta", "sigma": "--sigma"})
    for w in caught:
        if issubclass(w.category, PremiseWarning):
            print(f"autocable: warning: {w.message}", file=sys.stderr)
        else:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)


def _check_simulate(args) -> None:
    """Every numeric option of `simulate`, where it enters, before any work."""
    _check_parameters(args)
    if args.q0:
        for name, v in zip(("Q1", "Q1DOT", "Q2", "Q2DOT"), args.q0):
            if not (math.isfinite(v) and abs(v) <= Q0_LIMIT):
                raise _refuse("--q0", f"{name}: expected a finite number with |{name}| <= {Q0_LIMIT:g} "
                                      f"(beyond it the response has already diverged), got {v!r}")
    _check_number("--max-time", args.max_time, 0.0, MAX_TIME_LIMIT, lo_open=True)
    _check_number("--modes", args.modes, 1, MODES_LIMIT, integer=True)
    _check_out("--csv", args.csv)
    if args.csv and Path(args.csv).is_dir():       # found before the integration, not after it
        raise _refuse("--csv", f"{args.csv} is a folder; give a file name for the time history")


def _strict(x):
    """``x`` with every non-finite float replaced by None (strict JSON: no NaN, no Infinity)."""
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _strict(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_strict(v) for v in x]
    try:                                 # numpy scalars
        import numpy as np
        if isinstance(x, np.floating):
            return _strict(float(x))
        if isinstance(x, np.integer):
            return int(x)
        if isinstance(x, np.ndarray):
            return _strict(x.tolist())
    except ImportError:                  # pragma: no cover
        pass
    return x


def dumps(obj, **kw) -> str:
    """The JSON the command line prints or writes: strict (a non-finite number is null; a
    ``status`` beside it says why), so any JSON parser reads it."""
    return json.dumps(_strict(obj), allow_nan=False, **kw)


def response_status(a1: float, steady: bool) -> str:
    """The ``status`` of a simulated response: "diverged" (growth past the model's range; the
    amplitudes are null), "steady", or "not_steady" (``--max-time`` reached first)."""
    if not math.isfinite(a1):
        return "diverged"
    return "steady" if steady else "not_steady"


def _derivation(path):
    from autocable.model.derive import derive
    return derive(path)


def _fmt(x: float) -> str:
    return f"{x: .6e}"


def derive_report(d) -> str:
    """The readable report of `autocable derive` (eq. 21 and what it rests on)."""
    st, ode, spec = d.statics, d.ode, d.spec
    lines = [
        f"model {spec.name} ({spec.path})",
        "",
        "Statics (Sect. 2.1, nearly taut) and nondimensional groups (eq. 17):",
        f"  T-bar = {st.T_bar:.6g} N   kappa-bar = {st.kappa_bar:.6g} 1/m   alpha = {math.degrees(st.alpha):.4g} deg",
        f"  delta = kappa*l = {st.delta:.6g}   tau = T/EA = {st.tau:.6g}   chi = GJ/EI = {st.chi:.6g}",
        f"  Irvine lambda^2 = {st.lambda2:.6g}   m* = pi^2 tau = {st.m_star:.6g}",
        f"  reference frequency omega = (pi/l) sqrt(T/m) = {st.omega_ref:.6g} rad/s ({st.frequency_hz:.4g} Hz)",
        f"  quasi-static shape (eqs. 15-16, corrected C2): vhat(s) = {st.C1:.6g} s^2 + {st.C2:.6g} s",
        "",
        "Modes (eqs. 19-20, unit maximum):",
        f"  omega1 = {ode.omega1:.9f} (in-plane, Irvine)   omega2 = {ode.omega2:.9f} (out-of-plane)",
        f"  internal detuning rho = omega2 - omega1 = {ode.omega2 - ode.omega1:.6g}",
        f"  slaved twist theta2 = {d.twist[0]:.6g} sin(pi s) + {d.twist[1]:.6g} cosh({d.twist[2]:.6g} (s - 1/2))",
        "",
        "Wind (Sect. 2.3):",
        f"  U_c = {d.critical_wind_speed_m_s:g} m/s   yaw beta = {math.degrees(d.beta):.6f} deg   "
        f"rivulet Theta0 = {math.degrees(d.theta0):.6f} deg"
        + (f"   ({d.calibrated} calibrated)" if d.calibrated else ""),
        f"  angle convention (eq. 12): {d.spec.aero.angle_convention}   static angle phi0 = "
        f"{math.degrees(d.static_angle):.6f} deg",
        *(["  calibration roots [deg]: " + ", ".join(
            f"{r:.6f}" + (f" (rejected: {why})" if why else "") for r, why in d.calibration_roots)
           + "; kept the smallest valid |angle|"] if d.calibration_roots else []),
        f"  load scale K = {d.aero_scale:.6g}   velocity ratio nu = omega l / U_c = {d.velocity_ratio:.6g}",
        "",
        "Eq. (21): q_k'' + sum(coefficient * term) = 0; Appendix A names, forcing terms in the",
        "paper's sign (right-hand side). Unnamed terms are not listed in eq. (21) as printed.",
    ]
    for k in (1, 2):
        lines.append(f"  equation {k}:")
        for t in sorted(ode.equation(k), key=lambda t: (sum(t.powers), t.powers, t.forcing, t.u_power)):
            from autocable.model.equations import monomial_name
            mono = monomial_name(t.powers, t.forcing, t.u_power)
            name = t.name or {"linear": f"omega{k}^2", "damping": f"2 xi_s omega{k}"}.get(
                t.origin, "(not in eq. 21)")
            rhs = " [rhs]" if t.is_forcing else ""
            lines.append(f"    {name:<16} {_fmt(t.appendix_value)}  {mono}{rhs}  ({t.origin})")
    for w in d.warnings:
        lines.append(f"warning: {w}")
    src = "cache" if d.from_cache else "computed"
    lines.append(f"({src}; {', '.join(f'{k} {v:.3g}' for k, v in d.timings.items())})")
    return "\n".join(lines)


def derive_json(d) -> dict:
    st, ode = d.statics, d.ode
    return {
        "model": d.spec.name, "model_hash": d.spec.content_hash(),
        "reference_frequency_rad_s": st.omega_ref, "omega1": ode.omega1, "omega2": ode.omega2,
        "lambda2": st.lambda2, "delta": st.delta, "tau": st.tau, "chi": st.chi,
        "kappa_bar_1_m": st.kappa_bar, "T_bar_N": st.T_bar, "m_star": st.m_star,
        "vhat": {"C1": st.C1, "C2": st.C2},
        "critical_wind_speed_m_s": d.critical_wind_speed_m_s,
        "yaw_deg": math.degrees(d.beta), "rivulet_angle_deg": math.degrees(d.theta0),
        "calibrated": d.calibrated, "static_angle_deg": math.degrees(d.static_angle),
        "angle_convention": d.spec.aero.angle_convention,
        "calibration_roots_deg": [{"angle": r, "rejected": why} for r, why in d.calibration_roots],
        "xi_s": ode.xi_s,
        "coefficients": ode.coefficients(),
        "terms": [{"equation": t.equation, "name": t.label, "powers": list(t.powers),
                   "forcing": list(t.forcing), "U_power": t.u_power, "origin": t.origin,
                   "coefficient_lhs": t.coefficient} for t in ode.terms],
        "conventions": {
            "equation": "q_k'' + sum(coefficient_lhs * U^U_power * (eta f)^a (eta f')^b (eta f'')^c "
                        "* q1^i q2^j q1'^k q2'^l) = 0, f = sin(Omega t), t* = omega t",
            "coefficients": "Appendix A names; forcing terms (Gamma_1,23, Gamma_2,22) with the "
                            "paper's right-hand-side sign; unnamed terms keyed 'eq<k>:<monomial>'",
        },
        "warnings": list(d.warnings),
    }


AME_CONVENTION = ("a_k = sqrt(r_k^2 + s_k^2) is the peak modal amplitude (peak displacement / l); "
                  "q_k = r_k cos(Omega t) - s_k sin(Omega t) + O(eps^2), A_k = (r_k + i s_k)/2")


def ame_json(cached) -> dict:
    """The Cartesian AME (24) as a plain coefficient table (`autocable derive --json`, key "ame")."""
    ame = cached.ame
    return {
        "form": "Cartesian AME (24): d y_i/dt = sum over rows of equation i of coefficient "
                "* prod_j y_j^state_j * prod_m p_m^params_m; rows with aero=true exist only for U != 0",
        "state": list(ame.cartesian_state_names), "params": list(ame.param_names),
        "detunings": "sigma_1 = -sigma, sigma_2 = rho - sigma (rho = omega2 - omega1), "
                     "Omega = omega1 + sigma (exact, not expanded)",
        "amplitude_convention": AME_CONVENTION,
        "omega": ame.omega_mode,
        "rows": [{"equation": ame.cartesian_state_names[r.equation], "state": list(r.state),
                  "params": list(r.params), "coefficient": float(r.coefficient), "aero": bool(r.aero)}
                 for r in ame.cartesian_rows],
        "ordering_name": ame.provenance.get("ordering", "paper"),
        "ordering": ame.ordering.as_dict(),
        "checks": ame.checks,
        "cache_key": cached.key,
    }


def _monomial(names, exps) -> str:
    return "*".join(n if e == 1 else f"{n}^{e}" for n, e in zip(names, exps) if e)


def ame_report(cached, latex: bool = False) -> str:
    """Eq. (22) in readable form: dA_k/dt as a sum of complex coefficient * monomial rows."""
    ame = cached.ame
    name = ame.provenance.get("ordering", "paper")
    rules = "R1-R3" if name == "paper" else "R2-R3 for every term, aerodynamic ones too"
    lines = ["", f"Amplitude equations (22) by Multiple Scales (Sect. 4; {name!r} ordering, {rules} of "
             "autocable.model.multiscale, Omega exact):",
             f"  convention: {AME_CONVENTION}",
             "  detunings: sigma_1 = -sigma, sigma_2 = rho - sigma, Omega = omega1 + sigma; "
             "[aero] rows only when U != 0"]
    if latex:
        import sympy as sp
        for k, F in enumerate(ame.complex_expressions(), start=1):
            lines.append(f"  \\dot A_{k} = {sp.latex(F)}")
    else:
        names = ame.complex_state_names
        for k in range(ame.n_modes):
            lines.append(f"  dA_{k + 1}/dt =")
            for r in (r for r in ame.complex_rows if r.equation == k):
                re, im = (float(x) + 0.0 for x in r.coefficient)   # no "-0" in the report
                mono = _monomial(names, r.state) or "1"
                par = _monomial(ame.param_names, r.params)
                lines.append(f"    ({re: .6e} {im:+.6e} i) {mono}" + (f" * {par}" if par else "")
                             + ("  [aero]" if r.aero else ""))
    src = "cache" if cached.from_cache else "derived"
    lines.append(f"  ({len(ame.complex_rows)} complex rows, {len(ame.cartesian_rows)} Cartesian rows "
                 f"in `autocable derive --json`; {src} in {cached.seconds:.3g} s)")
    return "\n".join(lines)


def cmd_derive(args) -> int:
    from autocable.model.ame_cache import derive_ame
    d = _derivation(args.model)
    cached = derive_ame(d, ordering=args.ordering)
    if args.json:
        out = derive_json(d)
        out["ame"] = ame_json(cached)
        print(dumps(out, indent=1))
    else:
        print(derive_report(d))
        print(ame_report(cached, latex=args.latex))
    return 0


def cmd_simulate(args) -> int:
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator
    _check_simulate(args)
    d = _derivation(args.model)
    q0 = tuple(args.q0) if args.q0 else DEFAULT_Q0
    show = not (args.quiet or args.json)

    def progress(t, amps):
        if show:
            print(f"\r  t = {t:9.1f}   a1 = {amps[0]:.6e}   a2 = {amps[1]:.6e}", end="", file=sys.stderr)

    if getattr(args, "modes", None) is not None:
        return _simulate_nmode(args, d, q0, show, progress)
    if args.method == "ame":
        return _simulate_ame(args, d, q0, show, progress)
    if args.method == "shooting":
        return _simulate_shooting(args, d, q0)
    integ = Ode21Integrator(d.ode)
    r = integ.simulate(args.U, args.eta, args.sigma, q0, max_time=args.max_time,
                       keep_history=bool(args.csv), progress=progress)
    if show:
        print(file=sys.stderr)
    if args.csv:
        _write_history(Path(args.csv), r)
    out = {"status": response_status(r.a1, r.steady),
           "a1": r.a1, "a2": r.a2, "steady": r.steady, "periodic": r.periodic, "t_end": r.t_end,
           "U": r.U, "eta": r.eta, "sigma": r.sigma, "Omega": r.Omega,
           "a1_min": r.a1_min, "a1_max": r.a1_max, "a2_min": r.a2_min, "a2_max": r.a2_max,
           "amplitude_convention": "a_k = half the peak-to-peak of q_k over the last 20 forcing "
                                   "periods (peak modal amplitude = peak displacement / l)",
           "message": r.message, "method": "ode21", "wall_seconds": r.wall_seconds}
    _print_simulation(args, r, out)
    return 0


def _simulate_shooting(args, d, q0) -> int:
    """`autocable simulate --method shooting`: the steady response of eq. (21) by Newton on the
    stroboscopic map, with its Floquet multipliers and class."""
    from autocable.methods.integration.shooting import ShootingSolver, response_json
    if args.csv:
        raise SpecError("--csv", "", "--method shooting computes no time history; use --method ode21 "
                        "for --csv")
    r = ShootingSolver(d.ode).steady(args.U, args.eta, args.sigma, q0, max_time=args.max_time)
    out = {"status": response_status(r.a1, r.steady), **response_json(r)}
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
    return 0


def _simulate_ame(args, d, q0, show, progress) -> int:
    """`autocable simulate --method ame`: the Cartesian AME (24) from the same start as eq. (21)."""
    from autocable.methods.integration.ame import AmeIntegrator
    from autocable.model.ame_cache import derive_ame
    r = AmeIntegrator(derive_ame(d).ame).simulate(args.U, args.eta, args.sigma, q0,
                                                  max_time=args.max_time, keep_history=bool(args.csv),
                                                  progress=progress)
    if show:
        print(file=sys.stderr)
    if args.csv:
        from autocable._store import atomic_write_text
        # A diverged response keeps what was computed up to the divergence (possibly nothing).
        t, r1, s1, r2, s2 = r.history or ((),) * 5
        rows = ["t,r1,s1,r2,s2"] + [f"{a:.10g},{b:.10e},{c:.10e},{e:.10e},{f:.10e}"
                                    for a, b, c, e, f in zip(t, r1, s1, r2, s2)]
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
    _print_simulation(args, r, out)
    return 0


def _simulate_nmode(args, d, q0, show, progress) -> int:
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
    if show:
        print(file=sys.stderr)
    if args.csv:
        from autocable._store import atomic_write_text
        t, ys = r.history or ((), ())
        rows = [",".join(("t",) + integ.ode.state_names)]
        rows += [f"{a:.10g}," + ",".join(f"{v:.10e}" for v in y) for a, y in zip(t, ys)]
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
    if args.json:
        print(dumps(out, indent=1))
    else:
        print(f"U* = {r.U:g}  eta* = {r.eta:g}  sigma = {r.sigma:g}  (Omega = {r.Omega:.6g})  "
              f"method nmode ({args.modes} in-plane + {args.modes} out-of-plane modes)")
        print(f"a1 = {r.a1:.9e}   a2 = {r.a2:.9e}   ({r.message}; "
              f"{'periodic' if r.periodic else 'not period-1'}; t_end = {r.t_end:.1f})")
        print("modal amplitudes: " + "  ".join(f"{k} = {v:.6e}" for k, v in r.amplitudes.items()))
    return 0


def _print_simulation(args, r, out) -> None:
    if args.json:
        print(dumps(out, indent=1))
    else:
        print(f"U* = {r.U:g}  eta* = {r.eta:g}  sigma = {r.sigma:g}  (Omega = {r.Omega:.6g})  "
              f"method {out['method']}")
        if out["status"] == "diverged":
            print(f"diverged: no bounded steady state ({r.message}; t_end = {r.t_end:.6g})")
            return
        print(f"a1 = {r.a1:.9e}   a2 = {r.a2:.9e}   ({r.message}; "
              f"{'periodic' if r.periodic else 'not period-1'}; t_end = {r.t_end:.1f})")
        if not r.periodic:
            print(f"envelope: a1 in [{r.a1_min:.6e}, {r.a1_max:.6e}], a2 in [{r.a2_min:.6e}, {r.a2_max:.6e}]")
        if "equilibrium" in out:
            e = out["equilibrium"]
            print(f"AME equilibrium: {'stable' if e['stable'] else 'unstable'}, "
                  f"max Re(eigenvalue) = {e['max_real_eigenvalue']:.6e}, residual {e['residual']:.1e}")


def _write_history(path: Path, r) -> None:
    from autocable._store import atomic_write_text
    rows = ["t,q1,q2,q1dot,q2dot"]
    # A diverged response keeps the rows up to the divergence (none when it diverged at once).
    t, q1, q2, v1, v2 = r.history or ((),) * 5
    rows += [f"{a:.10g},{b:.10e},{c:.10e},{d:.10e},{e:.10e}" for a, b, c, d, e in zip(t, q1, q2, v1, v2)]
    atomic_write_text(path, "\n".join(rows) + "\n")


def cmd_work_precision(args) -> int:
    """`autocable bench --out DIR` without a subcommand: the method ladder's work-precision bench."""
    from autocable.studies.work_precision import run_bench as run_work_precision
    if args.out is None:
        raise SpecError("bench", "--out", "the work-precision bench writes files: give --out DIR "
                        "(or name a subcommand: derive, ame-vs-ode, continuation, auto, ...)")
    result = run_work_precision(args.out, scenes=args.scene or None, quick=args.quick,
                                repeats=max(args.repeats, 0),
                                log=None if args.quiet else (lambda s: print(s, file=sys.stderr)))
    print(dumps({"summary": result["summary"], "notes": result["notes"],
                      "wall_seconds": result["wall_seconds"],
                      "files": [str(Path(args.out) / f) for f in ("bench.json", "work_precision.png",
                                                                  "work_precision.md")]}, indent=1))
    return 0


def _cmd_advise(args) -> int:
    from autocable.studies.advise import cmd_advise
    return cmd_advise(args)


#: Repeats of a benchmark: each costs up to minutes.
REPEATS_LIMIT = 100
#: Processes or Dask workers: more than this is a typing error on any machine autocable targets.
WORKERS_LIMIT = 1024


def cmd_bench(args) -> int:
    _check_number("--repeats", args.repeats, 0, REPEATS_LIMIT, integer=True)
    _check_out("--out", args.out)
    if args.what is None:
        return cmd_work_precision(args)
    if args.what == "fuzz":
        return cmd_fuzz(args)
    if args.what == "kill":
        from autocable.bench.kill import run_kill_bench as run_bench
    else:
        from autocable.bench.commands import run_bench
    result = run_bench(args.what, args.model, repeats=args.repeats,
                       log=None if args.quiet else (lambda s: print(s, file=sys.stderr)),
                       out=args.out)
    if args.out:
        from autocable._store import atomic_write_json
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(out / f"bench_{args.what}.json", _strict(result))
    print(dumps(result, indent=1))
    return 0


def cmd_fuzz(args) -> int:
    """`autocable bench fuzz`: hostile specs, scenes and arguments through this command line;
    exit 1 when any case shows a problem."""
    from autocable.bench.fuzz import run_fuzz
    result = run_fuzz(main, specs=args.specs, scenes=args.scenes, args=args.args, seed=args.seed,
                      out=args.out, real_runs=args.runs,
                      log=None if args.quiet else (lambda s: print(s, file=sys.stderr)))
    if args.out:
        from autocable._store import atomic_write_json
        atomic_write_json(Path(args.out) / "bench_fuzz.json", result)
    print(json.dumps(result, indent=1))
    return 1 if result["problem_count"] else 0


def cmd_failure_map(args) -> int:
    """`autocable failure-map`: where the AME and the integrators fail."""
    import time
    from autocable.studies.failure_map import run_failure_map
    from autocable.studies.failure_map_report import write_failure_map
    _check_out("--out", args.out)
    say = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    t0 = time.perf_counter()
    result = run_failure_map(args.model, quick=args.quick, log=say)
    command = "autocable failure-map --out DIR" + (" --quick" if args.quick else "")
    files = write_failure_map(result, args.out, command)
    print("\n".join(result["statement"]))
    print(f"wrote {', '.join(str(f) for f in files)} in {time.perf_counter() - t0:.0f} s")
    return 0


# ------------------------------------------------------------------------------------------------
# autocable run
# ------------------------------------------------------------------------------------------------
def cmd_sweep(args) -> int:
    """`autocable sweep SWEEP.toml --out DIR`: a grid of steady responses as one dataset."""
    from autocable.scene.sweep_schema import load_sweep
    from autocable.studies.sweep import run_sweep
    _check_out("--out", args.out)
    _check_number("--workers", args.workers, 0, WORKERS_LIMIT, integer=True)   # 0: serial, no Dask
    _check_number("--chunk", args.chunk, 1, 10**6, integer=True)
    spec = load_sweep(args.sweep)
    summary = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler, chunk=args.chunk,
                        log=None if args.quiet else (lambda s: print(s, file=sys.stderr)))
    print(dumps(summary, indent=1))
    if summary["failed"]:
        first = summary["failed"][0]
        print(f"autocable: sweep: {len(summary['failed'])} point(s) failed (kept out of sweep.nc as not computed; "
              f"a rerun tries them again), first at U={first['U']:g} eta={first['eta']:g} "
              f"sigma={first['sigma']:g}: {first['error']}", file=sys.stderr)
        return 1
    return 0


def add_sweep_parser(subparsers) -> None:
    w = subparsers.add_parser("sweep", help="steady responses over a grid of (U, eta, sigma) on Dask; "
                              "writes DIR/sweep.nc (xarray) and resumes an interrupted sweep")
    w.add_argument("sweep", help="sweep file (TOML: model, method, [grid] U, eta, sigma)")
    w.add_argument("--out", required=True, help="output folder (points/, sweep.nc, sweep.json)")
    w.add_argument("--workers", type=int, default=None,
                   help="LocalCluster worker processes (default: one per core; 0: serial, without Dask)")
    w.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786 "
                   "(its workers need autocable installed)")
    w.add_argument("--chunk", type=int, help="grid points (with follow: lines) per Dask task (default: about 8 "
                   "tasks per worker, "
                   "at most 16 points)")
    w.add_argument("--quiet", action="store_true", help="no progress")
    w.set_defaults(func=cmd_sweep)


def add_run_parser(subparsers) -> None:
    """Add ``autocable run SCENE.toml --out DIR [--quiet] [--no-plot]`` to an argparse subparsers."""
    r = subparsers.add_parser("run", help="run a scene file (runs/*.toml): continuation, results, plot")
    r.add_argument("scene", help="scene file (runs/*.toml)")
    r.add_argument("--out", help="output folder (default: out/<scene name>)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    r.add_argument("--no-plot", action="store_true", help="write the tables only")
    r.add_argument("--resolution", choices=RESOLUTIONS, default="full",
                   help="coarse: longer steps, capped cycle runs, every third overlay value (what the tests run)")
    r.add_argument("--engine", choices=ENGINES,
                   help="override the scene's engine of equilibria, switching and cycles from Hopf points")
    r.set_defaults(func=cmd_run)


def cmd_run(args) -> int:
    """Run a scene; print a summary (branches, special points, files) on stdout."""
    _check_out("--out", getattr(args, "out", None))
    scene = load_scene(args.scene)
    out = Path(args.out) if getattr(args, "out", None) else Path("out") / scene.name
    # Before the computation, not after it: a folder that cannot be made would lose the results.
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("--out", "", f"cannot make the output folder {out}: {exc.strerror or exc}; "
                                     "give a folder that can be created") from None
    quiet = bool(getattr(args, "quiet", False))
    progress = None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    from autocable.scene.runner import run_scene
    from autocable.studies.advise import choose_ame
    res = run_scene(scene, out, progress=progress, plot=not getattr(args, "no_plot", False),
                    resolution=getattr(args, "resolution", "full") or "full",
                    engine=getattr(args, "engine", None), choose_ame=choose_ame)
    if not quiet and scene.time is not None:
        print(f"{scene.title}")
        summary = res.provenance["summary"]
        for src in ("ame", "ode21"):
            if src in summary:
                s = summary[src]
                period = s.get("modulation_period")
                print(f"  {src:<6} a1 in [{s.get('a1_min', math.nan):.6e}, {s.get('a1_max', math.nan):.6e}]  "
                      f"a2 in [{s.get('a2_min', math.nan):.6e}, {s.get('a2_max', math.nan):.6e}]  modulation period "
                      + (f"{period:.6g}" if period else "none (steady amplitude)") + f"  ({s['message']})")
        print(f"  results in {out}/ (time_series.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "") + ")")
    elif not quiet:
        print(f"{scene.title}")
        for b in res.branches:
            ends = "; ".join(f"{e.side}: {e.reason}" + (f" ({e.message})" if e.reason not in ("range",) and e.message else "")
                             for e in b.ends)
            print(f"  {b.name:<12} {b.kind:<11} {len(b):>5} points   {ends}")
            for s in b.special_points:
                conf = {True: "PyCont agrees", False: "PyCont missed it", None: ""}[s.confirmed_by_pycont] \
                    if s.origin == "autocable" else "PyCont only, not confirmed"
                extra = f" l1 = {s.extra['l1']:.4g}" if "l1" in s.extra else ""
                second = f", {s.extra['parameter2']} = {s.extra['value2']: .8g}" if "value2" in s.extra else ""
                print(f"    {s.label:<5} {s.parameter} = {s.value: .8g}{second}  a1 = {s.a1:.6e}  a2 = {s.a2:.6e}"
                      f"{extra}  {conf}")
        plane = scene.plot.plane and any(b.kind in ("fold", "hopf", "branch_point") for b in res.branches)
        print(f"  results in {out}/ (branches.csv, special_points.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "")
              + (f", {scene.name}_plane.png, {scene.name}_plane.pdf" if plane and not getattr(args, "no_plot", False)
                 else "") + ")")
    return 0


def add_chart_parser(subparsers) -> None:
    """``autocable chart SCENE.toml --out DIR [--map DIR/sweep.nc]``: a stability chart."""
    c = subparsers.add_parser("chart", help="a stability chart: fold/Hopf/pitchfork curves of the AME in a "
                              "parameter plane, its response regions labelled, a brute-force map of eq. (21) overlaid")
    c.add_argument("scene", help="scene file with a [chart] table (e.g. runs/chart_U_eta.toml)")
    c.add_argument("--out", help="output folder (default: out/<scene name>)")
    c.add_argument("--map", help="a brute-force map of eq. (21) (the sweep.nc of `autocable sweep`) to overlay")
    c.add_argument("--quiet", action="store_true", help="no progress on stderr")
    c.add_argument("--resolution", choices=RESOLUTIONS, default="full",
                   help="coarse: longer continuation steps and half the classification grid (what the tests run)")
    c.set_defaults(func=cmd_chart)


def cmd_chart(args) -> int:
    """Run a chart scene (its continuation runs and the [chart] table); print the regions and files."""
    _check_out("--out", args.out)
    scene = load_scene(args.scene)
    if scene.chart is None:
        raise SpecError(scene.path, "chart", "missing; `autocable chart` draws a scene with a [chart] table "
                                             "(runs/chart_U_eta.toml is one); use `autocable run` for others")
    if args.map and not Path(args.map).is_file():
        raise SpecError("--map", "", f"no such file: {args.map}; give the sweep.nc that `autocable sweep` wrote")
    out = Path(args.out) if args.out else Path("out") / scene.name
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("--out", "", f"cannot make the output folder {out}: {exc.strerror or exc}; "
                                     "give a folder that can be created") from None
    progress = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    from autocable.scene.runner import run_scene
    from autocable.studies.advise import choose_ame
    res = run_scene(scene, out, progress=progress, resolution=args.resolution, choose_ame=choose_ame,
                    response_map=args.map)
    if not args.quiet:
        import json
        data = json.loads((out / "regions.json").read_text())
        print(f"{scene.title}")
        for b in res.branches:
            if b.parameter2:
                pts = ", ".join(f"{s.label} ({b.parameter} = {s.value:.6g}, {b.parameter2} = {s.extra['value2']:.6g})"
                                for s in b.special_points if s.origin == "autocable")
                print(f"  {b.name:<10} {b.kind:<12} {len(b):>5} points  {pts}")
        x, y = data["plane"]
        # The regions the chart labels (at least 1 % of the grid); the small ones are counted.
        least = max(2, data["grid"][0] * data["grid"][1] // 100)
        for g in data["regions"]:
            if g["cells"] >= least:
                print(f"  region {g['label']:<36} {g['cells']:>4} cells, labelled at {x} = {g[x]:.4g}, {y} = {g[y]:.4g}")
        small = [g for g in data["regions"] if g["cells"] < least]
        if small:
            print(f"  and {len(small)} regions of fewer than {least} cells (coloured, not labelled; regions.json lists them)")
        if "map" in data:
            m = data["map"]
            print(f"  map: {m['points']} points of eq. (21), the AME's class predicts {m['agree']} of them")
        print(f"  results in {out}/ ({scene.name}_chart.png, .pdf, regions.csv, regions.json, branches.csv, run.json)")
    return 0


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="autocable", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"autocable {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    d = sub.add_parser("derive", help="derive eq. (21) from a model spec and report its coefficients")
    d.add_argument("model", help="model spec file (models/*.toml)")
    d.add_argument("--json", action="store_true", help="one JSON object instead of the report "
                   "(key 'ame': the Cartesian amplitude equations (24) as a coefficient table)")
    d.add_argument("--latex", action="store_true", help="print the amplitude equations (22) in LaTeX")
    d.add_argument("--ordering", choices=("paper", "natural"), default="paper",
                   help="Multiple Scales ordering of the AME: 'paper' (Sect. 4, every aerodynamic term at "
                        "third order; default) or 'natural' (aerodynamic terms at their natural order)")
    d.set_defaults(func=cmd_derive)

    s = sub.add_parser("simulate", help="integrate eq. (21) (or its amplitude equations) to a steady state")
    s.add_argument("model")
    s.add_argument("--U", type=float, default=0.0, help="nondimensional wind speed U* = U/U_c")
    s.add_argument("--eta", type=float, default=0.0, help="nondimensional support amplitude eta* = eta/l")
    s.add_argument("--sigma", type=float, default=0.0, help="external detuning: Omega = omega1 + sigma")
    s.add_argument("--q0", type=float, nargs=4, metavar=("Q1", "Q1DOT", "Q2", "Q2DOT"),
                   help="initial state (default: rest with q2 = 1e-6)")
    s.add_argument("--max-time", type=float, default=60000.0, help="give up after this time (t* units)")
    s.add_argument("--json", action="store_true")
    s.add_argument("--csv", metavar="FILE", help="write the time history")
    s.add_argument("--quiet", action="store_true", help="no progress")
    s.add_argument("--method", choices=["ode21", "ame", "shooting"], default="ode21",
                   help="ode21: direct integration of eq. (21); ame: the Multiple Scales amplitude "
                        "equations (24) to their steady state; shooting: the steady response of eq. (21) "
                        "by Newton on the period map after a short transient, with its Floquet "
                        "multipliers and class (rest, period-1, period-2, quasi-periodic, diverged) "
                        "(default ode21)")
    s.add_argument("--modes", type=int, metavar="N",
                   help="integrate eq. (21) with N in-plane and N out-of-plane modes (the check that "
                        "two modes suffice); a1, a2 are the first modes' amplitudes")
    s.set_defaults(func=cmd_simulate)

    b = sub.add_parser("bench", help="benchmarks (speed and accuracy); prints JSON")
    b.add_argument("what", nargs="?", default=None,
                   choices=["derive", "ame-vs-ode", "continuation", "auto", "figures", "ordering", "engines",
                            "shooting", "sweep", "kill", "fuzz"],
                   help="derive: derivation time and integration speed; ame-vs-ode: error map of the "
                        "amplitude equations against eq. (21) (with --out, also ame_vs_ode21.md/.png); "
                        "continuation: EP-C cost per point and a Fig. 6-sized scene, cold and warm; "
                        "auto: EP-C cost per point against AUTO-07p (bifpy; set AUTOCABLE_AUTO_PYTHON "
                        "or install autocable[auto]); figures: wall time of `autocable figures` (all scenes), "
                        "cold and warm cache, with the share of each stage; ordering: the paper's and the "
                        "natural Multiple Scales ordering (2-dof and A2 = 0) against eq. (21) at Figs. 4c, 7, 9 "
                        "(with --out, also ordering.md/.png); engines: every figure scene on PyCont and on the compiled "
                        "kernel (coarse), their special points compared; shooting: steady points of eq. (21) by "
                        "shooting against transient integration at equal accuracy (Figs. 5-10, 77 points); "
                        "sweep: 'autocable sweep' throughput with 1 and 2 Dask workers and the scaling; "
                        "kill: a scene run killed (SIGKILL, SIGINT) at random moments --repeats times (at least "
                        "20), each folder checked not to read as complete, leftovers checked after a rerun; "
                        "fuzz: hostile model specs, scenes and arguments, counts of tracebacks, exit-0 "
                        "results for invalid input, unnamed rejections and hangs. "
                        "Without a subcommand "
                        "(--out DIR): the work-precision bench of the method ladder (bench.json, "
                        "work_precision.png, work_precision.md)")
    b.add_argument("--model", default=str(SAMPLE_MODEL))
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--out", help="folder to write bench_<what>.json")
    b.add_argument("--quiet", action="store_true")
    b.add_argument("--quick", action="store_true", help="work-precision bench: the one-minute version "
                   "(Fig. 5a only, coarse reference, two knob settings per method, no repeats)")
    b.add_argument("--scene", action="append", metavar="SCENE",
                   help="work-precision bench: a scene name (fig06) or file; repeatable (default: "
                        "fig05a, fig06, fig09 and fig10 when its file exists)")
    b.add_argument("--specs", type=int, default=1000, help="fuzz: mutated model specs (default 1000)")
    b.add_argument("--scenes", type=int, default=300, help="fuzz: mutated scenes (default 300)")
    b.add_argument("--args", type=int, default=60, help="fuzz: argument vectors (default 60)")
    b.add_argument("--runs", type=int, default=16, help="fuzz: real scene runs at most (default 16)")
    b.add_argument("--seed", type=int, default=0, help="fuzz: seed of the mutations (default 0)")
    b.set_defaults(func=cmd_bench)

    adv = sub.add_parser("advise", help="which rung of the method ladder a scene needs at a tolerance "
                                        "(1-dof AME, 2-dof AME, or eq. (21) itself), with the evidence")
    adv.add_argument("scene", help="scene file (runs/*.toml)")
    adv.add_argument("--tol", type=float, default=0.02, help="relative tolerance on a1, a2 (default 0.02)")
    adv.add_argument("--json", action="store_true", help="one JSON object instead of the report")
    adv.set_defaults(func=_cmd_advise)

    fm = sub.add_parser("failure-map", help="maps over (sigma, eta) and (sigma, U) of where the AME "
                        "and the integrators fail; writes failure_map.md and failure_map_<k>.png")
    fm.add_argument("--out", required=True, help="folder for failure_map.md and the figures")
    fm.add_argument("--quick", action="store_true", help="a tiny grid (seconds, for tests)")
    fm.add_argument("--model", default=str(SAMPLE_MODEL))
    fm.add_argument("--quiet", action="store_true", help="no progress")
    fm.set_defaults(func=cmd_failure_map)

    cal = sub.add_parser("calibrate", help="search the paper's unknown inputs (yaw, rivulet angle, "
                         "and the readings it leaves open) against the statements of Sect. 5; writes "
                         "calibration.csv, calibration.md and beta-Theta0 maps")
    cal.add_argument("model", help="model spec file (models/*.toml)")
    cal.add_argument("targets", help="targets file (models/*.targets.toml)")
    cal.add_argument("--out", required=True, help="output folder (resumable: finished points are reused)")
    cal.add_argument("--space", help="search-space file (default: <model>.search.toml beside the model if "
                                     "it exists, else the built-in space)")
    cal.add_argument("--jobs", type=int, default=2, help="processes (default 2)")
    cal.add_argument("--full", type=int, help="candidates evaluated on every figure scene (overrides the space's)")
    cal.add_argument("--quiet", action="store_true", help="no progress lines")
    cal.set_defaults(func=_cmd_calibrate)

    add_run_parser(sub)
    add_chart_parser(sub)
    add_sweep_parser(sub)
    add_figures_parser(sub)
    return p


def _cmd_calibrate(args) -> int:
    """`autocable calibrate MODEL TARGETS --out DIR` (autocable.paper.calibration)."""
    from dataclasses import replace as _replace

    from autocable.paper import calibration as study
    _check_out("--out", args.out)
    _check_number("--jobs", args.jobs, 1, WORKERS_LIMIT, integer=True)
    _check_number("--full", args.full, 0, 10**6, integer=True)
    space_path = Path(args.space) if args.space else Path(args.model).with_suffix("").with_suffix(".search.toml")
    if args.space or space_path.is_file():
        space = study.load_space(space_path)
    else:
        space = study.SearchSpace()
    if args.full is not None:
        space = _replace(space, full=max(0, args.full))
    load_model(args.model)                  # bad files: one line before any work
    study.tg.load_targets(args.targets)
    stats = study.calibrate(args.model, args.targets, args.out, space=space, jobs=args.jobs, quiet=args.quiet)
    print(dumps(stats))
    return 0


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    import warnings
    from autocable.model.premises import PremiseWarning

    def one_line(message, category, filename, lineno, file=None, line=None):
        # a stretched premise is news for the user, not a Python warning with a source line
        if issubclass(category, PremiseWarning):
            print(f"autocable: warning: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        shown = warnings.showwarning
        warnings.showwarning = one_line
        warnings.simplefilter("default", PremiseWarning)    # once per place and text, every call
        return _dispatch(args)


#: The positional file arguments of the commands (model spec, scene, targets, sweep file).
_INPUT_ARGUMENTS = ("model", "scene", "targets", "sweep")


def _dispatch(args) -> int:
    """`main` after parsing: the command, its failures mapped to the exit status of `autocable.errors`."""
    if os.environ.get("AUTOCABLE_DEBUG"):
        return args.func(args)
    try:
        # an input file given as "" would read as the current folder: name the argument instead
        for arg in _INPUT_ARGUMENTS:
            if isinstance(getattr(args, arg, None), str) and not getattr(args, arg).strip():
                raise _refuse(arg.upper(), "an empty path; give the file")
        return args.func(args)
    except SpecError as exc:
        print(f"autocable: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except CacheError as exc:
        print(f"autocable: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except ComputationError as exc:
        print(f"autocable: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:            # output piped into `head` and cut: not an error
        return 0
    except KeyboardInterrupt:
        print("autocable: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # a failure we did not foresee: one line, never a raw traceback
        from autocable.codegen.compat import PyDSToolError
        kind = "PyDSTool" if isinstance(exc, PyDSToolError) else type(exc).__name__
        first = str(exc).splitlines()[0] if str(exc) else kind
        print(f"autocable: error ({kind}): {first} (set AUTOCABLE_DEBUG=1 for details)", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
