"""The k-th mode pair as the trial functions of eq. (21): every pair a stay can gallop in.

Eq. (21) (Sect. 3) projects eqs. (19)-(20) on the first symmetric in-plane mode and the first
out-of-plane mode (`modes.linear_modes`). Rain-wind vibration of stays is reported in modes 1 to 4
(about 1-3 Hz), so pair k takes, from the same linear problems (`modes_n`, which solves them for any
number of modes):

* in plane, the k-th mode of eq. (19)_1 by frequency: a symmetric mode (cos(b (s - 1/2)) - cos(b/2))/N,
  b the j-th root of Irvine's equation tan(b/2) = b/2 - (4/lambda^2)(b/2)^3, or an antisymmetric mode
  sin(2 j pi s) with omega = 2j exactly (its integral vanishes, so the sag term leaves it a taut-string
  mode). Below the crossover lambda^2 = 4 pi^2 (refused beyond, `premises.check_model`) they
  alternate: odd k is the symmetric mode j = (k + 1)/2 at omega a little above k, even k the
  antisymmetric mode j = k/2 at omega = k;
* out of plane, sin(k pi s) with omega = k exactly, and its twist slaved through eq. (19)_3 (with the
  (1 + chi) of docs/model.md, M4): theta = B sin(k pi s) + C cosh(kappa (s - 1/2)) for odd k,
  B sin(k pi s) + D sinh(kappa (s - 1/2)) for even k (`modes_n.slaved_twist`; with
  ``twist_ends = "restrained"`` only the B part).

Both modes have a unit maximum (Sect. 5), so a_k l is the peak displacement, found at mid-span only
for k = 1 (sin(k pi s) peaks at s = 1/(2k), 3/(2k), ...). Frequencies are in units of the reference
omega = (pi/l) sqrt(T/m) of eq. (17): the pair's nondimensional omega1 (in-plane) and omega2
(out-of-plane) are close to k, f = omega * omega_ref / (2 pi). The Galerkin projection
(`galerkin.project`) is the same for every pair: it sees the pair's shapes under the names phi1, phi2,
theta2 of eq. (21).

What pair k > 1 assumes (docs/mode-pairs.md):

* the wind angles are those of the model: a calibrated angle is fitted on the first pair (its onset
  at U_c, `calibration.calibrate`) and kept for every pair, not fitted again per pair;
* the modal damping ratio xi_s is the same for every mode (the model file has one);
* the pair is alone: the other modes are left out. `pair_premises` names the left-out modes within
  `CROWDED_FRACTION` of the pair's frequencies (a near resonance the two-mode model cannot see) and
  the bending stiffness the string frequencies leave out: (k pi)^2 EI / (T l^2) grows as k^2.
"""
from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from autocable.model.modes import Modes
from autocable.model.modes_n import IN_PLANE, SYMMETRIC, ModeInfo, mode_set
from autocable.model.premises import PremiseWarning
from autocable.model.shapes import Shape
from autocable.model.statics import CableStatics

#: A left-out mode within this fraction of one of the pair's frequencies crowds the pair: "a few per
#: cent", where its own linear coupling to the pair (aerodynamic damping and stiffness, of the order
#: of the damping ratios, 1e-3) is no longer small against the frequency gap.
CROWDED_FRACTION = 0.05
#: The relative frequency shift from bending, sqrt(1 + (k pi)^2 EI/(T l^2)) - 1 (a pinned tensioned
#: beam), above which a pair's string frequencies are flagged: eq. (21) has no bending in them.
BENDING_SHIFT_WARN = 0.01

#: The names `galerkin.project` reads, from the names `modes_n.mode_set` gives (``v`` in plane,
#: ``w`` out of plane, ``w_th`` its twist).
_SUFFIXES = ("", "_d", "_dd")


@dataclass(frozen=True)
class PairInfo:
    """What pair k is made of and what lies near it (nondimensional frequencies, eq. 17 units)."""

    k: int
    in_plane: ModeInfo
    out_of_plane: ModeInfo
    crowded_with: tuple           # ((plane, symmetry, index, omega, relative gap), ...) of left-out modes
    bending_shift: float          # sqrt(1 + (k pi)^2 EI/(T l^2)) - 1 of the out-of-plane mode

    @property
    def omega1(self) -> float:
        return self.in_plane.omega

    @property
    def omega2(self) -> float:
        return self.out_of_plane.omega

    def describe_in_plane(self) -> str:
        m = self.in_plane
        if m.symmetry == SYMMETRIC:
            return f"symmetric in-plane mode {m.k} (Irvine root b = {m.wavenumber:.6g})"
        return f"antisymmetric in-plane mode {m.k}, sin({2 * m.k} pi s)"


def _check_k(k) -> int:
    if isinstance(k, bool) or not isinstance(k, (int, np.integer)) or k < 1:
        raise ValueError(f"mode pair k must be an integer >= 1, got {k!r}")
    return int(k)


