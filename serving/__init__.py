"""The serving kit: any HAT model (the emulator, a firmware in the loop, an emulated chip) in front of a
host, in virtual time or at wall-clock pace, with its control channel and host lint.
"""
