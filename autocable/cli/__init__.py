"""The `autocable` command: derive, onset, simulate, run, chart, sweep, figures, bench, calibrate.

Errors a user can fix (a bad spec, a bad option, a failed build or run) are printed as one line
naming the file and field; no traceback. ``AUTOCABLE_DEBUG=1`` shows tracebacks. The exit status is
`autocable.errors`'s: 0 a result, 2 bad input, 3 a failed computation, 130 interrupted.

One module per group of commands: `derivation`, `simulate`, `runs` (run, chart, sweep), `studies`
(bench, advise, failure-map, calibrate); `checks` holds the option checks and the strict JSON.
"""
from __future__ import annotations

import argparse
import errno
import os
import sys

from autocable._paths import SAMPLE_MODEL
from autocable._version import __version__
from autocable.errors import EXIT_FAILED, EXIT_INPUT, EXIT_INTERRUPTED, CacheError, ComputationError
from autocable.paper.figures import add_figures_parser
from autocable.cli.checks import refuse
from autocable.cli.derivation import LOAD_HELP, PAIR_HELP, cmd_derive
from autocable.cli.damper import add_damper_parser
from autocable.cli.gallop import add_gallop_parser
from autocable.cli.onset import add_onset_parser
from autocable.cli.runs import add_chart_parser, add_run_parser, add_sweep_parser
from autocable.cli.simulate import add_si_options, cmd_simulate
from autocable.cli.studies import cmd_advise, cmd_bench, cmd_calibrate, cmd_failure_map
from autocable.spec import SpecError

__all__ = ["main", "build_parser", "add_run_parser"]

