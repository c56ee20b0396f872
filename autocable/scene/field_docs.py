"""What every field of autocable's input files means: model specs (`autocable.spec`), scene files
(`autocable.scene.schema`, with the ``[chart]`` table of stability charts) and sweep files
(`autocable.scene.sweep_schema`), one short text per field, keyed by its dotted name as an error
message names it (``plot.units``, ``run.steps.max_step``).

The file references of the documentation are generated from these texts and from the schemas' own
lists of allowed keys (`autocable.scene.reference`); tests/test_reference.py fails when a key the
schema accepts has no text here, or a text names a key the schema no longer accepts."""
from __future__ import annotations

#: Model spec (``models/*.toml``): SI units; paper symbols of Sect. 2 and 5.
MODEL = {
    "name": "A one-line label of the model (names outputs and cache entries); default: the file's stem.",
    "description": "Free text.",
    "cable": "The cable of Sect. 2.1 and Sect. 5 (table).",
    "aero": "The quasi-steady cable-rivulet load of Sect. 2.3, eqs. (9)-(14) (table).",
    "cable.length_m": "l, the initial length (the chord, for a nearly taut cable) [m].",
    "cable.chord_slope_deg": "alpha, the slope of the chord [deg]; negative: the lower end at the right.",
    "cable.horizontal_tension_N": "H-bar, the horizontal component of the static tension [N].",
    "cable.mass_per_length_kg_m": "m, the mass per unit length [kg/m].",
    "cable.diameter_m": "D, the outer diameter [m] (the load length of eq. 11 with load_length = \"diameter\").",
    "cable.axial_stiffness_N": "EA [N]. The paper prints 29.7e6 N; 2.1688e9 N (E = 195 GPa on the full section) "
                               "gives its omega1 = 1.004 (docs/model.md).",
    "cable.bending_stiffness_Nm2": "EI [N m^2] (with GJ, the ratio chi = GJ/EI of eq. 20).",
    "cable.torsional_stiffness_Nm2": "GJ [N m^2].",
    "cable.damping_ratio": "xi_s, the modal damping ratio of both modes (Sect. 3; 0.004 is 0.4 %).",
    "cable.gravity_m_s2": "g [m/s^2]; default 9.81.",
    "cable.twist_ends": "End conditions of the twist, eq. (20): \"natural\" (as printed; default) or "
                        "\"restrained\" (theta = 0 at both anchorages).",
    "cable.mode_pair": "k, the mode pair of eq. (21): the k-th in-plane mode (by frequency) and the k-th "
                       "out-of-plane mode sin(k pi s) with its slaved twist; default 1 (the paper's pair). "
                       "`--pair K` of derive, simulate and onset overrides it (docs/mode-pairs.md).",
    "aero.air_density_kg_m3": "rho_a [kg/m^3]; not printed by the paper (1.25 in the sample).",
    "aero.rivulet_diameter_ratio": "d/D of the rivulet; documents the A_k, B_k data (enters only through them).",
    "aero.lift": "A_0..A_3 of eq. (13): the cubic fit of the lift coefficient.",
    "aero.drag": "B_0..B_3 of eq. (13): the cubic fit of the drag coefficient.",
    "aero.critical_wind_speed_m_s": "U_c of eq. (18) [m/s]: U* = U / U_c, and the wind at which a "
                                    "calibrated angle makes the trivial solution lose stability.",
    "aero.yaw_deg": "beta, the yaw of the wind [deg], or \"calibrate\" (not printed by the paper).",
    "aero.rivulet_angle_deg": "Theta0, the rivulet's angle [deg], or \"calibrate\" (the sample calibrates it "
                              "to U_c; not printed by the paper).",
    "aero.load_length": "The length in eq. (11): \"diameter\" (1/2 rho V^2 D; default) or \"radius\".",
    "aero.angle_convention": "Required: the sense of phi against the relative-wind angle in eq. (12), "
                             "\"eq12\" (as printed) or \"reversed\"; the two give different cables.",
    "aero.calibration_root": "Which root a calibration keeps: \"smallest\" |angle| (default, the only choice).",
    "aero.load_axes": "The axes the load is projected on in eq. (14): \"reference\" (initial section axes; "
                      "default) or \"twisted\" (turned by the twist).",
    "aero.valid_phi_deg": "[lo, hi]: the range of phi (eq. 12, deg) over which the curves hold; results whose "
                          "motion leaves it are flagged (beyond_valid_range). Default: phi0 +- 15 deg for the cubic "
                          "fits, a table's own range (docs/aero-curves.md).",
    "aero.outside": "Beyond valid_phi_deg: \"cubic\" (the fits as they are; default) or \"dry-cylinder\" (the "
                    "fits blended smoothly to the dry cylinder's c_l = 0, c_d = dry_drag).",
    "aero.blend_deg": "The width of that blend [deg]; default 10.",
    "aero.dry_drag": "The dry circular cylinder's drag coefficient beyond the blend; default 1.2 (subcritical "
                     "Reynolds number; stays sit near the drag crisis, docs/aero-curves.md).",
    "aero.table": "Lift and drag measured against phi: a CSV file (relative to the model file) or an "
                  "[aero.table] with phi_deg, lift, drag (and periodic); replaces the cubic fits.",
    "aero.load": "The rung of the load: \"cubic\" (its cubic expansion, eq. 14: the paper's eq. 21; default) or "
                 "\"exact\" (eqs. 11-13 without expansion at every section, projected by quadrature; "
                 "docs/exact-load.md). `--load` of simulate, onset and gallop overrides it.",
    "damper": "A viscous damper near the lower anchorage (docs/dampers.md): its modal damping is added to "
              "cable.damping_ratio in onset, the frequency responses and the amplitude studies.",
    "damper.position_m": "x_d, the damper's distance from the lower anchorage along the chord [m].",
    "damper.constant_N_s_m": "c, the damper's viscous constant [N s/m].",
    "damper.support_stiffness_N_m": "k_s, the stiffness of the damper's support, in series with it [N/m]; "
                                    "left out: a rigid support.",
}

