"""The conformance cases: one ``test_*.py`` module per area of the protocol, each case citing its
requirement IDs, and the port fixtures they use (``fixtures.py``). What they check with lives one
folder up (link, needs, probes, verdict, oracles/); the pytest plugin that runs them is
conformance/plugin/, registered by this folder's conftest.py."""
