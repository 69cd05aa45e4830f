"""Where a table's numbers come from: inline arrays, a CSV file beside the model, gear geometry.

A table file is untrusted data named by an untrusted model file:

* **confined**: the path is relative to the model file's folder; it is resolved (every
  symbolic link followed) and must lie inside that folder, so neither ``../x.csv`` nor a
  link that leaves the folder is read; the resolved file is opened without following a link
  (``O_NOFOLLOW``) and without blocking, and must be a regular file;
* **size-limited**: at most :data:`MAX_TABLE_BYTES`, checked with ``fstat`` on the open file
  before anything is read (a 1 GB file is refused at once);
* **parsed strictly**: UTF-8 (a byte-order mark is allowed), the :mod:`csv` module's
  ``strict`` dialect, one header row, every other row as many cells as the header, every
  cell a decimal number (``1.5``, ``-2e-3``; no ``nan``, ``inf``, hex, ``1_000`` or empty
  cells), finite.  Every problem names the file, the row (the line of the file) and the
  column.

Layouts (the unit of every number is the table's ``domain`` / ``unit``):

* one axis: a header row, then one row per knot: ``domain, value`` (the value column may be
  chosen by its header with ``column = "..."``; the domain is the first column);
* two axes: a header row whose first cell is a label and whose other cells are the knots of
  the second axis (``phase, 100, 200, 340``), then one row per knot of the first axis: the
  knot, then the value at each knot of the second axis.
"""

from __future__ import annotations

import codecs
import csv
import io
import math
import os
import re
import stat
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import SpecError

#: Largest table file (bytes).
MAX_TABLE_BYTES = 4_000_000

_NUMBER = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?")


@dataclass
class Grid:
    """The numbers of a table before units and checks: knots and values, with their places.

    ``values[i][j]`` is the value at ``x[i]`` (and ``y[j]``); ``place(i, j)`` says where a
    number is for messages (``j = -1``: the knot ``x[i]``; ``i = -1``: the knot ``y[j]``).
    """

    x: list[float]
    y: list[float] | None
    values: list[list[float]]
    file: str
    place: Any = field(repr=False)


class Located:
    """Errors naming the file and the table (:class:`~gearsym.errors.SpecError`)."""

    def __init__(self, file: str, table: str):
        self.file = file
        self.table = table

    def error(self, message: str) -> SpecError:
        return SpecError(message, file=self.file, field=f"tables.{self.table}")


# ------------------------------------------------------------------------------- the file


def resolve_table_file(model_path: str, text: Any, table: str) -> Path:
    """The table file ``text`` names, confined to the model file's folder.

    Raises
    ------
    SpecError
        Naming the model file and ``tables.NAME.file``: not a relative path, not found, outside
        the model's folder (also through a symbolic link).
    """
    where = f"tables.{table}.file"

    def fail(msg: str) -> SpecError:
        return SpecError(msg, file=model_path, field=where)

    if not isinstance(text, str) or not text.strip():
        raise fail("must be the path of a CSV file, relative to the model file's folder")
    if "\x00" in text or len(text) > 1024:
        raise fail("not a usable path")
    rel = Path(text)
    if rel.is_absolute():
        raise fail(f"'{text}' is an absolute path: a table file is named relative to the model file's folder")
    mp = Path(model_path)
    if not mp.is_file():
        raise fail("a table file is read from beside the model file: this model has no file")
    base = mp.resolve().parent
    try:
        real = (base / rel).resolve(strict=True)
    except FileNotFoundError:
        raise fail(f"table file '{text}' not found (relative to {base})") from None
    except (OSError, RuntimeError) as exc:  # a loop of links
        raise fail(f"cannot resolve '{text}': {exc}") from None
    if not real.is_relative_to(base):
        raise fail(f"'{text}' is outside the model file's folder {base} (after following links): a table "
                   f"file must lie in the model's folder or below it")
    return real


