"""Where a motion of eq. (21) still lies inside the model it came from.

A galloping cycle of a real stay can be metres large. The slaved twist is linear in q2
(theta = theta2(s) q2, with theta2 up to hundreds of radians per unit q2 under the paper's natural
end conditions), so such a cycle turns the rivulet, and with it the angle phi of eq. (12), by tens to
hundreds of degrees. The aerodynamic curves (eq. 13, or a table) hold over a stated range of phi
only, and the cubic load of eq. (14) only while its truncation error stays small. A number a user
acts on must say whether it came from inside that range.

`motion_validity` measures, along sampled states (q1, q2, q1', q2') of a motion (a time history, a
continued cycle), at every quadrature node of the span:

* ``phi_range_deg``: the smallest and largest phi (eq. 12, degrees) the motion reached,
  ``phi_swept_deg`` = max |phi - phi0| about the static angle;
* ``twist_max_deg``: the largest |theta| along the span: max |q2| times the peak of the twist shape
  theta2(s) over the whole span (`twist_peak`), not over the quadrature nodes, which miss it (the
  24 Gauss nodes of the 190 m stay with restrained twist hold 0.5 % below its mid-span peak);
* ``cubic_load_error``: the largest difference of eq. (21)'s cubic aerodynamic forces from the exact
  quasi-steady load's (`autocable.model.exact_load`) along the samples, relative to the largest exact
  force: how far the truncation of eq. (14) is from the load it stands for;
* ``beyond_valid_range``: phi left the curves' valid range, or (on the cubic rung) the cubic load's
  error exceeded `aero.CUBIC_RTOL`; ``reasons`` says which.
"""
from __future__ import annotations

import math

import numpy as np

from autocable.model.aero import CUBIC_RTOL
from autocable.model.curves import curves_from_dict
from autocable.model.exact_load import ExactLoad, forces, section_angles


def exact_load_for(d) -> ExactLoad:
    """The exact load of a derivation (`autocable.model.derive.Derivation`), built from its modes and
    angles when it is on the cubic rung (eq. 21 then only carries the load's cubic expansion)."""
    if d.ode.exact_load is not None:
        return d.ode.exact_load
    from autocable.model.derive import with_exact_load
    data = {"aero_scale": d.aero_scale, "velocity_ratio": d.velocity_ratio, "beta": d.beta, "theta0": d.theta0}
    return with_exact_load(d.ode, d.spec, d.statics, data).exact_load


def twist_peak(d) -> float:
    """max over s in [0, 1] of |theta2(s)|, the slaved twist (rad) per unit q2 of the derivation's
    mode pair (eq. 20's closed form, `autocable.model.mode_pairs.pair_modes`): the largest of 1001
    equally spaced values, refined by bounded Brent between that point's neighbours (the peak of a
    smooth shape: its error falls from the grid's O(h^2) to round-off), and the ends themselves
    (where a natural twist's cosh part peaks)."""
    from scipy.optimize import minimize_scalar

    from autocable.model.mode_pairs import pair_modes
    shape = pair_modes(d.statics, d.mode_pair, d.spec.cable.twist_ends).shapes["theta2"]
    s = np.linspace(0.0, 1.0, 1001)
    values = np.abs(shape.evaluate(s))
    i = int(np.argmax(values))
    best = float(values[i])
    if 0 < i < len(s) - 1:
        r = minimize_scalar(lambda x: -abs(float(shape.evaluate(np.array([x]))[0])), bounds=(s[i - 1], s[i + 1]),
                            method="bounded", options={"xatol": 1e-12})
        best = max(best, -float(r.fun))
    return best


def valid_phi_of(ex: ExactLoad) -> tuple[float, float]:
    """The curves' valid range of phi (radians, absolute): the stated one or the default about phi0."""
    from autocable.model.curves import default_valid_phi
    curves = curves_from_dict(ex.curves)
    return curves.valid_phi if curves.valid_phi is not None else tuple(default_valid_phi(ex.static_angle))


def cubic_aero_forces(ode, q1, q2, v1, v2, U, Ed=0.0):
    """(F1, F2): eq. (21)'s cubic aerodynamic terms as accelerations at arrays of states (the part of
    `TwoModeODE.accelerations` the exact load replaces), vectorised."""
    q1, q2, v1, v2, U, Ed = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (q1, q2, v1, v2, U, Ed)))
    out = [np.zeros(q1.shape), np.zeros(q1.shape)]
    for t in ode.terms:
        if t.origin != "aerodynamic":
            continue
        if t.forcing[0] or t.forcing[2]:
            raise ValueError(f"an aerodynamic term of eq. (21) with support displacement or acceleration: {t}")
        m = t.coefficient * np.where(U == 0.0, 0.0, np.abs(U) ** t.u_power * np.sign(U) ** abs(t.u_power)
                                     if t.u_power < 0 else U ** t.u_power)
        for x, p in zip((q1, q2, v1, v2, Ed), (*t.powers, t.forcing[1])):
            if p:
                m = m * x**p
        out[t.equation - 1] -= m
    return out[0], out[1]


