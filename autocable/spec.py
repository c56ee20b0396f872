"""Model spec files (``models/*.toml``) -> frozen dataclasses in SI units, with validation.

A spec describes one cable (Sect. 5 of Luongo & Zulli) and its aerodynamics (eqs. 9-14). Every field
is checked: a missing, unknown, non-numeric or non-physical value raises `SpecError`, whose message is
one line naming the file, the field and what is expected. Nothing else in autocable reads TOML.

Inputs the paper does not give (the yaw angle beta, the rivulet angle Theta0, the air density, the
load length and angle convention of eqs. 11-12: docs/model.md, U1-U4) are explicit fields; the angle
convention is required (its senses give different cables). Values outside the ranges where the
model can apply are refused here; the premises of the derived cable are checked by
`autocable.model.premises.check_model` (docs/model.md, P). Exactly one
of (yaw, rivulet angle) may be the string ``"calibrate"``: it is then found so that the trivial
solution loses stability at ``critical_wind_speed_m_s`` (see `autocable.model.calibration.calibrate`).
"""
from __future__ import annotations

import csv
import hashlib
import math
import os
import re
import stat
import tomllib
from dataclasses import dataclass, field, fields
from pathlib import Path

CALIBRATE = "calibrate"


#: The longest message a `SpecError` carries: a value quoted in full (``drag = [1e300, ...]``, a
#: long string) must not turn a one-line error into kilobytes.
MAX_MESSAGE = 240
#: The longest file path a `SpecError` shows whole (a longer one keeps its last part).
MAX_PATH = 160


class SpecError(ValueError):
    """A bad model or scene file. ``str(err)`` is one line: ``file: field: what is expected``
    (line breaks are folded into spaces). Neither part's cut depends on the other: the file's path
    is kept whole up to `MAX_PATH` characters (beyond, its last part, which names the file); the
    field and the message after it are cut only beyond `MAX_MESSAGE` characters, which a message of
    the package's own fits whole, its fix included (a quoted value is bounded by `show`)."""

    def __init__(self, path, field: str, message: str):
        self.path = str(path)
        self.field = field
        rest = " ".join((f"{field}: {message}" if field else message).split())
        if len(rest) > MAX_MESSAGE:
            rest = rest[:MAX_MESSAGE - 3] + "..."
        shown = " ".join(self.path.split())
        if len(shown) > MAX_PATH:
            shown = "..." + shown[-(MAX_PATH - 3):]
        super().__init__(f"{shown}: {rest}")


