"""Evaluation of trained controllers beside the classical ones: the fixed suite, held-out flights,
the paper's experiments as a report, and robustness sweeps."""
