"""Findings: confirmed, shrunk, explained, written as scenario scripts and reproduced."""
