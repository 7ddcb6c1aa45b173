"""Snapshots read by VTK itself (Debian's python3-vtk9): a small run (a preparation and a triaxial test, about
150 spheres) writes its snapshots once in each encoding (`snapshots.format`: binary, zlib, ascii), and
vtkXMLUnstructuredGridReader / vtkXMLPolyDataReader read every file without an error or a warning. Then:
- the three encodings hold the same arrays, bit for bit and of the same types (snapshots do not change the
  physics, so the three runs have the same states);
- VTK's values agree with what the run wrote as text and VTK did not read: the ascii files parsed here with
  ElementTree, and the LAMMPS dump of the same step (ids, radii, positions, velocities, spins, contact counts,
  the net force and the particle stress's six components; the box: the test's cell is orthogonal, so the dump's
  frame is celldem's);
- the field data names the snapshot: TimeValue is the collection's time, step the file's step, cell_h the
  dump's box;
- the contact network is consistent with the particles: each line runs from i's centre by the branch, the
  lines' ends are the particles' contact counts, the particles' net forces are the sums of their contacts'
  forces, and their stresses V_p sigma_p add up to the contacts' sum of sym(f (x) branch).
A missing `import vtk` fails the test (CI installs python3-vtk9): it never skips.

Usage: CELLDEM=build/celldem /usr/bin/python3 -m pytest tests/io/test_snapshot_vtk.py (ctest: io_snapshot_vtk)
"""
import json
import math
import os
import re
import subprocess
import xml.etree.ElementTree as ET

import numpy as np
import pytest

try:
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy
    VTK_MISSING = None
except ImportError as e:  # the fixture below fails the test with this
    VTK_MISSING = str(e)

FORMATS = ("binary", "zlib", "ascii")
failures = []  # the checks' failures, all of them reported at the end of the test (cleared at its start)


def check(what, ok):
    if not ok:
        failures.append(what)


def deck(fmt):
    return {
        "format": 1,
        "sample": {"count": 150, "diameters": {"min": 3.0e-3, "max": 4.5e-3, "count": 4}, "density": 2650,
                   "seed": 7, "grid_spacing": 5.0e-3},
        "contact": {"kn": 1.0e6, "kt": 1.0e6},
        "damping": {"translational": 0.1, "rotational": 0.1},
        "time_step": 3.0e-6,
        "servo": {"max_strain_increment": 4e-5},
        "prepare": {"target_pressure": 1.0e5, "fast_strain_increment": 1e-4, "fast_solid_fraction": 0.55,
                    "output_interval": 500, "snapshots": {"interval": 10**9, "format": fmt},
                    "equilibrium": {"pressure_tolerance": 0.01, "stress_tolerance": 0.02,
                                    "unbalanced_force_ratio": 0.02, "min_steps": 1000, "check_interval": 500,
                                    "max_steps": 200000}},
        "tests": [{"name": "ttc", "friction": 0.3,
                   "axes": {"x1": {"strain_increment": 1e-5}, "x2": {"stress": 1e5}, "x3": {"stress": 1e5}},
                   "end": {"axis": "x1", "strain": 0.004}, "output_interval": 100,
                   "snapshots": {"interval": 150, "e1": [0.001], "format": fmt}}],
    }


class Errors:
    """Collects the errors and warnings a VTK object reports (VTK prints them and carries on)."""

    def __init__(self, obj):
        self.messages = []
        for event in ("ErrorEvent", "WarningEvent"):
            obj.AddObserver(event, self.seen)

    def seen(self, obj, event):
        self.messages.append(event)


def read_vtk(path):
    reader = vtk.vtkXMLUnstructuredGridReader() if path.endswith(".vtu") else vtk.vtkXMLPolyDataReader()
    errors = Errors(reader)
    reader.SetFileName(path)
    reader.Update()
    check(f"{path}: VTK reports {errors.messages}", not errors.messages)
    return reader.GetOutput()


