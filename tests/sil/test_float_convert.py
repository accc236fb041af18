"""sil/float_convert.py: the host build's float-to-integer conversions behave as the RP2040's.

The chip's conversions saturate (docs/FIRMWARE-BEHAVIOUR.md#fb-list-ranges: a negative
range prints as 00000000);
x86's do not. A small C program is compiled, its assembly rewritten, assembled and run; each
result must follow the chip's rule, computed here from the rule itself."""
import shutil
import struct
import subprocess

import pytest

from buildhat_conformance.sil.float_convert import rewrite_conversions

CC = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
pytestmark = pytest.mark.skipif(CC is None, reason="no C compiler on this machine")


def cc() -> str:
    assert CC is not None               # the skipif above
    return CC

VALUES = [-100.0, -0.5, 0.0, 3.7, 99.99, 2147483520.0, 3e9, 4294967040.0, 5e9, 1e20, -1e20, -3.7]

PROGRAM = r"""
#include <stdio.h>
struct box { float f; double d; };
unsigned to_u(float f) { return (unsigned)f; }
int to_i(float f) { return (int)f; }
unsigned d_to_u(double d) { return (unsigned)d; }
int d_to_i(double d) { return (int)d; }
unsigned mem_u(const struct box *b) { return (unsigned)b->f; }
int mem_i(const struct box *b) { return (int)b->f; }
volatile double in[] = {%s};
int main(void) {
    for (unsigned k = 0; k < sizeof in / sizeof in[0]; k++) {
        struct box b = {(float)in[k], in[k]};
        printf("%%u %%d %%u %%d %%u %%d\n", to_u(b.f), to_i(b.f), d_to_u(b.d), d_to_i(b.d),
               mem_u(&b), mem_i(&b));
    }
    return 0;
}
"""


def chip_u32(x: float) -> int:
    if x != x or x <= -1.0:
        return 0
    return min(int(x), 0xFFFFFFFF) if x > 0 else 0


def chip_i32(x: float) -> int:
    return max(-(2 ** 31), min(2 ** 31 - 1, int(x)))


@pytest.mark.parametrize("opt", ["-O0", "-O1", "-O2"])
def test_rewritten_conversions_saturate_like_the_chip(tmp_path, opt):
    src = tmp_path / "conv.c"
    src.write_text(PROGRAM % ", ".join(repr(v) for v in VALUES))
    asm = tmp_path / "conv.s"
    subprocess.run([cc(), opt, "-mno-red-zone", "-S", str(src), "-o", str(asm)], check=True)
    text, count = rewrite_conversions(asm.read_text(), "t")
    assert count >= 6, "the program's conversions were not all found"
    asm.write_text(text)
    exe = tmp_path / "conv"
    subprocess.run([cc(), str(asm), "-o", str(exe)], check=True)
    rows = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split("\n")
    for value, row in zip(VALUES, rows):
        f = float(value)
        f32 = struct.unpack("<f", struct.pack("<f", value))[0]     # what the float variable holds
        got = [int(x) for x in row.split()]
        want = [chip_u32(f32), chip_i32(f32), chip_u32(f), chip_i32(f), chip_u32(f32), chip_i32(f32)]
        assert got == want, f"{value}: got {got}, the chip gives {want}"


def test_unrewritten_host_code_differs_so_the_test_can_fail(tmp_path):
    src = tmp_path / "conv.c"
    src.write_text(PROGRAM % "-100.0")
    exe = tmp_path / "conv"
    subprocess.run([cc(), "-O1", str(src), "-o", str(exe)], check=True)
    row = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    assert int(row[0]) != chip_u32(-100.0)


INDEXED = r"""
#include <stdio.h>
struct mode { char name[12]; float low, high; };
struct mode modes[4];
volatile int which = 2;
void shown(unsigned low, unsigned high) { printf("%%u %%u\n", low, high); }
int main(void) {
    modes[which].low = %sf;
    modes[which].high = 100.0f;
    shown(modes[which].low, modes[which].high);
    return 0;
}
"""


SANITIZED = ["-O1", "-fsanitize=address,undefined", "-fsanitize-recover=all"]


@pytest.mark.parametrize("flags", [["-O1"], SANITIZED], ids=["plain", "sanitized"])
@pytest.mark.parametrize("low", [-100.0, 3e9, 5e9])
def test_a_conversion_read_through_an_index_saturates_in_both_builds(tmp_path, flags, low):
    """What `list` does with a mode's range (docs/FIRMWARE-BEHAVIOUR.md#fb-list-ranges): the
    sanitized build addresses the array through a register (``172(%rbx,%rax)``), which the pass
    must read too, or the sanitized firmware prints FFFFFF9C where the chip prints 00000000."""
    src = tmp_path / "modes.c"
    src.write_text(INDEXED % repr(low))
    asm = tmp_path / "modes.s"
    subprocess.run([cc(), *flags, "-mno-red-zone", "-S", str(src), "-o", str(asm)], check=True)
    text, count = rewrite_conversions(asm.read_text(), "t")
    assert count >= 2, "the program's conversions were not all found"
    asm.write_text(text)
    exe = tmp_path / "modes"
    subprocess.run([cc(), *flags, str(asm), "-o", str(exe)], check=True)
    got = subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout.split()
    f32 = struct.unpack("<f", struct.pack("<f", low))[0]
    assert [int(x) for x in got] == [chip_u32(f32), 100]
