"""The one error type of firmware loading and reset, with the exit status it maps to.

Exit statuses (the project's contract): 2 for what the user must fix in what they gave
(a missing or unreadable file, an image or signature the bootloader refuses: too large, wrong
signature length, signature that does not verify); 3 for the target (unreachable, silent,
bytes lost on the link: ``Checksum failure`` or ``Timed out waiting for data``, firmware that
does not come up, a HAT running firmware with no way to reset it).
"""
from __future__ import annotations

__all__ = ["LoadError", "EXIT_USAGE", "EXIT_TARGET"]

EXIT_USAGE = 2
EXIT_TARGET = 3


class LoadError(RuntimeError):
    """One line saying what went wrong; ``exit_status`` is 2 (the user's input) or 3 (the target)."""

    def __init__(self, message: str, exit_status: int = EXIT_TARGET):
        super().__init__(message)
        self.exit_status = exit_status
