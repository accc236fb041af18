"""The runner's corrections of rp2040js, each checked by a program of the test's own (Thumb code,
assembled bytes below with their source) against the chip's documented behaviour, and shown to be a
correction: with rp2040js's own model the same program reads something else.

The PL011 with its FIFOs off (ARM PL011 TRM, UARTTXINTR; RP2040 datasheet 4.2): one holding register
in front of the shift register. A byte written while the transmitter is idle moves on into the shift
register at once, so the holding register is empty and the transmit interrupt is raised; a write
clears it, and so does the interrupt-clear register (UARTICR), after which it stays clear until the
holding register empties again, which happens when the byte before it has left the wire.
"""
from __future__ import annotations

import shutil
import subprocess

import pytest
from rp2040_support import start_program

from buildhat_conformance.sil.frames import encode

UART_PROGRAM_SOURCE = """
    ldr  r0, =0x40034000   @ UART0
    movs r1, #67           @ 115200 baud from 125 MHz: IBRD 67, FBRD 52
    str  r1, [r0, #0x24]
    movs r1, #52
    str  r1, [r0, #0x28]
    movs r1, #0x60         @ LCR_H: 8 bits, FIFOs off
    str  r1, [r0, #0x2c]
    ldr  r1, =0x301        @ CR: UARTEN, TXE, RXE
    str  r1, [r0, #0x30]
    movs r1, #0x20         @ IMSC: the transmit interrupt
    str  r1, [r0, #0x38]
    movs r1, #0x20
    str  r1, [r0, #0x44]   @ ICR: start clear
    movs r1, #0x41
    str  r1, [r0, #0]      @ 'A' goes straight into the shift register
    ldr  r2, [r0, #0x3c]   @ RIS: the holding register emptied: TX raised (0x20)
    movs r1, #0x42
    str  r1, [r0, #0]      @ 'B' waits in the holding register: the write clears TX
    ldr  r3, [r0, #0x3c]   @ RIS: 0x00
    ldr  r4, [r0, #0x18]   @ FR: TXFF 0x20 | RXFE 0x10 | BUSY 0x08 = 0x38
1:  ldr  r5, [r0, #0x3c]   @ wait for TX: 'A' has left the wire, 'B' moved on
    cmp  r5, #0
    beq  1b
    movs r1, #0x20
    str  r1, [r0, #0x44]   @ ICR clears it
    ldr  r6, [r0, #0x3c]   @ RIS: 0x00
    str  r2, [r0, #0]      @ then report: r2 r3 r4 r6, each as one byte on the wire,
    bl   wait              @ each written when TX rises again
    str  r3, [r0, #0]
    bl   wait
    str  r4, [r0, #0]
    bl   wait
    str  r6, [r0, #0]
2:  b    2b
wait:
    ldr  r5, [r0, #0x3c]
    cmp  r5, #0
    beq  wait
    bx   lr
    .ltorg
"""
UART_PROGRAM = bytes.fromhex(
    "144843214162342181626021c16212490163202181632021416441210160c26b42210160c36b8469c56b002dfcd0"
    "20214164c66b026000f008f8036000f005f8046000f002f80660fee7c56b002dfcd0704700000040034001030000")
# The NVIC (ARMv6-M ARM B3.4.1; RP2040 datasheet 2.3.2): taking an interrupt clears its pending bit,
# so an interrupt pended once from software (NVIC_ISPR, as the firmware starts sending) runs its
# handler once while the peripheral's own line is low.
# UART0 at 115200 baud from 125 MHz (IBRD 67, FBRD 52), 8 bits, FIFOs off, enabled; r0 keeps its base.
UART0_SETUP = """
    ldr  r0, =0x40034000
    movs r1, #67
    str  r1, [r0, #0x24]
    movs r1, #52
    str  r1, [r0, #0x28]
    movs r1, #0x60
    str  r1, [r0, #0x2c]
    ldr  r1, =0x301
    str  r1, [r0, #0x30]
"""
NVIC_PROGRAM_SOURCE = UART0_SETUP + """
    ldr  r2, =0x20001000   @ a vector table of our own
    adr  r1, handler
    adds r1, #1            @ (Thumb)
    movs r6, #144          @ entry 16 + 20: UART0_IRQ
    str  r1, [r2, r6]
    ldr  r3, =0xe000ed08   @ VTOR
    str  r2, [r3]
    movs r7, #0            @ the handler counts its entries in r7
    ldr  r1, =0x100000     @ IRQ 20
    ldr  r3, =0xe000e100   @ NVIC_ISER: enable it (the UART's own line stays low: IMSC is 0)
    str  r1, [r3]
    ldr  r3, =0xe000e200   @ NVIC_ISPR: pend it from software, once
    str  r1, [r3]
    movs r4, #0            @ then spin 1000 times
    ldr  r5, =1000
1:  adds r4, #1
    cmp  r4, r5
    bne  1b
    str  r7, [r0, #0]      @ report the count: 1
2:  b    2b
    .balign 4
handler:
    adds r7, #1
    bx   lr
    .ltorg
"""
NVIC_PROGRAM = bytes.fromhex(
    "0f4843214162342181626021c1620d4901630d4a09a10131902691510b4b1a6000270b490b4b19600b4b196000240b4d"
    "0134ac42fcd10760fee7c0460137704700400340010300000010002008ed00e00000100000e100e000e200e0e8030000")
