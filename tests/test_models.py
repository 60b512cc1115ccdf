"""The bundled example robots stay clean: no warnings, canonical formatting."""

from __future__ import annotations

from pathlib import Path

import pytest

from rac.cli import main
from rac.fmt import format_model
from rac.load.files import load_model
from rac.pipeline import compile_model

MODELS = sorted(Path(__file__).resolve().parent.parent.joinpath("models").glob("*.ram"))


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_example_model_compiles_without_warnings(path: Path) -> None:
    compiled = compile_model(load_model(path))
    assert compiled.warnings == ()


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_example_model_is_in_canonical_form(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    assert format_model(load_model(path)) == text


def test_output_path_that_is_a_file_is_an_input_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    target = tmp_path / "out"
    target.write_text("keep me", encoding="utf-8")
    assert main(["compile", str(MODELS[0]), "-o", str(target), "-q"]) == 1
    assert "exists and is not a directory" in capsys.readouterr().err
    assert target.read_text(encoding="utf-8") == "keep me"
