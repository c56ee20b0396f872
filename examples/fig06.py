"""Fig. 6 of Luongo & Zulli in a dozen lines of the public API: no wind, eta* = 1.4e-3, a1 and a2
against sigma. Branch I from the small forced response, the bi-modal branches (III-V) switched at
its pitchfork points, the Hopf points of I, and the paper-style diagram (fig06.png, fig06.pdf).

    python examples/fig06.py [OUT_DIR]

`main` returns the branches; tests/test_examples.py runs it and checks its numbers.
"""
import sys
from pathlib import Path

import autocable as ac

MODEL = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def main(out_dir=".", engine="compiled", settings=None):
    ame = ac.derive_ame(ac.derive(ac.load_model(MODEL))).ame            # eq. (21), then the AME (24)
    system = ac.ame_system(ame, "2dof", wind=False)                     # U = 0: no aerodynamic rows
    values = {"U": 0.0, "eta": 1.4e-3, "sigma": -0.05}
    problem = ac.EquilibriumProblem(system, "sigma", values, (-0.05, 0.05))   # the AME's own state scale
    settings = settings or ac.ContinuationSettings(max_step=0.02)
    I = ac.continue_equilibria(problem, settings, name="I", engine=engine)  # from the trivial state
    bimodal = [ac.switch_branch(I, p, settings, name=f"I-{p.label}", engine=engine)
               for p in I.branch.special_points if p.label.startswith("BP")]
    ac.plot_branches([I, *bimodal], Path(out_dir) / "fig06", x="sigma", y=("a1", "a2"), title="Fig. 6")   # Figure
    return I, bimodal


if __name__ == "__main__":
    I, bimodal = main(sys.argv[1] if len(sys.argv) > 1 else ".")
    for r in (I, *bimodal):
        print(r.branch.name, [f"{p.label} sigma={p.value:.6f}" for p in r.branch.special_points])
