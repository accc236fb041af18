"""The sanitized firmware is the firmware (issue 34, item 2): what the plain build reproduces from
the chip holds in the ``--sanitize`` build too. Both builds of the R7 tree print the same bytes for
the same script, and `list` shows a negative range limit as the chip does
(docs/FIRMWARE-BEHAVIOUR.md#fb-list-ranges: 00000000, never the two's complement); plain `char`
is unsigned in both builds' flags (ARM EABI), checked by compiling with them."""
import json
import subprocess

import pytest
from sil_support import cli, firmware_tree

from buildhat_conformance.sil.build import SANITIZERS, _flags, find_compiler

pytestmark = pytest.mark.timeout(600)

BUILDS = {"plain": "", "sanitized": "?sanitize=address,undefined"}
# A SPIKE motor (0x30): its SPEED and POWER modes range over -100..100 (protocol/devices).
SCRIPT = "@device 0 0x30\n@device 1 0x3E\n@device 2 passive 8\n@device 3 none\n> list\n@wait 400\n"


@pytest.fixture(scope="module")
def listings(tmp_path_factory):
    cache = tmp_path_factory.mktemp("silcache")
    folder = tmp_path_factory.mktemp("list")
    script = folder / "list.script"
    script.write_text(SCRIPT)
    out = {}
    for name, options in BUILDS.items():
        transcript = folder / f"{name}.jsonl"
        target = f"sil:{firmware_tree()}{options}"
        done = cli("script", str(script), "--target", target, "-o", str(transcript), cache=cache)
        assert done.returncode == 0, done.stderr
        rows = [json.loads(line) for line in transcript.read_text().splitlines()]
        out[name] = "".join(r["partial"] if "partial" in r else r["line"] + "\n"
                            for r in rows if r.get("dir") == "hat")
    return out


def test_both_builds_print_the_same_bytes(listings):
    assert "    RAW: " in listings["plain"]
    assert listings["sanitized"] == listings["plain"]


@pytest.mark.parametrize("build", list(BUILDS))
def test_a_negative_range_limit_lists_as_00000000(listings, build):
    raw = [line.split()[1:3] for line in listings[build].splitlines() if line.startswith("    RAW: ")]
    # -100 as an unsigned 32-bit integer would be FFFFFF9C; the chip saturates it to 0.
    assert ["00000000", "00000064"] in raw, raw
    assert not any(word.startswith("FFFFFF") for pair in raw for word in pair), raw


@pytest.mark.parametrize("sanitize", [(), SANITIZERS], ids=["plain", "sanitized"])
def test_plain_char_is_unsigned_in_both_builds(tmp_path, sanitize):
    firmware_flags, _standin, link = _flags(sanitize, False)
    src = tmp_path / "char.c"
    # (the stand-in's clock hook, which the firmware's flags call at every block)
    src.write_text('#include <stdio.h>\nvoid __sanitizer_cov_trace_pc(void) {}\n'
                   'volatile char c = (char)0xC8;\nint main(void) { printf("%d\\n", c > 0); return 0; }\n')
    exe = tmp_path / "char"
    flags = [f for f in firmware_flags if f != "-fsanitize-coverage=trace-pc"]
    subprocess.run([find_compiler(), *flags, str(src), "-o", str(exe), *link], check=True)
    assert subprocess.run([str(exe)], capture_output=True, text=True, check=True).stdout == "1\n"
