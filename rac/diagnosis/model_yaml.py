"""Read a model-server ``model.yaml`` (docs/spec.md) into a :class:`Theory`.

Every problem names its line and column.  Two readers give the same document:

* the layout racc itself writes (top-level ``key: value`` lines and block lists of plain
  one-line scalars) is read line by line, a few string operations per line;
* anything else goes through libyaml's event parser (:func:`rac.limits.compose_yaml`: no
  recursion, depth and size limits, no anchors).

The fast reader accepts a line only when YAML reads it the same way, so a file it does not
recognise is read by the full parser, never misread.
"""

from __future__ import annotations

import re
from collections.abc import Callable
from dataclasses import dataclass
from itertools import chain
from types import MappingProxyType

import yaml

from rac.diagnosis.theory import ClauseTable, Key, Theory
from rac.errors import Diagnostic, RacError, Span, did_you_mean
from rac.limits import MAX_YAML_BYTES, YamlLimit, compose_yaml
from rac.logic import (
    AB,
    COMPACT_ATOM,
    FALSE,
    NAB,
    NEG_PREFIX,
    Atom,
    Clause,
    parse_atom,
    parse_clause,
)
from rac.perf import paused_gc

KEYS = ("ab", "nab", "neg_prefix", "props", "rules")
_COMPACT_LINES = re.compile(rf"^{COMPACT_ATOM}$", re.MULTILINE)  # one atom per line


@dataclass(frozen=True, slots=True)
class _Value:
    """A top-level value: a scalar's text, or a list's items (None for a non-scalar item)."""

    span: Span
    text: str | None = None  # a scalar
    items: list[str | None] | None = None  # a list
    item_span: Callable[[int], Span] | None = None


Entries = list[tuple[str, Span, _Value]]  # key, where the key is, value


def _span(file: str, node: yaml.Node) -> Span:
    start, end = node.start_mark, node.end_mark
    return Span(file, start.line + 1, start.column + 1, end.line + 1, end.column + 1)


def _error(span: Span | None, message: str, hint: str | None = None) -> Diagnostic:
    return Diagnostic("RAC006", message, span, hint=hint)


# The fast reader's lines.  A plain scalar made of these characters reads as itself in YAML:
# no indicator can start it, it holds no ': ', ' #', quote, anchor, tag or flow character,
# and it ends with no blank.
_PLAIN = r"[A-Za-z_(][A-Za-z0-9_(),. >-]*(?<! )"
_KEY_LINE = re.compile(rf"([a-z_]+):(?: ({_PLAIN}))?")
_ITEM_LINE = re.compile(rf"( *)- ({_PLAIN})")


# A run of item lines at one indent (0 or 2), each ended by a newline: read in one match.
_ITEM_BLOCKS = {width: re.compile(rf"(?:{' ' * width}- {_PLAIN}\n)+") for width in (0, 2)}


def _item_block(text: str, pos: int, width: int) -> tuple[list[str], int]:
    """The items of the run of ``width``-indented item lines at ``pos``, and where it ends."""
    found = _ITEM_BLOCKS[width].match(text, pos)
    if found is None:
        return [], pos
    return [line[width + 2 :] for line in text[pos : found.end() - 1].split("\n")], found.end()


