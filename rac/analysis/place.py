"""Observer placement: the cheapest added observers that make the detectable faults isolable.

**Candidates.**  A GObs on each published topic without a rate (but one a learned model has
without a rate: the recording found it irregular), a PObs on each node without a
CPU (else memory) limit, a DObs for each device a node drives and does not report (when the
device is already a component), and from a learned model its rates, limits, relations and
intervals (BiQObs/IObs pairs the model lacks).

**The program.**  One 0/1 variable per candidate j with cost w_j.  Each requirement is a set
A_k of candidates, at least one of which must be chosen:

- *covering*: an undetected fault c, and every candidate whose atom goes bad under c while the
  healthy model derives it;
- *separating*: a detected fault c with another single-fault candidate d, and every candidate
  whose atom goes bad under c while d alone abnormal still derives it (so {d} contradicts c's
  observations).

Minimise Σ w_j x_j subject to Σ_{j∈A_k} x_j ≥ 1.  Its LP relaxation (0 ≤ x ≤ 1) is solved with
clarabel; its optimum is a lower bound on any placement.  The LP solution is rounded (largest
x first until every requirement holds), redundant choices are dropped (dearest first), and the
result is checked by analysing the patched model; requirements that appear only then are
added greedily (most requirements met per cost).  With ``budget``, the program instead covers
as many requirements as the budget allows (the LP then bounds that number from above).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import clarabel
import networkx as nx
import numpy as np

from rac.analysis.analyze import Analysis, analyze, analyzer_for, cone, flow_graph
from rac.diagnosis.engine import Index
from rac.diagnosis.modes import truth_model
from rac.diagnosis.theory import Literal, Theory, theory_of
from rac.errors import Diagnostic, RacError
from rac.ir import FieldRef, Interval, Limits, Model, Name, Related
from rac.logic import Atom, mangle
from rac.pipeline import compile_model

PLACEHOLDER_RATE_HZ = 10.0
PLACEHOLDER_CPU = 100.0  # percent: a PObs that only says the node is alive and within a core
DEFAULT_COSTS = {"GObs": 1.0, "PObs": 1.0, "DObs": 1.0, "BiQObs": 1.0, "IObs": 1.0}

Cond = tuple[str, str, str]  # ("nab", component, role) or ("atom", predicate, arg-string)


@dataclass(frozen=True, slots=True)
class Candidate:
    kind: str
    key: str  # what it watches: "/topic", "node cpu", "node reports dev", "/a.x ~ /b.y"
    clauses: tuple[tuple[Cond, ...], ...]  # its atom holds when one of these holds
    cost: float
    value: float | None = None  # the rate, limit or interval bound to write, when known
    learned: bool = False

    @property
    def name(self) -> str:
        return f"{self.kind} {self.key}"


@dataclass(frozen=True, slots=True)
class Requirement:
    fault: str
    other: str | None  # None: covering (detect the fault); else separate it from `other`
    options: tuple[int, ...]  # candidate indices

    def describe(self) -> str:
        if self.other is None:
            return f"detects {self.fault}"
        return f"tells {self.fault} from {self.other}"


@dataclass(frozen=True, slots=True)
class Placement:
    mode: str
    candidates: tuple[Candidate, ...]
    chosen: tuple[int, ...]
    requirements: tuple[Requirement, ...]
    unresolvable: tuple[Requirement, ...]  # no candidate meets them
    lp_bound: float  # minimum cost of the LP relaxation (or max requirements under a budget)
    cost: float
    budget: float | None
    before: Analysis
    after: Analysis
    patched: Model

    def resolves(self, j: int) -> tuple[Requirement, ...]:
        return tuple(r for r in self.requirements if j in r.options)


# --- candidates -------------------------------------------------------------------------


def _ok_cond(topic: str) -> Cond:
    return ("atom", "ok", mangle(topic))


def _pair_clauses(model: Model, a: FieldRef, b: FieldRef) -> tuple[tuple[Cond, ...], ...]:
    publishers = model.publishers()
    regular = {t.name.value for t in model.topics if t.regular}
    observed = [_ok_cond(t) for t in dict.fromkeys((a.topic, b.topic)) if t in regular]
    out = []
    for n1 in publishers.get(a.topic, ()):
        for n2 in publishers.get(b.topic, ()):
            nabs = dict.fromkeys([("nab", mangle(n1), "out"), ("nab", mangle(n2), "out")])
            out.append((*nabs, *observed))
    return tuple(out)


def candidates(
    model: Model, learned: Model | None = None, costs: Mapping[str, float] | None = None
) -> tuple[Candidate, ...]:
    table = {**DEFAULT_COSTS, **(costs or {})}

    def cost(kind: str, key: str) -> float:
        return float(table.get(f"{kind} {key}", table.get(key, table.get(kind, 1.0))))

    publishers = model.publishers()
    learned_topics = learned.topic_by_name() if learned else {}
    learned_nodes = learned.node_by_name() if learned else {}
    found: list[Candidate] = []
    for topic in model.topics:
        t = topic.name.value
        if topic.regular or t not in publishers:
            continue
        if t in learned_topics and learned_topics[t].rate_hz is None:
            continue  # the recording found no steady rate: a GObs would report false faults
        rate = learned_topics[t].rate_hz if t in learned_topics else None
        found.append(
            Candidate("GObs", t, ((_ok_cond(t),),), cost("GObs", t), rate, learned=rate is not None)
        )
    for node in model.nodes:
        n = node.name.value
        prop = "cpu" if node.limits.cpu is None else "mem" if node.limits.mem is None else None
        if prop is None:
            continue
        limit = learned_nodes[n].limits if n in learned_nodes else Limits()
        value = limit.cpu if prop == "cpu" else limit.mem
        key = f"{n} {prop}"
        found.append(
            Candidate(
                "PObs",
                key,
                ((("nab", mangle(n), "run"),),),
                cost("PObs", key),
                None if value is None else float(value),
                learned=value is not None,
            )
        )
    components = set(compile_model(model).components)
    for node in model.nodes:
        reported = {d.value for d in node.diagnostics}
        for h in node.drives:
            if h.value in reported or mangle(h.value) not in components:
                continue
            key = f"{node.name.value} reports {h.value}"
            clause = (("nab", mangle(node.name.value), "rep"), ("nab", mangle(h.value), "out"))
            found.append(Candidate("DObs", key, (clause,), cost("DObs", key)))
    if learned is not None:
        have = {(r.a.text, r.b.text) for r in model.related}
        have |= {(b, a) for a, b in have}
        have_iv = {(i.a.text, i.b.text) for i in model.intervals}
        have_iv |= {(b, a) for a, b in have_iv}
        for r in learned.related:
            if (r.a.text, r.b.text) in have or not _pair_ok(model, r.a, r.b):
                continue
            key = f"{r.a.text} ~ {r.b.text}"
            clauses = _pair_clauses(model, r.a, r.b)
            found.append(Candidate("BiQObs", key, clauses, cost("BiQObs", key), learned=True))
        for iv in learned.intervals:
            if (iv.a.text, iv.b.text) in have_iv or not _pair_ok(model, iv.a, iv.b):
                continue
            key = f"{iv.a.text} ~ {iv.b.text}"
            clauses = _pair_clauses(model, iv.a, iv.b)
            found.append(
                Candidate("IObs", key, clauses, cost("IObs", key), iv.max_diff, learned=True)
            )
    return tuple(found)


def _pair_ok(model: Model, a: FieldRef, b: FieldRef) -> bool:
    publishers = model.publishers()
    return a.topic in publishers and b.topic in publishers and a.text != b.text


# --- requirements -----------------------------------------------------------------------


class _States:
    """Which atoms hold under each fault (truth) and with each component abnormal (theory)."""

    def __init__(self, theory: Theory, mode: str, cands: Sequence[Candidate]) -> None:
        self.analyzer = analyzer_for(theory)
        self.truth = truth_model(theory)
        self.mode = mode
        self.cands = cands
        graph = flow_graph(self.truth.model)
        self.below = {
            j: {t[2:] for t in nx.descendants(graph, "t:" + mangle(c.key))}
            for j, c in enumerate(cands)
            if c.kind == "GObs" and "t:" + mangle(c.key) in graph
        }
        self.cone = {c: set(cone(graph, c)) for c in theory.components}
        # Candidate conditions as atom ids of each index (-1: an atom the index lacks).
        self._truth_ids = [self._compile(c, self.truth.index) for c in cands]
        self._diag_ids = [self._compile(c, self.analyzer.index) for c in cands]
        self._truth_memo: dict[str, tuple[frozenset[str], set[int]]] = {}
        self._diag_memo: dict[str | None, set[int]] = {}

    @staticmethod
    def _compile(cand: Candidate, index: Index) -> list[list[tuple[str, str, int]]]:
        out = []
        for clause in cand.clauses:
            conds = []
            for kind, a, b in clause:
                if kind == "nab":
                    conds.append(("nab", f"{a}@{b}", -1))
                else:
                    found = index.number((a, tuple(b.split(","))))
                    conds.append(("atom", a, -1 if found is None else found))
            out.append(conds)
        return out

    @staticmethod
    def _true_ids(index: Index, bad: frozenset[str], strong: bool) -> set[int]:
        base, _ = index.base(())
        why = index.run(base, index.assignment(bad, strong=strong), stop=False).why
        return {i for i, v in enumerate(base.true) if v} | set(why)

    def holds_truth(self, j: int, fault: str) -> bool:
        hit = self._truth_memo.get(fault)
        if hit is None:
            broken = self.truth.broken(self.mode, (fault,))
            true = self._true_ids(self.truth.index, broken, False)
            hit = self._truth_memo[fault] = (broken, true)
        broken, true = hit
        return any(
            all(name not in broken if kind == "nab" else i in true for kind, name, i in clause)
            for clause in self._truth_ids[j]
        )

    def holds_diag(self, j: int, abnormal: str | None) -> bool:
        true = self._diag_memo.get(abnormal)
        if true is None:
            bad = frozenset() if abnormal is None else frozenset((abnormal,))
            true = self._diag_memo[abnormal] = self._true_ids(self.analyzer.index, bad, True)
        return any(
            all(
                name.split("@")[0] != abnormal if kind == "nab" else i in true
                for kind, name, i in clause
            )
            for clause in self._diag_ids[j]
        )


def _exonerating(states: _States, fault: str, other: str, good: list[int]) -> list[int]:
    """GObs candidates whose *good* report under ``fault`` rules ``other`` out.

    Observed ok, a topic feeds the clauses downstream of it: with ``other`` abnormal they may
    then derive an atom the fault makes bad.  That needs a topic ``other`` can reach (else
    its ok is derived anyway) and a symptom below it.
    """
    analyzer = states.analyzer
    obs = list(analyzer.observe(states.mode, (fault,)))
    symptoms = {lit.atom.args[0] for lit in obs if not lit.positive and lit.atom.args}
    reach = states.cone.get(other, set())
    out = []
    index = analyzer.index
    for j in good:
        below = states.below.get(j)
        topic = mangle(states.cands[j].key)
        if below is None or topic not in reach or not below & symptoms:
            continue
        literal = Literal(Atom("ok", (topic,)), True, analyzer.theory.neg_prefix)
        base, clash = index.base([*obs, literal])
        if clash or index.run(base, index.assignment(frozenset((other,)), strong=True)).clash:
            out.append(j)
    return out


def requirements(
    states: _States, analysis: Analysis, cands: Sequence[Candidate]
) -> tuple[list[Requirement], list[Requirement]]:
    met: list[Requirement] = []
    unmet: list[Requirement] = []
    for fault in analysis.faults:
        c = fault.component
        holds = [states.holds_truth(j, c) for j in range(len(cands))]
        bad = [j for j in range(len(cands)) if not holds[j]]
        good = [j for j in range(len(cands)) if holds[j]]
        if not fault.detectable:
            options = tuple(j for j in bad if states.holds_diag(j, None))
            (met if options else unmet).append(Requirement(c, None, options))
            continue
        if not fault.found:
            continue  # no observer makes {c} explain what c does: reported, not placed
        for d in fault.candidates:
            if d == c:
                continue
            direct = [j for j in bad if states.holds_diag(j, d)]
            options = tuple(sorted({*direct, *_exonerating(states, c, d, good)}))
            (met if options else unmet).append(Requirement(c, d, options))
    return met, unmet


# --- the LP relaxation (clarabel) ---------------------------------------------------------


@dataclass(frozen=True, slots=True)
class CscMatrix:
    """A sparse matrix in compressed sparse column form, in the attributes clarabel reads."""

    shape: tuple[int, int]
    indptr: np.ndarray
    indices: np.ndarray
    data: np.ndarray
    has_canonical_format: bool = True

    @staticmethod
    def from_columns(rows: int, columns: Sequence[Mapping[int, float]]) -> CscMatrix:
        indptr, indices, data = [0], [], []
        for column in columns:
            for r in sorted(column):
                indices.append(r)
                data.append(column[r])
            indptr.append(len(indices))
        return CscMatrix(
            (rows, len(columns)),
            np.asarray(indptr, dtype=np.int64),
            np.asarray(indices, dtype=np.int64),
            np.asarray(data, dtype=np.float64),
        )


def _solve_lp(
    objective: Sequence[float], columns: Sequence[Mapping[int, float]], rhs: Sequence[float]
) -> np.ndarray:
    """min c·x subject to A x ≤ b (every row a nonnegative slack), with clarabel."""
    n = len(objective)
    a = CscMatrix.from_columns(len(rhs), columns)
    p = CscMatrix.from_columns(n, [{} for _ in range(n)])
    settings = clarabel.DefaultSettings()
    settings.verbose = False
    solver = clarabel.DefaultSolver(
        p, list(objective), a, list(rhs), [clarabel.NonnegativeConeT(len(rhs))], settings
    )
    solution = solver.solve()
    if str(solution.status) not in ("Solved", "AlmostSolved"):
        raise RacError([Diagnostic("RAC063", f"the LP relaxation failed: {solution.status}")])
    return np.asarray(solution.x, dtype=np.float64)


def lp_cover(reqs: Sequence[Requirement], costs: Sequence[float]) -> tuple[float, np.ndarray]:
    """min Σ w x, Σ_{j∈A_k} x_j ≥ 1, 0 ≤ x ≤ 1."""
    n = len(costs)
    if not reqs:
        return 0.0, np.zeros(n)
    m = len(reqs)
    columns: list[dict[int, float]] = [{} for _ in range(n)]
    for k, r in enumerate(reqs):
        for j in r.options:
            columns[j][k] = -1.0
    for j in range(n):
        columns[j][m + j] = -1.0  # -x ≤ 0
        columns[j][m + n + j] = 1.0  # x ≤ 1
    rhs = [-1.0] * m + [0.0] * n + [1.0] * n
    x = _solve_lp(costs, columns, rhs)
    return float(np.dot(costs, x)), np.clip(x, 0.0, 1.0)


def lp_budget(
    reqs: Sequence[Requirement], costs: Sequence[float], budget: float
) -> tuple[float, np.ndarray]:
    """max Σ y_k, y_k ≤ Σ_{j∈A_k} x_j, Σ w x ≤ B, 0 ≤ x, y ≤ 1; returns (max Σ y, x)."""
    n, m = len(costs), len(reqs)
    columns: list[dict[int, float]] = [{} for _ in range(n + m)]
    row = 0
    for k, r in enumerate(reqs):
        columns[n + k][row] = 1.0
        for j in r.options:
            columns[j][row] = -1.0
        row += 1
    for j in range(n):
        columns[j][row] = costs[j]
    row += 1
    for v in range(n + m):
        columns[v][row] = -1.0
        columns[v][row + 1] = 1.0
        row += 2
    rhs = [0.0] * m + [budget] + [0.0, 1.0] * (n + m)
    x = _solve_lp([0.0] * n + [-1.0] * m, columns, rhs)
    return float(np.sum(np.clip(x[n:], 0.0, 1.0))), np.clip(x[:n], 0.0, 1.0)


# --- rounding and improvement -------------------------------------------------------------


def _satisfied(reqs: Sequence[Requirement], chosen: set[int]) -> int:
    return sum(1 for r in reqs if chosen.intersection(r.options))


def round_cover(reqs: Sequence[Requirement], costs: Sequence[float], x: np.ndarray) -> set[int]:
    chosen: set[int] = set()
    for j in sorted(range(len(costs)), key=lambda j: (-x[j], costs[j], j)):
        if all(chosen.intersection(r.options) for r in reqs):
            break
        if any(j in r.options and not chosen.intersection(r.options) for r in reqs):
            chosen.add(j)
    for j in sorted(chosen, key=lambda j: (-costs[j], -j)):  # drop what is redundant
        rest = chosen - {j}
        if all(rest.intersection(r.options) for r in reqs):
            chosen = rest
    return chosen


def greedy_add(
    reqs: Sequence[Requirement], costs: Sequence[float], chosen: set[int], budget: float | None
) -> set[int]:
    chosen = set(chosen)
    while True:
        spent = sum(costs[j] for j in chosen)
        open_reqs = [r for r in reqs if not chosen.intersection(r.options)]
        best, best_ratio = None, 0.0
        for j in range(len(costs)):
            if j in chosen or (budget is not None and spent + costs[j] > budget + 1e-9):
                continue
            gain = sum(1 for r in open_reqs if j in r.options)
            ratio = gain / max(costs[j], 1e-9)
            if gain and ratio > best_ratio:
                best, best_ratio = j, ratio
        if best is None:
            return chosen
        chosen.add(best)


# --- the patched model --------------------------------------------------------------------


def patch_model(
    model: Model,
    cands: Sequence[Candidate],
    chosen: Sequence[int],
    notes: Mapping[int, tuple[str, ...]] | None = None,
    measured_rates_only: bool = False,
) -> Model:
    """The model with the chosen observers added (``notes``: comments to put above each);
    ``measured_rates_only``: a new GObs without a learned rate gets none (the patch a user
    reads), else a placeholder rate (the model the analysis counts)."""
    notes = notes or {}
    topics = list(model.topics)
    nodes = list(model.nodes)
    related = list(model.related)
    intervals = list(model.intervals)
    by_topic = {t.name.value: k for k, t in enumerate(topics)}
    by_node = {n.name.value: k for k, n in enumerate(nodes)}
    for j in chosen:
        cand = cands[j]
        comment = notes.get(j, ())
        if cand.kind == "GObs":
            # The analysis counts the GObs with a placeholder rate; the patch written for
            # the user has no made-up rate: on an on-demand topic (a joystick, /cmd_vel) it
            # would make the GObs report false faults, so annotate says to measure it.
            k = by_topic[cand.key]
            rate = cand.value
            if rate is None and not measured_rates_only:
                rate = PLACEHOLDER_RATE_HZ
            topics[k] = dataclasses.replace(
                topics[k], rate_hz=rate, comments=(*topics[k].comments, *comment)
            )
        elif cand.kind == "PObs":
            name, prop = cand.key.split(" ")
            k = by_node[name]
            node = nodes[k]
            value = cand.value if cand.value is not None else None
            if prop == "cpu":
                limits = dataclasses.replace(
                    node.limits, cpu=value if value is not None else PLACEHOLDER_CPU
                )
            else:
                mem = int(value) if value is not None else 1 << 30
                limits = dataclasses.replace(node.limits, mem=mem)
            nodes[k] = dataclasses.replace(node, limits=limits, comments=(*node.comments, *comment))
        elif cand.kind == "DObs":
            name, _, device = cand.key.split(" ")
            k = by_node[name]
            node = nodes[k]
            nodes[k] = dataclasses.replace(
                node,
                diagnostics=(*node.diagnostics, Name(device)),
                comments=(*node.comments, *comment),
            )
        else:
            left, right = cand.key.split(" ~ ")
            a, b = FieldRef.parse(left), FieldRef.parse(right)
            for ref in (a, b):
                k = by_topic[ref.topic]
                if ref.field not in {f.value for f in topics[k].fields}:
                    topics[k] = dataclasses.replace(
                        topics[k], fields=(*topics[k].fields, Name(ref.field))
                    )
            if cand.kind == "BiQObs":
                related.append(Related(a, b, comments=comment))
            else:
                assert cand.value is not None
                intervals.append(Interval(a, b, cand.value, comments=comment))
    return dataclasses.replace(
        model,
        topics=tuple(topics),
        nodes=tuple(nodes),
        related=tuple(related),
        intervals=tuple(intervals),
        source=None,
    )


def annotate(
    cands: Sequence[Candidate], chosen: Sequence[int], reqs: Sequence[Requirement], mode: str
) -> dict[int, tuple[str, ...]]:
    """One comment per chosen observer: the ambiguities it resolves."""
    notes: dict[int, tuple[str, ...]] = {}
    for j in chosen:
        met = [r.describe() for r in reqs if j in r.options]
        what = "; ".join(met[:4]) + ("; …" if len(met) > 4 else "")
        line = f"racc place ({mode}): {cands[j].name} {what or 'adds an observation'}"
        extra: tuple[str, ...] = ()
        if not cands[j].learned and cands[j].kind == "GObs":
            topic = cands[j].key
            extra = (
                f"racc place: no rate written: if {topic} is periodic, measure its rate "
                "(racc record, then racc learn) and add '@ RATE Hz'; an on-demand topic "
                "must have none (its frequency observer would report false faults)",
            )
        elif not cands[j].learned and cands[j].kind == "PObs":
            extra = ("racc place: the value is a placeholder; measure it (racc learn)",)
        notes[j] = (line, *extra)
    return notes


# --- the whole placement ------------------------------------------------------------------


def place(
    theory: Theory,
    mode: str = "output",
    budget: float | None = None,
    learned: Model | None = None,
    costs: Mapping[str, float] | None = None,
    rounds: int = 4,
    before: Analysis | None = None,
) -> Placement:
    """Place observers for ``mode``; ``before`` is the model's analysis when already made."""
    model = theory.model
    if model is None:
        raise RacError([Diagnostic("RAC060", "racc place needs a .ram or .json model")])
    if before is None or before.mode != mode:
        before = analyze(theory, mode, name=model.path)
    cands = candidates(model, learned, costs)
    weights = [c.cost for c in cands]
    reqs, unmet = requirements(_States(theory, mode, cands), before, cands)
    bound, chosen = _first_choice(reqs, weights, budget)
    all_reqs, chosen, bound, after = _refine(
        model, mode, cands, budget, reqs, chosen, bound, rounds, before
    )
    notes = annotate(cands, sorted(chosen), all_reqs, mode)
    patched = patch_model(model, cands, sorted(chosen), notes, measured_rates_only=True)
    cost = sum(weights[j] for j in chosen)
    return Placement(
        mode,
        cands,
        tuple(sorted(chosen)),
        tuple(all_reqs),
        tuple(unmet),
        bound,
        cost,
        budget,
        before,
        after,
        patched,
    )


