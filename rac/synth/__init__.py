"""``racc synth``: synthetic recordings of the robot a model describes (for demos and tests)."""

from rac.synth.recording import Plan, SynthOptions, plan_recording, write_recording

__all__ = ["Plan", "SynthOptions", "plan_recording", "write_recording"]
