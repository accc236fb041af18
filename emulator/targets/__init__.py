"""The emulator as a target: in this process in virtual time (in_process.py), or buildhat-emulator on a pty
(pty_process.py).
"""
