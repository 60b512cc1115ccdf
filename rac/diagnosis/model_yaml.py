"""Read a model-server ``model.yaml`` (docs/spec.md) into a :class:`Theory`.

The file is composed (not just loaded) so that every problem names its line and column.
"""

from __future__ import annotations

import re

import yaml

from rac.diagnosis.theory import Theory, components_of
from rac.errors import Diagnostic, RacError, Span, did_you_mean
from rac.limits import MAX_YAML_BYTES, YamlLimit, compose_yaml
from rac.logic import AB, FALSE, NAB, NEG_PREFIX, Atom, Clause, parse_atom, parse_clause

KEYS = ("ab", "nab", "neg_prefix", "props", "rules")


def _span(file: str, node: yaml.Node) -> Span:
    start, end = node.start_mark, node.end_mark
    return Span(file, start.line + 1, start.column + 1, end.line + 1, end.column + 1)


def _error(file: str, node: yaml.Node | None, message: str, hint: str | None = None) -> Diagnostic:
    return Diagnostic("RAC006", message, _span(file, node) if node else None, hint=hint)


def _scalar(file: str, node: yaml.Node, what: str, errors: list[Diagnostic]) -> str | None:
    if isinstance(node, yaml.ScalarNode):
        return str(node.value)
    errors.append(_error(file, node, f"{what} must be a string"))
    return None


def _items(file: str, node: yaml.Node, key: str, errors: list[Diagnostic]) -> list[yaml.Node]:
    if isinstance(node, yaml.SequenceNode):
        return list(node.value)
    if isinstance(node, yaml.ScalarNode) and node.value in ("", "~", "null"):
        return []
    errors.append(_error(file, node, f"'{key}' must be a list of strings"))
    return []


def _check_assumption(
    file: str, node: yaml.Node, atom: Atom, ab: str, nab: str, errors: list[Diagnostic]
) -> None:
    if atom.predicate in (ab, nab) and len(atom.args) != 1:
        errors.append(_error(file, node, f"'{atom}' must name exactly one component"))


def _name_problems(
    file: str, values: dict[str, yaml.Node], names: dict[str, str]
) -> list[Diagnostic]:
    """ab, nab and neg_prefix are identifiers that cannot be mistaken for one another."""
    found: list[Diagnostic] = []
    for key, value in names.items():
        pattern = r"[A-Za-z_][A-Za-z0-9_]*"
        if re.fullmatch(pattern, value) is None:
            found.append(_error(file, values.get(key), f"'{key}' must be an identifier"))
    ab, nab, neg = names["ab"], names["nab"], names["neg_prefix"]
    if ab == nab:
        found.append(_error(file, values.get("nab"), "'ab' and 'nab' must differ"))
    for key in ("ab", "nab"):
        if names[key].startswith(neg) or names[key] == FALSE:
            message = f"'{key}' must not start with the negation prefix '{neg}' nor be 'false'"
            found.append(_error(file, values.get(key), message))
    return found


def parse_model_yaml(text: str, file: str) -> Theory:
    """The theory of a model-server file; RacError RAC006 with every problem found."""
    if len(text) > MAX_YAML_BYTES:
        message = f"the file is {len(text):,} characters long (at most {MAX_YAML_BYTES:,})"
        raise RacError([Diagnostic("RAC009", message, Span(file, 1, 1, 1, 2))])
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
        raise RacError([_error(file, root, message)], text)
    errors: list[Diagnostic] = []
    values: dict[str, yaml.Node] = {}
    for key_node, value_node in root.value:
        key = str(key_node.value)
        if key not in KEYS:
            errors.append(_error(file, key_node, f"unknown key '{key}'", did_you_mean(key, KEYS)))
        elif key in values:
            errors.append(_error(file, key_node, f"key '{key}' given twice"))
        else:
            values[key] = value_node
    names = {"ab": AB, "nab": NAB, "neg_prefix": NEG_PREFIX}
    for key in names:
        if key in values:
            value = _scalar(file, values[key], f"'{key}'", errors)
            if value is not None and value.strip():
                names[key] = value.strip()
            elif value is not None:
                errors.append(_error(file, values[key], f"'{key}' must not be empty"))
    ab, nab = names["ab"], names["nab"]
    errors.extend(_name_problems(file, values, names))
    if "rules" not in values:
        errors.append(_error(file, root, "missing key 'rules'"))
    props: list[Atom] = []
    for item in _items(file, values["props"], "props", errors) if "props" in values else []:
        text_value = _scalar(file, item, "a prop", errors)
        if text_value is None:
            continue
        try:
            props.append(parse_atom(text_value))
        except ValueError:
            errors.append(_error(file, item, f"not an atom: {text_value!r}"))
    clauses: list[Clause] = []
    negated_assumptions = {names["neg_prefix"] + ab, names["neg_prefix"] + nab}
    for item in _items(file, values["rules"], "rules", errors) if "rules" in values else []:
        text_value = _scalar(file, item, "a rule", errors)
        if text_value is None:
            continue
        try:
            clause = parse_clause(text_value)
        except ValueError as err:
            errors.append(_error(file, item, str(err), "write a rule as 'A, B -> C'"))
            continue
        for atom in (*clause.body, clause.head):
            _check_assumption(file, item, atom, ab, nab, errors)
            if atom.predicate in negated_assumptions:
                message = f"'{atom}' negates an assumption; write '{ab}(…)' or '{nab}(…)'"
                errors.append(_error(file, item, message))
        if clause.head == Atom(FALSE) and not clause.body:
            errors.append(_error(file, item, "'-> false' makes every observation inconsistent"))
        clauses.append(clause)
    if errors:
        raise RacError(errors, text)
    unique = tuple(dict.fromkeys(clauses))
    return Theory(
        clauses=unique,
        props=tuple(dict.fromkeys(props)),
        components=components_of(unique, ab, nab),
        ab=ab,
        nab=nab,
        neg_prefix=names["neg_prefix"],
    )
