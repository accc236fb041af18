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

from buildhat_conformance.sil.protocol import encode

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
BYTE_NS = 10 * 1_000_000_000 // 115200        # one byte of 10 bits at 115200 baud, ~86.8 us


def host_bytes(tmp_path, program: bytes, run_ns: int, args=()) -> list:
    chip = start_program(tmp_path, program, args)
    try:
        frames = chip.run(run_ns)
    finally:
        chip.quit()
    return [(f.t, b) for f in frames if f.kind == "h" for b in f.payload]


def test_the_program_is_its_source():
    if shutil.which("llvm-mc") is None or shutil.which("llvm-objcopy") is None:
        pytest.skip("llvm-mc/llvm-objcopy not installed: the bytes are not re-assembled")
    import tempfile
    with tempfile.TemporaryDirectory() as tmp:
        src = f"{tmp}/p.s"
        with open(src, "w") as fh:
            fh.write("    .syntax unified\n    .thumb\n" + UART_PROGRAM_SOURCE)
        subprocess.run(["llvm-mc", "--triple=thumbv6m-none-eabi", "-filetype=obj", src, "-o", f"{tmp}/p.o"],
                       check=True)
        subprocess.run(["llvm-objcopy", "-O", "binary", "-j", ".text", f"{tmp}/p.o", f"{tmp}/p.bin"], check=True)
        with open(f"{tmp}/p.bin", "rb") as fh:
            assert fh.read() == UART_PROGRAM


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
