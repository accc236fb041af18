"""The stand-in's command-port UART keeps a transmit interrupt that is raised while its handler
runs (time moves inside a handler, as on the chip).

A handler entered while a byte is on the wire finds the transmitter busy and sends nothing; if
that byte finishes before the handler returns, the PL011 raises its TX interrupt again and the
next byte goes out. The stand-in used to clear that interrupt at the handler's exit, so the rest
of the TX ring waited for the firmware's next output: the real firmware's ``list`` stopped after
``P0: con`` for 3 s of HAT time and the suite called a healthy HAT garbled.

The program here is the test's own (not a Build HAT firmware): a message sent byte by byte from
the UART interrupt, whose handler stays longer than one byte takes on the wire."""
import shutil

import pytest

from buildhat_conformance.sil.build import build_tree
from buildhat_conformance.sil.hat import SilHat

pytestmark = pytest.mark.timeout(300)

MESSAGE = "0123456789abcdef\r\n"

PROGRAM = r"""
/* The test's program for the stand-in's command-port UART. */
#include "pico/stdlib.h"
#include "hardware/irq.h"
#include "hardware/uart.h"

static const char message[] = "%s";
static volatile unsigned sent;

static void on_uart(void) {
    uart_hw_t *hw = uart_get_hw(uart0);
    if (hw->fr & 0x80) {                       /* room to send */
        if (message[sent]) hw->dr = (uint8_t)message[sent++];
        else hw->icr = 0x20;
    }
    for (volatile int spin = 0; spin < 4000; spin++) {
        /* longer than a byte on the wire at 115200 (86.8 us) */
    }
}

int main(void) {
    uart_init(uart0, 115200);
    uart_set_fifo_enabled(uart0, false);
    irq_set_exclusive_handler(UART0_IRQ, on_uart);
    uart_get_hw(uart0)->imsc = 0x20;
    irq_set_enabled(UART0_IRQ, true);
    irq_set_pending(UART0_IRQ);                /* the first byte starts */
    irq_set_pending(UART0_IRQ);                /* entered again while it is on the wire */
    for (;;) sleep_ms(1);
}
"""


def test_a_byte_that_ends_inside_the_handler_raises_the_tx_interrupt_again(tmp_path):
    if not (shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")):
        pytest.skip("no C compiler on this machine")
    tree = tmp_path / "tree"
    tree.mkdir()
    (tree / "main.c").write_text(PROGRAM % MESSAGE.replace("\r", "\\r").replace("\n", "\\n"))
    build = build_tree(str(tree), cache=tmp_path / "cache")
    hat = SilHat(str(build.program))
    try:
        hat.advance(20)              # 18 bytes take 1.6 ms on the wire (the handler's spins more)
        assert hat.read() == MESSAGE.encode()
    finally:
        hat.close()
