"""Hypothesis strategies for random VALID robot architecture models (contract §1).

``models()`` draws a :class:`rac.ir.Model` that passes validation: unique names that
mangle apart, switchable hardware on distinct channels, ``affected_by`` within the node's
subscriptions and never the published topic itself, related pairs (either side perhaps
integrated, ``I(...)``) and interval pairs over fields of published topics.
``rac.fmt.format_model`` turns one into ``.ram`` text.
"""

from __future__ import annotations

from hypothesis import strategies as st

from rac.ir import (
    CONTAINER_RUNTIMES,
    Container,
    FieldRef,
    Hardware,
    Interval,
    Limits,
    Machine,
    Model,
    Name,
    Node,
    Publication,
    Related,
    Topic,
)

_SUFFIX = st.text(alphabet="abcdefghijklmnopqrstuvwxyz0123456789_", min_size=0, max_size=5)
_WORD = st.text(alphabet="abcdefghijklmnopqrstuvwxyz", min_size=1, max_size=6)

# Positive numbers that survive the text round trip exactly (format_number uses repr).
_RATE = st.one_of(
    st.sampled_from([1.0, 2.5, 10.0, 20.0, 40.0, 100.0]),
    st.floats(min_value=0.05, max_value=2000.0, allow_nan=False, allow_infinity=False),
)
_KEYWORDS = ["from", "window", "node", "topic", "within", "Hz", "cpu", "mem", "relate", "I"]
_POSITIVE = st.floats(min_value=1e-3, max_value=1e4, allow_nan=False, allow_infinity=False)


def _unique_names(prefix: str, count: int, draw: st.DrawFn) -> list[str]:
    # The index right after the prefix keeps mangled names apart: "n3_..." never equals "n31_...".
    return [f"{prefix}{i}_{draw(_SUFFIX)}".rstrip("_") for i in range(count)]


@st.composite
def _topic(draw: st.DrawFn, name: str) -> Topic:
    nfields = draw(st.integers(0, 4))
    fields = []
    for j in range(nfields):
        field = f"f{j}"
        if draw(st.booleans()):
            field += "." + draw(_WORD).replace("hz", "h")
        fields.append(Name(field))
    # Keywords are names too where the grammar expects a name.
    fields += [Name(k) for k in draw(st.lists(st.sampled_from(_KEYWORDS), unique=True, max_size=2))]
    rate = draw(st.one_of(st.none(), _RATE))
    tolerance = window = mismatch = None
    if rate is not None:
        if draw(st.booleans()):
            tolerance = draw(st.floats(min_value=0.0, max_value=rate, exclude_max=True))
            if tolerance != 0.0 and rate - tolerance < 1e-6:
                tolerance = rate / 2
        window = draw(st.one_of(st.none(), _POSITIVE))
        mismatch = draw(st.one_of(st.none(), st.integers(0, 50)))
    msg_type = draw(st.one_of(st.none(), st.sampled_from(["std_msgs/Float64", "pkg/sub/Msg"])))
    return Topic(
        Name(name),
        msg_type=msg_type,
        fields=tuple(fields),
        rate_hz=rate,
        rate_tolerance_hz=tolerance,
        window_s=window,
        mismatch_threshold=mismatch,
    )


def _subset(draw: st.DrawFn, items: list[str], max_size: int | None = None) -> list[str]:
    if not items:
        return []
    return draw(st.lists(st.sampled_from(items), unique=True, max_size=max_size))


