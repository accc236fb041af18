"""Protocol data shared by the emulator, the conformance suite and the fuzzer.

Everything here is *data* transcribed from ``shared/protocol`` (FIRMWARE-FACTS.md,
devices.json): firmware release profiles and the LPF2 device catalogue. Code that
behaves differently per release consults a :class:`~.profiles.Profile` instead of
forking.
"""
