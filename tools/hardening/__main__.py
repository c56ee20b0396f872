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
    for s, repeats in ((k, 20), (ks, 4)):
        s.add_argument("--repeats", type=int, default=repeats, help=f"trials (default {repeats})")
    for s in (f, k, ks):
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


def run(argv: list[str] | None = None) -> int:
    """The command; the exit status."""
    args = _parser().parse_args(argv)
    log = None if args.quiet else (lambda s: print(s, file=sys.stderr))
    try:
        check_out("--out", args.out)
        check_folder("--out", args.out)
        if args.what == "fuzz":
            result, bad = _fuzz(args, log)
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
                       or not result["final_runs_complete"])
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
