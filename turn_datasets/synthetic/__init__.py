"""Synthetic data for the demo and the tests: mocap, ELAN sessions, estimator-like degradation, the demo corpus."""
