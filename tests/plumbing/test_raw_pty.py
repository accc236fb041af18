"""A raw pseudo-terminal (plumbing/raw_pty.py): bytes cross it exactly (no echo, no CR/LF translation, all 256
values), and a link path replaces only a symlink, never a real file."""
from __future__ import annotations

import os

import pytest

from buildhat_conformance.plumbing.raw_pty import open_raw_pty


def _read(fd: int, n: int) -> bytes:
    got = b""
    while len(got) < n:
        got += os.read(fd, n - len(got))
    return got


def test_every_byte_crosses_unchanged_both_ways(tmp_path):
    master, slave, path = open_raw_pty(str(tmp_path / "hat"))
    try:
        assert os.path.realpath(tmp_path / "hat") == os.path.realpath(path)
        data = bytes(range(256)) + b"\r\n\rvin\r"
        os.write(master, data)
        assert _read(slave, len(data)) == data            # no CR -> LF, no line editing
        os.write(slave, data)
        assert _read(master, len(data)) == data            # no LF -> CRLF, no echo of the first write
    finally:
        os.close(master)
        os.close(slave)


def test_a_link_replaces_a_symlink_but_never_a_file(tmp_path):
    old = tmp_path / "hat"
    old.symlink_to(tmp_path / "nowhere")
    master, slave, path = open_raw_pty(str(old))
    os.close(master)
    os.close(slave)
    assert os.path.realpath(old) == os.path.realpath(path)
    real = tmp_path / "real"
    real.write_text("keep me")
    with pytest.raises(ValueError, match="not a symlink"):
        open_raw_pty(str(real))
    assert real.read_text() == "keep me"
