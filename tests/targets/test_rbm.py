"""model.yaml against contract §2 and §3, derived independently of the compiler.

The reference below reads the ram/1 JSON (``racc export --json``, contract §1) and follows
contract §3 literally; it shares no code with ``rac.passes``.  Clauses are compared as sets
of (body atoms, head), so order and spacing are free.
"""

from __future__ import annotations

import functools
import itertools
import json
import re
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from ram_strategies import models

from rac.cli import main
from rac.interchange import model_to_json
from rac.load.files import load_model
from rac.logic import parse_atom
from rac.parse import parse_ram
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.model_yaml import emit_model_yaml

ROOT = Path(__file__).resolve().parents[2]
MODELS = sorted((ROOT / "models").glob("*.ram"))
TEDUSAR = ROOT / "models" / "tedusar.ram"

Clause = tuple[frozenset[str], str]


# --- the reference: contract §2 and §3, read literally -------------------------------------


def mangle(name: str) -> str:
    """Contract §2: drop a leading '/', then every '/', '.' and '-' becomes '_'."""
    if name.startswith("/"):
        name = name[1:]
    return name.replace("/", "_").replace(".", "_").replace("-", "_")


def atom(predicate: str, *names: str) -> str:
    return f"{predicate}({','.join(mangle(n) for n in names)})"


def split_ref(ref: str) -> tuple[str, str]:
    """``TOPIC.FIELD_PATH``: the first dot splits topic from field; the field of an
    integrated side ``I(TOPIC.FIELD_PATH)`` is ``I_FIELD_PATH`` in atoms."""
    if ref.startswith("I(") and ref.endswith(")"):
        topic, field = split_ref(ref[2:-1])
        return topic, f"I_{field}"
    topic, field = ref.split(".", 1)
    return topic, field


def pairs(doc: dict[str, Any]) -> list[tuple[str, str, str]]:
    out = [("matched", a, b) for a, b in doc.get("related") or []]
    out += [("equal", i["a"], i["b"]) for i in doc.get("intervals") or []]
    return out


def reference_rbm(doc: dict[str, Any]) -> set[Clause]:
    hardware = {h["name"]: h for h in doc.get("hardware") or []}
    switchable = {n for n, h in hardware.items() if h.get("switchable")}
    topics = {t["name"]: t for t in doc.get("topics") or []}
    regular = {n for n, t in topics.items() if t.get("rate_hz") is not None}
    nodes = doc.get("nodes") or []
    clauses: set[Clause] = set()

    def add(body: list[str], head: str) -> None:
        clauses.add((frozenset(body), head))

    for h in switchable:  # 1
        add([atom("NAB", h)], atom("on", h))
    for n in nodes:
        name = n["name"]
        for pub in n.get("publishes") or []:  # 2
            body = [atom("NAB", name)]
            body += [atom("NAB", h) for h in n.get("drives") or [] if h in switchable]
            body += [atom("ok", i) for i in pub.get("affected_by") or []]
            add(body, atom("ok", pub["topic"]))
        add([atom("NAB", name)], atom("running", name))  # 3
        for prop in sorted((n.get("limits") or {}).keys()):  # 4
            add([atom("NAB", name)], f"ok({mangle(name)},{prop})")
        for d in n.get("diagnostics") or []:  # 5
            body = [atom("NAB", name)] + ([atom("NAB", d)] if d in hardware else [])
            add(body, atom("ok", d))
    publishers: dict[str, list[str]] = {}
    for n in nodes:
        for pub in n.get("publishes") or []:
            publishers.setdefault(pub["topic"], []).append(n["name"])
    for predicate, a, b in pairs(doc):  # 6, 7
        (t1, f1), (t2, f2) = split_ref(a), split_ref(b)
        head = atom(predicate, t1, f1, t2, f2)
        observed = [atom("ok", t) for t in (t1, t2) if t in regular]
        for n1 in publishers.get(t1, []):
            for n2 in publishers.get(t2, []):
                add([atom("NAB", n1), atom("NAB", n2), *observed], head)
    for body, head in reference_loop_rules(nodes, switchable):  # the loop rule
        add(body, head)
    return clauses


def _strongly_connected(members: tuple[str, ...], edges: set[tuple[str, str]]) -> bool:
    """Every member reaches every other along ``edges`` (plain search, no library)."""
    for start in members:
        seen, stack = {start}, [start]
        while stack:
            u = stack.pop()
            for a, b in edges:
                if a == u and b not in seen:
                    seen.add(b)
                    stack.append(b)
        if not set(members) <= seen:
            return False
    return True


