"""Feedback loops: the loop rule, against a brute-force semantics of the data flow.

The reference works on the model, not on clauses: with the components ``bad`` abnormal, the
topics that must be ok are the greatest fixed point of "the topic is observed ok, or some
publication of it has a healthy node, healthy switchable hardware and ok inputs" (a fault never
comes out of nothing: a bad topic needs a bad component, or a bad input, upstream).  The
observations are consistent with ``bad`` when no topic observed bad must be ok.  Minimal
consistent sets are the diagnoses.
"""

from __future__ import annotations

import random
from itertools import combinations
from pathlib import Path

import pytest
from goldens import assert_golden

from rac.diagnosis import Literal, diagnose
from rac.diagnosis.theory import Theory
from rac.errors import RacError, Severity
from rac.ir import Hardware, Model, Name, Node, Publication, Topic
from rac.load.theory import load_theory
from rac.logic import Atom, mangle
from rac.passes.loops import find_loops, strongly_connected
from rac.pipeline import compile_model
from rac.targets import EmitOptions
from rac.targets.model_yaml import emit_model_yaml

GOLDEN = Path(__file__).parent.parent / "golden" / "loops"
LOOP_RAM = Path(__file__).parent.parent / "models" / "odometry_loop.ram"


def _theory(model: Model) -> Theory:
    compiled = compile_model(model)
    return Theory(compiled.rbm, compiled.props, compiled.components, model=model)


def test_all_healthy_loop_derives_its_topics() -> None:
    theory = load_theory(str(LOOP_RAM))
    result = diagnose(theory, [Literal(Atom("ok", ("odom",)), False)])
    assert not result.consistent
    assert ("base_driver",) in result.diagnoses
    assert ("laser_scan_matching",) in result.diagnoses
    assert () not in result.diagnoses


def test_loop_note_names_the_loop() -> None:
    from rac.load.files import load_model

    compiled = compile_model(load_model(str(LOOP_RAM)))
    notes = [d for d in compiled.warnings if d.code == "RAC104"]
    assert len(notes) == 1 and notes[0].severity is Severity.NOTE
    assert "/odom" in notes[0].message and "laser_scan_matching" in notes[0].message


def test_loop_rules_golden(update_goldens: bool) -> None:
    from rac.load.files import load_model

    compiled = compile_model(load_model(str(LOOP_RAM)))
    text = emit_model_yaml(compiled, EmitOptions())
    assert_golden(GOLDEN / "odometry_loop.model.yaml", text, update_goldens)


# --- brute force ------------------------------------------------------------------------


def _random_model(rng: random.Random) -> Model | None:
    n_topics = rng.randint(2, 4)
    topics = [f"/t{k}" for k in range(n_topics)]
    hw = Hardware(Name("dev"), switchable=True, channel=1)
    nodes = []
    for k in range(rng.randint(2, 4)):
        outs = rng.sample(topics, rng.randint(1, 2))
        subs = sorted(set(rng.sample(topics, rng.randint(0, 2))) - set(outs))
        pubs = tuple(
            Publication(Name(t), tuple(Name(i) for i in subs if rng.random() < 0.8)) for t in outs
        )
        drives = (Name("dev"),) if k == 0 else ()
        nodes.append(
            Node(Name(f"n{k}"), drives, tuple(Name(s) for s in subs), pubs, diagnostics=())
        )
    decl = tuple(
        Topic(Name(t), "std_msgs/Empty", (), 10.0 if rng.random() < 0.6 else None) for t in topics
    )
    model = Model(Name("random"), (hw,), decl, tuple(nodes))
    try:
        compile_model(model)
    except RacError:
        return None
    return model


def _must_ok(model: Model, bad: frozenset[str], pos: set[str]) -> set[str]:
    """The topics every world consistent with ``bad`` and ``pos`` makes ok."""
    switchable = {h.name.value for h in model.hardware if h.switchable}
    pubs = [
        (n.name.value, [h.value for h in n.drives if h.value in switchable], p)
        for n in model.nodes
        for p in n.publishes
    ]

    def healthy(node: str, hw: list[str]) -> bool:
        return node not in bad and not any(h in bad for h in hw)

    # Greatest fixed point: start from everything, drop what nothing healthy can explain.
    ok = {p.topic.value for _, _, p in pubs} | pos
    changed = True
    while changed:
        changed = False
        for t in sorted(ok - pos):
            if not any(
                p.topic.value == t and healthy(n, hw) and all(i.value in ok for i in p.affected_by)
                for n, hw, p in pubs
            ):
                ok.discard(t)
                changed = True
    return ok


def _consistent(model: Model, bad: frozenset[str], obs: list[tuple[str, bool]]) -> bool:
    pos = {t for t, v in obs if v}
    world = _must_ok(model, bad, pos)
    return not any(t in world for t, v in obs if not v)


def _brute_diagnoses(
    model: Model, comps: tuple[str, ...], obs: list[tuple[str, bool]]
) -> list[tuple[str, ...]]:
    found: list[frozenset[str]] = []
    for size in range(len(comps) + 1):
        for combo in combinations(comps, size):
            delta = frozenset(combo)
            if any(d <= delta for d in found):
                continue
            if _consistent(model, delta, obs):
                found.append(delta)
    return sorted((tuple(sorted(d)) for d in found), key=lambda d: (len(d), d))


@pytest.mark.parametrize("seed", range(150))
def test_loop_rule_matches_brute_force(seed: int) -> None:
    rng = random.Random(seed)
    model = None
    while model is None or not find_loops(model):
        model = _random_model(rng)
    theory = _theory(model)
    by_arg = {mangle(t.name.value): t.name.value for t in model.topics}
    published = set(model.publishers())
    for _ in range(6):
        chosen = rng.sample(sorted(published), rng.randint(1, len(published)))
        obs = [(t, rng.random() < 0.4) for t in chosen]
        literals = [Literal(Atom("ok", (mangle(t),)), v) for t, v in obs]
        got = diagnose(theory, literals).diagnoses
        assert got == tuple(_brute_diagnoses(model, theory.components, obs)), (
            [str(c) for c in theory.clauses],
            obs,
            by_arg,
        )


@pytest.mark.parametrize("seed", range(60))
def test_strongly_connected_matches_networkx(seed: int) -> None:
    """Our Tarjan against networkx's components on random graphs, self-loops and
    repeated edges included."""
    import networkx as nx

    rng = random.Random(seed)
    size = rng.randint(1, 40)
    graph: dict[str, list[str]] = {str(v): [] for v in range(size)}
    for _ in range(rng.randint(0, 90)):
        graph[str(rng.randrange(size))].append(str(rng.randrange(size)))
    reference: nx.DiGraph = nx.DiGraph()
    reference.add_nodes_from(graph)
    reference.add_edges_from((a, b) for a, succ in graph.items() for b in succ)
    ours = sorted(sorted(c) for c in strongly_connected(graph))
    assert ours == sorted(sorted(c) for c in nx.strongly_connected_components(reference))