def _fast_entries(text: str, file: str) -> Entries | None:
    """The document as racc writes it, or None when it is laid out any other way."""
    if not text.isascii() or "\r" in text or "\t" in text:
        return None
    entries: Entries = []
    key_line = _KEY_LINE.fullmatch
    item_line = _ITEM_LINE.fullmatch
    items: list[str | None] | None = None
    lines: list[int] = []
    indent = -1
    pending: tuple[str, Span, int] | None = None  # a 'key:' whose list may follow

    def close() -> None:
        nonlocal pending, items, lines
        if pending is None:
            return
        key, where, number = pending
        if items is None:  # 'key:' and nothing: YAML's empty scalar
            column = len(key) + 2
            entries.append((key, where, _Value(Span(file, number, column, number, column), "")))
        else:
            entries.append((key, where, _list_value(file, items, lines, indent)))
        pending, items, lines = None, None, []

    all_lines = text.split("\n")
    index, pos = 0, 0  # the line and the offset of its first character
    while index < len(all_lines):
        line = all_lines[index]
        number = index + 1
        width = 0 if line[:2] == "- " else 2 if line[:4] == "  - " else -1
        if pending is not None and width >= 0 and (items is None or width == indent):
            block, end = _item_block(text, pos, width)
            if block:  # most of a model file: its rules and props, a few operations in all
                if items is None:
                    items, indent = [], width
                items.extend(block)
                lines.extend(range(number, number + len(block)))
                index, pos = index + len(block), end
                continue
        index += 1
        pos += len(line) + 1
        stripped = line.lstrip(" ")
        if not stripped or stripped[0] == "#":
            continue
        if line[0] == " " or line[0] == "-":
            found = item_line(line)
            if found is None or pending is None:
                return None
            width = len(found.group(1))
            if items is None:
                if width not in (0, 2):
                    return None
                items, indent = [], width
            elif width != indent:
                return None
            items.append(found.group(2))
            lines.append(number)
            continue
        found = key_line(line)
        if found is None:
            return None
        close()
        key, value = found.group(1), found.group(2)
        where = Span(file, number, 1, number, 1 + len(key))
        if value is None:
            pending = (key, where, number)
        else:
            column = len(key) + 3
            span = Span(file, number, column, number, column + len(value))
            entries.append((key, where, _Value(span, value)))
    close()
    return entries if entries else None


def _list_value(file: str, items: list[str | None], lines: list[int], indent: int) -> _Value:
    column = indent + 3

    def item_span(i: int) -> Span:
        text = items[i] or ""
        return Span(file, lines[i], column, lines[i], column + len(text))

    first = lines[0] if lines else 1
    return _Value(Span(file, first, indent + 1, lines[-1], column), None, items, item_span)


def _node_span(file: str, nodes: list[yaml.Node]) -> Callable[[int], Span]:
    return lambda i: _span(file, nodes[i])


def _node_entries(root: yaml.MappingNode, file: str) -> Entries:
    """The same entries from composed nodes (the full parser's path)."""
    entries: Entries = []
    for key_node, node in root.value:
        value: _Value
        if isinstance(node, yaml.ScalarNode):
            value = _Value(_span(file, node), str(node.value))
        elif isinstance(node, yaml.SequenceNode):
            nodes = list(node.value)
            items = [str(n.value) if isinstance(n, yaml.ScalarNode) else None for n in nodes]
            value = _Value(_span(file, node), None, items, _node_span(file, nodes))
        else:
            value = _Value(_span(file, node))
        entries.append((str(key_node.value), _span(file, key_node), value))
    return entries


def _read_entries(text: str, file: str) -> tuple[Entries, Span]:
    """The top-level entries, and where the document's mapping starts."""
    if len(text) > MAX_YAML_BYTES:
        message = f"the file is {len(text):,} characters long (at most {MAX_YAML_BYTES:,})"
        raise RacError([Diagnostic("RAC009", message, Span(file, 1, 1, 1, 2))])
    fast = _fast_entries(text, file)
    if fast is not None:
        return fast, fast[0][1]
    try:
        root = compose_yaml(text)
    except YamlLimit as err:
        line, column = err.mark.line + 1, err.mark.column + 1
        where = Span(file, line, column, line, column + 1)
        raise RacError([Diagnostic("RAC009", err.message, where)], text) from None
    except yaml.YAMLError as err:
        mark = getattr(err, "problem_mark", None)
        span = (
            Span(file, mark.line + 1, mark.column + 1, mark.line + 1, mark.column + 2)
            if mark
            else None
        )
        problem = getattr(err, "problem", None) or str(err)
        raise RacError([Diagnostic("RAC006", f"not valid YAML: {problem}", span)], text) from None
    if not isinstance(root, yaml.MappingNode):
        message = "a model file is a mapping with keys " + ", ".join(KEYS)
        if root is None:  # an empty file: still name it
            raise RacError([Diagnostic("RAC006", message, Span(file, 1, 1, 1, 1))], text)
        raise RacError([_error(_span(file, root), message)], text)
    return _node_entries(root, file), _span(file, root)


