"""Protocol data shared by the emulator, the conformance suite and the fuzzer.

Everything here is *data* transcribed from the firmware facts (the project's account of them:
docs/FIRMWARE-BEHAVIOUR.md) and devices.json: firmware release profiles and the LPF2 device
catalogue. Code that behaves differently per release consults a :class:`~.profiles.Profile`
instead of forking.
"""
