"""Write the bundled simulated recordings: the paper's eight set-ups, with known truth.

For each set-up of Oss's Tables 1-2 and the soft/hard drumhead pair this writes, into
``data/`` (or ``--out``):

* ``NAME.toml``: a config whose priors are the paper's measured values with their ± and
  whose ``[simulate]`` section holds the truth (alpha as the paper measured it);
* ``NAME.flac``: the recording (mono, 44.1 kHz, PCM_16), made by ``drumroll simulate``;
* ``NAME.truth.json``: impact times, speeds, local SNRs, spurious events, all parameters.

The room is a modest one (an echo from the floor or a wall, RT60 0.35 s, the microphone
close), with pink-ish background noise at 30 dB SNR, a little mains hum, a tap before the
roll and a handling knock after it. Existing files are never overwritten unless ``--force``.

Run from the repository root::

    python examples/make_bundled_recordings.py
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from drumroll.cli.main import main as drumroll

#: name: (pivot d mm, height h mm, alpha as measured, its ±, where it comes from)
SETUPS = {
    "table1_d110": (110, 80, 0.86, 0.01, "Table 1: d = 110 ± 2 mm, h = 80 mm"),
    "table1_d131": (131, 80, 0.88, 0.01, "Table 1: d = 131 ± 2 mm, h = 80 mm"),
    "table1_d152": (152, 80, 0.84, 0.01, "Table 1: d = 152 ± 2 mm, h = 80 mm"),
    "table2_h50": (131, 50, 0.90, 0.01, "Table 2: d = 131 mm, h = 50 ± 3 mm"),
    "table2_h80": (131, 80, 0.90, 0.01, "Table 2: d = 131 mm, h = 80 ± 3 mm"),
    "table2_h110": (131, 110, 0.89, 0.01, "Table 2: d = 131 mm, h = 110 ± 3 mm"),
    "tension_soft": (131, 80, 0.860, 0.005, "soft drumhead: h = 80, d = 131 mm"),
    "tension_hard": (131, 80, 0.899, 0.002, "hard drumhead: h = 80, d = 131 mm"),
}

TEMPLATE = """\
# Simulated recording of the set-up of Oss, "A simple mechanical model of the drumroll",
# {source}; the paper measured alpha = {alpha} ± {alpha_err}.
# Priors: the paper's measured geometry with its ±. [simulate]: the truth of {name}.flac.
model = "pendulum"
compare = ["small-angle", "powerlaw"]

[stick]
shape = "cylinder-cone"
length_mm = {{ dist = "normal", mu = 348, sigma = 1 }}
tip_mm = {{ dist = "normal", mu = 60, sigma = 1 }}
radius_mm = 7.5

[priors]
alpha = {{ dist = "uniform", low = 0.5, high = 1.0 }}
pivot_mm = {{ dist = "normal", mu = {d}, sigma = 2 }}
height_mm = {{ dist = "normal", mu = {h}, sigma = 3 }}
release_speed_m_s = 0
release_angle_deg = 0
jitter_ms = {{ dist = "loguniform", low = 0.01, high = 10 }}
t_b = {{ dist = "uniform", low = 0.01, high = 2.0 }}

# The onset extractor can time the faintest last onsets a few ms late; heavier-tailed noise
# keeps such an onset from dragging the fit (with Gaussian noise it would be trusted at its
# stated sigma_s).
[likelihood]
noise = "student-t"
nu = 4

[simulate]
model = "pendulum"
alpha = {alpha}
pivot_mm = {d}
height_mm = {h}
release_speed_m_s = 0.0
release_angle_deg = 0.0
jitter_ms = 0.1
min_tip_speed_m_s = 0.04
sample_rate = 44100
subtype = "PCM_16"
channels = 1
seed = {seed}

[simulate.room]
echo = true
echo_delay_s = [0.004, 0.012]
echo_gain = 0.4
reverb_time_s = 0.35
direct_to_reverb_db = 8.0

[simulate.disturbances]
snr_db = 30.0
hum_hz = 50.0
hum_db = -40.0
spurious = true
lead_in_s = 0.5
tail_s = 1.0
"""


def main(argv: list[str] | None = None) -> int:
    """Write every set-up's config, recording and truth; return the exit status."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", default="data", help="folder to write into")
    parser.add_argument("--force", action="store_true", help="overwrite existing files")
    args = parser.parse_args(argv)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    targets = [out / f"{name}{suffix}" for name in SETUPS
               for suffix in (".toml", ".flac", ".truth.json")]
    existing = [str(p) for p in targets if p.exists()]
    if existing and not args.force:
        print(f"refusing to overwrite {len(existing)} existing files (first: {existing[0]}); "
              "use --force", file=sys.stderr)
        return 2
    for seed, (name, (d, h, alpha, err, source)) in enumerate(SETUPS.items(), start=1):
        config = out / f"{name}.toml"
        config.write_text(TEMPLATE.format(source=source, alpha=alpha, alpha_err=err, name=name,
                                          d=d, h=h, seed=seed), encoding="utf-8")
        code = drumroll(["simulate", str(config), "-o", str(out / f"{name}.flac"),
                         "--truth", str(out / f"{name}.truth.json"), "--force"])
        if code:
            return code
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
