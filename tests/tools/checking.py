"""What the tools' tests share besides their fixtures (conftest.py): the checkout's folders, running a script of
the checkout as a user does, and the comparisons."""

import math
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TOOLS = os.path.join(ROOT, "tools")
HERE = os.path.join(ROOT, "tests", "tools")
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"


def run_script(path, *args, check=True, **kwargs):
    """Runs a Python script of the checkout with this interpreter, tools/ on its PYTHONPATH; returns the
    CompletedProcess (text). check: fail the test, with its output, when the script exits non-zero."""
    env = dict(kwargs.pop("env", os.environ))
    env["PYTHONPATH"] = os.pathsep.join([TOOLS] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    r = subprocess.run([sys.executable, path, *map(str, args)], capture_output=True, text=True, env=env, **kwargs)
    if check and r.returncode != 0:
        pytest.fail(f"{os.path.basename(path)} {' '.join(map(str, args))} exited {r.returncode}:\n"
                    f"{r.stdout[-2000:]}\n{r.stderr[-4000:]}")
    return r


def tool(name, *args, check=True, **kwargs):
    """tools/<name>.py ARGS, as a user runs it."""
    return run_script(os.path.join(TOOLS, f"{name}.py"), *args, check=check, **kwargs)


def is_png(path):
    """The file exists, is not empty and starts with PNG's signature."""
    if not os.path.isfile(path) or os.path.getsize(path) == 0:
        return False
    with open(path, "rb") as f:
        return f.read(8) == PNG_MAGIC


def read_text(path):
    with open(path, encoding="utf-8") as f:
        return f.read()


def close_enough(got, want, tol=1e-12):
    """got == want; for a finite float want, within tol relative (absolute below 1)."""
    if isinstance(want, float) and math.isfinite(want):
        return got is not None and abs(got - want) <= tol * max(1, abs(want))
    return got == want


def check(what, got, want, tol=1e-12):
    assert close_enough(got, want, tol), f"{what}: got {got!r}, want {want!r}"
