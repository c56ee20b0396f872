"""`autocable bench engines` (every figure on PyCont and on the compiled kernel): how it matches
special points. The run itself is a benchmark (minutes); its result is in docs/benchmarks.md."""
def test_engine_comparison_matches_points_by_branch_and_type():
    """`autocable bench engines` judges two runs of a scene: equal points pass, a point moved past the
    tolerance, a missing point or branch is named."""
    from autocable.bench.engines import TOLERANCE, compare_points

    a = {"I": [("BP", -0.0261400), ("H", 0.01)], "P": [("PD", 0.015782)]}
    same = compare_points(a, {"I": [("BP", -0.0261400 + 1e-9), ("H", 0.01)], "P": [("PD", 0.015782 + 5e-5)]})
    assert same["problems"] == [] and same["matched"] == 3
    assert abs(same["max_difference"]["equilibria"] - 1e-9) < 1e-15
    moved = compare_points(a, {"I": [("BP", -0.0261400 + 10 * TOLERANCE["equilibria"]), ("H", 0.01)],
                               "P": [("PD", 0.015782)]})
    assert len(moved["problems"]) == 1 and moved["problems"][0].startswith("BP:")
    missing = compare_points(a, {"I": [("BP", -0.02614)]})
    assert any("only on pycont" in p for p in missing["problems"]) and "H: 1 points against 0" in missing["problems"]
    # switched branches whose names follow the order their branch points were met (Fig. 6)
    swapped = compare_points({"II-BP1": [("BP", 0.0296)], "II-BP2": [("BP", 0.0050)]},
                             {"II-BP1": [("BP", 0.0050)], "II-BP2": [("BP", 0.0296)]})
    assert swapped["problems"] == [] and swapped["matched"] == 2
