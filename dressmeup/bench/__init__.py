"""dressmeup.bench: benchmark editions, submissions and their validation, scoring, results
and leaderboards (docs/spec.md section 4; docs/benchmark.md).

>>> from dressmeup.bench import load_edition, write_submission, score_submission  # doctest: +SKIP
>>> ed = load_edition("synth-retarget-v2")                                        # doctest: +SKIP
>>> write_submission("subs/mine", preds, edition=ed, method="Mine")               # doctest: +SKIP
>>> score_submission("subs/mine", ed, "data/synth", "results/mine")               # doctest: +SKIP
"""

from __future__ import annotations

from dressmeup.bench.boards.leaderboard import build_leaderboard, write_leaderboard
from dressmeup.bench.edition import Edition, list_editions, load_edition
from dressmeup.bench.scoring.results import Result, load_result
from dressmeup.bench.scoring.score import InvalidSubmissionError, ScoreResult, score_submission
from dressmeup.bench.scoring.submission import SubmissionInfo, submission_hash, write_submission
from dressmeup.bench.scoring.validate import Problem, ValidationReport, validate_submission

__all__ = [
    "Edition",
    "InvalidSubmissionError",
    "Problem",
    "Result",
    "ScoreResult",
    "SubmissionInfo",
    "ValidationReport",
    "build_leaderboard",
    "list_editions",
    "load_edition",
    "load_result",
    "score_submission",
    "submission_hash",
    "validate_submission",
    "write_leaderboard",
    "write_submission",
]
