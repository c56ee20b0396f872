"""Shared test fixtures: the repository's paths and the sample cable's derivations, computed once
per test session (each is content-cached on disk as well, so a warm cache makes them cheap).

Test modules import the paths (``from conftest import REPO, SAMPLE``) and request the fixtures by
name; a module that needs a variant (another integrator, no cache) builds its own.
"""
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
