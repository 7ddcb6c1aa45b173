"""A test's incremental response probes as celldem writes them (`tests[].probes`, docs/deck.md), and what the
report measures on them.

celldem writes, per test with probes: summary.json tests.<test>.probes (kind, plane, magnitudes, steps, hold_steps,
table, stiffness, and per point its status, counts, linearity or elastic asymmetry), <test>/probes/probes.csv (one
row per probe, net of the point's reference probe: the direction, the stress and strain increments at the end of
the loaded hold, the plastic strain left after unloading, its elastic part and the residual stress) and, for strain
probes, <test>/probes/stiffness.json (per point and magnitude the tangent and elastic 6x6 stiffness; later also the
stiffness assembled from the contact network). Strains and stresses are compression positive, stresses in Pa.

Stress probes' strain responses are shown in the plane of their directions, on the unit basis the directions are
built on, d = cos a u1 + sin a u2 (Rendulic: u1 = (1, 0, 0), u2 = (0, 1, 1) / sqrt 2; pi: u1 = (2, -1, -1) / sqrt 6,
u2 = (0, 1, -1) / sqrt 2), taken from the solver (`celldem schema --constants` probe_planes, solver/run/probes.cpp
plane_basis): the strain increment's coordinates are (de . u1, de . u2), and a response along its stress
direction lies at the direction's own angle. Listed directions have no plane: their responses are shown by size
against the index. The asymmetry of a stiffness, |C - C^T| / |C|, is celldem's too (stiffness.json).
"""

from __future__ import annotations

import csv
import math
import os
from typing import Any, Dict, List, Optional, Sequence, Tuple, Union

import numpy as np
import numpy.typing as npt

from . import binary
from .binary import PathLike
from .files import number, read_json
from .results import RunArrays

Array = npt.NDArray[np.float64]
# A probes.csv row: numbers as floats (NaN where the cell is empty), `controlled` a bool, the rest text.
Row = Dict[str, Any]

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

    def __init__(self, test: str, info: Dict[str, Any], rows: List[Row], stiffness: Optional[Dict[str, Any]]) -> None:
        self.test = test
        self.info = info
        self.rows = rows
        self.stiffness = stiffness

    @property
    def kind(self) -> Optional[str]:
        """"stress" or "strain"."""
        return self.info.get("kind")

    @property
    def plane(self) -> Optional[str]:
        """The stress probes' plane ("rendulic", "pi", "list"); None for strain probes."""
        return self.info.get("plane")

    @property
    def magnitudes(self) -> List[float]:
        """The set's magnitudes M (Pa for stress probes, strain for strain probes); a set whose magnitudes follow
        each point's stiffness (summary.json magnitude_factors) has none of its own: every magnitude of
        probes.csv, ascending."""
        given = [m for m in (number(v) for v in self.info.get("magnitudes") or []) if m is not None]
        if given:
            return given
        return sorted({r["magnitude"] for r in self.rows if isinstance(r.get("magnitude"), float)
                       and math.isfinite(r["magnitude"])})

    def point_magnitudes(self, point: str) -> List[float]:
        """The magnitudes probed at `point`, ascending: the set's, or the point's own where they follow its
        stiffness."""
        if self.info.get("magnitude_factors"):
            return sorted({r["magnitude"] for r in self.point_rows(point) if isinstance(r.get("magnitude"), float)
                           and math.isfinite(r["magnitude"])})
        return self.magnitudes

    @property
    def points(self) -> Dict[str, Dict[str, Any]]:
        """{point name: its summary.json entry}, in celldem's order (the e1 points, then the named ones)."""
        points = self.info.get("points")
        return {k: v for k, v in points.items() if isinstance(v, dict)} if isinstance(points, dict) else {}

    def point_rows(self, point: str, magnitude: Optional[float] = None) -> List[Row]:
        """probes.csv's rows of `point` (and of one magnitude), in the file's order (the directions' order)."""
        return [r for r in self.rows if r["point"] == point
                and (magnitude is None or math.isclose(r["magnitude"], magnitude, rel_tol=1e-9))]

    def stiffness_point(self, point: str) -> Dict[str, Any]:
        """stiffness.json's entry of `point` ({} when there is none)."""
        entry = ((self.stiffness or {}).get("points") or {}).get(point)
        return entry if isinstance(entry, dict) else {}


def is_ok(row: Row) -> bool:
    """Whether a probe ran (status "ok")."""
    return row.get("status") == "ok"


def parse_cell(name: str, text: str) -> Union[bool, float, str]:
    """One probes.csv cell: `controlled` a bool, the names a text, a number a float (NaN when empty)."""
    if name == "controlled":
        return text == "true"
    if name in ("point", "kind", "probe", "status", "cone"):
        return text
    try:
        return float(text) if text != "" else math.nan
    except ValueError:
        return text


def parse_row(names: Sequence[str], cells: Sequence[Optional[str]]) -> Row:
    """One probes.csv row (its header's names, its cells as text) as a dict of parse_cell values."""
    return {k: parse_cell(k, v or "") for k, v in zip(names, cells)}


def read_table(path: PathLike) -> List[Row]:
    """A probes.csv table.

    Parameters
    ----------
    path : str or os.PathLike
        The file.

    Returns
    -------
    list of dict
        One dict per row (parse_row), in the file's order; [] when the file is missing.
    """
    if not os.path.isfile(path):
        return []
    with open(path, encoding="utf-8", newline="") as f:
        reader = csv.reader(f)
        names: List[str] = next(reader, [])
        return [parse_row(names, cells) for cells in reader if cells]


