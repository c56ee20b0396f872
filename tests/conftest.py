"""Shared test fixtures: the repository's paths and the sample cable's derivations, computed once
per test session (each is content-cached on disk as well, so a warm cache makes them cheap).

Test modules import the paths (``from conftest import REPO, SAMPLE``) and request the fixtures by
name; a module that needs a variant (another integrator, no cache) builds its own.
"""
import functools
from pathlib import Path

import pytest

#: The repository's top folder.
REPO = Path(__file__).resolve().parents[1]
#: The sample cable of Sect. 5.
SAMPLE = REPO / "models" / "luongo_zulli_2012.toml"
#: The figure scenes.
RUNS = REPO / "runs"


def two_run_scene(second_start: str, extra: str = "", *, engine: str = "pycont", title: str = "two runs") -> str:
    """The text of a small scene at Fig. 5a's setting (U = 0, eta* = 8.2e-5, the sample cable): run I
    from the trivial state and run II from ``second_start`` (TOML), then ``extra`` (more keys of II,
    more tables)."""
    return (f'title = "{title}"\nmodel = "{SAMPLE.as_posix()}"\name = "2dof"\nengine = "{engine}"\n'
            '[fixed]\nU = 0.0\neta = 8.2e-5\n'
            '[[run]]\nname = "I"\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstart = "trivial"\n'
            f'[[run]]\nname = "II"\nparameter = "sigma"\nrange = [-0.05, 0.05]\nstart = {second_start}\n{extra}\n')


def scene_error(path, text: str):
    """Write a scene file of ``text`` at ``path``, load it, and return the `SpecError` it raises,
    checked to be one line (the message a user sees names the file, the field and the fix)."""
    from autocable.scene.schema import load_scene
    from autocable.spec import SpecError
    path.write_text(text)
    with pytest.raises(SpecError) as err:
        load_scene(path)
    assert "\n" not in str(err.value)
    return err.value


@pytest.fixture(scope="session")
def sample_spec():
    """The sample cable's `ModelSpec`."""
    from autocable.spec import load_model
    return load_model(SAMPLE)


@pytest.fixture(scope="session")
def derivation(sample_spec):
    """Eq. (21) of the sample cable (`autocable.derive`)."""
    from autocable.model.derive import derive
    return derive(sample_spec)


@pytest.fixture(scope="session")
def sample_ame(derivation):
    """The AME (22)-(24) of the sample cable, the paper's ordering (Sect. 4)."""
    from autocable.model.ame_cache import derive_ame
    return derive_ame(derivation).ame


#: A long stay of a cable-stayed bridge with rain-wind vibration on record (the user's cable of the
#: project's issue on new cables): 190 m, D = 0.19 m, 88 kg/m, T = 4.4 MN along the chord, xi = 0.1 %,
#: U_c = 10 m/s, yaw 30 deg, the sample's lift/drag fits and readings. The chord slope (30 deg), EA
#: (E = 195 GPa on 9.5e-3 m^2 of steel) and EI, GJ (the sample's scaled by D^4) are not given: typical
#: values. Its wind coupling is strong: at eta* = 0 it gallops super-critically with a2 about 0.12 a1
#: (autocable simulate), a coupled cable where a2 is slaved to a1. The angle sense is the sample's at
#: the time the issue was filed ("reversed", now a legacy reading with a warning): with "mirrored"
#: the same cable's eq. (21) at U* = 1.2, eta* = 0 is a large modulated motion (a1 = 0.064), not the
#: small super-critical cycle these tests need.
STAY190 = """\
name = "stay190"
description = "190 m stay with rain-wind vibration (test cable)"
[cable]
length_m = 190.0
chord_slope_deg = -30.0
horizontal_tension_N = 3810512.0        # 4.4 MN cos 30 deg
mass_per_length_kg_m = 88.0
diameter_m = 0.19
axial_stiffness_N = 1.85e9
bending_stiffness_Nm2 = 13700.0
torsional_stiffness_Nm2 = 1030.0
damping_ratio = 0.001
gravity_m_s2 = 9.81
twist_ends = "natural"
[aero]
air_density_kg_m3 = 1.25
rivulet_diameter_ratio = 0.1
lift = [-0.48, 0.84, 4.69, 0.86]
drag = [1.25, -0.65, -0.08, 6.81]
critical_wind_speed_m_s = 10.0
load_length = "diameter"
angle_convention = "reversed"
load_axes = "reference"
yaw_deg = 30.0
rivulet_angle_deg = "calibrate"
calibration_root = "smallest"
"""