#: Scene files (``runs/*.toml``): one paper figure each.
SCENE = {
    "title": "Free text; the plot's default title.",
    "description": "Free text.",
    "model": "The model spec, a path relative to the scene file.",
    "ame": "The amplitude equations: \"2dof\" (eq. 24, default), \"1dof\" (the A2 = 0 reduction of Sect. 5), "
           "\"1dof-amplitude\" (the polar eq. 23 at eta = 0, Fig. 3) or \"auto\" (the lightest within ame_tol, "
           "chosen by `autocable advise`'s probes).",
    "ame_tol": "With ame = \"auto\": the relative tolerance on a1, a2 (default 0.02).",
    "ordering": "The Multiple Scales ordering of Sect. 4: \"paper\" (every aerodynamic term at third order; "
                "default) or \"natural\".",
    "engine": "Equilibria, switching and cycles: \"pycont\" (PyCont EP-C, LC-C; default) or \"compiled\" "
              "(autocable's C kernel and collocation; the same branches, 25-100x faster). Curves always use PyCont.",
    "state_scale": "The amplitude scale of the continuation: \"auto\" (default: the linear forced response) or "
                   "a positive number.",
    "units": "The units of the file's inputs: \"paper\" (U*, eta*, sigma of eqs. 17-18; default) or \"si\": "
             "every U in m/s, eta in m (the support motion) and sigma as the deck frequency in Hz, converted on "
             "the model's cable (U* = U/U_c, eta* = eta/l, sigma = 2 pi f/omega - omega1); [plot] units then "
             "defaults to \"si\".",
    "fixed": "U, eta, sigma shared by every run (table; default 0 each).",
    "fixed.U": "U* = U / U_c, the nondimensional wind speed (eq. 18).",
    "fixed.eta": "eta* = eta / l, the nondimensional support amplitude (eq. 18).",
    "fixed.sigma": "sigma, the detuning of the excitation frequency: Omega = omega1 + sigma.",
    "run": "The continuation runs, in order (array of tables [[run]]).",
    "run.name": "The branch name: letters, digits, '_' and '-'.",
    "run.kind": "\"equilibria\" (default), \"cycles\" (from start = \"RUN:Hk\" or { orbit = [a1, a2] }), "
                "\"switch\" (from \"RUN:BPk\") or \"curve\" (from \"RUN:LPk\", \"RUN:Hk\" or \"RUN:BPk\": a "
                "two-parameter curve of folds, Hopf points or pitchforks).",
    "run.parameter": "The continued parameter: \"sigma\", \"U\" or \"eta\".",
    "run.range": "[lo, hi] of the continued parameter.",
    "run.start": "\"trivial\" | \"RUN:LABEL\" | { integrate = [a1, a2] } | { state = [r1, s1, r2, s2] } | "
                 "{ orbit = [a1, a2] } (cycles) | { search = [v1, ...] } (every stable equilibrium Newton finds "
                 "at those values: isolas and disconnected branches).",
    "run.at": "The parameter's start value (default: range[0], or the label's).",
    "run.directions": "\"both\" (default), \"forward\" or \"backward\" (curves: forward = increasing parameter2).",
    "run.cycles": "Follow-up: continue the periodic orbits born at every Hopf point of the run (default false).",
    "run.switch": "Follow-up: switch branches at every branch point of the run (default false).",
    "run.fixed": "Per-run overrides of [fixed] (U, eta, sigma).",
    "run.steps": "Step controls of this run (table; the names of ContinuationSettings below).",
    "run.parameter2": "Curves only: the second parameter.",
    "run.range2": "Curves only: [lo, hi] of the second parameter.",
    "run.steps.step": "The initial pseudo-arclength step (scaled units: the range spans 1).",
    "run.steps.min_step": "The smallest step before the branch is ended.",
    "run.steps.max_step": "The largest step.",
    "run.steps.max_points": "Points per direction (equilibria) or per cycle branch.",
    "run.steps.chunk": "PyCont points per call (range and closure checked in between).",
    "run.steps.max_corrector_iters": "Newton iterations of the corrector per point.",
    "run.steps.tol": "PyCont's FuncTol and VarTol (scaled units).",
    "run.steps.test_tol": "PyCont's TestTol (locating special points).",
    "run.steps.newton_tol": "autocable's refinement of special points: relative Newton step.",
    "run.steps.ntst": "Mesh intervals of the periodic-orbit collocation.",
    "run.steps.ncol": "Collocation points per interval.",
    "run.steps.cycle_step": "Initial step of cycle continuation.",
    "run.steps.cycle_max_step": "Largest step of cycle continuation.",
    "run.steps.cycle_max_points": "Points of a cycle branch at most.",
    "run.steps.max_period_ratio": "A cycle branch ends when its period exceeds this times the Hopf period.",
    "run.steps.switch_step": "The step off a branch point when switching.",
    "run.steps.curve_step": "Initial step of a two-parameter curve.",
    "run.steps.curve_max_step": "Largest step of a two-parameter curve.",
    "run.steps.curve_max_points": "Points of a curve per direction.",
    "run.steps.curve_check_tol": "The independent check of every curve point: sigma_min(J) / sigma_max(J).",
    "run.steps.settle_seconds": "Wall-time budget of one integration to an equilibrium or orbit (a start).",
    "run.steps.settle_evaluations": "Right-hand-side evaluations budget of that integration.",
    "run.steps.orbit_seconds": "Wall-time budget of finding a periodic orbit by integration.",
    "plot": "The figure (table).",
    "plot.x": "The horizontal axis: a parameter (default: the first run's).",
    "plot.y": "One panel per amplitude: a list of \"a1\" and/or \"a2\".",
    "plot.title": "The figure's title (default: the scene title).",
    "plot.labels": "Write the special points' labels (H1, LP1, BP1) on the plot (default true).",
    "plot.plane": "[p, p2]: the parameter plane of the curves, <scene>_plane.png (default: the first curve run's).",
    "plot.units": "\"paper\" (default: a_1, sigma, U*, eta* of eqs. 17-18) or \"si\" (a_k l [m], "
                  "sigma omega / 2 pi [Hz], U [m/s], eta [m], t [s]); `--units` on the command line overrides it.",
    "compare": "Digitised points of the published figure to draw and measure against (table).",
    "compare.csv": "The points: columns x, y, curve, stable (a path relative to the scene).",
    "compare.panel": "The amplitude panel they belong to (default: the first).",
    "compare.label": "The legend's word for them (default \"digitised\").",
    "overlay": "Direct integrations swept up and down over a parameter, drawn as the paper's empty boxes (table).",
    "overlay.method": "\"ode21\" (eq. 21 itself; default) or \"ame\".",
    "overlay.parameter": "The swept parameter (default: plot.x).",
    "overlay.range": "[lo, hi] (default: the first run's range of that parameter).",
    "overlay.points": "Values in the range, evenly spaced (1 to 201; default 11).",
    "overlay.directions": "[\"up\", \"down\"] (default both): each point starts from the previous response.",
    "overlay.max_time": "Integration time per point at most (t* units; default 30000).",
    "time": "A time scene (Fig. 11) instead of runs: the AME and eq. (21) integrated at one point (table).",
    "time.U": "U* (> 0).",
    "time.eta": "eta*.",
    "time.sigma": "sigma.",
    "time.t_end": "The end time (t* units).",
    "time.start": "\"rest\" (q2 = 1e-6) or { amplitudes = [a1, a2] }.",
    "time.ode21": "Also the amplitude envelope of eq. (21) (default true).",
    "time.summary_from": "The summary's window starts here (default t_end / 2).",
    "time.samples_per_period": "AME output samples per forcing period (1 to 64; default 2).",
    "chart": "A stability chart in a parameter plane (table; `autocable chart`).",
    "chart.plane": "[x, y]: two parameters (default: plot.plane); the third comes from [fixed].",
    "chart.x_range": "The chart's extent in x (default: the curve runs' range).",
    "chart.y_range": "The chart's extent in y (default: the curve runs' range2).",
    "chart.grid": "[nx, ny]: points where the AME's response is classified.",
    "chart.t_end": "AME integration time per start and point (t* units).",
    "chart.starts": "[[a1, a2], ...]: the starts of the classification.",
    "chart.map": "A brute-force map of eq. (21) (the sweep.nc of `autocable sweep`) to overlay, relative to the scene.",
}

#: Sweep files: a grid of steady responses of eq. (21) (or its AME).
SWEEP = {
    "title": "Free text.",
    "model": "The model spec, relative to the sweep file or absolute.",
    "method": "\"shooting\" (default: Newton on the period map, with Floquet multipliers), \"ode21\" (transient "
              "integration) or \"ame\" (the AME integrated to its steady state).",
    "q0": "The start (q1, q1', q2, q2'); default rest with q2 = 1e-6.",
    "max_time": "Give up on a point after this time (t* units; default 60000).",
    "follow": "Along this axis each point starts from its neighbour's response (\"U\", \"eta\" or \"sigma\").",
    "direction": "With follow: \"up\" (default) or \"down\" the axis.",
    "grid": "The axes (table): each a number, a list, or { from = .., to = .., num = .. }.",
    "grid.U": "U* values (default 0).",
    "grid.eta": "eta* values (default 0).",
    "grid.sigma": "sigma values (default 0).",
    "grid.start": "A list of starts [[q1, q1', q2, q2'], ...] as one more axis (instead of q0).",
}
