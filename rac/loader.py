"""Read a model file: ``.ram`` (the DSL) or ``.json`` (the ``ram/1`` interchange)."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import yaml

from rac.errors import Diagnostic, RacError
from rac.logic import parse_atom

if TYPE_CHECKING:  # the parsers and passes load on first use: `racc diagnose x.yaml` needs none
    from rac.ir import Model
    from rac.passes.observers import ObserverSpec, ParamValue


def read_text(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RacError([Diagnostic("RAC004", f"{path}: no such file")]) from None
    except IsADirectoryError:
        raise RacError([Diagnostic("RAC004", f"{path}: is a directory, not a file")]) from None
    except (OSError, UnicodeDecodeError) as err:
        raise RacError([Diagnostic("RAC004", f"{path}: cannot read: {err}")]) from None


def load_model(path: str | Path) -> Model:
    """Parse (not validate) a model; the suffix picks the format."""
    from rac.interchange import parse_json
    from rac.parse import parse_ram

    if str(path).endswith((".yaml", ".yml")):
        # A model server file holds clauses only: without this, the .ram parser's
        # "unexpected 'ab'; expected 'robot'" would be all the user learns.
        raise RacError(
            [
                Diagnostic(
                    "RAC060",
                    f"{path}: a model server file (model.yaml) has only clauses, and this "
                    "command needs the architecture: give a .ram or a ram/1 .json model",
                    hint="diagnose, repair, scenario, simulate and analyze take a model.yaml",
                )
            ]
        )
    text = read_text(path)
    if str(path).endswith(".json"):
        return parse_json(text, str(path))
    return parse_ram(text, str(path))


def load_observers(path: str | Path) -> tuple[str, tuple[ObserverSpec, ...]]:
    """``observers.yaml`` (what ``racc compile`` writes): the robot's name and its observers.

    RAC056 when the file is not of that shape; an observer's parameters are checked later,
    when the observer core builds it (RAC050/RAC051).
    """
    text = read_text(path)

    def bad(why: str) -> RacError:
        hint = "give the observers.yaml that 'racc compile' wrote"
        return RacError([Diagnostic("RAC056", f"{path}: {why}", hint=hint)])

    try:
        data = yaml.safe_load(text)
    except yaml.YAMLError as err:
        raise bad(f"not YAML: {err}") from None
    if not isinstance(data, dict) or not isinstance(data.get("observers"), list):
        raise bad("expected a mapping with a list 'observers'")
    from rac.passes.observers import ObserverSpec

    specs: list[ObserverSpec] = []
    for i, entry in enumerate(data["observers"], 1):
        if not isinstance(entry, dict):
            raise bad(f"observer {i} is not a mapping")
        kind, name = entry.get("kind"), entry.get("name")
        params, reports = entry.get("params") or {}, entry.get("reports") or []
        if not isinstance(kind, str) or not isinstance(name, str):
            raise bad(f"observer {i} needs a 'kind' and a 'name'")
        if not isinstance(params, dict) or not isinstance(reports, list):
            raise bad(f"observer '{name}': 'params' must be a mapping, 'reports' a list")
        values: list[tuple[str, ParamValue]] = []
        for key, value in params.items():
            # Booleans are ints in Python: integral1/integral2 of a BiQObs are true/false.
            if not isinstance(value, str | int | float):
                raise bad(
                    f"observer '{name}': parameter '{key}' is not a number, a boolean or a string"
                )
            values.append((str(key), value))
        try:
            atoms = tuple(parse_atom(str(a)) for a in reports)
        except ValueError as err:
            raise bad(f"observer '{name}': {err}") from None
        specs.append(ObserverSpec(kind, name, tuple(values), atoms))
    return str(data.get("robot") or Path(path).resolve().parent.name), tuple(specs)