def _items(value: _Value, key: str, errors: list[Diagnostic]) -> list[tuple[int, str | None]]:
    """(position, text) of each item of a list value; a null scalar is an empty list."""
    if value.items is not None:
        return list(enumerate(value.items))
    if value.text in ("", "~", "null"):
        return []
    errors.append(_error(value.span, f"'{key}' must be a list of strings"))
    return []


def _name_problems(values: dict[str, _Value], names: dict[str, str]) -> list[Diagnostic]:
    """ab, nab and neg_prefix are identifiers that cannot be mistaken for one another."""
    found: list[Diagnostic] = []

    def where(key: str) -> Span | None:
        value = values.get(key)
        return value.span if value else None

    for key, value in names.items():
        pattern = r"[A-Za-z_][A-Za-z0-9_]*"
        if re.fullmatch(pattern, value) is None:
            found.append(_error(where(key), f"'{key}' must be an identifier"))
    ab, nab, neg = names["ab"], names["nab"], names["neg_prefix"]
    if ab == nab:
        found.append(_error(where("nab"), "'ab' and 'nab' must differ"))
    for key in ("ab", "nab"):
        if names[key].startswith(neg) or names[key] == FALSE:
            message = f"'{key}' must not start with the negation prefix '{neg}' nor be 'false'"
            found.append(_error(where(key), message))
    return found


class _Atoms:
    """Atoms numbered once per distinct text: a model names each atom in many rules.

    Numbers follow first appearance; one :class:`Atom` object per atom, however it was
    written (later passes key on identity).
    """

    def __init__(self) -> None:
        self.by_text: dict[str, int] = {}
        self.by_key: dict[Key, int] = {}
        self.atoms: list[Atom] = []  # by number; by_key is numbered in insertion order

    def number(self, text: str) -> int:
        found = self.by_text.get(text)
        if found is None:
            stripped = text.strip()
            found = self.by_text.get(stripped)
            if found is None:
                parsed = parse_atom(stripped)  # ValueError when it is not an atom
                key = (parsed.predicate, parsed.args)
                found = self.by_key.get(key)
                if found is None:
                    found = self.by_key[key] = len(self.atoms)
                    self.atoms.append(parsed)
                self.by_text[stripped] = found
            self.by_text[text] = found
        return found

    def atom(self, text: str) -> Atom:
        return self.atoms[self.number(text)]

    def clause(self, text: str) -> Clause:
        """``parse_clause``, splitting at ', ' first: the layout racc writes."""
        body_text, arrow, head_text = text.partition("->")
        if arrow:
            try:
                body = tuple([self.atom(p) for p in body_text.split(", ")])
                return Clause(body, self.atom(head_text))
            except ValueError:
                pass  # another layout, or not a rule: the full parser says which
        parsed = parse_clause(text)
        return Clause(tuple(self.atom(str(a)) for a in parsed.body), self.atom(str(parsed.head)))

    def number_compact(self, texts: list[str]) -> bool:
        """Number ``texts`` (distinct, in order) when every one is a compact atom (``p`` or
        ``p(a,b)``, no blanks): one regular-expression pass over them all.  False, with
        nothing numbered, when one is not."""
        found = _COMPACT_LINES.findall("\n".join(texts))
        if len(found) != len(texts):  # a match never spans lines: some text did not match
            return False
        by_text, by_key, atoms = self.by_text, self.by_key, self.atoms
        for text, (pred, args) in zip(texts, found, strict=True):
            key = (pred, tuple(args.split(",")) if args else ())
            number = by_key.get(key)
            if number is None:
                number = by_key[key] = len(atoms)
                atoms.append(Atom(*key))
            by_text[text] = number
        return True

    def numbered_rules(self, items: list[str | None]) -> tuple[list[int], list[list[int]]] | None:
        """Every rule as atom numbers, heads first and then bodies (the engine's order), when
        every rule is in racc's layout (``a, b -> c`` of compact atoms); None otherwise."""
        head_texts: list[str] = []
        body_texts: list[list[str]] = []
        for item in items:
            if item is None:
                return None
            body_text, arrow, head_text = item.partition(" -> ")
            if not arrow:
                if not item.startswith("-> "):
                    return None
                body_text, head_text = "", item[3:]  # a fact
            head_texts.append(head_text)
            body_texts.append(body_text.split(", ") if body_text else [])
        # Each distinct text is numbered once, in order of first appearance (heads, then
        # bodies); every occurrence is then one dictionary look-up.
        heads_first = dict.fromkeys(head_texts)
        heads_first.update(dict.fromkeys(chain.from_iterable(body_texts)))
        if not self.number_compact(list(heads_first)):
            return None
        by_text = self.by_text
        heads = [by_text[text] for text in head_texts]
        bodies = [[by_text[text] for text in body] for body in body_texts]
        return heads, bodies


