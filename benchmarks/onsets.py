"""Benchmark: drumroll's onset extractor against librosa on simulated recordings with truth.

Usage: ``python benchmarks/onsets.py [--trials N] [--first-seed S] [--jitter-ms J] [--quick]
[--no-memory] [--no-peers] [--no-real-hits | --real-hits-only] [--no-phone | --phone-only]
[--phone-condition TEXT ...] [--misses] [--against REV]``

Per condition: F1 at ±2 ms (misses counted only for impacts with truth ``local_snr_db >=
0``; a detection matching no impact is a false positive; one matching an inaudible impact is
neither), recall over all impacts, offset-free timing error (MAD of detected - true) over
the impacts F1 counts, as the corpus's own scorer (``../shared/tools/score_onsets.py``) has
it, and ("MAD all") over every matched detection, inaudible impacts included, as this
benchmark had it before (an extractor that reports more of a roll's inaudible bounces scores
worse on it, whatever their ``sigma_s`` says), and onsets before the first impact / after
the last one. ``--against REV`` scores the onset extractor of a git revision (its ``src``
from ``git archive``, run in a subprocess) on the same recordings, in the same tables, for a
before/after comparison in one run, and times both on the same impacts: each roll's MAD over
the impacts both matched, and the paired difference with a bootstrap interval over rolls.
Peers: librosa ``onset_detect`` with its defaults, and with hop 64 and ``backtrack=True``.
The grid is every SNR (30/20/12 dB) x room and disturbance condition x sample rate
(22.05/44.1/48/96 kHz); then recordings that hold no roll (one hit, two, three unrelated
ones), which should give none. Then the same rolls (same seeds) made of real recorded hits
(``data/samples``: three AVL snares in five velocity layers, the Sonic Pi snare in two,
claves for a ball) in two measured rooms, scored the same way (``--no-real-hits`` skips this
grid, ``--real-hits-only`` runs nothing else). Then throughput on a 60 s 44.1 kHz file
against librosa's onset_detect (best of five CPU times each, and their ratio); peak memory
(peak RSS of a fresh subprocess, and tracemalloc's peak) and speed on 10-, 20- and 60-minute
files of a roll every 3.2 s, written blockwise; and on a 60-minute AAC .m4a (decoded by
FFmpeg into a temporary file).

Phone recordings (``--phone-only`` runs nothing else, ``--no-phone`` skips them): the corpus
and the real ping-pong encoded as a phone, a camera or a messaging app would (AAC 128 and
64 kb/s, a camera's .mp4 and .mov with AAC 128 kb/s beside H.264 video, Opus 64 and 32 kb/s,
MP3 128 kb/s, AMR-NB 12.2 kb/s at 8 kHz, ALAC as a check),
resampled to 16 and 8 kHz, and through a phone's automatic gain control (alone and before AAC
64 kb/s), each scored side by side with the lossless original by the corpus's rules (F1, MAD
against the truth, first impact found) and onset by onset against the original's onsets: the
share found within 1 ms (of all the original's onsets, and of those that time an audible true
impact: :func:`audible_onsets`), the share of audible true impacts with an onset within 1 ms
of the truth itself (:func:`timed_impacts`), the median shift, the decoded audio's offset
against the original
(cross-correlation: the priming taken off, or not) and the spread of the shifts (1.4826 x MAD,
an sd), which is the timing floor ``drumroll.audio.timing`` adds to ``sigma_s``.
``--phone-condition`` runs only the conditions whose label holds the text (``'AAC 128'``);
``--misses`` lists every onset a condition moves by more than 1 ms or loses, with its level
and the step of the extractor (tracker or stage) after which the original has it and the
coded file does not.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import warnings
from fractions import Fraction
from pathlib import Path

import numpy as np
import soundfile as sf
from scipy import signal

from drumroll.audio import read_audio
from drumroll.errors import AudioError, DrumrollWarning
from drumroll.onsets import OnsetTable, detect
from drumroll.onsets.refine import CODEC_SNR_DB, IMPACT_RISE_S
from drumroll.simulation import Disturbances, HitBank, MeasuredRoom, Room, render, render_hits
from drumroll.simulation.phone import phone_agc


def roll_truth(rng: np.random.Generator, jitter_s: float = 0.0
               ) -> tuple[np.ndarray, np.ndarray]:
    """A geometric roll's impact times and speeds; ``jitter_s`` scatters the times about the
    law (Gaussian), as a real bouncer's do, so that nothing can lean on an exact law."""
    alpha = rng.uniform(0.8, 0.95)
    tb = rng.uniform(0.15, 0.4)
    flights = tb * alpha ** np.arange(1, 80)
    flights = flights[flights > 0.004]
    times = np.concatenate(([0.0], np.cumsum(flights)))
    speeds = rng.uniform(0.8, 1.6) * alpha ** np.arange(times.size)
    if jitter_s > 0:
        times = np.sort(times + jitter_s * rng.standard_normal(times.size))
    return times, speeds


