"""Every structure error of a ``ram/1`` document is located: the span covers the bad value,
the unknown key, or the object that lacks a key (RAC005, and RAC007 for numbers).  So is
every semantic error (validation's, RAC010 and up), on a second read with spans."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rac.cli import main
from rac.errors import Diagnostic, RacError, Span
from rac.interchange import (
    JsonPath,
    _in_order,
    _Locator,
    _SpanLookup,
    _where,
    dumps,
    model_to_json,
    parse_json,
)
from rac.ir import Name, Node
from rac.load.files import load_model
from rac.pipeline import compile_model

TEDUSAR = Path(__file__).resolve().parent.parent / "models" / "tedusar.ram"


def _doc() -> dict[str, Any]:
    return model_to_json(load_model(TEDUSAR))


def _offset(lines: list[str], line: int, column: int) -> int:
    return sum(len(x) + 1 for x in lines[: line - 1]) + column - 1


def spanned(text: str, span: Span) -> str:
    """The source text a span covers (``text`` has ``\\n`` line ends)."""
    lines = text.split("\n")
    return text[
        _offset(lines, span.line, span.column) : _offset(lines, span.end_line, span.end_column)
    ]


def errors_of(text: str) -> tuple[Diagnostic, ...]:
    with pytest.raises(RacError) as info:
        parse_json(text, "t.json")
    for diag in info.value.diagnostics:
        assert diag.span is not None and diag.span.file == "t.json", diag
        assert not diag.message.startswith("t.json"), "the span names the file now"
    return info.value.diagnostics


# (change to the document, what the span covers, words of the message)
CHANGES: list[tuple[Callable[[dict[str, Any]], Any], str, str]] = [
    (lambda d: d["hardware"][0].update(switchable="yes"), '"yes"', "true or false"),
    (lambda d: d["topics"][1].update(rate_hz="fast"), '"fast"', "topics[1].rate_hz"),
    (lambda d: d["nodes"][2].update(subscribes="/cmd_vel"), '"/cmd_vel"', "a list"),
    (lambda d: d["nodes"][0]["drives"].append(7), "7", "drives[1]: expected a name"),
    (lambda d: d["nodes"][1]["limits"].update(cpu=[]), "[]", "limits.cpu"),
    (lambda d: d["related"][0].__setitem__(1, "nodot"), '"nodot"', "related[0][1]"),
    (lambda d: d["intervals"].append({"a": "/x.y", "b": 1, "max_diff": 0}), "1", "intervals"),
    (lambda d: d["topics"].append("/t"), '"/t"', "expected an object for topic"),
    (lambda d: d["topics"][0].update(rate_hz=1e300), "1e+300", "out of range"),
    (lambda d: d.update(format="ram/2"), '"ram/2"', "ram/1"),
]


@pytest.mark.parametrize(("change", "covered", "words"), CHANGES)
def test_a_bad_value_is_spanned(
    change: Callable[[dict[str, Any]], Any], covered: str, words: str
) -> None:
    doc = _doc()
    change(doc)
    text = json.dumps(doc, indent=2)
    (diag,) = errors_of(text)
    assert words in diag.message
    assert spanned(text, diag.span) == covered  # type: ignore[arg-type]


def test_an_unknown_key_is_spanned_with_a_hint() -> None:
    doc = _doc()
    doc["nodes"][6]["publishes"][1]["afected_by"] = []
    text = json.dumps(doc, indent=2)
    (diag,) = errors_of(text)
    assert diag.message == "nodes[6].publishes[1]: unknown key 'afected_by'"
    assert spanned(text, diag.span) == '"afected_by"'  # type: ignore[arg-type]
    assert diag.hint == "did you mean 'affected_by'?"


def test_a_missing_key_spans_the_object() -> None:
    doc = _doc()
    del doc["nodes"][3]["publishes"][0]["topic"]
    text = json.dumps(doc)  # one line: the span is exactly the object
    (diag,) = errors_of(text)
    assert diag.message == "nodes[3].publishes[0]: missing key 'topic'"
    assert spanned(text, diag.span) == json.dumps(doc["nodes"][3]["publishes"][0])  # type: ignore[arg-type]


def test_errors_come_in_file_order() -> None:
    doc = _doc()
    doc["zzz"] = 1  # the document's own keys are checked first, but this one is written last
    doc["nodes"][-1]["bogus"] = 2
    doc["topics"][0]["rate_hz"] = "x"
    doc["hardware"][-1]["name"] = 3
    diags = errors_of(json.dumps(doc, indent=1))
    assert [d.message.split(":")[0] for d in diags] == [
        f"hardware[{len(doc['hardware']) - 1}].name",
        "topics[0].rate_hz",
        f"nodes[{len(doc['nodes']) - 1}]",
        "document",
    ]
    places = [(d.span.line, d.span.column) for d in diags]  # type: ignore[union-attr]
    assert places == sorted(places)


def test_a_duplicated_key_is_an_error_at_the_key_the_decoder_kept() -> None:
    """The decoder keeps the last value: a second "nodes" list silently dropped the first."""
    text = '{"format": "ram/1", "name": "r",\n "nodes": [{"name": "n", "name": 5}]}'
    twice, typed = errors_of(text)
    assert twice.message == "nodes[0]: key 'name' given twice (only the last one would count)"
    assert (twice.span.line, twice.span.column) == (2, 26)  # type: ignore[union-attr]
    assert typed.message == "nodes[0].name: expected a string"
    assert (typed.span.line, typed.span.column) == (2, 34)  # type: ignore[union-attr]
    text = '{"format": "ram/1", "name": "r", "nodes": [{"name": "a"}], "nodes": []}'
    (diag,) = errors_of(text)
    assert diag.message == "document: key 'nodes' given twice (only the last one would count)"
    assert diag.span.column == text.rindex('"nodes"') + 1  # type: ignore[union-attr]


def test_repeated_keys_are_looked_for_only_when_the_colons_do_not_add_up(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A valid document is decoded once, without a Python call per object; a colon inside a
    string sends it to the exact read, which finds a repeated key beside it, or none."""
    import rac.interchange as interchange

    calls: list[int] = []
    exact = interchange._object

    def counting(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
        calls.append(len(pairs))
        return exact(pairs)

    monkeypatch.setattr(interchange, "_object", counting)
    parse_json(dumps(load_model(TEDUSAR)), "t.json")
    assert calls == []
    colon = '{"format": "ram/1", "name": "r", "topics": [{"name": "/a", "type": "x/Y:z"}]}'
    parse_json(colon, "t.json")  # valid, on the exact path
    assert calls
    both = colon.replace('"type"', '"name": "/b", "type"')
    (diag,) = errors_of(both)
    assert diag.message == "topics[0]: key 'name' given twice (only the last one would count)"


def test_columns_count_characters() -> None:
    text = '{"format": "ram/1", "name": "r", "topics": [{"name": "/é→", "rate_hz": "x"}]}'
    (diag,) = errors_of(text)
    assert spanned(text, diag.span) == '"x"'  # type: ignore[arg-type]


def test_crlf_and_tabs() -> None:
    text = '{\r\n\t"format": "ram/1",\r\n\t"name": 1\r\n}\r\n'
    (diag,) = errors_of(text)
    assert (diag.span.line, diag.span.column, diag.span.end_column) == (3, 10, 11)  # type: ignore[union-attr]
    assert "   3 | " in RacError([diag], text).render()


def test_a_valid_document_is_read_as_before() -> None:
    model = load_model(TEDUSAR)
    assert parse_json(dumps(model), "t.json") == model


def _paths(value: Any, path: tuple[str | int, ...] = ()) -> list[tuple[str | int, ...]]:
    found = [path]
    if isinstance(value, dict):
        for key, item in value.items():
            found += _paths(item, (*path, key))
    elif isinstance(value, list):
        for index, item in enumerate(value):
            found += _paths(item, (*path, index))
    return found


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats(allow_nan=False) | st.text(max_size=4),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=3), inner, max_size=3)
    ),
    max_leaves=12,
)


