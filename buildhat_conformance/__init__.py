"""buildhat-conformance: conformance suite, fuzzer and reference emulator for the Build HAT."""
__version__ = "0.1.0"
