"""Benchmark: stick rolls in sounds, rooms and interference that drumroll's renderer does not
make, through ``drumroll estimate`` as a user runs it.

Each roll is an exact-pendulum roll of 18 impacts drawn from ``data/table2_h80.toml``'s priors
(α ≥ 0.8, restitution scatter and contact time as the config's defaults draw them), its onsets
timed to 0.1 ms. Its sound is one of ``tests/foreign_rolls.py``'s (a damped tone, inharmonic
modes, a noise burst, a tone with a 1 ms attack) or a real snare hit of ``../shared/samples``,
each impact's level as the tip speed to the power 1.5; every other roll is played in a
measured room of ``../shared/samples/rooms`` (resampled to 44.1 kHz); white noise at 12 to
40 dB under the first impact; and one condition by seed: nothing more, a chord with vibrato
10 dB under the first impact ("music"), clipping at a quarter of the peak, resampling to
8 or 16 kHz, 50 Hz hum with a DC offset, syllable-like bursts of band-passed noise 6 dB under
the first impact at a steady 4 Hz ("pulses"), a metronome click every 0.25 or 0.5 s, MP3. One
roll in three begins 60 ms after its first impact's sound arrives, so that the roll's first
onset is impact 1.

Prints, per roll, α's truth, estimate and z, whether its 90 % interval holds the truth, the
impact the first fitted onset is numbered as against the one it is, and the probability of
each numbering; then the pooled coverage of α's 90 % intervals (with the binomial 99 % band),
the rms of z, the rolls numbered right, and any run that ended in an error.

Run: ``python benchmarks/foreign_stick_rolls.py [--first-seed 0] [--seeds 35]
[--shared ../shared]`` (about 10 s a roll on two cores).
"""

from __future__ import annotations

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

import numpy as np
import soundfile as sf
from scipy import signal, stats

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))

from drumroll.calibration.roll import RollSimulator  # noqa: E402
from drumroll.config import load_config  # noqa: E402
from foreign_rolls import impact_sound  # noqa: E402  (the tests' own sound makers)

RATE = 44100
CONFIG = ROOT / "data" / "table2_h80.toml"
KINDS = ("sine", "modes", "noise", "sample", "attack")
CONDITIONS = ("none", "music", "clip", "rate8k", "hum_dc", "pulses", "metronome", "rate16k",
              "mp3")


def _room_delay(ir: np.ndarray) -> float:
    """When a room's direct sound arrives (s): its first sample within 20 dB of the peak."""
    return float(np.argmax(np.abs(ir) >= 0.1 * np.max(np.abs(ir)))) / RATE