def _first_choice(
    reqs: Sequence[Requirement], weights: Sequence[float], budget: float | None
) -> tuple[float, set[int]]:
    """The LP's bound and its rounding: a cover of every requirement, or within ``budget``
    the observers the LP takes most of, then greedily the best of the rest."""
    if budget is None:
        bound, x = lp_cover(reqs, weights)
        return bound, round_cover(reqs, weights, x)
    bound, x = lp_budget(reqs, weights, budget)
    chosen: set[int] = set()
    for j in sorted(range(len(weights)), key=lambda j: (-x[j], weights[j], j)):
        spent = sum(weights[i] for i in chosen)
        if x[j] > 0.5 and spent + weights[j] <= budget + 1e-9:
            chosen.add(j)
    return bound, greedy_add(reqs, weights, chosen, budget)


def _refine(
    model: Model,
    mode: str,
    cands: Sequence[Candidate],
    budget: float | None,
    reqs: Sequence[Requirement],
    chosen: set[int],
    bound: float,
    rounds: int,
    before: Analysis,
) -> tuple[list[Requirement], set[int], float, Analysis]:
    """Up to ``rounds`` times: analyse the model with the chosen observers, add the
    requirements they reveal (a fault they detect but do not yet tell apart) and solve again.
    Returns every requirement, the choice, the LP's bound and the analysis with the choice."""
    weights = [c.cost for c in cands]
    all_reqs = list(reqs)
    after = before
    patched = model
    for _ in range(rounds):
        patched = patch_model(model, cands, sorted(chosen))
        patched_theory = _theory_of(patched)
        after = analyze(patched_theory, mode, name=model.path)
        open_faults = dataclasses.replace(
            after, faults=tuple(f for f in after.faults if not f.isolable)
        )
        new, _ = requirements(_States(patched_theory, mode, cands), open_faults, cands)
        fresh = [r for r in new if not chosen.intersection(r.options) and r not in all_reqs]
        if not fresh:
            break
        all_reqs.extend(fresh)
        if budget is None:
            bound, x = lp_cover(all_reqs, weights)
            chosen = round_cover(all_reqs, weights, x)
        else:
            chosen = greedy_add(all_reqs, weights, chosen, budget)
    if patch_model(model, cands, sorted(chosen)) != patched:  # chosen again after the check
        after = analyze(_theory_of(patch_model(model, cands, sorted(chosen))), mode)
    return all_reqs, chosen, bound, after