@settings(max_examples=150, deadline=None)
@given(JSON, st.sampled_from([None, 0, 1, 2]))
def test_the_locator_finds_every_value(doc: Any, indent: int | None) -> None:
    """Each path's span decodes back to the value at that path, whatever the layout."""
    text = json.dumps(doc, indent=indent, ensure_ascii=False)
    paths = _paths(doc)
    spans = _Locator(text, set(paths)).spans
    for path in paths:
        start, end, key_start, key_end = spans[path]
        value: Any = doc
        for step in path:
            value = value[step]
        assert json.loads(text[start:end]) == value, _where(path)
        if path and isinstance(path[-1], str):
            assert json.loads(text[key_start:key_end]) == path[-1]


@settings(max_examples=100, deadline=None)
@given(JSON, st.sampled_from([None, 0, 2]), st.booleans())
def test_the_full_locators_agree_with_the_targeted_one(
    doc: Any, indent: int | None, ascii_only: bool
) -> None:
    """Walking every value, or pairing the decoded document with the text's strings and
    brackets (what locating a semantic error uses), finds what the targeted walk finds."""
    text = json.dumps(doc, indent=indent, ensure_ascii=ascii_only)
    targeted = _Locator(text, set(_paths(doc))).spans
    assert _Locator(text, None).spans == targeted
    in_order = _in_order(text, json.loads(text))
    assert in_order is not None
    assert in_order == {
        p: (s[0], s[1])
        for p, s in targeted.items()
        if text[s[0]] in '"[{'  # numbers, true, false and null are not paired
    }


