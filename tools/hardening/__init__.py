"""The hardening harness of autocable: generated hostile inputs (`fuzz`, `fuzz_surfaces`) and runs
killed at random moments (`kill`, `kill_surfaces`). Test tools, kept out of the shipped package;
run from the repository's top folder as ``python -m tools.hardening {fuzz,kill,kill-surfaces}``
(docs/robustness.md), and imported by the tests (tests/test_fuzz.py, tests/test_run_folders.py,
tests/test_sweep_faults.py)."""
