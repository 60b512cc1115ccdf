"""racc replay --plot (rac.replay.plot): the labels of the fault windows and of the
diagnoses never overlap, however close in time, and stay on the figure."""

from __future__ import annotations

import pytest

from rac.replay.timeline import DiagnosisRecord, ObservationRecord, Record, Timeline
from rac.synth.truth import InjectedFault

pytest.importorskip("matplotlib")


def crowded() -> tuple[Timeline, list[InjectedFault]]:
    """Six faults 1.5 s apart, each diagnosed, with names as long as a real robot's; the
    last fault's label would run past the right edge."""
    records: list[Record] = []
    faults = []
    for k in range(6):
        t = 5.0 + k * 1.5
        node = f"/robot_41/localization/node_{k}"
        faults.append(InjectedFault("crash", node, t, t + 3, (node,)))
        records.append(ObservationRecord(t + 0.2, f"not_ok(topic_{k})"))
        records.append(DiagnosisRecord(t + 0.3, ((node,), (f"device_{k}", "driver_x"))))
        records.append(DiagnosisRecord(t + 1.0, ()))
        records.append(ObservationRecord(t + 1.1, f"ok(topic_{k})"))
    faults.append(InjectedFault("freq", "/robot_41/drivers/sick_front/scan", 19.5, 20.0, ()))
    return Timeline(tuple(records), 20.0), faults


def test_no_two_labels_overlap_and_none_leaves_the_figure() -> None:
    """Issue 37: the replay plot's labels overlapped (all on one line each)."""
    import matplotlib.pyplot as plt

    from rac.replay.plot import figure

    timeline, faults = crowded()
    fig = figure(timeline, faults, "crowded")
    try:
        fig.canvas.draw()
        renderer = fig.canvas.get_renderer()  # type: ignore[attr-defined]
        ax = fig.axes[0]
        texts = [t for t in ax.texts if t.get_text()]
        assert len(texts) == len(faults) + 6  # a label per fault and per diagnosis
        boxes = [t.get_window_extent(renderer) for t in texts]
        for i, a in enumerate(boxes):
            for b in boxes[i + 1 :]:
                assert not a.overlaps(b), (a, b)
        width, height = fig.bbox.width, fig.bbox.height
        for box in boxes:
            assert box.x0 >= 0 and box.x1 <= width and box.y1 <= height, box
    finally:
        plt.close(fig)
