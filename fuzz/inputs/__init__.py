"""Fuzz input: the command language as data and the seeded generator."""
