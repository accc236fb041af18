"""The Python API beyond the command port: wire pacing (§1 rings), world actions, resets, bootloader."""
from __future__ import annotations

import pytest

from buildhat_conformance.emulator import Emulator
from buildhat_conformance.emulator.world_actions import WORLD_HANDLERS, WorldError
from buildhat_conformance.transcripts.script import WORLD_ACTIONS

EMPTY = {0: None, 1: None, 2: None, 3: None}
HELP_R7 = 4201          # §4.3: the R6-R7 help text is 4201 bytes


def test_paced_wire_carries_115200_baud():
    emu = Emulator(firmware="R7", devices=EMPTY, baud=115200)
    emu.boot()
    emu.advance(50)
    emu.read()
    emu.write(b"help\r")
    emu.advance(5)                    # nothing can arrive before the 5 command bytes went over the wire
    got = emu.read()
    assert 0 < len(got) < 2 + HELP_R7
    emu.advance(100)
    got += emu.read()
    # 115200 baud 8N1 = 11.52 bytes/ms: 105 ms carry at most ~1210 bytes (5 of them inbound)
    assert len(got) <= 105 * 11.52 + 12
    emu.advance(1000)
    got += emu.read()
    assert got.startswith(b"\r\nCommands available:\r\n") and len(got) == 2 + HELP_R7


def test_tx_ring_overflow_drops_output():
    # §1: an output byte is silently dropped when the 8192-byte TX ring is full; three help texts
    # (3 x 4201 bytes) written at once overflow it, so exactly 8192 bytes reach the wire.
    emu = Emulator(firmware="R7", devices=EMPTY, baud=115200)
    emu.boot()
    emu.advance(50)
    emu.read()
    emu.write(b"help;help;help\r")
    emu.advance(2500)             # the whole line runs in one pass; the wire then drains the ring
    out = emu.read()
    assert len(out) == 8192
    assert emu.uart.tx_dropped == 2 + 3 * HELP_R7 - 8192
    assert out.startswith(b"\r\nCommands available:\r\n")


def test_unpaced_tx_pending_is_zero():
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.boot()
    emu.write(b"help\r")
    assert emu.hat.tx_pending() == 0


def test_world_table_covers_every_script_action():
    assert set(WORLD_HANDLERS) == set(WORLD_ACTIONS)


def test_world_errors_are_clear():
    emu = Emulator(firmware="R7", devices=EMPTY)
    with pytest.raises(WorldError, match="unknown world action"):
        emu.world("@frobnicate 1")
    with pytest.raises(WorldError, match="port must be in 0..3"):
        emu.world("@unplug 7")
    with pytest.raises(WorldError, match="ADC"):
        emu.world("@adc 5000")
    assert emu.world("@time") == "ok 0"
    assert emu.world("@firmware") == "ok 1737564117 2025-01-22T16:41:57+00:00"


def test_reset_restarts_the_firmware():
    emu = Emulator(firmware="R5", devices=EMPTY)
    emu.boot()
    emu.write(b"echo 1\rport 2\r")
    emu.read()
    assert emu.world("@reset") == "ok"
    assert emu.hat.port == 0 and emu.hat.echo == 0
    emu.boot()
    assert emu.read().startswith(b"\r\nType help <RETURN> for help\r\n")


def test_reset_into_bootloader_and_back_with_an_upload():
    emu = Emulator(firmware="R7", devices=EMPTY)
    emu.boot()
    emu.read()
    emu.world("@reset bootloader")
    assert emu.in_bootloader and emu.hat is None
    emu.advance(1)
    assert emu.read() == b"\r\nType help <RETURN> for help\r\nBHBL> "      # §9 banner and prompt
    with pytest.raises(WorldError, match="bootloader"):
        emu.world("@plug 1 0x30")
    assert emu.world("@firmware") == "ok bootloader"
    image = bytes(range(256)) * 4
    from buildhat_conformance.emulator.bootloader import bootloader_checksum
    sig = bytes(range(64))
    emu.write(b"load %d %d\r" % (len(image), bootloader_checksum(image)))
    emu.write(b"\x02" + image + b"\x03\r")
    emu.write(b"signature 64\r")
    emu.write(b"\x02" + sig + b"\x03\r")
    out = emu.read()
    assert b"Checksum OK" in out and b"Signature received" in out
    emu.write(b"reboot\r")
    emu.advance(150)                             # 100 ms after `Rebooting...` the image runs
    assert not emu.in_bootloader
    assert any(e["dir"] == "note" and "no known release" in e["text"] for e in emu.events)
    emu.boot()
    emu.read()
    emu.write(b"signature\r")                   # §4.1: the signature the bootloader copied to RAM
    assert emu.read() == b"\r\nFirmware signature:" + b"".join(b" %02X" % b for b in sig) + b"\r\n"