def _on_cycles(edges: set[tuple[str, str]]) -> set[str]:
    """The topics that can lie in a strongly connected set: those left after removing, again
    and again, any topic with no input or no reader among the rest.  The subsets below are
    then drawn from these only (a 150-topic model without loops has none: 2^150 subsets
    otherwise)."""
    left = {t for edge in edges for t in edge}
    while True:
        inner = {(a, b) for a, b in edges if a in left and b in left}
        keep = {b for _, b in inner} & {a for a, _ in inner}
        if keep == left:
            return left
        left = keep


def reference_loop_rules(
    nodes: list[dict[str, Any]], switchable: set[str]
) -> list[tuple[list[str], str]]:
    """Every set R of two or more topics with one publication each (an input in R) that
    connects R strongly: the chosen nodes and hardware NAB, inputs outside R ok -> ok(τ ∈ R)."""
    pubs = [
        (n["name"], [h for h in n.get("drives") or [] if h in switchable], p)
        for n in nodes
        for p in n.get("publishes") or []
    ]
    topics = sorted(
        _on_cycles({(i, p["topic"]) for _, _, p in pubs for i in p.get("affected_by") or []})
    )
    out: list[tuple[list[str], str]] = []
    for size in range(2, len(topics) + 1):
        for subset in itertools.combinations(topics, size):
            inside = set(subset)
            options = [
                [
                    x
                    for x in pubs
                    if x[2]["topic"] == t and inside & set(x[2].get("affected_by") or [])
                ]
                for t in subset
            ]
            for choice in itertools.product(*options):
                edges = {
                    (i, p["topic"])
                    for _, _, p in choice
                    for i in p.get("affected_by") or []
                    if i in inside
                }
                if not _strongly_connected(subset, edges):
                    continue
                body = [atom("NAB", n) for n, _, _ in choice]
                body += [atom("NAB", h) for _, hw, _ in choice for h in hw]
                body += [
                    atom("ok", i)
                    for _, _, p in choice
                    for i in p.get("affected_by") or []
                    if i not in inside
                ]
                out.extend((body, atom("ok", t)) for t in subset)
    return out


def reference_props(doc: dict[str, Any]) -> set[str]:
    """Contract §2's observer table: every atom some observer reports."""
    props: set[str] = set()
    for n in doc.get("nodes") or []:
        props.add(atom("running", n["name"]))
        props.update(f"ok({mangle(n['name'])},{p})" for p in (n.get("limits") or {}))
        props.update(atom("ok", d) for d in n.get("diagnostics") or [])
    for t in doc.get("topics") or []:
        if t.get("rate_hz") is not None:
            props.add(atom("ok", t["name"]))
    props.update(atom("on", h["name"]) for h in doc.get("hardware") or [] if h.get("switchable"))
    for predicate, a, b in pairs(doc):
        props.add(atom(predicate, *split_ref(a), *split_ref(b)))
    return props


def reference_comps(doc: dict[str, Any]) -> set[str]:
    """Every node, every switchable device, every reported device that is declared hardware."""
    hardware = {h["name"]: h for h in doc.get("hardware") or []}
    comps = {mangle(n["name"]) for n in doc.get("nodes") or []}
    comps |= {mangle(h) for h, v in hardware.items() if v.get("switchable")}
    comps |= {
        mangle(d)
        for n in doc.get("nodes") or []
        for d in n.get("diagnostics") or []
        if d in hardware
    }
    return comps


# --- reading model.yaml independently -------------------------------------------------------

_ATOM = re.compile(r"\s*([A-Za-z_]\w*)\s*(?:\(([^()]*)\))?\s*")


def parse_atoms(text: str) -> list[str]:
    """``NAB(a), ok(b, c)`` -> ['NAB(a)', 'ok(b,c)'] (spacing normalised)."""
    atoms, pos = [], 0
    while pos < len(text):
        m = _ATOM.match(text, pos)
        assert m and m.end() > pos, f"cannot read atoms in {text!r} at {pos}"
        args = m.group(2)
        if args is None:
            atoms.append(m.group(1))
        else:
            atoms.append(f"{m.group(1)}({''.join(args.split())})")
        pos = m.end()
        if pos < len(text):
            assert text[pos] == ",", f"expected ',' in {text!r} at {pos}"
            pos += 1
    return atoms


