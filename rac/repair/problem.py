"""makePlanningProblem (Algorithm 11, §7.1.2.1): the PDDL repair problem.

Objects are the components, typed by kind.  The initial state holds what Θ
says about ``running``/``on`` and, where Θ says nothing, the component's normal
state (a node running, a device on), plus ``bad``/``good`` from the diagnosis
and the static ``drives`` facts.  The goal is every component ``good``; in the
domain only the action that brings a component back to its normal state makes
it good.  Other observations (``ok``, ``matched``, …) do not bear on any action,
so they appear in the problem only as a comment, for the reader.
"""

from __future__ import annotations

import re
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Protocol

from rac.logic import NEG_PREFIX, Atom, mangle
from rac.repair.system import Kind, RepairSystem
from rac.targets.pddl_domain import domain_name

# PDDL words an object may not be called; FD also folds case, so names are lowered.
_RESERVED = frozenset(
    [
        "and",
        "or",
        "not",
        "imply",
        "forall",
        "exists",
        "when",
        "either",
        "object",
        "define",
        "domain",
        "problem",
    ]
)
# The repair domain's types, predicates and actions: unified-planning's reader (--validate)
# keeps one namespace for them and the objects, so a component called "node" breaks it.
_DOMAIN_NAMES = frozenset(
    [
        "component",
        "node",
        "device",
        "hardware",
        "driver",
        "running",
        "on",
        "bad",
        "good",
        "drives",
        "stop_node",
        "start_node",
        "shutdown",
        "power_up",
    ]
)
_PDDL_NAME = re.compile(r"[a-z][a-z0-9_]*")


class LiteralLike(Protocol):
    """An observation: ``rac.diagnosis.Literal`` or anything shaped like it."""

    @property
    def atom(self) -> Atom: ...

    @property
    def positive(self) -> bool: ...


@dataclass(frozen=True, slots=True)
class RepairProblem:
    """One repair problem: what the planner is asked, before it is written as PDDL."""

    robot: str
    system: RepairSystem
    running: tuple[str, ...]  # nodes running in the initial state
    on: tuple[str, ...]  # devices on in the initial state
    bad: tuple[str, ...]
    observations: tuple[str, ...] = ()  # Θ as text, for the comment
    names: tuple[tuple[str, str], ...] = ()  # component -> PDDL object name

    @property
    def good(self) -> tuple[str, ...]:
        bad = set(self.bad)
        return tuple(c for c in self.system.names() if c not in bad)

    def pddl_name(self, component: str) -> str:
        return dict(self.names)[component]

    def component_of(self) -> dict[str, str]:
        """PDDL object name -> component, to read a plan back."""
        return {p: c for c, p in self.names}


def pddl_names(components: Iterable[str]) -> tuple[tuple[str, str], ...]:
    """A distinct, valid, lower-case PDDL object name per component."""
    taken: set[str] = set()
    out: list[tuple[str, str]] = []
    for comp in sorted(components):
        base = comp.lower()
        if not _PDDL_NAME.fullmatch(base) or base in _RESERVED or base in _DOMAIN_NAMES:
            base = "c_" + re.sub(r"[^a-z0-9_]", "_", base)
        name, k = base, 2
        while name in taken:
            name, k = f"{base}_{k}", k + 1
        taken.add(name)
        out.append((comp, name))
    return tuple(out)


def state_facts(
    observations: Iterable[LiteralLike], neg_prefix: str = NEG_PREFIX
) -> dict[Atom, bool]:
    """Θ as atom -> truth, with ``not_p`` atoms read as ``p`` false; later literals win."""
    facts: dict[Atom, bool] = {}
    for lit in observations:
        atom, positive = lit.atom, lit.positive
        if atom.predicate.startswith(neg_prefix):
            atom = Atom(atom.predicate.removeprefix(neg_prefix), atom.args)
            positive = not positive
        facts[atom] = positive
    return facts


def literal_text(atom: Atom, positive: bool, neg_prefix: str = NEG_PREFIX) -> str:
    return str(atom) if positive else f"{neg_prefix}{atom}"


def make_problem(
    robot: str,
    system: RepairSystem,
    observations: Iterable[LiteralLike],
    bad: Iterable[str],
    neg_prefix: str = NEG_PREFIX,
) -> RepairProblem:
    """Algorithm 11's makePlanningProblem(Δ, Θ); components Θ is silent on are normal."""
    facts = state_facts(observations, neg_prefix)
    running = tuple(n for n in system.of_kind(Kind.NODE) if facts.get(Atom("running", (n,)), True))
    on = tuple(d for d in system.of_kind(Kind.DEVICE) if facts.get(Atom("on", (d,)), True))
    comps = set(system.names())
    bad_set = set(bad)
    unknown = sorted(bad_set - comps)
    if unknown:
        raise ValueError(f"not components of the model: {', '.join(unknown)}")
    return RepairProblem(
        robot=robot,
        system=system,
        running=running,
        on=on,
        bad=tuple(c for c in system.names() if c in bad_set),
        observations=tuple(sorted(literal_text(a, v, neg_prefix) for a, v in facts.items())),
        names=pddl_names(comps),
    )


def problem_name(robot: str) -> str:
    return f"repair_{mangle(robot).lower()}_problem"


def _wrap(first: str, rest: str, words: Iterable[str], width: int = 96) -> list[str]:
    """``words`` on lines starting ``first`` then ``rest``, each at most ``width`` wide."""
    lines: list[str] = []
    line = first
    for word in words:
        if line not in (first, rest) and len(line) + 1 + len(word) > width:
            lines.append(line)
            line = rest
        line = f"{line} {word}"
    if line not in (first, rest):
        lines.append(line)
    return lines


def render_problem(problem: RepairProblem) -> str:
    """The problem as PDDL text: one section per concern, sorted, with comments."""
    name: Mapping[str, str] = dict(problem.names)
    system = problem.system
    bad = set(problem.bad)
    out = [f"; Repair problem of robot {problem.robot}, generated by racc (section 7.1.2.1)."]
    out += _wrap("; Observations:", ";  ", problem.observations) or ["; Observations: none"]
    out += _wrap("; Diagnosis, bad:", ";  ", problem.bad) or ["; Diagnosis, bad: none"]
    out += [
        f"(define (problem {problem_name(problem.robot)})",
        f"  (:domain {domain_name(problem.robot)})",
        "  (:objects",
    ]
    drivers = {n for n, _ in system.drives}
    groups = (
        ("driver", [c for c in system.of_kind(Kind.NODE) if c in drivers]),
        ("node", [c for c in system.of_kind(Kind.NODE) if c not in drivers]),
        ("device", list(system.of_kind(Kind.DEVICE))),
        ("hardware", list(system.of_kind(Kind.HARDWARE))),
    )
    for pddl_type, comps in groups:
        members = [name[c] for c in comps]
        if members:
            out += _wrap("   ", "   ", [*members[:-1], f"{members[-1]} - {pddl_type}"])
    out += ["  )", "  (:init"]
    if system.drives:
        out.append("    ; which node drives which device")
        out += [f"    (drives {name[n]} {name[d]})" for n, d in system.drives]
    out.append("    ; observed, else the normal state (a node running, a device on)")
    out += [f"    (running {name[n]})" for n in problem.running]
    out += [f"    (on {name[d]})" for d in problem.on]
    out.append("    ; the diagnosis")
    out += [f"    ({'bad' if c in bad else 'good'} {name[c]})" for c in system.names()]
    out += ["  )", "  (:goal (and"]
    out += [f"    (good {name[c]})" for c in system.names()]
    out += ["  ))", ")"]
    return "\n".join(out) + "\n"