def _assumption_problems(
    atoms: list[Atom], ab: str, nab: str, negated: set[str]
) -> dict[Atom, list[str]]:
    """What is wrong with each distinct atom of the rules about the assumptions, if anything."""
    found: dict[Atom, list[str]] = {}
    for atom in atoms:
        if atom.predicate in (ab, nab) and len(atom.args) != 1:
            found.setdefault(atom, []).append(f"'{atom}' must name exactly one component")
        if atom.predicate in negated:
            message = f"'{atom}' negates an assumption; write '{ab}(…)' or '{nab}(…)'"
            found.setdefault(atom, []).append(message)
    return found


def _where(value: _Value, i: int) -> Span:
    return value.item_span(i) if value.item_span else value.span


Numbers = tuple[list[int], list[list[int]]]  # heads, bodies


def _rules(
    value: _Value, names: dict[str, str], errors: list[Diagnostic]
) -> tuple[list[Clause], _Atoms, Numbers | None]:
    """The clauses of ``rules`` (every problem in file order), their atoms, and the clauses
    as atom numbers when every rule is in racc's layout."""
    items = _items(value, "rules", errors)
    atoms = _Atoms()
    numbers = atoms.numbered_rules([item for _, item in items])
    parsed: list[tuple[int, Clause | str | None]] = []
    if numbers is not None:
        table = atoms.atoms
        for (i, _), head, body in zip(items, *numbers, strict=True):
            parsed.append((i, Clause(tuple([table[a] for a in body]), table[head])))
    else:
        atoms = _Atoms()
        for i, item in items:
            if item is None:
                parsed.append((i, None))
                continue
            try:
                parsed.append((i, atoms.clause(item)))
            except ValueError as err:
                parsed.append((i, str(err)))
    ab, nab = names["ab"], names["nab"]
    negated = {names["neg_prefix"] + ab, names["neg_prefix"] + nab}
    # checked once per distinct atom, then reported at every rule using it
    problems = _assumption_problems(atoms.atoms, ab, nab, negated)
    clauses: list[Clause] = []
    for i, outcome in parsed:
        if outcome is None:
            errors.append(_error(_where(value, i), "a rule must be a string"))
        elif isinstance(outcome, str):
            errors.append(_error(_where(value, i), outcome, "write a rule as 'A, B -> C'"))
        else:
            if problems:
                for atom in (*outcome.body, outcome.head):
                    for message in problems.get(atom, ()):
                        errors.append(_error(_where(value, i), message))
            if not outcome.body and outcome.head == Atom(FALSE):
                message = "'-> false' makes every observation inconsistent"
                errors.append(_error(_where(value, i), message))
            clauses.append(outcome)
    return clauses, atoms, numbers


