"""Fixtures every Python test shares (pytest; the root pyproject.toml names tests/ as the test path).

`/usr/bin/python3 -m pytest` from the repository root collects every Python test; ctest runs each file (or
group of files) as its own test (tests/CMakeLists.txt). The celldem binary is $CELLDEM, else build/celldem.
"""

import os

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def celldem_path():
    """$CELLDEM, else the checkout's build/celldem."""
    return os.path.abspath(os.environ.get("CELLDEM") or os.path.join(ROOT, "build", "celldem"))



@pytest.fixture(scope="session")
def celldem():
    """The celldem binary; a test that needs it fails (never skips) without it."""
    path = celldem_path()
    if not os.access(path, os.X_OK):
        pytest.fail(f"no celldem binary at {path} (tools/build.sh builds it; $CELLDEM names another)")
    os.environ["CELLDEM"] = path  # the fakes and the package's binary.find() read it
    return path


@pytest.fixture(scope="session")
def root():
    """The checkout's root folder (inputs/, tests/run/ decks)."""
    return ROOT
