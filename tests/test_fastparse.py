"""The fast reader of rac.fastparse builds exactly what the Lark parser builds, or bails.

Differential tests: for every input the fast path accepts, the model (values, spans and
comments, compared through ``repr``) must equal Lark's; inputs it does not accept go to Lark,
so error messages never depend on it.
"""

from __future__ import annotations

import random
from pathlib import Path

import pytest
from hypothesis import given, settings
from ram_strategies import commented_models, models

from rac import parse
from rac.errors import RacError
from rac.fastparse import Bail, fast_parse
from rac.fmt import format_model
from rac.ir import Interval, Related

ROOT = Path(__file__).resolve().parent.parent
MODELS = sorted((ROOT / "models").glob("*.ram"))
# RAC004 files cannot be read (not UTF-8): no parser ever sees them.
ERRORS = sorted(p for p in (ROOT / "tests" / "errors").glob("*.ram") if p.name[:6] != "RAC004")

# Odd but valid layouts: semicolons, glued tokens, options in any order, comments anywhere.
ODD = """# head
robot r;
hardware a switchable channel 2 ; hardware b
topic /t : std_msgs/Float64 { x, y.z, } @ 1.5e1 Hz ± 2 Hz window 300 ms mismatch 3;
topic /u{}@.5Hz+-0.1Hz window 2s
topic /v:a/b # after
topic /w { p } @ 10 Hz
  window 2 s
node n drives a, b { subscribes /t, /u; publishes /v from /t, /u; publishes /w, /z
  limits cpu 5 %, mem 1.5 GiB; limits mem 3 kB reports a, dev-1 } ;
node m;node k {}
node j {
  # inside
  subscribes /t,
    /u
  publishes /q
    from /t
  limits cpu 5 %, mem 64 MB, cpu 7 %
}
relate /t.x ~ /v.y # c
interval /t.x~/t.y.z within 0.25;
# tail
"""
PIECES = [" ", "\n", ";", ",", "#c\n", "{", "}", "x", "/", "~", ".", "1", "Hz", "from", "+-"]
PIECES += ["±", "\t", "s", "ms", "%", "MB", "node", "topic", "  ", "@", ":", "0.5", "-", "\r\n"]
PIECES += ["I(", "(", ")", "I"]


def _lark(text: str) -> str:
    try:
        model, comments = parse._parse_with_lark(text, "f.ram")
    except RacError as err:
        return "error: " + err.render()
    return repr(parse._attach_comments(model, comments))


def _fast(text: str) -> str | None:
    try:
        model, comments = fast_parse(text, "f.ram")
    except Bail:
        return None
    return repr(parse._attach_comments(model, comments))


def _same_or_bail(text: str) -> bool:
    """True when the fast path read ``text``; fails when it read it differently."""
    fast = _fast(text)
    if fast is not None:
        assert fast == _lark(text), text
    return fast is not None


@pytest.mark.parametrize("path", MODELS, ids=lambda p: p.name)
def test_example_models_take_the_fast_path(path: Path) -> None:
    assert _same_or_bail(path.read_text(encoding="utf-8"))


def test_odd_layouts() -> None:
    assert _same_or_bail(ODD)  # lists and 'from' continued on the next line too
    flat = ODD.replace(",\n    /u", ", /u").replace("\n    from", " from")
    flat = flat.replace("\n  window 2 s", " window 2 s")
    assert _same_or_bail(flat)