def motion_validity(d, states, U, Ed=0.0) -> dict:
    """Validity of a motion (module docstring): ``states`` an (n, 4) array of (q1, q2, q1', q2'),
    ``U`` the wind (units of U_c, a number or n values), ``Ed`` = eta f' (support velocity, 0 for
    galloping). Plain JSON-able values; nothing is judged at U = 0 but the twist."""
    Y = np.atleast_2d(np.asarray(states, dtype=float))
    if Y.shape[-1] != 4:
        raise ValueError(f"states must be (n, 4) samples of (q1, q2, q1', q2'), got shape {Y.shape}")
    ex = exact_load_for(d)
    U = np.broadcast_to(np.asarray(U, dtype=float), Y.shape[:1])
    Ed = np.broadcast_to(np.asarray(Ed, dtype=float), Y.shape[:1])
    finite = np.all(np.isfinite(Y), axis=1) & np.isfinite(U)
    if not finite.any():
        return {"phi_range_deg": None, "phi_swept_deg": None, "twist_max_deg": None, "valid_phi_deg": None,
                "cubic_load_error": None, "beyond_valid_range": True, "reasons": ["no finite state"]}
    Y, U, Ed = Y[finite], U[finite], Ed[finite]
    phi, theta = section_angles(ex, Y[:, 1], Y[:, 2], Y[:, 3], U, Ed)
    phi0 = ex.static_angle
    lo, hi = valid_phi_of(ex)
    wind = U != 0.0
    reasons = []
    # the peak over the span, not over the nodes (theta = theta2(s) q2: its largest is max|q2| times
    # theta2's own peak)
    out = {"twist_max_deg": float(np.degrees(float(np.max(np.abs(Y[:, 1]))) * twist_peak(d))),
           # an unbounded side (a periodic table holds at every angle) is null in JSON
           "valid_phi_deg": [math.degrees(x) if math.isfinite(x) else None for x in (lo, hi)],
           "load": "exact" if d.ode.exact_load is not None else "cubic"}
    if wind.any():
        p = phi[wind]
        pmin, pmax = float(np.min(p)), float(np.max(p))
        out["phi_range_deg"] = [math.degrees(pmin), math.degrees(pmax)]
        out["phi_swept_deg"] = float(np.degrees(np.max(np.abs(p - phi0))))
        if pmin < lo or pmax > hi:
            reasons.append(f"phi reached {math.degrees(pmin):.1f} to {math.degrees(pmax):.1f} deg, outside "
                           f"the curves' valid range {math.degrees(lo):.1f} to {math.degrees(hi):.1f} deg")
        e1, e2 = forces(ex, Y[wind, 1], Y[wind, 2], Y[wind, 3], U[wind], Ed[wind])
        c1, c2 = cubic_aero_forces(d.ode, *Y[wind].T, U[wind], Ed[wind])
        scale = max(float(np.max(np.abs(e1))), float(np.max(np.abs(e2))), 1e-300)
        err = max(float(np.max(np.abs(c1 - e1))), float(np.max(np.abs(c2 - e2)))) / scale
        out["cubic_load_error"] = err
        if d.ode.exact_load is None and err > CUBIC_RTOL:
            reasons.append(f"the cubic load of eq. (14) is {100 * err:.0f} % off the exact load along the motion "
                           f"(bound {100 * CUBIC_RTOL:.0f} %): use aero.load = \"exact\"")
    else:
        out.update(phi_range_deg=None, phi_swept_deg=0.0, cubic_load_error=None)
    out["beyond_valid_range"] = bool(reasons)
    out["reasons"] = reasons
    return out


def validity_line(v: dict) -> str:
    """One line for a report: the swept angle, the twist and the verdict."""
    if v.get("phi_swept_deg") is None:
        return f"validity: {'; '.join(v.get('reasons', [])) or 'not measured'}"
    lo, hi = ("-inf" if x is None else f"{x:.1f}" for x in v["valid_phi_deg"])
    text = (f"validity: phi swept +-{v['phi_swept_deg']:.1f} deg (valid {lo} to {hi} deg), "
            f"twist up to {v['twist_max_deg']:.1f} deg")
    if v.get("cubic_load_error") is not None:
        text += f", cubic load error {100 * v['cubic_load_error']:.2g} %"
    return text + (": BEYOND THE MODEL'S RANGE (" + "; ".join(v["reasons"]) + ")" if v["beyond_valid_range"]
                   else ": inside")
