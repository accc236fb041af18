"""What a basic block costs on the chip, where the host is much faster: software floating point.

The RP2040's Cortex-M0+ has no FPU; every float operation is a library routine of tens to
hundreds of cycles, where the host does it in one instruction. The stand-in's clock charges a
fixed time per basic block (standin/machine.c), so float-heavy code (number formatting, the
PID) would run too fast in virtual time, and a long `list` would not stretch its main-loop pass
into the `deltat=` line a real HAT prints (docs/FIRMWARE-BEHAVIOUR.md#fb-stall).

This pass counts the floating-point instructions of each basic block in the compiler's output
(a block begins at the compiler's ``__sanitizer_cov_trace_pc`` call) and, where there are any,
calls ``__sil_cov_fpN`` instead: the same clock tick plus N software-float operations. The
firmware's C is not touched.
"""
from __future__ import annotations

import re
from typing import List, Tuple

__all__ = ["charge_soft_float", "MAX_FP_PER_BLOCK"]

MAX_FP_PER_BLOCK = 16
_COV = re.compile(r"^(\s*)call\s+__sanitizer_cov_trace_pc(@PLT)?\s*$")
_FP = re.compile(r"^\s*(add|sub|mul|div|sqrt|min|max|ucomi|comi|cvtsi2|cvtts|cvtt|cvts)"
                 r"(ss|sd|s2sd|d2ss|i2ss|i2sd|s2si|d2si|s2siq|d2siq|s2sil|d2sil)[lq]?\s")


def charge_soft_float(asm: str) -> Tuple[str, int]:
    """``asm`` with each float-using block's clock call charging its float operations; and how
    many blocks were changed."""
    lines = asm.splitlines()
    out: List[str] = list(lines)
    changed = 0
    calls = [i for i, ln in enumerate(lines) if _COV.match(ln)]
    for n, i in enumerate(calls):
        end = calls[n + 1] if n + 1 < len(calls) else len(lines)
        fp = sum(1 for ln in lines[i + 1:end] if _FP.match(ln))
        if fp:
            m = _COV.match(lines[i])
            assert m is not None
            out[i] = f"{m.group(1)}call\t__sil_cov_fp{min(fp, MAX_FP_PER_BLOCK)}{m.group(2) or ''}"
            changed += 1
    return "\n".join(out) + "\n", changed
