"""The fuzzer's oracles: each a named check of one run, in one registry."""