def nearest_errors(det: np.ndarray, truth: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each detection's nearest true impact (index) and its error against it (s)."""
    d = det[:, None] - truth[None, :]
    near = np.abs(d).argmin(axis=1)
    return near, d[np.arange(det.size), near]


def read_truth(path: Path) -> tuple[dict, np.ndarray, np.ndarray]:
    """A ``<name>.truth.json``: its contents, the impact times (s) and which impacts are
    audible (``local_snr_db >= 0``: the impacts F1 counts)."""
    truth = json.loads(path.read_text())
    t = np.asarray(truth["onset_times_s"], dtype=float)
    return truth, t, np.asarray(truth.get("local_snr_db", np.zeros(t.size))) >= 0


def constant_latency(det: np.ndarray, truth: np.ndarray) -> float:
    """The median difference (s) of detections from their nearest impacts within 25 ms: a
    constant latency, which changes no flight (0 when none is that close)."""
    lag = nearest_errors(det, truth)[1]
    lag = lag[np.abs(lag) <= 0.025]
    return float(np.median(lag)) if lag.size else 0.0


def evaluate(det: np.ndarray, truth: np.ndarray, audible: np.ndarray, tol: float = 0.002):
    """F1, recall, MAD (s) over the matched impacts F1 counts, onsets before the first impact
    and after the last, and MAD (s) over every matched detection (module docstring)."""
    if det.size == 0:
        return 0.0, 0.0, np.nan, 0, 0, np.nan
    near, err = nearest_errors(det, truth)
    ok = np.abs(err) <= tol
    hit = set(near[ok].tolist())
    tp = len(hit & set(np.flatnonzero(audible).tolist()))
    fp = int(np.count_nonzero(~ok))
    fn = int(audible.sum()) - tp
    f1 = 2 * tp / max(2 * tp + fp + fn, 1)
    recall = len(hit) / truth.size
    mad = _mad(err[ok & audible[near]])
    before = int(np.count_nonzero(det < truth[0] - tol))
    after = int(np.count_nonzero(det > truth[-1] + tol))
    return f1, recall, mad, before, after, _mad(err[ok])


def _mad(e: np.ndarray) -> float:
    """Median absolute deviation of ``e`` about its median (NaN for none)."""
    return float(np.median(np.abs(e - np.median(e)))) if e.size else float("nan")


def matched_errors(det: np.ndarray, truth: np.ndarray, tol: float = 0.002) -> dict[int, float]:
    """Each detection's error against its nearest impact, by impact index, within ``tol``."""
    if det.size == 0:
        return {}
    near, err = nearest_errors(det, truth)
    return {int(k): float(e) for k, e in zip(near, err, strict=True)
            if abs(e) <= tol}


def same_impacts_mad(ours: np.ndarray, theirs: np.ndarray, truth: np.ndarray
                     ) -> tuple[float, float]:
    """Both extractors' MAD (s) over the impacts both matched: the like-for-like timing
    comparison (an extractor that finds more faint impacts than another is not timed on
    impacts the other never reported)."""
    a, b = matched_errors(ours, truth), matched_errors(theirs, truth)
    common = sorted(set(a) & set(b))
    if not common:
        return float("nan"), float("nan")
    return (_mad(np.array([a[k] for k in common])), _mad(np.array([b[k] for k in common])))


def paired_difference_ms(ours: np.ndarray, theirs: np.ndarray, seed: int = 0
                         ) -> tuple[float, float, float]:
    """Median over rolls of ours - theirs (per-roll MADs, s) in ms, with a 95 % bootstrap
    interval over rolls (2000 resamples)."""
    ok = np.isfinite(ours) & np.isfinite(theirs)
    diff = 1e3 * (ours[ok] - theirs[ok])
    if diff.size == 0:
        return float("nan"), float("nan"), float("nan")
    rng = np.random.default_rng(seed)
    boot = np.median(diff[rng.integers(0, diff.size, (2000, diff.size))], axis=1)
    lo, hi = np.quantile(boot, [0.025, 0.975])
    return float(np.median(diff)), float(lo), float(hi)


def standard_errors(table, truth: np.ndarray) -> np.ndarray:
    """Each detected onset's error (offset-free: less the roll's median error) over its own
    ``sigma_s``, against the nearest true impact: honest uncertainties scatter like a unit
    Gaussian."""
    if len(table.time_s) == 0:
        return np.zeros(0)
    err = nearest_errors(table.time_s, truth)[1]
    return (err - np.median(err)) / table.sigma_s


def peers(x: np.ndarray, sr: int) -> dict[str, np.ndarray]:
    import librosa

    y = x if x.ndim == 1 else x.mean(axis=1)
    y = y.astype(np.float32)
    out = {"librosa": librosa.onset.onset_detect(y=y, sr=sr, units="time")}
    out["librosa h64 bt"] = librosa.onset.onset_detect(y=y, sr=sr, hop_length=64,
                                                       backtrack=True, units="time")
    return out


CONDITIONS = {
    "clean": dict(room=Room(), spurious=False, hum=None),
    "echo": dict(room=Room(echo=True), spurious=False, hum=None),
    "reverb": dict(room=Room(reverb_time_s=0.4), spurious=False, hum=None),
    "hum+spurious": dict(room=Room(), spurious=True, hum=50.0),
    "all": dict(room=Room(echo=True, reverb_time_s=0.4), spurious=True, hum=60.0),
}


def run_grid(trials: int, quick: bool, with_peers: bool, first_seed: int = 0,
             jitter_s: float = 0.0, against: Revision | None = None
             ) -> dict[str, dict[int, dict[str, float]]]:
    rates = (44100,) if quick else (22050, 44100, 48000, 96000)
    grid = [(snr, name, sr) for sr in rates for snr in (30, 20, 12) for name in CONDITIONS]
    if quick:
        grid = [g for g in grid if g[1] in ("clean", "all")]

    def make(snr: int, name: str, sr: int):
        cond = CONDITIONS[name]

        def recording(times, speeds, rng):
            dist = Disturbances(snr_db=snr, hum_hz=cond["hum"], spurious=cond["spurious"])
            return render(times, speeds, sample_rate=sr, room=cond["room"], disturbances=dist,
                          rng=rng)
        return recording

    return score_grid([(snr, f"{snr} dB {name} {sr / 1000:g} kHz", make(snr, name, sr))
                       for snr, name, sr in grid], trials, with_peers, first_seed, jitter_s,
                      against)


SAMPLES = Path(__file__).resolve().parents[1] / "data" / "samples"
#: The corpus of rolls built by others from real recorded hits (outside this repository).
CORPUS = Path(__file__).resolve().parents[2] / "shared" / "corpus"
#: Bundled real recordings with reference impacts.
REAL = Path(__file__).resolve().parents[1] / "data"
#: Real recorded hits (velocity layers, softest first) and measured rooms, in data/samples.
REAL_HITS = {
    "pearl": [f"avl/38-PearlSnare-{i}.flac" for i in range(1, 6)],
    "pearl2": [f"avl/38-PearlSnare2-{i}.flac" for i in range(1, 6)],
    "porkpie": [f"avl/38-PorkpieSnare-{i}.flac" for i in range(1, 6)],
    "sonic": ["sonic_pi/drum_snare_soft.flac", "sonic_pi/drum_snare_hard.flac"],
    "claves": ["js30/claves-1.ogg"],
}
REAL_ROOMS = {"live": "rooms/genesis6_live_room.flac",
              "hall": "rooms/arthur_sykes_rymer_auditorium.flac"}


def run_real_grid(trials: int, quick: bool, with_peers: bool, first_seed: int = 0,
                  jitter_s: float = 0.0, against: Revision | None = None
                  ) -> dict[str, dict[int, dict[str, float]]]:
    """The grid of :func:`run_grid` with real recorded hits in measured rooms: every snare
    and the claves x both rooms x SNR x sample rate, the same rolls (same seeds), scored the
    same way. Hits are layered by speed with the defaults of ``drumroll simulate`` (6 dB per
    layer, level exponent 1.2, 1.5 dB spread, room at -12 dB)."""
    print("\nreal recorded hits (data/samples) in measured rooms (live: Genesis 6 live room, "
          "hall: Arthur Sykes Rymer Auditorium)")
    rates = (44100,) if quick else (22050, 44100, 48000, 96000)
    grid = [(snr, inst, room, sr) for sr in rates for snr in (30, 20, 12)
            for inst in REAL_HITS for room in REAL_ROOMS]
    if quick:
        grid = [g for g in grid if g[1] in ("pearl", "claves")]
    banks: dict[tuple[str, int], HitBank] = {}
    rooms: dict[tuple[str, int], MeasuredRoom] = {}

    def make(snr: int, inst: str, room: str, sr: int):
        def recording(times, speeds, rng):
            if (inst, sr) not in banks:
                banks[inst, sr] = HitBank.load([SAMPLES / f for f in REAL_HITS[inst]], sr)
            if (room, sr) not in rooms:
                rooms[room, sr] = MeasuredRoom.load(SAMPLES / REAL_ROOMS[room], sr)
            return render_hits(times, speeds, bank=banks[inst, sr], room=rooms[room, sr],
                               disturbances=Disturbances(snr_db=snr), rng=rng)
        return recording

    return score_grid([(snr, f"{snr} dB {inst} {room} {sr / 1000:g} kHz",
                        make(snr, inst, room, sr))
                for snr, inst, room, sr in grid], trials, with_peers, first_seed, jitter_s,
                      against)


def score_grid(grid, trials: int, with_peers: bool, first_seed: int, jitter_s: float,
               against: Revision | None = None) -> dict[str, dict[int, dict[str, float]]]:
    """Score every ``(snr, label, recording)`` of ``grid`` over ``trials`` rolls; print a row
    per condition and method, then the summary per SNR and the sigma_s check.
    ``recording(times, speeds, rng)`` renders one roll; ``against`` is an earlier revision's
    extractor, scored on the same rolls. Returns drumroll's summary per SNR (mean F1,
    median MAD and MAD all in ms, the fractions of errors within 1 and 2 sigma_s), and the
    revision's, by method name."""
    rows = []
    print(f"{'condition':28s} {'method':17s} {'F1':>5s} {'recall':>6s} {'MAD ms':>7s} "
          f"{'MAD all':>7s} {'before':>6s} {'after':>5s}")
    zs: dict[str, dict[int, list]] = {}
    paired: dict[int, list[tuple[float, float]]] = {}
    for snr, label, recording in grid:
        acc: dict[str, list] = {}
        for seed in range(first_seed, first_seed + trials):
            rng = np.random.default_rng(1000 * snr + seed)
            times, speeds = roll_truth(rng, jitter_s)
            r = recording(times, speeds, rng)
            truth, audible = r.impact_times_s, r.local_snr_db >= 0
            try:
                table = detect(r.samples, r.sample_rate)
                ours = table.time_s
                zs.setdefault("drumroll", {}).setdefault(snr, []).append(
                    standard_errors(table, truth))
            except AudioError:
                ours = np.zeros(0)
            results = {"drumroll": ours}
            if against is not None:
                theirs = against.detect(r.samples, r.sample_rate)
                if theirs is not None:
                    zs.setdefault(against.name, {}).setdefault(snr, []).append(
                        standard_errors(theirs, truth))
                results[against.name] = np.zeros(0) if theirs is None else theirs.time_s
                paired.setdefault(snr, []).append(
                    same_impacts_mad(ours, results[against.name], truth))
            if with_peers:
                results.update(peers(r.samples, r.sample_rate))
            for method, det in results.items():
                acc.setdefault(method, []).append(evaluate(det, truth, audible))
        for method, vals in acc.items():
            v = np.array(vals, dtype=float)
            print(f"{label:28s} {method:17s} {np.mean(v[:, 0]):5.3f} {np.mean(v[:, 1]):6.3f} "
                  f"{_median_ms(v[:, 2]):7.3f} {_median_ms(v[:, 5]):7.3f} "
                  f"{int(v[:, 3].sum()):6d} {int(v[:, 4].sum()):5d}")
            rows.append((snr, method, v))
        sys.stdout.flush()
    print("\nsummary over conditions and sample rates (mean F1, min F1 of any roll; MAD over "
          "the impacts F1 counts, MAD all over every matched detection)")
    summary: dict[str, dict[int, dict[str, float]]] = {}
    for method in dict.fromkeys(r[1] for r in rows):
        for snr in (30, 20, 12):
            vs = np.concatenate([r[2] for r in rows if r[0] == snr and r[1] == method])
            mad, mad_all = _median_ms(vs[:, 2]), _median_ms(vs[:, 5])
            print(f"  {method:17s} {snr} dB: F1 {np.mean(vs[:, 0]):.3f} "
                  f"(min {np.min(vs[:, 0]):.3f}), recall {np.mean(vs[:, 1]):.3f}, MAD "
                  f"{mad:.3f} ms, MAD all {mad_all:.3f} ms, before {int(vs[:, 3].sum())}, "
                  f"after {int(vs[:, 4].sum())}")
            if method in zs:
                summary.setdefault(method, {})[snr] = {"f1": float(np.mean(vs[:, 0])),
                                                       "mad_ms": mad, "mad_all_ms": mad_all}
    if paired:
        print(f"\ntiming on the same impacts (the impacts both drumroll and {against.name} "
              "matched, roll by roll): median per-roll MAD, and the median paired difference "
              "with its 95 % bootstrap interval over rolls")
        for snr in (30, 20, 12):
            pairs = np.array(paired.get(snr, []), dtype=float).reshape(-1, 2)
            diff, lo, hi = paired_difference_ms(pairs[:, 0], pairs[:, 1])
            print(f"  {snr} dB: drumroll {_median_ms(pairs[:, 0]):.3f} ms, {against.name} "
                  f"{_median_ms(pairs[:, 1]):.3f} ms, difference {diff:+.4f} ms "
                  f"[{lo:+.4f}, {hi:+.4f}] ({pairs.shape[0]} rolls)")
    print("\nsigma_s against the actual errors (a unit Gaussian has 0.683 within 1 sigma, "
          "0.954 within 2, 0.0000006 beyond 5)")
    for method, by_snr in zs.items():
        for snr in (30, 20, 12):
            z = np.abs(np.concatenate(by_snr.get(snr, [np.zeros(0)])))
            if z.size:
                print(f"  {method:17s} {snr} dB: within 1 sigma {np.mean(z <= 1):.3f}, within "
                      f"2 {np.mean(z <= 2):.3f}, beyond 5 {np.mean(z > 5):.4f} ({z.size} "
                      "onsets)")
                summary.setdefault(method, {}).setdefault(snr, {}).update(
                    within_1=float(np.mean(z <= 1)), within_2=float(np.mean(z <= 2)))
    return summary


def _median_ms(mads: np.ndarray) -> float:
    """The median of the finite per-roll MADs (s), in ms; NaN for none."""
    finite = mads[np.isfinite(mads)]
    return 1e3 * float(np.median(finite)) if finite.size else float("nan")


class Revision:
    """The onset extractor of an earlier git revision of this repository, for a
    before/after comparison on the same recordings: the revision's ``src`` (``git archive``)
    in a temporary folder, imported by a child process (this environment's Python and
    packages) that detects, recording by recording, what :meth:`detect` hands it."""

    _CHILD = """
import json, sys, warnings
import numpy as np
warnings.simplefilter("ignore")
from drumroll.onsets import detect
for line in sys.stdin:
    ask = json.loads(line)
    try:
        if "npz" in ask:
            z = np.load(ask["npz"])
            t = detect(z["x"], int(z["sr"]))
        else:
            t = detect(ask["path"])
        bounce = getattr(t, "bounce", None)
        out = {"t": t.time_s.tolist(), "s": t.sigma_s.tolist(),
               "b": None if bounce is None else np.asarray(bounce).tolist()}
    except Exception as e:  # the revision's own AudioError: no roll
        out = {"error": f"{type(e).__name__}: {e}"}
    print(json.dumps(out), flush=True)
"""

    def __init__(self, rev: str) -> None:
        import io
        import tarfile

        root = Path(__file__).resolve().parents[1]
        commit = subprocess.run(["git", "-C", str(root), "rev-parse", "--short", rev],
                                capture_output=True, text=True, check=True).stdout.strip()
        self.name = f"drumroll@{commit}"
        self._dir = tempfile.TemporaryDirectory(prefix="drumroll-rev-")
        archive = subprocess.run(["git", "-C", str(root), "archive", "--format=tar", commit,
                                  "src"], capture_output=True, check=True).stdout
        with tarfile.open(fileobj=io.BytesIO(archive)) as tar:
            tar.extractall(self._dir.name, filter="data")
        env = dict(os.environ, PYTHONPATH=str(Path(self._dir.name) / "src"))
        self._child = subprocess.Popen([sys.executable, "-c", self._CHILD], env=env,
                                       stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                       text=True)

    def _ask(self, request: dict) -> OnsetTable | None:
        assert self._child.stdin is not None and self._child.stdout is not None
        self._child.stdin.write(json.dumps(request) + "\n")
        self._child.stdin.flush()
        got = json.loads(self._child.stdout.readline())
        if "error" in got:
            return None
        t = np.asarray(got["t"], dtype=float)
        bounce = np.arange(t.size) if got["b"] is None else np.asarray(got["b"])
        return OnsetTable(t, np.zeros(t.size), np.zeros(t.size), np.asarray(got["s"]),
                          bounce=bounce)

    def detect(self, samples: np.ndarray, sr: int) -> OnsetTable | None:
        """The revision's onsets of a recording given as samples; None where it finds no
        roll."""
        with tempfile.NamedTemporaryFile(suffix=".npz", dir=self._dir.name) as f:
            np.savez(f, x=samples, sr=sr)
            f.flush()
            return self._ask({"npz": f.name})

    def detect_file(self, path: Path) -> OnsetTable | None:
        """The revision's onsets of a recording file; None where it finds no roll."""
        return self._ask({"path": str(path)})

    def close(self) -> None:
        if self._child.stdin is not None:
            self._child.stdin.close()
        self._child.wait()
        self._dir.cleanup()


def score_folder(folder: Path, pattern: str = "*", tol: float = 0.002, *,
                 tables: dict | None = None, verbose: bool = True,
                 against: Revision | None = None) -> dict[str, float] | None:
    """Score the extractor on recordings made by others: every ``<name>.truth.json`` in
    ``folder`` whose name matches ``pattern``, with its recording beside it
    (``onset_times_s``, ``local_snr_db``; with
    ``"complete": false`` detections after the last referenced impact are not judged). The
    rules of the corpus's own scorer: a constant latency is taken out first (the median
    difference within 25 ms: it changes no flight); F1 at ±2 ms over the impacts with local
    SNR >= 0 dB (a detection matching no impact is a false positive); the timing MAD over
    those impacts (and, as "MAD all", over every matched detection); whether the first
    impact is found and every bounce number names the right impact; and each error (less the
    latency) over its own sigma_s. Prints a row per recording (with ``verbose``), returns
    the pooled figures (None without recordings); ``tables``, if given, receives each
    recording's onset table by name. With ``against``, the earlier revision's extractor is
    the one scored."""
    rows, zs, mads, mads_all = [], [], [], []
    pooled = np.zeros(3, dtype=int)
    first_ok = numbered_ok = 0
    for truth_file in sorted(folder.glob(pattern + ".truth.json")):
        name = truth_file.name[: -len(".truth.json")]
        audio = [p for p in folder.glob(name + ".*")
                 if not p.name.endswith((".json", ".txt", ".toml", ".md", ".LICENSE"))]
        if not audio:
            continue
        truth, t, counted = read_truth(truth_file)
        try:
            table = detect(audio[0]) if against is None else against.detect_file(audio[0])
            if table is None:
                raise AudioError("no roll")
            det, bounce, sigma = table.time_s, table.bounce, table.sigma_s
            if tables is not None:
                tables[name] = table
        except AudioError:
            det, bounce, sigma = np.zeros(0), np.zeros(0, dtype=int), np.zeros(0)
        det = det - constant_latency(det, t)
        if not truth.get("complete", True):
            keep = det <= t[-1] + 0.3 * (t[-1] - t[-2])
            det, bounce, sigma = det[keep], bounce[keep], sigma[keep]
        pairs = sorted((abs(d - x), i, j) for i, x in enumerate(t) for j, d in enumerate(det)
                       if abs(d - x) <= tol)
        match: dict[int, int] = {}
        used: set[int] = set()
        for _, i, j in pairs:
            if i not in match and j not in used:
                match[i] = j
                used.add(j)
        tp = sum(1 for i in match if counted[i])
        fp, fn = det.size - len(match), int(counted.sum()) - tp
        err = np.array([det[j] - t[i] for i, j in match.items()])
        mad = _mad(np.array([det[j] - t[i] for i, j in match.items() if counted[i]]))
        mads_all.append(_mad(err))
        nearest = nearest_errors(det, t)[0]
        numbered = bool(det.size) and nearest[0] == 0 and all(
            bounce[k] - bounce[0] == i for k, i in enumerate(nearest))
        first_ok += 0 in match
        numbered_ok += numbered
        pooled += (tp, fp, fn)
        mads.append(mad)
        if err.size:
            zs.append(np.array([(det[j] - t[i]) / sigma[j] for i, j in match.items()]))
        f1 = 2 * tp / max(2 * tp + fp + fn, 1)
        rows.append(name)
        if not verbose:
            continue
        print(f"{name:30s} F1 {f1:.3f} (tp {tp} fp {fp} fn {fn}), MAD {1e3 * mad:.3f} ms, "
              f"first impact {'found' if 0 in match else 'MISSED'}, numbering "
              f"{'right' if numbered else 'WRONG'}")
    if not rows:
        return None
    tp, fp, fn = pooled
    z = np.abs(np.concatenate(zs)) if zs else np.zeros(0)
    out = {"f1": 2 * tp / max(2 * tp + fp + fn, 1), "mad_ms": 1e3 * float(np.nanmedian(mads)),
           "mad_all_ms": 1e3 * float(np.nanmedian(mads_all)),
           "within_1": float(np.mean(z <= 1)), "within_2": float(np.mean(z <= 2)),
           "first": first_ok, "numbered": numbered_ok, "n": len(rows)}
    if not verbose:
        return out
    print(f"pooled over {len(rows)}: F1 {out['f1']:.3f} (tp {tp} fp {fp} fn {fn}), median MAD "
          f"{out['mad_ms']:.3f} ms (all {out['mad_all_ms']:.3f}), first impact found "
          f"{first_ok}/{len(rows)}, numbering right {numbered_ok}/{len(rows)}; sigma_s: within "
          f"1 sigma {out['within_1']:.3f}, within 2 "
          f"{out['within_2']:.3f} ({z.size} onsets)")
    return out


def _tag(method: str) -> str:
    """How a part's label names the extractor scored: nothing for this tree's."""
    return "" if method == "drumroll" else f" ({method})"


def side_by_side(parts: dict[str, dict]) -> None:
    """The drumroll rows of every part of the run in one table."""
    print("\nside by side: drumroll on our simulator, on real recorded hits, on recordings "
          "made by others")
    print(f"  {'recordings':54s} {'F1':>6s} {'MAD ms':>7s} {'MAD all':>7s} {'in 1σ':>6s} "
          f"{'in 2σ':>6s}  notes")
    for label, row in parts.items():
        note = (f"first impact {row['first']}/{row['n']}, numbering {row['numbered']}/{row['n']}"
                if "first" in row else "")
        print(f"  {label:54s} {row['f1']:6.3f} {row['mad_ms']:7.3f} "
              f"{row.get('mad_all_ms', float('nan')):7.3f} "
              f"{row.get('within_1', float('nan')):6.3f} {row.get('within_2', float('nan')):6.3f}"
              f"  {note}")


#: Phone conditions: label -> (kind, argument). ``encode``: a preset of
#: :data:`drumroll.audio.encode.PRESETS`; ``rate``: resampled (16-bit WAV); ``agc``: a phone's
#: automatic gain control (:func:`drumroll.simulation.phone.phone_agc`), then the preset if any.
PHONE_CONDITIONS = {
    "ALAC .m4a (lossless)": ("encode", "alac"),
    "AAC 128 kb/s .m4a": ("encode", "aac-128"),
    "AAC 64 kb/s .m4a": ("encode", "aac-64"),
    "camera .mp4, AAC 128 kb/s": ("encode", "mp4-video"),
    "camera .mov, AAC 128 kb/s": ("encode", "mov-video"),
    "Opus 64 kb/s .webm": ("encode", "opus-64"),
    "Opus 32 kb/s .webm": ("encode", "opus-32"),
    "MP3 128 kb/s": ("encode", "mp3-128"),
    "Vorbis q0.5 .ogg": ("vorbis", 0.5),
    "AMR-NB 12.2 kb/s, 8 kHz .3gp": ("encode", "amr-nb"),
    "PCM at 16 kHz": ("rate", 16000),
    "PCM at 8 kHz": ("rate", 8000),
    "phone AGC": ("agc", None),
    "phone AGC + AAC 64 kb/s": ("agc", "aac-64"),
}


def make_phone_file(source: Path, out: Path, kind: str, arg) -> Path:
    """``source`` made into the phone condition ``(kind, arg)``, written into folder ``out``
    under the same stem."""
    from drumroll.audio.encode import PRESETS, encode

    x, sr = sf.read(source, always_2d=True)
    x = x[:, 0] if x.shape[1] == 1 else x
    if kind == "rate":
        ratio = Fraction(arg, sr)
        y = signal.resample_poly(x, ratio.numerator, ratio.denominator, axis=0)
        path = out / f"{source.stem}.wav"
        sf.write(path, np.clip(y, -1, 1), arg, subtype="PCM_16")
        return path
    if kind == "vorbis":  # soundfile's Vorbis (libvorbis), at a quality (about 110 kb/s mono)
        path = out / f"{source.stem}.ogg"
        sf.write(path, x, sr, format="OGG", subtype="VORBIS", compression_level=1 - arg)
        return path
    if kind == "agc":
        x = phone_agc(x, sr)
        if arg is None:
            path = out / f"{source.stem}.wav"
            sf.write(path, x, sr, subtype="PCM_16")
            return path
    return encode(x, sr, out / f"{source.stem}{PRESETS[arg].suffix}", arg)


def decoded_offset_ms(original: Path, coded: Path) -> float:
    """The decoded file's time offset against the original (ms; the cross-correlation peak,
    parabolic interpolation): the encoder's priming left in, or too much taken off."""
    x, sr = read_audio(original, check=False)
    y, rate = read_audio(coded, check=False)
    if rate != sr:
        ratio = Fraction(rate, sr)
        x = signal.resample_poly(x, ratio.numerator, ratio.denominator)
    n = min(x.size, y.size)
    cc = signal.correlate(y[:n], x[:n], method="fft")
    k = int(np.argmax(cc))
    a, b, c = cc[k - 1], cc[k], cc[k + 1]
    den = a - 2 * b + c
    return 1e3 * (k - (n - 1) + (0.5 * (a - c) / den if den else 0.0)) / rate


def onset_shifts(reference: dict, coded: dict, pair_s: float = 0.003
                 ) -> tuple[int, int, np.ndarray, np.ndarray]:
    """Each reference onset time (s, by recording) against the nearest coded onset of the same
    recording: how many reference onsets, how many found within 1 ms, the shifts within
    ``pair_s`` (s) and the same less their recording's median (the spread a codec adds)."""
    total = found = 0
    raw, centred = [], []
    for name, ref in reference.items():
        total += ref.size
        table = coded.get(name)
        if table is None or len(table) == 0 or ref.size == 0:
            continue
        s = -nearest_errors(ref, table.time_s)[1]  # coded minus reference
        found += int(np.count_nonzero(np.abs(s) <= 1e-3))
        s = s[np.abs(s) <= pair_s]
        if s.size:
            raw.append(s)
            centred.append(s - np.median(s))
    def joined(parts: list[np.ndarray]) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(0)

    return total, found, joined(raw), joined(centred)


def audible_onsets(reference: dict, folder: Path, tol: float = 0.002) -> dict:
    """Of each recording's onsets, those that time an audible true impact: within ``tol``
    of an impact of ``<name>.truth.json`` with ``local_snr_db >= 0`` (the impacts F1
    counts), the recording's constant latency taken out as :func:`score_folder` does. An
    onset that matches no impact (a false positive, an inaudible bounce, a bounce after the
    last one an incomplete truth references) is no measure of what a codec does to timing.
    Returns ``name -> times (s)``."""
    out = {}
    for name, table in reference.items():
        _, t, audible = read_truth(folder / f"{name}.truth.json")
        det = table.time_s
        if det.size == 0 or t.size == 0:
            out[name] = np.zeros(0)
            continue
        near, err = nearest_errors(det - constant_latency(det, t), t)
        out[name] = det[(np.abs(err) <= tol) & audible[near]]
    return out


def timed_impacts(tables: dict, folder: Path, tol: float = 0.001) -> tuple[int, int]:
    """Against the truth itself: of the audible true impacts of the recordings in ``tables``
    (``name -> onset table``; truth in ``folder``), how many, and how many have an onset
    within ``tol`` (the recording's constant latency taken out as :func:`score_folder`
    does). Comparing a coded file's onsets with the original's counts as the codec's fault
    an onset the original itself places over 1 ms from its impact (a snare's faint first
    stage, timed late) when the coded file's lies nearer the impact; this does not."""
    total = timed = 0
    for name, table in tables.items():
        _, t, audible = read_truth(folder / f"{name}.truth.json")
        total += int(audible.sum())
        det = table.time_s
        if det.size == 0 or t.size == 0:
            continue
        d = np.abs((det - constant_latency(det, t))[None, :] - t[:, None]).min(axis=1)
        timed += int(np.sum((d <= tol) & audible))
    return total, timed


def share(total: int, part: int) -> float:
    """``part`` over ``total`` (0 when there is none)."""
    return part / max(total, 1)


def traced_detect(path: Path):
    """:func:`~drumroll.onsets.detect` on ``path``, with every roll's onset times as the
    tracker gave them and after each stage of ``drumroll.onsets.detector.STAGES``: returns
    the table and ``[(stage, times), ...]`` in the order they ran (a stage's times are
    pooled over the rolls)."""
    from unittest import mock

    from drumroll.onsets import detector

    log: dict[str, list[np.ndarray]] = {}

    def logged(name: str, stage):
        def run(roll, *args):
            out = stage(roll, *args)
            log.setdefault(name, []).append(out.time_s.copy())
            return out
        return run

    initial = detector._initial

    def tracked(c, tr):
        roll = initial(c, tr)
        log.setdefault("tracker", []).append(roll.time_s.copy())
        return roll

    stages = tuple(logged(s.__name__, s) for s in detector.STAGES)
    with mock.patch.object(detector, "STAGES", stages), \
            mock.patch.object(detector, "_initial", tracked):
        table = detector.detect(path)
    return table, [(name, np.concatenate(parts)) for name, parts in log.items()]


def list_misses(condition: str, name: str, original: Path, coded: Path,
                within: float = 1e-3, truth: Path | None = None) -> int:
    """Print every onset of the lossless ``original`` that the ``coded`` file does not give
    within ``within`` (s): its number, time, amplitude and SNR (as the original has them),
    its shift (to the nearest coded onset), the first step of the extractor after which
    the original has it (within ``within``) and the coded file does not ("tracker": the
    candidates and the tracker; a stage of ``detector.STAGES`` otherwise: one that moved the
    coded file's onset away, or that brought the original's to it and not the coded one),
    and, with the recording's ``truth`` file, how far the original's onset is from the
    nearest true impact (the recording's constant latency taken out, as
    :func:`score_folder` does): a miss where the original is itself off the truth is a
    sound whose start the extractor cannot tell, not a codec's doing alone. Returns how
    many."""
    ref, ref_log = traced_detect(original)
    table, log = traced_detect(coded)
    steps = dict(ref_log)
    true_t = read_truth(truth)[1] if truth is not None else np.zeros(0)
    latency = constant_latency(ref.time_s, true_t) if true_t.size else 0.0

    def nearest(times: np.ndarray, t: float) -> float:
        return float(times[np.argmin(np.abs(times - t))]) if times.size else np.inf

    count = 0
    for i, t in enumerate(ref.time_s):
        shift = nearest(table.time_s, t) - t
        if abs(shift) <= within:
            continue
        count += 1
        parted = next((stage for stage, times in log if abs(nearest(times, t) - t) > within
                       and abs(nearest(steps.get(stage, np.zeros(0)), t) - t) <= within),
                      "the table")
        off = (f", original - truth {1e3 * (t - latency - nearest(true_t, t - latency)):+.3f}"
               " ms" if true_t.size else "")
        print(f"    miss {condition:24s} {name[:26]:26s} #{i:<3d} {t:8.4f} s amplitude "
              f"{ref.amplitude[i]:.4f} SNR {ref.snr_db[i]:6.1f} dB shift {1e3 * shift:+8.3f} ms"
              f", parted by {parted}{off}")
    return count


def impact_rises(reference: dict, folder: Path, bin_s: float = 0.125e-3,
                 within_s: float = 0.005) -> np.ndarray:
    """How long each onset of the lossless recordings in ``folder`` (``reference``: name ->
    onset table) takes to rise to ``refine.CODEC_SNR_DB`` under its peak (s): from the onset,
    the first ``bin_s`` bin of the sound high-passed as onsets are refined whose power is
    within that of the loudest bin over the next ``within_s`` (or up to the next onset).
    ``refine.IMPACT_RISE_S``, the longest an impact's start can hide under a codec's noise,
    bounds them."""
    from drumroll.onsets.odf import OdfParams, wide_filter

    out = []
    for name, table in reference.items():
        audio = [p for p in folder.glob(name + ".*") if p.suffix.lower() in
                 (".wav", ".flac", ".ogg", ".mp3")]
        if not audio:
            continue
        x, sr = read_audio(audio[0], check=False)
        y = wide_filter(OdfParams(), sr).filter.filter(x)[0]
        b = max(1, round(bin_s * sr))
        at = np.round(table.time_s * sr).astype(int)
        ends = np.append(at[1:] - b, y.size)
        for a, end in zip(at, np.minimum(ends, at + round(within_s * sr)), strict=True):
            n = (end - a) // b
            if n < 2:
                continue
            power = np.mean(y[a: a + n * b].reshape(n, b) ** 2, axis=1)
            out.append(np.flatnonzero(power >= power.max() * 10 ** (-CODEC_SNR_DB / 10))[0]
                       * b / sr)
    return np.asarray(out)


def run_phone(sources: dict[str, tuple[Path, str]], conditions: list[str] | None = None,
              misses: bool = False) -> dict[str, dict[str, dict]]:
    """Every recording of each source ``label -> (folder, pattern)`` through every phone
    condition (those whose label contains one of ``conditions``, if given), scored side by
    side with its lossless original; prints the table and the pooled timing floors, and with
    ``misses`` every onset of the original not found within 1 ms, and what moved it
    (:func:`list_misses`). Returns ``source -> condition -> row``."""
    import av

    from drumroll.audio.encode import PRESETS, can_encode

    out: dict[str, dict[str, dict]] = {}
    pooled: dict[str, list[np.ndarray]] = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DrumrollWarning)
        for label, (folder, pattern) in sources.items():
            print(f"\nphone recordings: {label} ({folder}/{pattern})", flush=True)
            reference: dict = {}
            row = score_folder(folder, pattern, tables=reference, verbose=False)
            if row is None:
                continue
            rows = {"lossless original": dict(row, found=1.0, found_impacts=1.0,
                                              timed=share(*timed_impacts(reference, folder)),
                                              shift_ms=0.0, offset_ms=0.0, sd_ms=0.0)}
            rise = impact_rises(reference, folder)
            if rise.size:
                print(f"  impact rise (lossless onset to {CODEC_SNR_DB:g} dB under its peak; "
                      f"refine.IMPACT_RISE_S = {1e3 * IMPACT_RISE_S:g} ms bounds it): median "
                      f"{1e3 * np.median(rise):.2f} ms, 99 % {1e3 * np.quantile(rise, 0.99):.2f}"
                      f" ms, longest {1e3 * rise.max():.2f} ms ({rise.size} onsets)", flush=True)
            for condition, (kind, arg) in PHONE_CONDITIONS.items():
                if conditions and not any(c.lower() in condition.lower() for c in conditions):
                    continue
                if kind == "encode" and not can_encode(arg):
                    print(f"  {condition:30s} skipped: PyAV {av.__version__} has no "
                          f"{PRESETS[arg].codec} encoder", flush=True)
                    continue
                with tempfile.TemporaryDirectory() as tmp:
                    tmp_dir = Path(tmp)
                    offsets = []
                    for truth in sorted(folder.glob(pattern + ".truth.json")):
                        name = truth.name[: -len(".truth.json")]
                        audio = [p for p in folder.glob(name + ".*") if p.suffix.lower() in
                                 (".wav", ".flac", ".ogg", ".mp3")]
                        if not audio:
                            continue
                        shutil.copy(truth, tmp_dir / truth.name)
                        coded = make_phone_file(audio[0], tmp_dir, kind, arg)
                        offsets.append(decoded_offset_ms(audio[0], coded))
                    tables: dict = {}
                    scored = score_folder(tmp_dir, "*", tables=tables, verbose=False) or {}
                    if misses:
                        for name in reference:
                            coded = [p for p in tmp_dir.glob(name + ".*")
                                     if not p.name.endswith(".json")]
                            original = [p for p in folder.glob(name + ".*") if p.suffix.lower()
                                        in (".wav", ".flac", ".ogg", ".mp3")]
                            if coded and original:
                                list_misses(condition, name, original[0], coded[0],
                                            truth=folder / f"{name}.truth.json")
                total, found, raw, centred = onset_shifts(
                    {name: table.time_s for name, table in reference.items()}, tables)
                impacts, found_impacts = onset_shifts(audible_onsets(reference, folder),
                                                      tables)[:2]
                pooled.setdefault(condition, []).append((total, found, centred))
                sd = 1.4826 * float(np.median(np.abs(centred))) if centred.size else np.nan
                rows[condition] = dict(scored, found=found / max(total, 1),
                                       found_impacts=found_impacts / max(impacts, 1),
                                       timed=share(*timed_impacts(tables, folder)),
                                       shift_ms=1e3 * float(np.median(raw)) if raw.size
                                       else np.nan,
                                       offset_ms=float(np.median(np.abs(offsets))),
                                       sd_ms=1e3 * sd, n_onsets=total)
                print(f"  {condition:30s} done", flush=True)
            out[label] = rows
    print("\nphone recordings side by side with their lossless originals (F1 at +-2 ms and MAD "
          "against the truth; then each onset against the original's: found within 1 ms, of "
          "all of them and of those that time an audible true impact; the share of audible "
          "true impacts with an onset within 1 ms of the truth; median shift, "
          "|offset| of the decoded audio by cross-correlation, spread of the "
          "shifts as an sd = 1.4826 MAD)")
    print(f"  {'recordings':26s} {'condition':30s} {'F1':>6s} {'MAD ms':>7s} {'first':>6s} "
          f"{'found':>6s} {'impacts':>7s} {'1 ms':>6s} {'shift ms':>9s} {'offset ms':>9s} "
          f"{'sd ms':>6s}")
    for label, rows in out.items():
        for condition, r in rows.items():
            print(f"  {label:26s} {condition:30s} {r.get('f1', np.nan):6.3f} "
                  f"{r.get('mad_ms', np.nan):7.3f} {r.get('first', 0):>2d}/{r.get('n', 0):<3d} "
                  f"{r['found']:6.3f} {r['found_impacts']:7.3f} {r['timed']:6.3f} "
                  f"{r['shift_ms']:9.3f} "
                  f"{r['offset_ms']:9.4f} {r['sd_ms']:6.3f}")
    print("\ntiming floors, pooled over every source (sd = 1.4826 MAD of the shifts, less each "
          "recording's median; drumroll.audio.timing holds them)")
    for condition, parts in pooled.items():
        c = np.concatenate([p[2] for p in parts])
        total, found = sum(p[0] for p in parts), sum(p[1] for p in parts)
        if c.size:
            mad = float(np.median(np.abs(c)))
            print(f"  {condition:30s} MAD {1e3 * mad:.3f} ms, sd {1e3 * 1.4826 * mad:.3f} ms "
                  f"({c.size} onsets); moved by more than 1 ms or lost: "
                  f"{1 - found / max(total, 1):.3f} of {total}")
    return out


