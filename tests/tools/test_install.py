"""The package installed as a user installs it: `pip install --no-deps --no-build-isolation .` (Debian's pip and
setuptools, nothing downloaded) into a fresh virtual environment with the system's site packages, from a copy of
the checkout's package files alone (so that nothing of the checkout is found through the package's location);
then the installed commands and `import celldem` work with the binary found through $CELLDEM or PATH.
And mypy (Debian's python3-mypy) passes on the public modules."""

import json
import os
import shutil
import subprocess
import sys

import pytest

from checking import ROOT

pytestmark = pytest.mark.slow

# Typed throughout; mypy checks them with disallow_untyped_defs (pyproject.toml's [tool.mypy] overrides).
PUBLIC_MODULES = ["api", "binary", "files", "results", "decks", "probes", "scenes", "metrics", "stats"]


@pytest.fixture(scope="module")
def venv(tmp_path_factory):
    """A venv with celldem installed from a copy of pyproject.toml and tools/celldem (no checkout around it)."""
    work = tmp_path_factory.mktemp("install")
    source = work / "source"
    (source / "tools").mkdir(parents=True)
    shutil.copy(os.path.join(ROOT, "pyproject.toml"), source)
    shutil.copytree(os.path.join(ROOT, "tools", "celldem"), source / "tools" / "celldem",
                    ignore=shutil.ignore_patterns("__pycache__"))
    env_dir = work / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(env_dir)], check=True)
    pip = subprocess.run([str(env_dir / "bin" / "pip"), "install", "--no-deps", "--no-build-isolation",
                          "--no-index", "--disable-pip-version-check", "-q", str(source)],
                         capture_output=True, text=True, cwd=work)
    assert pip.returncode == 0, f"pip install failed:\n{pip.stdout[-2000:]}\n{pip.stderr[-3000:]}"
    return env_dir


@pytest.fixture(scope="module")
def small_run(celldem, tmp_path_factory):
    """tests/run/small_run.json with its tests cut short (a few seconds)."""
    folder = tmp_path_factory.mktemp("run")
    with open(os.path.join(ROOT, "tests", "run", "small_run.json")) as f:
        deck = json.load(f)
    for test in deck["tests"]:
        test["end"]["strain"] = 0.002
    with open(folder / "deck.json", "w") as f:
        json.dump(deck, f)
    subprocess.run([celldem, "run", str(folder / "deck.json"), "--out", str(folder / "small"), "--quiet",
                    "--threads", "1"], check=True, capture_output=True)
    return folder / "small"


def clean_env(**extra):
    """The environment without the checkout's PYTHONPATH or $CELLDEM (the test's own settings go in extra)."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "CELLDEM")}
    env.update(extra)
    return env


def test_installed_commands_and_import_find_the_binary(celldem, venv, small_run, tmp_path):
    env = clean_env(CELLDEM=celldem, MPLBACKEND="Agg")
    python = str(venv / "bin" / "python")
    where = subprocess.run([python, "-c", "import celldem, os; print(os.path.dirname(celldem.__file__))"],
                           capture_output=True, text=True, env=env, cwd=tmp_path, check=True).stdout.strip()
    assert where.startswith(str(venv)), f"celldem imported from {where}, not the venv"
    code = ("import celldem, sys; run = celldem.open_run(sys.argv[1]); "
            "print(list(run.tests), run.tests['ttc'].series.attrs['units']['s11'])")
    r = subprocess.run([python, "-c", code, str(small_run)], capture_output=True, text=True, env=env, cwd=tmp_path)
    assert r.returncode == 0 and r.stdout.split() == ["['ttc',", "'psc']", "Pa"], r.stdout + r.stderr[-2000:]
    r = subprocess.run([str(venv / "bin" / "celldem-report"), str(small_run)], capture_output=True, text=True,
                       env=env, cwd=tmp_path)
    assert r.returncode == 0, f"celldem-report: exit {r.returncode}\n{r.stdout[-1000:]}\n{r.stderr[-2000:]}"
    assert (small_run / "report.md").is_file()
    for command in ("celldem-figures", "celldem-failure-surface", "celldem-study", "celldem-sufficiency", "celldem-roofline",
                    "celldem-compare-binaries", "celldem-plot-bench"):
        r = subprocess.run([str(venv / "bin" / command), "--help"], capture_output=True, text=True, env=env)
        assert r.returncode == 0 and "usage" in r.stdout.lower(), f"{command} --help: {r.stderr[-1000:]}"


def test_installed_package_finds_the_binary_on_path_or_says_where_it_looked(celldem, venv, tmp_path):
    python = str(venv / "bin" / "python")
    code = "from celldem import binary; print(binary.find()); print(binary.CHECKOUT)"
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    os.symlink(celldem, bin_dir / "celldem")
    env = clean_env(PATH=f"{bin_dir}{os.pathsep}{os.environ.get('PATH', '')}")
    out = subprocess.run([python, "-c", code], capture_output=True, text=True, env=env, check=True).stdout.split()
    assert out == [str(bin_dir / "celldem"), "False"], out
    env = clean_env(PATH=os.path.dirname(sys.executable))
    r = subprocess.run([python, "-c", "import celldem; celldem.check_deck({'format': 1})"], capture_output=True,
                       text=True, env=env, cwd=tmp_path)
    assert r.returncode != 0 and "no celldem binary found; tried: $CELLDEM (not set), celldem on PATH" in r.stderr, \
        r.stderr[-1000:]


def test_mypy_passes_on_the_public_modules():
    files = [os.path.join(ROOT, "tools", "celldem", m + ".py") for m in PUBLIC_MODULES]
    r = subprocess.run([sys.executable, "-m", "mypy", "--config-file", os.path.join(ROOT, "pyproject.toml"),
                        "--no-incremental", *files],
                       capture_output=True, text=True, cwd=ROOT)
    assert r.returncode == 0, f"mypy:\n{r.stdout[-3000:]}{r.stderr[-1000:]}"