def load(run: RunArrays, test: str) -> Optional[ProbeSet]:
    """A test's probes.

    Parameters
    ----------
    run : results.RunArrays
        The run.
    test : str
        The test's name.

    Returns
    -------
    ProbeSet or None
        Its summary.json entry, probes.csv and stiffness.json; None when the test ran no probes.
    """
    info = run.test_summary(test).get("probes")
    if not isinstance(info, dict):
        return None
    table = os.path.join(run.directory, info.get("table") or os.path.join(test, "probes", "probes.csv"))
    stiffness = read_json(os.path.join(run.directory, info["stiffness"])) if info.get("stiffness") else None
    return ProbeSet(test, info, read_table(table), stiffness if isinstance(stiffness, dict) else None)


def load_all(run: RunArrays) -> List[ProbeSet]:
    """Every test's probes.

    Parameters
    ----------
    run : results.RunArrays
        The run.

    Returns
    -------
    list of ProbeSet
        One per test that ran probes, in the run's test order.
    """
    sets = (load(run, t) for t in run.test_names)
    return [s for s in sets if s is not None]


def vector(row: Row, columns: Sequence[str]) -> Array:
    """The row's values of `columns` as a float array."""
    return np.array([row[c] for c in columns], dtype=float)


def plane_bases(celldem: Optional[PathLike] = None) -> Dict[str, Tuple[Array, Array]]:
    """The unit bases of the stress probe planes, the solver's.

    Parameters
    ----------
    celldem : str or os.PathLike, optional
        The binary; default as binary.find.

    Returns
    -------
    dict
        {plane: (u1, u2)} for "rendulic" and "pi": a direction at angle a is cos a u1 + sin a u2 (`celldem schema
        --constants` probe_planes, read once per binary).
    """
    planes = binary.constants(celldem)["probe_planes"]["value"]
    return {name: (np.array(b["u1"], dtype=float), np.array(b["u2"], dtype=float)) for name, b in planes.items()}


def in_a_plane(plane: Optional[str]) -> bool:
    """Whether a probe set's `plane` is one of the solver's probe planes (a listed set has none)."""
    return plane in plane_bases()


def in_plane(plane: str, vectors: npt.ArrayLike) -> Array:
    """Normal components in a probe plane's coordinates.

    Parameters
    ----------
    plane : str
        "rendulic" or "pi".
    vectors : array_like
        (n x 3) or (3,): the 11, 22, 33 components of stress or strain increments.

    Returns
    -------
    numpy.ndarray
        (n x 2): (v . u1, v . u2) on the plane's basis (plane_bases).
    """
    u1, u2 = plane_bases()[plane]
    v = np.atleast_2d(vectors)
    return np.column_stack([v @ u1, v @ u2])


def response_size(row: Row, part: str = "total") -> float:
    """|de| of a probe's response part, the six strains (engineering shears) as celldem's linearity takes it."""
    return float(np.linalg.norm(vector(row, PARTS[part])))


def envelope(rows: List[Row], plane: Optional[str], part: str = "total") -> Array:
    """The response envelope of one point and magnitude.

    Parameters
    ----------
    rows : list of dict
        The probes.csv rows of the point and magnitude, the directions in order.
    plane : str or None
        The probes' plane; a listed set (or None) has none.
    part : str
        "total", "plastic" or "elastic" (PARTS).

    Returns
    -------
    numpy.ndarray
        The tips of the responses per unit of the magnitude [1/Pa]: (n x 2) plane coordinates for stress probes
        in a plane, else (n,) sizes; NaN for a probe that failed.
    """
    scale = np.array([1.0 / r["magnitude"] if is_ok(r) else math.nan for r in rows])
    if plane is not None and in_a_plane(plane):
        normal = np.array([vector(r, PARTS[part][:3]) for r in rows]).reshape(-1, 3)
        return in_plane(plane, normal) * scale[:, None]
    return np.array([response_size(r, part) if is_ok(r) else math.nan for r in rows]) * scale


def direction_angle(row: Row, plane: Optional[str]) -> Optional[float]:
    """The direction's angle in its plane (deg), from its components; None for listed directions."""
    if plane is None or not in_a_plane(plane):
        return None
    x, y = in_plane(plane, vector(row, DIRECTION[:3]))[0]
    return math.degrees(math.atan2(y, x)) % 360.0


def direction_text(row: Row, plane: Optional[str]) -> str:
    """'d07 (315°; Δσ/M = 0.71, -0.5, -0.5)' in a plane, 'd03 (Δσ/M = 0.58, 0.58, 0.58)' for a listed direction."""
    name = row["probe"].split("-")[-1]
    angle = direction_angle(row, plane)
    components = "Δσ/M = " + ", ".join(f"{round(v, 2) + 0.0:g}" for v in vector(row, DIRECTION[:3]))
    return f"{name} ({'' if angle is None else f'{angle:.0f}°; '}{components})"


def envelope_findings(rows: List[Row], plane: Optional[str]) -> Optional[Dict[str, Any]]:
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


def matrix(value: Any) -> Optional[Array]:
    """A 6x6 stiffness from JSON, or None when it is not one."""
    try:
        m = np.array(value, dtype=float)
    except (TypeError, ValueError):
        return None
    return m if m.shape == (6, 6) else None


def stiffness_matrices(entry: Dict[str, Any]) -> List[Tuple[str, Array, Optional[float]]]:
    """The stiffness matrices of one point.

    Parameters
    ----------
    entry : dict
        The point's entry of stiffness.json.

    Returns
    -------
    list of (str, numpy.ndarray, float or None)
        (label, 6x6 stiffness [Pa], asymmetry): per magnitude its elastic and tangent stiffness, then the contact
        network's affine and relaxed stiffness when present; each asymmetry is celldem's (stiffness.json's
        <kind>_asymmetry; None where a run predates it).
    """
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
                out.append((f"network {kind}", c, number(network.get(f"{kind}_asymmetry"))))
    return out