def pair_modes(st: CableStatics, k: int, twist_ends: str = "natural") -> Modes:
    """Pair k as the trial functions of eq. (21): a `Modes` whose shapes phi1, phi2, theta2 are the
    k-th in-plane mode, the k-th out-of-plane mode and its slaved twist (module docstring), omega1 and
    omega2 their frequencies. ``b`` is the in-plane wavenumber (pi omega1 for both symmetries); the
    twist is B sin(k pi s) + C cosh(kappa (s - 1/2)) + D sinh(kappa (s - 1/2)). For k = 1 these are
    the shapes of `modes.linear_modes` (the same expressions: tests/test_mode_pairs.py)."""
    k = _check_k(k)
    ms = mode_set(st, k, k, twist_ends)
    v, w = ms.in_plane[k - 1], ms.out_of_plane[k - 1]
    shapes = {}
    for src, dst in ((v.name, "phi1"), (w.name, "phi2")):
        for suf in _SUFFIXES:
            s = ms.shapes[src + suf]
            shapes[dst + suf] = Shape(dst + suf, s.exp, s.evaluate)
    th = ms.shapes[f"{w.name}_th"]
    shapes["theta2"] = Shape("theta2", th.exp, th.evaluate)
    for name in ("vhat", "vhat_d", "vhat_dd"):
        shapes[name] = ms.shapes[name]
    B, C, D, kappa = w.twist
    return Modes(omega1=v.omega, omega2=w.omega, b=v.wavenumber, twist_B=B, twist_C=C, twist_k=kappa,
                 shapes=shapes, twist_D=D)


def pair_info(st: CableStatics, k: int, bending_ratio: float = 0.0) -> PairInfo:
    """The modes of pair k, the left-out modes within `CROWDED_FRACTION` of either of its frequencies
    (every in-plane and out-of-plane mode up to k + 2 of each plane, which holds every neighbour:
    below the crossover the in-plane modes of both symmetries lie one apart, the out-of-plane modes
    at the integers) and the bending shift, ``bending_ratio`` = EI / (T l^2)."""
    k = _check_k(k)
    ms = mode_set(st, k + 2, k + 2)
    v, w = ms.in_plane[k - 1], ms.out_of_plane[k - 1]
    crowded = []
    for m in ms.modes:
        if m.name in (v.name, w.name):
            continue
        gap = min(abs(m.omega - v.omega) / v.omega, abs(m.omega - w.omega) / w.omega)
        if gap < CROWDED_FRACTION:
            crowded.append((m.plane, m.symmetry, m.k, m.omega, gap))
    shift = math.sqrt(1.0 + (k * math.pi) ** 2 * bending_ratio) - 1.0
    return PairInfo(k=k, in_plane=v, out_of_plane=w, crowded_with=tuple(sorted(crowded, key=lambda c: c[4])),
                    bending_shift=shift)


def bending_ratio(cable, st: CableStatics) -> float:
    """EI / (T l^2): the bending stiffness against the tension over the span (eq. 21 leaves it out of
    the frequencies)."""
    return cable.bending_stiffness_Nm2 / (st.T_bar * cable.length_m ** 2)


def describe_mode(plane: str, symmetry: str, index: int) -> str:
    """``in-plane symmetric 2``, ``out-of-plane 3``: a left-out mode named for a message."""
    return f"in-plane {symmetry} {index}" if plane == IN_PLANE else f"out-of-plane {index}"


def pair_premises(spec, st: CableStatics, k: int, where: str | None = None) -> PairInfo:
    """`pair_info` of pair k of ``spec``'s cable, with a `premises.PremiseWarning` (one line, naming
    the file and ``cable.mode_pair``) where the pair is crowded or its string frequencies miss more
    than `BENDING_SHIFT_WARN` of bending. Never refuses: a crowded pair is computed and flagged."""
    info = pair_info(st, k, bending_ratio(spec.cable, st))
    where = where or spec.path or spec.name
    if info.crowded_with:
        names = ", ".join(f"{describe_mode(p, s, i)} (omega = {om:.5g}, {100 * g:.2g} % away)"
                          for p, s, i, om, g in info.crowded_with)
        warnings.warn(PremiseWarning(
            f"{where}: cable.mode_pair = {k}: left-out modes within {100 * CROWDED_FRACTION:g} % of the pair's "
            f"frequencies ({names}): the two-mode eq. (21) cannot see their coupling"), stacklevel=2)
    if info.bending_shift > BENDING_SHIFT_WARN:
        warnings.warn(PremiseWarning(
            f"{where}: cable.mode_pair = {k}: bending would raise the pair's frequencies by "
            f"{100 * info.bending_shift:.2g} % ((k pi)^2 EI/(T l^2) = {(k * math.pi) ** 2 * bending_ratio(spec.cable, st):.3g}); "
            "eq. (21) has taut-string frequencies (check cable.bending_stiffness_Nm2)"), stacklevel=2)
    return info


def twist_peak_per_unit(modes: Modes) -> float:
    """max over s of |theta2(s)|: the slaved twist (rad) per unit modal amplitude q2, on a dense grid
    (the cosh and sinh parts peak at the ends, the sine part inside)."""
    s = np.linspace(0.0, 1.0, 4001)
    return float(np.max(np.abs(modes.shapes["theta2"].evaluate(s))))