@pytest.fixture(scope="session")
def stay190(tmp_path_factory):
    """Eq. (21) of `STAY190` (`autocable.derive`), the spec written in a temporary folder."""
    from autocable.model.derive import derive
    from autocable.spec import load_model
    path = tmp_path_factory.mktemp("stay190") / "stay190.toml"
    path.write_text(STAY190)
    return derive(load_model(path))


#: The sample read with the legacy "reversed" angle sense (docs/model.md, U4): not frame
#: indifferent, kept readable because its eq. (21) blows up in finite time above U_c (at U* = 1.3,
#: eta* = 1.4e-3 for sigma >= -0.01; the out-of-plane cubic wind stiffness softens). The tests of
#: how divergence is handled need a model known to diverge; the sample ("mirrored") stays bounded there.
def legacy_text() -> str:
    text = SAMPLE.read_text()
    assert 'angle_convention = "mirrored"' in text
    return text.replace('angle_convention = "mirrored"', 'angle_convention = "reversed"')


@pytest.fixture(scope="session")
def legacy_sample(tmp_path_factory):
    """The path of the legacy-sense sample (`legacy_text`)."""
    path = tmp_path_factory.mktemp("legacy") / "luongo_zulli_2012_reversed.toml"
    path.write_text(legacy_text())
    return path


@pytest.fixture(scope="session")
def legacy_derivation(legacy_sample):
    """Eq. (21) of the legacy-sense sample, its legacy warning silenced."""
    import warnings

    from autocable.model.derive import derive
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return derive(legacy_sample)


@functools.lru_cache(maxsize=1)
def legacy_path() -> Path:
    """`legacy_text` written once per test session (for the helpers that take no fixture)."""
    import tempfile
    path = Path(tempfile.mkdtemp(prefix="autocable-legacy-")) / "luongo_zulli_2012_reversed.toml"
    path.write_text(legacy_text())
    return path


def load_legacy_scene(path):
    """A figure scene (runs/*.toml) on the legacy-sense sample. The tests of the wind scenes'
    branches, special points, overlays and orbits were measured on that reading (their numbers are
    regression pins of it, and their cross-checks between engines and methods were established
    there); they keep testing the code on that known model. The sample itself ("mirrored") runs
    every scene in tests/test_figures.py and the report's decisions in tests/test_targets.py."""
    from dataclasses import replace

    from autocable.scene.schema import load_scene
    return replace(load_scene(path), model=legacy_path())


#: One continuation run of Fig. 3's galloping equation (the 1-dof amplitude equation, a second with a
#: warm cache): the body of the small scenes of the run-folder and filesystem-fault tests.
TRIVIAL_GALLOPING_RUN = f'''
model = "{SAMPLE.as_posix()}"
ame = "1dof-amplitude"
state_scale = 0.01

[fixed]
eta = 0.0
sigma = 0.0

[[run]]
name = "trivial"
parameter = "U"
range = [0.2, 0.9999]
at = 0.5
start = {{ state = [0.0] }}
'''


#: The rotation frequency of `hopf_normal_form_branch`.
HOPF_W = 2.0


def hopf_normal_form_branch(a: float):
    """The Hopf normal form x' = mu x - w y + a x r^2, y' = w x + mu y + a y r^2 (w = `HOPF_W`)
    continued in mu over [-0.2, 0.3]: one Hopf point at mu = 0 whose first Lyapunov coefficient
    (Kuznetsov's normalisation, |q| = 1) is l1 = 2 a / w: subcritical for a > 0, supercritical for
    a < 0 (the closed form tests/test_continuation.py checks l1 against)."""
    import sympy as sp

    from autocable.methods.continuation import ContinuationSettings, EquilibriumProblem, System, continue_equilibria
    x, y, mu = sp.symbols("x y mu")
    r2 = x * x + y * y
    system = System("hopf_nf", ("x", "y"), (mu * x - HOPF_W * y + a * x * r2, HOPF_W * x + mu * y + a * y * r2),
                    {"mu": -0.2}, (("a1", ("x", "y")),))
    problem = EquilibriumProblem(system, "mu", {"mu": -0.2}, (-0.2, 0.3))
    return continue_equilibria(problem, ContinuationSettings(), name="EQ", engine="compiled").branch
