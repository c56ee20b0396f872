"""Benchmarks (`autocable bench ...`): speed targets live here, never in timed tests."""
