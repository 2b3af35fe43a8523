"""Config fragments the tests share: the paper's stick and its measured geometry, and a
ball's power-law config."""

#: The stick of the paper: a cylinder R = 7.5, l1 = 348 mm with a 60 mm conical tip.
PAPER_STICK = """\
[stick]
shape = "cylinder-cone"
length_mm = 348
tip_mm = 60
radius_mm = 7.5
"""

#: A bouncing ball: the power law alone, a quick sampler without evidence, one process.
BALL_CONFIG = """\
model = "powerlaw"

[priors]
alpha = { dist = "uniform", low = 0.3, high = 1.0 }
t_b = { dist = "uniform", low = 0.05, high = 3.0 }
jitter_ms = { dist = "loguniform", low = 0.01, high = 10 }

[sampler]
evidence = false
workers = 1
"""
