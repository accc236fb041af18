"""Firmware upload through the user's own ``buildhat-conformance load``: how long a release-sized
image (R7's 51,456 bytes) takes from STX to the bootloader's ``Checksum OK``, against the least
time its bytes need on the wire at 115200 baud (8N1: 10 bits a byte, FIRMWARE-BEHAVIOUR.md#fb-uart,
#fb-bootloader).

The HAT is the emulator in its bootloader behind a real pty (``buildhat-emulator --pty
--bootloader``), at real time. The image has R7's size and checksum and is signed with a key
made for the run (the emulator verifies with its public half), so the whole sequence runs:
clear, load, signature, reboot, ``version``.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import tempfile
import time
from typing import Any, Dict, Tuple

from ..protocol.image_checksum import image_with_checksum
from ..protocol.profiles import get_profile

__all__ = ["new_key", "sign", "release_sized_files", "upload", "installed_tool"]

RELEASE = "R7"
_LOADED = re.compile(r"loaded: firmware version (\S+).*\(upload ([0-9.]+) s, wire minimum ([0-9.]+) s\)")


def new_key(folder: str) -> Tuple[Any, str]:
    """A fresh P-256 key: (private key, path of its public half as PEM for ``--bootloader-key``)."""
    from cryptography.hazmat.primitives import serialization
    from cryptography.hazmat.primitives.asymmetric import ec

    private = ec.generate_private_key(ec.SECP256R1())
    pem = os.path.join(folder, "key.pem")
    with open(pem, "wb") as fh:
        fh.write(private.public_key().public_bytes(serialization.Encoding.PEM,
                                                   serialization.PublicFormat.SubjectPublicKeyInfo))
    return private, pem


def sign(private: Any, data: bytes) -> bytes:
    """The 64-byte signature the bootloader takes (r and s, 32 bytes each, of ECDSA/SHA-256)."""
    from cryptography.hazmat.primitives import hashes
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.asymmetric.utils import decode_dss_signature

    r, s = decode_dss_signature(private.sign(data, ec.ECDSA(hashes.SHA256())))
    return r.to_bytes(32, "big") + s.to_bytes(32, "big")


def release_sized_files(folder: str, release: str = RELEASE) -> Tuple[str, str, str]:
    """(image, signature, public key PEM) in ``folder``: the release's size and checksum, signed."""
    profile = get_profile(release)
    image = image_with_checksum(profile.image_size, profile.image_checksum)
    private, pem = new_key(folder)
    img, sig = os.path.join(folder, "firmware.bin"), os.path.join(folder, "signature.bin")
    with open(img, "wb") as fh:
        fh.write(image)
    with open(sig, "wb") as fh:
        fh.write(sign(private, image))
    return img, sig, pem


def installed_tool(name: str) -> str:
    """The path of ``name`` (a console script of this package) beside the running interpreter."""
    path = os.path.join(os.path.dirname(sys.executable), name)
    if not os.path.exists(path):
        raise RuntimeError(f"{name} is not installed beside {sys.executable}")
    return path


def upload() -> Dict[str, Any]:
    """One ``load`` of a release-sized image into a fresh emulator bootloader over a pty."""
    with tempfile.TemporaryDirectory() as tmp:
        img, sig, pem = release_sized_files(tmp)
        link = os.path.join(tmp, "hat")
        emu = subprocess.Popen([installed_tool("buildhat-emulator"), "--pty", "--bootloader",
                                "--bootloader-key", pem, "--link", link], stdout=subprocess.PIPE,
                               stderr=subprocess.DEVNULL, text=True, start_new_session=True)
        try:
            assert emu.stdout is not None
            emu.stdout.readline()                   # it prints the pty's path once it serves
            began = time.monotonic()
            done = subprocess.run([installed_tool("buildhat-conformance"), "load", "--target", link, img,
                                   sig], capture_output=True, text=True, timeout=120)
            total = time.monotonic() - began
        finally:
            emu.terminate()
            emu.wait(timeout=10)
    m = _LOADED.search(done.stdout)
    if done.returncode != 0 or m is None:
        raise RuntimeError(f"load exited {done.returncode}: {(done.stderr or done.stdout).strip()[-200:]}")
    up, minimum = float(m.group(2)), float(m.group(3))
    return {"upload_s": up, "wire_min_s": minimum, "over_min_pct": 100.0 * (up - minimum) / minimum,
            "total_s": total,
            "note": f"{get_profile(RELEASE).image_size:,}-byte image, then firmware {m.group(1)}"}