def parse_rule(rule: str) -> tuple[list[str], str]:
    body, arrow, head = rule.rpartition("->")
    assert arrow, f"not a rule: {rule!r}"
    (head_atom,) = parse_atoms(head)
    return parse_atoms(body), head_atom


def rule_set(rules: list[str]) -> set[Clause]:
    return {(frozenset(body), head) for body, head in map(parse_rule, rules)}


def check_model_yaml(text: str, doc: dict[str, Any]) -> dict[str, Any]:
    """Assert everything contract §2/§3/§4 says about model.yaml; return it parsed."""
    data: dict[str, Any] = yaml.safe_load(text)
    assert set(data) == {"ab", "nab", "neg_prefix", "props", "rules"}
    assert (data["ab"], data["nab"], data["neg_prefix"]) == ("AB", "NAB", "not_")
    rules = [parse_rule(r) for r in data["rules"]]
    for body, head in rules:
        assert len(body) == len(set(body)), f"repeated atom in a body: {body} -> {head}"
    assert len(rule_set(data["rules"])) == len(data["rules"]), "duplicate clauses"
    expected = reference_rbm(doc)
    got = rule_set(data["rules"])
    assert got == expected, (
        f"missing: {sorted(map(str, expected - got))}\nextra: {sorted(map(str, got - expected))}"
    )
    props = [parse_atoms(p)[0] for p in data["props"]]
    assert len(props) == len(set(props)), "duplicate props"
    assert set(props) == reference_props(doc)
    return data


# --- the example models, through the command line -------------------------------------------


@functools.cache
def exported_json(model: Path) -> dict[str, Any]:
    """``racc export --json MODEL``, in process."""
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert main(["export", "--json", str(model)]) == 0
    doc: dict[str, Any] = json.loads(out.getvalue())
    return doc


@functools.cache
def compiled_yaml(model: Path) -> str:
    return emit_model_yaml(compile_model(load_model(model)), EmitOptions())


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_model_yaml_holds_exactly_the_contract_clauses(model: Path) -> None:
    check_model_yaml(compiled_yaml(model), exported_json(model))


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_comps_are_the_nab_arguments(model: Path) -> None:
    compiled = compile_model(load_model(model))
    data = yaml.safe_load(compiled_yaml(model))
    nab_args = {a[4:-1] for r in data["rules"] for a in parse_rule(r)[0] if a.startswith("NAB(")}
    assert set(compiled.components) == nab_args == reference_comps(exported_json(model))
    assert len(compiled.components) == len(set(compiled.components))


@pytest.mark.parametrize("model", MODELS, ids=lambda p: p.stem)
def test_every_prop_has_a_clause_deriving_it(model: Path) -> None:
    data = yaml.safe_load(compiled_yaml(model))
    heads = {parse_rule(r)[1] for r in data["rules"]}
    assert not [p for p in data["props"] if parse_atoms(p)[0] not in heads]


def test_reference_sees_a_wrong_clause() -> None:
    """The checker fails when one clause is missing, extra or altered."""
    doc = exported_json(TEDUSAR)
    data = yaml.safe_load(compiled_yaml(TEDUSAR))
    good = data["rules"]
    broken = [
        good[1:],
        [*good, "NAB(rviz) -> ok(map)"],
        [r.replace("NAB(hokuyo)", "NAB(imu)") for r in good],
        [r.replace(", ok(scan)", "") for r in good],
        [*good, good[0]],
    ]
    for rules in broken:
        text = yaml.safe_dump({**data, "rules": rules})
        with pytest.raises(AssertionError):
            check_model_yaml(text, doc)
    with pytest.raises(AssertionError):
        check_model_yaml(yaml.safe_dump({**data, "props": data["props"][1:]}), doc)


