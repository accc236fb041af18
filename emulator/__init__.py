"""The reference emulator of the Build HAT firmware (all releases R1..R7, as profiles)."""
