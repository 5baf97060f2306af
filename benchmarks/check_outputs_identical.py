"""Check that the command line writes byte-identical files on the demo and benchmark scenes.

Runs a fixed list of ``avtrack`` commands (simulation, visual, acoustic, audio-visual and
SMC-PHD tracking, localization, the robot head, evaluation) into a work directory and hashes
every file they write. ``--write MANIFEST`` stores the hashes; ``--check MANIFEST`` compares
with a stored manifest and lists every file that differs, is missing or is new.

    python benchmarks/check_outputs_identical.py --work /tmp/out-a --write manifest.json
    python benchmarks/check_outputs_identical.py --work /tmp/out-b --check manifest.json

Figures (PNG) are left out, being renderer-dependent; timings printed on the terminal are not
files and so are not compared. A WAV file is hashed by its sample rate and samples (libsndfile
stamps the time into the PEAK chunk of float WAVs), and the work directory's path is taken out
of text files (the JSON scores name their input files). Steps that need the shared data
(``../shared/data`` or
``AVTRACK_SHARED_DATA``) are skipped, saying so, where it is absent.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

SHARED = Path(
    os.environ.get("AVTRACK_SHARED_DATA", Path(__file__).resolve().parents[1] / "../shared/data")
)

#: The simulated LOCATA-like recording and its array, as the audio commands take them.
LOCATA = ["{w}/locata/audio.wav", "--array", "{w}/locata/array.json"]

# (name, argv after "avtrack", needs shared data); "{w}" is the work directory
STEPS: list[tuple[str, list[str], bool]] = [
    ("sim-meeting", ["simulate", "meeting", "-o", "{w}/meeting", "--seed", "0",
                     "--duration", "8", "--utterances", "synthetic"], False),
    ("sim-walkout", ["simulate", "walkout", "-o", "{w}/walkout", "--seed", "3",
                     "--duration", "10", "--utterances", "synthetic"], False),
    ("sim-locata", ["simulate", "locata-like", "-o", "{w}/locata", "--seed", "1",
                    "--duration", "6", "--utterances", "synthetic"], False),
    ("track-av-direction", ["track-av", "{w}/walkout", "-o", "{w}/av-direction"], False),
    ("track-av-meeting", ["track-av", "{w}/meeting", "-o", "{w}/av-meeting"], False),
    ("track-av-image", ["track-av", "{w}/meeting", "-o", "{w}/av-image", "--model", "image"],
     False),
    ("track-av-noaudio", ["track-av", "{w}/walkout", "-o", "{w}/av-noaudio", "--no-audio"],
     False),
    ("track-mot-scene", ["track-mot", "{w}/meeting/detections.txt", "-o", "{w}/mot-meeting.txt"],
     False),
    ("localize-dprtf-eg", ["localize", *LOCATA, "--method", "dprtf-eg",
                           "-o", "{w}/doa-dprtf-eg.csv"], False),
    ("localize-default", ["localize", *LOCATA, "-o", "{w}/doa-default.csv"], False),
    ("localize-srp", ["localize", *LOCATA, "--method", "srp-phat", "-o", "{w}/doa-srp.csv"],
     False),
    ("localize-prp-rem", ["localize", *LOCATA, "--method", "prp-rem",
                          "-o", "{w}/doa-prp-rem.csv"], False),
    ("localize-dprtf-rem", ["localize", *LOCATA, "--method", "dprtf-rem",
                            "-o", "{w}/doa-dprtf-rem.csv"], False),
    ("track-audio-vonmises", ["track-audio", *LOCATA, "--tracker", "vonmises",
                              "-o", "{w}/tracks-vonmises.csv"], False),
    ("track-audio-gauss", ["track-audio", *LOCATA, "--tracker", "gauss",
                           "-o", "{w}/tracks-gauss.csv"], False),
    ("track-audio-doa", ["track-audio", "--doa", "{w}/doa-dprtf-eg.csv", "--tracker", "vonmises",
                         "-o", "{w}/tracks-doa.csv"], False),
    ("stream", ["stream", *LOCATA, "-o", "{w}/stream.csv"], False),
    ("eval-doa", ["eval", "doa", "{w}/locata/gt/doa.csv", "{w}/doa-dprtf-eg.csv",
                  "--json", "{w}/eval-doa.json"], False),
    ("eval-mot", ["eval", "mot", "{w}/walkout/gt/gt.txt", "{w}/av-direction/tracks.txt",
                  "--json", "{w}/eval-mot.json"], False),
    ("eval-der", ["eval", "der", "{w}/walkout/gt/speech.rttm", "{w}/av-direction/speech.rttm",
                  "--json", "{w}/eval-der.json"], False),
    ("robot-sim", ["robot-sim", "follow1", "-o", "{w}/robot", "--seed", "0",
                   "--duration", "5"], False),
    ("track-mot-tud", ["track-mot", "{s}/mot15/TUD-Campus/det/det.txt", "-o", "{w}/tud.txt"],
     True),
    ("track-phd-lpf", ["track-phd", "{s}/av16.3", "--seq", "45", "--cam", "1", "--filter", "lpf",
                       "--seed", "0", "-o", "{w}/phd-lpf.csv"], True),
    ("track-phd-npf", ["track-phd", "{s}/av16.3", "--seq", "24", "--cam", "1", "--filter", "npf",
                       "--seed", "0", "-o", "{w}/phd-npf.csv"], True),
]


def run_steps(work: Path) -> None:
    """Run every step into ``work`` (emptied first); a failing step stops with its output."""
    if work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True)
    exe = shutil.which("avtrack") or "avtrack"
    for name, argv, needs_shared in STEPS:
        if needs_shared and not SHARED.is_dir():
            print(f"skip {name}: no shared data at {SHARED}")
            continue
        args = [a.format(w=work, s=SHARED) for a in argv]
        proc = subprocess.run([exe, *args, "-q"] if args[0] != "eval" else [exe, *args],
                              capture_output=True, text=True)
        if proc.returncode != 0:
            sys.exit(f"{name} failed ({proc.returncode}):\n{proc.stdout}\n{proc.stderr}")
        print(f"ran {name}")


def file_bytes(path: Path, work: Path) -> bytes:
    """What is compared of ``path``: its bytes, a WAV's rate and samples, a text file's bytes
    with ``work`` replaced by ``{work}``."""
    if path.suffix == ".wav":
        import soundfile

        data, fs = soundfile.read(path, dtype="float64", always_2d=True)
        return str(fs).encode() + data.tobytes()
    raw = path.read_bytes()
    if path.suffix in (".json", ".csv", ".txt", ".yaml", ".md", ".rttm"):
        raw = raw.replace(str(work).encode(), b"{work}")
    return raw


def hash_tree(work: Path) -> dict[str, str]:
    """SHA-256 of every file under ``work`` but figures, by path relative to ``work``."""
    out = {}
    for p in sorted(work.rglob("*")):
        if p.is_file() and p.suffix != ".png":
            digest = hashlib.sha256(file_bytes(p, work)).hexdigest()
            out[p.relative_to(work).as_posix()] = digest
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--work", type=Path, required=True, help="output directory (emptied)")
    mode = ap.add_mutually_exclusive_group(required=True)
    mode.add_argument("--write", type=Path, metavar="MANIFEST", help="store the hashes")
    mode.add_argument("--check", type=Path, metavar="MANIFEST", help="compare with stored hashes")
    ap.add_argument("--no-run", action="store_true", help="hash what --work holds already")
    args = ap.parse_args(argv)
    if not args.no_run:
        run_steps(args.work)
    hashes = hash_tree(args.work)
    if args.write:
        args.write.write_text(json.dumps(hashes, indent=1, sort_keys=True) + "\n")
        print(f"{len(hashes)} files hashed into {args.write}")
        return 0
    stored = json.loads(args.check.read_text())
    common = sorted(stored.keys() & hashes.keys())
    bad = [f"differs: {k}" for k in common if stored[k] != hashes[k]]
    bad += [f"missing: {k}" for k in sorted(stored.keys() - hashes.keys())]
    bad += [f"new: {k}" for k in sorted(hashes.keys() - stored.keys())]
    for line in bad:
        print(line)
    print(f"{len(stored)} files in the manifest, {len(bad)} problems")
    return 1 if bad else 0


if __name__ == "__main__":
    raise SystemExit(main())
