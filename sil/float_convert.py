"""Float-to-integer conversions as the RP2040 does them, in the host build's assembly.

The firmware runs on a Cortex-M0+ whose float routines *saturate*: a negative float converted
to an unsigned integer gives 0, a value past the range gives the largest value
(docs/FIRMWARE-BEHAVIOUR.md#fb-list-ranges: `list` prints a negative range as 00000000).
x86-64's truncating conversions do not: a negative float becomes its two's complement, an
out-of-range one 0x80000000. The firmware's C
is compiled unchanged; this pass rewrites the compiler's output instead, after each
``cvttss2si``/``cvttsd2si`` (float/double to integer):

- to a 64-bit register: on the chip's 32-bit ABI this is a conversion to ``unsigned int``, so
  the result is clamped to 0..0xFFFFFFFF (negative -> 0, too large -> 0xFFFFFFFF);
- to a 32-bit register: a conversion to ``int``; x86's "indefinite" 0x80000000 becomes
  0x7FFFFFFF when the value was positive.

The added code keeps every register but the destination and the flags (pushfq/popfq; the
firmware is compiled with -mno-red-zone so pushing is safe). The tests in
tests/sil/test_float_convert.py check it against the chip's rules.
"""
from __future__ import annotations

import re
from typing import List, Tuple

__all__ = ["rewrite_conversions"]

# The source may be a memory operand with an index (``172(%rbx,%rax)``, as a sanitized build
# addresses arrays): everything up to the last comma.
_CVT = re.compile(r"^(\s*)cvtt(ss|sd)2si([lq]?)\s+(.+),\s*%(\w+)\s*$")
_REG32 = {"rax": "eax", "rbx": "ebx", "rcx": "ecx", "rdx": "edx", "rsi": "esi", "rdi": "edi",
          "rbp": "ebp", "rsp": "esp", **{f"r{i}": f"r{i}d" for i in range(8, 16)}}
_MEM = re.compile(r"^(-?\d*)\((%\w+)(.*)\)$")


def _sign_test(src: str, double: bool, pushed: int) -> str:
    """An instruction that sets ZF when the source value's sign bit is clear (memory source)."""
    m = _MEM.match(src.strip())
    if not m:
        raise ValueError(f"cannot read the sign of {src!r}")
    disp = int(m.group(1) or "0") + (7 if double else 3)
    if m.group(2) == "%rsp":
        disp += pushed
    return f"testb $0x80, {disp}({m.group(2)}{m.group(3)})"


def _expand(indent: str, line: str, kind: str, width: str, src: str, dst: str, label: str) -> List[str]:
    double = kind == "sd"
    is_reg = src.strip().startswith("%xmm")
    if dst in _REG32:                       # a 64-bit destination: unsigned int on the chip
        d32 = _REG32.get(dst, dst)
        out = [line, "pushfq", f"testq %{dst}, %{dst}", f"jns {label}p"]
        if is_reg:
            out += [f"movmskp{'d' if double else 's'} {src.strip()}, %{d32}", f"andl $1, %{d32}",
                    f"decl %{d32}"]
        else:
            out += [f"movl $0, %{d32}", _sign_test(src, double, 8), f"jnz {label}e", f"movl $-1, %{d32}"]
        out += [f"jmp {label}e", f"{label}p:", f"pushq %{dst}", f"shrq $32, %{dst}", f"popq %{dst}",
                f"jz {label}e", f"movl $-1, %{d32}", f"{label}e:", "popfq"]
    else:
        out = [line, "pushfq", f"cmpl $-2147483648, %{dst}", f"jne {label}e"]
        if is_reg:
            out += [f"movmskp{'d' if double else 's'} {src.strip()}, %{dst}", f"andl $1, %{dst}",
                    f"decl %{dst}", f"xorl $-2147483648, %{dst}"]
        else:
            out += [_sign_test(src, double, 8), f"jnz {label}e", f"movl $2147483647, %{dst}"]
        out += [f"{label}e:", "popfq"]
    return [out[0]] + [f"{indent}{x}" if not x.endswith(":") else x for x in out[1:]]


def rewrite_conversions(asm: str, tag: str = "f") -> Tuple[str, int]:
    """``asm`` with every float-to-integer conversion made saturating; and how many there were."""
    lines: List[str] = []
    count = 0
    for line in asm.splitlines():
        m = _CVT.match(line)
        if not m:
            lines.append(line)
            continue
        indent, kind, width, src, dst = m.groups()
        lines.extend(_expand(indent or "\t", line, kind, width, src, dst, f".Lsilcvt_{tag}_{count}"))
        count += 1
    return "\n".join(lines) + "\n", count
