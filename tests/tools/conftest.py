"""Shared set-up of the tools' tests (pytest; ctest runs each file as a test, tests/CMakeLists.txt).

The package is found through PYTHONPATH (tools/ and this folder; ctest sets it, and the root pyproject.toml does
for `/usr/bin/python3 -m pytest`). The binary's fixture `celldem` is tests/conftest.py's: the fake runs'
summaries come from its `summarize`, and some tests run it.
"""

import os

import pytest

from checking import HERE, run_script


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
