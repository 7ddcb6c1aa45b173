"""A test's incremental response probes as celldem writes them (`tests[].probes`, docs/deck.md), and what the
report measures on them.

celldem writes, per test with probes: summary.json tests.<test>.probes (kind, plane, magnitudes, steps, hold_steps,
table, stiffness, and per point its status, counts, linearity or elastic asymmetry), <test>/probes/probes.csv (one
row per probe, net of the point's reference probe: the direction, the stress and strain increments at the end of
the loaded hold, the plastic strain left after unloading, its elastic part and the residual stress) and, for strain
probes, <test>/probes/stiffness.json (per point and magnitude the tangent and elastic 6x6 stiffness; later also the
stiffness assembled from the contact network). Strains and stresses are compression positive, stresses in Pa.

Stress probes' strain responses are shown in the plane of their directions, on the unit basis the directions are
built on (solver/run/probes.cpp probe_directions): d = cos a u1 + sin a u2 with
  Rendulic  u1 = (1, 0, 0),               u2 = (0, 1, 1) / sqrt 2
  pi        u1 = (2, -1, -1) / sqrt 6,    u2 = (0, 1, -1) / sqrt 2
so the strain increment's coordinates are (de . u1, de . u2), and a response along its stress direction lies at
the direction's own angle. Listed directions have no plane: their responses are shown by size against the index.
"""

import csv
import math
import os

import numpy as np

from .results import number, read_json

SQRT2, SQRT6 = math.sqrt(2.0), math.sqrt(6.0)
PLANE_BASES = {
    "rendulic": (np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 1.0]) / SQRT2),
    "pi": (np.array([2.0, -1.0, -1.0]) / SQRT6, np.array([0.0, 1.0, -1.0]) / SQRT2),
}
STRESS_INCREMENTS = ("ds11", "ds22", "ds33", "ds12", "ds13", "ds23")
STRAIN_INCREMENTS = ("de1", "de2", "de3", "dg12", "dg13", "dg23")
DIRECTION = ("d11", "d22", "d33", "d12", "d13", "d23")
VOIGT = ("11", "22", "33", "12", "13", "23")

# The parts of a stress probe's strain response: the columns of probes.csv that hold them.
PARTS = {"total": STRAIN_INCREMENTS, "plastic": tuple(c + "_plastic" for c in STRAIN_INCREMENTS),
         "elastic": tuple(c + "_elastic" for c in STRAIN_INCREMENTS)}


class ProbeSet:
    """One test's probes: `info` (summary.json tests.<test>.probes), `rows` (probes.csv, each a dict of its columns:
    numbers as floats, NaN where the cell is empty, `controlled` a bool, the rest text) and `stiffness`
    (stiffness.json, None for stress probes or when absent)."""

    def __init__(self, test, info, rows, stiffness):
        self.test = test
        self.info = info
        self.rows = rows
        self.stiffness = stiffness

    kind = property(lambda self: self.info.get("kind"))
    plane = property(lambda self: self.info.get("plane"))

    @property
    def magnitudes(self):
        """The set's magnitudes; a set whose magnitudes follow each point's stiffness (summary.json
        magnitude_factors) has none of its own: every magnitude of probes.csv, ascending."""
        given = [m for m in (number(v) for v in self.info.get("magnitudes") or []) if m is not None]
        if given:
            return given
        return sorted({r["magnitude"] for r in self.rows if isinstance(r.get("magnitude"), float)
                       and math.isfinite(r["magnitude"])})

    def point_magnitudes(self, point):
        """The magnitudes probed at `point`, ascending: the set's, or the point's own where they follow its
        stiffness."""
        if self.info.get("magnitude_factors"):
            return sorted({r["magnitude"] for r in self.point_rows(point) if isinstance(r.get("magnitude"), float)
                           and math.isfinite(r["magnitude"])})
        return self.magnitudes

    @property
    def points(self):
        """{point name: its summary.json entry}, in celldem's order (the e1 points, then the named ones)."""
        points = self.info.get("points")
        return {k: v for k, v in points.items() if isinstance(v, dict)} if isinstance(points, dict) else {}

    def point_rows(self, point, magnitude=None):
        """probes.csv's rows of `point` (and of one magnitude), in the file's order (the directions' order)."""
        return [r for r in self.rows if r["point"] == point
                and (magnitude is None or math.isclose(r["magnitude"], magnitude, rel_tol=1e-9))]

    def stiffness_point(self, point):
        """stiffness.json's entry of `point` ({} when there is none)."""
        entry = ((self.stiffness or {}).get("points") or {}).get(point)
        return entry if isinstance(entry, dict) else {}


def is_ok(row):
    return row.get("status") == "ok"


def parse_cell(name, text):
    if name == "controlled":
        return text == "true"
    if name in ("point", "kind", "probe", "status", "cone"):
        return text
    try:
        return float(text) if text != "" else math.nan
    except ValueError:
        return text


def parse_row(names, cells):
    """One probes.csv row (its header's names, its cells as text) as a dict of parse_cell values."""
    return {k: parse_cell(k, v or "") for k, v in zip(names, cells)}


def read_table(path):
    """probes.csv as a list of row dicts (parse_row), [] when the file is missing."""
    if not os.path.isfile(path):
        return []
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.reader(f)
        names = next(reader, [])
        return [parse_row(names, cells) for cells in reader if cells]