# Example 6.1 with the errata: joy_teleop_node is jaguar_teleop_node and its clause derives
# ok(cmd_vel) from ok(joy); hector_mapping's clause derives ok(map) from ok(pose), ok(scan);
# "hectla_servo1_movingor_mapping" is hector_mapping.
EXAMPLE_6_1 = """
NAB(jaguar) -> on(jaguar)
NAB(hokuyo) -> on(hokuyo)
NAB(laser_alignment) -> on(laser_alignment)
NAB(jaguar), NAB(jaguar_node) -> ok(pose)
NAB(hokuyo), NAB(hokuyo_node) -> ok(scan)
NAB(imu_node) -> ok(imu_data)
NAB(joy_node) -> ok(joy)
NAB(jaguar_teleop_node), ok(joy) -> ok(cmd_vel)
NAB(hector_mapping), ok(pose), ok(scan) -> ok(map)
NAB(laser_alignment_control) -> ok(la_servo1_moving)
NAB(laser_alignment_control) -> ok(la_servo2_moving)
NAB(jaguar_node) -> running(jaguar_node)
NAB(hokuyo_node) -> running(hokuyo_node)
NAB(imu_node) -> running(imu_node)
NAB(laser_alignment_node) -> running(laser_alignment_node)
NAB(laser_alignment_control) -> running(laser_alignment_control)
NAB(jaguar_teleop_node) -> running(jaguar_teleop_node)
NAB(joy_node) -> running(joy_node)
NAB(hector_mapping) -> running(hector_mapping)
NAB(rviz) -> running(rviz)
"""

# The matched clauses of Example 6.1 by their NAB atoms: contract §3 (Algorithm 18) adds ok(τ)
# of regular topics to the body.  The fourth printed one, matched(i.d.yaw, l_s_m.yaw), names a
# field la_servo1_moving does not have (δ_fld of Example 4.1), so it is not in the model.  The
# model relates the turn rate integrated (Table 10.3's Intg), I_twist_twist_angular_z, and
# checks the pitch and the servo angle with an interval (equal), not a relation: on a healthy
# recording their trends match barely more often than chance (models/tedusar.ram says more).
EXAMPLE_6_1_MATCHED = {
    "matched(imu_data,yaw,pose,yaw)": {"NAB(imu_node)", "NAB(jaguar_node)"},
    "matched(pose,I_twist_twist_angular_z,pose,yaw)": {"NAB(jaguar_node)"},
    "equal(imu_data,pitch,la_servo1_moving,angle)": {
        "NAB(imu_node)",
        "NAB(laser_alignment_control)",
    },
}


def test_example_6_1_clauses_are_in_tedusar() -> None:
    rules = yaml.safe_load(compiled_yaml(TEDUSAR))["rules"]
    got = rule_set(rules)
    by_head: dict[str, list[frozenset[str]]] = {}
    for got_body, got_head in got:
        by_head.setdefault(got_head, []).append(got_body)
    for line in EXAMPLE_6_1.strip().splitlines():
        body, head = parse_rule(line)
        if head in {"ok(la_servo1_moving)", "ok(la_servo2_moving)"}:
            # δ_aff(lac, la_servo_i_moving) = {imu_data} (Example 4.1): §3 rule 2 adds ok(imu_data).
            body = [*body, "ok(imu_data)"]
        assert (frozenset(body), head) in got, line
    for head, nabs in EXAMPLE_6_1_MATCHED.items():
        bodies = by_head.get(head, [])
        assert len(bodies) == 1, head
        assert {a for a in bodies[0] if a.startswith("NAB(")} == nabs
        assert {a for a in bodies[0] if not a.startswith("NAB(")} <= {
            "ok(imu_data)",
            "ok(pose)",
            "ok(la_servo1_moving)",
        }


def test_tedusar_observer_counts_match_example_6_2() -> None:
    """Example 6.2: nine nodes (errata), 5 regular topics, DObs(hokuyo), one HObs."""
    data = yaml.safe_load(compiled_yaml(TEDUSAR))
    props = data["props"]
    assert sum(p.startswith("running(") for p in props) == 9
    assert {p for p in props if re.fullmatch(r"ok\(\w+\)", p)} == {
        "ok(pose)",
        "ok(imu_data)",
        "ok(scan)",
        "ok(la_servo1_moving)",
        "ok(la_servo2_moving)",
        "ok(hokuyo)",
    }
    assert {p for p in props if p.startswith("on(")} == {
        "on(jaguar)",
        "on(hokuyo)",
        "on(laser_alignment)",
    }


# --- small hand-made models for the corners of §3 -------------------------------------------

CORNERS = """\
robot corners
hardware base switchable channel 1
hardware arm switchable channel 2
hardware imu
topic /in { v }
topic /odom { x, y } @ 10 Hz
topic /raw { x }
node driver drives base, imu {
  subscribes /in
  publishes /odom from /in
  publishes /raw
  reports base, imu, battery
}
node twin drives arm, base { publishes /raw }
node source { publishes /in }
relate /odom.x ~ /odom.y
relate /raw.x ~ /odom.x
relate I(/odom.x) ~ /in.v
interval /in.v ~ /raw.x within 0.5
"""