def _theory_of(model: Model) -> Theory:
    return theory_of(compile_model(model))


def exact_cover_cost(reqs: Sequence[Requirement], costs: Sequence[float]) -> float:
    """The optimum of the covering program by exhaustive search (for tests, small n)."""
    import itertools

    relevant = sorted({j for r in reqs for j in r.options})
    best = math.inf
    for size in range(len(relevant) + 1):
        for subset in itertools.combinations(relevant, size):
            s = set(subset)
            if all(s.intersection(r.options) for r in reqs):
                best = min(best, sum(costs[j] for j in s))
    return 0.0 if best is math.inf and not reqs else best


def atom_of(cand: Candidate) -> Atom:
    """The atom the candidate observer reports (for messages)."""
    if cand.kind == "GObs":
        return Atom("ok", (mangle(cand.key),))
    if cand.kind == "PObs":
        name, prop = cand.key.split(" ")
        return Atom("ok", (mangle(name), prop))
    if cand.kind == "DObs":
        return Atom("ok", (mangle(cand.key.split(" ")[2]),))
    left, right = cand.key.split(" ~ ")
    a, b = FieldRef.parse(left), FieldRef.parse(right)
    pred = "matched" if cand.kind == "BiQObs" else "equal"
    return Atom(pred, (mangle(a.topic), mangle(a.field), mangle(b.topic), mangle(b.field)))
