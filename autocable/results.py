"""Results of autocable runs as plain, immutable records, and their files (CSV tables, JSON metadata).

A `Branch` is one continued solution family: equilibria of the amplitude equations (eq. 24 of
Luongo & Zulli: period-1 motions of eq. 21) or periodic orbits of them (quasi-periodic motions of
eq. 21). It carries its columns (every parameter of the system, the peak modal amplitudes a1, a2,
the Cartesian state r1, s1, r2, s2, and for cycles the period and the min/max of a1, a2 over the
cycle), an explicit `stable` column, the eigenvalues (equilibria) or Floquet multipliers (cycles)
at every point, its labelled `SpecialPoint`s and how each end of it came about (`EndPoint`).
A two-parameter curve (``kind = "fold"``, ``"hopf"`` or ``"branch_point"``: the locus of folds,
Hopf points or symmetry-breaking pitchforks of the equilibria,
`autocable.methods.continuation.continue_folds` / ``continue_hopf`` / ``continue_branch_points``)
is a `Branch` too:
its ``parameter`` and ``parameter2`` both vary along it, ``stable`` says whether every eigenvalue
except the critical one(s) has a negative real part (the bifurcation happens on an otherwise stable
equilibrium), and its special points are codimension-2 points (CP, BT, GH, ZH, DH).
`RunResults` bundles the branches of one run with the provenance (model hash, scene, versions, wall
time per stage).

Files in an output folder (written atomically, read back by `read_results`):

* ``branches.csv``: one row per point: ``branch, kind, parameter, parameter2, point``, every system
  parameter by its name (``sigma, U, eta`` for the cable), ``a1, a2, stable, period, a1_min, a1_max,
  a2_min, a2_max``, ``det_J, omega, check_residual`` (two-parameter curves: det J of the Jacobian,
  the Hopf frequency, and the independent check's residual), the state, ``max_real`` (equilibria: the largest real part of an eigenvalue; cycles: the
  largest modulus of a non-trivial multiplier) and ``ev<k>_re, ev<k>_im``.
* ``special_points.csv``: ``branch, type, label, parameter``, every system parameter, ``a1, a2``,
  the state, ``converged, confirmed_by_pycont, origin, l1, criticality, omega, period, message``
  (``criticality``: "supercritical" or "subcritical" at a Hopf point by the sign of its first
  Lyapunov coefficient l1, empty elsewhere). ``parameter``
  is the branch's first parameter; on a two-parameter curve ``parameters`` holds both values.
* Both tables end, when the run's provenance carries the cable's scales (``si_scales``, ``omega1``),
  with the same points in SI (`autocable.model.units.SI_COLUMNS`): ``U_m_s, eta_m, Omega_Hz,
  peak_in_plane_m, peak_out_of_plane_m`` (peak displacements a_k l at mid-span).
* The DataFrames (`Branch.to_dataframe`, `RunResults.to_dataframe`: ``branches.csv``'s columns)
  end with three columns of their own, from the special points: ``special`` (the label at a
  special point's row), ``l1`` and ``criticality`` (at a Hopf point's row).
* ``run.json``: provenance, per-branch metadata (ends, diagnostics) and every special point with
  its ``extra`` data; ``status`` (``"complete"`` only for a run that finished) and ``files`` (the
  other files of the run, the manifest). It is written last.

A branch that stopped at its point budget (an `EndPoint` with reason ``"max_points"``) before the
end of its range is *truncated*: `Branch.truncated` lists those ends, the DataFrames name them in
``frame.attrs["truncated"]``, the plots mark them, and the continuation warns
(`TruncatedBranchWarning`) when it happens.

A run writes into a staging folder inside its output folder and publishes from there
(`autocable.run_folder.output_folder`): the folder reads as complete (`is_complete`) only once run.json says so, and a
rerun replaces only the files an earlier run listed (docs/robustness.md, "Output folders").

This module imports neither PyDSTool nor matplotlib.
"""
from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Iterable, Mapping, Sequence

import numpy as np

from autocable._store import atomic_write_json, atomic_write_text, read_json

__all__ = [
    "KINDS",
    "CURVE_KINDS",
    "SPECIAL_TYPES",
    "END_REASONS",
    "SpecialPoint",
    "EndPoint",
    "Branch",
    "RunResults",
    "write_results",
    "branches_dataframe",
    "stability_measure",
    "read_results",
    "BRANCHES_CSV",
    "SPECIAL_CSV",
    "RUN_JSON",
    "STATUS_COMPLETE",
    "IncompleteResults",
    "run_status",
    "is_complete",
    "status_of",
    "TruncatedBranchWarning",
    "hopf_criticality",
    "truncation_notes",
    "FRAME_SPECIAL_COLUMNS",
]

