"""Every YAML reader reports a text that is not YAML alike: its own code, 'not valid YAML'
and the line and column where PyYAML found the problem (rac.limits.yaml_error_diagnostic)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import pytest

from rac.errors import RacError
from rac.learn.graph import parse_graph
from rac.load.costs import load_costs
from rac.load.files import load_observers
from rac.tug import import_tug

BROKEN = "nodes: [a, b\n  c: d\n"


def _tug(path: Path) -> object:
    return import_tug(path.read_text(), str(path), "robot")


def _graph(path: Path) -> object:
    return parse_graph(path.read_text(), str(path))


def _costs(path: Path) -> object:
    return load_costs(str(path))


def _observers(path: Path) -> object:
    return load_observers(path)


@pytest.mark.parametrize(
    ("read", "code"),
    [(_tug, "RAC064"), (_graph, "RAC081"), (_costs, "RAC062"), (_observers, "RAC056")],
)
def test_a_text_that_is_not_yaml_is_located(
    tmp_path: Path, read: Callable[[Path], object], code: str
) -> None:
    path = tmp_path / "broken.yaml"
    path.write_text(BROKEN)
    with pytest.raises(RacError) as err:
        read(path)
    (found,) = err.value.diagnostics
    assert found.code == code
    assert found.message.startswith("not valid YAML: ")
    assert found.span is not None
    assert (found.span.file, found.span.line, found.span.column) == (str(path), 2, 4)
