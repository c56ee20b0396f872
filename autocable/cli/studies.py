"""`autocable bench`, `autocable advise`, `autocable failure-map`, `autocable calibrate`: the
benchmarks and studies."""
from __future__ import annotations

import sys
from pathlib import Path

from autocable.cli.checks import (REPEATS_LIMIT, check_folder, check_number, check_out,
                                  check_workers, dumps, refuse, strict)
from autocable.spec import SpecError, load_model

#: The `bench` subcommands that were the hardening harness (now tools/hardening in the repository).
HARNESS = ("fuzz", "kill", "kill-surfaces")


def cmd_work_precision(args) -> int:
    """`autocable bench --out DIR` without a subcommand: the method ladder's work-precision bench."""
    from autocable.studies.work_precision import run_bench as run_work_precision
    if args.out is None:
        raise SpecError("bench", "--out", "the work-precision bench writes files: give --out DIR "
                        "(or name a subcommand: derive, ame-vs-ode, continuation, auto, ...)")
    result = run_work_precision(args.out, scenes=args.scene or None, quick=args.quick,
                                repeats=max(args.repeats, 0),
                                log=None if args.quiet else (lambda s: print(s, file=sys.stderr)))
    print(dumps({"summary": result["summary"], "notes": result["notes"],
                      "wall_seconds": result["wall_seconds"],
                      "files": [str(Path(args.out) / f) for f in ("bench.json", "work_precision.png",
                                                                  "work_precision.md")]}, indent=1))
    return 0


def cmd_advise(args) -> int:
    from autocable.studies.advise import cmd_advise
    return cmd_advise(args)


def cmd_bench(args) -> int:
    if args.what in HARNESS:
        # test tools, not the product: they live in the repository, outside the shipped package
        raise refuse(f"bench {args.what}", "the hardening harness moved out of the package; from the "
                     f"repository's top folder run: python -m tools.hardening {args.what} (docs/robustness.md)")
    check_number("--repeats", args.repeats, 0, REPEATS_LIMIT, integer=True)
    check_out("--out", args.out)
    check_folder("--out", args.out)
    if args.what is None:
        return cmd_work_precision(args)
    from autocable.bench.commands import run_bench
    result = run_bench(args.what, args.model, repeats=args.repeats,
                       log=None if args.quiet else (lambda s: print(s, file=sys.stderr)),
                       out=args.out)
    if args.out:
        from autocable._store import atomic_write_json
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        atomic_write_json(out / f"bench_{args.what}.json", strict(result))
    print(dumps(result, indent=1))
    return 0


def cmd_failure_map(args) -> int:
    """`autocable failure-map`: where the AME and the integrators fail."""
    import time
    from autocable.studies.failure_map import run_failure_map
    from autocable.studies.failure_map_report import write_failure_map
    check_out("--out", args.out)
    check_folder("--out", args.out)
    say = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    t0 = time.perf_counter()
    result = run_failure_map(args.model, quick=args.quick, log=say)
    command = "autocable failure-map --out DIR" + (" --quick" if args.quick else "")
    files = write_failure_map(result, args.out, command)
    print("\n".join(result["statement"]))
    print(f"wrote {', '.join(str(f) for f in files)} in {time.perf_counter() - t0:.0f} s")
    return 0


# ------------------------------------------------------------------------------------------------
# autocable run
# ------------------------------------------------------------------------------------------------


def cmd_calibrate(args) -> int:
    """`autocable calibrate MODEL TARGETS --out DIR` (autocable.paper.calibration)."""
    from dataclasses import replace as _replace

    from autocable.paper import calibration as study
    check_out("--out", args.out)
    check_workers("--workers", args.workers)           # 0: this process, one task after the other
    if args.scheduler is not None:
        from autocable.executor import check_scheduler
        check_scheduler(args.scheduler)
    check_number("--full", args.full, 0, 10**6, integer=True)
    check_number("--bound-margin", args.bound_margin, 0, 10**3, integer=True)
    if args.bound_minutes is not None:
        check_number("--bound-minutes", args.bound_minutes, 0, 10**6)
    if args.space is not None and not args.space.strip():
        raise refuse("--space", "an empty path; give the search-space file (or leave --space out for the "
                                "default beside the model)")
    space_path = Path(args.space) if args.space else Path(args.model).with_suffix("").with_suffix(".search.toml")
    if args.space or space_path.is_file():
        space = study.load_space(space_path)
    else:
        space = study.SearchSpace()
    if args.full is not None:
        space = _replace(space, full=max(0, args.full))
    load_model(args.model)                  # bad files: one line before any work
    study.tg.load_targets(args.targets)
    if args.prior_bound is not None:
        if not args.prior_bound:
            raise SpecError("arguments", "--prior-bound", "expected the path of an earlier call's bound.csv, got ''")
        from autocable.paper.bound import read_csv
        read_csv(Path(args.prior_bound))
    if args.bound and study.tg.load_goal(args.targets) is None:
        raise study.tg.TargetsError(args.targets, "goal", "--bound needs a [goal] table "
                                                          "(statements_yes, boxes_share, boxes_scenes)")
    check_folder("--out", args.out)
    stats = study.calibrate(args.model, args.targets, args.out, space=space, workers=args.workers,
                            scheduler=args.scheduler, quiet=args.quiet,
                            bound=args.bound or args.bound_minutes is not None or args.bound_margin > 0,
                            bound_minutes=args.bound_minutes, bound_margin=args.bound_margin,
                            prior_bound=Path(args.prior_bound) if args.prior_bound else None)
    print(dumps(stats))
    return 0
