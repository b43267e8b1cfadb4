"""Where a number was made: the one description of the machine for submissions and results.

``hardware()`` goes into ``submission.json`` (``"hardware"``) of every baseline run (CLI,
demo, benchmark scripts); ``environment()`` is the machine part of a result's provenance.
"""

from __future__ import annotations

import os
import platform
import socket

__all__ = ["cpu_model", "hardware", "environment"]


def cpu_model() -> str:
    """The processor's model name, e.g. ``"AMD EPYC 7B13"`` or ``"Intel(R) Xeon(R) ..."``: the
    first ``model name`` of ``/proc/cpuinfo`` (Linux), else ``platform.processor()``, else the
    machine type (``"x86_64"``). It tells an Intel from an AMD machine in a record, which
    matters where numerics differ by CPU maker."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8", errors="replace") as fh:
            for line in fh:
                if line.startswith("model name") and ":" in line:
                    name = line.split(":", 1)[1].strip()
                    if name:
                        return name
    except OSError:
        pass
    return platform.processor() or platform.machine()


def hardware() -> str:
    """The processor and core count, e.g. ``"AMD EPYC 7B13, 2 cores"``.

    Returns
    -------
    str : :func:`cpu_model`, ``", "``, the number of logical cores and ``" cores"``.
    """
    return f"{cpu_model()}, {os.cpu_count()} cores"


def environment() -> dict[str, str]:
    """Host name, platform string and Python version of this process.

    Returns
    -------
    dict with ``host``, ``platform``, ``python`` (str each).
    """
    return {"host": socket.gethostname(), "platform": platform.platform(),
            "python": platform.python_version()}
