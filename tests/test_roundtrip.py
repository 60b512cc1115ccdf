"""DSL -> JSON -> DSL -> JSON, ``racc fmt`` idempotence and comments, JSON strictness."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from ram_strategies import commented_models, models

from rac.errors import RacError
from rac.fmt import format_model
from rac.interchange import dumps, model_to_json, parse_json
from rac.ir import Model
from rac.load.files import load_model
from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.targets import EmitOptions, targets

ROOT = Path(__file__).resolve().parent.parent
MODELS = sorted((ROOT / "models").glob("*.ram"))
TEDUSAR = ROOT / "models" / "tedusar.ram"
SETTINGS = settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def comments_of(text: str) -> list[str]:
    """The text of every ``#`` comment (``#`` appears nowhere else in the language)."""
    return [c[1:].strip() for c in re.findall(r"#[^\n]*", text)]


def round_trip(model: Model) -> None:
    doc = model_to_json(model)
    from_json = parse_json(json.dumps(doc), "m.json")
    assert from_json == model
    text = format_model(from_json)
    again = parse_ram(text, "m.ram")
    assert again == model
    assert model_to_json(again) == doc
    assert dumps(parse_json(dumps(again))) == dumps(model)


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_example_round_trip(path: Path) -> None:
    model = load_model(path)
    round_trip(model)
    assert model_to_json(model)["name"] == path.stem


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_json_export_compiles_to_the_same_files(path: Path, tmp_path: Path) -> None:
    """Contract §1: the .ram and its ram/1 export are the same model, down to every byte."""
    json_path = tmp_path / f"{path.stem}.json"
    json_path.write_text(dumps(load_model(path)), encoding="utf-8")
    from_ram = compile_model(load_model(path))
    from_json = compile_model(load_model(json_path))
    for target in targets():
        assert target.emit(from_json, EmitOptions()) == target.emit(from_ram, EmitOptions()), (
            target.filename
        )


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_fmt_is_idempotent_and_keeps_comments(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    once = format_model(parse_ram(text, str(path)))
    assert format_model(parse_ram(once, str(path))) == once
    assert sorted(comments_of(once)) == sorted(comments_of(text))
    assert parse_ram(once) == parse_ram(text)


def test_fmt_keeps_comments_in_place() -> None:
    text = (
        "# head\nrobot r  # robot\n# hw\nhardware imu # fixed\n"
        "topic /x\n# node\nnode n drives imu {\n  # inside\n  publishes /x\n}\n# tail\n"
    )
    out = format_model(parse_ram(text))
    assert sorted(comments_of(out)) == sorted(comments_of(text))
    lines = out.splitlines()
    assert lines.index("# head") < lines.index("robot r")
    assert lines.index("# hw") < lines.index("hardware imu")
    assert lines.index("# node") < lines.index("node n drives imu {")
    assert lines.index("node n drives imu {") < lines.index("  # inside") < lines.index("}")
    assert lines[-1] == "# tail"
    assert format_model(parse_ram(out)) == out


@pytest.mark.slow
@SETTINGS
@given(models())
def test_random_round_trip(model: Model) -> None:
    round_trip(model)


@pytest.mark.slow
@SETTINGS
@given(commented_models())
def test_random_fmt_idempotent_and_keeps_comments(model: Model) -> None:
    text = format_model(model)
    parsed = parse_ram(text, "m.ram")
    assert parsed == model
    again = format_model(parsed)
    assert again == text
    expected = [
        *model.comments,
        *(c for h in model.hardware for c in h.comments),
        *(c for t in model.topics for c in t.comments),
        *(c for n in model.nodes for c in (*n.comments, *n.inner_comments)),
        *(c for r in model.related for c in r.comments),
        *model.trailing_comments,
    ]
    assert sorted(comments_of(again)) == sorted(c.strip() for c in expected)


# --- ram/1 is strict: unknown keys are errors (contract §1) ---------------------------------


def _tedusar_doc() -> dict[str, Any]:
    doc: dict[str, Any] = model_to_json(load_model(TEDUSAR))
    return doc


UNKNOWN_KEY_AT = {
    "document": lambda d: d,
    "hardware[0]": lambda d: d["hardware"][0],
    "topics[2]": lambda d: d["topics"][2],
    "nodes[1]": lambda d: d["nodes"][1],
    "nodes[0].publishes[0]": lambda d: d["nodes"][0]["publishes"][0],
    "nodes[0].limits": lambda d: d["nodes"][0]["limits"],
    "intervals[0]": lambda d: d["intervals"][0],
}


@pytest.mark.parametrize("where", UNKNOWN_KEY_AT)
def test_json_unknown_key_is_an_error(where: str) -> None:
    doc = copy.deepcopy(_tedusar_doc())
    UNKNOWN_KEY_AT[where](doc)["colour"] = "red"
    with pytest.raises(RacError) as info:
        parse_json(json.dumps(doc), "t.json")
    (diag,) = info.value.diagnostics
    assert diag.code == "RAC005"
    assert where in diag.message and "colour" in diag.message


@pytest.mark.parametrize(
    ("change", "words"),
    [
        (lambda d: d.pop("name"), "missing key 'name'"),
        (lambda d: d.update(format="ram/2"), "ram/1"),
        (lambda d: d["hardware"][0].update(switchable="yes"), "true or false"),
        (lambda d: d["topics"][0].update(rate_hz="fast"), "a number"),
        (lambda d: d["nodes"][0].update(subscribes="/cmd_vel"), "a list"),
        (lambda d: d["related"][0].pop(), "two field references"),
        (lambda d: d["related"][0].__setitem__(0, "I(/pose.yaw"), "I(TOPIC.FIELD)"),
        (lambda d: d["related"][0].__setitem__(0, "J(/pose.yaw)"), "I(TOPIC.FIELD)"),
        (lambda d: d["related"][0].__setitem__(0, "I(/pose)"), "I(TOPIC.FIELD)"),
    ],
)
def test_json_shape_errors(change: Any, words: str) -> None:
    doc = copy.deepcopy(_tedusar_doc())
    change(doc)
    with pytest.raises(RacError) as info:
        parse_json(json.dumps(doc), "t.json")
    assert all(d.code == "RAC005" for d in info.value.diagnostics)
    assert any(words in d.message for d in info.value.diagnostics), info.value.render()


def test_json_reports_every_problem_at_once() -> None:
    doc = copy.deepcopy(_tedusar_doc())
    doc["extra"] = 1
    doc["nodes"][0]["bogus"] = 2
    doc["topics"][0]["rate_hz"] = "x"
    with pytest.raises(RacError) as info:
        parse_json(json.dumps(doc), "t.json")
    assert len(info.value.diagnostics) == 3


def test_json_optional_keys_absent_or_empty_alike() -> None:
    """Contract §1: optional keys are absent or empty alike."""
    doc = {"format": "ram/1", "name": "r", "nodes": [{"name": "n"}]}
    full = {
        "format": "ram/1",
        "name": "r",
        "hardware": [],
        "topics": [],
        "nodes": [
            {
                "name": "n",
                "drives": [],
                "subscribes": [],
                "publishes": [],
                "limits": {},
                "diagnostics": [],
            }
        ],
        "related": [],
        "intervals": [],
    }
    assert parse_json(json.dumps(doc)) == parse_json(json.dumps(full))


def test_fmt_keeps_the_order_of_publications() -> None:
    text = "robot r\n\ntopic /a\ntopic /b\ntopic /c\n\nnode n {\n  subscribes /a\n"
    text += "  publishes /b from /a\n  publishes /c, /a\n}\n"
    model = parse_ram(text)
    assert [p.topic.value for p in model.nodes[0].publishes] == ["/b", "/c", "/a"]
    assert parse_ram(format_model(model)) == model
    assert format_model(model) == text


# --- the two parsers agree ---------------------------------------------------------------------
# parse_ram reads valid models with a hand-written fast path and falls back to Lark, the
# definition of the language; both must build the same IR, spans and comments included.


def _lark_and_fast(text: str) -> tuple[str, str | None]:
    from rac.fastparse import Bail, fast_parse
    from rac.parse import _attach_comments, _parse_with_lark

    lark = _attach_comments(*_parse_with_lark(text, "m.ram"))
    try:
        fast = _attach_comments(*fast_parse(text, "m.ram"))
    except Bail:
        return repr(lark), None
    return repr(lark), repr(fast)


@st.composite
def _respaced(draw: st.DrawFn) -> str:
    """A valid model's text with its line breaks and blanks shuffled (comments kept intact)."""
    model = draw(st.one_of(models(), commented_models()))
    out = []
    for line in format_model(model).split("\n"):
        if "#" not in line:
            line = line.replace(" ", draw(st.sampled_from([" ", "  ", "\t"])))
        out.append(line + draw(st.sampled_from(["\n", "\n\n", "\n  "])))
    text = "".join(out)
    if "#" not in text and draw(st.booleans()):
        text = text.replace("\n", " ")
    return text


@pytest.mark.slow
@SETTINGS
@given(_respaced())
def test_fast_parser_builds_what_lark_builds(text: str) -> None:
    lark, fast = _lark_and_fast(text)
    if fast is not None:
        assert fast == lark


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.stem)
def test_fast_parser_reads_the_examples(path: Path) -> None:
    lark, fast = _lark_and_fast(path.read_text(encoding="utf-8"))
    assert fast == lark


INTEGRATED = """robot r

topic /pose { yaw, twist.twist.angular.z } @ 10 Hz

node base {
  publishes /pose
}

relate I(/pose.twist.twist.angular.z) ~ /pose.yaw
"""


def test_integrated_side_in_json_and_fmt() -> None:
    model = parse_ram(INTEGRATED, "r.ram")
    doc = model_to_json(model)
    assert doc["related"] == [["I(/pose.twist.twist.angular.z)", "/pose.yaw"]]
    (rel,) = parse_json(json.dumps(doc)).related
    assert rel.a.integrated and not rel.b.integrated
    assert rel.a.path == "/pose.twist.twist.angular.z"
    round_trip(model)
    assert format_model(model) == INTEGRATED
    integral = "I(/pose.twist.twist.angular.z)"
    spaced = INTEGRATED.replace(integral, "I( /pose.twist.twist.angular.z )")
    assert format_model(parse_ram(spaced)) == INTEGRATED