# Bytes from the host arrive one by one at the baud rate, a later burst as well as the first.
ECHO_PROGRAM_SOURCE = UART0_SETUP + """
1:  ldr  r1, [r0, #0x18]   @ FR: wait while RX is empty (RXFE, bit 4)
    lsls r1, r1, #27
    bmi  1b
    ldr  r1, [r0, #0]      @ echo what came
    str  r1, [r0, #0]
    b    1b
    .ltorg
"""
ECHO_PROGRAM = bytes.fromhex(
    "074843214162342181626021c162054901638169c906fcd401680160f9e700000040034001030000")
PROGRAMS = [(UART_PROGRAM_SOURCE, UART_PROGRAM), (NVIC_PROGRAM_SOURCE, NVIC_PROGRAM),
            (ECHO_PROGRAM_SOURCE, ECHO_PROGRAM)]
BYTE_NS = 10 * 1_000_000_000 // 115200        # one byte of 10 bits at 115200 baud, ~86.8 us


def host_bytes(tmp_path, program: bytes, run_ns: int, args=()) -> list:
    chip = start_program(tmp_path, program, args)
    try:
        frames = chip.run(run_ns)
    finally:
        chip.quit()
    return [(f.t, b) for f in frames if f.kind == "h" for b in f.payload]


@pytest.mark.parametrize("source,program", PROGRAMS, ids=["uart", "nvic", "echo"])
def test_the_program_is_its_source(source, program):
    if shutil.which("llvm-mc") is None or shutil.which("llvm-objcopy") is None:
        pytest.skip("llvm-mc/llvm-objcopy not installed: the bytes are not re-assembled")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        src = f"{tmp}/p.s"
        with open(src, "w") as fh:
            fh.write("    .syntax unified\n    .thumb\n" + source)
        subprocess.run(["llvm-mc", "--triple=thumbv6m-none-eabi", "-filetype=obj", src, "-o", f"{tmp}/p.o"],
                       check=True)
        subprocess.run(["llvm-objcopy", "-O", "binary", "-j", ".text", f"{tmp}/p.o", f"{tmp}/p.bin"],
                       check=True)
        with open(f"{tmp}/p.bin", "rb") as fh:
            assert fh.read() == program


def test_pl011_transmit_interrupt_follows_the_holding_register(tmp_path):
    sent = host_bytes(tmp_path, UART_PROGRAM, 2_000_000)
    assert [b for _t, b in sent] == [0x41, 0x42, 0x20, 0x00, 0x38, 0x00]
    # one byte after the other on the wire, each 10 bit times long: the last leaves six byte times
    # after the first was written (the few instructions before it take microseconds)
    end = sent[-1][0]
    assert 6 * BYTE_NS <= end < 6 * BYTE_NS + 20_000, end


def test_rp2040js_own_pl011_reads_otherwise(tmp_path):
    """Without the correction the interrupt stays raised after the clear, and the transmitter is never
    busy (what made the firmware's handler run forever)."""
    sent = host_bytes(tmp_path, UART_PROGRAM, 2_000_000, ["--stock-uart"])
    assert [b for _t, b in sent] != [0x41, 0x42, 0x20, 0x00, 0x38, 0x00]
    assert [b for _t, b in sent][3] == 0x20          # RIS after the clear: still raised


def test_nvic_a_software_pend_enters_the_handler_once(tmp_path):
    sent = host_bytes(tmp_path, NVIC_PROGRAM, 1_000_000)
    assert [b for _t, b in sent] == [1]