def read_table_text(path: Path, shown: str) -> str:
    """The text of a table file: a regular file of at most :data:`MAX_TABLE_BYTES`, UTF-8.

    Raises
    ------
    SpecError
        Naming the file.
    """
    flags = os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_CLOEXEC", 0) | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags)
    except OSError as exc:
        raise SpecError(f"cannot read the table file: {exc.strerror}", file=shown) from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise SpecError("a table file must be a regular file (not a folder, device, FIFO or socket)", file=shown)
        if st.st_size > MAX_TABLE_BYTES:
            raise SpecError(f"table file too large ({st.st_size} bytes, limit {MAX_TABLE_BYTES})", file=shown)
        chunks, size = [], 0
        while size <= MAX_TABLE_BYTES:
            chunk = os.read(fd, MAX_TABLE_BYTES + 1 - size)
            if not chunk:
                break
            chunks.append(chunk)
            size += len(chunk)
        if size > MAX_TABLE_BYTES:
            raise SpecError(f"table file too large (more than {MAX_TABLE_BYTES} bytes)", file=shown)
    except OSError as exc:
        raise SpecError(f"cannot read the table file: {exc.strerror}", file=shown) from None
    finally:
        os.close(fd)
    data = b"".join(chunks)
    try:
        return codecs.decode(data, "utf-8-sig")
    except UnicodeDecodeError as exc:
        raise SpecError(f"not a text (UTF-8) file (byte {exc.start})", file=shown) from None


def strict_number(cell: str) -> float | str:
    """The number a CSV cell holds, or the problem (a string)."""
    text = cell.strip()
    if not text:
        return "empty cell"
    shown = text if len(text) <= 40 else text[:37] + "..."
    if not _NUMBER.fullmatch(text):
        return f"'{shown}' is not a number (a decimal number such as 1.5 or -2e-3)"
    v = float(text)
    if not math.isfinite(v):
        return f"'{shown}' is not a finite number"
    return v


def _csv_rows(text: str, shown: str, table: str) -> list[tuple[int, list[str]]]:
    """``(line, cells)`` of every row; blank rows only at the end."""
    rows: list[tuple[int, list[str]]] = []
    reader = csv.reader(io.StringIO(text, newline=""), strict=True)
    try:
        for cells in reader:
            rows.append((reader.line_num, cells))
    except csv.Error as exc:
        raise SpecError(f"row {reader.line_num + 1}: {exc} (table '{table}')", file=shown,
                        field=f"tables.{table}") from None
    while rows and not any(c.strip() for c in rows[-1][1]):
        rows.pop()
    for line, cells in rows:
        if not any(c.strip() for c in cells):
            raise SpecError(f"row {line} is empty (table '{table}')", file=shown, field=f"tables.{table}")
    return rows


def read_csv_grid(path: Path, shown: str, table: str, axes: int, column: str | None) -> Grid:
    """The numbers of a CSV table file (see the module docstring for the layouts).

    Raises
    ------
    SpecError
        Naming the file, the row and the column: ragged rows, non-numeric or empty cells,
        a missing header, too few columns.
    """
    rows = _csv_rows(read_table_text(path, shown), shown, table)
    loc = Located(shown, table)
    if len(rows) < 2:
        raise loc.error("a table file needs a header row and at least one row of numbers")
    hline, header = rows[0]
    names = [h.strip() for h in header]

    def place(line: int, col: int) -> str:
        label = names[col] if col < len(names) and names[col] else ""
        return f"row {line}, column {col + 1}" + (f" ('{label[:30]}')" if label else "")

    width = len(header)
    if axes == 1:
        if column is None:
            if width != 2:
                raise loc.error(f"row {hline}: a one-axis table file has two columns (domain, value), this header "
                                f"has {width}; name the value column with column = \"...\"")
            vcol = 1
        else:
            if column not in names[1:]:
                raise loc.error(f"row {hline}: no column '{column}' in the header (columns: {', '.join(names)})")
            vcol = names.index(column, 1)
    elif width < 3:
        raise loc.error(f"row {hline}: a two-axis table file has a header row 'label, y_1, y_2, ...' with at "
                        f"least two knots of the second axis, this one has {width} cells")
    y: list[float] | None = None
    if axes == 2:
        y = [_cell(loc, names[c], place(hline, c)) for c in range(1, width)]
    x: list[float] = []
    values: list[list[float]] = []
    lines: list[int] = []
    for line, cells in rows[1:]:
        if len(cells) != width:
            raise loc.error(f"row {line} has {len(cells)} cells, the header (row {hline}) has {width}")
        x.append(_cell(loc, cells[0], place(line, 0)))
        if axes == 1:
            values.append([_cell(loc, cells[vcol], place(line, vcol))])
        else:
            values.append([_cell(loc, cells[c], place(line, c)) for c in range(1, width)])
        lines.append(line)

    def where(i: int, j: int) -> str:
        if i < 0:
            return place(hline, j + 1)
        return place(lines[i], 0 if j < 0 else (vcol if axes == 1 else j + 1))

    return Grid(x, y, values, shown, where)


