"""Do two modes suffice? Eq. (21) (one in-plane, one out-of-plane mode, Sect. 3) against the
N + N-mode Galerkin models at the settings of Figs. 5a, 6 and 9 (docs/modes_suffice.md):

    python -m autocable.studies.modes_suffice models/luongo_zulli_2012.toml
"""
from __future__ import annotations

import math

from autocable.methods.integration.nmode import NModeIntegrator, default_start
from autocable.methods.integration.ode21 import half_range
from autocable.model.symbolic import parameter_values


#: The settings of the "two modes suffice?" table (docs/modes_suffice.md): (label, U*, eta*).
SUFFICE_SETTINGS = (("Fig. 5a", 0.0, 8.2e-5), ("Fig. 6", 0.0, 1.4e-3), ("Fig. 9", 0.7, 1.4e-3))
SUFFICE_SIGMAS = (-0.04, -0.02, 0.0, 0.02, 0.04)


def modes_suffice_rows(derivation, ns=(2, 3), settings=SUFFICE_SETTINGS, sigmas=SUFFICE_SIGMAS,
                       max_time: float = 60000.0) -> list[dict]:
    """a1, a2 of eq. (21) against the N-mode models (n_in = n_out = N) at each (U, eta, sigma).

    Each N-mode model is run twice: from rest (the seeded start of `default_start`, as eq. (21)
    from its own default start), and from eq. (21)'s final state (first modes set, the others at
    rest), which follows the same branch where several coexist.
    """
    from autocable.methods.integration.ode21 import Ode21Integrator
    eq21 = Ode21Integrator(derivation.ode)
    models = {n: NModeIntegrator(derivation, n, n) for n in ns}
    rows = []
    for label, U, eta in settings:
        for sigma in sigmas:
            r = eq21.simulate(U, eta, sigma, max_time=max_time)
            row = {"setting": label, "U": U, "eta": eta, "sigma": sigma, "eq21": r}
            q1, q2, q1d, q2d = r.final_state
            for n, integ in models.items():
                ode = integ.ode
                x = [0.0] * (2 * ode.n)
                if math.isfinite(r.a1):   # a diverged eq. (21) leaves no branch to follow
                    x[integ._i1], x[integ._i2] = q1, q2
                    x[ode.n + integ._i1], x[ode.n + integ._i2] = q1d, q2d
                row[f"N{n}_rest"] = integ.simulate(U, eta, sigma, max_time=max_time)
                row[f"N{n}_same"] = integ.simulate(U, eta, sigma, tuple(x), max_time=max_time)
            rows.append(row)
    return rows


def _rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b) if b else (0.0 if a == b else math.inf)


def modes_suffice_markdown(rows: list[dict], ns=(2, 3)) -> str:
    """The table of `modes_suffice_rows` in Markdown: amplitudes, relative differences, added modes.

    N-mode entries are from eq. (21)'s final state (same branch); "qp" marks a response that is not
    period-1 in the forcing (amplitude-modulated: a_k is then the largest half peak-to-peak over the
    last 20 periods); a second table lists the runs from rest that ended elsewhere (> 1 %).
    """
    head = ["setting", "sigma", "eq21 a1", "eq21 a2"]
    for n in ns:
        head += [f"N={n} a1", f"N={n} a2", f"d a1 (N={n})", f"d a2 (N={n})", f"added modes (N={n})"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]

    def amp(r, x):
        if not math.isfinite(x):
            return "div."
        return f"{x:.4e}" + ("" if r.periodic else " qp") + ("" if r.steady else " (not steady)")

    def rel(a, b):
        if not (math.isfinite(a) and math.isfinite(b)):
            return "-"
        if b < 1e-9 and a < 1e-9:
            return "both < 1e-9"
        return f"{100 * (a - b) / b:+.2f} %"

    moved = []
    for row in rows:
        r = row["eq21"]
        cells = [row["setting"], f"{row['sigma']:+.2f}", amp(r, r.a1), amp(r, r.a2)]
        for n in ns:
            s = row[f"N{n}_same"]
            extra = ", ".join(f"{k} {v:.1e}" for k, v in s.amplitudes.items()
                              if k not in ("v1", "w1") and v > 1e-12) or "all < 1e-12"
            cells += [amp(s, s.a1), amp(s, s.a2), rel(s.a1, r.a1), rel(s.a2, r.a2), extra]
            z = row[f"N{n}_rest"]
            if any(_rel(x, y) > 0.01 for x, y in ((z.a1, s.a1), (z.a2, s.a2)) if max(x, y) > 1e-9):
                moved.append(f"| {row['setting']} | {row['sigma']:+.2f} | {n} | {amp(z, z.a1)} | "
                             f"{amp(z, z.a2)} | {amp(s, s.a1)} | {amp(s, s.a2)} |")
        lines.append("| " + " | ".join(cells) + " |")
    if moved:
        lines += ["", "Runs from rest that ended on another response than the same-branch run:", "",
                  "| setting | sigma | N | from rest a1 | from rest a2 | same branch a1 | same branch a2 |",
                  "|---|---|---|---|---|---|---|"] + moved
    return "\n".join(lines)