def arrays(dataset):
    """Every array of the dataset as {(where, name): numpy array}, where = field, point, cell, points or cells."""
    out = {}
    for where, data in (("field", dataset.GetFieldData()), ("point", dataset.GetPointData()),
                        ("cell", dataset.GetCellData())):
        for k in range(data.GetNumberOfArrays()):
            a = data.GetAbstractArray(k)
            out[(where, a.GetName())] = vtk_to_numpy(a)
    if dataset.GetPoints() is not None:
        out[("points", "")] = vtk_to_numpy(dataset.GetPoints().GetData())
    cells = dataset.GetCells() if hasattr(dataset, "GetCells") else dataset.GetLines()
    if cells is not None and cells.GetNumberOfCells() > 0:
        out[("cells", "connectivity")] = vtk_to_numpy(cells.GetConnectivityArray())
        out[("cells", "offsets")] = vtk_to_numpy(cells.GetOffsetsArray())
    if hasattr(dataset, "GetCellTypesArray") and dataset.GetCellTypesArray() is not None:
        out[("cells", "types")] = vtk_to_numpy(dataset.GetCellTypesArray())
    return out


def ascii_arrays(path):
    """The ascii file's arrays parsed here (no VTK), as {name: list of floats}; the points' array is ""."""
    out = {}
    for e in ET.parse(path).getroot().iter("DataArray"):
        check(f"{path}: array {e.get('Name')} is ascii", e.get("format") == "ascii")
        out[e.get("Name", "")] = [float(w) for w in (e.text or "").split()]
    return out


def collection(path):
    """[(time, file)] of a .pvd."""
    return [(float(d.get("timestep")), d.get("file")) for d in ET.parse(path).getroot().iter("DataSet")]


def dump(path):
    """The box bounds and the atoms (rows of floats, in id order) of a LAMMPS dump."""
    lines = open(path).read().splitlines()
    check(f"{path}: orthogonal box", lines[4].split() == ["ITEM:", "BOX", "BOUNDS", "pp", "pp", "pp"])
    box = [[float(w) for w in lines[k].split()] for k in (5, 6, 7)]
    atoms = np.array([[float(w) for w in line.split()] for line in lines[9:]])
    return box, atoms


@pytest.fixture(scope="module")
def runs(celldem, tmp_path_factory):
    """The small run once in each encoding: {format: its folder}."""
    if VTK_MISSING:
        pytest.fail(f"cannot import VTK's Python bindings ({VTK_MISSING}): install python3-vtk9 "
                    "(tools/install-deps.sh) and run this test with /usr/bin/python3")
    tmp = str(tmp_path_factory.mktemp("vtk"))
    out = {}
    for fmt in FORMATS:
        path = os.path.join(tmp, f"{fmt}.json")
        with open(path, "w") as f:
            json.dump(deck(fmt), f)
        out[fmt] = os.path.join(tmp, fmt)
        r = subprocess.run([celldem, "run", path, "--out", out[fmt], "--threads", "1", "--quiet"],
                           capture_output=True, text=True)
        assert r.returncode == 0, f"celldem run ({fmt}) exit {r.returncode}: {r.stderr.strip()}"
    return out