#: Branch kinds.
KINDS = ("equilibrium", "cycle", "fold", "hopf", "branch_point")
#: Two-parameter curves (both ``parameter`` and ``parameter2`` vary along them).
CURVE_KINDS = ("fold", "hopf", "branch_point")
#: Special-point types: fold (LP), Hopf (H), branch point (BP) of equilibria; fold (LPC), period
#: doubling (PD) and Neimark-Sacker (NS) of cycles; the range end (B) and the start point (S); on
#: two-parameter curves: cusp (CP), Bogdanov-Takens (BT), generalized Hopf (GH), zero-Hopf (ZH),
#: double Hopf (DH).
SPECIAL_TYPES = ("LP", "H", "BP", "LPC", "PD", "NS", "B", "S", "CP", "BT", "GH", "ZH", "DH")
#: Why a branch ended, with what to try when the end was not wanted.
END_REASONS = MappingProxyType({
    "range": "the continued parameter reached the end of the range",
    "closed": "the branch closed on itself (an isola or a loop)",
    "max_points": "the maximum number of points was reached: raise max_points or the step",
    "step_collapse": "the step size fell below the minimum without convergence: lower min_step, "
                     "or the branch may end at a singular point (a fold with a large step, a "
                     "singularity of the equations)",
    "no_convergence": "the corrector did not converge: lower the step sizes or tighten the start",
    "period_blowup": "the period grew without bound: the cycles approach a homoclinic orbit",
    "error": "the continuation engine failed (see the message)",
    "neutral_saddle": "the Hopf curve reached a Bogdanov-Takens point: beyond it the critical pair is "
                      "real (lambda, -lambda), a neutral saddle, not a Hopf point",
    "not_run": "this direction was not run",
})

BRANCHES_CSV = "branches.csv"
SPECIAL_CSV = "special_points.csv"
RUN_JSON = "run.json"
#: run.json's ``status`` of a run that finished; anything else ("running", "failed",
#: "interrupted", none at all) reads as incomplete.
STATUS_COMPLETE = "complete"

_CYCLE_COLUMNS = ("period", "a1_min", "a1_max", "a2_min", "a2_max")
_CURVE_COLUMNS = ("det_J", "omega", "check_residual")


def _frozen_array(values, dtype=float) -> np.ndarray:
    arr = np.array(values, dtype=dtype)
    arr.setflags(write=False)
    return arr


class TruncatedBranchWarning(UserWarning):
    """A branch stopped at its point budget (``max_points``) before the end of its range: what it
    shows is part of the solution family, not all of it."""


def hopf_criticality(l1) -> str:
    """The criticality of a Hopf point from its first Lyapunov coefficient ``l1`` (Kuznetsov's
    normalisation, Elements of Applied Bifurcation Theory, Sect. 3.5): "supercritical" (l1 < 0: a
    stable cycle is born, the amplitude grows continuously), "subcritical" (l1 > 0: an unstable
    cycle, the response jumps), "degenerate" (l1 = 0: a generalized Hopf point), "" without a
    finite l1."""
    try:
        v = float(l1)
    except (TypeError, ValueError):
        return ""
    if not math.isfinite(v):
        return ""
    return "supercritical" if v < 0 else "subcritical" if v > 0 else "degenerate"


def _g(x) -> str:
    """A number in at most 4 significant digits (reprs and summaries)."""
    try:
        return f"{float(x):.4g}"
    except (TypeError, ValueError):
        return str(x)


def _short(text: str, n: int = 40) -> str:
    text = str(text)
    return text if len(text) <= n else text[:n - 3] + "..."


