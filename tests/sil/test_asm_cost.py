"""Software float charged per basic block (sil/asm_cost.py): each block's clock call (the compiler's
``__sanitizer_cov_trace_pc``) counts the float instructions up to the next one; blocks without any
keep the plain call. Assembly written for this test (x86-64, AT&T syntax)."""
from __future__ import annotations

from buildhat_conformance.sil.asm_cost import MAX_FP_PER_BLOCK, charge_soft_float

ASM = """\
f:
\tcall\t__sanitizer_cov_trace_pc@PLT
\tmovss\t(%rdi), %xmm0
\tmulss\t%xmm1, %xmm0
\taddss\t%xmm2, %xmm0
\tcvttss2si\t%xmm0, %eax
\tcall\t__sanitizer_cov_trace_pc@PLT
\taddl\t$1, %eax
\tret
"""


def test_a_float_block_charges_its_float_operations_and_an_integer_block_nothing():
    out, changed = charge_soft_float(ASM)
    lines = out.splitlines()
    # mulss, addss, cvttss2si: three (movss moves, it computes nothing); addl is integer.
    assert lines[1] == "\tcall\t__sil_cov_fp3@PLT"
    assert lines[6] == "\tcall\t__sanitizer_cov_trace_pc@PLT"
    assert changed == 1
    assert [ln for i, ln in enumerate(lines) if i not in (1,)] == [ln for i, ln in enumerate(ASM.splitlines())
                                                                  if i not in (1,)]


def test_a_block_with_very_many_float_operations_is_capped():
    block = "\tcall\t__sanitizer_cov_trace_pc\n" + "\tmulsd\t%xmm1, %xmm0\n" * (MAX_FP_PER_BLOCK + 5)
    out, changed = charge_soft_float(block)
    assert out.splitlines()[0] == f"\tcall\t__sil_cov_fp{MAX_FP_PER_BLOCK}" and changed == 1
