"""Fuzzing every command's argument surface: whatever the arguments, a command exits 0 or 2,
never with a traceback, and never changes an input file.

For each command Hypothesis draws an argument list from that command's options, each given a
value from a pool that mixes good inputs (small valid files), bad ones (missing, empty,
garbage, a folder) and odd values (negative, zero, huge, NaN, words). The command runs in
this process; what must not happen is an exception other than ``SystemExit(0 | 2)`` (argparse's
usage errors exit 2), an exit status other than 0 or 2, or any input file changing. Outputs go
to a fresh folder per case (with ``--force`` drawn sometimes). CI runs a fixed
(derandomized) set of examples; ``AVTRACK_FUZZ_EXAMPLES=500`` searches longer locally.
"""

from __future__ import annotations

import hashlib
import itertools
import os
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from avtrack.cli.main import main
from avtrack.io.doa import DOA_HEADER

EXAMPLES = int(os.environ.get("AVTRACK_FUZZ_EXAMPLES", "20"))
_CASE = itertools.count()


@pytest.fixture(scope="module")
def pool(tmp_path_factory) -> dict[str, Path]:
    """Small input files, good and bad."""
    d = tmp_path_factory.mktemp("fuzz-inputs")
    files = {
        "det": "1,-1,10,10,20,40,0.9\n2,-1,12,10,20,40,0.8\n3,-1,14,11,20,40,0.9\n",
        "gt": "1,1,10,10,20,40,1,1,1\n2,1,12,10,20,40,1,1,1\n",
        "doa": f"{DOA_HEADER}\n0,0.0,-1,10.0,0.0,1.0,1\n1,0.016,-1,12.0,0.0,1.0,1\n",
        "rttm": "SPEAKER rec 1 0.000 1.000 <NA> <NA> A <NA> <NA>\n",
        "empty": "",
        "garbage": "\x00\xffnot a file of any kind,,,\n\n",
        "yaml": "people: 2\n",
        "badyaml": "a: [1, 2\n",
    }
    out = {}
    for name, text in files.items():
        p = d / f"{name}.txt"
        p.write_text(text, encoding="latin-1")
        out[name] = p
    rng = np.random.default_rng(0)
    for name, shape in (("wav4", (4800, 4)), ("wav1", (4800, 1)), ("tiny", (100, 4))):
        p = d / f"{name}.wav"
        sf.write(p, 0.1 * rng.standard_normal(shape), 16000)
        out[name] = p
    out["folder"] = d / "a-folder"
    out["folder"].mkdir()
    out["missing"] = d / "missing.txt"
    return out


def _hashes(pool: dict[str, Path]) -> dict[str, str]:
    return {k: hashlib.sha256(p.read_bytes()).hexdigest() for k, p in pool.items()
            if p.is_file()}


NUMBERS = ["0", "1", "-1", "3", "0.5", "1e9", "nan", "inf", "-0.2", "abc", ""]


def _value(kind: str):
    """Strategy of one option value: ``file`` (from the pool), ``number`` or ``word``."""
    if kind == "file":
        return st.sampled_from(["det", "gt", "doa", "rttm", "empty", "garbage", "yaml",
                                "badyaml", "wav4", "wav1", "tiny", "folder", "missing"])
    if kind == "number":
        return st.sampled_from(NUMBERS)
    return st.sampled_from(["nao4", "kemar", "lpf", "gauss", "x", "walkout", "meeting", "-",
                            "follow1", "640x480", "MOT15"])


