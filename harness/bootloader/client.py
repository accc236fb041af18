"""The host side of the bootloader protocol (FIRMWARE-BEHAVIOUR.md#fb-bootloader) over a :class:`~.wire.Wire`.

``identify`` (who answers ``version``: bootloader or firmware), ``clear``, ``upload_image``
(``load <len> <checksum>`` then STX, the image, ETX), ``upload_signature`` (``signature 64``
the same way), ``reboot`` (the bootloader verifies, then starts the image) and
``confirm`` (``version`` once the firmware is up). Raw uploads are paced by the wire: a chunk
goes out only when the bytes before it have had the time to cross at the link's baud rate,
so the HAT's 4096-byte ring never overflows and its 1000 ms data timeout never fires.
Every refusal of the bootloader is a :class:`LoadError` with one line and its exit status.
"""
from __future__ import annotations

import re
import time
from typing import Callable, Optional, Tuple

from ...protocol.profiles import bootloader_data
from .errors import EXIT_TARGET, EXIT_USAGE, LoadError
from .image import FirmwareImage
from .progress import Progress
from .wire import Wire

__all__ = ["BootloaderClient", "WIRE_BAUD", "wire_seconds"]

# FIRMWARE-BEHAVIOUR.md#fb-uart, #fb-bootloader: the HAT's UART, 8N1: 10 bits a byte
WIRE_BAUD = 115200
STX, ETX = b"\x02", b"\x03"
_FIRMWARE = re.compile(rb"Firmware version: ([^\r\n]*)\r\n")
_BOOTLOADER = re.compile(rb"BuildHAT bootloader version ([^\r\n]*)\r\n")
# the 2021-09-12 build printed the number only (#fb-bootloader-version)
_BARE = re.compile(rb"version\r\n(\d{10})\r\n")
_ERROR = re.compile(rb"(?:^|\r\n)Error\r\n")
_GAVE_UP = re.compile(rb"Timed out waiting for data\r\n")
_DONE = b"Done initialising ports\r\n"
_ANSWER_TIMEOUT = 2.0        # wall seconds for a short answer
_VERIFY_TIMEOUT = 10.0       # verify = SHA-256 + ECDSA on the HAT's CPU
_BOOT_TIMEOUT = 10.0         # the firmware's start-up until `Done initialising ports`


def wire_seconds(nbytes: int, baud: int = WIRE_BAUD) -> float:
    """The least time ``nbytes`` take on the wire (8N1: 10 bits each)."""
    return nbytes * 10.0 / baud


