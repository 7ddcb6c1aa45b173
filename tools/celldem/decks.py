"""Decks as data: load a deck, change values in the dict, write it back with a generic, readable JSON layout.

Nothing here knows the deck's keys; what a deck implies comes from `celldem plan` (binary.py).
"""

from __future__ import annotations

import copy
import json
import os
from typing import Any, Dict, Mapping

from .binary import CHECKOUT, REPO, PathLike
from .files import load_json

# A deck as data: the JSON object of a deck file.
DeckData = Dict[str, Any]

# The paper's deck: the checkout's inputs/paper.json, or in an installed package its copy, data/paper.json (a
# link to inputs/paper.json in the checkout, which pip copies when it installs the package). The reports need it
# to tell the paper's scene from others.
PAPER_DECK = os.path.join(REPO, "inputs", "paper.json") if CHECKOUT else \
    os.path.join(os.path.dirname(os.path.abspath(__file__)), "data", "paper.json")
LINE_WIDTH = 110


def load(path: PathLike = PAPER_DECK) -> DeckData:
    """A deck file as data.

    Parameters
    ----------
    path : str or os.PathLike
        The deck; default the paper's (PAPER_DECK).

    Returns
    -------
    dict
        The deck's JSON value (a deck is an object; the callers check).

    Raises
    ------
    files.FileFormatError
        The file is not JSON (the message names it, the line and the column).
    OSError
        The file cannot be opened.
    """
    data: DeckData = load_json(path)
    return data


def edited(deck: Mapping[str, Any], changes: Mapping[str, Any]) -> DeckData:
    """A deck with some values changed.

    Parameters
    ----------
    deck : dict
        The deck (not changed).
    changes : dict
        Key path -> value: {"time_step": 3e-6, "servo.max_strain_increment": 1e-5}; a value None removes the key.
        Missing objects on a path are created.

    Returns
    -------
    dict
        A deep copy of `deck` with `changes` applied.
    """
    out: DeckData = copy.deepcopy(dict(deck))
    for path, value in changes.items():
        *parents, last = path.split(".")
        node = out
        for key in parents:
            node = node.setdefault(key, {})
        if value is None:
            node.pop(last, None)
        else:
            node[last] = copy.deepcopy(value)
    return out


def insert_after(mapping: Mapping[str, Any], after: str, key: str, value: Any) -> Dict[str, Any]:
    """A copy of a dict with key: value placed right after `after` (or replaced in place when present).

    Parameters
    ----------
    mapping : dict
        The dict (not changed).
    after : str
        The key to place the new one after; at the end when absent.
    key : str
        The new key.
    value : object
        Its value.

    Returns
    -------
    dict
        The copy, in the order a reader of the JSON expects.
    """
    if key in mapping:
        return {k: (value if k == key else v) for k, v in mapping.items()}
    out: Dict[str, Any] = {}
    for k, v in mapping.items():
        out[k] = v
        if k == after:
            out[key] = value
    out.setdefault(key, value)
    return out


def json_number(x: float) -> str:
    """A float as the decks in inputs/ write it.

    Parameters
    ----------
    x : float
        The number.

    Returns
    -------
    str
        1.0e6, 2.0e-7, 0.05: 12 significant digits at most, a decimal point always.
    """
    if x == 0:
        return "0.0"
    if 1e-2 <= abs(x) < 1e4:
        text = f"{x:.12g}"
        return text if "." in text else text + ".0"
    mantissa, exponent = f"{x:.11e}".split("e")
    mantissa = mantissa.rstrip("0")
    return f"{mantissa}0e{int(exponent)}" if mantissa.endswith(".") else f"{mantissa}e{int(exponent)}"


def _inline(v: Any) -> str:
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)}: {_inline(x)}" for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ", ".join(_inline(x) for x in v) + "]"
    if isinstance(v, float):
        return json_number(v)
    return json.dumps(v, ensure_ascii=False)


def _layout(v: Any, indent: int, used: int, width: int) -> str:
    """v at `indent`, `used` columns of its line already taken: on one line when it fits (with a trailing
    comma), else one member per line."""
    one = _inline(v)
    if not isinstance(v, (dict, list)) or not v or used + len(one) + 1 <= width:
        return one
    pad = " " * (indent + 2)
    if isinstance(v, dict):
        items = [f"{pad}{json.dumps(k)}: " + _layout(x, indent + 2, len(pad) + len(json.dumps(k)) + 2, width)
                 for k, x in v.items()]
        open_, close = "{", "}"
    else:
        items = [pad + _layout(x, indent + 2, len(pad), width) for x in v]
        open_, close = "[", "]"
    return open_ + "\n" + ",\n".join(items) + "\n" + " " * indent + close


def format_json(value: Any, width: int = LINE_WIDTH) -> str:
    """JSON text for people.

    Parameters
    ----------
    value : object
        A JSON value.
    width : int
        The line width.

    Returns
    -------
    str
        Each object or array on one line when it fits in `width` columns, else one member per line, nested
        alike; floats as json_number writes them; a final newline.
    """
    return _layout(value, 0, 0, width) + "\n"


def write(path: PathLike, deck: Mapping[str, Any]) -> None:
    """Writes a deck with format_json (under a temporary name, then renamed).

    Parameters
    ----------
    path : str or os.PathLike
        The file.
    deck : dict
        The deck.
    """
    tmp = os.fspath(path) + ".tmp"
    with open(tmp, "w", encoding="utf-8") as f:
        f.write(format_json(deck))
    os.replace(tmp, path)
