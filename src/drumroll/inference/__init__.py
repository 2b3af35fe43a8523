"""Inference: priors, likelihood, sampling and model comparison."""
