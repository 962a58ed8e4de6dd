"""Benchmarks and accuracy reports (run as commands, never as pass/fail tests)."""