def test_corner_cases_of_section_3() -> None:
    model = parse_ram(CORNERS, "corners.ram")
    data = check_model_yaml(
        emit_model_yaml(compile_model(model), EmitOptions()), model_to_json(model)
    )
    got = rule_set(data["rules"])
    # 2: only switchable driven hardware; affected_by inputs as ok(...)
    assert (frozenset({"NAB(driver)", "NAB(base)", "ok(in)"}), "ok(odom)") in got
    assert (frozenset({"NAB(twin)", "NAB(arm)", "NAB(base)"}), "ok(raw)") in got
    # 5: NAB(d) only for declared hardware, switchable or not
    assert (frozenset({"NAB(driver)", "NAB(imu)"}), "ok(imu)") in got
    assert (frozenset({"NAB(driver)"}), "ok(battery)") in got
    # 6: n1 = n2 gives one NAB; a regular topic adds its ok(...) once
    assert (frozenset({"NAB(driver)", "ok(odom)"}), "matched(odom,x,odom,y)") in got
    # 6: one clause per pair of publishers (/raw has two)
    heads = [h for _, h in got if h == "matched(raw,x,odom,x)"]
    assert len(heads) == 2
    assert (frozenset({"NAB(source)", "NAB(twin)"}), "equal(in,v,raw,x)") in got
    # 6: an integrated side is the field argument I_<field>, in the clauses and the props
    integrated = (frozenset({"NAB(driver)", "NAB(source)", "ok(odom)"}), "matched(odom,I_x,in,v)")
    assert integrated in got
    assert "matched(odom,I_x,in,v)" in data["props"]
    assert parse_atom("matched(odom,I_x,in,v)").args == ("odom", "I_x", "in", "v")
    # non-switchable hardware that nobody reports is no component
    assert "NAB(imu)" in {a for body, _ in got for a in body}
    assert not any(h == "on(imu)" for _, h in got)


# --- random valid models ---------------------------------------------------------------------


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(models())
def test_random_models_hold_exactly_the_contract_clauses(model: Any) -> None:
    compiled = compile_model(model)
    doc = model_to_json(model)
    check_model_yaml(emit_model_yaml(compiled, EmitOptions()), doc)
    assert set(compiled.components) == reference_comps(doc)


# --- regressions found by the random models -------------------------------------------------


def _compile_text(text: str) -> tuple[Any, dict[str, Any]]:
    model = parse_ram(text, "r.ram")
    compiled = compile_model(model)
    data = check_model_yaml(emit_model_yaml(compiled, EmitOptions()), model_to_json(model))
    return compiled, data


def test_regular_topic_without_publisher_compiles() -> None:
    """Its GObs reports ok(t) (§2), though no clause of §3 derives it."""
    _, data = _compile_text("robot r\ntopic /ext @ 5 Hz\nnode n { subscribes /ext }\n")
    assert "ok(ext)" in data["props"]
    assert not [r for r in data["rules"] if parse_rule(r)[1] == "ok(ext)"]


def test_device_reported_by_two_nodes() -> None:
    compiled, data = _compile_text(
        "robot r\nhardware laser\ntopic /scan\n"
        "node a drives laser { publishes /scan\nreports laser }\n"
        "node b { subscribes /scan\nreports laser }\n"
    )
    assert [o.kind for o in compiled.observers].count("DObs") == 1
    assert data["props"].count("ok(laser)") == 1
    heads = [parse_rule(r) for r in data["rules"]]
    assert sorted(sorted(b) for b, h in heads if h == "ok(laser)") == [
        ["NAB(a)", "NAB(laser)"],
        ["NAB(b)", "NAB(laser)"],
    ]


def test_pair_on_one_topic_with_two_publishers_has_no_duplicate_clause() -> None:
    _, data = _compile_text(
        "robot r\ntopic /p { x, y }\nnode a { publishes /p }\nnode b { publishes /p }\n"
        "relate /p.x ~ /p.y\n"
    )
    bodies = [sorted(b) for b, h in map(parse_rule, data["rules"]) if h == "matched(p,x,p,y)"]
    assert sorted(bodies) == [["NAB(a)"], ["NAB(a)", "NAB(b)"], ["NAB(b)"]]
