"""`autocable run`, `autocable chart`, `autocable sweep`: scene files and sweep files into output
folders."""
from __future__ import annotations

import math
import sys
from pathlib import Path

from autocable.cli.checks import check_folder, check_number, check_out, check_workers, dumps, refuse
from autocable.errors import EXIT_FAILED
from autocable.scene.schema import ENGINES, PLOT_UNITS, RESOLUTIONS, load_scene
from autocable.spec import SpecError


def _units_option(parser) -> None:
    parser.add_argument("--units", choices=PLOT_UNITS,
                        help="axes of the figures: the paper's nondimensional symbols (a_1, sigma, U*, eta*) "
                             "or SI (a_k l [m], sigma omega/2pi [Hz], U [m/s], eta [m]); default: the scene's "
                             "[plot] units, else paper")


def _load_scene(args):
    """The scene file with ``--units`` (when given) in place of its ``[plot] units``."""
    from dataclasses import replace
    scene = load_scene(args.scene)
    units = getattr(args, "units", None)
    return replace(scene, plot=replace(scene.plot, units=units)) if units else scene

def cmd_sweep(args) -> int:
    """`autocable sweep SWEEP.toml --out DIR`: a grid of steady responses as one dataset."""
    from autocable.scene.sweep_schema import load_sweep
    from autocable.studies.sweep import run_sweep
    check_out("--out", args.out)
    check_workers("--workers", args.workers)           # 0: serial, no Dask
    check_number("--chunk", args.chunk, 1, 10**6, integer=True)
    if args.scheduler is not None and not args.scheduler.strip():
        raise refuse("--scheduler", "an empty address; give one like tcp://host:8786 (or leave --scheduler out)")
    spec = load_sweep(args.sweep)
    if args.scheduler is not None:
        from autocable.studies.sweep import check_scheduler
        check_scheduler(args.scheduler)      # before the folder is made
    check_folder("--out", args.out)
    summary = run_sweep(spec, args.out, workers=args.workers, scheduler=args.scheduler, chunk=args.chunk,
                        log=None if args.quiet else (lambda s: print(s, file=sys.stderr)))
    print(dumps(summary, indent=1))
    if summary["failed"]:
        first = summary["failed"][0]
        print(f"autocable: sweep: {len(summary['failed'])} point(s) failed (kept out of sweep.nc as not computed; "
              f"a rerun tries them again), first at U={first['U']:g} eta={first['eta']:g} "
              f"sigma={first['sigma']:g}: {first['error']}", file=sys.stderr)
        return EXIT_FAILED
    return 0


def add_sweep_parser(subparsers) -> None:
    w = subparsers.add_parser("sweep", help="steady responses over a grid of (U, eta, sigma) on Dask; "
                              "writes DIR/sweep.nc (xarray) and resumes an interrupted sweep")
    w.add_argument("sweep", help="sweep file (TOML: model, method, [grid] U, eta, sigma)")
    w.add_argument("--out", required=True, help="output folder (points/, sweep.nc, sweep.json)")
    w.add_argument("--workers", type=int, default=None,
                   help="LocalCluster worker processes (default: one per core; 0: serial, without Dask)")
    w.add_argument("--scheduler", metavar="ADDRESS", help="an existing Dask scheduler, e.g. tcp://host:8786 "
                   "(its workers need autocable installed)")
    w.add_argument("--chunk", type=int, help="grid points per Dask task (default: about 8 tasks per worker, "
                   "at most 16 points; with follow: consecutive points of a line, default 1, each task "
                   "starting from the one before)")
    w.add_argument("--quiet", action="store_true", help="no progress")
    w.set_defaults(func=cmd_sweep)


def add_run_parser(subparsers) -> None:
    """Add ``autocable run SCENE.toml --out DIR [--quiet] [--no-plot]`` to an argparse subparsers."""
    r = subparsers.add_parser("run", help="run a scene file (runs/*.toml): continuation, results, plot")
    r.add_argument("scene", help="scene file (runs/*.toml)")
    r.add_argument("--out", help="output folder (default: out/<scene name>)")
    r.add_argument("--quiet", action="store_true", help="no progress on stderr")
    r.add_argument("--no-plot", action="store_true", help="write the tables only")
    r.add_argument("--resolution", choices=RESOLUTIONS, default="full",
                   help="coarse: longer steps, capped cycle runs, every third overlay value (what the tests run)")
    r.add_argument("--engine", choices=ENGINES,
                   help="override the scene's engine of equilibria, switching and cycles from Hopf points")
    _units_option(r)
    r.set_defaults(func=cmd_run)


