"""Planted faults (faults.py) and their byte proxy (proxy.py): a package so that tests import
``planted.faults`` like any helper; proxy.py, run as a script, imports faults.py beside it."""
