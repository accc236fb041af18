"""The stand-in's command-port UART keeps an interrupt that is raised while its handler runs
(time moves inside a handler, as on the chip): a byte sent or received meanwhile is not lost.

A handler entered while a byte is on the wire finds the transmitter busy and sends nothing; if
that byte finishes before the handler returns, the PL011 raises its TX interrupt again and the
next byte goes out. The stand-in used to clear that interrupt at the handler's exit, so the rest
of the TX ring waited for the firmware's next output: the real firmware's ``list`` stopped after
``P0: con`` for 3 s of HAT time and the suite called a healthy HAT garbled.

Likewise a byte that arrives while the handler that read the previous one still runs waits in the
receive holding register (the handler has read it empty); it was dropped as an overrun.

The programs here are the test's own (not a Build HAT firmware): a message sent byte by byte
from the UART interrupt, and received bytes sent back, each with a handler that stays longer
than one byte takes on the wire (86.8 us at 115200)."""
import shutil

import pytest

from buildhat_conformance.sil.build import build_tree
from buildhat_conformance.sil.hat import SilHat

pytestmark = pytest.mark.timeout(300)

MESSAGE = "0123456789abcdef\r\n"

def _sender(wait_before: str = "", wait_after: str = "", enter_again: str = "") -> str:
    """The test's program for the stand-in's command-port UART: its interrupt handler sends
    :data:`MESSAGE` a byte at a time, with C statements of its own before or after each byte."""
    message = MESSAGE.replace("\r", "\\r").replace("\n", "\\n")
    return (SENDER.replace("@MESSAGE@", message).replace("@BEFORE@", wait_before)
            .replace("@AFTER@", wait_after).replace("@AGAIN@", enter_again))


SENDER = r"""
/* The test's program for the stand-in's command-port UART. */
#include "pico/stdlib.h"
#include "hardware/irq.h"
#include "hardware/uart.h"

static const char message[] = "@MESSAGE@";
static volatile unsigned sent;

static void on_uart(void) {
    uart_hw_t *hw = uart_get_hw(uart0);
    if (hw->fr & 0x80) {                       /* room to send */
        @BEFORE@
        if (message[sent]) hw->dr = (uint8_t)message[sent++];
        else hw->icr = 0x20;
    }
    @AFTER@
}

int main(void) {
    uart_init(uart0, 115200);
    uart_set_fifo_enabled(uart0, false);
    irq_set_exclusive_handler(UART0_IRQ, on_uart);
    uart_get_hw(uart0)->imsc = 0x20;
    irq_set_enabled(UART0_IRQ, true);
    irq_set_pending(UART0_IRQ);                /* the first byte starts */
    @AGAIN@
    for (;;) sleep_ms(1);
}
"""

# A handler that spins after each byte for longer than a byte takes on the wire at 115200 (86.8 us),
# and is entered again while the first is on the wire.
SPINS_AFTER = "for (volatile int spin = 0; spin < 4000; spin++) { }"
ENTERED_AGAIN = "irq_set_pending(UART0_IRQ);"


ECHO = r"""
/* The test's program for the stand-in's command-port UART: what arrives is sent back. */
#include "pico/stdlib.h"
#include "hardware/irq.h"
#include "hardware/uart.h"

static volatile char kept[64];
static volatile unsigned received, sent, first = 1;

static void on_uart(void) {
    uart_hw_t *hw = uart_get_hw(uart0);
    unsigned flags = hw->fr;
    if (flags & 0x80) {                        /* room to send */
        if (sent < received) hw->dr = (uint8_t)kept[sent++];
        else hw->icr = 0x20;
    }
    if (!(flags & 0x10)) {                     /* a byte to read */
        char c = (char)hw->dr;
        if (received < sizeof kept) kept[received++] = c;
        if (first) {
            first = 0;
            busy_wait_us(130);                 /* the next byte arrives meanwhile */
        }
    }
}

int main(void) {
    uart_init(uart0, 115200);
    uart_set_fifo_enabled(uart0, false);
    irq_set_exclusive_handler(UART0_IRQ, on_uart);
    uart_get_hw(uart0)->imsc = 0x30;
    irq_set_enabled(UART0_IRQ, true);
    for (;;) {
        sleep_ms(1);
        if (sent < received) irq_set_pending(UART0_IRQ);
    }
}
"""


def _program(tmp_path, source: str) -> SilHat:
    if not (shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")):
        pytest.skip("no C compiler on this machine")
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "main.c").write_text(source)
    build = build_tree(str(tree), cache=tmp_path / "cache")
    return SilHat(str(build.program))


