"""A frequency response in one call: the sample cable without wind at eta* = 1.4e-3 (Fig. 6's
setting), branch I with its folds, Hopf and branch points, and the bi-modal branches switched at the
branch points; the table as a pandas DataFrame, the diagram in SI units (frequency_response.png/.pdf).

    python examples/frequency_response.py [OUT_DIR]

`main` returns the results and the figure; tests/test_examples.py runs it and checks its numbers.
"""
import sys
from pathlib import Path

import autocable as ac

MODEL = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def main(out_dir="."):
    eq21 = ac.derive(MODEL)
    print(eq21.summary())
    res = ac.frequency_response(eq21, U=0.0, eta=1.4e-3, sigma=(-0.05, 0.05))
    table = res.to_dataframe()                       # the rows of branches.csv
    units = ac.si_scales(eq21.spec.cable.length_m, eq21.statics.omega_ref, eq21.critical_wind_speed_m_s)
    fig = ac.plot_branches(res.branches, Path(out_dir) / "frequency_response", x="sigma", y=("a1", "a2"),
                           title="Sample cable, U = 0, eta* = 1.4e-3", units=units)
    return res, table, fig


if __name__ == "__main__":
    res, table, fig = main(sys.argv[1] if len(sys.argv) > 1 else ".")
    print(table.groupby("branch")[["a1", "a2"]].max())
    for b in res.branches:
        print(b.name, [f"{p.label} sigma={p.value:.6f}" for p in b.special_points])
