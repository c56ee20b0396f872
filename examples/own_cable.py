"""A cable of your own: a model spec written from scratch (a 160 m stay, not the paper's), eq. (21)
derived from it, and its response to support motion without wind, by eq. (21) and by the AME.

    python examples/own_cable.py [OUT_DIR]

Every field of the spec is one of `models/luongo_zulli_2012.toml` (which documents each); the
unknown wind angles are calibrated the same way (Theta0 so that galloping starts at U_c through the
in-plane mode). `main` returns the derivation and the two responses; tests/test_examples.py checks
omega1 against Irvine's closed form and the AME against eq. (21).
"""
import sys
from pathlib import Path

import autocable as ac

SPEC = """
# --8<-- [start:spec]
name = "stay_160m"
description = "A 160 m stay (illustrative data), fixed rivulet"

[cable]
length_m = 160.0
chord_slope_deg = -28.0
horizontal_tension_N = 4.2e6
mass_per_length_kg_m = 62.0
diameter_m = 0.135
axial_stiffness_N = 2.79e9          # E = 195 GPa on the full section
bending_stiffness_Nm2 = 2600.0
torsional_stiffness_Nm2 = 200.0
damping_ratio = 0.003
gravity_m_s2 = 9.81

[aero]
air_density_kg_m3 = 1.25
rivulet_diameter_ratio = 0.1
lift = [-0.48, 0.84, 4.69, 0.86]    # the wind-tunnel fits the paper uses (eq. 13)
drag = [1.25, -0.65, -0.08, 6.81]
critical_wind_speed_m_s = 30.0
load_length = "diameter"
angle_convention = "reversed"
yaw_deg = 0.0
rivulet_angle_deg = "calibrate"
# --8<-- [end:spec]
"""


def main(out_dir=".", eta=5e-5, sigma=0.01):
    path = Path(out_dir) / "stay_160m.toml"
    path.write_text(SPEC)
    d = ac.derive(path)                                       # statics, modes, eq. (21)
    ode21 = ac.Ode21Integrator(d.ode).simulate(0.0, eta, sigma)     # from rest (q2 = 1e-6)
    ame = ac.AmeIntegrator(ac.derive_ame(d).ame).simulate(0.0, eta, sigma)
    return d, ode21, ame


if __name__ == "__main__":
    d, r21, rame = main(sys.argv[1] if len(sys.argv) > 1 else ".")
    print(f"omega1 = {d.ode.omega1:.6f}, omega2 = {d.ode.omega2:.6f}, Theta0 = {d.theta0 * 57.29578:.3f} deg")
    print(f"eq. (21): a1 = {r21.a1:.6e}, a2 = {r21.a2:.6e}; AME: a1 = {rame.a1:.6e}, a2 = {rame.a2:.6e}")
