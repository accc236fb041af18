"""Campaigns that run the whole suite on many builds of a firmware tree: planted mutants (mutation.py),
bisection and history of a repository.
"""
