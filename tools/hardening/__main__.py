"""``python -m tools.hardening {fuzz,kill,kill-surfaces}`` from the repository's top folder: the
hardening runs that were ``autocable bench fuzz``, ``bench kill`` and ``bench kill-surfaces``; JSON
on stdout, progress on stderr, exit 1 when a run finds a problem and 2 on bad options (one line
naming the option, as the `autocable` command does)."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from autocable.cli.checks import REPEATS_LIMIT, check_folder, check_number, check_out, dumps, strict
from autocable.errors import EXIT_INPUT
from autocable.spec import SpecError


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m tools.hardening",
                                description="autocable's hardening harness (docs/robustness.md)")
    sub = p.add_subparsers(dest="what", required=True)
    f = sub.add_parser("fuzz", help="hostile model specs, scenes and arguments (and with --surfaces, --api: "
                                    "sweep files, chart tables, targets and search-space files, --map files, "
                                    "API calls); counts of tracebacks, exit-0 results for invalid input, "
                                    "unnamed rejections and hangs")
    f.add_argument("--specs", type=int, default=1000, help="mutated model specs (default 1000)")
    f.add_argument("--scenes", type=int, default=300, help="mutated scenes (default 300)")
    f.add_argument("--args", type=int, default=60, help="argument vectors (default 60)")
    f.add_argument("--runs", type=int, default=16, help="real scene runs at most (default 16)")
    f.add_argument("--surfaces", type=int, default=0, help="cases of each of sweep files, chart tables, "
                   "targets files, search-space files and --map files (default 0)")
    f.add_argument("--api", type=int, default=0, help="calls of the Python API (default 0)")
    f.add_argument("--seed", type=int, default=0, help="seed of the mutations (default 0)")
    k = sub.add_parser("kill", help="a scene run (runs/fig06.toml) killed (SIGKILL, SIGINT) at random moments "
                                    "--repeats times (at least 20), each folder checked not to read as "
                                    "complete, leftovers checked after a rerun")
    ks = sub.add_parser("kill-surfaces", help="a grid and a followed sweep, a chart and a calibration killed "
                                              "--repeats times each, checked not to read as complete and to "
                                              "leave no orphaned process")
    o = sub.add_parser("options", help="onset and damper options and specs, the API's keywords "
                                       "(tools/hardening/fuzz_options.py): --cases of each kind, classified")
    o.add_argument("--cases", type=int, default=1000, help="cases of each kind (default 1000)")
    o.add_argument("--kinds", default="", help="comma-separated kinds (default: onset_args, onset_specs, "
                                               "damper_args, damper_specs, api_keywords; also cache_edits and "
                                               "scheduler_failures, real processes: tools/hardening/fuzz_cache.py, "
                                               "fuzz_scheduler.py)")
    o.add_argument("--light", action="store_true", help="leave out the valid cases that compute for seconds")
    o.add_argument("--budget-minutes", type=float, default=None,
                   help="cache_edits, scheduler_failures: start no case after so many minutes of each kind "
                        "(the JSON's cases says how many ran; default: no limit)")
    o.add_argument("--seed", type=int, default=0, help="seed of the cases (default 0)")
    for s, repeats in ((k, 20), (ks, 4)):
        s.add_argument("--repeats", type=int, default=repeats, help=f"trials (default {repeats})")
    for s in (f, k, ks, o):
        s.add_argument("--out", help="folder to write bench_<what>.json")
        s.add_argument("--quiet", action="store_true")
    return p


def _fuzz(args, log) -> tuple[dict, bool]:
    from autocable.cli import main          # the whole command line is what the fuzz cases run
    from tools.hardening.fuzz import run_fuzz
    from tools.hardening.fuzz_surfaces import cases, run_mode
    for option in ("specs", "scenes", "args", "runs", "surfaces", "api"):
        check_number(f"--{option}", getattr(args, option), 0, 10**6, integer=True)
    result = run_fuzz(main, specs=args.specs, scenes=args.scenes, args=args.args, seed=args.seed,
                      out=args.out, real_runs=args.runs, extra=list(cases(args.surfaces, args.api, args.seed)),
                      runner=run_mode, log=log)
    return result, bool(result["problem_count"])


#: The kinds of real processes (a private package copy edited during a run; Dask clusters whose
#: workers fail): their own runners, the same table shape, and "failed" (exit 3, said) is expected.
PROCESS_KINDS = ("cache_edits", "scheduler_failures")


def _options(args, log) -> tuple[dict, bool]:
    from tools.hardening.fuzz_options import KINDS, run_options
    check_number("--cases", args.cases, 0, 10**6, integer=True)
    if args.budget_minutes is not None:
        check_number("--budget-minutes", args.budget_minutes, 0, 10**5)
    kinds = [k.strip() for k in args.kinds.split(",") if k.strip()] or list(KINDS)
    for k in kinds:
        if k not in KINDS and k not in PROCESS_KINDS:
            raise SpecError("arguments", "--kinds", f"unknown kind {k!r}; give some of "
                                                    f"{', '.join(list(KINDS) + list(PROCESS_KINDS))}")
    in_process = [k for k in kinds if k in KINDS]
    result = run_options(args.cases, args.seed, in_process, heavy=not args.light, log=log) if in_process else \
        {"seed": args.seed, "cases_per_kind": args.cases, "table": {}, "seconds": {}, "examples": {}}
    bad = any(n for row in result["table"].values() for c, n in row.items() if c not in ("ok", "refused_named"))
    budget = None if args.budget_minutes is None else 60.0 * args.budget_minutes
    for k in (k for k in kinds if k in PROCESS_KINDS):
        if k == "cache_edits":
            from tools.hardening.fuzz_cache import run_cache_edits as runner
        else:
            from tools.hardening.fuzz_scheduler import run_scheduler_failures as runner
        r = runner(args.cases, args.seed, log=log, budget_s=budget)
        result["table"][k] = r["table"][k]
        result["seconds"][k] = r["seconds"][k]
        result["examples"][k] = r.pop("examples")
        result[k] = {key: v for key, v in r.items() if key not in ("table", "seed")}
        bad = bad or any(n for c, n in r["table"][k].items() if c not in ("ok", "refused_named", "failed"))
    return result, bad


def _interrupted(signum, frame):
    raise KeyboardInterrupt     # SIGTERM as Ctrl-C: the runs' clean-up (their processes, folders) runs


def run(argv: list[str] | None = None) -> int:
    """The command; the exit status."""
    import signal
    signal.signal(signal.SIGTERM, _interrupted)
    args = _parser().parse_args(argv)
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    try:
        check_out("--out", args.out)
        check_folder("--out", args.out)
        if args.what == "fuzz":
            result, bad = _fuzz(args, log)
        elif args.what == "options":
            result, bad = _options(args, log)
        else:
            check_number("--repeats", args.repeats, 0, REPEATS_LIMIT, integer=True)
            if args.what == "kill":
                from tools.hardening.kill import run_kill_bench
                result = run_kill_bench("kill", "", repeats=args.repeats, log=log)
                bad = (result["read_as_complete_while_incomplete"] or result["leftovers_after_rerun"]
                       or not result["final_run_complete_and_clean"])
            else:
                from tools.hardening.kill_surfaces import run_kill_surfaces
                result = run_kill_surfaces(max(1, args.repeats), log=log)
                bad = (result["read_as_complete_while_incomplete"] or result["orphaned_processes"]
                       or result["interrupt_ignored"] or not result["final_runs_complete"])
    except SpecError as exc:
        print(f"{_parser().prog}: error: {exc}", file=sys.stderr)
        return EXIT_INPUT
    if args.out:
        from autocable._store import atomic_write_json
        atomic_write_json(Path(args.out) / f"bench_{args.what.replace('-', '_')}.json", strict(result))
    print(dumps(result, indent=1) if args.what != "fuzz" else json.dumps(result, indent=1))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(run())
