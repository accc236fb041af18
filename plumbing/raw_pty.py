"""A raw pseudo-terminal, optionally reachable through a symlink: what a host opens like a UART."""
from __future__ import annotations

import os
import termios
import tty
from typing import Optional, Tuple

__all__ = ["open_raw_pty"]


def open_raw_pty(link: Optional[str] = None) -> Tuple[int, int, str]:
    """(master fd, slave fd, slave path) of a new pty in raw mode: no echo, no CR/LF
    translation, 8-bit clean, so the host sees exactly the bytes written.

    ``link``: also make this path a symlink to the slave. An existing symlink is replaced; any
    other existing file is not (ValueError), so a typo cannot delete a real device node.
    """
    master, slave = os.openpty()
    tty.setraw(slave, termios.TCSANOW)
    path = os.ttyname(slave)
    if link:
        try:
            if os.path.lexists(link):
                if not os.path.islink(link):
                    raise ValueError(f"{link!r} exists and is not a symlink; not replacing it")
                os.unlink(link)
            os.symlink(path, link)
        except (OSError, ValueError) as exc:
            os.close(master)
            os.close(slave)
            if isinstance(exc, ValueError):
                raise
            raise ValueError(f"{link!r}: {exc.strerror}") from None
    return master, slave, path
