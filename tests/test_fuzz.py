"""Hostile input, generated: mutated model specs, scenes and argument vectors (tools/hardening/fuzz.py)
through the command line, with hypothesis drawing the mutations (derandomized: the same cases on
every machine; a bounded count so the file stays short; ``python -m tools.hardening fuzz`` is the long run).

Each test collects every case that breaks a property and lists them all in one assertion (a case
is printed with its files and command line), instead of stopping at the first:

* no traceback, and no unforeseen exception behind the catch-all line;
* an input labelled invalid never exits 0;
* a rejection names a file of the case, the field or the option;
* exit 0 with ``--json`` prints strict JSON (no NaN, no Infinity);
* nothing is written outside the case's ``--out`` and the cache; no run passes its time limit.
"""
import json
import random

import pytest
from hypothesis import Phase, example, given, settings

from tools.hardening import fuzz
from autocable.cli import main

# No shrinking: the cases are single labelled mutations already, and a failing one is listed as is.
_SETTINGS = dict(deadline=None, derandomize=True, database=None,
                 phases=(Phase.explicit, Phase.generate))
STRATEGIES = fuzz.strategies()


@pytest.fixture(scope="module")
def harness(tmp_path_factory):
    """Cases run in a private tree with its own cache (writes elsewhere in it are caught)."""
    # 20 s: a hang costs less; every case that ends ends within a few seconds here
    from tools.hardening.fuzz_surfaces import run_mode
    return fuzz.Harness(main, tmp_path_factory.mktemp("fuzz"), max_timeout=20.0, runner=run_mode)


def _collect(harness, strategy, max_examples, examples=()):
    """Run ``max_examples`` drawn cases (and the explicit ``examples`` first); the failing ones."""
    failures = []

    def each(case):
        outcome = harness.run(case)
        if outcome is not None and outcome.problems:
            failures.append({"input": case.describe(), "exit": outcome.exit, "problems": outcome.problems})

    run = given(case=strategy)(each)
    for case in examples:
        run = example(case=case)(run)
    settings(max_examples=max_examples, **_SETTINGS)(run)()
    return failures


def _report(failures) -> str:
    return f"{len(failures)} failing cases:\n" + "\n".join(json.dumps(f, ensure_ascii=False) for f in failures)


# The reproductions of the hostile-input review, pinned as explicit examples.
def _spec(kind, seed=0, **_):
    return fuzz.spec_case(kind, random.Random(seed))


def _spec_with(label_part, kind, tries=400):
    """The first drawn case of ``kind`` whose label contains ``label_part`` (a named reproduction)."""
    for seed in range(tries):
        case = fuzz.spec_case(kind, random.Random(seed))
        if label_part in case.label:
            return case
    raise AssertionError(f"no {kind} case labelled {label_part!r}")


SPEC_EXAMPLES = [
    _spec_with('name = "../../escaped"', "name"),                     # a name that leaves the cache
    _spec_with("axial_stiffness_N = 1.0", "impossible"),              # EA = 1 N: static strain 3.8e6
    _spec_with("horizontal_tension_N = 1000000000000.0", "impossible"),
    _spec_with("length_m = 1e-06", "impossible"),
    _spec_with("drag = [1e+300", "impossible"),                       # a 4.4 kB error line
    _spec_with("<4", "huge_int"),                                     # 400-digit integer
    _spec_with("caf", "non_utf8"),
]


def test_specs(harness):
    """Mutated sample models through ``autocable derive --json`` (60 drawn + the reproductions)."""
    failures = _collect(harness, STRATEGIES["specs"], 60, SPEC_EXAMPLES)
    assert not failures, _report(failures)


def test_scenes(harness):
    """Mutated figure scenes through `load_scene`: invalid ones rejected there, naming the field."""
    failures = _collect(harness, STRATEGIES["scenes"], 30)
    assert not failures, _report(failures)


def _args(label):
    return fuzz.args_case(next(i for i, c in enumerate(fuzz.ARG_CASES) if c[0] == label))


ARG_EXAMPLES = [_args(label) for label in (
    "simulate --eta=nan", "simulate --U=inf", "simulate --max-time=-5", "simulate --method ame --eta nan",
    "derive: a FIFO", "run --out ''")]