def finite_or_none(x):
    if x is None:
        return None
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    if isinstance(x, complex):
        return [finite_or_none(x.real), finite_or_none(x.imag)]
    if isinstance(x, Mapping):
        return {str(k): finite_or_none(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [finite_or_none(v) for v in x]
    return x


@dataclass(frozen=True)
class SpecialPoint:
    """A labelled point of a branch (BifurcationKit-style: type, location, whether it converged).

    ``origin`` is ``"autocable"`` for points located by autocable's own test functions (and refined
    on the branch), ``"pycont"`` for points only PyCont reported (autocable's test functions show no
    sign change there: a point PyCont invents). ``confirmed_by_pycont`` says whether PyCont's own
    list has the same point (None where PyCont was not asked, e.g. cycles' labels from multipliers
    when AUTO reports none). ``extra`` holds type-specific data: ``l1`` (first Lyapunov coefficient,
    Kuznetsov's normalisation) and ``omega`` at H, ``eigenvalues``, ``period`` at cycle points.
    """

    branch: str
    type: str
    label: str
    parameter: str
    value: float
    a1: float
    a2: float
    state: tuple[float, ...]
    parameters: Mapping[str, float]
    index: int = -1                      # index of the nearest branch point (the point before it)
    converged: bool = True
    confirmed_by_pycont: bool | None = None
    origin: str = "autocable"
    message: str = ""
    extra: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "state", tuple(float(v) for v in self.state))
        object.__setattr__(self, "parameters", MappingProxyType(dict(self.parameters)))
        object.__setattr__(self, "extra", MappingProxyType(dict(self.extra)))

    @property
    def name(self) -> str:
        """``<branch>:<label>``, the name a scene uses to start from this point."""
        return f"{self.branch}:{self.label}"

    @property
    def criticality(self) -> str:
        """At a Hopf point (type H): "supercritical" or "subcritical" by the sign of ``extra["l1"]``
        (`hopf_criticality`); "" at any other point or without l1."""
        return hopf_criticality(self.extra.get("l1")) if self.type == "H" else ""

    @property
    def hopf_text(self) -> str:
        """``"subcritical, l1 = 2.35e+04"`` at a Hopf point with l1, else "" (labels, summaries)."""
        crit = self.criticality
        return f"{crit}, l1 = {float(self.extra['l1']):.3g}" if crit else ""

    def __repr__(self) -> str:
        hopf = f", {self.hopf_text}" if self.hopf_text else ""
        return (f"SpecialPoint({_short(self.name, 50)}: {self.type} at {self.parameter} = {_g(self.value)}, "
                f"a1 = {_g(self.a1)}, a2 = {_g(self.a2)}{hopf})")

    def to_dict(self) -> dict:
        return {"branch": self.branch, "type": self.type, "label": self.label,
                "parameter": self.parameter, "value": self.value, "a1": self.a1, "a2": self.a2,
                "state": list(self.state), "parameters": dict(self.parameters),
                "index": self.index, "converged": self.converged,
                "confirmed_by_pycont": self.confirmed_by_pycont, "origin": self.origin,
                "message": self.message, "extra": finite_or_none(dict(self.extra))}

    @classmethod
    def from_dict(cls, d: Mapping) -> "SpecialPoint":
        def num(x):
            return math.nan if x is None else float(x)
        return cls(branch=d["branch"], type=d["type"], label=d["label"], parameter=d["parameter"],
                   value=num(d["value"]), a1=num(d["a1"]), a2=num(d["a2"]),
                   state=tuple(num(v) for v in d["state"]),
                   parameters={k: num(v) for k, v in d["parameters"].items()},
                   index=int(d.get("index", -1)), converged=bool(d.get("converged", True)),
                   confirmed_by_pycont=d.get("confirmed_by_pycont"),
                   origin=d.get("origin", "autocable"), message=d.get("message", ""),
                   extra=dict(d.get("extra") or {}))


@dataclass(frozen=True)
class EndPoint:
    """How one end of a branch came about: ``reason`` is a key of `END_REASONS`."""

    side: str            # "forward" | "backward" (relative to the start) or "+"/"-" after a BP
    reason: str
    value: float         # parameter value at the last point kept
    points: int          # points computed on this side
    message: str = ""

    def __post_init__(self):
        if self.reason not in END_REASONS:
            raise ValueError(f"unknown end reason {self.reason!r}; use one of {sorted(END_REASONS)}")

    @property
    def hint(self) -> str:
        return END_REASONS[self.reason]

    @property
    def truncated(self) -> bool:
        """Whether this end is the point budget's (``max_points``): the branch goes on beyond it."""
        return self.reason == "max_points"

    def __repr__(self) -> str:
        return f"EndPoint({self.side}: {self.reason} at {_g(self.value)}, {self.points} points)"

    def to_dict(self) -> dict:
        return {"side": self.side, "reason": self.reason, "value": finite_or_none(self.value),
                "points": self.points, "message": self.message, "hint": self.hint}

    @classmethod
    def from_dict(cls, d: Mapping) -> "EndPoint":
        v = d.get("value")
        return cls(d["side"], d["reason"], math.nan if v is None else float(v), int(d["points"]),
                   d.get("message", ""))


@dataclass(frozen=True)
class Branch:
    """One continued branch (see the module docstring for its columns).

    ``table`` maps column names to read-only float arrays of equal length: every name in
    ``parameter_names``, the ``amplitude_names`` (a1, a2), the ``variables`` (r1, s1, ...), for
    cycles ``period, a1_min, a1_max, a2_min, a2_max`` (a1, a2 of a cycle are its maxima), and for
    two-parameter curves (``kind`` "fold" or "hopf", second parameter ``parameter2``) ``det_J,
    omega, check_residual``.
    ``eigenvalues[i]`` are those of point i (equilibria: of the Jacobian, by decreasing real part;
    cycles: the Floquet multipliers, by decreasing modulus). ``stable`` is autocable's verdict from
    them, never PyCont's flag.
    """

    name: str
    kind: str
    parameter: str
    parameter_names: tuple[str, ...]
    variables: tuple[str, ...]
    amplitude_names: tuple[str, ...]
    table: Mapping[str, np.ndarray]
    stable: np.ndarray
    eigenvalues: np.ndarray
    special_points: tuple[SpecialPoint, ...] = ()
    ends: tuple[EndPoint, ...] = ()
    info: Mapping[str, Any] = field(default_factory=dict)
    parameter2: str = ""                 # the second parameter of a two-parameter curve

    def __post_init__(self):
        if self.kind not in KINDS:
            raise ValueError(f"branch kind must be one of {KINDS}, got {self.kind!r}")
        if (self.kind in CURVE_KINDS) != bool(self.parameter2):
            raise ValueError(f"branch {self.name!r}: a {self.kind} branch "
                             + ("needs a second parameter" if self.kind in CURVE_KINDS else "has no second parameter"))
        table = {str(k): _frozen_array(v) for k, v in self.table.items()}
        lengths = {len(v) for v in table.values()}
        if len(lengths) > 1:
            raise ValueError(f"branch {self.name!r}: columns of unequal length {sorted(lengths)}")
        n = lengths.pop() if lengths else 0
        for col in (self.parameter, *((self.parameter2,) if self.parameter2 else ()),
                    *self.amplitude_names, *self.variables):
            if col not in table:
                raise ValueError(f"branch {self.name!r}: missing column {col!r}")
        stable = _frozen_array(self.stable, dtype=bool)
        if len(stable) != n:
            raise ValueError(f"branch {self.name!r}: {n} points but {len(stable)} stability flags")
        ev = np.array(self.eigenvalues, dtype=complex)
        if ev.size == 0:
            ev = ev.reshape(n, 0)
        if ev.shape[0] != n:
            raise ValueError(f"branch {self.name!r}: {n} points but {ev.shape[0]} eigenvalue rows")
        ev.setflags(write=False)
        object.__setattr__(self, "table", MappingProxyType(table))
        object.__setattr__(self, "stable", stable)
        object.__setattr__(self, "eigenvalues", ev)
        object.__setattr__(self, "parameter_names", tuple(self.parameter_names))
        object.__setattr__(self, "variables", tuple(self.variables))
        object.__setattr__(self, "amplitude_names", tuple(self.amplitude_names))
        object.__setattr__(self, "special_points", tuple(self.special_points))
        object.__setattr__(self, "ends", tuple(self.ends))
        object.__setattr__(self, "info", MappingProxyType(dict(self.info)))

    def __len__(self) -> int:
        return len(self.stable)

    def __repr__(self) -> str:
        n = len(self)
        if n:
            v = np.asarray(self.values, float)
            span = f"{self.parameter} in [{_g(np.nanmin(v))}, {_g(np.nanmax(v))}]" if np.any(np.isfinite(v)) \
                else f"{self.parameter} not finite"
        else:
            span = f"{self.parameter}: no point"
        if self.parameter2:
            span += f" x {self.parameter2}"
        labels = [sp.label for sp in self.special_points]
        shown = " ".join(labels[:6]) + (f" +{len(labels) - 6}" if len(labels) > 6 else "")
        ends = "/".join(e.reason for e in self.ends[:2]) or "none"
        return (f"Branch({_short(self.name, 30)!r}, {self.kind}, {n} points, {span}, "
                f"special: {shown or 'none'}, ends: {ends})")

    @property
    def truncated(self) -> tuple[EndPoint, ...]:
        """The ends at which the branch stopped at its point budget (``max_points``) rather than at
        the range, a closure or a failure: the solution family goes on beyond them."""
        return tuple(e for e in self.ends if e.truncated)

    def end_index(self, end: EndPoint) -> int:
        """The row of the branch's point at ``end``: the first row for the side continued backwards
        ("backward", or "-" after a branch point), the last row otherwise."""
        return 0 if end.side in ("backward", "-") else len(self) - 1

    def __getitem__(self, column: str) -> np.ndarray:
        return self.table[column]

    @property
    def values(self) -> np.ndarray:
        """The continued parameter along the branch."""
        return self.table[self.parameter]

    @property
    def states(self) -> np.ndarray:
        """(points, variables) array of the state (for cycles: the state at the cycle's phase origin)."""
        return np.column_stack([self.table[v] for v in self.variables]) if self.variables else \
            np.zeros((len(self), 0))

    def special(self, label: str) -> SpecialPoint:
        """The special point labelled ``label`` (e.g. ``"H1"``)."""
        for sp in self.special_points:
            if sp.label == label:
                return sp
        known = ", ".join(sp.label for sp in self.special_points) or "none"
        raise KeyError(f"branch {self.name!r} has no special point {label!r} (it has: {known})")

    def of_type(self, kind: str) -> tuple[SpecialPoint, ...]:
        return tuple(sp for sp in self.special_points if sp.type == kind)

    def to_dataframe(self):
        """This branch as a pandas DataFrame with the columns and values of its rows in
        ``branches.csv`` (`branches_dataframe`; a branch alone has no run's SI scales:
        `RunResults.to_dataframe` adds those columns), then ``special``, ``l1`` and
        ``criticality`` (a special point's label at its row; a Hopf point's first Lyapunov
        coefficient and "supercritical"/"subcritical"). ``frame.attrs["truncated"]``: its ends at the
        point budget (`truncation_notes`), empty when it is whole."""
        return branches_dataframe([self])

    def replace(self, **changes) -> "Branch":
        data = {f: getattr(self, f) for f in self.__dataclass_fields__}
        data.update(changes)
        return Branch(**data)

    def metadata(self) -> dict:
        return {"name": self.name, "kind": self.kind, "parameter": self.parameter,
                **({"parameter2": self.parameter2} if self.parameter2 else {}),
                "parameter_names": list(self.parameter_names), "variables": list(self.variables),
                "amplitude_names": list(self.amplitude_names), "points": len(self),
                "ends": [e.to_dict() for e in self.ends], "info": finite_or_none(dict(self.info)),
                "special_points": [sp.label for sp in self.special_points]}


@dataclass(frozen=True)
class RunResults:
    """The branches of one run (a scene) and where they came from."""

    name: str
    branches: tuple[Branch, ...]
    provenance: Mapping[str, Any] = field(default_factory=dict)

    def __post_init__(self):
        object.__setattr__(self, "branches", tuple(self.branches))
        object.__setattr__(self, "provenance", MappingProxyType(dict(self.provenance)))

    def __repr__(self) -> str:
        parts = ", ".join(f"{_short(b.name, 16)}: {len(b)}" for b in self.branches[:4])
        more = f", +{len(self.branches) - 4}" if len(self.branches) > 4 else ""
        rng = self.provenance.get("range")
        span = ""
        if isinstance(rng, (list, tuple)) and len(rng) == 2:
            span = f", range [{_g(rng[0])}, {_g(rng[1])}]"
        cut = sum(len(b.truncated) for b in self.branches)
        return (f"RunResults({_short(self.name, 30)!r}, {len(self.branches)} branches ({parts}{more}), "
                f"{len(self.special_points)} special points{span}"
                + (f", {cut} truncated end(s)" if cut else "") + ")")

    def branch(self, name: str) -> Branch:
        for b in self.branches:
            if b.name == name:
                return b
        raise KeyError(f"no branch {name!r} (there are: {', '.join(b.name for b in self.branches)})")

    @property
    def special_points(self) -> tuple[SpecialPoint, ...]:
        return tuple(sp for b in self.branches for sp in b.special_points)

    def to_dataframe(self):
        """Every branch as one pandas DataFrame: the columns and values of ``branches.csv``
        (`branches_dataframe`), with its SI columns when the provenance has the scales, then
        ``special``, ``l1``, ``criticality`` (the Hopf criticality at a Hopf point's row);
        ``frame.attrs["truncated"]`` names every branch end at the point budget (`truncation_notes`)."""
        return branches_dataframe(self.branches, _si(self.provenance))

    def special_points_dataframe(self):
        """The special points as a pandas DataFrame with the columns of ``special_points.csv``."""
        import pandas as pd
        frame = pd.read_csv(io.StringIO(special_points_csv(self.special_points, self.branches, _si(self.provenance))),
                            float_precision="round_trip")   # the CSV writes repr: read back exactly
        frame["criticality"] = frame["criticality"].fillna("").astype(str)   # an empty column reads as NaN
        return frame

    def special(self, name: str) -> SpecialPoint:
        """A special point by ``<branch>:<label>``."""
        branch, _, label = name.partition(":")
        return self.branch(branch).special(label)


def stability_measure(kind: str, eigenvalues) -> float:
    """Equilibria: the largest real part of an eigenvalue (stable if < 0). Cycles: the largest
    modulus of a non-trivial Floquet multiplier (stable if < 1); the trivial multiplier is the one
    nearest to 1."""
    ev = np.asarray(eigenvalues, dtype=complex).ravel()
    ev = ev[np.isfinite(ev)]
    if ev.size == 0:
        return math.nan
    if kind in ("equilibrium",) + CURVE_KINDS:
        return float(np.max(ev.real))
    rest = np.delete(ev, int(np.argmin(np.abs(ev - 1.0))))
    return float(np.max(np.abs(rest))) if rest.size else math.nan


# -- writing ----------------------------------------------------------------------------------------
def _fmt(x) -> str:
    if x is None:
        return ""
    if isinstance(x, (bool, np.bool_)):
        return "1" if x else "0"
    if isinstance(x, (int, np.integer)):
        return str(int(x))
    if isinstance(x, str):
        return x
    x = float(x)
    return repr(x) if math.isfinite(x) else ("" if math.isnan(x) else repr(x))


def _union(seqs: Iterable[Sequence[str]]) -> list[str]:
    out: list[str] = []
    for seq in seqs:
        for s in seq:
            if s not in out:
                out.append(s)
    return out


def _si(provenance) -> tuple | None:
    """(units, omega1) from a run's provenance (``si_scales``, ``omega1``), or None without them."""
    from autocable.model.units import units_from_dict
    if not provenance or not provenance.get("si_scales") or provenance.get("omega1") is None:
        return None
    return units_from_dict(provenance["si_scales"]), float(provenance["omega1"])


def _si_row(si, values: Mapping) -> list:
    """The `SI_COLUMNS` of one point (``values``: U, eta, sigma, a1, a2); empty where one is missing."""
    from autocable.model.units import SI_COLUMNS, si_columns
    if si is None:
        return []
    x = {k: values.get(k) for k in ("U", "eta", "sigma", "a1", "a2")}
    if any(v is None for v in x.values()):
        return [None] * len(SI_COLUMNS)
    cols = si_columns(si[0], si[1], *(float(x[k]) for k in ("U", "eta", "sigma", "a1", "a2")))
    return [cols[c] for c in SI_COLUMNS]


def _branch_rows(branches: Sequence[Branch], si=None) -> tuple[list[str], Iterable[list]]:
    """The header of ``branches.csv`` and its rows as Python values (None where a cell is empty):
    the one definition of the table that the CSV file and the DataFrames share; with ``si`` =
    (units, omega1), the `autocable.model.units.SI_COLUMNS` at the end."""
    from autocable.model.units import SI_COLUMNS
    params = _union(b.parameter_names for b in branches)
    amps = _union([("a1", "a2")] + [b.amplitude_names for b in branches])
    states = _union(b.variables for b in branches)
    nev = max((b.eigenvalues.shape[1] for b in branches), default=0)
    known = set(params) | set(amps) | set(states) | set(_CYCLE_COLUMNS) | set(_CURVE_COLUMNS)
    # any further table column (e.g. the twist a scene adds), after the eigenvalues, in order
    extra = _union([c for c in b.table if c not in known] for b in branches)
    header = (["branch", "kind", "parameter", "parameter2", "point"] + params + amps
              + ["stable", *_CYCLE_COLUMNS, *_CURVE_COLUMNS] + states + ["max_real"] + [f"ev{k}_{part}" for k in range(1, nev + 1) for part in ("re", "im")]
              + extra + (list(SI_COLUMNS) if si else []))

    def rows():
        for b in branches:
            for i in range(len(b)):
                ev = b.eigenvalues[i]
                max_real = stability_measure(b.kind, ev)
                row = [b.name, b.kind, b.parameter, b.parameter2, i]
                row += [b.table[p][i] if p in b.table else None for p in params]
                row += [b.table[a][i] if a in b.table else None for a in amps]
                row += [bool(b.stable[i])]
                row += [b.table[c][i] if c in b.table else None for c in _CYCLE_COLUMNS + _CURVE_COLUMNS]
                row += [b.table[s][i] if s in b.table else None for s in states]
                row += [max_real]
                for k in range(nev):
                    if k < ev.size:
                        row += [ev[k].real, ev[k].imag]
                    else:
                        row += [None, None]
                row += [b.table[c][i] if c in b.table else None for c in extra]
                row += _si_row(si, {k: b.table[k][i] for k in ("U", "eta", "sigma", "a1", "a2") if k in b.table})
                yield row
    return header, rows()


def branches_csv(branches: Sequence[Branch], si=None) -> str:
    """The text of ``branches.csv`` (see the module docstring); with ``si`` = (units, omega1), the
    `autocable.model.units.SI_COLUMNS` at the end."""
    header, rows = _branch_rows(branches, si)
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for row in rows:
        w.writerow([_fmt(x) for x in row])
    return buf.getvalue()


def branches_dataframe(branches: Sequence[Branch], si=None):
    """``branches.csv`` as a pandas DataFrame: the same columns in the same order, one row per
    point; numbers as float64 (an empty cell is NaN), ``stable`` as bool, ``point`` as int, the
    names as strings (``parameter2`` is "" off two-parameter curves); ``si`` as for `branches_csv`.
    Then the `FRAME_SPECIAL_COLUMNS` (the frame's only, from the special points): ``special`` (the
    label of a special point at that row, e.g. "H1"), and at a Hopf row ``l1`` (first Lyapunov
    coefficient) and ``criticality`` ("supercritical" / "subcritical"; "" and NaN elsewhere)."""
    import pandas as pd

    header, rows = _branch_rows(branches, si)
    frame = pd.DataFrame(list(rows), columns=header)
    # A state that is also an amplitude (the 1-dof AME's polar state a1 is the amplitude a1, Fig. 3)
    # appears twice in branches.csv; a DataFrame needs one name per column: the state's copy is
    # dropped where it repeats the amplitude, renamed "<name>_state" where it does not.
    seen, keep, names = set(), [], []
    for i, col in enumerate(header):
        if col in seen:
            first = header.index(col)
            if frame.iloc[:, i].equals(frame.iloc[:, first]):
                continue
            col = f"{col}_state"
        seen.add(col)
        keep.append(i)
        names.append(col)
    frame = frame.iloc[:, keep]
    frame.columns = names
    header = names
    text = ("branch", "kind", "parameter", "parameter2")
    for col in header:
        if col in text:
            frame[col] = frame[col].astype(str)
        elif col == "stable":
            frame[col] = frame[col].astype(bool)
        elif col == "point":
            frame[col] = frame[col].astype("int64")
        else:
            frame[col] = pd.to_numeric(frame[col], errors="coerce").astype("float64")
    for col, values in _special_columns(branches).items():
        frame[col] = values
    frame.attrs["truncated"] = truncation_notes(branches)
    return frame


#: The columns `branches_dataframe` adds after those of ``branches.csv`` (a DataFrame's only: the
#: CSV keeps its documented columns; the values come from the special points, which run.json
#: holds, so a run read back gives the same frame).
FRAME_SPECIAL_COLUMNS = ("special", "l1", "criticality")


def _special_columns(branches: Sequence[Branch]) -> dict:
    """`FRAME_SPECIAL_COLUMNS` of every row of ``branches`` (in the order of `_branch_rows`):
    ``special`` the labels of the special points whose ``index`` is that row (the point before a
    located point, as `SpecialPoint.index` says; several joined by a space), "" elsewhere; at a Hopf
    point's row ``l1`` its first Lyapunov coefficient and ``criticality`` "supercritical" or
    "subcritical" (`SpecialPoint.criticality`, Kuznetsov's sign), NaN and "" elsewhere."""
    special, l1, crit = [], [], []
    for b in branches:
        labels = [[] for _ in range(len(b))]
        lyap = [math.nan] * len(b)
        word = [""] * len(b)
        for sp in b.special_points:
            if not 0 <= sp.index < len(b):
                continue
            labels[sp.index].append(sp.label)
            if sp.criticality:
                lyap[sp.index], word[sp.index] = float(sp.extra["l1"]), sp.criticality
        special += [" ".join(x) for x in labels]
        l1 += lyap
        crit += word
    return {"special": special, "l1": np.array(l1, dtype="float64"), "criticality": crit}


def truncation_notes(branches: Sequence[Branch]) -> list[str]:
    """One line per branch end at the point budget (``max_points``): the branch, the side, the
    parameter value reached and, where the branch's ``info`` has it, the range it was asked for."""
    out = []
    for b in branches:
        rng = b.info.get("range")
        for e in b.truncated:
            where = f" of [{_g(rng[0])}, {_g(rng[1])}]" if isinstance(rng, (list, tuple)) and len(rng) == 2 else ""
            out.append(f"branch {b.name} ({e.side}) stopped at max_points ({e.points} points) at "
                       f"{b.parameter} = {_g(e.value)}{where}: raise max_points to cover the range")
    return out


def special_points_csv(points: Sequence[SpecialPoint], branches: Sequence[Branch] = (), si=None) -> str:
    """The text of ``special_points.csv`` (see the module docstring); ``si`` as for `branches_csv`."""
    from autocable.model.units import SI_COLUMNS
    params = _union([b.parameter_names for b in branches] + [list(sp.parameters) for sp in points])
    states = _union(b.variables for b in branches)
    header = (["branch", "type", "label", "parameter"] + params + ["a1", "a2"] + states
              + ["converged", "confirmed_by_pycont", "origin", "l1", "criticality", "omega", "period", "message"]
              + (list(SI_COLUMNS) if si else []))
    by_branch = {b.name: b for b in branches}
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(header)
    for sp in points:
        variables = by_branch[sp.branch].variables if sp.branch in by_branch else ()
        state = dict(zip(variables, sp.state))
        row = [sp.branch, sp.type, sp.label, sp.parameter]
        row += [sp.parameters.get(p) for p in params]
        row += [sp.a1, sp.a2]
        row += [state.get(s) for s in states]
        row += [sp.converged, sp.confirmed_by_pycont, sp.origin, sp.extra.get("l1"), sp.criticality,
                sp.extra.get("omega"), sp.extra.get("period"), sp.message]
        row += _si_row(si, {**sp.parameters, "a1": sp.a1, "a2": sp.a2})
        w.writerow([_fmt(x) for x in row])
    return buf.getvalue()


def write_results(results: RunResults, out_dir: str | Path, *, status: str = STATUS_COMPLETE,
                  tables: bool = True) -> dict[str, Path]:
    """Write ``branches.csv``, ``special_points.csv`` and ``run.json`` into ``out_dir`` (atomic), run.json
    last with ``status`` (`run_scene` writes "running" into its staging folder and publishes).
    ``tables=False`` writes run.json only: for a caller that wrote the same branches before and
    now adds to the provenance (formatting a large branches.csv again costs 0.1-0.2 s)."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    branches = results.branches
    si = _si(results.provenance)
    paths = {}
    if tables:
        paths["branches"] = atomic_write_text(out / BRANCHES_CSV, branches_csv(branches, si))
        paths["special_points"] = atomic_write_text(out / SPECIAL_CSV,
                                                    special_points_csv(results.special_points, branches, si))
    meta = {"format": "autocable.run/1", "name": results.name,
            "provenance": finite_or_none(dict(results.provenance)),
            "branches": [b.metadata() for b in branches],
            "special_points": [sp.to_dict() for sp in results.special_points],
            "status": status, "files": [BRANCHES_CSV, SPECIAL_CSV]}
    paths["run"] = atomic_write_json(out / RUN_JSON, meta)
    return paths


# -- reading ----------------------------------------------------------------------------------------
def _num(text: str) -> float:
    return float(text) if text != "" else math.nan


def read_results(out_dir: str | Path) -> RunResults:
    """Read what `write_results` wrote. Branch info and special points come from ``run.json``; each
    branch's ``info`` gets the run's ``si_scales`` and ``omega1`` when the provenance has them (a
    branch then plots in SI on its own: `autocable.plotting.units.cable_of`)."""
    folder = Path(out_dir)
    meta = read_json(folder / RUN_JSON)
    if not isinstance(meta, dict):
        raise FileNotFoundError(f"{folder / RUN_JSON}: missing or not valid JSON")
    status = status_of(meta)
    if status != STATUS_COMPLETE:
        reason = f" ({meta['reason']})" if meta.get("reason") else ""
        raise IncompleteResults(f"{folder / RUN_JSON}: status {status!r}{reason}: the run in this folder did "
                                f"not finish, its files are not a result; run the scene again")
    if not (folder / BRANCHES_CSV).is_file():
        if meta.get("branches"):
            raise IncompleteResults(f"{folder / BRANCHES_CSV}: missing, while {RUN_JSON} lists "
                                    f"{len(meta['branches'])} branch(es); run the scene again")
        rows = []      # a scene without branches (a time evolution, Fig. 11): its files are its result
    else:
        with open(folder / BRANCHES_CSV, newline="", encoding="utf-8") as fh:
            rows = list(csv.DictReader(fh))
    specials = [SpecialPoint.from_dict(d) for d in meta.get("special_points", [])]
    branches = []
    for bm in meta.get("branches", []):
        mine = [r for r in rows if r["branch"] == bm["name"]]
        cols = list(bm["parameter_names"]) + list(bm["amplitude_names"]) + list(bm["variables"])
        if bm["kind"] == "cycle":
            cols += list(_CYCLE_COLUMNS)
        if bm["kind"] in CURVE_KINDS:
            cols += list(_CURVE_COLUMNS)
        table = {c: [_num(r.get(c, "")) for r in mine] for c in cols}
        stable = [r["stable"] == "1" for r in mine]
        nev = 0
        if mine:
            while f"ev{nev + 1}_re" in mine[0] and any(r[f"ev{nev + 1}_re"] != "" for r in mine):
                nev += 1
        ev = [[complex(_num(r[f"ev{k}_re"]), _num(r[f"ev{k}_im"])) for k in range(1, nev + 1)]
              for r in mine]
        info = dict(bm.get("info") or {})
        prov = meta.get("provenance") or {}
        if prov.get("si_scales") and prov.get("omega1") is not None and "si_scales" not in info:
            # each branch carries its cable, so that it plots in SI (the deck frequency in Hz) alone
            info.update(si_scales=prov["si_scales"], omega1=prov["omega1"])
        branches.append(Branch(
            name=bm["name"], kind=bm["kind"], parameter=bm["parameter"],
            parameter_names=tuple(bm["parameter_names"]), variables=tuple(bm["variables"]),
            amplitude_names=tuple(bm["amplitude_names"]), table=table, stable=stable,
            eigenvalues=np.array(ev, dtype=complex).reshape(len(mine), nev),
            special_points=tuple(sp for sp in specials if sp.branch == bm["name"]),
            ends=tuple(EndPoint.from_dict(e) for e in bm.get("ends", [])), info=info,
            parameter2=bm.get("parameter2", "")))
    return RunResults(meta.get("name", folder.name), tuple(branches), meta.get("provenance", {}))


# -- output folders ---------------------------------------------------------------------------------
class IncompleteResults(ValueError):
    """An output folder whose run.json does not say ``status = "complete"``."""


def status_of(meta) -> str:
    """The ``status`` of a parsed run.json (``meta``): "missing" when there is none, "unmarked"
    when it has no status (a folder of an earlier version)."""
    if not isinstance(meta, dict):
        return "missing"
    return str(meta.get("status") or "unmarked")


def run_status(folder: str | Path) -> str:
    """run.json's ``status`` in ``folder``: "complete", "running" (being written, or killed),
    "failed", "interrupted", "unmarked" (no status: not a result of this version) or "missing"."""
    return status_of(read_json(Path(folder) / RUN_JSON))


def is_complete(folder: str | Path) -> bool:
    """Whether ``folder`` holds a run that finished (run.json written last, ``status = "complete"``)."""
    return run_status(folder) == STATUS_COMPLETE
