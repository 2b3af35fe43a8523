"""Write ``data/pingpong.m4a``: the bundled real ping-pong as a phone's voice-memo app saves
it (AAC 128 kb/s, mono, 44.1 kHz, in an .m4a).

It is made with :func:`drumroll.audio.encode.encode`, the encoder the tests and the onset
benchmark use, from ``data/pingpong.wav`` (MIT licence, ``data/pingpong.md``), so that the
README can show a phone file working end to end::

    python examples/make_phone_recording.py [--force]
    drumroll onsets data/pingpong.m4a -o onsets.csv
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import soundfile as sf

from drumroll.audio.encode import encode

DATA = Path(__file__).resolve().parents[1] / "data"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DATA / "pingpong.m4a")
    parser.add_argument("--force", action="store_true", help="overwrite an existing file")
    args = parser.parse_args(argv)
    if args.out.exists() and not args.force:
        print(f"{args.out}: already exists (use --force to overwrite it)", file=sys.stderr)
        return 2
    x, sr = sf.read(DATA / "pingpong.wav")
    encode(x, sr, args.out, "aac-128")
    print(f"wrote {args.out} ({args.out.stat().st_size / 1000:.0f} kB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
