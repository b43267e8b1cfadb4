"""Every numeric (and a few textual) option of the command line with negative, zero, huge,
wrong-type and wrong-unit values, each on a command line that is otherwise valid.

``SPECS``: command -> (base argv, {option: kind}); a kind names which values are tried and
what each should do (see ``VALUES``). ``base`` is run as it is too (expect: correct) when
``run_base`` says so (only for commands that finish in seconds).
"""

from __future__ import annotations

from runner import Case

HUGE_INT, HUGE_FLOAT = "1000000000000", "1e12"

#: kind -> [(value, expect)]
VALUES: dict[str, list[tuple[str, str]]] = {
    # a count that must be at least one, bounded by what a machine can hold
    "count": [("-1", "refuse"), ("0", "refuse"), (HUGE_INT, "refuse"), ("abc", "refuse"),
              ("2.5", "refuse")],
    # a count of at least one where large values are only a ceiling (or a step)
    "positive": [("-1", "refuse"), ("0", "refuse"), (HUGE_INT, "either"), ("abc", "refuse")],
    # a count where 0 means "none" / "all" and large values are only a ceiling
    "ceiling": [("-1", "refuse"), ("0", "either"), (HUGE_INT, "either"), ("abc", "refuse")],
    # a count where 0 means none but large values are work to do
    "work": [("-1", "refuse"), ("0", "either"), (HUGE_INT, "refuse"), ("abc", "refuse")],
    # the same for commands whose valid runs take minutes: only values to refuse
    "work!": [("-1", "refuse"), (HUGE_INT, "refuse"), ("abc", "refuse")],
    "workers": [("-1", "refuse"), ("0", "refuse"), (HUGE_INT, "refuse"), ("x", "refuse")],
    "seed": [("-1", "either"), ("340282366920938463463374607431768211457", "either"),
             ("abc", "refuse")],
    # a length / size in its unit that must be positive and is bounded by memory
    "size": [("-1", "refuse"), ("0", "refuse"), ("nan", "refuse"), ("inf", "refuse"),
             ("1e-9", "refuse"), (HUGE_FLOAT, "either"), ("abc", "refuse")],
    # a non-negative float where 0 is valid and large values are fine
    "nonneg": [("-1", "refuse"), ("0", "either"), ("nan", "refuse"), ("inf", "refuse"),
               (HUGE_FLOAT, "either"), ("abc", "refuse")],
    # a non-negative float where large values ask for too much (angles, noise, seconds)
    "bounded": [("-1", "refuse"), ("nan", "refuse"), ("inf", "refuse"), (HUGE_FLOAT, "refuse"),
                ("abc", "refuse")],
    "port": [("-1", "refuse"), ("70000", "refuse"), ("abc", "refuse")],
    "depth": [("-1", "refuse"), ("0", "refuse"), ("40", "refuse"), ("abc", "refuse")],
    "pixels": [("-1", "refuse"), ("0", "refuse"), ("1000000", "refuse"), ("abc", "refuse")],
}

F = "{F}"
W = "{W}"
DATA = ["--data", f"{F}/data", "--edition", f"{F}/ed.json"]