def load(run, test):
    """The ProbeSet of `test` in `run` (a results.Run), or None when the test ran no probes."""
    info = run.test_summary(test).get("probes")
    if not isinstance(info, dict):
        return None
    table = os.path.join(run.directory, info.get("table") or os.path.join(test, "probes", "probes.csv"))
    stiffness = read_json(os.path.join(run.directory, info["stiffness"])) if info.get("stiffness") else None
    return ProbeSet(test, info, read_table(table), stiffness if isinstance(stiffness, dict) else None)


def load_all(run):
    """[ProbeSet] of every test of `run` that ran probes, in the run's test order."""
    sets = (load(run, t) for t in run.test_names)
    return [s for s in sets if s is not None]


def vector(row, columns):
    return np.array([row[c] for c in columns], dtype=float)


def in_plane(plane, vectors):
    """(n x 3) normal components -> (n x 2) coordinates (. u1, . u2) on the plane's basis."""
    u1, u2 = PLANE_BASES[plane]
    v = np.atleast_2d(vectors)
    return np.column_stack([v @ u1, v @ u2])


def response_size(row, part="total"):
    """|de| of a probe's response part, the six strains (engineering shears) as celldem's linearity takes it."""
    return float(np.linalg.norm(vector(row, PARTS[part])))


def envelope(rows, plane, part="total"):
    """The tips of the responses of `rows` (one point and magnitude, the directions in order) per unit of the
    magnitude [1/Pa]: (n x 2) plane coordinates (stress probes in a plane), else (n,) sizes; NaN for a failed
    probe."""
    scale = np.array([1.0 / r["magnitude"] if is_ok(r) else math.nan for r in rows])
    if plane in PLANE_BASES:
        normal = np.array([vector(r, PARTS[part][:3]) for r in rows]).reshape(-1, 3)
        return in_plane(plane, normal) * scale[:, None]
    return np.array([response_size(r, part) if is_ok(r) else math.nan for r in rows]) * scale


def direction_angle(row, plane):
    """The direction's angle in its plane (deg), from its components; None for listed directions."""
    if plane not in PLANE_BASES:
        return None
    x, y = in_plane(plane, vector(row, DIRECTION[:3]))[0]
    return math.degrees(math.atan2(y, x)) % 360.0


def direction_text(row, plane):
    """'d07 (315°; Δσ/M = 0.71, -0.5, -0.5)' in a plane, 'd03 (Δσ/M = 0.58, 0.58, 0.58)' for a listed direction."""
    name = row["probe"].split("-")[-1]
    angle = direction_angle(row, plane)
    components = "Δσ/M = " + ", ".join(f"{round(v, 2) + 0.0:g}" for v in vector(row, DIRECTION[:3]))
    return f"{name} ({'' if angle is None else f'{angle:.0f}°; '}{components})"


def envelope_findings(rows, plane):
    """What the response envelope of one point and magnitude shows, computed from its probes that ran: the
    directions of the largest and of the smallest total response and the ratio of the two, the direction of the
    largest plastic response with its compliance [1/Pa] and its ratio to that probe's total response, and the
    plastic responses' sum over the total ones' (above 1 where unloading did not bring the sample back, as near a
    peak). None without two probes that ran."""
    ok = [r for r in rows if is_ok(r)]
    if len(ok) < 2:
        return None
    total = np.array([response_size(r) for r in ok])
    plastic = np.array([response_size(r, "plastic") for r in ok])
    largest, smallest, most_plastic = int(np.argmax(total)), int(np.argmin(total)), int(np.argmax(plastic))
    return {
        "largest": direction_text(ok[largest], plane), "smallest": direction_text(ok[smallest], plane),
        "ratio": float(total[largest] / total[smallest]) if total[smallest] > 0 else None,
        "most_plastic": direction_text(ok[most_plastic], plane),
        "most_plastic_compliance": float(plastic[most_plastic] / ok[most_plastic]["magnitude"]),
        "most_plastic_over_total": float(plastic[most_plastic] / total[most_plastic]) if total[most_plastic] > 0
        else None,
        "plastic_over_total": float(plastic.sum() / total.sum()) if total.sum() > 0 else None,
    }


def matrix(value):
    """A 6x6 stiffness from JSON, or None when it is not one."""
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return None
    return m if m.shape == (6, 6) else None


def asymmetry(m):
    """|C - C^T| / |C| (Frobenius), 0 for a symmetric matrix: the measure celldem writes (solver/run/probes.cpp)."""
    size = np.linalg.norm(m)
    return float(np.linalg.norm(m - m.T) / size) if size > 0 else None


def stiffness_matrices(entry):
    """[(label, 6x6 [Pa], asymmetry)] of one point of stiffness.json: per magnitude its elastic and tangent
    stiffness (celldem's asymmetry), then the contact network's affine and relaxed stiffness when present."""
    out = []
    magnitudes = [m for m in entry.get("magnitudes") or [] if isinstance(m, dict)]
    for m in magnitudes:
        at = f" at M = {m.get('magnitude'):g}" if len(magnitudes) > 1 else ""
        for kind in ("elastic", "tangent"):
            c = matrix(m.get(kind))
            if c is not None:
                out.append((f"{kind}{at}", c, number(m.get(f"{kind}_asymmetry"))))
    network = entry.get("network")
    if isinstance(network, dict):
        for kind in ("affine", "relaxed"):
            c = matrix(network.get(kind))
            if c is not None:
                out.append((f"network {kind}", c, asymmetry(c)))
    return out
