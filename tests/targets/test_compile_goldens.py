"""Goldens of every target for every example model (``models/*.ram``).

``pytest --update-goldens`` rewrites ``tests/golden/<model>/<file>``; review the diff.
"""

from __future__ import annotations

import functools
from pathlib import Path

import pytest
from goldens import UPDATE_HINT, assert_golden

from rac.commands.reports import compile_undetected
from rac.load.files import load_model
from rac.pipeline import compile_model
from rac.targets import EmitOptions, targets

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "models").glob("*.ram"))
GOLDEN_DIR = Path(__file__).resolve().parents[1] / "golden"
TARGET_FILES = tuple(t.filename for t in targets())
CONTRACT_FILES = {
    "model.yaml",
    "observers.yaml",
    "observers.launch",
    "observers.launch.xml",
    "repair_domain.pddl",
    "architecture.dot",
}


@functools.cache
def emitted(model_path: Path) -> dict[str, str]:
    compiled = compile_model(load_model(model_path))
    # What racc compile passes: the faults no observer detects, marked on architecture.dot.
    options = EmitOptions(undetected=compile_undetected(compiled, quiet=True))
    return {t.filename: t.emit(compiled, options) for t in targets()}


def test_there_are_example_models() -> None:
    assert any(p.stem == "tedusar" for p in MODELS), "models/tedusar.ram is missing"


def test_targets_are_the_contract_files() -> None:
    assert set(TARGET_FILES) == CONTRACT_FILES
    assert len(TARGET_FILES) == len(CONTRACT_FILES)


@pytest.mark.parametrize("filename", TARGET_FILES)
@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_golden(model: Path, filename: str, update_goldens: bool) -> None:
    assert_golden(GOLDEN_DIR / model.stem / filename, emitted(model)[filename], update_goldens)


def test_no_stale_goldens() -> None:
    """No target golden is left over from a model that is gone (other goldens may live here)."""
    if not GOLDEN_DIR.exists():
        pytest.fail(f"{GOLDEN_DIR} is missing: {UPDATE_HINT}", pytrace=False)
    models = {p.stem for p in MODELS}
    stale = [
        str(p.relative_to(GOLDEN_DIR))
        for p in sorted(GOLDEN_DIR.glob("*/*"))
        if p.name in TARGET_FILES and p.parent.name not in models
    ]
    assert not stale, f"target goldens of no model in models/ (delete them): {stale}"


def test_missing_golden_tells_how_to_fix(tmp_path: Path) -> None:
    missing = tmp_path / "nope" / "model.yaml"
    with pytest.raises(pytest.fail.Exception, match=r"pytest --update-goldens"):
        assert_golden(missing, "text\n", update=False)
    assert not missing.exists()


def test_changed_golden_fails_with_a_diff(tmp_path: Path) -> None:
    path = tmp_path / "g.txt"
    path.write_text("one\ntwo\n", encoding="utf-8")
    with pytest.raises(pytest.fail.Exception, match=r"(?s)update-goldens.*-two.*\+three"):
        assert_golden(path, "one\nthree\n", update=False)
    assert_golden(path, "one\ntwo\n", update=False)


def test_update_rewrites_golden(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "g.txt"
    assert_golden(path, "fresh\n", update=True)
    assert path.read_text(encoding="utf-8") == "fresh\n"
    assert_golden(path, "newer\n", update=True)
    assert path.read_text(encoding="utf-8") == "newer\n"
    assert_golden(path, "newer\n", update=False)