#: command -> (base argv, {option: kind}, run the base itself)
SPECS: dict[str, tuple[list[str], dict[str, str], bool]] = {
    "metrics": (["metrics", f"{F}/garment.ply", f"{F}/garment.ply", "--samples", "2000"],
                {"--samples": "count", "--seed": "seed"}, True),
    "register": (["register", f"{F}/scan.npy", "--model", "procedural", "--out",
                  f"{W}/fit.npz", "--iterations", "1,1,1", "--no-picture"],
                 {"--seed": "seed"}, False),
    "synth": (["synth", f"{W}/out", "--subjects", "1", "--garments", "1", "--poses", "2",
               "--body-model", "procedural", "--edge-length", "0.05"],
              {"--subjects": "count", "--garments": "count", "--poses": "count",
               "--seed": "seed", "--registration-noise": "bounded", "--edge-length": "size",
               "--workers": "workers"}, True),
    "import-dataset": (["import-dataset", "4ddress", f"{F}/4ddress", "--out", f"{W}/out"],
                       {"--seed": "seed", "--stride": "positive", "--pictures": "ceiling"}, True),
    "synth-capture": (["synth-capture", "mannequin", "--out", f"{W}/s", "--scale", "0.2"],
                      {"--frames": "count", "--perturb-deg": "bounded",
                       "--perturb-cm": "bounded", "--scale": "size", "--seed": "seed"}, True),
    "fuse": (["fuse", f"{F}/session", "--out", f"{W}/scan", "--voxel", "0.02"],
             {"--voxel": "size", "--min-weight": "nonneg", "--refine-max-deg": "bounded",
              "--refine-max-cm": "bounded", "--refine-seconds": "bounded",
              "--poisson-depth": "depth", "--decimate": "count"}, True),
    "build-dataset": (["build-dataset", f"{F}/session", "--out", f"{W}/bd", "--voxel", "0.02",
                       "--body", "none", "--target-faces", "2000", "--texture-size", "64"],
                      {"--voxel": "size", "--target-faces": "positive",
                       "--texture-size": "pixels", "--workers": "workers",
                       "--poisson-depth": "depth"}, True),
    "baseline retarget": (["baseline", "retarget", "--method", "rigid", *DATA, "--out",
                           f"{W}/sub"], {"--limit": "positive", "--workers": "workers"}, True),
    "baseline train-retarget": (["baseline", "train-retarget", "--data", f"{F}/data",
                                 "--split", "test", "--val-split", "none", "--out",
                                 f"{W}/w.pt", "--steps", "1"],
                                {"--max-val": "positive", "--steps": "count",
                                 "--max-triplets": "ceiling", "--wall-minutes": "bounded",
                                 "--val-every": "positive", "--checkpoint-every": "positive",
                                 "--threads": "workers"}, False),
    "baseline uvparam": (["baseline", "uvparam", "--method", "xatlas", "--meshes",
                          f"{F}/garment.ply", "--out", f"{W}/sub"],
                         {"--workers": "workers"}, True),
    "validate-submission": (["validate-submission", f"{F}/sub", *DATA],
                            {"--max-per-kind": "ceiling"}, True),
    "score": (["score", f"{F}/sub", *DATA, "--out", f"{W}/res"],
              {"--workers": "workers"}, True),
    "demo": (["demo", "--quick", "--out", f"{W}/demo"],
             {"--workers": "workers", "--train-steps": "work!"}, False),
    "edition create": (["edition", "create", "--data", f"{F}/data", "--task", "retarget",
                        "--name", "sweep-made", "--out", f"{W}/ed.json"],
                       {"--version": "positive"}, True),
    "serve": (["serve", "--root", f"{W}/srv"],
              {"--port": "port", "--daily-limit": "positive", "--max-upload-mb": "count",
               "--workers": "workers"}, False),
    "report": (["report", f"{F}/res", f"{F}/res-noisy", "--out", f"{W}/site",
                "--images-per-side", "1"],
               {"--images-per-side": "ceiling", "--max-images": "ceiling"}, True),
}

#: textual options with values that must be refused: (command, option, value)
TEXT = [
    ("register", "--gender", "robot"), ("register", "--model", "robot"),
    ("register", "--iterations", "1,-1,1"), ("register", "--iterations", "1000000000,1,1"),
    ("register", "--format", "nope"), ("register", "--registrar", "nope"),
    ("synth-capture", "--subject-up", "w"), ("synth-capture", "--rig", "default-0"),
    ("fuse", "--device", "tpu:9"), ("fuse", "--device", "cuda:99"),
    ("build-dataset", "--body-model", "robot"), ("build-dataset", "--split", ""),
    ("baseline retarget", "--method", "nope"), ("baseline retarget", "--method", "rigid+nope"),
    ("baseline retarget", "--param", "k_place=-1"), ("baseline retarget", "--param", "x"),
    ("baseline train-retarget", "--split", "nope"),
    ("baseline uvparam", "--param", "nope=1"), ("baseline uvparam", "--meshes", "no-such-mesh"),
    ("edition create", "--name", "../evil"), ("edition create", "--name", ""),
    ("edition create", "--metrics", "p2s,nope"), ("edition create", "--primary-metric", "nope"),
    ("edition create", "--split", "nope"),
    ("report", "--data", "{F}/missing"),
    ("serve", "--host", "not a host"),
]
#: leaderboard options on the fixture results
LEADERBOARD = [(["--sort-by", "nope"], "refuse"), (["--per-category", "nope"], "refuse"),
               (["--per-category", "none"], "ok"), (["--std"], "ok"),
               (["--format", "html", "--out", "{W}/lb.html"], "ok"),
               (["--out", "{F}/data"], "refuse")]


def _with(argv: list[str], option: str, value: str) -> list[str]:
    out = list(argv)
    if option in out:
        i = out.index(option)
        out[i + 1] = value
        return out
    return out + [f"{option}={value}"]


def _serving(cmd: str, expect: str) -> str:
    """What still running at the time limit means: a server serves until stopped."""
    if cmd != "serve":
        return "crash"
    return "correct" if expect == "either" else "accepted"


def cases() -> list[Case]:
    """The option sweep's cases."""
    out = []
    for cmd, (base, options, run_base) in SPECS.items():
        if run_base:
            out.append(Case("options", f"{cmd} (valid)", base, "ok", timeout=120))
        for option, kind in options.items():
            for value, expect in VALUES[kind]:
                out.append(Case("options", f"{cmd} {option} {value}",
                                _with(base, option, value), expect, timeout=45,
                                timeout_outcome=_serving(cmd, expect)))
    for cmd, option, value in TEXT:
        base = SPECS[cmd][0]
        out.append(Case("options", f"{cmd} {option} {value!r}",
                        _with(base, option, value.replace("{F}", F)), "refuse", timeout=45))
    for extra, expect in LEADERBOARD:
        out.append(Case("options", f"leaderboard {' '.join(extra)}",
                        ["leaderboard", f"{F}/res", f"{F}/res-noisy", *extra], expect))
    return out