@st.composite
def models(
    draw: st.DrawFn, max_nodes: int = 6, max_topics: int = 6, max_hardware: int = 4
) -> Model:
    hw_names = _unique_names("hw", draw(st.integers(0, max_hardware)), draw)
    channels = draw(st.permutations(range(1, len(hw_names) + 1)))
    hardware = []
    for name, channel in zip(hw_names, channels, strict=True):
        switchable = draw(st.booleans())
        hardware.append(
            Hardware(Name(name), switchable=switchable, channel=channel if switchable else None)
        )

    topic_names = []
    for i in range(draw(st.integers(0, max_topics))):
        ns = draw(st.one_of(st.none(), _WORD))
        name = f"/{ns}/t{i}" if ns else f"/t{i}_{draw(_SUFFIX)}".rstrip("_")
        topic_names.append(name[1:] if draw(st.integers(0, 4)) == 0 else name)  # relative names
    topics = [draw(_topic(n)) for n in topic_names]

    node_names = [
        f"/{ns}/{name}" if ns else name
        for name in _unique_names("node", draw(st.integers(0, max_nodes)), draw)
        for ns in [draw(st.one_of(st.none(), st.none(), _WORD))]
    ]
    devices = [*hw_names, *_unique_names("dev", draw(st.integers(0, 2)), draw)]
    # Where nodes run (issue 28): a few machines, an address or not; some nodes placed on
    # one, some in a container.
    machine_names = _unique_names("m", draw(st.integers(0, 2)), draw)
    machines = tuple(
        Machine(Name(m), address=draw(st.sampled_from([None, "10.0.0.2", "base.local", "fe80::1"])))
        for m in machine_names
    )
    nodes = []
    for name in node_names:
        subscribes = _subset(draw, topic_names)
        publishes = []
        for topic in _subset(draw, topic_names, max_size=3):
            inputs = [t for t in subscribes if t != topic]
            publishes.append(
                Publication(Name(topic), tuple(Name(t) for t in _subset(draw, inputs)))
            )
        cpu = draw(st.one_of(st.none(), _POSITIVE))
        mem = draw(
            st.one_of(st.none(), st.integers(1, 2**32), st.sampled_from([64 * 10**6, 3 * 2**20]))
        )
        nodes.append(
            Node(
                Name(name),
                drives=tuple(Name(h) for h in _subset(draw, hw_names, max_size=2)),
                subscribes=tuple(Name(t) for t in subscribes),
                publishes=tuple(publishes),
                limits=Limits(cpu=cpu, mem=mem),
                diagnostics=tuple(Name(d) for d in _subset(draw, devices, max_size=2)),
                machine=(
                    Name(draw(st.sampled_from(machine_names)))
                    if bool(machine_names) and draw(st.booleans())
                    else None
                ),
                container=(
                    Container(
                        Name(f"c_{draw(_SUFFIX)}x"), draw(st.sampled_from(CONTAINER_RUNTIMES))
                    )
                    if draw(st.integers(0, 3)) == 0
                    else None
                ),
            )
        )

    published = {p.topic.value for n in nodes for p in n.publishes}
    refs = [
        f"{t.name.value}.{f.value}" for t in topics if t.name.value in published for f in t.fields
    ]
    related: list[Related] = []
    intervals: list[Interval] = []
    seen: set[frozenset[str]] = set()
    if len(refs) >= 2:
        pair = st.lists(st.sampled_from(refs), min_size=2, max_size=2, unique=True)
        for a, b in draw(st.lists(pair, max_size=3)):
            # Either side may be integrated, I(...), a distinct pair of atoms.
            a, b = (f"I({r})" if draw(st.booleans()) else r for r in (a, b))
            if frozenset((a, b)) not in seen:
                seen.add(frozenset((a, b)))
                related.append(Related(FieldRef.parse(a), FieldRef.parse(b)))
        bounded: set[frozenset[str]] = set()
        for a, b in draw(st.lists(pair, max_size=2)):
            diff = draw(st.floats(min_value=0.0, max_value=100.0))
            if frozenset((a, b)) not in bounded:  # one bound per pair (RAC030)
                bounded.add(frozenset((a, b)))
                intervals.append(Interval(FieldRef.parse(a), FieldRef.parse(b), diff))

    return Model(
        name=Name(f"robot_{draw(_SUFFIX)}".rstrip("_")),
        hardware=tuple(hardware),
        topics=tuple(topics),
        nodes=tuple(nodes),
        related=tuple(related),
        intervals=tuple(intervals),
        machines=machines,
    )


_COMMENT = st.text(
    alphabet=st.characters(
        blacklist_categories=("Cc", "Cs", "Zl", "Zp"), blacklist_characters="\r"
    ),
    max_size=20,
).map(lambda s: (" " + s.strip()).rstrip())


@st.composite
def commented_models(draw: st.DrawFn) -> Model:
    """A valid model with comments before declarations, inside nodes and at both ends."""
    from dataclasses import replace

    model = draw(models(max_nodes=4, max_topics=4, max_hardware=3))

    def notes() -> tuple[str, ...]:
        return tuple(draw(st.lists(_COMMENT, max_size=2)))

    nodes = []
    for node in model.nodes:
        body = node.subscribes or node.publishes or node.limits.declared or node.diagnostics
        nodes.append(replace(node, comments=notes(), inner_comments=notes() if body else ()))
    return replace(
        model,
        hardware=tuple(replace(h, comments=notes()) for h in model.hardware),
        topics=tuple(replace(t, comments=notes()) for t in model.topics),
        nodes=tuple(nodes),
        related=tuple(replace(r, comments=notes()) for r in model.related),
        comments=notes(),
        trailing_comments=notes(),
    )
