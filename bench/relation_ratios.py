"""The trend match ratio of every declared relation of a model on a recording of it.

A declared ``relate`` must read "matched" on a healthy robot; the learner's trend machinery
(rac.learn.trends, rac.learn.correlate) is the proxy.  For each declared pair this prints
the ratio as declared (with its I() sides), the chance level, and the ratios of the other
admissible variants (raw, one side integrated), so that a weak declaration and its better
form are both visible, and the declared ratio again with both topics' trends over the one
regression window ``ws`` the compiled observer uses::

    racc synth models/tedusar.ram -o /tmp/t.bag --duration 300
    python bench/relation_ratios.py models/tedusar.ram /tmp/t.bag

Prints one line per relation and exits 0; it judges nothing.
"""

from __future__ import annotations

import sys

import numpy as np

from rac.ir import FieldRef
from rac.learn.correlate import TrendSet
from rac.learn.fields import FieldSelector
from rac.learn.recording import TopicData
from rac.learn.trends import Signal, TopicTrends, topic_trends
from rac.load.bags import read_recording
from rac.load.files import load_model
from rac.passes.observers import biqobs_params

OCCURRENCES = 10


def _ratio(
    trends: dict[str, TopicTrends], a: FieldRef, ia: bool, b: FieldRef, ib: bool
) -> tuple[float, float]:
    """The match ratio (checks while a side moves) and its chance level, as racc learn
    counts them (rac.learn.correlate)."""
    pair = (Signal(a.topic, a.field, ia), Signal(b.topic, b.field, ib))
    (found,) = TrendSet(trends).evidence([pair])
    if found is None:
        raise KeyError(f"{a.text} ~ {b.text}: no trend of a side (constant or missing)")
    return found.ratio, found.chance


def _common_window(data: dict[str, TopicData], a: str, b: str, ws: float) -> dict[str, TopicTrends]:
    """Both topics' trends over the observer's one window ``ws`` (not C occurrences each)."""
    out = {}
    for name in (a, b):
        median = float(np.median(data[name].intervals()))
        found = topic_trends(data[name], max(3, round(ws / median)), integrate=True)
        if found is not None:
            out[name] = found
    return out


def main(model_path: str, run: str) -> int:
    model = load_model(model_path)
    declared = {t.name.value: frozenset(f.value for f in t.fields) for t in model.topics}
    wanted = {r.topic for rel in model.related for r in (rel.a, rel.b)}
    recording = read_recording([run], FieldSelector(declared, ()), frozenset(wanted))
    data = recording.topic_by_name()
    trends = {}
    for topic in recording.topics:
        found = topic_trends(topic, OCCURRENCES, integrate=True)
        if found is not None:
            trends[topic.name] = found
    topics = model.topic_by_name()
    for rel in model.related:
        a, b = rel.a, rel.b
        ws = float(dict(biqobs_params(a, b, topics))["ws"])
        try:
            ratio, chance = _ratio(trends, a, a.integrated, b, b.integrated)
            common = _common_window(data, a.topic, b.topic, ws)
            at_ws, _ = _ratio(common, a, a.integrated, b, b.integrated)
        except KeyError as err:
            print(f"{rel.a.text} ~ {rel.b.text}: {err}")
            continue
        others = []
        for ia, ib in ((False, False), (True, False), (False, True)):
            if (ia, ib) != (a.integrated, b.integrated):
                other, _ = _ratio(trends, a, ia, b, ib)
                side = "raw" if not (ia or ib) else f"I({(a if ia else b).path})"
                others.append(f"{side} {other:.2f}")
        print(
            f"{a.text} ~ {b.text}: {ratio:.2f} (chance {chance:.2f}; {', '.join(others)}; "
            f"{at_ws:.2f} over one {ws:g} s window)"
        )
    return 0


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        sys.exit(2)
    sys.exit(main(sys.argv[1], sys.argv[2]))
