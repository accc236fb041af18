"""The Build HAT bootloader on the command port (FIRMWARE-BEHAVIOUR.md#fb-bootloader, #fb-timing), in
virtual time.

The same machine interface as ``Hat`` for ``emulator/api.py``: ``Bootloader(uart, now=...,
event_sink=..., reboot=..., key=...)``, ``tick()`` (one millisecond), ``poll()`` (handle the
bytes received so far), ``now``. Echo is always on, the prompt is ``BHBL> ``, the command
table is ``help, ?, load, signature, clear, verify, reboot, version`` (``v`` -> verify), and
the line editor and the prefix matcher are the firmware's (``lineeditor.py``, ``parser.py``).

``load <len> <checksum>`` and ``signature 64`` read raw bytes straight from the receive ring
(no echo, no line editing): everything up to STX is discarded, then exactly ``len`` bytes are
taken, then everything up to ETX is discarded; each wait gives up after 1000 ms without a
byte. ``verify`` checks an ECDSA P-256 signature (r||s, big-endian) over SHA-256(image) with the
public key given as PEM (``key``); without a key an image is accepted unverified and a ``note``
event says so. ``reboot`` verifies, prints ``Rebooting...``, and 100 ms later calls
``reboot(image, signature)``.
"""
from __future__ import annotations

import hashlib
import os
from typing import Any, Callable, Dict, List, Optional, Union

from ..protocol.image_checksum import bootloader_checksum
from ..protocol.profiles import bootloader_data
from .command_uart import Uart
from .commands.line_editor import CRLF, LineEditor
from .commands.parser import CommandError, Cursor

__all__ = ["Bootloader", "bootloader_checksum", "load_public_key", "RELEASE_PUBLIC_KEY",
           "DATA_TIMEOUT_MS", "REBOOT_DELAY_MS", "STX", "ETX"]

STX, ETX = 0x02, 0x03
DATA_TIMEOUT_MS = 1000
REBOOT_DELAY_MS = 100
_ERROR = b"Error"

# The key the released bootloader holds (bhbl-pico/key.public.h, 64 bytes as stored). Only
# printed on the `Public key:` line when no key file is given; the emulator cannot verify
# with it because it has no release images to check.
RELEASE_PUBLIC_KEY = bytes.fromhex(
    "40587058 4339164F 9DEADF8B B716735C 531E3ACC 0CE39E4E 2912C069 0768DF5F"
    "D1B4C50A D3973DD1 B275294E 58826D8A E199C0A0 7FFE079D 6C6E1D7D BEA93AF9".replace(" ", ""))

EventSink = Callable[[str, int, Dict[str, Any]], None]
RebootHook = Callable[[bytes, Optional[bytes]], None]


def load_public_key(key: Union[bytes, str, os.PathLike]) -> Any:
    """An EC P-256 public key from PEM bytes or a PEM file path; clear errors otherwise."""
    from cryptography.hazmat.primitives.asymmetric import ec
    from cryptography.hazmat.primitives.serialization import load_pem_public_key

    if isinstance(key, (str, os.PathLike)):
        with open(key, "rb") as fh:
            key = fh.read()
    try:
        public = load_pem_public_key(bytes(key))
    except ValueError as exc:
        raise ValueError(f"bootloader key is not a PEM public key: {exc}") from None
    if not isinstance(public, ec.EllipticCurvePublicKey) or public.curve.name != "secp256r1":
        raise ValueError("bootloader key must be an ECDSA P-256 (secp256r1) public key")
    return public


def _hex_bytes(data: bytes) -> bytes:
    return b"".join(b" %02X" % b for b in data)


class _RawRead:
    """A pending ``load``/``signature`` transfer: STX, ``length`` bytes, ETX."""

    def __init__(self, kind: str, length: int, checksum: int, started: int, rest: Cursor):
        self.kind = kind
        self.length = length
        self.checksum = checksum
        self.stage = "stx"
        self.data = bytearray()
        self.last = started          # time of the last byte (or of the command)
        self.rest = rest             # the rest of the command line, run after the transfer


