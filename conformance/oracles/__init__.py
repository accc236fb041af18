"""Independent oracles: what the document and docs/FIRMWARE-BEHAVIOUR.md say the HAT prints or
computes.

Written from the text only, never from ``emulator/``: the point of a conformance oracle is to
be a second, independent reading of the facts.
"""