def test_arguments(harness):
    """Abusive argument vectors of derive, simulate, advise (drawn), run (explicit: one real run)."""
    failures = _collect(harness, STRATEGIES["quick_args"], 20, ARG_EXAMPLES)
    assert not failures, _report(failures)


@pytest.mark.slow
def test_a_bad_compare_csv_fails_the_run_naming_it(harness):
    """A real coarse run of Fig. 5a on the compiled engine with a [compare] csv that is not
    numbers: the run exits non-zero naming the csv (after the continuation today)."""
    case = next(c for c in (fuzz.scene_case("run_compare", random.Random(s)) for s in range(200))
                if "a non-number" in c.label)
    outcome = harness.run(case)
    assert outcome.exit not in (0, None), outcome
    assert not outcome.problems, _report([{"input": case.describe(), "exit": outcome.exit,
                                           "problems": outcome.problems}])


def test_the_checks_catch_what_they_claim(tmp_path):
    """The harness itself: a fake command that exits 0 on invalid input, prints Infinity, writes
    beside its input and names nothing is caught on each count."""
    def liar(argv):
        import pathlib
        import sys
        pathlib.Path(argv[1]).with_name("stray.txt").write_text("x")
        print('{"a1": Infinity}')
        print("something went wrong", file=sys.stderr)
        return 0

    h = fuzz.Harness(liar, tmp_path)
    case = fuzz.Case("spec", "fake", fuzz.INVALID, ("length_m",), {fuzz.MODEL_FILE: "x = 1\n"},
                     ("derive", f"{{case}}/{fuzz.MODEL_FILE}", "--json"))
    kinds = {k for k, _ in h.run(case).problems}
    assert kinds == {"exit0_invalid", "bad_json", "escaped_write"}

    def rejects_unnamed(argv):
        import sys
        print("autocable: error (KeyError): 'x' (set AUTOCABLE_DEBUG=1 for details)", file=sys.stderr)
        return 2
    kinds = {k for k, _ in fuzz.Harness(rejects_unnamed, tmp_path / "b").run(case).problems}
    assert kinds == {"unforeseen_exception", "unnamed_rejection"}

    def names_it(argv):
        import sys
        print(f"autocable: error: {argv[1]}: cable.length_m: expected a positive length", file=sys.stderr)
        return 2
    assert fuzz.Harness(names_it, tmp_path / "c").run(case).problems == []


def test_surfaces(harness):
    """Sweep files, chart tables, targets and search-space files and --map files, each read the
    way its command reads it (`tools.hardening.fuzz_surfaces`)."""
    from tools.hardening.fuzz_surfaces import strategies
    failures = _collect(harness, strategies()["surfaces"], 60)
    assert not failures, _report(failures)


def test_api_calls(harness):
    """Calls of the Python API: a bad argument is a SpecError naming it; no NaN as a result."""
    from tools.hardening.fuzz_surfaces import strategies
    failures = _collect(harness, strategies()["api"], 40)
    assert not failures, _report(failures)


def test_the_surface_checks_catch_what_they_claim(tmp_path):
    """The harness flags an accepted invalid input and a NaN result, and counts a refusal that
    names the case's file as named (cases built for each)."""
    from tools.hardening.fuzz_surfaces import SWEEP_FILE, run_mode
    h = fuzz.Harness(main, tmp_path, max_timeout=20.0, runner=run_mode)
    accepted = fuzz.Case("sweep", "a valid sweep labelled invalid", fuzz.INVALID, ("max_time",),
                         {fuzz.MODEL_FILE: fuzz.SAMPLE_MODEL.read_text(),
                          SWEEP_FILE: 'model = "model.toml"\n[grid]\neta = 1e-4\n'}, mode="load_sweep")
    assert [k for k, _ in h.run(accepted).problems] == ["exit0_invalid"]
    named = fuzz.Case("sweep", "a refusal naming the file", fuzz.INVALID, ("zzz",),
                      {SWEEP_FILE: 'model = 3\n'}, mode="load_sweep")
    o = h.run(named)
    assert o.exit == 2 and "sweep.toml: model:" in o.stderr and o.problems == []
    nan = fuzz.Outcome(0, "NaN result\n", "", 0.1, [], [])
    assert ("nan_result", "x") in fuzz.check(fuzz.Case("api", "x", fuzz.ODD, ()), nan, [], 1.0)
