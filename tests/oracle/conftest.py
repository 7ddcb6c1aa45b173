"""Shared set-up of the result oracle's tests (pytest; ctest runs each file, tests/CMakeLists.txt).

The celldem binary is $CELLDEM, else build/celldem. Nothing runs at import: the sample is prepared by the first test
that asks for it.
"""

import os
import sys

import pytest

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
sys.path.insert(0, HERE)  # oracle.py, random_decks.py


@pytest.fixture(scope="session")
def celldem():
    """The celldem binary; a test that needs it fails (never skips) without it."""
    path = os.environ.get("CELLDEM") or os.path.join(ROOT, "build", "celldem")
    if not os.access(path, os.X_OK):
        pytest.fail(f"no celldem binary at {path} (tools/build.sh builds it; $CELLDEM names another)")
    return os.path.abspath(path)


@pytest.fixture(scope="session")
def draws_folder(tmp_path_factory):
    """The folder of the random draws (the sample, the decks, the runs), kept by pytest's tmp_path rules."""
    return str(tmp_path_factory.mktemp("oracle-draws"))


@pytest.fixture(scope="session")
def sample_state(celldem, draws_folder):
    """The 300-sphere sample every draw starts from (prepared once per session)."""
    import random_decks
    return random_decks.prepare_sample(celldem, draws_folder)


@pytest.fixture(scope="session")
def schema_keys(celldem):
    import random_decks
    return random_decks.schema_keys(celldem)
