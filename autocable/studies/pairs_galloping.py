"""The mode-pair table with its galloping columns: `autocable onset --modes-below F --design-wind U`.

`autocable.studies.onset.pairs_below` gives each pair's linear onset and linear least damping; here
each pair that gallops is continued (`autocable.studies.gallop`): its lowest galloping speed, the
largest stable cycle at the design wind (peak mid-span, m, in-plane and out-of-plane, with its
validity) and the global least damping (no cycle up to the design wind). Kept apart from both
modules because it needs both (the studies import no circle)."""
from __future__ import annotations

from autocable.errors import ComputationError
from autocable.spec import SpecError
from autocable.studies.gallop import DampedSystem, gallop_study, least_damping_global
from autocable.studies.onset import pair_spec, pairs_below, with_damper


def pairs_with_galloping(d, below_hz: float, design_wind_m_s: float | None, U_max: float, log=None) -> dict:
    """`pairs_below` with ``least_damping_global``, ``amplitude_at_design_wind_m``,
    ``lowest_galloping_U_m_s`` and ``beyond_valid_range`` filled for every pair (the galloping
    study looks for Hopf points beyond the scanned winds too)."""
    from autocable.model.derive import derive
    from autocable.model.units import units_of
    report = pairs_below(d, below_hz, design_wind_m_s, U_max)
    if design_wind_m_s is None:
        return report
    U_max_m_s = units_of(d.spec, d.statics).wind_m_s(U_max)
    for row in report["pairs"]:
        row.update(lowest_galloping_U_m_s=None, lowest_galloping_U_bound=None, lowest_galloping_U_at_most_m_s=None,
                   beyond_valid_range=None)
        # a pair stable over the scanned winds may still have a Hopf point above them whose
        # sub-critical branch folds back below the design wind: the continuation looks for it
        dk = d if row["k"] == d.mode_pair else derive(pair_spec(d.spec, row["k"]))
        if log:
            log(f"pair {row['k']}: galloping branch and global least damping")
        if row.get("damper_note"):      # the pair's damping with the damper is not known: nothing to continue
            row["galloping_note"] = row["damper_note"]
            continue
        try:
            # the model's [damper] in the pair's modal damping, as in its linear columns (`with_damper`)
            dk, _ = with_damper(dk)
            # one compiled system for the pair's every damping ratio: the study's and least_damping_global's
            shared = DampedSystem(dk.ode)
            g = gallop_study(dk, design_wind_m_s, U_max_m_s=U_max_m_s, checks=False, shared=shared)
            row["lowest_galloping_U_m_s"] = g.get("lowest_galloping_U_m_s")
            # null above where a branch is still descending when it ends: the bound and why
            row["lowest_galloping_U_bound"] = g.get("lowest_galloping_U_bound")
            row["lowest_galloping_U_at_most_m_s"] = g.get("lowest_galloping_U_at_most_m_s")
            if g.get("lowest_galloping_note"):
                row["lowest_galloping_note"] = g["lowest_galloping_note"]
            row["amplitude_at_design_wind_m"] = g.get("amplitude_at_design_wind_m")
            row["envelope_at_design_wind_m"] = g.get("envelope_at_design_wind_m")
            row["beyond_valid_range"] = g.get("beyond_valid_range")
            cycle = ((g.get("cases") or [{}])[0].get("design_cycle")) or {}
            row["phi_swept_deg"] = cycle.get("phi_swept_deg")
            row["twist_max_deg"] = cycle.get("twist_max_deg")
            row["design_verdict"] = g.get("design_verdict")
            row["missing_ingredient"] = [m["ingredient"] for m in g.get("missing_ingredient") or []]
            lg = least_damping_global(dk, design_wind_m_s, U_max_m_s, shared=shared)
            row["least_damping_global"] = lg["least_damping_ratio_global"]
            row["least_damping_global_beyond_valid_range"] = lg.get("beyond_valid_range")
            row["least_damping_global_at_least"] = lg["at_least"]
            if g.get("off_branch_cycle"):
                row["off_branch_cycle"] = g["off_branch_cycle"]
        except (SpecError, ComputationError) as exc:
            row["galloping_note"] = str(exc)
    report.pop("pending_columns", None)
    report["conventions"].update({
        "least_damping_global": "the least damping ratio for which no galloping cycle of the pair exists up to the "
                                "design wind (autocable.studies.gallop.least_damping_global)",
        "amplitude_at_design_wind_m": "[in-plane, out-of-plane] peak mid-span of the largest stable galloping cycle "
                                      "at the design wind (null: none there)",
        "lowest_galloping_U_m_s": "the lowest wind speed on the pair's galloping branch (a cycle fold below a "
                                  "sub-critical onset); null where a branch is still descending when it ends (the "
                                  "scan's lower bound reached without a fold), lowest_galloping_U_bound then says "
                                  "\"at most X m/s\" and lowest_galloping_note why",
        "beyond_valid_range": "the design-wind cycle leaves the aerodynamic curves' valid range or the cubic "
                              "load's (autocable.model.validity)",
        "phi_swept_deg": "max |phi - phi0| along the design-wind cycle [deg] (null: no stable cycle there)",
        "twist_max_deg": "the largest twist along the design-wind cycle [deg]",
        "missing_ingredient": "what the model lacks for the design-wind motion (autocable gallop): the twist, "
                              "the curves, the load or more modes",
        "least_damping_global_beyond_valid_range": "the cycle that sets the global least damping leaves the "
                                                   "model's range (the bound does not hold within validity)"})
    return report