#: command -> (positional kinds, {option: value kind or None for a flag}). Every command's
#: outputs are folded in by the test (-o OUT and the like).
SURFACE = {
    "track-mot": (["file"], {"--image-size": "word", "--appearance": "file",
                             "--min-score": "number", "--config": "file", "--video": "file"}),
    "eval mot": (["file", "file"], {"--benchmark": "word"}),
    "eval doa": (["file", "file"], {"--threshold": "number", "--roc": None,
                                    "--max-shift": "number", "--period": "number"}),
    "eval der": (["file", "file"], {"--collar": "number", "--skip-overlap": None}),
    "localize": (["file"], {"--array": "word", "--method": "word", "--threshold": "number",
                            "--floor": "number", "--block-size": "number"}),
    "track-audio": (["file"], {"--array": "word", "--tracker": "word", "--doa": "file"}),
    "stream": (["file"], {"--array": "word", "--block-ms": "number", "--tracker": "word"}),
    "simulate": (["word"], {"--seed": "number", "--duration": "number", "--array": "word",
                            "--print": None}),
    "track-phd": (["file"], {"--seq": "number", "--cam": "number", "--filter": "word",
                             "--seed": "number"}),
    "track-av": (["file"], {"--fov-fraction": "number", "--no-audio": None,
                            "--threshold": "number", "--fps": "number", "--doa": "file",
                            "--detections": "file", "--camera": "file"}),
    "robot-sim": (["word"], {"--seed": "number", "--duration": "number"}),
}


#: A valid start for each command (drawn half of the time instead of random positionals), so
#: that the options are also fuzzed on runs that get past the inputs.
GOOD = {
    "track-mot": ["{det}"],
    "eval mot": ["{gt}", "{det}"],
    "eval doa": ["{doa}", "{doa}"],
    "eval der": ["{rttm}", "{rttm}"],
    "localize": ["{wav4}", "--array", "nao4"],
    "track-audio": ["{wav4}", "--array", "nao4"],
    "stream": ["{wav4}", "--array", "nao4"],
    "simulate": ["walkout"],
    "track-phd": ["{folder}", "--seq", "1", "--cam", "1"],
    "track-av": ["--detections", "{det}", "--fps", "25", "--doa", "{doa}", "--camera",
                 "{yaml}"],
    "robot-sim": ["follow1"],
}


@pytest.mark.parametrize("command", sorted(SURFACE))
@settings(max_examples=EXAMPLES, deadline=None, derandomize=True,
          suppress_health_check=[HealthCheck.function_scoped_fixture,
                                 HealthCheck.too_slow])
@given(data=st.data())
def test_command_exits_0_or_2_and_leaves_inputs_alone(pool, tmp_path, command, data):
    positional, options = SURFACE[command]
    argv = command.split()
    if data.draw(st.booleans()):
        argv += [t.format(**{k: str(p) for k, p in pool.items()}) for t in GOOD[command]]
    else:
        for kind in positional:
            v = data.draw(_value(kind))
            argv.append(str(pool[v]) if kind == "file" else v)
    chosen = data.draw(st.lists(st.sampled_from(sorted(options)), max_size=3, unique=True))
    for opt in chosen:
        kind = options[opt]
        argv.append(opt)
        if kind is not None:
            v = data.draw(_value(kind))
            argv.append(str(pool[v]) if kind == "file" else v)
    if not command.startswith("eval"):
        out = tmp_path / f"case-{next(_CASE)}"  # a fresh place every example
        argv += ["-o", str(out / ("res" if command in ("simulate", "track-av", "robot-sim")
                                  else "res.txt"))]
    if command in ("simulate", "robot-sim"):
        argv += ["--duration", "0.5"]  # last one wins: keep each case short
    if data.draw(st.booleans()):
        argv.append("--force")
    argv.append("-q")
    before = _hashes(pool)
    try:
        rc = main(argv)
    except SystemExit as exc:  # argparse: usage errors exit 2, --help exits 0
        rc = exc.code
    if os.environ.get("AVTRACK_FUZZ_LOG"):
        with open(os.environ["AVTRACK_FUZZ_LOG"], "a") as fh:
            fh.write(f"{rc} {argv[:8]}\n")
    assert rc in (0, 2), f"{argv} -> exit {rc}"
    assert _hashes(pool) == before, f"{argv} changed an input"


def test_fuzzing_stays_under_2_gib():
    """Peak resident memory of this test process, after the fuzz cases above: under 2 GiB
    (no case may allocate by the numbers it was given)."""
    import resource
    import sys

    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    peak_bytes = peak if sys.platform == "darwin" else peak * 1024  # Linux: KiB
    assert peak_bytes < 2 * 2**30, f"peak {peak_bytes / 2**30:.2f} GiB"
