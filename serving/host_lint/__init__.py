"""The host lint: what a host library does that works only by luck, or not at all."""
