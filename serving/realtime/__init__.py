"""Ways to run the emulator: real time (pty, TCP, stdio) and virtual time (scenario scripts).

Only this package reads the wall clock (docs/DEVELOPING.md, "Virtual time").
"""