def test_a_byte_that_ends_inside_the_handler_raises_the_tx_interrupt_again(tmp_path):
    hat = _program(tmp_path, _sender(wait_after=SPINS_AFTER, enter_again=ENTERED_AGAIN))
    try:
        hat.advance(20)              # 18 bytes take 1.6 ms on the wire (the handler's spins more)
        assert hat.read() == MESSAGE.encode()
    finally:
        hat.close()


def test_a_byte_that_arrives_inside_the_handler_is_read_after_it(tmp_path):
    hat = _program(tmp_path, ECHO)
    try:
        hat.advance(2)
        hat.write(b"abcdef")
        hat.advance(20)
        assert hat.read() == b"abcdef"
    finally:
        hat.close()


# A handler that takes its time before it sends the next byte of its ring: a stop of the firmware
# (a world action due, a device's message out) may come while it runs.
WAITS_BEFORE = "busy_wait_us(300);"


def test_the_port_is_not_at_rest_while_a_handler_that_may_send_runs(tmp_path):
    """The sil liveness of seed 22 (342 runs against emulator): a fuzz pause ended 32 ms into a
    step whose `help` had filled the ring, and the fence's answer was cut. The stand-in said the
    port was at rest at a stop that came inside the UART handler, after it took the interrupt
    and before it wrote the next byte: nothing on the wire, no interrupt pending, yet the ring
    full. Stopped every 13 us, the port must not say so until the whole message has gone."""
    hat = _program(tmp_path, _sender(wait_before=WAITS_BEFORE))
    try:
        proc = hat.proc
        assert proc is not None
        out = b""
        quiet_inside = []
        for _ in range(3000):                 # 39 ms; 18 bytes take 18 x (300 + 87) us
            frames = proc.run(proc.now + 13_000, [], yield_on_host_idle=False)
            out += b"".join(f.payload for f in frames if f.kind == "h")
            if out and len(out) < len(MESSAGE) and proc.host_quiet:
                quiet_inside.append((proc.now, len(out)))
        assert out == MESSAGE.encode()
        assert not quiet_inside, f"at rest with the message half sent: {quiet_inside[:5]}"
        assert proc.host_quiet                # and at rest once it has gone
    finally:
        hat.close()


def _booted_firmware_hat() -> SilHat:
    from sil_support import firmware_tree
    hat = SilHat(str(build_tree(str(firmware_tree())).program))
    hat.boot()
    hat.read()
    return hat


def test_settle_ends_when_the_answer_has_left_the_ring():
    """`help` prints about 3 KB, some 270 ms on a 115200-baud wire. settle() lets HAT time pass
    until the command port is at rest: the whole answer has come, in whole ms, and well before
    the bound (a fuzz pause reckons the most a step may print)."""
    hat = _booted_firmware_hat()
    try:
        hat.write(b"help\r")
        start = hat.now
        waited = hat.settle(5, 5000)
        out = hat.read()
        assert hat.now - start == waited
        wire_ms = len(out) / 11.52
        assert len(out) > 2000, out[-200:]
        assert out.rstrip(b"\r\n").endswith(b"32=unknown messages"), out[-200:]
        assert wire_ms <= waited < wire_ms + 50, (waited, wire_ms)
        hat.advance(200)
        assert hat.read() == b"", "output came after settle() said the port was at rest"
    finally:
        hat.close()


def test_settle_waits_at_least_for_the_input_and_at_most_the_bound():
    hat = _booted_firmware_hat()
    try:
        start = hat.now
        assert hat.settle(7, 500) == 7 and hat.now - start == 7       # nothing to send: at rest
        hat.write(b"echo 0 ; " * 40 + b"\r")                          # 360 bytes: 31 ms of input
        start = hat.now
        waited = hat.settle(1, 500)
        assert 31 <= waited < 60, waited                              # not at rest while input arrives
        hat.write(b"help ; help ; help\r")                               # a full ring: 700 ms to drain
        assert hat.settle(5, 300) == 300
    finally:
        hat.close()


def test_a_chip_started_later_prints_later_by_as_much():
    """BUILDHAT_SIL_START_NS (sil mutate's phase controls): the program starts that many ns after
    power-on, so its first output comes that much later on the world's clock."""
    import os

    from sil_support import firmware_tree

    from buildhat_conformance.sil.process import FirmwareProcess
    program = str(build_tree(str(firmware_tree())).program)
    firsts = []
    for start_ns in (0, 250_000):
        proc = FirmwareProcess(program, env=dict(os.environ, BUILDHAT_SIL_START_NS=str(start_ns)))
        try:
            frames = proc.run(50_000_000)                     # 50 ms: the banner is out
            firsts.append(next(f.t for f in frames if f.kind == "h"))
        finally:
            proc.quit()
    assert firsts[1] - firsts[0] == 250_000, firsts
