"""The bootloader (FIRMWARE-FACTS §9, §10): texts, checksum, raw uploads, timeouts, ECDSA, reboot."""
from __future__ import annotations

import hashlib
import random

import pytest
from cryptography.hazmat.primitives import hashes, serialization
from cryptography.hazmat.primitives.asymmetric import ec
from cryptography.hazmat.primitives.asymmetric.utils import decode_dss_signature

from buildhat_conformance.emulator.api import Emulator
from buildhat_conformance.emulator.bootloader import Bootloader, bootloader_checksum
from buildhat_conformance.emulator.command_uart import Uart
from buildhat_conformance.protocol.profiles import get_profile

PROMPT = b"BHBL> "
VERSION = b"BuildHAT bootloader version 1737564075 2025-01-22T16:41:15+00:00"
# §9, verbatim.
HELP = b"""Commands available:
  help, ?                  : display this text
  version                  : display version string
  load <length> <checksum> : initiate upload
                             followed by <STX><<length> data bytes><ETX>
  signature <length>       : upload signature
                             followed by <STX><<length> data bytes><ETX>
  clear                    : clear any uploaded image
  verify                   : verify upload
  reboot                   : reboot if upload successfully verified
""".replace(b"\n", b"\r\n")


class Machine:
    """A bootloader on its own UART, with the events and reboots it reports."""

    def __init__(self, key=None):
        self.uart = Uart(rx_size=4096, tx_size=4096)
        self.events = []
        self.reboots = []
        self.bl = Bootloader(self.uart, now=0, event_sink=lambda k, t, f: self.events.append((k, t, f)),
                             reboot=lambda image, sig: self.reboots.append((self.bl.now, image, sig)),
                             key=key)
        self.banner = self.uart.host_read()

    def send(self, data: bytes) -> bytes:
        self.bl.feed(data)
        return self.uart.host_read()

    def advance(self, ms: int) -> bytes:
        for _ in range(ms):
            self.bl.tick()
        return self.uart.host_read()


# -- checksum -------------------------------------------------------------------------------

def test_checksum_hand_values():
    assert bootloader_checksum(b"") == 1                       # §9: the empty image gives 1
    # s=1; byte 01: s = 2 ^ 1 = 3; byte 80: s = 6 ^ 0x80 = 0x86
    assert bootloader_checksum(b"\x01\x80") == 0x86
    # 31 zero bytes shift the initial 1 to bit 31; the 32nd shifts it out -> s = 0x1D872B41
    assert bootloader_checksum(bytes(31)) == 0x80000000
    assert bootloader_checksum(bytes(32)) == 0x1D872B41
    assert bootloader_checksum(bytes(33)) == 0x3B0E5682          # 0x1D872B41 << 1, no reduction


def _gf2_mod(value: int, poly: int) -> int:
    while value.bit_length() >= poly.bit_length():
        value ^= poly << (value.bit_length() - poly.bit_length())
    return value


def test_checksum_equals_the_gf2_polynomial_form():
    # §9: s = (x^n + sum b_i(x) x^(n-1-i)) mod P(x), P = x^32 + poly(0x1D872B41)
    rng = random.Random(7)
    data = bytes(rng.randrange(256) for _ in range(300))
    n = len(data)
    total = 1 << n
    for i, b in enumerate(data):
        total ^= b << (n - 1 - i)
    assert bootloader_checksum(data) == _gf2_mod(total, (1 << 32) | 0x1D872B41)


# -- texts ----------------------------------------------------------------------------------

def test_banner_help_version_and_prefixes():
    m = Machine()
    assert m.banner == b"\r\nType help <RETURN> for help\r\n" + PROMPT
    assert m.send(b"help\r") == b"help\r\n" + VERSION + b"\r\n" + HELP + PROMPT
    assert m.send(b"?\r") == b"?\r\n" + VERSION + b"\r\n" + HELP + PROMPT
    assert m.send(b"version\r") == b"version\r\n" + VERSION + b"\r\n" + PROMPT
    # `v` is verify (table order), `ve` is still verify, `vers` is version
    assert m.send(b"v\r") == b"v\r\nNo image loaded\r\nError\r\n" + PROMPT
    assert m.send(b"ve\r") == b"ve\r\nNo image loaded\r\nError\r\n" + PROMPT
    assert m.send(b"vers\r") == b"vers\r\n" + VERSION + b"\r\n" + PROMPT
    assert m.send(b"c\r") == b"c\r\n" + PROMPT                  # clear: no output
    assert m.send(b"bogus\r") == b"bogus\r\nError\r\n" + PROMPT
    assert m.send(b"\r") == b"\r\n" + PROMPT