def _cell(loc: Located, cell: str, place: str) -> float:
    v = strict_number(cell)
    if isinstance(v, str):
        raise loc.error(f"{place}: {v}")
    return v


# ------------------------------------------------------------------------------- inline


def inline_grid(model_path: str, table: str, tbl: dict[str, Any], axes: int) -> Grid:
    """The numbers of a table written in the model file: ``x``, ``y`` (two axes), ``values``.

    Raises
    ------
    SpecError
        Naming the model file and the field (``tables.NAME.values[3][1]``).
    """
    base = f"tables.{table}"

    def fail(fld: str, msg: str) -> SpecError:
        return SpecError(msg, file=model_path, field=f"{base}.{fld}")

    def numbers(key: str, value: Any) -> list[float]:
        if not isinstance(value, list) or not value:
            raise fail(key, "must be a non-empty array of numbers")
        return [_number(fail, f"{key}[{i}]", v) for i, v in enumerate(value)]

    if "x" not in tbl:
        raise fail("x", "missing: the knots of the first axis (or give file = \"...\")")
    if "values" not in tbl:
        raise fail("values", "missing: the values at the knots")
    x = numbers("x", tbl["x"])
    y = None
    rows = tbl["values"]
    if not isinstance(rows, list) or len(rows) != len(x):
        raise fail("values", f"needs one entry per knot of x ({len(x)}), got "
                             f"{len(rows) if isinstance(rows, list) else type(rows).__name__}")
    if axes == 1:
        if "y" in tbl:
            raise fail("y", "a table with one axis in its domain has no y")
        values = [[_number(fail, f"values[{i}]", v)] for i, v in enumerate(rows)]
    else:
        if "y" not in tbl:
            raise fail("y", "missing: the knots of the second axis")
        y = numbers("y", tbl["y"])
        values = []
        for i, row in enumerate(rows):
            if not isinstance(row, list) or len(row) != len(y):
                raise fail(f"values[{i}]", f"row {i + 1} needs one value per knot of y ({len(y)}), got "
                                           f"{len(row) if isinstance(row, list) else type(row).__name__}")
            values.append([_number(fail, f"values[{i}][{j}]", v) for j, v in enumerate(row)])

    def where(i: int, j: int) -> str:
        if i < 0:
            return f"y[{j}] (column {j + 1})"
        if j < 0:
            return f"x[{i}] (row {i + 1})"
        return f"values[{i}]" + (f"[{j}]" if axes == 2 else "") + f" (row {i + 1}, column {j + 1})"

    return Grid(x, y, values, model_path, where)


def _number(fail, fld: str, v: Any) -> float:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise fail(fld, f"wrong type: expected a number, got {type(v).__name__} {str(v)[:40]!r}")
    v = float(v)
    if not math.isfinite(v):
        raise fail(fld, f"non-finite value {v}")
    return v
