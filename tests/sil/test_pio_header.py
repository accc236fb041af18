"""sil/pio_header.py: a PIO program's header as the stand-in needs it (names, lengths, kinds)."""
from buildhat_conformance.sil.pio_header import (
    KIND_OTHER,
    KIND_UART_RX,
    KIND_UART_TX,
    pio_header,
    pio_programs,
)

# Programs written for this test in the pioasm language: an 8N1 transmitter and receiver of
# our own, and a program that is neither.
TEXT = """
.program tx8n1
.side_set 1 opt
    pull       side 1 [7]   ; wait for a byte
    set x, 7   side 0 [7]
next:
    out pins, 1
    jmp x-- next      [6]

.program rx8n1
begin:
    wait 0 pin 0
    set x, 7    [10]
loop: in pins, 1
    jmp x-- loop [6]
    push

.program blink
    set pins, 1 [31]
    set pins, 0 [31]
% c-sdk {
static inline void helper(void) {}
%}
"""


def test_programs_and_their_lengths():
    progs = pio_programs(TEXT)
    assert list(progs) == ["tx8n1", "rx8n1", "blink"]
    assert [len(v) for v in progs.values()] == [4, 5, 2]


def test_header_tags_each_program_by_its_job(tmp_path):
    f = tmp_path / "progs.pio"
    f.write_text(TEXT)
    header = pio_header(f)
    assert f"tx8n1_program = {{tx8n1_program_instructions, 4, -1, {KIND_UART_TX}}}" in header
    assert f"rx8n1_program = {{rx8n1_program_instructions, 5, -1, {KIND_UART_RX}}}" in header
    assert f"blink_program = {{blink_program_instructions, 2, -1, {KIND_OTHER}}}" in header
    assert "tx8n1_program_get_default_config(uint offset)" in header