def cmd_run(args) -> int:
    """Run a scene; print a summary (branches, special points, files) on stdout."""
    check_out("--out", getattr(args, "out", None))
    scene = _load_scene(args)
    out = Path(args.out) if getattr(args, "out", None) else Path("out") / scene.name
    # Before the computation, not after it: a folder that cannot be made would lose the results.
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("--out", "", f"cannot make the output folder {out}: {exc.strerror or exc}; "
                                     "give a folder that can be created") from None
    quiet = bool(getattr(args, "quiet", False))
    progress = None if quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    from autocable.scene.runner import run_scene
    from autocable.studies.advise import choose_ame
    res = run_scene(scene, out, progress=progress, plot=not getattr(args, "no_plot", False),
                    resolution=getattr(args, "resolution", "full") or "full",
                    engine=getattr(args, "engine", None), choose_ame=choose_ame)
    if not quiet and scene.time is not None:
        print(f"{scene.title}")
        summary = res.provenance["summary"]
        for src in ("ame", "ode21"):
            if src in summary:
                s = summary[src]
                period = s.get("modulation_period")
                print(f"  {src:<6} a1 in [{s.get('a1_min', math.nan):.6e}, {s.get('a1_max', math.nan):.6e}]  "
                      f"a2 in [{s.get('a2_min', math.nan):.6e}, {s.get('a2_max', math.nan):.6e}]  modulation period "
                      + (f"{period:.6g}" if period else "none (steady amplitude)") + f"  ({s['message']})")
        print(f"  results in {out}/ (time_series.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "") + ")")
    elif not quiet:
        print(f"{scene.title}")
        from autocable.scene.runner import summary_lines
        for line in summary_lines(res, scene.plot.units):      # in SI with units = "si"
            print(line)
        plane = scene.plot.plane and any(b.kind in ("fold", "hopf", "branch_point") for b in res.branches)
        print(f"  results in {out}/ (branches.csv, special_points.csv, run.json"
              + (f", {scene.name}.png, {scene.name}.pdf" if not getattr(args, "no_plot", False) else "")
              + (f", {scene.name}_plane.png, {scene.name}_plane.pdf" if plane and not getattr(args, "no_plot", False)
                 else "") + ")")
    return 0


def add_chart_parser(subparsers) -> None:
    """``autocable chart SCENE.toml --out DIR [--map DIR/sweep.nc]``: a stability chart."""
    c = subparsers.add_parser("chart", help="a stability chart: fold/Hopf/pitchfork curves of the AME in a "
                              "parameter plane, its response regions labelled, a brute-force map of eq. (21) overlaid")
    c.add_argument("scene", help="scene file with a [chart] table (e.g. runs/chart_U_eta.toml)")
    c.add_argument("--out", help="output folder (default: out/<scene name>)")
    c.add_argument("--map", help="a brute-force map of eq. (21) (the sweep.nc of `autocable sweep`) to overlay")
    c.add_argument("--quiet", action="store_true", help="no progress on stderr")
    c.add_argument("--resolution", choices=RESOLUTIONS, default="full",
                   help="coarse: longer continuation steps and half the classification grid (what the tests run)")
    _units_option(c)
    c.set_defaults(func=cmd_chart)


def cmd_chart(args) -> int:
    """Run a chart scene (its continuation runs and the [chart] table); print the regions and files."""
    check_out("--out", args.out)
    scene = _load_scene(args)
    if scene.chart is None:
        raise SpecError(scene.path, "chart", "missing; `autocable chart` draws a scene with a [chart] table "
                                             "(runs/chart_U_eta.toml is one); use `autocable run` for others")
    check_out("--map", args.map)
    if args.map and not Path(args.map).is_file():
        raise SpecError("arguments", "--map", f"no such file: {args.map}; give the sweep.nc that "
                                              "`autocable sweep` wrote")
    out = Path(args.out) if args.out else Path("out") / scene.name
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise SpecError("--out", "", f"cannot make the output folder {out}: {exc.strerror or exc}; "
                                     "give a folder that can be created") from None
    progress = None if args.quiet else (lambda msg: print(msg, file=sys.stderr, flush=True))
    from autocable.scene.runner import run_scene
    from autocable.studies.advise import choose_ame
    res = run_scene(scene, out, progress=progress, resolution=args.resolution, choose_ame=choose_ame,
                    response_map=args.map)
    if not args.quiet:
        import json
        data = json.loads((out / "regions.json").read_text())
        print(f"{scene.title}")
        for b in res.branches:
            if b.parameter2:
                pts = ", ".join(f"{s.label} ({b.parameter} = {s.value:.6g}, {b.parameter2} = {s.extra['value2']:.6g})"
                                for s in b.special_points if s.origin == "autocable")
                print(f"  {b.name:<10} {b.kind:<12} {len(b):>5} points  {pts}")
        x, y = data["plane"]
        # The regions the chart labels (at least 1 % of the grid); the small ones are counted.
        least = max(2, data["grid"][0] * data["grid"][1] // 100)
        for g in data["regions"]:
            if g["cells"] >= least:
                print(f"  region {g['label']:<36} {g['cells']:>4} cells, labelled at {x} = {g[x]:.4g}, {y} = {g[y]:.4g}")
        small = [g for g in data["regions"] if g["cells"] < least]
        if small:
            print(f"  and {len(small)} regions of fewer than {least} cells (coloured, not labelled; regions.json lists them)")
        if "map" in data:
            m = data["map"]
            print(f"  map: {m['points']} points of eq. (21), the AME's class predicts {m['agree']} of them")
        print(f"  results in {out}/ ({scene.name}_chart.png, .pdf, regions.csv, regions.json, branches.csv, run.json)")
    return 0
