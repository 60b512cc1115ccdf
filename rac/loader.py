"""Read a model file: ``.ram`` (the DSL) or ``.json`` (the ``ram/1`` interchange)."""

from __future__ import annotations

from pathlib import Path

from rac.errors import Diagnostic, RacError
from rac.interchange import parse_json
from rac.ir import Model
from rac.parse import parse_ram


def read_text(path: str | Path) -> str:
    try:
        return Path(path).read_text(encoding="utf-8")
    except FileNotFoundError:
        raise RacError([Diagnostic("RAC004", f"{path}: no such file")]) from None
    except IsADirectoryError:
        raise RacError(
            [Diagnostic("RAC004", f"{path}: is a directory, not a model file")]
        ) from None
    except (OSError, UnicodeDecodeError) as err:
        raise RacError([Diagnostic("RAC004", f"{path}: cannot read: {err}")]) from None


def load_model(path: str | Path) -> Model:
    """Parse (not validate) a model; the suffix picks the format."""
    text = read_text(path)
    if str(path).endswith(".json"):
        return parse_json(text, str(path))
    return parse_ram(text, str(path))
