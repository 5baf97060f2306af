"""Evaluation metrics.

- :func:`~avtrack.metrics.mot.evaluate_mot`: MOTChallenge CLEAR-MOT, identity and HOTA scores of
  a visual tracker (through TrackEval).
"""

from avtrack.metrics.mot import BENCHMARKS, MOTScores, evaluate_mot, format_table

__all__ = ["BENCHMARKS", "MOTScores", "evaluate_mot", "format_table"]
