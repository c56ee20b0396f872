"""The bounds of the AME-against-eq.-(21) study (docs/ame_vs_ode21.md, `autocable bench ame-vs-ode`),
which the report, the ordering study and the calibration judge overlays by, and the one rule that
applies them (`within`)."""
import math

#: Largest same-branch relative a1 error of the AME against eq. (21) per eta* over sigma in
#: [-0.05, 0.05] and the wind speeds studied (docs/ame_vs_ode21.md, `autocable bench ame-vs-ode`):
#: the largest of the summary's rows of that eta* (tests/test_ame_bounds.py reads the page). At
#: 1.4e-3 the U* = 0.7 row of the sample with the frame-indifferent angle sense, 2.76e-1 (2.65e-1
#: without wind; the legacy "reversed" sample gave 2.58e-1 at U* = 0.7).
STUDY_MAX_ERROR = {8.2e-5: 1.08e-3, 4.1e-4: 2.62e-2, 1.4e-3: 2.76e-1}

#: An AME equilibrium farther than this (relative, in the (a1, a2) plane) from eq. (21)'s response
#: is on another branch: the AME-vs-(21) study's rule.
NEAR = 0.5


def within(error, bound: float) -> bool:
    """An AME-vs-(21) error within the study's ``bound``: the error rounded as the study prints it
    (three significant digits) at most the bound, so a table and its verdict never disagree."""
    return error is not None and math.isfinite(error) and float(f"{error:.2e}") <= bound


def study_stamp(study: dict | None = None) -> list:
    """The study's bounds (default `STUDY_MAX_ERROR`) as plain data: what, besides the scenes,
    decides every ``<scene>.boxes`` statement, stamped on the records decided with it."""
    study = STUDY_MAX_ERROR if study is None else study
    return sorted([float(k), float(v)] for k, v in study.items())
