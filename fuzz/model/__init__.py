"""The fuzzer's own reference model of the firmware: what a HAT prints for an input."""
