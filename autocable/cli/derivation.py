"""`autocable derive`: eq. (21)'s coefficients and the amplitude equations (22)-(24) of a model spec,
as a report or as one JSON object."""
from __future__ import annotations

import math

from autocable.cli.checks import check_number, dumps

#: The help of ``--pair`` (derive, simulate, onset).
PAIR_HELP = ("the mode pair k of eq. (21): the k-th in-plane and k-th out-of-plane modes (overrides the "
             "model's cable.mode_pair; default: the file's, 1 if it has none)")


#: The help of ``--load`` (simulate, onset, gallop).
LOAD_HELP = ('the rung of the aerodynamic load: "cubic" (the cubic expansion of eq. 14, the paper\'s eq. 21) '
             'or "exact" (eqs. 11-13 without expansion, projected by quadrature); overrides the model\'s '
             'aero.load (default: the file\'s, "cubic" if it has none)')


def derivation(path, pair: int | None = None, load: str | None = None):
    """Eq. (21) of the model file ``path``, on mode pair ``pair`` if given (``--pair``: it overrides
    the file's ``cable.mode_pair``; a calibrated angle is still fitted on the first pair), on the
    load rung ``load`` if given (``--load``: it overrides the file's ``aero.load``)."""
    from autocable.model.derive import derive
    if pair is None and load is None:
        return derive(path)
    from dataclasses import replace

    from autocable.spec import MODE_PAIR_MAX, load_model
    spec = load_model(path)
    if pair is not None:
        check_number("--pair", pair, 1, MODE_PAIR_MAX, integer=True)
        spec = replace(spec, cable=replace(spec.cable, mode_pair=int(pair)))
    if load is not None:
        spec = replace(spec, aero=replace(spec.aero, load=load))
    return derive(spec)


def modes_lines(d, u) -> list[str]:
    """The report's lines on the two trial functions: the paper's first pair, or pair k."""
    ode = d.ode
    if d.mode_pair == 1:
        return [
            f"  omega1 = {ode.omega1:.9f} (in-plane, Irvine; {u.frequency_hz(ode.omega1):.5g} Hz)   "
            f"omega2 = {ode.omega2:.9f} (out-of-plane; {u.frequency_hz(ode.omega2):.5g} Hz)",
            f"  internal detuning rho = omega2 - omega1 = {ode.omega2 - ode.omega1:.6g}",
            f"  slaved twist theta2 = {d.twist[0]:.6g} sin(pi s) + {d.twist[1]:.6g} cosh({d.twist[2]:.6g} (s - 1/2))"]
    from autocable.model.mode_pairs import pair_info
    k, info = d.mode_pair, pair_info(d.statics, d.mode_pair)
    B, C, kappa = d.twist
    hom = (f"{d.twist_D:.6g} sinh({kappa:.6g} (s - 1/2))" if k % 2 == 0 and C == 0.0
           else f"{C:.6g} cosh({kappa:.6g} (s - 1/2))")
    return [
        f"  mode pair {k} (cable.mode_pair or --pair; docs/mode-pairs.md): the {info.describe_in_plane()} and "
        f"the out-of-plane mode sin({k} pi s)",
        f"  omega1 = {ode.omega1:.9f} (in-plane; {u.frequency_hz(ode.omega1):.5g} Hz)   "
        f"omega2 = {ode.omega2:.9f} (out-of-plane; {u.frequency_hz(ode.omega2):.5g} Hz)",
        f"  internal detuning rho = omega2 - omega1 = {ode.omega2 - ode.omega1:.6g}",
        f"  slaved twist theta2 = {B:.6g} sin({k} pi s) + {hom}",
        "  unit maximum: the peak displacements a_k l are at each mode's maximum, not at mid-span"]


def _fmt(x: float) -> str:
    return f"{x: .6e}"


def derive_report(d) -> str:
    """The readable report of `autocable derive` (eq. 21 and what it rests on)."""
    from autocable.model.units import units_of
    st, ode, spec = d.statics, d.ode, d.spec
    u = units_of(spec, st)
    lines = [
        f"model {spec.name} ({spec.path})",
        "",
        "Statics (Sect. 2.1, nearly taut) and nondimensional groups (eq. 17):",
        f"  T-bar = {st.T_bar:.6g} N   kappa-bar = {st.kappa_bar:.6g} 1/m   alpha = {math.degrees(st.alpha):.4g} deg",
        f"  delta = kappa*l = {st.delta:.6g}   tau = T/EA = {st.tau:.6g}   chi = GJ/EI = {st.chi:.6g}",
        f"  Irvine lambda^2 = {st.lambda2:.6g}   m* = pi^2 tau = {st.m_star:.6g}",
        f"  reference frequency omega = (pi/l) sqrt(T/m) = {st.omega_ref:.6g} rad/s ({u.frequency_hz(1.0):.4g} Hz)",
        f"  quasi-static shape (eqs. 15-16, corrected C2): vhat(s) = {st.C1:.6g} s^2 + {st.C2:.6g} s",
        "",
        "Modes (eqs. 19-20, unit maximum):",
        *modes_lines(d, u),
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
        "model": d.spec.name, "model_hash": d.spec.content_hash(), "mode_pair": d.mode_pair,
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


#: Why `derive` on pair k > 1 prints no amplitude equations.
NO_AME_NOTE = ("the amplitude equations (22)-(24) are derived for the first mode pair only (Sect. 4's 1:1 "
               "resonance near the first frequencies, and every scene and figure built on them)")


def cmd_derive(args) -> int:
    from autocable.model.ame_cache import derive_ame
    d = derivation(args.model, getattr(args, "pair", None))
    cached = derive_ame(d, ordering=args.ordering) if d.mode_pair == 1 else None
    from autocable.studies.onset import onset_report, onset_text
    onset = onset_report(d)
    if args.json:
        out = derive_json(d)
        out["ame"] = ame_json(cached) if cached is not None else None
        if cached is None:
            out["ame_note"] = NO_AME_NOTE
        out["onset"] = onset
        print(dumps(out, indent=1))
    else:
        print(derive_report(d))
        print(ame_report(cached, latex=args.latex) if cached is not None
              else f"\nNo amplitude equations for mode pair {d.mode_pair}: {NO_AME_NOTE}.")
        print()
        print("\n".join(onset_text(onset)))
        print("  (autocable onset MODEL --damping A:B --design-wind U: the damping that keeps it stable)")
        for w in onset["warnings"]:
            print(f"warning: {w}")
    return 0
