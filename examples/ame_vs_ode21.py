"""The amplitude equations against eq. (21) itself: both swept up and down in sigma at Fig. 5b's
setting (no wind, eta* = 4.1e-4), with the largest relative a1 difference and a plot of both.

    python examples/ame_vs_ode21.py [OUT_DIR]

The Multiple Scales AME (24) are a perturbative reduction of eq. (21): this is the check a user runs
before trusting a continuation diagram at their own setting. `main` returns the two sweeps and the
worst relative a1 difference; tests/test_examples.py holds it to the bound of the AME-vs-(21) study
at this eta*.
"""
import sys
from pathlib import Path

import numpy as np

import autocable as ac

MODEL = Path(__file__).resolve().parents[1] / "models" / "luongo_zulli_2012.toml"


def main(out_dir=".", sigmas=np.linspace(-0.04, 0.04, 9), eta=4.1e-4):
    d = ac.derive(MODEL)
    fixed = {"U": 0.0, "eta": eta}
    by_ode21 = ac.sweep(ac.Ode21Integrator(d.ode), "sigma", sigmas, fixed)
    by_ame = ac.sweep(ac.AmeIntegrator(ac.derive_ame(d).ame), "sigma", sigmas, fixed)
    worst = max(abs(a.a1 - o.a1) / o.a1 for a, o in zip(by_ame, by_ode21)
                if a.direction == o.direction and a.value == o.value)

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6, 4))
    for pts, style, label in ((by_ode21, "s", "eq. (21)"), (by_ame, "+", "AME (24)")):
        ax.plot([p.value for p in pts], [p.a1 for p in pts], style, mfc="none", label=label)
    ax.set(xlabel="sigma", ylabel="a1", title=f"U = 0, eta* = {eta:g}: worst difference {worst:.2%}")
    ax.legend()
    fig.tight_layout()
    fig.savefig(Path(out_dir) / "ame_vs_ode21.png", dpi=120)
    plt.close(fig)
    return by_ode21, by_ame, worst


if __name__ == "__main__":
    _, _, worst = main(sys.argv[1] if len(sys.argv) > 1 else ".")
    print(f"largest relative a1 difference, AME against eq. (21): {worst:.3e}")
