"""Consistency-based diagnosis (§3.4, chapter 6): theories, observations, minimal diagnoses.

:class:`Theory` is the model reasoned over (``rac.load.theory`` reads one from a file);
``parse_literal`` and ``collect`` build the observation set Θ (Algorithm 10);
``diagnose`` returns the minimal conflicts and all minimal diagnoses.
"""

from rac.diagnosis.result import DiagnosisResult, compile_theory, diagnose, is_consistent
from rac.diagnosis.simulate import (
    Simulation,
    all_single_faults,
    ambiguity_groups,
    predict,
    simulate,
)
from rac.diagnosis.theory import Literal, Theory, collect, parse_literal

__all__ = [
    "DiagnosisResult",
    "Literal",
    "Simulation",
    "Theory",
    "all_single_faults",
    "ambiguity_groups",
    "collect",
    "compile_theory",
    "diagnose",
    "is_consistent",
    "parse_literal",
    "predict",
    "simulate",
]