def _unique(
    clauses: list[Clause],
    props: tuple[Atom, ...],
    atoms: _Atoms,
    numbers: Numbers | None,
    nab: dict[str, int],
) -> tuple[tuple[Clause, ...], ClauseTable | None]:
    """The distinct clauses in file order, and their table when the rules were numbered."""
    if numbers is None:
        return tuple(dict.fromkeys(clauses)), None
    heads, bodies = numbers
    first: dict[tuple[int, tuple[int, ...]], int] = {}
    for k, key in enumerate(zip(heads, map(tuple, bodies), strict=True)):
        first.setdefault(key, k)  # equal numbers are equal clauses: one object per atom
    kept = list(first.values())
    unique = tuple([clauses[k] for k in kept])
    table = ClauseTable(
        clauses=unique,
        props=props,
        ids=MappingProxyType(atoms.by_key),
        heads=tuple([heads[k] for k in kept]),
        bodies=tuple([tuple(dict.fromkeys(bodies[k])) for k in kept]),
        nab=MappingProxyType(nab),
    )
    return unique, table


def parse_model_yaml(text: str, file: str) -> Theory:
    """The theory of a model-server file; RacError RAC006 with every problem found."""
    with paused_gc():  # a hundred thousand atoms and clauses, none cyclic (rac.perf)
        return _parse(text, file)


def _parse(text: str, file: str) -> Theory:
    entries, root = _read_entries(text, file)
    errors: list[Diagnostic] = []
    values: dict[str, _Value] = {}
    for key, where, value in entries:
        if key not in KEYS:
            errors.append(_error(where, f"unknown key '{key}'", did_you_mean(key, KEYS)))
        elif key in values:
            errors.append(_error(where, f"key '{key}' given twice"))
        else:
            values[key] = value
    names = {"ab": AB, "nab": NAB, "neg_prefix": NEG_PREFIX}
    for key in names:
        if key in values:
            scalar = values[key].text
            if scalar is None:
                errors.append(_error(values[key].span, f"'{key}' must be a string"))
            elif scalar.strip():
                names[key] = scalar.strip()
            else:
                errors.append(_error(values[key].span, f"'{key}' must not be empty"))
    ab, nab = names["ab"], names["nab"]
    errors.extend(_name_problems(values, names))
    if "rules" not in values:
        errors.append(_error(root, "missing key 'rules'"))
    # The rules are read first (so that their atoms are known apart from the props'), but
    # the props' problems are reported first, in file order.
    rule_errors: list[Diagnostic] = []
    clauses, atoms, numbers = (
        _rules(values["rules"], names, rule_errors) if "rules" in values else ([], _Atoms(), None)
    )
    in_rules = list(atoms.atoms)
    props: list[Atom] = []
    if "props" in values:
        value = values["props"]
        for i, item in _items(value, "props", errors):
            if item is None:
                errors.append(_error(_where(value, i), "a prop must be a string"))
                continue
            try:
                props.append(atoms.atom(item))
            except ValueError:
                errors.append(_error(_where(value, i), f"not an atom: {item!r}"))
    errors.extend(rule_errors)
    if errors:
        # in file order: the rules are read before the props and the keys, wherever they are
        errors.sort(key=lambda d: (d.span.line, d.span.column) if d.span else (0, 0))
        raise RacError(errors, text)
    # COMPS from the distinct atoms of the rules (rac.diagnosis.theory.components_of); the
    # atoms are in number order, so the NAB numbers come with the same scan
    comps: set[str] = set()
    nab_numbers: dict[str, int] = {}
    for number, a in enumerate(in_rules):
        if a.predicate in (ab, nab) and len(a.args) == 1:
            comps.add(a.args[0])
            if a.predicate == nab:
                nab_numbers[a.args[0]] = number
    distinct_props = tuple(dict.fromkeys(props))
    unique, table = _unique(clauses, distinct_props, atoms, numbers, nab_numbers)
    return Theory(
        clauses=unique,
        props=distinct_props,
        components=tuple(sorted(comps)),
        ab=ab,
        nab=nab,
        neg_prefix=names["neg_prefix"],
        table=table,
    )