def galloping_lines(report: dict) -> list[str]:
    """The galloping columns of the table, one line per pair (after `pairs_text`)."""
    if report.get("design_wind_m_s") is None:
        return []
    des = report["design_wind_m_s"]
    lines = [f"  galloping (eq. 21 cycles, autocable gallop) with the design wind {des:g} m/s:",
             "   k  lowest U [m/s]  peak at design wind [m] (in / out)  least xi, global  validity"]
    for r in report["pairs"]:
        low = r.get("lowest_galloping_U_m_s")
        amp = r.get("amplitude_at_design_wind_m")
        xi = r.get("least_damping_global")
        amp_text = f"{amp[0]:.3g} / {amp[1]:.3g}" if amp else "-"
        valid = {True: "BEYOND the model's range", False: "inside", None: "-"}[r.get("beyond_valid_range")]
        if r.get("phi_swept_deg") is not None:
            valid += f" (phi +-{r['phi_swept_deg']:.3g} deg, twist {r.get('twist_max_deg') or 0.0:.2g} deg)"
        if r.get("missing_ingredient"):
            valid += "; missing: " + ", ".join(r["missing_ingredient"])
        if r.get("least_damping_global_beyond_valid_range"):
            valid += "; global xi set beyond the range"
        at_most = r.get("lowest_galloping_U_at_most_m_s")
        if low is not None:
            line = f"  {r['k']:2d}  {low:14.4g}"
        elif at_most is not None:        # not known: a bound (the branch did not turn)
            line = f"  {r['k']:2d}  {'<= ' + format(at_most, '.3g'):>14}"
        else:
            line = f"  {r['k']:2d}  {'-':>14}"
        if r.get("off_branch_cycle"):
            valid += "; design cycle off the branches (found by integration)"
        env = r.get("envelope_at_design_wind_m")
        if env and amp and env != amp:
            valid += f"; another stable cycle: envelope {env[0]:.3g} / {env[1]:.3g} m"
        xi_text = f"{'>= ' if r.get('least_damping_global_at_least') else ''}{100 * xi:.4g} %" if xi is not None else "-"
        line += f"  {amp_text:>34}  {xi_text:>16}  {valid}"
        if r.get("galloping_note") and low is None:
            line += f"  ({r['galloping_note']})"
        lines.append(line)
    notes: dict = {}            # one line per reason (every pair of a stay often has the same)
    for r in report["pairs"]:
        if r.get("lowest_galloping_note"):
            known = r.get("lowest_galloping_U_m_s") is not None
            notes.setdefault((known, r["lowest_galloping_note"]), []).append(str(r["k"]))
    for (known, note), ks in notes.items():
        lines.append(f"  lowest U of pair{'s' if len(ks) > 1 else ''} {', '.join(ks)}: {'' if known else 'not known, '}{note}")
    if any(r.get("least_damping_global_at_least") for r in report["pairs"]):
        lines.append("  >= : at that damping a stable cycle off the branches from the Hopf points still gallops just "
                     "below the design wind (found by integration): more damping is needed")
    return lines