class BootloaderClient:
    def __init__(self, wire: Wire, baud: int = WIRE_BAUD, chunk: int = 128,
                 progress: Optional[Callable[[int, str], Progress]] = None,
                 sleep: Callable[[float], None] = time.sleep):
        data = bootloader_data()
        self.wire = wire
        self.baud = int(baud)
        self.chunk = max(1, int(chunk))
        self.prompt = data["prompt"].encode("ascii")
        self.max_image = int(data["max_image"])
        self.signature_length = int(data["signature_length"])
        self.progress = progress
        self.sleep = sleep

    # -- who answers -----------------------------------------------------------------------
    def identify(self, attempts: int = 3) -> Tuple[str, str]:
        """("bootloader" | "firmware", version text) of what answers ``version``."""
        self.wire.drain(quiet=0.05, limit=1.0)
        for _ in range(attempts):
            self.wire.send(b"version\r")
            m = self.wire.wait_for(_FIRMWARE, _BOOTLOADER, _BARE, timeout=_ANSWER_TIMEOUT)
            if m is None:
                continue
            kind = "firmware" if m.re is _FIRMWARE else "bootloader"
            if kind == "bootloader":
                self.wire.wait_for(self.prompt, timeout=0.5)
            return kind, m.group(1).decode("ascii", "replace")
        url = self.wire.target.url
        if not self.wire.received:
            raise LoadError(f"nothing answers on {url}: sent `version` {attempts} times and not one byte "
                            "came back (is the HAT powered from its own supply, and is this its port?)")
        raise LoadError(f"{url} answers, but not like a Build HAT (no 'BuildHAT bootloader version' or "
                        f"'Firmware version:' line); last bytes: {self.wire.recent()}")

    # -- commands --------------------------------------------------------------------------
    def command(self, line: str, timeout: float = _ANSWER_TIMEOUT) -> bytes:
        """Send a line; the bootloader's output up to its next prompt (echo included)."""
        self.wire.skip()
        start = self.wire.pos
        self.wire.send(line.encode("ascii") + b"\r")
        if self.wire.wait_for(self.prompt, timeout=timeout) is None:
            raise LoadError(f"no `{self.prompt.decode().strip()}` prompt within {timeout:g} s after "
                            f"`{line}`; received {self.wire.recent()}")
        return bytes(self.wire.received[start:self.wire.pos])

    def clear(self) -> None:
        out = self.command("clear")
        if _ERROR.search(out):
            raise LoadError(f"the bootloader answered `clear` with Error: {out!r}")

    def upload_image(self, fw: FirmwareImage) -> None:
        image = fw.image
        self._start_transfer(f"load {len(image)} {fw.checksum}", refused_usage=(
            rb"Image too large \(maximum (\d+) bytes\)",
            f"the bootloader refused the image: Image too large (maximum {{0}} bytes); "
            f"{fw.image_path or 'the image'} is {len(image)} bytes"),
            expect_refusal=len(image) > self.max_image)
        self._paced(STX + image + ETX, "image")
        m = self.wire.wait_for(b"Checksum OK\r\n", b"Checksum failure\r\n", b"Timed out waiting for data\r\n",
                               timeout=_ANSWER_TIMEOUT + 1.0)
        if m is None:
            raise LoadError(f"no answer from the bootloader after the image's last byte; received "
                            f"{self.wire.recent()}")
        self.wire.wait_for(self.prompt, timeout=0.5)
        if m.group(0).startswith(b"Checksum failure"):
            raise LoadError(f"the bootloader answered Checksum failure: the image ({len(image)} bytes, "
                            f"checksum {fw.checksum}) did not arrive intact; bytes were changed or lost "
                            "on the link", EXIT_TARGET)
        if m.group(0).startswith(b"Timed out"):
            raise LoadError("the bootloader answered Timed out waiting for data during the image upload: "
                            "bytes were lost or delayed on the link (more than 1 s without a byte)",
                            EXIT_TARGET)

    def upload_signature(self, fw: FirmwareImage) -> None:
        sig = fw.signature
        self._start_transfer(f"signature {len(sig)}", refused_usage=(
            rb"Incorrect signature length \(should be ?(\d+) bytes\)",
            f"the bootloader refused the signature: Incorrect signature length (should be{{0}} bytes); "
            f"{fw.signature_path or 'the signature'} is {len(sig)} bytes"),
            expect_refusal=len(sig) != self.signature_length)
        self._paced(STX + sig + ETX, "signature", show=False)
        m = self.wire.wait_for(b"Signature received\r\n", b"Timed out waiting for data\r\n",
                               timeout=_ANSWER_TIMEOUT)
        if m is None:
            raise LoadError("no answer from the bootloader after the signature; received "
                            f"{self.wire.recent()}")
        self.wire.wait_for(self.prompt, timeout=0.5)
        if m.group(0).startswith(b"Timed out"):
            raise LoadError("the bootloader answered Timed out waiting for data during the signature upload: "
                            "bytes were lost or delayed on the link", EXIT_TARGET)

    def reboot(self) -> None:
        """``reboot``: the bootloader verifies the signature, then starts the image."""
        self.wire.skip()
        self.wire.send(b"reboot\r")
        m = self.wire.wait_for(b"Rebooting...\r\n", b"Image verification failed\r\n", b"No image loaded\r\n",
                               _ERROR, timeout=_VERIFY_TIMEOUT)
        if m is None:
            raise LoadError(f"no answer to `reboot` within {_VERIFY_TIMEOUT:g} s; "
                            f"received {self.wire.recent()}")
        said = m.group(0)
        if said.startswith(b"Image verification failed"):
            raise LoadError("the bootloader answered Image verification failed: the signature is not this "
                            "image's (or not made with the key in this HAT's bootloader)", EXIT_USAGE)
        if not said.startswith(b"Rebooting"):
            raise LoadError(f"the bootloader refused `reboot`: {said.strip().decode('ascii', 'replace')} "
                            f"(received {self.wire.recent()})")

    def wait_started(self) -> None:
        if self.wire.wait_for(_DONE, timeout=_BOOT_TIMEOUT) is None:
            raise LoadError(f"the firmware did not finish starting (no 'Done initialising ports' within "
                            f"{_BOOT_TIMEOUT:g} s of `reboot`); received {self.wire.recent()}")

    def confirm(self) -> str:
        """The running firmware's version text (after ``Firmware version: ``)."""
        kind, version = self.identify()
        if kind != "firmware":
            raise LoadError(f"after the reboot the bootloader still answers (version {version}): the image "
                            "did not start")
        return version

    # -- raw transfers ---------------------------------------------------------------------
    def _start_transfer(self, line: str, refused_usage: Tuple[bytes, str], expect_refusal: bool) -> None:
        """Send the command and make sure the bootloader now reads raw bytes (it said no error)."""
        self.wire.skip()
        self.wire.send(line.encode("ascii") + b"\r")
        refusal = re.compile(refused_usage[0])
        echo = line.encode("ascii") + b"\r\n"
        if self.wire.wait_for(echo, timeout=_ANSWER_TIMEOUT) is None:
            raise LoadError(f"the bootloader did not echo `{line}`; received {self.wire.recent()}")
        # A refusal comes right after the echo. Wait for it when the size says it will come;
        # otherwise look briefly (a bootloader with other limits) before sending raw bytes.
        m = self.wire.wait_for(refusal, _ERROR, timeout=_ANSWER_TIMEOUT if expect_refusal else 0.1)
        if m is None:
            if expect_refusal:
                raise LoadError(f"the bootloader took `{line}` although its limit is exceeded; "
                                f"received {self.wire.recent()}")
            return
        self.wire.wait_for(self.prompt, timeout=0.5)
        if m.re is refusal:
            raise LoadError(refused_usage[1].format(m.group(1).decode()), EXIT_USAGE)
        raise LoadError(f"the bootloader answered `{line}` with Error; received {self.wire.recent()}")

    def _paced(self, data: bytes, label: str, show: bool = True) -> None:
        """Write ``data`` in chunks, never ahead of the wire: a chunk starting at byte ``o``
        goes out no sooner than the time ``o`` bytes take at ``baud``."""
        bar = self.progress(len(data), label) if (show and self.progress) else None
        clock = self.wire.clock
        start = clock()
        sent = 0
        began = len(self.wire.received)
        try:
            while sent < len(data):
                due = start + wire_seconds(sent, self.baud)
                wait = due - clock()
                if wait > 0:
                    self.sleep(wait)
                piece = data[sent:sent + self.chunk]
                self.wire.send(piece)
                sent += len(piece)
                if self.wire.poll(0.0) and _GAVE_UP.search(self.wire.received, began):
                    break                     # it stopped reading raw bytes: the rest would be typed
                if bar is not None:
                    bar.update(sent)
        finally:
            if bar is not None:
                bar.finish(sent)