def test_vtk_reads_every_snapshot_and_the_encodings_agree(runs):
    failures.clear()
    checked_contacts = checked_sliding = snapshots = 0
    for stage in ("prepare", "ttc"):
        folders = {fmt: os.path.join(runs[fmt], stage, "snapshots") for fmt in FORMATS}
        particles = collection(os.path.join(folders["binary"], f"{stage}.pvd"))
        contact_files = collection(os.path.join(folders["binary"], f"{stage}_contacts.pvd"))
        check(f"{stage}: snapshots listed", len(particles) >= 2 and len(particles) == len(contact_files))
        for fmt in FORMATS:
            check(f"{stage} ({fmt}): the same collection",
                  collection(os.path.join(folders[fmt], f"{stage}.pvd")) == particles)
        for (time, vtu_name), (_, vtp_name) in zip(particles, contact_files):
            step = int(re.fullmatch(rf"{re.escape(stage)}_(\d+)\.vtu", vtu_name).group(1))
            where = f"{stage} step {step}"
            snapshots += 1
            vtu = {fmt: arrays(read_vtk(os.path.join(folders[fmt], vtu_name))) for fmt in FORMATS}
            vtp = {fmt: arrays(read_vtk(os.path.join(folders[fmt], vtp_name))) for fmt in FORMATS}

            # The three encodings: the same arrays, the same types, the same bits.
            for files in (vtu, vtp):
                for fmt in ("zlib", "ascii"):
                    check(f"{where}: {fmt} has the binary file's arrays", files[fmt].keys() == files["binary"].keys())
                    for key, a in files["binary"].items():
                        b = files[fmt].get(key)
                        check(f"{where}: {key} in {fmt} equals binary",
                              b is not None and a.dtype == b.dtype and np.array_equal(a, b))

            p = vtu["binary"]
            n = len(p[("point", "radius")])
            # VTK's values of the binary files = the ascii files' text, parsed without VTK.
            for vtk_arrays, name in ((p, f"{stage}_{step}.vtu"), (vtp["binary"], f"{stage}_contacts_{step}.vtp")):
                text = ascii_arrays(os.path.join(folders["ascii"], name))
                for (kind, array_name), a in vtk_arrays.items():
                    if kind == "cells":
                        continue
                    check(f"{where}: {array_name or 'points'} as text = VTK's binary",
                          np.array_equal(np.asarray(text.get(array_name, []), dtype=float), a.astype(float).ravel()))

            # The field data names the snapshot.
            check(f"{where}: TimeValue = the collection's time", p[("field", "TimeValue")].tolist() == [time])
            check(f"{where}: step", p[("field", "step")].tolist() == [step])
            h = p[("field", "cell_h")].reshape(3, 3)
            check(f"{where}: cell_h in the contact file", np.array_equal(vtp["binary"][("field", "cell_h")].reshape(3, 3), h))

            # The LAMMPS dump of the same step (text, %.17g): the same particles.
            box, atoms = dump(os.path.join(folders["binary"], f"{stage}_{step}.dump"))
            check(f"{where}: dump box = cell_h", [b[1] for b in box] == np.diag(h).tolist()
                  and [b[0] for b in box] == [0.0] * 3 and np.count_nonzero(h - np.diag(np.diag(h))) == 0)
            check(f"{where}: dump atoms", atoms.shape == (n, 21))
            check(f"{where}: ids", np.array_equal(atoms[:, 0] - 1, p[("point", "id")]))
            check(f"{where}: radii", np.array_equal(atoms[:, 1], p[("point", "radius")]))
            check(f"{where}: positions", np.array_equal(atoms[:, 2:5], p[("points", "")]))
            check(f"{where}: velocities", np.array_equal(atoms[:, 5:8], p[("point", "velocity")]))
            check(f"{where}: spins", np.array_equal(atoms[:, 8:11], p[("point", "spin")]))
            check(f"{where}: contact counts", np.array_equal(atoms[:, 11], p[("point", "contacts")]))
            check(f"{where}: dump net force (fx fy fz) = the .vtu's",
                  np.array_equal(atoms[:, 12:15], p[("point", "net_force")].reshape(n, 3)))
            t = p[("point", "stress")].reshape(n, 3, 3)
            six = np.stack([t[:, 0, 0], t[:, 1, 1], t[:, 2, 2], 0.5 * (t[:, 0, 1] + t[:, 1, 0]),
                            0.5 * (t[:, 0, 2] + t[:, 2, 0]), 0.5 * (t[:, 1, 2] + t[:, 2, 1])], axis=1)
            check(f"{where}: dump c_stress[1-6] = the .vtu's stress (xx yy zz, symmetric xy xz yz)",
                  np.array_equal(atoms[:, 15:21], six))
            check(f"{where}: one vertex per particle", np.array_equal(p[("cells", "types")], np.full(n, vtk.VTK_VERTEX))
                  and np.array_equal(p[("cells", "connectivity")], np.arange(n)))

            # The contact network against the particles.
            c = vtp["binary"]
            m = len(c.get(("cell", "normal_force"), []))
            check(f"{where}: contact lines = half the contact counts", 2 * m == int(p[("point", "contacts")].sum()))
            force_sum = np.zeros((n, 3))
            stress_sum = np.zeros((3, 3))
            if m:
                i, j = c[("cell", "i")], c[("cell", "j")]
                branch, fn, ft = c[("cell", "branch")], c[("cell", "normal_force")], c[("cell", "tangential_force")]
                x = c[("points", "")]
                check(f"{where}: lines 2c -> 2c + 1", np.array_equal(c[("cells", "connectivity")], np.arange(2 * m))
                      and np.array_equal(c[("cells", "offsets")], np.arange(0, 2 * m + 1, 2)))
                check(f"{where}: lines start at i's centre", np.array_equal(x[0::2], p[("points", "")][i]))
                scale = np.abs(branch).max()
                check(f"{where}: lines end at the branch", np.allclose(x[1::2] - x[0::2], branch, rtol=0, atol=1e-12 * scale))
                radius = p[("point", "radius")]
                check(f"{where}: touching pairs overlap",
                      bool(np.all(np.linalg.norm(branch, axis=1) < radius[i] + radius[j])))
                check(f"{where}: compression positive", bool(np.all(fn > 0)))
                check(f"{where}: sliding is 0/1", set(c[("cell", "sliding")].tolist()) <= {0, 1})
                unit = branch / np.linalg.norm(branch, axis=1)[:, None]
                f = fn[:, None] * unit + ft  # on j by i
                np.add.at(force_sum, j, f)
                np.add.at(force_sum, i, -f)
                outer = f[:, :, None] * branch[:, None, :]
                stress_sum = (outer + outer.transpose(0, 2, 1)).sum(axis=0) / 2
                checked_contacts += m
                checked_sliding += int(c[("cell", "sliding")].sum())
            fscale = max(np.abs(force_sum).max(), 1e-300)
            check(f"{where}: net forces = the contacts' sums",
                  np.allclose(p[("point", "net_force")], force_sum, rtol=0, atol=1e-9 * fscale))
            volume = 4.0 / 3.0 * math.pi * p[("point", "radius")] ** 3
            particle_sum = (volume[:, None, None] * p[("point", "stress")].reshape(n, 3, 3)).sum(axis=0)
            sscale = max(np.abs(stress_sum).max(), 1e-300)
            check(f"{where}: sum V_p sigma_p = sum sym(f (x) branch)",
                  np.allclose(particle_sum, stress_sum, rtol=0, atol=1e-9 * sscale))
    check(f"contacts read ({checked_contacts}), some sliding ({checked_sliding})",
          checked_contacts > 100 and checked_sliding > 0)
    print(f"{snapshots} snapshots, {checked_contacts} contacts ({checked_sliding} sliding), each in {len(FORMATS)} encodings")

    assert not failures, "\n".join(failures)


def test_binary_files_are_smaller_than_text(runs):
    last = collection(os.path.join(runs["binary"], "ttc", "snapshots", "ttc_contacts.pvd"))[-1][1]
    sizes = {fmt: os.path.getsize(os.path.join(runs[fmt], "ttc", "snapshots", last)) for fmt in FORMATS}
    print(f"{last}: " + ", ".join(f"{fmt} {size} bytes" for fmt, size in sizes.items()))
    assert sizes["zlib"] < sizes["binary"] < sizes["ascii"], f"binary and zlib files smaller than ascii: {sizes}"

