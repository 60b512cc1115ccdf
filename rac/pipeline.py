"""The visible compiler pipeline: parse -> validate -> derive (RBM, observers) -> emit.

``compile_model`` runs the passes in ``PASSES`` order and verifies the IR
between them; only the CLI touches files.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from rac.errors import Diagnostic, RacError
from rac.ir import Model
from rac.logic import Atom, Clause, mangle
from rac.passes.machines import place_observers
from rac.passes.observers import ObserverSpec, derive_observers, observable_atoms
from rac.passes.rbm import components, derive_rbm
from rac.passes.validate import validate
from rac.perf import paused_gc


@dataclass(frozen=True, slots=True)
class Compiled:
    """Everything the targets emit from, derived from one validated model."""

    model: Model
    rbm: tuple[Clause, ...]
    observers: tuple[ObserverSpec, ...]
    props: tuple[Atom, ...]
    components: tuple[str, ...]
    warnings: tuple[Diagnostic, ...] = ()
    # Text that several emitters share (both launch files render the same parameter lines),
    # computed once per compilation.  A cache of derived values only: it never changes what
    # an emitter returns, and it takes no part in comparison or hashing.
    memo: dict[object, object] = dataclasses.field(
        default_factory=dict, init=False, compare=False, hash=False, repr=False
    )


def check_model(model: Model) -> tuple[Diagnostic, ...]:
    """Validate; raise with every error (warnings included) when there is one."""
    diagnostics = validate(model)
    if any(d.is_error for d in diagnostics):
        raise RacError(located(model, diagnostics), model.source)
    return diagnostics


# Warnings of a ram/1 model are located up to this size of text.  Locating reads the whole
# text again with positions and validates once more: about 0.1 s for 1,000 nodes (0.7 MiB),
# but 1.4 s and 135 MB more for 10,000 nodes (7 MiB), too much to add to every compile of a
# large model that has a warning.  Errors are always located: the run stops there anyway.
WARNINGS_LOCATED_UP_TO = 1 << 20


def located(
    model: Model, diagnostics: tuple[Diagnostic, ...], *, up_to: int | None = None
) -> tuple[Diagnostic, ...]:
    """``diagnostics`` of ``model`` with spans, when they lack them because it came from JSON.

    A model read from ``ram/1`` has no spans (its fast read stays on the C decoder), so its
    diagnostics are found again on the model read once more with spans: only when some are
    shown, never on the way of a valid model, and (``up_to``) only for a text of at most
    that many characters.
    """
    if all(d.span is not None for d in diagnostics):
        return diagnostics
    if up_to is not None and model.source is not None and len(model.source) > up_to:
        return diagnostics
    from rac.interchange import located_model

    with paused_gc():
        again = located_model(model)
        return diagnostics if again is None else validate(again)


def _verify(compiled: Compiled) -> None:
    """IR invariants between passes: a broken pass fails loudly, not in an output file."""
    heads = {c.head for c in compiled.rbm}
    # A regular topic nobody in the model publishes still gets its GObs (docs/spec.md), but
    # no clause derives its ok(t) (docs/spec.md): the observation then only informs the user.
    published = compiled.model.publishers()
    # By atom argument, and only for the topics nobody publishes (usually none): not an
    # atom built and hashed for every topic of a large model.
    unpublished = {mangle(t.name.value) for t in compiled.model.topics}.difference(
        map(mangle, published)
    )
    missing = [
        a
        for a in compiled.props
        if a not in heads
        and not (a.predicate == "ok" and len(a.args) == 1 and a.args[0] in unpublished)
    ]
    assert not missing, f"observable atoms no clause derives: {missing}"
    names = [o.name for o in compiled.observers]
    assert len(set(names)) == len(names), "observer names collide"


PASSES = ("validate", "derive_rbm", "derive_observers", "verify")


def compile_model(model: Model) -> Compiled:
    with paused_gc():  # see rac.perf: half the time of a large model otherwise
        warnings = check_model(model)
        rbm = derive_rbm(model)
        observers = place_observers(model, derive_observers(model))
        compiled = Compiled(
            model=model,
            rbm=rbm,
            observers=observers,
            props=observable_atoms(observers),
            components=components(rbm),
            warnings=warnings,
        )
        _verify(compiled)
        return compiled