@pytest.mark.parametrize("path", ERRORS, ids=lambda p: p.name)
def test_bad_models(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    if path.name[:6] in ("RAC001", "RAC002", "RAC003"):
        assert _fast(text) is None  # syntax errors are Lark's to report
    else:
        _same_or_bail(text)


@pytest.mark.slow
def test_mutants() -> None:
    rng = random.Random(2)
    texts = [ODD, *(p.read_text(encoding="utf-8") for p in MODELS)]
    read = 0
    for _ in range(1500):
        text = rng.choice(texts)
        for _ in range(rng.randint(1, 3)):
            pos = rng.randrange(len(text) + 1)
            if rng.random() < 0.5:
                text = text[:pos] + rng.choice(PIECES) + text[pos:]
            else:
                text = text[:pos] + text[pos + rng.randint(1, 4) :]
        read += _same_or_bail(text)
    assert read > 100  # the fast path is exercised, not only bailed from


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(models())
def test_formatted_random_models(model: object) -> None:
    _same_or_bail(format_model(model))  # type: ignore[arg-type]


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(commented_models())
def test_commented_random_models(model: object) -> None:
    _same_or_bail(format_model(model))  # type: ignore[arg-type]


def test_declarations_continued_on_the_next_line() -> None:
    # Read a line at a time at first, then again token by token once the next line goes on.
    text = "robot r\nhardware a\n  switchable\ntopic /t\n;\nnode n {\n  limits cpu 5 %\n  ;\n}\n;\n"
    text += "node m drives a {\n  publishes /t\n}\n  # c\n ;\nrelate /t.x ~ /u.y\n# c\n;\n"
    text += "interval /t.x ~ /u.y within 2\n;\n"
    assert _same_or_bail(text)


# Integrated sides, I(...): one-line, spread over lines, with comments inside, glued, and
# the near misses Lark rejects (which the fast path must leave to it).
INTEGRALS = [
    "relate I(/a.b.c) ~ /d.e\n",
    "relate /d.e ~ I(/a.b.c);# c\n",
    "relate I(/a.b)~I(/d.e)\n",
    "relate I.x ~ I(/a.b)\n",  # a topic named I
    "relate I ( /a.b ) ~ /c.d\n",
    "relate I( # c\n /a.b\n) ~ /c.d\n",
    "relate I(/a.b)\n ~ /c.d\n",
    "relate I(/a.b) ~ /c.d\n;\n",
    "interval I(/a.b) ~ /c.d within 1\n",
    "interval /c.d ~ I(/a.b) within 1;\n",
    "relate Ix(/a.b) ~ /c.d\n",
    "relate I(/a.b ~ /c.d\n",
    "relate I/a.b) ~ /c.d\n",
    "relate i(/a.b) ~ /c.d\n",
    "relate I(I(/a.b)) ~ /c.d\n",
    "relate I() ~ /c.d\n",
    "relateI(/a.b) ~ /c.d\n",
]


@pytest.mark.parametrize("text", INTEGRALS)
def test_integrated_sides(text: str) -> None:
    source = "robot r\ntopic /a { b }\n" + text
    if _same_or_bail(source):
        model, _ = fast_parse(source, "f.ram")
        pairs: tuple[Related | Interval, ...] = (*model.related, *model.intervals)
        assert any(r.integrated for p in pairs for r in (p.a, p.b))


def test_integrated_sides_usually_take_the_fast_path() -> None:
    read = [_same_or_bail("robot r\n" + text) for text in INTEGRALS[:10]]
    assert all(read), read


def test_integral_mutants() -> None:
    # Mutants of relations and intervals with I(...) sides, where the edits land near them.
    text = "robot r\ntopic /a { b }\n" + "".join(INTEGRALS[:10])
    rng = random.Random(5)
    read = 0
    for _ in range(600):
        mutant = text
        for _ in range(rng.randint(1, 3)):
            pos = rng.randrange(len(mutant) + 1)
            if rng.random() < 0.5:
                mutant = mutant[:pos] + rng.choice(PIECES) + mutant[pos:]
            else:
                mutant = mutant[:pos] + mutant[pos + rng.randint(1, 4) :]
        read += _same_or_bail(mutant)
    assert read > 20


# Machines and where nodes run: one line, spread over lines, glued, with comments, and the
# near misses Lark rejects (which the fast path must leave to it).
PLACEMENTS = [
    "machine base address 10.0.0.1\nmachine laptop address laptop.local;\nmachine c\n"
    "node a on laptop { publishes /t }\nnode b drives h on base in container b_1 via docker\n"
    "node c in container c via podman {}\n",
    "machine base\n  address\n  fe80::1 ;node a\n on # c\n base\n in container x via podman\n{}\n",
    "machine m address 10.0.0.1\nnode a drives h, g on m {\n  publishes /t\n}\n",
    "node a on on\n",  # a machine named 'on'
    "node a in container in via docker\n",
    "machine m address\n",
    "node a on\n",
    "node a in container x via lxc\n",
    "node a in x via docker\n",
    "node a on m on m\n",
    "node a in container x via docker on m\n",
    "machine m address 10.0.0.1x\n",
    "machine m address10.0.0.1\n",
    "node a onm\n",
]


@pytest.mark.parametrize("text", PLACEMENTS)
def test_placements(text: str) -> None:
    _same_or_bail("robot r\ntopic /t\nhardware h\nhardware g\n" + text)


def test_placements_take_the_fast_path() -> None:
    read = [_same_or_bail("robot r\n" + text) for text in PLACEMENTS[:3]]
    assert all(read), read


def test_placement_mutants() -> None:
    text = "robot r\ntopic /t\n" + "".join(PLACEMENTS[:3])
    rng = random.Random(28)
    pieces = [*PIECES, "on", "in", "container", "via", "docker", "machine", "address", "10.0"]
    read = 0
    for _ in range(600):
        mutant = text
        for _ in range(rng.randint(1, 3)):
            pos = rng.randrange(len(mutant) + 1)
            if rng.random() < 0.5:
                mutant = mutant[:pos] + rng.choice(pieces) + mutant[pos:]
            else:
                mutant = mutant[:pos] + mutant[pos + rng.randint(1, 4) :]
        read += _same_or_bail(mutant)
    assert read > 20


@pytest.mark.parametrize(
    "text",
    [
        "relate /a.b ~/d.e\n",  # '~' glued to the field reference after it
        "relate /a.b~/d.e\ninterval /a.b ~I(/d.e) within 1\n",
        "node a {\n  subscribes /t,\n    /u\n  publishes /q\n    from /t\n}\n",  # lists go on
        "topic /t @ 10 Hz\n  +- 1 Hz\n  window 2 s\n",
    ],
)
def test_layouts_only_a_contextual_lexer_reads_take_the_fast_path(text: str) -> None:
    assert _same_or_bail("robot r\n" + text)


# Keywords are whole words (issue 38): Lark's contextual lexer read a keyword out of the front
# of a longer word where no name may come (`fromage` as `from age`, `onboard` as `on board`,
# `memory` as `mem ory`); the fast path reads words whole and bails.  Both now refuse them.
@pytest.mark.parametrize(
    ("text", "word"),
    [
        ("node n { subscribes /age; publishes /a fromage }\n", "fromage"),
        ("machine board\nnode n onboard {}\n", "onboard"),
        ("topic /a\nnode n { publishes /a; limits cpu 5 %, memory 64 MB }\n", "memory"),
        ("topic /a @ 10 Hz window 2 sec\nnode n { publishes /a }\n", "sec"),
        ("hardware h switchablechannel 1\n", "switchablechannel"),
    ],
)
def test_a_keyword_glued_to_a_word_is_no_keyword(text: str, word: str) -> None:
    text = "robot r\n" + text
    assert _fast(text) is None
    assert _lark(text).startswith("error: f.ram:"), _lark(text)
    assert f"'{word}'" in _lark(text)


@pytest.mark.parametrize(
    "text",
    [
        "topic /u{}@.5Hz+-0.1Hz window 2s\nnode n{publishes/u}\n",  # glued to punctuation
        "node n { publishes /a from /b; subscribes /b }\ntopic /a\ntopic /b\n",
        "topic /a @ 10 Hz;node n{publishes /a;limits cpu 5%,mem 2MB}\n",
    ],
)
def test_keywords_before_punctuation_and_numbers_still_read(text: str) -> None:
    text = "robot r\n" + text
    assert not _lark(text).startswith("error:"), _lark(text)
    _same_or_bail(text)
