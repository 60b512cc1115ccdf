"""Diagnosability: which faults the observers detect, and which they tell apart.

For every component c that can fail in a mode, the truth model (``rac.diagnosis.modes``)
gives the observers' report; the diagnosis theory then decides, under the single-fault
assumption, which components {d} that can fail in the same mode are consistent with that
report: c's *candidates* (in output mode, a node's wrong output is not blamed on its device:
the device is not a suspect of that mode; ``racc simulate`` shows the engine's full answer).  c is
detectable when the report contradicts the all-healthy assumption, and isolable when c is its
only candidate.  Components linked through candidates form *ambiguity groups*.

Checking every pair (c, d) with a propagation would cost n² runs; a cheap filter comes first.
{d} can only be consistent if no atom observed bad is derived with d alone abnormal, so each
d's derivable observables are computed once as a bit set, and only those d that pass get the
exact check (which also sees what the good observations derive).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence
from dataclasses import dataclass

import networkx as nx

from rac.diagnosis.engine import Index
from rac.diagnosis.modes import truth_model
from rac.diagnosis.result import compile_theory, diagnose
from rac.diagnosis.simulate import observable, predict
from rac.diagnosis.theory import Literal, Theory
from rac.ir import Model
from rac.logic import mangle


@dataclass(frozen=True, slots=True)
class FaultReport:
    component: str
    detectable: bool
    candidates: tuple[str, ...]  # single faults consistent with its observations, sorted
    symptoms: tuple[str, ...]  # the atoms observed bad
    cone: tuple[str, ...]  # the topics the fault can reach through the data flow

    @property
    def found(self) -> bool:
        return self.component in self.candidates

    @property
    def isolable(self) -> bool:
        return self.detectable and self.candidates == (self.component,)


@dataclass(frozen=True, slots=True)
class DoubleReport:
    pairs: int
    detected: int
    isolated: int
    ambiguous: tuple[tuple[str, str], ...]  # detected pairs that are not the only diagnosis


@dataclass(frozen=True, slots=True)
class Analysis:
    model: str
    mode: str
    faults: tuple[FaultReport, ...]
    groups: tuple[tuple[str, ...], ...]
    double: DoubleReport | None = None

    @property
    def detectable(self) -> int:
        return sum(f.detectable for f in self.faults)

    @property
    def isolable(self) -> int:
        return sum(f.isolable for f in self.faults)

    @property
    def detectable_pct(self) -> float:
        return 100.0 * self.detectable / len(self.faults) if self.faults else 100.0

    @property
    def isolable_pct(self) -> float:
        return 100.0 * self.isolable / len(self.faults) if self.faults else 100.0

    @property
    def mean_group(self) -> float:
        """Mean number of candidates of a detectable fault (1.0: every one is isolated)."""
        sizes = [len(f.candidates) for f in self.faults if f.detectable]
        return sum(sizes) / len(sizes) if sizes else 0.0


def flow_graph(model: Model) -> nx.DiGraph:
    """Hardware → driver, node → topic it publishes, input → output for ``from``.

    Names are mangled, with ``t:`` in front of topics (components and topics may share a
    name: a reported device is both).
    """
    graph: nx.DiGraph = nx.DiGraph()
    for node in model.nodes:
        n = mangle(node.name.value)
        graph.add_node(n, kind="node")
        for h in node.drives:
            graph.add_edge(mangle(h.value), n)
            graph.nodes[mangle(h.value)]["kind"] = "hardware"
        for pub in node.publishes:
            t = "t:" + mangle(pub.topic.value)
            graph.add_edge(n, t)
            graph.nodes[t]["kind"] = "topic"
            graph.add_edges_from(("t:" + mangle(i.value), t) for i in pub.affected_by)
    return graph


def cone(graph: nx.DiGraph, component: str) -> tuple[str, ...]:
    """The topics a fault of ``component`` can reach (its fault-propagation cone)."""
    if component not in graph:
        return ()
    reach = nx.descendants(graph, component)
    return tuple(sorted(t[2:] for t in reach if t.startswith("t:")))


class Analyzer:
    """The diagnosis theory of one model compiled once, for many fault reports."""

    def __init__(self, theory: Theory) -> None:
        self.theory = theory
        self.index: Index = compile_theory(theory)
        self.props = observable(theory)
        self.base0, _ = self.index.base(())
        self._derivable_memo: dict[str, int] = {}
        self._observed: dict[tuple[str, tuple[str, ...]], tuple[Literal, ...]] = {}

    def derivable(self, component: str) -> int:
        hit = self._derivable_memo.get(component)
        if hit is None:
            hit = self._derivable_memo[component] = self._derivable(frozenset((component,)))
        return hit

    def _derivable(self, bad: frozenset[str]) -> int:
        """Bit set of the props derived with ``bad`` abnormal and all else normal."""
        index = self.index
        why = index.run(self.base0, index.assignment(bad, strong=True), stop=False).why
        mask = 0
        for k, atom in enumerate(self.props):
            i = index.atom_id(atom)
            if i is not None and (self.base0.true[i] or i in why):
                mask |= 1 << k
        return mask

    def detects(self, observations: Sequence[Literal]) -> bool:
        """Whether ``observations`` contradict the all-healthy assumption."""
        index = self.index
        base, clash = index.base(observations)
        return bool(clash) or bool(
            index.run(base, index.assignment(frozenset(), strong=True)).clash
        )

    def candidates(
        self, observations: Sequence[Literal], universe: Sequence[str] | None = None
    ) -> tuple[bool, tuple[str, ...]]:
        """(detected, the single faults of ``universe`` consistent with ``observations``)."""
        index = self.index
        bad = 0
        for k, lit in enumerate(observations):
            if not lit.positive:
                bad |= 1 << k
        base, clash = index.base(observations)
        if clash:
            return True, ()
        detected = bool(index.run(base, index.assignment(frozenset(), strong=True)).clash)
        if not detected:
            return False, ()
        found = []
        for c in self.theory.components if universe is None else universe:
            if self.derivable(c) & bad:
                continue  # c alone abnormal still derives an atom observed bad
            if not index.run(base, index.assignment(frozenset((c,)), strong=True)).clash:
                found.append(c)
        return True, tuple(found)

    def observe(self, mode: str, faults: Sequence[str]) -> tuple[Literal, ...]:
        key = (mode, tuple(faults))
        hit = self._observed.get(key)
        if hit is None:
            if mode == "crash" and self.theory.model is None:
                hit = predict(self.theory, faults)
            else:
                hit = truth_model(self.theory).observe(mode, faults)
            self._observed[key] = hit
        return hit


_ANALYZERS: dict[int, Analyzer] = {}


def analyzer_for(theory: Theory) -> Analyzer:
    """One analyzer per theory object (kept for the last few), as ``compile_theory`` does."""
    hit = _ANALYZERS.get(id(theory))
    if hit is not None and hit.theory is theory:
        return hit
    if len(_ANALYZERS) >= 4:
        _ANALYZERS.pop(next(iter(_ANALYZERS)))
    analyzer = _ANALYZERS[id(theory)] = Analyzer(theory)
    return analyzer


def fault_components(theory: Theory, mode: str) -> tuple[str, ...]:
    if mode == "crash" and theory.model is None:
        return theory.components
    truth = truth_model(theory)
    return tuple(c for c in theory.components if truth.applies(mode, c))


def undetected(theory: Theory, modes: Sequence[str]) -> dict[str, tuple[str, ...]]:
    """Per component, the fault ``modes`` whose report no observer contradicts: the
    ``detected`` column of :func:`analyze`, without the isolation (one propagation a fault,
    where isolation costs one a candidate).  Components every mode detects are left out."""
    analyzer = analyzer_for(theory)
    missed: dict[str, list[str]] = {}
    for mode in modes:
        for c in fault_components(theory, mode):
            if not analyzer.detects(analyzer.observe(mode, (c,))):
                missed.setdefault(c, []).append(mode)
    return {c: tuple(ms) for c, ms in missed.items()}


def ambiguity_groups(faults: Sequence[FaultReport]) -> tuple[tuple[str, ...], ...]:
    graph: nx.Graph = nx.Graph()
    for f in faults:
        if f.detectable:
            graph.add_edges_from((f.component, d) for d in f.candidates if d != f.component)
    groups = (tuple(sorted(g)) for g in nx.connected_components(graph))
    return tuple(sorted(g for g in groups if len(g) > 1))


def analyze(
    theory: Theory, mode: str = "crash", double: bool = False, name: str = "model"
) -> Analysis:
    analyzer = analyzer_for(theory)
    graph = flow_graph(theory.model) if theory.model is not None else nx.DiGraph()
    reports = []
    universe = fault_components(theory, mode)
    for c in universe:
        obs = analyzer.observe(mode, (c,))
        detected, found = analyzer.candidates(obs, universe)
        symptoms = tuple(str(o) for o in obs if not o.positive)
        reports.append(FaultReport(c, detected, found, symptoms, cone(graph, c)))
    result = Analysis(name, mode, tuple(reports), ambiguity_groups(reports))
    if double:
        result = Analysis(name, mode, result.faults, result.groups, _double(analyzer, mode))
    return result


def _double(analyzer: Analyzer, mode: str) -> DoubleReport:
    """Every pair of faults: detected, and isolated (the pair is the only diagnosis of ≤ 2)."""
    comps = fault_components(analyzer.theory, mode)
    detected = isolated = 0
    ambiguous = []
    pairs = list(itertools.combinations(comps, 2))
    for pair in pairs:
        obs = analyzer.observe(mode, pair)
        result = diagnose(analyzer.theory, obs, max_card=2)
        if result.consistent:
            continue
        detected += 1
        if result.diagnoses == (pair,):
            isolated += 1
        else:
            ambiguous.append(pair)
    return DoubleReport(len(pairs), detected, isolated, tuple(ambiguous))