def test_echo_is_always_on_with_rubout():
    m = Machine()
    assert m.send(b"vx\x08") == b"vx\x08 \x08"
    assert m.send(b"\x7f\x7f") == b"\x08 \x08"                   # nothing left to rub out
    assert m.send(b"\r") == b"\r\n" + PROMPT


# -- load -------------------------------------------------------------------------------------

def test_load_with_junk_around_the_frame_and_checksum_ok():
    m = Machine()
    image = bytes(range(10))
    command = b"load 10 %d\r" % bootloader_checksum(image)
    assert m.send(command) == command + b"\n"
    # Raw bytes: no echo; junk before STX and between the data and ETX is discarded.
    assert m.send(b"zz\x02" + image + b"junk") == b""
    assert m.send(b"\x03") == b"\r\nImage received\r\nChecksum OK\r\n" + PROMPT
    assert m.bl.image == image
    assert m.send(b"\r") == b"\r\n" + PROMPT


def test_load_checksum_failure_leaves_no_image():
    m = Machine()
    m.send(b"load 3 1\r")
    assert m.send(b"\x02abc\x03") == b"\r\nImage received\r\nChecksum failure\r\nError\r\n" + PROMPT
    assert m.bl.image is None
    assert m.send(b"verify\r").endswith(b"No image loaded\r\nError\r\n" + PROMPT)


def test_empty_image_has_checksum_1():
    m = Machine()
    m.send(b"load 0 1\r")
    assert m.send(b"\x02\x03") == b"\r\nImage received\r\nChecksum OK\r\n" + PROMPT
    assert m.bl.image == b""


def test_image_too_large():
    m = Machine()
    assert m.send(b"load 245761 5\r") == (b"load 245761 5\r\n\r\nImage too large (maximum 245760 bytes)\r\n"
                                          b"Error\r\n" + PROMPT)
    # 245760 itself is accepted (then waits for STX)
    assert m.send(b"load 245760 5\r") == b"load 245760 5\r\n"


def test_load_arguments_are_required():
    m = Machine()
    assert m.send(b"load 5\r") == b"load 5\r\nError\r\n" + PROMPT
    assert m.send(b"load\r") == b"load\r\nError\r\n" + PROMPT


@pytest.mark.req("FW-9")
def test_timeout_waiting_for_stx_is_1000_ms():
    m = Machine()
    m.send(b"load 4 1\r")
    assert m.advance(999) == b""
    assert m.advance(1) == b"\r\nTimed out waiting for data\r\nError\r\n" + PROMPT
    # back in the line editor
    assert m.send(b"v\r").startswith(b"v\r\nNo image loaded")


def test_timeout_restarts_with_every_byte():
    m = Machine()
    m.send(b"load 4 1\r")
    m.advance(900)
    m.send(b"\x02ab")                 # bytes arrive: the wait restarts
    assert m.advance(999) == b""
    assert m.advance(1) == b"\r\nTimed out waiting for data\r\nError\r\n" + PROMPT
    assert m.bl.image is None


def test_rest_of_the_line_runs_after_the_transfer():
    m = Machine()
    image = b"xyz"
    m.send(b"load 3 %d version\r" % bootloader_checksum(image))
    assert m.send(b"\x02xyz\x03") == b"\r\nImage received\r\nChecksum OK\r\n" + VERSION + b"\r\n" + PROMPT


# -- signature, verify, reboot ---------------------------------------------------------------

def test_signature_length_must_be_64():
    m = Machine()
    assert m.send(b"signature 32\r") == (b"signature 32\r\n\r\nIncorrect signature length (should be64 bytes)"
                                         b"\r\nError\r\n" + PROMPT)
    sig = bytes(range(64))
    m.send(b"s 64\r")
    assert m.send(b"\x02" + sig + b"\x03") == b"\r\nSignature received\r\n" + PROMPT
    assert m.bl.signature == sig


def _keypair():
    private = ec.generate_private_key(ec.SECP256R1())
    pem = private.public_key().public_bytes(serialization.Encoding.PEM,
                                            serialization.PublicFormat.SubjectPublicKeyInfo)
    return private, pem


def _sign(private, image: bytes) -> bytes:
    r, s = decode_dss_signature(private.sign(image, ec.ECDSA(hashes.SHA256())))
    return r.to_bytes(32, "big") + s.to_bytes(32, "big")


def _upload(m: Machine, image: bytes, signature: bytes) -> None:
    m.send(b"load %d %d\r" % (len(image), bootloader_checksum(image)))
    m.send(b"\x02" + image + b"\x03\r")
    m.send(b"signature 64\r")
    m.send(b"\x02" + signature + b"\x03\r")