def test_time_only_moves_with_advance():
    emu = Emulator(firmware="R7", devices=EMPTY)
    assert emu.now == 0
    emu.advance(7)
    assert emu.now == 7
    with pytest.raises(ValueError):
        emu.advance(-1)


def test_default_layout_boots_and_devices_can_be_overridden():
    emu = Emulator(firmware="R7")
    took = emu.boot()
    assert 0 < took < 20000 and emu.settled()
    assert Emulator(devices={1: "none", 0: "passive 8"}).devices == {
        0: ("passive", 8), 1: None, 2: ("passive", 8), 3: None}
    with pytest.raises(ValueError):
        Emulator(devices={5: "0x30"})


def test_unpaced_large_upload_reaches_the_bootloader_whole():
    # the bootloader's ring is 4096 bytes (§9); a 20000-byte image must still arrive complete
    from buildhat_conformance.emulator.bootloader import bootloader_checksum
    emu = Emulator(firmware="R7", devices=EMPTY, bootloader=True)
    image = bytes((i * 7) & 0xFF for i in range(20000))
    emu.write(b"load %d %d\r" % (len(image), bootloader_checksum(image)) + b"\x02" + image + b"\x03\r")
    out = emu.read()
    assert b"\r\nImage received\r\nChecksum OK\r\n" in out


def test_random_state_is_seeded():
    assert Emulator(devices=EMPTY, seed=5).hat.seed == 5


def _image_with_checksum(target: int, prefix: bytes = b"BUILDHAT") -> bytes:
    """An image whose §9 checksum is ``target``: per byte s = (s << 1) (^ P on carry), s ^= b, so the
    low bit of each of 32 trailing bytes lands on its own power of x: pick them to hit the target."""
    from buildhat_conformance.emulator.bootloader import bootloader_checksum
    base = bootloader_checksum(prefix + bytes(32))
    diff = base ^ target
    return prefix + bytes((diff >> (31 - j)) & 1 for j in range(32))


def test_reboot_runs_the_release_whose_checksum_matches():
    # §9: checksums of the release images; R5 is 2080457803
    from buildhat_conformance.emulator.bootloader import bootloader_checksum
    image = _image_with_checksum(2080457803)
    assert bootloader_checksum(image) == 2080457803
    emu = Emulator(firmware="R7", devices=EMPTY, bootloader=True)
    emu.write(b"load %d %d\r\x02" % (len(image), 2080457803) + image + b"\x03\r")
    emu.write(b"reboot\r")
    emu.advance(150)
    assert emu.hat is not None and emu.profile.name == "R5"
    emu.boot()
    emu.read()
    emu.write(b"version\r")
    assert emu.read() == b"\r\nFirmware version: 1670596313 2022-12-09T14:31:53+00:00\r\n"


def test_unpowered_matrix_grace_counts_from_its_set_up_not_from_the_boot():
    # Issue 37: on a release that never powers the LED matrix (R2), the default layout's motor sets up
    # at 2400 baud for longer than the matrix's grace, so the grace runs out during the start-up, as on
    # the firmware in the loop; the boot's restart helps only a matrix still alive then. The matrix
    # stops talking a grace after its set-up and the HAT drops it 500 ms (plus a keep-alive) later.
    emu = Emulator(firmware="R2")
    out = bytearray()
    times = {}

    def pump() -> None:
        data = emu.read()
        out.extend(data)
        for key in (b"P1: established", b"P1: timeout during data phase"):
            if key in data and key not in times:
                times[key] = emu.now
    emu.boot(each_ms=pump)
    t0 = emu.now
    for _ in range(2000):
        emu.step()
        pump()
    est, out_t = times[b"P1: established"], times[b"P1: timeout during data phase"]
    grace = emu.profile.feature("matrix_power_grace_ms")
    assert est < t0 and grace + 500 < out_t - est <= grace + 500 + 110
    assert out_t - t0 < grace          # within the scenario's first second, not grace + 500 ms into it