def test_rp2040js_own_nvic_enters_it_forever(tmp_path):
    """rp2040js keeps the hardware interrupt pending: the handler runs again and again, the spin
    never ends and nothing is reported."""
    sent = host_bytes(tmp_path, NVIC_PROGRAM, 1_000_000, ["--stock-nvic"])
    assert sent == []


def test_host_bytes_arrive_at_the_baud_rate_in_every_burst(tmp_path):
    chip = start_program(tmp_path, ECHO_PROGRAM)
    try:
        echoed = b""
        for burst in (b"ab", b"cd"):
            chip.send(encode("H", chip.now, burst))
            start = chip.now
            frames = chip.run(chip.now + 1_000_000)
            got = b"".join(f.payload for f in frames if f.kind == "h")
            assert got == burst
            last = max(f.t for f in frames if f.kind == "h")
            # two bytes in, each 10 bit times; the echo of the second leaves one byte time later
            assert 3 * BYTE_NS <= last - start < 3 * BYTE_NS + 20_000, last - start
            echoed += got
        assert echoed == b"abcd"
    finally:
        chip.quit()


def crash_of(tmp_path, program: bytes) -> str:
    """The summary of the crash ``program`` ends in (a crashed firmware in the loop's)."""
    from buildhat_conformance.sil.process import FirmwareDied
    chip = start_program(tmp_path, program)
    try:
        with pytest.raises(FirmwareDied) as died:
            chip.run(1_000_000)
    finally:
        chip.kill()
    assert died.value.kind == "crashed"
    # The same line is the finding a run keeps (a case fails with it and the run goes on:
    # conformance/plugin/firmware_findings.py), named by the signal the runner ends by.
    finding = died.value.findings[-1]
    assert finding.fatal and finding.kind == "SIGABRT" and finding.first == died.value.summary
    assert chip.take_reports() == [finding]
    return died.value.summary


def test_a_core_that_stops_is_a_crash_with_one_line(tmp_path):
    """A breakpoint (the SDK's panic ends in one) ends the chip as a crashed firmware in the loop ends."""
    summary = crash_of(tmp_path, bytes.fromhex("00bf00be"))        # nop; bkpt #0
    assert "the core stopped at a breakpoint (BKPT/UDF #0) at PC 0x20000002" in summary


def test_skipping_idle_polling_changes_nothing_the_world_sees():
    """R7's start-up and a `list` after it: the same bytes, the start-up at the same virtual times,
    whether the runner skips the firmware's idle polling or runs every instruction of it."""
    from rp2040_support import image_wheels, start_image

    from buildhat_conformance.protocol.profiles import get_profile
    from buildhat_conformance.rp2040.images import find_image
    image = find_image("R7", str(image_wheels("R7"))).path
    assert find_image("R7", str(image_wheels("R7"))).release == get_profile("R7").number

    def output(args):
        chip = start_image(image, args)
        try:
            for port in range(4):        # empty ports (sil/port_world.py's ID lines for nothing), Vin
                chip.send(encode("I", 0, b"\xc0\x0c\x01", port=port))
            chip.send(encode("A", 0, b"\xce\x06"))
            sent, asked = [], False
            while chip.now < 320_000_000:
                if chip.now >= 250_000_000 and not asked:
                    chip.send(encode("H", chip.now, b"list\r"))
                    asked = True
                sent += [(f.t, f.payload) for f in chip.run(min(chip.now + 50_000_000, 320_000_000))
                         if f.kind == "h"]
            return sent
        finally:
            chip.quit()

    skipped, every = output([]), output(["--no-idle-skip"])
    assert b"P3: no device detected\r\n" in b"".join(p for _t, p in skipped)
    assert [p for _t, p in skipped] == [p for _t, p in every]
    start_up = [f for f in every if f[0] < 250_000_000]
    assert skipped[:len(start_up)] == start_up
    # A byte from the host meets the polling loop where a skip left it (at a timer read), not where
    # the loop happened to be: the answer may move by less than one pass of the loop (~1,000
    # instructions, 8 us).
    assert all(abs(a[0] - b[0]) < 8_000 for a, b in zip(skipped, every))


def test_an_access_where_nothing_answers_is_a_hardfault(tmp_path):
    """On the chip a load from an address with nothing behind it is a bus fault (a HardFault); rp2040js
    reads 0xffffffff and goes on, so the runner ends the chip as a crash instead."""
    # movs r0, #3; lsls r0, r0, #28 (0x30000000: nothing there); ldr r1, [r0]; b .
    summary = crash_of(tmp_path, bytes.fromhex("03200007016800bffee7"))
    assert "HardFault: a bus fault" in summary and "30000000" in summary