def test_a_duplicated_key_leaves_the_pairing_to_the_walk() -> None:
    text = '{"a": {"b": "x"}, "a": ["y"], "c": "z"}'
    assert _in_order(text, json.loads(text)) is None
    spans = _SpanLookup(text, json.loads(text), "t.json")
    assert spans.offsets[("a", 0)] == (text.index('"y"'), text.index('"y"') + 3)
    assert spans.offsets[("c",)] == (text.index('"z"'), text.index('"z"') + 3)


# Semantic errors (validation, RAC010 and up) of a model read from JSON.


def _semantic_errors(text: str) -> RacError:
    with pytest.raises(RacError) as info:
        compile_model(parse_json(text, "t.json"))
    return info.value


@pytest.mark.parametrize(
    ("change", "covered", "code"),
    [
        (lambda d: d["nodes"][2]["subscribes"].append("/cmd_vell"), '"/cmd_vell"', "RAC012"),
        (lambda d: d["nodes"][0]["drives"].append("jagaur"), '"jagaur"', "RAC011"),
        (lambda d: d["nodes"].append({"name": d["nodes"][1]["name"]}), None, "RAC010"),
        (lambda d: d["related"][0].__setitem__(1, "/pose.yw"), '"/pose.yw"', "RAC014"),
    ],
)
def test_a_semantic_error_is_spanned(
    change: Callable[[dict[str, Any]], Any], covered: str | None, code: str
) -> None:
    doc = _doc()
    change(doc)
    text = json.dumps(doc, indent=2)
    err = _semantic_errors(text)
    assert err.source == text
    (diag,) = [d for d in err.diagnostics if d.is_error]
    assert diag.code == code and diag.span is not None and diag.span.file == "t.json"
    expected = covered or json.dumps(doc["nodes"][1]["name"])
    assert spanned(text, diag.span) == expected
    assert f"{diag.span.line:>4} | " in err.render()
    assert all(d.span is not None for d in err.diagnostics)


def test_a_valid_json_model_takes_the_fast_path(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """No second, position-recording read for a valid model, nor for one whose warnings are
    not shown; a shown warning is located."""
    doc = _doc()
    doc["topics"].append({"name": "/unused"})  # RAC103, a warning
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc, indent=2))
    built: list[str] = []

    class Locator(_Locator):
        def __init__(self, text: str, wanted: set[JsonPath] | None) -> None:
            built.append("locator")
            super().__init__(text, wanted)

    class Lookup(_SpanLookup):
        def __init__(self, text: str, doc: Any, path: str) -> None:
            built.append("lookup")
            super().__init__(text, doc, path)

    monkeypatch.setattr("rac.interchange._Locator", Locator)
    monkeypatch.setattr("rac.interchange._SpanLookup", Lookup)
    compiled = compile_model(load_model(path))
    assert [d.code for d in compiled.warnings] == ["RAC103"]
    assert compiled.warnings[0].span is None
    assert main(["check", "--quiet", str(path)]) == 0
    assert built == []
    assert main(["check", str(path)]) == 0
    assert built == ["lookup"]
    assert f"{path}:" in capsys.readouterr().err


def test_a_model_derived_from_json_is_not_located_from_the_text() -> None:
    """The text no longer says what the model is: its diagnostics stay without spans rather
    than point at the wrong place."""
    model = parse_json(dumps(load_model(TEDUSAR)), "t.json")
    extra = Node(Name("extra"), subscribes=(Name("/nowhere"),))
    with pytest.raises(RacError) as info:
        compile_model(replace(model, nodes=(*model.nodes, extra)))
    assert [d.code for d in info.value.diagnostics if d.is_error] == ["RAC012"]
    assert all(d.span is None for d in info.value.diagnostics)


def test_warnings_of_a_large_json_model_are_shown_unlocated_but_errors_located(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Locating re-reads the whole text: for a warning of a large model that is not worth
    seconds of every compile; for an error it is."""
    monkeypatch.setattr("rac.pipeline.WARNINGS_LOCATED_UP_TO", 100)  # the file is larger
    doc = _doc()
    doc["topics"].append({"name": "/unused"})  # RAC103, a warning
    path = tmp_path / "m.json"
    path.write_text(json.dumps(doc, indent=2))
    assert main(["check", str(path)]) == 0
    err = capsys.readouterr().err
    assert "warning[RAC103]" in err and f"{path}:" not in err
    doc["nodes"].append({"name": "extra", "subscribes": ["/nowhere"]})  # RAC012, an error
    path.write_text(json.dumps(doc, indent=2))
    assert main(["check", str(path)]) == 1
    err = capsys.readouterr().err
    assert f"{path}:" in err and "error[RAC012]" in err
