"""What the case lists share: the fixture folder of a case, the standard bad files of one
reader."""

from __future__ import annotations

from pathlib import Path

import bad_files as bf
from runner import Case

F, W = "{F}", "{W}"


def _fx(w: Path) -> Path:
    """The fixtures folder of a case's working folder ({W} is <work>/cases/<n>)."""
    return w.parents[1] / "fixtures"


def _standard(group: str, argv: list[str], name: str, valid: str,
              extra: list[tuple[str, callable]] = ()) -> list[Case]:
    """missing / empty / truncated / random / wrong kind / folder (+ ``extra``) cases of the
    file ``{W}/name`` whose valid example is the fixture ``valid``."""
    target = f"{W}/{name}"
    makers = [
        ("missing", lambda w: None),
        ("empty", lambda w: bf.empty(w / name)),
        ("truncated", lambda w: bf.truncated(_fx(w) / valid, w / name)),
        ("random bytes", lambda w: bf.random_bytes(w / name)),
        ("a PNG", lambda w: bf.png(w / name)),
        ("a folder", lambda w: (w / name).mkdir()),
        *extra,
    ]
    return [Case(group, f"{argv[0]} {name}: {label}",
                 [a.replace("@", target) for a in argv], "refuse", setup=make, timeout=60)
            for label, make in makers]
