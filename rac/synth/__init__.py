"""``racc synth``: synthetic recordings of the robot a model describes (for demos and tests).

The names below load on first use (see :mod:`rac.lazy`), so that the command line's
start-up does not import rosbags.
"""

from rac.lazy import lazy_exports

_EXPORTS = {
    "Plan": "rac.synth.recording",
    "SynthOptions": "rac.synth.recording",
    "plan_recording": "rac.synth.recording",
    "write_recording": "rac.synth.recording",
}

__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
