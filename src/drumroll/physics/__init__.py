"""Stick geometry and the forward models: power law, small-angle and exact pendulum."""

from drumroll.physics.bounces import REASONS, Bounces
from drumroll.physics.geometry import STICK_SHAPES, StickGeometry, cylinder_cone, thin_rod
from drumroll.physics.models import GEOMETRIC_MODELS, MODELS, bounce_sequence
from drumroll.physics.release import STANDARD_GRAVITY, Release, prepare_release

__all__ = [
    "GEOMETRIC_MODELS",
    "MODELS",
    "REASONS",
    "STANDARD_GRAVITY",
    "STICK_SHAPES",
    "Bounces",
    "Release",
    "StickGeometry",
    "bounce_sequence",
    "cylinder_cone",
    "prepare_release",
    "thin_rod",
]