class Bootloader:
    """The bootloader: line editor, command table, raw uploads, verification, reboot."""

    def __init__(self, uart: Uart, now: int = 0, event_sink: Optional[EventSink] = None,
                 reboot: Optional[RebootHook] = None,
                 key: Union[bytes, str, os.PathLike, None] = None,
                 version: Optional[str] = None) -> None:
        data = bootloader_data()
        self.uart = uart
        self.now = now
        self.event_sink = event_sink
        self.reboot_hook = reboot
        self.public_key = load_public_key(key) if key is not None else None
        self.version = version or data["default_version"]
        self.prompt = data["prompt"].encode("ascii")
        self.commands: List[str] = list(data["commands"])
        self.help_lines: List[str] = list(data["help_text"])
        self.max_image = int(data["max_image"])
        self.signature_length = int(data["signature_length"])
        self.image: Optional[bytes] = None
        self.signature = bytes(self.signature_length)    # the RAM copy; zeros until uploaded
        self.editor = LineEditor(self.write_out, lambda: True)
        self._raw: Optional[_RawRead] = None
        self._reboot_at: Optional[int] = None
        self.rebooted = False
        self._table: Dict[str, Callable[[Cursor], bool]] = {
            "help": self._help, "?": self._help, "load": self._load,
            "signature": self._signature, "clear": self._clear, "verify": self._verify,
            "reboot": self._reboot, "version": self._version,
        }
        self.write_out(b"\r\nType help <RETURN> for help\r\n" + self.prompt)

    # -- output --------------------------------------------------------------------------
    def write_out(self, data: bytes) -> None:
        self.uart.write(bytes(data))

    def emit(self, line: bytes) -> None:
        self.uart.write(bytes(line) + CRLF)

    def note(self, text: str) -> None:
        if self.event_sink is not None:
            self.event_sink("note", self.now, {"text": text})

    # -- time and input ------------------------------------------------------------------
    def tick(self) -> None:
        """One millisecond: wire, input, data timeouts, the reboot delay."""
        self.now += 1
        self.uart.tick()
        self.poll()
        raw = self._raw
        if raw is not None and self.now - raw.last >= DATA_TIMEOUT_MS:
            self._raw = None
            self.emit(b"\r\nTimed out waiting for data")
            self._fail()
        if self._reboot_at is not None and self.now >= self._reboot_at:
            self._reboot_at = None
            self.rebooted = True
            if self.reboot_hook is not None:
                self.reboot_hook(self.image or b"", self.signature)

    def poll(self) -> None:
        """Handle every received byte now (line editing, or a raw transfer in progress)."""
        while self._reboot_at is None and not self.rebooted:
            byte = self.uart.read_byte()
            if byte is None:
                return
            if self._raw is not None:
                self._raw_byte(byte)
                continue
            line = self.editor.feed(byte)
            if line is not None:
                self._run(Cursor(line))

    def feed(self, data: bytes) -> None:
        """Convenience for direct use: bytes from the host, handled at once."""
        for i in range(0, len(data), 256):
            self.uart.host_write(bytes(data[i:i + 256]))
            self.poll()

    # -- the command line ----------------------------------------------------------------
    def _run(self, cur: Cursor) -> None:
        """Run commands until the line ends, a command fails, or a raw transfer starts."""
        while True:
            cur.skip_separators()
            if cur.at_end():
                break
            name = cur.match(self.commands)
            try:
                if name is None:
                    raise CommandError("unknown command")
                if self._table[name](cur):
                    return                      # a transfer reads the next bytes; line resumes after it
            except CommandError:
                self._fail()
                return
            if self._reboot_at is not None:
                return                          # rebooting: nothing else runs
        self.write_out(self.prompt)

    def _fail(self) -> None:
        self.emit(_ERROR)
        self.write_out(self.prompt)

    # -- commands (return True when a raw transfer has started) --------------------------
    def _help(self, cur: Cursor) -> bool:
        self._version(cur)
        for line in self.help_lines:
            self.emit(line.encode("utf-8"))
        return False

    def _version(self, cur: Cursor) -> bool:
        self.emit(b"BuildHAT bootloader version " + self.version.encode("ascii"))
        return False

    def _clear(self, cur: Cursor) -> bool:
        self.image = None
        return False

    def _load(self, cur: Cursor) -> bool:
        length = cur.unsigned()
        checksum = cur.unsigned()
        self.image = None                               # marked empty first
        if length > self.max_image:
            self.emit(b"\r\nImage too large (maximum %d bytes)" % self.max_image)
            raise CommandError("image too large")
        self._raw = _RawRead("load", length, checksum, self.now, cur)
        return True

    def _signature(self, cur: Cursor) -> bool:
        length = cur.unsigned()
        if length != self.signature_length:
            self.emit(b"\r\nIncorrect signature length (should be%d bytes)" % self.signature_length)
            raise CommandError("bad signature length")
        self._raw = _RawRead("signature", length, 0, self.now, cur)
        return True

    def _verify(self, cur: Cursor) -> bool:
        if not self.verify_image():
            raise CommandError("verification failed")
        return False

    def _reboot(self, cur: Cursor) -> bool:
        if not self.verify_image():
            raise CommandError("verification failed")
        self.emit(b"Rebooting...")
        self._reboot_at = self.now + REBOOT_DELAY_MS
        return False

    # -- raw transfers -------------------------------------------------------------------
    def _raw_byte(self, byte: int) -> None:
        raw = self._raw
        assert raw is not None
        raw.last = self.now
        if raw.stage == "stx":
            if byte == STX:
                raw.stage = "data" if raw.length else "etx"
        elif raw.stage == "data":
            raw.data.append(byte)
            if len(raw.data) == raw.length:
                raw.stage = "etx"
        elif byte == ETX:
            self._raw = None
            self._finish(raw)

    def _finish(self, raw: _RawRead) -> None:
        data = bytes(raw.data)
        if raw.kind == "signature":
            self.signature = data
            self.emit(b"\r\nSignature received")
        else:
            self.emit(b"\r\nImage received")
            if bootloader_checksum(data) != raw.checksum:
                self.emit(b"Checksum failure")
                self._fail()
                return
            self.image = data
            self.emit(b"Checksum OK")
        self._run(raw.rest)

    # -- verification --------------------------------------------------------------------
    def verify_image(self) -> bool:
        """Print the verify report; True if the image may run."""
        image = self.image
        if image is None:
            self.emit(b"No image loaded")
            return False
        n = len(image)
        # The first byte is printed twice (a firmware quirk). Bytes before the start of a
        # 1-byte image are not known; they print as 00.
        b0 = image[0] if n else 0
        b2 = image[n - 2] if n >= 2 else 0
        b1 = image[n - 1] if n else 0
        self.emit(b"Verifying image...")
        self.emit(b"Verifying image length=%d %02X %02X %02X %02X" % (n, b0, b0, b2, b1))
        self.emit(b"SHA256:")
        self.emit(_hex_bytes(hashlib.sha256(image).digest()))
        self.emit(b"Public key:")
        self.emit(_hex_bytes(self._public_key_bytes()))
        if self._signature_ok(image):
            self.emit(b"Image verifed OK")
            return True
        self.emit(b"Image verification failed")
        return False

    def _public_key_bytes(self) -> bytes:
        if self.public_key is None:
            return RELEASE_PUBLIC_KEY
        numbers = self.public_key.public_numbers()
        return numbers.x.to_bytes(32, "big") + numbers.y.to_bytes(32, "big")

    def _signature_ok(self, image: bytes) -> bool:
        if self.public_key is None:
            self.note("bootloader: no public key given (--bootloader-key); "
                      "the image is accepted without checking its signature")
            return True
        from cryptography.exceptions import InvalidSignature
        from cryptography.hazmat.primitives import hashes
        from cryptography.hazmat.primitives.asymmetric import ec
        from cryptography.hazmat.primitives.asymmetric.utils import encode_dss_signature

        half = self.signature_length // 2
        r = int.from_bytes(self.signature[:half], "big")
        s = int.from_bytes(self.signature[half:], "big")
        try:
            self.public_key.verify(encode_dss_signature(r, s), image, ec.ECDSA(hashes.SHA256()))
        except (InvalidSignature, ValueError):
            return False
        return True
