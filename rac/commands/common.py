"""Helpers the commands share: help formatting, model loading, atomic writes."""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from rac.errors import Diagnostic, RacError
from rac.ir import Model
from rac.loader import load_model
from rac.pipeline import Compiled, compile_model


def add_command(
    sub: Any, name: str, summary: str, description: str, examples: str
) -> argparse.ArgumentParser:
    """A subcommand parser whose help ends with worked examples."""
    parser: argparse.ArgumentParser = sub.add_parser(
        name,
        help=summary,
        description=description,
        epilog="examples:\n" + examples,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    return parser


def print_warnings(diagnostics: tuple[Diagnostic, ...], source: str | None) -> None:
    """The warnings, capped like errors (:meth:`RacError.render`)."""
    warnings = [d for d in diagnostics if not d.is_error]
    if warnings:
        print(RacError(warnings, source).render(), file=sys.stderr)


def load_and_compile(path: str, *, quiet: bool = False) -> Compiled:
    """Load a .ram/.json model, validate and derive; warnings go to stderr."""
    model = load_model(path)
    compiled = compile_model(model)
    if not quiet:
        print_warnings(compiled.warnings, model.source)
    return compiled


def load_checked(path: str) -> Model:
    return load_and_compile(path, quiet=True).model


def write_files_atomically(directory: Path, files: Mapping[str, str | bytes]) -> None:
    """Write every file into a temp dir beside ``directory``, then move each in place.

    Either all files land or none does: nothing half-written is left behind.
    """
    directory = directory.resolve()
    if directory.exists() and not directory.is_dir():
        message = f"{directory}: exists and is not a directory; choose another output directory"
        raise RacError([Diagnostic("RAC004", message)])
    try:
        directory.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory(prefix=".racc-", dir=directory.parent) as tmp:
            for name, content in files.items():
                data = content.encode("utf-8") if isinstance(content, str) else content
                (Path(tmp) / name).write_bytes(data)
            directory.mkdir(parents=True, exist_ok=True)
            for name in files:
                os.replace(Path(tmp) / name, directory / name)
    except OSError as err:
        raise RacError([Diagnostic("RAC004", f"{directory}: cannot write: {err}")]) from None


def write_file_atomically(path: Path, content: str) -> None:
    """Replace one file atomically (a temp file beside it, then a rename)."""
    path = path.resolve()
    tmp: str | None = None
    try:
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", dir=path.parent)
        with os.fdopen(fd, "w", encoding="utf-8", newline="") as handle:
            handle.write(content)
        os.replace(tmp, path)
    except OSError as err:
        if tmp is not None and os.path.exists(tmp):
            os.unlink(tmp)  # nothing half-written is left behind
        raise RacError([Diagnostic("RAC004", f"{path}: cannot write: {err}")]) from None
