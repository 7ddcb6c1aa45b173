"""Markdown tables and the formatting of numbers in them."""

import math

import numpy as np


def fmt(value, digits=3):
    """A number for a table; 'n/a' for missing or non-finite values."""
    if value is None:
        return "n/a"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    try:
        v = float(value)
    except (TypeError, ValueError):
        return str(value)
    if not math.isfinite(v):
        return "n/a"
    if v != 0 and (abs(v) >= 1e5 or abs(v) < 1e-3):
        return f"{v:.{digits}g}"
    return f"{v:.{digits}f}"


def fmt_spec(value, spec=".4g", missing="—"):
    """A number by a format spec (".3g", ".1f"); `missing` for None."""
    return missing if value is None else format(value, spec)


def scaled(value, factor):
    """value × factor, None staying None."""
    return None if value is None else value * factor


def yes_no(flag):
    return "n/a" if flag is None else ("yes" if flag else "no")


def md_cell(value):
    return str(value).replace("|", "\\|").replace("\n", " ")


def md_table(headers, rows, align=None):
    """A Markdown table; '|' inside a cell is escaped. align: one letter per column, "l" or "r" (right-aligned
    numbers); default all left."""
    align = align or "l" * len(headers)
    lines = ["| " + " | ".join(md_cell(h) for h in headers) + " |",
             "|" + "|".join("---:" if a == "r" else "---" for a in align) + "|"]
    lines += ["| " + " | ".join(md_cell(c) for c in row) + " |" for row in rows]
    return "\n".join(lines)
