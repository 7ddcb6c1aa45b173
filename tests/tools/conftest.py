"""Shared set-up of the tools' tests (pytest; ctest runs each file as a test, tests/CMakeLists.txt).

The package is found through PYTHONPATH (tools/ and this folder; ctest sets it, and tools/pyproject.toml does for
`cd tools && /usr/bin/python3 -m pytest`). The celldem binary is $CELLDEM, else build/celldem: the fake runs'
summaries come from its `summarize`, and some tests run it.
"""

import os

import pytest

from checking import HERE, ROOT, run_script


def celldem_path():
    return os.environ.get("CELLDEM") or os.path.join(ROOT, "build", "celldem")


@pytest.fixture(scope="session")
def celldem():
    """The celldem binary; a test that needs it fails (never skips) without it."""
    path = celldem_path()
    if not os.access(path, os.X_OK):
        pytest.fail(f"no celldem binary at {path} (tools/build.sh builds it; $CELLDEM names another)")
    os.environ["CELLDEM"] = path  # the fakes and the tools' binary.find() read it
    return path


@pytest.fixture(scope="session")
def make_fake_run(celldem):
    """make_fake_run(out_dir, *options): tests/tools/make_fake_run.py (a synthetic run; summary.json from
    `celldem summarize`)."""
    def make(out_dir, *options):
        run_script(os.path.join(HERE, "make_fake_run.py"), out_dir, *options)
        return str(out_dir)
    return make


@pytest.fixture(scope="session")
def make_fake_study(celldem):
    """make_fake_study(root): tests/tools/make_fake_study.py (a synthetic study root with expected.json)."""
    def make(root):
        run_script(os.path.join(HERE, "make_fake_study.py"), root)
        return str(root)
    return make
