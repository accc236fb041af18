"""The real firmware in the loop: a Build HAT firmware tree built for the host against the
project's own stand-in for the pico-sdk (``standin/``), run in virtual time with the
emulator's device models on its ports. See README.md in this folder."""