def per_period_envelope(integrator, x0, indices, U: float, eta: float, sigma: float, *,
                        transient: float = 40000.0, periods: int = 400, samples_per_period: int = 64):
    """For an amplitude-modulated response: after ``transient``, the smallest and largest half
    peak-to-peak of the coordinates ``indices`` over single forcing periods, in ``periods`` periods.
    Works with `NModeIntegrator` and `integration.Ode21Integrator` (both have ``run``)."""
    omega1 = integrator.ode.omega1 if hasattr(integrator.ode, "omega1") else integrator.ode.omegas[0]
    Omega = omega1 + sigma
    period = 2 * math.pi / Omega
    pars = parameter_values(U, eta, Omega)
    tt, ys = integrator.run(tuple(x0), 0.0, transient, period, pars)
    tt, ys = integrator.run(tuple(ys[-1]), float(tt[-1]), float(tt[-1]) + periods * period,
                            period / samples_per_period, pars)
    m = samples_per_period
    out = []
    for k in indices:
        per = [half_range(ys[i:i + m + 1, k]) for i in range(0, len(ys) - m, m)]
        out.append((min(per), max(per)))
    return out


#: Where the table's responses are amplitude-modulated (Fig. 9 settings): their envelopes compared.
MODULATED = (("Fig. 9", 0.7, 1.4e-3, -0.02), ("Fig. 9", 0.7, 1.4e-3, 0.0))


def modulated_rows(derivation, ns=(2, 3), cases=MODULATED) -> list[str]:
    """Markdown rows: per-period envelope of a1, a2 for eq. (21) and the N-mode models from rest."""
    from autocable.methods.integration.ode21 import DEFAULT_Q0, Ode21Integrator
    q1, q1d, q2, q2d = DEFAULT_Q0
    models = [("eq21", Ode21Integrator(derivation.ode), (q1, q2, q1d, q2d), (0, 1))]
    for n in ns:
        it = NModeIntegrator(derivation, n, n)
        models.append((f"N={n}", it, default_start(it.ode), (it._i1, it._i2)))
    rows = ["| setting | sigma | model | a1 per period: min | max | a2 per period: min | max |",
            "|---|---|---|---|---|---|---|"]
    for label, U, eta, sigma in cases:
        for name, it, x0, idx in models:
            (l1, h1), (l2, h2) = per_period_envelope(it, x0, idx, U, eta, sigma)
            rows.append(f"| {label} | {sigma:+.2f} | {name} | {l1:.3e} | {h1:.3e} | {l2:.3e} | {h2:.3e} |")
    return rows


if __name__ == "__main__":   # python -m autocable.studies.modes_suffice MODEL.toml
    import sys
    from autocable.model.derive import derive
    derivation = derive(sys.argv[1])
    table_rows = modes_suffice_rows(derivation)
    print(modes_suffice_markdown(table_rows))
    print()
    print("\n".join(modulated_rows(derivation)))
    for row in table_rows:
        for key in sorted(k for k in row if k.startswith("N")):
            s = row[key]
            print(f"{row['setting']:8s} sigma={row['sigma']:+.2f} {key:8s} a1={s.a1:.6e} a2={s.a2:.6e} "
                  f"eq21 a1={row['eq21'].a1:.6e} a2={row['eq21'].a2:.6e} steady={s.steady} "
                  f"periodic={s.periodic} {s.message}")