def make_roll(seed: int, simulator: RollSimulator, rooms: list[np.ndarray],
              samples: list[Path], out: Path) -> tuple[Path, dict]:
    """Write roll ``seed`` into ``out``; returns its path and truth."""
    rng = np.random.default_rng([seed, 7])
    roll = simulator.draw(rng)
    while roll.values["alpha"] < 0.8:
        roll = simulator.draw(rng)
    kind = KINDS[seed % len(KINDS)]
    condition = CONDITIONS[seed % len(CONDITIONS)]
    frequency = float(rng.choice([700.0, 1500.0, 3000.0]))
    snr_db = float(rng.choice([12.0, 20.0, 30.0, 40.0]))
    room = rooms[(seed // 2) % len(rooms)] if seed % 2 == 0 else None
    times = (roll.model_times - roll.t0 + 0.4
             + rng.normal(0.0, 1e-4, roll.model_times.size))
    speeds = roll.speeds / roll.speeds[0]
    x = np.zeros(int((times[-1] + 0.8) * RATE))
    length = int(0.15 * RATE)
    if kind == "sample":
        hit, rate = sf.read(samples[seed % len(samples)], always_2d=True)
        hit = signal.resample_poly(hit[:, 0], RATE, rate) if rate != RATE else hit[:, 0]
    for k, start in enumerate(times):
        first = int(np.ceil(start * RATE))
        t = (first - start * RATE + np.arange(length)) / RATE
        sound = hit[:length] if kind == "sample" else impact_sound(kind, frequency, t, rng)
        stop = min(first + sound.size, x.size)
        x[first:stop] += speeds[k] ** 1.5 * sound[: stop - first]
    delay = 0.0
    if room is not None:
        delay = _room_delay(room)
        x = signal.fftconvolve(x, room[: int(0.6 * RATE)] / np.max(np.abs(room)))[: x.size]
    head = int((times[0] + delay) * RATE)
    power = float(np.mean(x[head: head + int(0.02 * RATE)] ** 2))
    x = x + rng.standard_normal(x.size) * math.sqrt(power / 10 ** (snr_db / 10))
    tt = np.arange(x.size) / RATE
    if condition == "music":
        chord = sum(np.sin(2 * np.pi * f * tt + 3 * np.sin(2 * np.pi * 5 * tt))
                    for f in (220, 277, 330, 440, 554))
        x = x + chord * math.sqrt(power / 10 / np.mean(chord**2))
    elif condition == "pulses":
        envelope = np.clip(np.sin(2 * np.pi * 4.0 * tt + rng.uniform(0, 6)), 0, None) ** 2
        b, a = signal.butter(2, [300 / (RATE / 2), 3000 / (RATE / 2)], "band")
        bursts = signal.lfilter(b, a, rng.standard_normal(x.size)) * envelope
        x = x + bursts * math.sqrt(power / 10 ** 0.6 / np.mean(bursts**2))
    elif condition == "metronome":
        period = 0.25 if seed % 2 else 0.5
        tc = np.arange(int(0.01 * RATE)) / RATE
        click = np.sin(2 * np.pi * 2500 * tc) * np.exp(-tc / 0.002)
        for at in np.arange(rng.uniform(0, period), x.size / RATE, period):
            i = int(at * RATE)
            x[i: i + click.size] += math.sqrt(power) * click[: x.size - i]
    elif condition == "hum_dc":
        x = x + math.sqrt(power) * (0.3 * np.sin(2 * np.pi * 50 * tt) + 0.5)
    cut = seed % 3 == 1
    offset = 0.0
    if cut:  # the recording starts 60 ms into the first impact's sound
        offset = times[0] + delay + 0.06
        x = x[int(offset * RATE):]
    x = 0.5 * x / np.max(np.abs(x))
    rate = RATE
    if condition == "clip":
        x = np.clip(4 * x, -0.99, 0.99)
    elif condition in ("rate8k", "rate16k"):
        rate = 8000 if condition == "rate8k" else 16000
        x = signal.resample_poly(x, rate // 100, RATE // 100)
    path = out / f"roll{seed:03d}.{'mp3' if condition == 'mp3' else 'wav'}"
    if condition == "mp3":
        sf.write(path, x, rate, format="MP3")
    else:
        sf.write(path, x, rate, subtype="PCM_16")
    truth = {"alpha": roll.values["alpha"], "impacts": times + delay - offset,
             "kind": kind, "condition": condition, "room": room is not None, "cut": cut,
             "snr_db": snr_db}
    return path, truth


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--first-seed", type=int, default=0)
    parser.add_argument("--seeds", type=int, default=35)
    parser.add_argument("--shared", type=Path, default=ROOT.parent / "shared")
    args = parser.parse_args()
    rooms = []
    for p in sorted((args.shared / "samples" / "rooms").glob("*.flac")):
        ir, rate = sf.read(p, always_2d=True)
        rooms.append(signal.resample_poly(ir[:, 0], RATE // 100, rate // 100))
    samples = sorted((args.shared / "samples" / "avl").glob("38-*.flac"))
    if not rooms or not samples:
        sys.exit(f"no rooms or snare samples under {args.shared / 'samples'}")
    simulator = RollSimulator(load_config(CONFIG), "pendulum", 18)
    rows = []
    print(f"{'seed':>4} {'sound':7} {'condition':9} {'room':4} {'cut':3} {'SNR':>3}  "
          f"{'alpha':>7} {'estimate':>16} {'z':>6} in90  {'over the numberings':>30} "
          f"first: fitted/true  P(0, 1, 2)")
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first_seed, args.first_seed + args.seeds):
            path, truth = make_roll(seed, simulator, rooms, samples, Path(tmp))
            out = Path(tmp) / f"{path.stem}-estimate"
            run = subprocess.run(["drumroll", "estimate", str(path), "--prior", str(CONFIG),
                                  "-o", str(out), "-q"], capture_output=True, text=True)
            head = (f"{seed:4d} {truth['kind']:7} {truth['condition']:9} "
                    f"{'yes' if truth['room'] else '':4} {'yes' if truth['cut'] else '':3} "
                    f"{truth['snr_db']:3.0f}  {truth['alpha']:7.4f}")
            if run.returncode:
                print(f"{head}  exit {run.returncode}: {run.stderr.strip().splitlines()[-1]}")
                rows.append({"error": run.returncode})
                continue
            summary = json.loads((out / "summary.json").read_text())
            alpha = summary["parameters"]["alpha"]
            lo, hi = alpha["hdi_low"], alpha["hdi_high"]
            z = (alpha["mean"] - truth["alpha"]) / alpha["sd"]
            first = summary["onsets"][0]
            true_first = int(np.argmin(np.abs(truth["impacts"] - first["time_s"])))
            numbered = first["bounce"] == true_first
            p = summary.get("missed_first_impacts") or []
            # Over the numberings, where the estimate averaged them (else the fit's own).
            averaged = (summary.get("numbering_average") or {}).get("parameters", {}).get(
                "alpha", alpha)
            z_avg = (averaged["mean"] - truth["alpha"]) / averaged["sd"]
            rows.append({"z": z, "covered": lo <= truth["alpha"] <= hi, "numbered": numbered,
                         "z_avg": z_avg, "covered_avg":
                         averaged["hdi_low"] <= truth["alpha"] <= averaged["hdi_high"]})
            mark = "yes" if rows[-1]["covered"] else "NO"
            mark_avg = "yes" if rows[-1]["covered_avg"] else "NO"
            shown_avg = (f"{averaged['mean']:8.4f} ± {averaged['sd']:.4f} {z_avg:+6.2f} "
                         f"{mark_avg:4}" if averaged is not alpha else f"{'(same)':>30}")
            print(f"{head} {alpha['mean']:8.4f} ± {alpha['sd']:.4f} {z:+6.2f} {mark:4} "
                  f"{shown_avg} {first['bounce']:6d}/{true_first:<5d}"
                  f"{'' if numbered else '(!)'} {', '.join(f'{q:.2f}' for q in p)}",
                  flush=True)
    fitted = [r for r in rows if "z" in r]
    n = len(fitted)
    covered = sum(r["covered"] for r in fitted)
    band = stats.binom.ppf([0.005, 0.995], n, 0.9) / n if n else (math.nan, math.nan)
    rms = math.sqrt(sum(r["z"] ** 2 for r in fitted) / n) if n else math.nan
    covered_avg = sum(r["covered_avg"] for r in fitted)
    rms_avg = math.sqrt(sum(r["z_avg"] ** 2 for r in fitted) / n) if n else math.nan
    print(f"\n{len(rows)} rolls: {len(rows) - n} ended in an error; α's 90 % interval holds the "
          f"truth in {covered}/{n} = {covered / max(n, 1):.3f} (99 % band {band[0]:.2f}-"
          f"{band[1]:.2f}), rms z {rms:.2f}; first onset numbered right in "
          f"{sum(r['numbered'] for r in fitted)}/{n}")
    print(f"over the numberings, where the estimate averages them: {covered_avg}/{n} = "
          f"{covered_avg / max(n, 1):.3f}, rms z {rms_avg:.2f}")


if __name__ == "__main__":
    main()
