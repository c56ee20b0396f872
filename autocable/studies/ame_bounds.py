"""The bounds of the AME-against-eq.-(21) study (docs/ame_vs_ode21.md, `autocable bench ame-vs-ode`),
which the report and the ordering study judge overlays by."""

#: Largest same-branch relative a1 error of the AME against eq. (21) per eta* over sigma in
#: [-0.05, 0.05] and the wind speeds studied (docs/ame_vs_ode21.md, `autocable bench ame-vs-ode`):
#: the largest of the summary's rows of that eta* (tests/test_ame_bounds.py reads the page). At
#: 1.4e-3 the U* = 0.7 row of the sample with the frame-indifferent angle sense, 2.76e-1 (2.65e-1
#: without wind; the legacy "reversed" sample gave 2.58e-1 at U* = 0.7).
STUDY_MAX_ERROR = {8.2e-5: 1.08e-3, 4.1e-4: 2.62e-2, 1.4e-3: 2.76e-1}

#: An AME equilibrium farther than this (relative, in the (a1, a2) plane) from eq. (21)'s response
#: is on another branch: the AME-vs-(21) study's rule.
NEAR = 0.5
