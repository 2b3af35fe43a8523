"""Where the tests find the project's bundled data and the shared recordings beside it."""

from pathlib import Path

#: The project's root (this file is ``<root>/tests/paths.py``).
ROOT = Path(__file__).resolve().parents[1]
#: The bundled recordings, configs and samples.
DATA = ROOT / "data"
#: Recordings made by others, with truth (``../shared/corpus``), when present.
CORPUS = ROOT.parent / "shared" / "corpus"