def _verify_report(image: bytes, key_xy: bytes) -> bytes:
    n = len(image)
    return (b"Verifying image...\r\n"
            + b"Verifying image length=%d %02X %02X %02X %02X\r\n"
            % (n, image[0], image[0], image[-2], image[-1])
            + b"SHA256:\r\n" + b"".join(b" %02X" % b for b in hashlib.sha256(image).digest()) + b"\r\n"
            + b"Public key:\r\n" + b"".join(b" %02X" % b for b in key_xy) + b"\r\n")


@pytest.mark.req("FW-9")
def test_verify_and_reboot_with_a_key_and_a_good_signature(tmp_path):
    private, pem = _keypair()
    key_file = tmp_path / "key.pem"
    key_file.write_bytes(pem)
    m = Machine(key=str(key_file))
    nums = private.public_key().public_numbers()
    xy = nums.x.to_bytes(32, "big") + nums.y.to_bytes(32, "big")
    image = bytes(random.Random(1).randrange(256) for _ in range(1000))
    sig = _sign(private, image)
    _upload(m, image, sig)
    assert m.send(b"verify\r") == b"verify\r\n" + _verify_report(image, xy) + b"Image verifed OK\r\n" + PROMPT
    out = m.send(b"reboot\r")
    assert out == b"reboot\r\n" + _verify_report(image, xy) + b"Image verifed OK\r\nRebooting...\r\n"
    start = m.bl.now
    m.advance(99)
    assert m.reboots == []
    m.advance(1)
    assert m.reboots == [(start + 100, image, sig)]
    assert not any(k == "note" for k, _, _ in m.events)


def test_bad_signature_fails_and_does_not_reboot():
    private, pem = _keypair()
    m = Machine(key=pem)
    image = b"\x10\x20\x30\x40\x50"
    sig = bytearray(_sign(private, image))
    sig[5] ^= 1
    _upload(m, image, bytes(sig))
    out = m.send(b"verify\r")
    assert out.endswith(b"Image verification failed\r\nError\r\n" + PROMPT)
    assert b"Verifying image length=5 10 10 40 50\r\n" in out
    out = m.send(b"reboot\r")
    assert out.endswith(b"Image verification failed\r\nError\r\n" + PROMPT)
    m.advance(500)
    assert m.reboots == []


def test_without_a_key_images_are_accepted_with_a_note():
    m = Machine()
    image = b"abcd"
    _upload(m, image, bytes(64))
    out = m.send(b"verify\r")
    assert out.endswith(b"Image verifed OK\r\n" + PROMPT)
    # The line still shows a public key: the one in the released bootloader (§9).
    assert b"Public key:\r\n 40 58 70 58 43 39 16 4F" in out
    notes = [f["text"] for k, _, f in m.events if k == "note"]
    assert notes and "without checking" in notes[0]
    assert all(b"\r\n" not in n.encode() for n in notes)


def test_bad_key_file_is_a_clear_error(tmp_path):
    bad = tmp_path / "k.pem"
    bad.write_bytes(b"not a key")
    with pytest.raises(ValueError, match="PEM"):
        Machine(key=str(bad))
    rsa_free = ec.generate_private_key(ec.SECP384R1()).public_key().public_bytes(
        serialization.Encoding.PEM, serialization.PublicFormat.SubjectPublicKeyInfo)
    with pytest.raises(ValueError, match="P-256"):
        Machine(key=rsa_free)


def _image_with_checksum(prefix: bytes, target: int) -> bytes:
    """Append 32 bytes of 0/1 so that the checksum becomes ``target`` (the map is linear:
    each appended byte's low bit lands on one of the 32 state bits)."""
    base = bootloader_checksum(prefix + bytes(32))
    bits = base ^ target
    return prefix + bytes((bits >> (31 - j)) & 1 for j in range(32))


def test_reboot_through_the_emulator_boots_the_release_with_that_checksum():
    r3 = get_profile("R3")
    image = _image_with_checksum(b"not really R3", r3.image_checksum)
    assert bootloader_checksum(image) == r3.image_checksum
    emu = Emulator(bootloader=True, devices={0: "none", 1: "none", 2: "none", 3: "none"})
    emu.advance(2)
    emu.write(b"load %d %d\r" % (len(image), r3.image_checksum))
    emu.write(b"\x02" + image + b"\x03\r")
    emu.write(b"signature 64\r")
    emu.write(b"\x02" + bytes(64) + b"\x03\r")
    emu.write(b"reboot\r")
    out = emu.read()
    assert out.endswith(b"Image verifed OK\r\nRebooting...\r\n")
    emu.advance(99)
    assert emu.in_bootloader
    emu.advance(420)        # `Done initialising ports` about 404 ms after power-on (emulator/startup.py)
    assert not emu.in_bootloader and emu.hat.profile.name == "R3"
    assert b"Done initialising ports" in emu.read()