def show(value, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, for quoting a rejected value in a message; a
    float in its shortest form (`number_text`: ``1e9``, as typed, not ``1000000000.0``)."""
    text = number_text(value) if type(value) is float else repr(value)
    return text if len(text) <= limit else text[:limit - 3] + "..."


def number_text(x: float) -> str:
    """``repr(x)``, or the shortest exponent form that reads back as ``x`` where that is clearly
    shorter (by 3 characters or more: ``1e9``, not ``1000000000.0``; ``500.0`` stays, not ``5e2``;
    an exponent ``repr`` is written the short way, ``2.5e-7``): the command line and TOML hand over
    floats, not the text typed, and a message quoting ``1000000000.0`` is not the value the user
    wrote."""
    text = repr(x)
    if not math.isfinite(x):
        return text
    for digits in range(17):
        short = f"{x:.{digits}e}"
        if float(short) == x:
            mantissa, exponent = short.split("e")
            short = f"{mantissa}e{int(exponent)}"
            return short if ("e" in text and len(short) <= len(text)) or len(short) + 3 <= len(text) else text
    return text                          # pragma: no cover - 17 digits always read back


@dataclass(frozen=True)
class CableSpec:
    """The cable of Sect. 2 and Sect. 5 (SI units)."""

    length_m: float                  # l, initial length (= chord for a nearly taut cable)
    chord_slope_deg: float           # alpha, slope of the chord (negative: lower end at the right)
    horizontal_tension_N: float      # H-bar, horizontal component of the static tension
    mass_per_length_kg_m: float      # m
    diameter_m: float                # D
    axial_stiffness_N: float         # EA
    bending_stiffness_Nm2: float     # EI
    torsional_stiffness_Nm2: float   # GJ
    damping_ratio: float             # xi_s, modal damping ratio of both modes
    gravity_m_s2: float = 9.81       # g
    twist_ends: str = "natural"      # end conditions of the twist, eq. (20): "natural" (eq. 20 as
                                     # printed, chi (theta' + kappa w') = 0) or "restrained"
                                     # (theta(0) = theta(1) = 0, twist held at the anchorages)
    mode_pair: int = 1               # k: the k-th in-plane and k-th out-of-plane modes are eq. (21)'s
                                     # trial functions (1: the paper's pair; autocable.model.mode_pairs)


@dataclass(frozen=True)
class AeroTable:
    """Lift and drag measured against phi (``[aero.table]`` or a CSV file; docs/aero-curves.md)."""

    phi_deg: tuple                   # angles of eq. (12), increasing [deg]
    lift: tuple                      # c_l at those angles
    drag: tuple                      # c_d at those angles
    periodic: bool = False           # the rows span 360 deg, the last repeating the first
    source: str = field(default="", repr=False, compare=False)   # the CSV file, for messages only


#: The [aero] fields of the coefficient curves beyond eq. (13)'s cubics (`autocable.model.curves`):
#: in `ModelSpec.content_hash` only when set, so a model without them keeps the hash it had.
CURVE_FIELDS = ("valid_phi_deg", "outside", "blend_deg", "dry_drag", "table")


@dataclass(frozen=True)
class AeroSpec:
    """The quasi-steady cable-rivulet model of Sect. 2.3 (eqs. 9-14)."""

    air_density_kg_m3: float
    rivulet_diameter_ratio: float    # d/D (documents the A_k, B_k data; it enters only through them)
    lift: tuple[float, float, float, float]   # A_0..A_3 of eq. (13)
    drag: tuple[float, float, float, float]   # B_0..B_3 of eq. (13)
    critical_wind_speed_m_s: float   # U_c of eq. (18)
    yaw_deg: float | None            # beta (None: to be calibrated)
    rivulet_angle_deg: float | None  # Theta0 (None: to be calibrated)
    load_length: str = "diameter"    # the length in eq. (11): "diameter" (1/2 rho V D) or "radius"
    angle_convention: str = "eq12"   # sense of phi (aero.ANGLE_SENSES): "eq12" | "mirrored" | "reversed" (legacy)
    calibration_root: str = "smallest"  # which root the calibration keeps: "smallest" |angle|
    load_axes: str = "reference"     # axes the load is projected on in eq. (14): "reference" (the
                                     # initial section axes a2-bar, a3-bar of eqs. 8) or "twisted"
                                     # (the current axes a2, a3, turned by the twist theta)
    load: str = "cubic"              # the rung of the load: "cubic" (eq. 14, the paper's eq. 21) or
                                     # "exact" (eqs. 11-13 unexpanded, `autocable.model.exact_load`)
    # The curves c_l, c_d beyond eq. (13)'s cubics (`autocable.model.curves`, docs/aero-curves.md);
    # lift and drag are None when a table is given. None: not given (the curves' defaults).
    valid_phi_deg: tuple | None = field(default=None, repr=False)   # (lo, hi) of phi the curves hold over
    outside: str = field(default="cubic", repr=False)   # beyond valid_phi_deg: "cubic" | "dry-cylinder"
    blend_deg: float | None = field(default=None, repr=False)   # width of the blend to the dry cylinder
    dry_drag: float | None = field(default=None, repr=False)    # the dry cylinder's c_d
    table: AeroTable | None = field(default=None, repr=False)   # measured c_l, c_d against phi

    def curve_fields(self) -> tuple:
        """((name, value), ...) of the `CURVE_FIELDS` that are set (not at their defaults)."""
        return tuple((k, getattr(self, k)) for k in CURVE_FIELDS
                     if getattr(self, k) is not None and not (k == "outside" and self.outside == "cubic"))


@dataclass(frozen=True)
class DamperSpec:
    """A viscous damper near the lower anchorage (`autocable.model.damper`; docs/dampers.md)."""

    position_m: float                # x_d, distance from the lower anchorage along the chord [m]
    constant_N_s_m: float            # c, the dashpot constant [N s/m]
    support_stiffness_N_m: float | None = None   # k_s of the support, in series (None: rigid)


@dataclass(frozen=True)
class ModelSpec:
    name: str
    description: str
    cable: CableSpec
    aero: AeroSpec
    path: str = ""
    damper: DamperSpec | None = None

    def content_hash(self) -> str:
        """Hash of the physical content (not the file path or comments)."""
        text = repr((self.cable, self.aero))
        if self.damper is not None:     # a model without a damper keeps the hash it always had
            text = repr((self.cable, self.aero, self.damper))
        if self.aero.curve_fields():    # so does a model with eq. (13)'s cubics alone (a table: its values)
            text += repr(self.aero.curve_fields())
        return hashlib.sha256(text.encode()).hexdigest()[:12]


#: The highest mode pair a model may ask for (``cable.mode_pair``, ``--pair``): the field's rain-wind
#: modes are the first four; 50 leaves room for a long stay's modes below a few hertz.
MODE_PAIR_MAX = 50

# field name -> (kind, rule, unit/expected text). kind: "pos" > 0, "nonneg" >= 0, "angle" (lo, hi).
_CABLE_RULES = {
    "length_m": ("pos", None, "a positive length in m"),
    "chord_slope_deg": ("range", (-90.0, 90.0), "an angle in degrees strictly between -90 and 90"),
    "horizontal_tension_N": ("pos", None, "a positive force in N"),
    "mass_per_length_kg_m": ("pos", None, "a positive mass per unit length in kg/m"),
    "diameter_m": ("pos", None, "a positive diameter in m"),
    "axial_stiffness_N": ("pos", None, "a positive axial stiffness EA in N"),
    "bending_stiffness_Nm2": ("pos", None, "a positive bending stiffness EI in N m^2"),
    "torsional_stiffness_Nm2": ("pos", None, "a positive torsional stiffness GJ in N m^2"),
    "damping_ratio": ("range", (0.0, 1.0), "a damping ratio between 0 and 1 (0.004 is 0.4 %)"),
    "gravity_m_s2": ("pos", None, "a positive acceleration in m/s^2"),
    "twist_ends": ("choice", ("natural", "restrained"),
                   '"natural" (eq. 20 as printed) or "restrained" (theta = 0 at both anchorages)'),
    "mode_pair": ("count", (1, MODE_PAIR_MAX), f"an integer k from 1 to {MODE_PAIR_MAX}: the k-th in-plane and k-th out-of-plane "
                                    "modes as the pair of eq. (21) (1, the default: the paper's first pair)"),
}
_AERO_RULES = {
    # Air, not a liquid: the quasi-steady load of eqs. (9-14) has no added mass or buoyancy.
    "air_density_kg_m3": ("bounded", (0.1, 10.0), "an air density in kg/m^3 from 0.1 to 10 (standard air: 1.25)"),
    "rivulet_diameter_ratio": ("range", (0.0, 1.0), "the ratio d/D, between 0 and 1"),
    "lift": ("coeffs", (-100.0, 100.0),
             "a list of the 4 numbers A_0, A_1, A_2, A_3 of eq. (13), each in [-100, 100]"),
    "drag": ("coeffs", (-100.0, 100.0),
             "a list of the 4 numbers B_0, B_1, B_2, B_3 of eq. (13), each in [-100, 100]"),
    # Incompressible quasi-steady flow: below Mach 0.3 (about 100 m/s in air).
    "critical_wind_speed_m_s": ("bounded", (0.0, 100.0), "a wind speed in m/s above 0 and at most 100 "
                                                          "(incompressible air, Mach < 0.3)"),
    "yaw_deg": ("angle_or_cal", (-90.0, 90.0), 'an angle in degrees in [-90, 90], or "calibrate"'),
    "rivulet_angle_deg": ("angle_or_cal", (-180.0, 180.0),
                          'an angle in degrees in [-180, 180], or "calibrate"'),
    "load_length": ("choice", ("diameter", "radius"), '"diameter" or "radius"'),
    "calibration_root": ("choice", ("smallest",), '"smallest"'),
    "angle_convention": ("choice", ("eq12", "mirrored", "reversed"),
                         '"eq12" (eq. 12 as printed), "mirrored" (the coefficient curves read as '
                         'c(-phi)) or the legacy "reversed" (not frame indifferent)'),
    "load_axes": ("choice", ("reference", "twisted"),
                  '"reference" (initial section axes) or "twisted" (axes turned by the twist)'),
    "load": ("choice", ("cubic", "exact"),
             '"cubic" (the cubic expansion of eq. 14, the paper\'s eq. 21) or "exact" (the quasi-steady '
             'load of eqs. 11-13 without expansion)'),
    "valid_phi_deg": ("phi_range", (-720.0, 720.0), "[lo, hi]: the range of the angle phi of eq. (12) the "
                                                    "curves hold over, degrees, lo < hi, each in [-720, 720]"),
    "outside": ("choice", ("cubic", "dry-cylinder"),
                '"cubic" (the fits of eq. 13 at every angle) or "dry-cylinder" (blended to the dry '
                'cylinder\'s c_l = 0, c_d = dry_drag beyond valid_phi_deg)'),
    "blend_deg": ("bounded", (0.0, 90.0), "the width of the blend to the dry cylinder in degrees, above 0 "
                                          "and at most 90 (default 10)"),
    "dry_drag": ("bounded", (0.0, 3.0), "the dry circular cylinder's drag coefficient, above 0 and at most 3 "
                                        "(default 1.2, subcritical flow)"),
    "table": ("curve_table", None, 'lift and drag measured against phi: a CSV file (columns phi_deg, lift, '
                                   'drag) or a table with phi_deg, lift, drag (lists) and periodic'),
}
# angle_convention is required: its senses give different cables (the sample's Theta0 is -13.9
# deg with "mirrored" and "reversed", 58.2 deg with "eq12"), so a default would silently pick one.
_OPTIONAL = {"gravity_m_s2", "load_length", "calibration_root", "twist_ends", "load_axes", "load", "mode_pair",
             "lift", "drag", "valid_phi_deg", "outside", "blend_deg", "dry_drag", "table"}

#: A model's ``name``: a one-line label (it names outputs and cache entries).
NAME_RULE = ('a label of 1 to 64 characters, on one line, without "/", "\\" or control characters, '
             'and not "." or ".."')
_BAD_NAME = re.compile(r"[/\\\x00-\x1f\x7f]")


def finite_number(value, path, field, expected="a finite number") -> float:
    """``value`` as a finite float, or a one-line `SpecError` naming ``path`` and ``field`` (a bool,
    a string, NaN, an infinity, an integer beyond the float range). Shared by every file schema."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise SpecError(path, field, f"expected {expected}, got {show(value)}")
    try:
        value = float(value)
    except OverflowError:       # an integer beyond the float range (e.g. 400 digits)
        raise SpecError(path, field, f"expected {expected}, got an integer of {len(str(abs(value)))} "
                                     f"digits") from None
    if not math.isfinite(value):
        raise SpecError(path, field, f"expected {expected}, got {show(value)}")
    return value


def _check(value, rule, path, field):
    kind, bounds, expected = rule
    if kind == "choice":
        if value not in bounds:
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        return value
    if kind == "coeffs":
        if not isinstance(value, list) or len(value) != 4:
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        out = tuple(finite_number(v, path, field, expected) for v in value)
        for k, x in enumerate(out):
            if not bounds[0] <= x <= bounds[1]:
                raise SpecError(path, f"{field}[{k}]", f"expected {expected}, got {show(value[k])}")
        return out
    if kind == "phi_range":
        if not isinstance(value, list) or len(value) != 2:
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        lo, hi = (finite_number(v, path, field, expected) for v in value)
        if not (bounds[0] <= lo < hi <= bounds[1]):
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        return (lo, hi)
    if kind == "curve_table":
        return _curve_table(value, path, field)
    if kind == "angle_or_cal":
        if value == CALIBRATE:
            return None
        x = finite_number(value, path, field, expected)
        if not bounds[0] <= x <= bounds[1]:
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        return x
    if kind == "count":
        # an integer as TOML writes it: 2.0, "2" and true are refused, not rounded or coerced
        if isinstance(value, bool) or not isinstance(value, int) or not bounds[0] <= value <= bounds[1]:
            raise SpecError(path, field, f"expected {expected}, got {show(value)}")
        return value
    x = finite_number(value, path, field, expected)
    if kind == "pos" and not x > 0:
        raise SpecError(path, field, f"expected {expected}, got {show(value)}")
    if kind == "range" and not bounds[0] < x < bounds[1]:
        raise SpecError(path, field, f"expected {expected}, got {show(value)}")
    if kind == "bounded" and not bounds[0] < x <= bounds[1]:
        raise SpecError(path, field, f"expected {expected}, got {show(value)}")
    return x


#: The [aero.table] keys: the values inline, or a CSV file.
_TABLE_KEYS = ("phi_deg", "lift", "drag", "periodic", "file")
_TABLE_COLUMNS = ("phi_deg", "lift", "drag")
_TABLE_BOUND = 100.0        # |c_l|, c_d of a table, as eq. (13)'s coefficients


def _read_table_csv(name, path, field) -> tuple[dict, str]:
    """{"phi_deg": [...], "lift": [...], "drag": [...]} of a CSV file named relative to the model
    file (a header row naming the three columns in any order; lines starting with # are skipped)."""
    if not isinstance(name, str) or not name.strip():
        raise SpecError(path, field, f"expected the name of a CSV file (relative to the model file), got {show(name)}")
    csv_path = Path(str(path)).parent / name
    where = f"{csv_path}"
    try:
        if not stat.S_ISREG(os.stat(csv_path).st_mode):
            raise SpecError(path, field, f"{where} is not a regular file; give a CSV file")
        text = csv_path.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise SpecError(path, field, f"no such file {where}; the path is relative to the model file") from None
    except UnicodeDecodeError:
        raise SpecError(path, field, f"{where} is not UTF-8 text; save the CSV as UTF-8") from None
    except OSError as exc:
        raise SpecError(path, field, f"cannot read {where}: {exc.strerror}") from None
    rows = [(n, r) for n, r in enumerate(csv.reader(text.splitlines()), start=1)
            if r and any(c.strip() for c in r) and not r[0].lstrip().startswith("#")]
    if not rows:
        raise SpecError(path, field, f"{where} is empty; give a header row phi_deg,lift,drag and one row per angle")
    header = [c.strip() for c in rows[0][1]]
    if sorted(header) != sorted(_TABLE_COLUMNS):
        raise SpecError(path, field, f"{where}: expected the columns phi_deg, lift, drag in a header row, "
                                     f"got {show(header)}")
    out = {c: [] for c in _TABLE_COLUMNS}
    for n, row in rows[1:]:
        if len(row) != len(header):
            raise SpecError(path, field, f"{where} line {n}: expected {len(header)} values, got {len(row)}")
        for c, v in zip(header, row):
            try:
                x = float(v)
            except ValueError:
                raise SpecError(path, field, f"{where} line {n}: {c} is not a number: {show(v.strip())}") from None
            out[c].append(x)
    return out, str(csv_path)


def _curve_table(value, path, field) -> AeroTable:
    """An `AeroTable` from ``[aero.table]`` (inline lists or ``file``) or a CSV file name: at least
    4 rows, angles strictly increasing, spanning at most 360 deg, or exactly 360 with the last row
    repeating the first when ``periodic``; finite values, c_d >= 0."""
    if isinstance(value, str):
        value = {"file": value}
    if not isinstance(value, dict):
        raise SpecError(path, field, f"expected a CSV file name or a table, got {show(value)}")
    for key in value:
        if key not in _TABLE_KEYS:
            raise SpecError(path, f"{field}.{key}", f"unknown key; allowed: {', '.join(_TABLE_KEYS)}")
    periodic = value.get("periodic", False)
    if not isinstance(periodic, bool):
        raise SpecError(path, f"{field}.periodic", f"expected true or false, got {show(periodic)}")
    inline = [k for k in _TABLE_COLUMNS if k in value]
    if "file" in value and inline:
        raise SpecError(path, field, f"give either file or the lists {', '.join(_TABLE_COLUMNS)}, not both")
    if "file" in value:
        data, source = _read_table_csv(value["file"], path, f"{field}.file")
        where = f"{field}.file ({source})"
    else:
        for k in _TABLE_COLUMNS:
            if k not in value:
                raise SpecError(path, f"{field}.{k}", "missing; give phi_deg, lift and drag as lists of numbers "
                                                      "(or file = a CSV file)")
            if not isinstance(value[k], list):
                raise SpecError(path, f"{field}.{k}", f"expected a list of numbers, got {show(value[k])}")
        data = {k: [finite_number(v, path, f"{field}.{k}[{i}]") for i, v in enumerate(value[k])]
                for k in _TABLE_COLUMNS}
        source, where = "", field
    phi, lift, drag = (data[k] for k in _TABLE_COLUMNS)
    if not len(phi) == len(lift) == len(drag):
        raise SpecError(path, where, f"phi_deg, lift and drag have {len(phi)}, {len(lift)}, {len(drag)} values; "
                                     f"give one of each per angle")
    if len(phi) < 4:
        raise SpecError(path, where, f"{len(phi)} angles; a cubic spline needs at least 4")
    for k, (a, b) in enumerate(zip(phi, phi[1:]), start=1):
        if b == a:
            raise SpecError(path, where, f"angle {a:g} deg given twice (rows {k} and {k + 1}); keep one row per angle")
        if b < a:
            raise SpecError(path, where, f"angles not increasing ({b:g} deg after {a:g} deg, row {k + 1}); "
                                         f"sort the rows by phi_deg")
    if not (-720.0 <= phi[0] and phi[-1] <= 720.0):
        raise SpecError(path, where, f"angles from {phi[0]:g} to {phi[-1]:g} deg; keep them in [-720, 720]")
    for name, vals in (("lift", lift), ("drag", drag)):
        for k, v in enumerate(vals, start=1):
            if not -_TABLE_BOUND <= v <= _TABLE_BOUND or (name == "drag" and v < 0):
                expected = "in [0, 100] (a drag coefficient is not negative)" if name == "drag" else "in [-100, 100]"
                raise SpecError(path, where, f"{name} at row {k} is {v!r}; expected {expected}")
    span = phi[-1] - phi[0]
    if periodic:
        if abs(span - 360.0) > 1e-9 or abs(lift[-1] - lift[0]) > 1e-9 or abs(drag[-1] - drag[0]) > 1e-9:
            raise SpecError(path, where, f"periodic = true needs the last row to repeat the first 360 deg on "
                                         f"(the same angle): got {phi[0]:g} to {phi[-1]:g} deg, lift {lift[0]:g} "
                                         f"and {lift[-1]:g}, drag {drag[0]:g} and {drag[-1]:g}; add or fix that row")
    elif span > 360.0:
        raise SpecError(path, where, f"the angles span {span:g} deg, more than a turn; give one turn with "
                                     f"periodic = true, or less")
    return AeroTable(tuple(phi), tuple(lift), tuple(drag), periodic, source)


def _check_curve_fields(aero: dict, path) -> None:
    """The [aero] fields of the curves agree: eq. (13)'s lift and drag or a table; the blend's
    fields only with ``outside = "dry-cylinder"``, which needs the fits' range."""
    table = aero.get("table")
    if table is not None:
        for key in ("lift", "drag", "outside", "blend_deg", "dry_drag"):
            if key in aero:
                raise SpecError(path, f"aero.{key}", "not with a table: the table gives lift and drag at every "
                                                     "angle (held beyond a non-periodic table's ends); remove "
                                                     "this field or the table")
        aero["lift"] = aero["drag"] = None
        return
    for key in ("lift", "drag"):
        if key not in aero:
            raise SpecError(path, f"aero.{key}", f"missing; expected {_AERO_RULES[key][2]} (or give [aero.table], "
                                                 f"the coefficients measured against phi)")
    if aero.get("outside", "cubic") == "dry-cylinder":
        if "valid_phi_deg" not in aero:
            raise SpecError(path, "aero.valid_phi_deg", 'outside = "dry-cylinder" needs the range of phi the fits '
                                                        'hold over: give [lo, hi] in degrees (e.g. the static '
                                                        'angle phi0 that `autocable derive` prints, +- 15)')
    else:
        for key in ("blend_deg", "dry_drag"):
            if key in aero:
                raise SpecError(path, f"aero.{key}", 'used only with outside = "dry-cylinder"; set that or '
                                                     'remove this field')


def _section(data, name, rules, path):
    if name not in data:
        raise SpecError(path, f"[{name}]", f"missing section; add a [{name}] table")
    table = data[name]
    if not isinstance(table, dict):
        raise SpecError(path, name, "expected a table")
    for key in table:
        if key not in rules:
            close = [k for k in rules if k.split("_")[0] == key.split("_")[0]]
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise SpecError(path, f"{name}.{key}", f"unknown key{hint}; allowed: {', '.join(rules)}")
    out = {}
    for key, rule in rules.items():
        if key not in table:
            if key in _OPTIONAL:
                continue
            raise SpecError(path, f"{name}.{key}", f"missing; expected {rule[2]}")
        out[key] = _check(table[key], rule, path, f"{name}.{key}")
    return out


#: The top-level keys of a model spec.
TOP_KEYS = ("name", "description", "cable", "aero", "damper")

#: The ``[damper]`` table (optional): field -> what is expected.
_DAMPER_RULES = {
    "position_m": "the damper's distance from the lower anchorage in m, above 0 and below half the cable length",
    "constant_N_s_m": "a positive dashpot constant c in N s/m",
    "support_stiffness_N_m": "a positive stiffness of the damper's support in N/m (leave it out for a rigid support)",
}


def _damper(data, path, cable: CableSpec) -> DamperSpec | None:
    """The optional ``[damper]`` table, checked against the cable's length."""
    if "damper" not in data:
        return None
    table = data["damper"]
    if not isinstance(table, dict):
        raise SpecError(path, "damper", "expected a table [damper] with position_m and constant_N_s_m")
    for key in table:
        if key not in _DAMPER_RULES:
            raise SpecError(path, f"damper.{key}", f"unknown key; allowed: {', '.join(_DAMPER_RULES)}")
    out = {}
    for key, expected in _DAMPER_RULES.items():
        if key not in table:
            if key == "support_stiffness_N_m":
                continue
            raise SpecError(path, f"damper.{key}", f"missing; add it to [damper]: {expected}")
        x = finite_number(table[key], path, f"damper.{key}", expected)
        if not x > 0:
            raise SpecError(path, f"damper.{key}", f"expected {expected}, got {show(table[key])}")
        out[key] = x
    if not out["position_m"] < cable.length_m / 2:
        raise SpecError(path, "damper.position_m", f"expected {_DAMPER_RULES['position_m']} "
                                                   f"({cable.length_m / 2:g} m), got {show(table['position_m'])}; "
                                                   "measure it from the nearer (lower) anchorage")
    return DamperSpec(**out)


def model_fields() -> dict[str, tuple[str, bool]]:
    """Every field a model spec accepts, by dotted name (``cable.length_m``): (what is expected,
    whether it is required). The schema's own rules, for the generated file reference."""
    out = {"name": (NAME_RULE, False), "description": ("text", False),
           "cable": ("a table", True), "aero": ("a table", True)}
    for section, rules in (("cable", _CABLE_RULES), ("aero", _AERO_RULES)):
        for key, (_, _, expected) in rules.items():
            out[f"{section}.{key}"] = (expected, key not in _OPTIONAL)
    out["damper"] = ("a table (optional): a viscous damper near the lower anchorage", False)
    for key, expected in _DAMPER_RULES.items():
        out[f"damper.{key}"] = (expected, False)
    return out


def parse_model(data: dict, path="<spec>") -> ModelSpec:
    """Validate a parsed TOML document and build a `ModelSpec`."""
    allowed = set(TOP_KEYS)
    for key in data:
        if key not in allowed:
            raise SpecError(path, key, f"unknown key; allowed top-level keys: {', '.join(sorted(allowed))}")
    name = data.get("name", Path(str(path)).stem)
    if not isinstance(name, str) or not 1 <= len(name) <= 64 or name in (".", "..") or _BAD_NAME.search(name):
        raise SpecError(path, "name", f"expected {NAME_RULE}, got {show(name)}")
    description = data.get("description", "")
    if not isinstance(description, str):
        raise SpecError(path, "description", "expected a string")
    cable = CableSpec(**_section(data, "cable", _CABLE_RULES, path))
    aero_fields = _section(data, "aero", _AERO_RULES, path)
    aero_fields.setdefault("load_length", "diameter")
    aero_fields.setdefault("calibration_root", "smallest")
    aero_fields.setdefault("load_axes", "reference")
    aero_fields.setdefault("load", "cubic")
    _check_curve_fields(aero_fields, path)
    aero = AeroSpec(**aero_fields)
    if aero.yaw_deg is None and aero.rivulet_angle_deg is None:
        raise SpecError(path, "aero.yaw_deg", 'only one of yaw_deg and rivulet_angle_deg may be "calibrate"')
    return ModelSpec(name=name, description=description, cable=cable, aero=aero, path=str(path),
                     damper=_damper(data, path, cable))


def read_toml(path) -> tuple[dict, str]:
    """(parsed document, text) of a TOML file; a missing, unreadable or malformed file raises a
    one-line `SpecError`. Shared by model specs and scene files."""
    if not isinstance(path, (str, os.PathLike)):
        raise SpecError("<path>", "", f"expected the path of a .toml file, got {show(path)}")
    if not str(path).strip():
        raise SpecError("<empty path>", "", "no file given; give the path of a .toml file")
    path = Path(path)
    try:
        # stat before opening: opening a FIFO blocks until a writer comes, forever for a user who
        # gave the wrong path; a directory or a device is no TOML file either.
        if not stat.S_ISREG(os.stat(path).st_mode):
            raise SpecError(path, "", "not a regular file (a directory, FIFO or device); give a .toml file")
        raw = path.read_bytes()
    except FileNotFoundError:
        raise SpecError(path, "", "no such file") from None
    except OSError as exc:
        raise SpecError(path, "", f"cannot read: {exc.strerror}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise SpecError(path, "", f"not UTF-8 text (byte {exc.start}); TOML files are UTF-8") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise SpecError(path, "", f"not valid TOML: {exc}") from None
    return data, text


def load_model(path) -> ModelSpec:
    """Read and validate a model spec file. Raises `SpecError` with a one-line message."""
    data, _ = read_toml(path)
    return parse_model(data, Path(path))


def spec_fields(cls) -> list[str]:
    return [f.name for f in fields(cls)]
