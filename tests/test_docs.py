"""The docs stand alone: every code racc can emit is documented, no page cites a file
outside the repository, and the README's examples work as written."""

from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from rac.cli import main
from rac.errors import CODES

ROOT = Path(__file__).resolve().parent.parent
DOCS = sorted((ROOT / "docs").glob("*.md"))
_CODE = re.compile(r"RAC\d{3}")


def _emitted() -> set[str]:
    """Every RACnnn string in the package's source."""
    return {c for p in (ROOT / "rac").rglob("*.py") for c in _CODE.findall(p.read_text())}


def _in_tables() -> set[str]:
    """Codes in a row of a Markdown table of docs/ (the code tables)."""
    return {
        c
        for page in DOCS
        for line in page.read_text(encoding="utf-8").splitlines()
        if line.startswith("|")
        for c in _CODE.findall(line)
    }


def test_every_emitted_code_is_in_codes() -> None:
    missing = sorted(_emitted() - set(CODES))
    assert not missing, f"codes used in rac/ but not in rac.errors.CODES: {missing}"


def test_every_emitted_code_is_in_a_docs_code_table() -> None:
    missing = sorted(_emitted() - _in_tables())
    assert not missing, f"codes used in rac/ but in no table of docs/*.md: {missing}"


def test_no_page_cites_the_contract() -> None:
    pages = [*DOCS, ROOT / "README.md"]
    cited = [p.name for p in pages if re.search(r"contract §", p.read_text(encoding="utf-8"))]
    assert not cited, f"cite docs/spec.md instead of the contract: {cited}"
    sources = [
        str(p.relative_to(ROOT))
        for p in (ROOT / "rac").rglob("*.py")
        if "contract §" in p.read_text(encoding="utf-8")
    ]
    assert not sources, sources


def test_links_to_spec_sections_exist() -> None:
    spec = (ROOT / "docs" / "spec.md").read_text(encoding="utf-8")
    anchors = {
        re.sub(r"[^a-z0-9 -]", "", h.lower()).replace(" ", "-")
        for h in re.findall(r"^#+ (.+)$", spec, re.MULTILINE)
    }
    texts = [p.read_text(encoding="utf-8") for p in [*DOCS, ROOT / "README.md"]]
    texts += [p.read_text(encoding="utf-8") for p in (ROOT / "rac").rglob("*.py")]
    used = {a for t in texts for a in re.findall(r"spec\.md#([a-z0-9-]+)", t)}
    assert used and used <= anchors, sorted(used - anchors)


def _readme() -> str:
    return (ROOT / "README.md").read_text(encoding="utf-8")


def test_readme_sample_error_is_what_racc_prints(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    readme = _readme()
    model = re.search(r"```ram\n(.*?)```", readme, re.S)
    sample = re.search(r"```\n(robot\.ram:.*?)```", readme, re.S)
    assert model and sample
    bad = model.group(1).replace(
        "node jaguar_node drives jaguar {", "node jaguar_node drives jaguarr {"
    )
    (tmp_path / "robot.ram").write_text(bad, encoding="utf-8")
    monkeypatch.chdir(tmp_path)
    assert main(["check", "robot.ram"]) == 1
    assert sample.group(1) in capsys.readouterr().err


def test_readme_session_runs(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    block = re.search(r"A session with the example robot.*?```sh\n(.*?)```", _readme(), re.S)
    assert block
    lines = [line for line in block.group(1).splitlines() if line.startswith("racc ")]
    assert len(lines) >= 4
    monkeypatch.chdir(ROOT)
    for line in lines:
        assert main(shlex.split(line)[1:]) == 0, line
    capsys.readouterr()
