"""How a study's record names its inputs: data by what they are (manifest sha256, generator),
not where they lie on the machine that ran it; weights by their training record."""

from __future__ import annotations

from pathlib import Path


def data_label(root: str) -> str:
    """The data named by what they are, not where they lie: manifest sha256 and generator."""
    from dressmeup.bench.tasks.common import manifest_sha256
    from dressmeup.io.jsonio import parse_json_file

    info = parse_json_file(Path(root) / "dataset.json")
    gen = info.get("generator") or {}
    return (f"the data with manifest {manifest_sha256(root)[:12]} ({info.get('name')}, generator "
            f"{gen.get('version', info.get('version'))})")


def weights_label(weights: str | None) -> str:
    """The refinement weights used: file name and what their training record says."""
    import torch

    from dressmeup.methods.retarget import get_method
    from dressmeup.runs.common import shipped_weights

    path = Path(weights) if weights else shipped_weights(get_method("isomap-refine"), "anny")
    rec = torch.load(path, map_location="cpu", weights_only=False).get("training") or {}
    return (f"`{path.name}`" + ("" if weights else " (shipped)")
            + (f", trained on manifest {str(rec['data_manifest_sha256'])[:12]} split "
               f"{rec.get('split')} to step {rec.get('kept_step')} ({rec.get('stopped_by')})"
               if rec.get("data_manifest_sha256") else ""))


def command_line(argv: list[str], paths: dict[str, str]) -> str:
    """``argv`` with each local path replaced by its placeholder (``{"/data/v5": "DATA"}``),
    for the "Produced by" line of a record."""
    return " ".join(paths.get(a, a) for a in argv)
