"""Benchmarks: timing, throughput and fidelity figures, printed next to their goals."""