def no_roll(kind: str, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Impacts of a recording that holds no roll: one hit, a flam and a later hit, or three
    unrelated hits."""
    if kind == "single hit":
        return np.array([0.0]), np.array([1.2])
    if kind == "two hits":
        return np.array([0.0, rng.uniform(0.02, 0.3)]), np.array([1.2, 0.9])
    times = np.sort(rng.uniform(0.0, 2.0, 3))
    return times - times[0], rng.uniform(0.3, 1.5, 3)


def false_rolls(trials: int, first_seed: int = 0) -> None:
    """How often a recording without a roll is reported as one (44.1 kHz, every SNR and
    condition): the other side of the F1, since a detector that always finds a roll scores
    well on recordings that all hold one."""
    print("\nrecordings without a roll, reported as a roll (should be 0):")
    for kind in ("single hit", "two hits", "three unrelated hits"):
        found = total = 0
        for snr in (30, 20, 12):
            for cond in CONDITIONS.values():
                for seed in range(first_seed, first_seed + trials):
                    rng = np.random.default_rng(7919 + 1000 * snr + seed)
                    times, speeds = no_roll(kind, rng)
                    dist = Disturbances(snr_db=snr, hum_hz=cond["hum"],
                                        spurious=cond["spurious"])
                    r = render(times, speeds, sample_rate=44100, room=cond["room"],
                               disturbances=dist, rng=rng)
                    total += 1
                    try:
                        detect(r.samples, r.sample_rate)
                        found += 1
                    except AudioError:
                        pass
        print(f"  {kind:22s} {found:3d} of {total}")
    sys.stdout.flush()


def throughput() -> None:
    """drumroll's onsets of a 60 s file against librosa's ``onset_detect`` (file read,
    sample rate kept, hop 64 with backtracking: the peer setting that times onsets to about
    a millisecond) on the same file, best of five CPU times each, and their ratio."""
    rng = np.random.default_rng(5)
    times, speeds = roll_truth(rng)
    r = render(times, speeds, sample_rate=44100, disturbances=Disturbances(snr_db=30), rng=rng)
    x = np.resize(r.samples, 60 * 44100)

    def librosa_onsets(path: Path) -> np.ndarray:
        import librosa

        y, sr = librosa.load(path, sr=None)
        return librosa.onset.onset_detect(y=y, sr=sr, hop_length=64, backtrack=True,
                                          units="time")

    methods = {"drumroll": detect}
    try:
        import librosa  # noqa: F401

        methods["librosa h64 bt"] = librosa_onsets
    except ImportError:
        pass
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "60s.wav"
        sf.write(path, x, 44100, subtype="PCM_16")
        cpu = {}
        for name, run in methods.items():
            run(path)  # imports and caches outside the timing
            best = np.inf
            for _ in range(5):  # best of five: the machine's other load only ever adds time
                c0 = time.process_time()
                run(path)
                best = min(best, time.process_time() - c0)
            cpu[name] = best
    # CPU time is the one-core figure (librosa's numba and BLAS may use more than one).
    for name, best in cpu.items():
        print(f"throughput, {name}: 60 s at 44.1 kHz in {best:.3f} s CPU = {60 / best:.0f}x "
              "real time on one core")
    if len(cpu) == 2:
        print(f"  drumroll / librosa CPU time: {cpu['drumroll'] / cpu['librosa h64 bt']:.2f}")


_MEM_CHILD = """
import sys, time, tracemalloc
from drumroll.onsets import detect
def hwm():  # this process's own peak resident set (ru_maxrss can inherit the parent's)
    for line in open("/proc/self/status"):
        if line.startswith("VmHWM:"):
            return int(line.split()[1])
    return -1
base = hwm()
traced = sys.argv[2:] == ["traced"]
if traced:
    tracemalloc.start()
c0 = time.process_time()
table = detect(sys.argv[1])
cpu = time.process_time() - c0
peak = tracemalloc.get_traced_memory()[1] if traced else -1
print(peak, base, hwm(), cpu, len(table.rolls), len(table))
"""


def _measure(path: Path, traced: bool = False) -> tuple[int, int, int, float, int, int] | str:
    """detect() on ``path`` in a fresh subprocess: peak traced bytes (-1 untraced), resident
    kB after imports and at peak, CPU seconds of detect(), rolls and onsets; or the error."""
    out = subprocess.run([sys.executable, "-c", _MEM_CHILD, str(path),
                          *(["traced"] if traced else [])],
                         capture_output=True, text=True, check=False)
    words = out.stdout.split()
    if len(words) != 6:
        return out.stderr.strip().splitlines()[-1] if out.stderr.strip() else "no output"
    return (int(words[0]), int(words[1]), int(words[2]), float(words[3]), int(words[4]),
            int(words[5]))


def memory(minutes: tuple[int, ...] = (10, 20, 60), traced_up_to: int = 20) -> None:
    """Peak memory and speed of detect() on long files of many rolls: one simulated roll
    (30 dB) tiled back to back, a roll every 3.2 s with 1.5 s of noise between (hundreds of
    rolls, one stretch of candidates), written blockwise as 16-bit WAV. Each file is run in
    a fresh subprocess for its peak resident set and CPU time (one core), and again under
    tracemalloc for Python's own peak up to ``traced_up_to`` minutes (tracemalloc slows it
    several times)."""
    rng = np.random.default_rng(6)
    times, speeds = roll_truth(rng)
    r = render(times, speeds, sample_rate=44100, disturbances=Disturbances(snr_db=30), rng=rng)
    block = r.samples if r.samples.ndim == 1 else r.samples.mean(axis=1)
    period = block.size / 44100
    with tempfile.TemporaryDirectory() as d:
        for m in minutes:
            path = Path(d) / f"{m}min.wav"
            with sf.SoundFile(path, "w", 44100, 1, subtype="PCM_16") as f:
                written = 0
                while written < m * 60 * 44100:
                    f.write(block)
                    written += block.size
            tiles = int(np.ceil(m * 60 / period))
            got = _measure(path)
            if isinstance(got, str):
                print(f"memory: {m} min file ({tiles} rolls): {got}")
                continue
            _, base, rss, cpu, rolls, onsets = got
            line = (f"memory: {m} min file ({tiles} rolls written, {rolls} found, {onsets} "
                    f"onsets): peak RSS {rss / 1024:.0f} MB ({base / 1024:.0f} MB after "
                    f"imports), {cpu:.1f} s CPU = {m * 60 / cpu:.0f}x real time")
            if m <= traced_up_to:
                traced = _measure(path, traced=True)
                if not isinstance(traced, str):
                    line += f", peak traced {traced[0] / 2**20:.1f} MB"
            print(line)
            sys.stdout.flush()
            path.unlink()


def memory_m4a(minutes: int = 60) -> None:
    """Peak memory of detect() on an hour-long phone recording: quiet noise with the real
    ping-pong dropped every ten minutes, as a 16-bit WAV and as an AAC 128 kb/s .m4a (both
    written blockwise), each in a fresh subprocess. The .m4a is decoded by FFmpeg into a
    temporary file first: the difference between the two is what decoding costs."""
    import av

    x, sr = sf.read(REAL / "pingpong.wav")
    rng = np.random.default_rng(8)
    block = 1 << 16
    total = minutes * 60 * sr
    drops = {int((300 + 600 * k) * sr) for k in range(minutes // 10)}
    with tempfile.TemporaryDirectory() as d:
        wav, m4a = Path(d) / "long.wav", Path(d) / "long.m4a"
        t0 = time.perf_counter()
        with sf.SoundFile(wav, "w", sr, 1, subtype="PCM_16") as f, \
                av.open(str(m4a), "w") as out:
            stream = out.add_stream("aac", rate=sr, layout="mono")
            stream.bit_rate = 128_000
            for pos in range(0, total, block):
                n = min(block, total - pos)
                chunk = 1e-3 * rng.standard_normal(n)
                for at in drops:
                    lo, hi = max(at, pos), min(at + x.size, pos + n)
                    if hi > lo:
                        chunk[lo - pos: hi - pos] += x[lo - at: hi - at]
                f.write(chunk)
                frame = av.AudioFrame.from_ndarray(chunk.astype(np.float32)[None, :],
                                                   format="fltp", layout="mono")
                frame.sample_rate, frame.pts = sr, pos
                frame.time_base = Fraction(1, sr)
                out.mux(stream.encode(frame))
            out.mux(stream.encode(None))
        print(f"memory: {minutes} min of a phone recording ({len(drops)} ping-pong rolls), "
              f"written in {time.perf_counter() - t0:.0f} s: WAV "
              f"{wav.stat().st_size / 1e6:.0f} MB, .m4a {m4a.stat().st_size / 1e6:.0f} MB")
        for path in (wav, m4a):
            got = _measure(path, traced=True)
            if isinstance(got, str):
                print(f"memory: {minutes} min {path.suffix}: {got}")
                continue
            peak, base, rss, cpu, rolls, onsets = got
            print(f"memory: {minutes} min {path.suffix} ({rolls} rolls, {onsets} onsets): "
                  f"peak traced {peak / 2**20:.1f} MB, peak RSS {rss / 1024:.0f} MB "
                  f"({base / 1024:.0f} MB after imports), {cpu:.1f} s CPU under tracemalloc")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=5)
    ap.add_argument("--first-seed", type=int, default=0,
                    help="first trial's seed: another value draws rolls the code was not "
                         "developed on")
    ap.add_argument("--jitter-ms", type=float, default=0.0,
                    help="Gaussian scatter of the impact times about the geometric law")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--no-memory", action="store_true")
    ap.add_argument("--no-peers", action="store_true")
    ap.add_argument("--no-grid", action="store_true", help="only throughput and memory")
    ap.add_argument("--corpus", type=Path, default=CORPUS, metavar="DIR",
                    help="a folder of recordings made by others, each with <name>.truth.json "
                         f"(default: {CORPUS}, scored when it exists)")
    real = ap.add_mutually_exclusive_group()
    real.add_argument("--no-real-hits", action="store_true",
                      help="skip the grid of real recorded hits in measured rooms")
    real.add_argument("--real-hits-only", action="store_true",
                      help="only the grid of real recorded hits in measured rooms")
    phone = ap.add_mutually_exclusive_group()
    phone.add_argument("--no-phone", action="store_true",
                       help="skip the phone recordings (codecs, rates, AGC)")
    phone.add_argument("--phone-only", action="store_true",
                       help="only the phone recordings (codecs, rates, AGC)")
    ap.add_argument("--phone-condition", action="append", metavar="TEXT",
                    help="only the phone conditions whose label contains TEXT (repeatable; "
                         "e.g. 'AAC 128', 'Opus 64')")
    ap.add_argument("--misses", action="store_true",
                    help="list every onset of a lossless original that a phone condition "
                         "moves by more than 1 ms or loses, and the stage that did")
    ap.add_argument("--against", metavar="REV",
                    help="also score the onset extractor of this git revision (e.g. a commit "
                         "or a branch) on the same simulated rolls, real-hit rolls, corpus "
                         "and ping-pong, side by side")
    args = ap.parse_args()
    against = Revision(args.against) if args.against else None
    try:
        _run(args, against)
    finally:
        if against is not None:
            against.close()


def _run(args: argparse.Namespace, against: Revision | None) -> None:
    """The parts of the benchmark ``args`` asks for (see :func:`main`)."""
    jitter = 1e-3 * args.jitter_ms
    parts: dict[str, dict] = {}
    sources = {"real ping-pong": (REAL, "pingpong")}
    if args.corpus.is_dir():
        sources = {f"{args.corpus.name} (12 rolls)": (args.corpus, "*"), **sources}
    if args.phone_only:
        run_phone(sources, args.phone_condition, args.misses)
        return
    def add(label: str, by_method: dict[str, dict[int, dict[str, float]]]) -> None:
        for method, by_snr in by_method.items():
            for snr, row in by_snr.items():
                parts[f"{label}, {snr} dB{_tag(method)}"] = row

    if args.real_hits_only:
        add("real hits, measured rooms", run_real_grid(
            args.trials, args.quick, not args.no_peers, args.first_seed, jitter, against))
        side_by_side(parts)
        return
    if not args.no_grid:
        add("our simulator", run_grid(args.trials, args.quick, not args.no_peers,
                                      args.first_seed, jitter, against))
        false_rolls(args.trials, args.first_seed)
        if not args.no_real_hits:
            add("real hits, measured rooms", run_real_grid(
                args.trials, args.quick, not args.no_peers, args.first_seed, jitter, against))
        scorers = [None] if against is None else [None, against]
        if args.corpus.is_dir():
            for who in scorers:
                print(f"\nrecordings made by others: {args.corpus}"
                      f"{_tag(who.name) if who else ''}")
                row = score_folder(args.corpus, against=who)
                if row:
                    parts[f"{args.corpus.name} ({row['n']} recordings, pooled)"
                          f"{_tag(who.name) if who else ''}"] = row
        for who in scorers:
            print(f"\na real recording: {REAL / 'pingpong.wav'}{_tag(who.name) if who else ''}")
            row = score_folder(REAL, "pingpong", against=who)
            if row:
                parts[f"real ping-pong (data/pingpong.wav){_tag(who.name) if who else ''}"] = row
        side_by_side(parts)
    if not args.no_phone:
        run_phone(sources, args.phone_condition, args.misses)
    throughput()
    if not args.no_memory:
        memory()
        memory_m4a()


if __name__ == "__main__":
    main()
