"""Property observations (Definition 9.4) from a CSV of ``time,node,cpu,mem`` samples,
and the limits they give (Algorithm 15, lines 11-14)."""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from rac.errors import Diagnostic, RacError

COLUMNS = ("time", "node", "cpu", "mem")


@dataclass(frozen=True, slots=True)
class PropertyStats:
    node: str
    prop: str  # cpu or mem
    samples: int
    mean: float
    stddev: float
    maximum: float

    def limit(self, sigmas: float) -> float:
        """mean + k·σ, never below the largest sample of the fault-free run."""
        return max(self.mean + sigmas * self.stddev, self.maximum)


def properties_error(path: str) -> Callable[[int, str], RacError]:
    """RAC082 at a line of the properties CSV ``path`` (learn and replay read it alike)."""

    def bad(line: int, why: str) -> RacError:
        hint = f"the file needs the header {','.join(COLUMNS)} and one sample per line"
        return RacError([Diagnostic("RAC082", f"{path}:{line}: {why}", hint=hint)])

    return bad


def csv_rows(text: str, bad: Callable[[int, str], RacError]) -> Iterator[tuple[int, list[str]]]:
    """The rows of a CSV text with the line each starts on.

    Lines end in LF, CR LF or a lone CR alike (universal newlines, as Python reads a text
    file): csv took a CR-only file for one line holding stray newlines.  What csv cannot
    read (a field beyond its size limit, a quote left open) is ``bad`` at its line.
    """
    reader = csv.reader(io.StringIO(text, newline=None))
    start = 1
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as err:
            raise bad(max(reader.line_num, 1), f"not CSV: {err}") from None
        yield start, row
        start = reader.line_num + 1


Sample = tuple[float, str, float | None, float | None]  # time, node, cpu, mem


def property_rows(text: str, path: str) -> list[Sample]:
    """The ``time,node,cpu,mem`` rows of a properties CSV in file order, checked (RAC082 at
    the line): learn and replay read the file through this one reader.  An empty cpu or mem
    cell is a missing sample (None); blank lines are skipped."""
    bad = properties_error(path)
    rows = csv_rows(text, bad)
    header = next(rows, (1, None))[1]
    if header is None or [h.strip() for h in header] != list(COLUMNS):
        raise bad(1, f"expected the header '{','.join(COLUMNS)}'")
    samples: list[Sample] = []
    for line, row in rows:
        if not row or all(not cell.strip() for cell in row):
            continue
        if len(row) != len(COLUMNS):
            raise bad(line, f"expected {len(COLUMNS)} columns, found {len(row)}")
        node = row[1].strip().removeprefix("/")
        if not node:
            raise bad(line, "empty node name")
        t = _number(row[0], "time", line, bad)
        if t is None:
            raise bad(line, "empty time")
        samples.append(
            (t, node, _number(row[2], "cpu", line, bad), _number(row[3], "mem", line, bad))
        )
    return samples


def _number(cell: str, what: str, line: int, bad: Callable[[int, str], RacError]) -> float | None:
    if not cell.strip():
        return None
    try:
        value = float(cell)
    except ValueError:
        value = math.nan
    if not math.isfinite(value) or value < 0:
        raise bad(line, f"{what} must be a finite number >= 0, not '{cell.strip()}'")
    return value


def parse_properties(text: str, path: str) -> dict[str, dict[str, list[float]]]:
    """node -> property -> samples, in file order; empty cells are missing samples."""
    samples: dict[str, dict[str, list[float]]] = {}
    for _, node, cpu, mem in property_rows(text, path):
        per_node = samples.setdefault(node, {"cpu": [], "mem": []})
        if cpu is not None:
            per_node["cpu"].append(cpu)
        if mem is not None:
            per_node["mem"].append(mem)
    return samples


def property_stats(samples: dict[str, dict[str, list[float]]]) -> list[PropertyStats]:
    out = []
    for node in sorted(samples):
        for prop in ("cpu", "mem"):
            values = np.asarray(samples[node][prop], dtype=np.float64)
            if values.size == 0:
                continue
            out.append(
                PropertyStats(
                    node,
                    prop,
                    int(values.size),
                    float(values.mean()),
                    float(values.std()),
                    float(values.max()),
                )
            )
    return out