def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="autocable", description=__doc__.splitlines()[0])
    p.add_argument("--version", action="version", version=f"autocable {__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    d = sub.add_parser("derive", help="derive eq. (21) from a model spec and report its coefficients")
    d.add_argument("model", help="model spec file (models/*.toml)")
    d.add_argument("--json", action="store_true", help="one JSON object instead of the report "
                   "(key 'ame': the Cartesian amplitude equations (24) as a coefficient table)")
    d.add_argument("--latex", action="store_true", help="print the amplitude equations (22) in LaTeX")
    d.add_argument("--ordering", choices=("paper", "natural"), default="paper",
                   help="Multiple Scales ordering of the AME: 'paper' (Sect. 4, every aerodynamic term at "
                        "third order; default) or 'natural' (aerodynamic terms at their natural order)")
    d.add_argument("--pair", type=int, metavar="K", help=PAIR_HELP)
    d.set_defaults(func=cmd_derive)

    s = sub.add_parser("simulate", help="integrate eq. (21) (or its amplitude equations) to a steady state")
    s.add_argument("model")
    s.add_argument("--U", type=float, default=0.0, help="nondimensional wind speed U* = U/U_c")
    s.add_argument("--eta", type=float, default=0.0, help="nondimensional support amplitude eta* = eta/l")
    s.add_argument("--sigma", type=float, default=0.0, help="external detuning: Omega = omega1 + sigma")
    s.add_argument("--q0", type=float, nargs=4, metavar=("Q1", "Q1DOT", "Q2", "Q2DOT"),
                   help="initial state (default: rest with q2 = 1e-6)")
    s.add_argument("--max-time", type=float, default=60000.0, help="give up after this time (t* units)")
    s.add_argument("--json", action="store_true")
    s.add_argument("--csv", metavar="FILE", help="write the time history (thinned to at most 50,000 rows "
                   "unless --every or --samples says otherwise)")
    s.add_argument("--every", type=int, metavar="N", help="--csv: keep every N-th sample (of 64 per forcing "
                   "period; --every 1 keeps them all)")
    s.add_argument("--samples", type=int, metavar="N", help="--csv: at most N rows, evenly thinned "
                   "(default 50000)")
    s.add_argument("--plot", metavar="STEM", help="draw STEM.png and STEM.pdf: q1, q2 against time with their "
                   "envelope, the phase plane and the Poincare section at the forcing period (--method ode21)")
    s.add_argument("--units", choices=("paper", "si"), default="paper",
                   help="axes of --plot: the paper's nondimensional quantities (default) or SI units")
    s.add_argument("--quiet", action="store_true", help="no progress (on a terminal a progress bar, "
                   "otherwise one line per tenth of --max-time)")
    s.add_argument("--method", choices=["ode21", "ame", "shooting"], default="ode21",
                   help="ode21: direct integration of eq. (21); ame: the Multiple Scales amplitude "
                        "equations (24) to their steady state; shooting: the steady response of eq. (21) "
                        "by Newton on the period map after a short transient, with its Floquet "
                        "multipliers and class (rest, period-1, period-2, quasi-periodic, diverged) "
                        "(default ode21)")
    s.add_argument("--modes", type=int, metavar="N",
                   help="integrate eq. (21) with N in-plane and N out-of-plane modes (the check that "
                        "two modes suffice); a1, a2 are the first modes' amplitudes")
    s.add_argument("--pair", type=int, metavar="K", help=PAIR_HELP + "; the forcing is near the pair's in-plane "
                   "frequency, Omega = omega1 + sigma")
    s.add_argument("--load", choices=("cubic", "exact"), help=LOAD_HELP)
    add_si_options(s)
    s.set_defaults(func=cmd_simulate)

    b = sub.add_parser("bench", help="benchmarks (speed and accuracy); prints JSON")
    b.add_argument("what", nargs="?", default=None,
                   choices=["derive", "ame-vs-ode", "continuation", "auto", "figures", "bound-scenes", "ordering",
                            "engines", "shooting", "sweep", "kill", "kill-surfaces", "fuzz", "onset", "calibration",
                            "pairs", "exact-load", "gallop"],
                   help="derive: derivation time and integration speed; ame-vs-ode: error map of the "
                        "amplitude equations against eq. (21) (with --out, also ame_vs_ode21.md/.png); "
                        "continuation: EP-C cost per point and a Fig. 6-sized scene, cold and warm; "
                        "auto: EP-C cost per point against AUTO-07p (bifpy; set AUTOCABLE_AUTO_PYTHON "
                        "or install autocable[auto]); figures: wall time of `autocable figures` (all scenes), "
                        "cold, warm (stored scenes reused) and recomputed on the warm cache (--recompute), with "
                        "the share of each stage; bound-scenes: the calibration "
                        "bound stage's wind scenes of one model (--model) as the stage runs them (no figures, "
                        "orbit-started runs dropped), wall, CPU and scene seconds per scene; ordering: the paper's and the "
                        "natural Multiple Scales ordering (2-dof and A2 = 0) against eq. (21) at Figs. 4c, 7, 9 "
                        "(with --out, also ordering.md/.png); engines: every figure scene on PyCont and on the compiled "
                        "kernel (coarse), their special points compared; shooting: steady points of eq. (21) by "
                        "shooting against transient integration at equal accuracy (Figs. 5-10, 77 points); "
                        "sweep: 'autocable sweep' throughput with 1 and 2 Dask workers and the scaling; "
                        "fuzz, kill, kill-surfaces: moved out of the package (the hardening harness: "
                        "python -m tools.hardening in the repository); "
                        "onset: the onset report and a 50-point damping grid of `autocable onset` (target under 2 s "
                        "warm); gallop: `autocable gallop` on one cable (--model) and mode pair, cold (compiled "
                        "builds) and warm (target under 10 s); calibration: the screen of "
                        "8 points on 1 and 2 workers (the scaling) and the bound stage on 20 candidate models "
                        "(stage wall time and summed scene time); pairs: `autocable onset --modes-below 3 "
                        "--design-wind 25` on models/stay_190m.toml (or --model): the linear table cold and warm, "
                        "then the whole table with its galloping columns on the cubic load (target 30 s) and, for "
                        "a model with blended curves, on the exact load (wall and CPU); exact-load: "
                        "the exact quasi-steady load's compiled right-hand side against eq. (21)'s cubic one, "
                        "ns per evaluation, forced and autonomous (target under 3x). "
                        "Without a subcommand "
                        "(--out DIR): the work-precision bench of the method ladder (bench.json, "
                        "work_precision.png, work_precision.md)")
    b.add_argument("--model", default=str(SAMPLE_MODEL))
    b.add_argument("--repeats", type=int, default=3)
    b.add_argument("--out", help="folder to write bench_<what>.json")
    b.add_argument("--quiet", action="store_true")
    b.add_argument("--quick", action="store_true", help="work-precision bench: the one-minute version "
                   "(Fig. 5a only, coarse reference, two knob settings per method, no repeats)")
    b.add_argument("--scene", action="append", metavar="SCENE",
                   help="work-precision bench: a scene name (fig06) or file; repeatable (default: "
                        "fig05a, fig06, fig09 and fig10 when its file exists)")
    b.set_defaults(func=cmd_bench)

    adv = sub.add_parser("advise", help="which rung of the method ladder a scene needs at a tolerance "
                                        "(1-dof AME, 2-dof AME, or eq. (21) itself), with the evidence")
    adv.add_argument("scene", help="scene file (runs/*.toml)")
    adv.add_argument("--tol", type=float, default=0.02, help="relative tolerance on a1, a2 (default 0.02)")
    adv.add_argument("--json", action="store_true", help="one JSON object instead of the report")
    adv.set_defaults(func=cmd_advise)

    fm = sub.add_parser("failure-map", help="maps over (sigma, eta) and (sigma, U) of where the AME "
                        "and the integrators fail; writes failure_map.md and failure_map_<k>.png")
    fm.add_argument("--out", required=True, help="folder for failure_map.md and the figures")
    fm.add_argument("--quick", action="store_true", help="a tiny grid (seconds, for tests)")
    fm.add_argument("--model", default=str(SAMPLE_MODEL))
    fm.add_argument("--quiet", action="store_true", help="no progress")
    fm.set_defaults(func=cmd_failure_map)

    cal = sub.add_parser("calibrate", help="search the paper's unknown inputs (yaw, rivulet angle, "
                         "and the readings it leaves open) against the statements of Sect. 5; writes "
                         "calibration.csv, calibration.md and beta-Theta0 maps")
    cal.add_argument("model", help="model spec file (models/*.toml)")
    cal.add_argument("targets", help="targets file (models/*.targets.toml)")
    cal.add_argument("--out", required=True, help="output folder (resumable: finished points are reused)")
    cal.add_argument("--space", help="search-space file (default: <model>.search.toml beside the model if "
                                     "it exists, else the built-in space)")
    cal.add_argument("--workers", type=int, help="Dask worker processes of a LocalCluster for every stage (screen "
                                                 "points, full evaluations, bound scenes; default: one per "
                                                 "core; 0: in this process, one task after the other)")
    cal.add_argument("--jobs", type=int, dest="workers", help=argparse.SUPPRESS)   # the older name of --workers
    cal.add_argument("--scheduler", metavar="ADDRESS", help="run every stage on an existing Dask cluster: its "
                     "scheduler's address (tcp://host:8786) or scheduler file (docs/cluster.md)")
    cal.add_argument("--full", type=int, help="candidates evaluated on every figure scene (overrides the space's)")
    cal.add_argument("--bound", action="store_true",
                     help="then ask of every candidate whether it can reach the targets file's [goal] (branch "
                          "and bound: its wind scenes one at a time until its upper bound is below the goal); "
                          "writes bound.csv and bound.png")
    cal.add_argument("--bound-minutes", type=float, help="start no scene of the bound stage after this many "
                                                         "minutes; a rerun goes on with the candidates left")
    cal.add_argument("--bound-margin", type=int, default=0,
                     help="stop a candidate only when its bound is below the goal by more than this many "
                          "statements (default 0): with N, the conclusion holds even if any N of the decisions "
                          "that lowered a bound were wrong")
    cal.add_argument("--prior-bound", metavar="CSV",
                     help="an earlier call's bound.csv: its models of readings outside this space join "
                          "bound.csv, bound.png and calibration.md (a space grown by one reading is bounded "
                          "without deciding the others again)")
    cal.add_argument("--quiet", action="store_true", help="no progress lines")
    cal.set_defaults(func=cmd_calibrate)

    add_onset_parser(sub)
    add_damper_parser(sub)
    add_gallop_parser(sub)
    add_run_parser(sub)
    add_chart_parser(sub)
    add_sweep_parser(sub)
    add_figures_parser(sub)
    return p


def main(argv=None) -> int:
    args = build_parser().parse_args(argv)
    import warnings
    from autocable.model.premises import PremiseWarning
    from autocable.results import TruncatedBranchWarning

    def one_line(message, category, filename, lineno, file=None, line=None):
        # a stretched premise or a branch cut at its point budget is news for the user, not a
        # Python warning with a source line
        if issubclass(category, (PremiseWarning, TruncatedBranchWarning)):
            print(f"autocable: warning: {message}", file=sys.stderr)
        else:
            shown(message, category, filename, lineno, file, line)

    with warnings.catch_warnings():
        shown = warnings.showwarning
        warnings.showwarning = one_line
        warnings.simplefilter("default", PremiseWarning)    # once per place and text, every call
        return _dispatch(args)


#: The positional file arguments of the commands (model spec, scene, targets, sweep file).
_INPUT_ARGUMENTS = ("model", "scene", "targets", "sweep")


def _dispatch(args) -> int:
    """`main` after parsing: the command, its failures mapped to the exit status of `autocable.errors`."""
    if os.environ.get("AUTOCABLE_DEBUG"):
        return args.func(args)
    try:
        # an input file given as "" would read as the current folder: name the argument instead
        for arg in _INPUT_ARGUMENTS:
            if isinstance(getattr(args, arg, None), str) and not getattr(args, arg).strip():
                raise refuse(arg.upper(), "an empty path; give the file")
        return args.func(args)
    except SpecError as exc:
        print(f"autocable: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    except CacheError as exc:
        # a full disk, a quota or an I/O error under the cache: the run failed where it stood (exit
        # 3, as for any other storage fault); a cache that cannot be written is a path to change
        storage = exc.errno in (errno.ENOSPC, errno.EDQUOT, errno.EIO)
        print(f"autocable: {'failed' if storage else 'error'}: {exc}", file=sys.stderr)
        return EXIT_FAILED if storage else EXIT_INPUT
    except ComputationError as exc:
        print(f"autocable: failed: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except BrokenPipeError:            # output piped into `head` and cut: not an error
        return 0
    except OSError as exc:             # a file that cannot be written or read mid-run: named, not raw
        from autocable.cli.checks import os_error
        if not (exc.filename or exc.filename2) and exc.errno not in (errno.ENOSPC, errno.EDQUOT, errno.EIO):
            first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            print(f"autocable: error ({type(exc).__name__}): {first} (set AUTOCABLE_DEBUG=1 for details)",
                  file=sys.stderr)
            return EXIT_INPUT
        message, status = os_error(exc, args)
        print(f"autocable: {'failed' if status == EXIT_FAILED else 'error'}: {message}", file=sys.stderr)
        return status
    except KeyboardInterrupt:
        print("autocable: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Exception as exc:  # a failure we did not foresee: one line, never a raw traceback
        from autocable.codegen.compat import PyDSToolError
        kind = "PyDSTool" if isinstance(exc, PyDSToolError) else type(exc).__name__
        first = str(exc).splitlines()[0] if str(exc) else kind
        print(f"autocable: error ({kind}): {first} (set AUTOCABLE_DEBUG=1 for details)", file=sys.stderr)
        return 2

