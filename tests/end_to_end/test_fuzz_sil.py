"""Fuzzer findings on the firmware in the loop (``sil:TREE``) that were the fuzzer's own model,
replayed with ``fuzz --reproduce`` as a user would: each must be ``not reproduced`` now. One whose
cause was a pause the fuzzer did not make (a replayed script waits what it says) runs its steps
through the fuzzer's runner instead.

The firmware's command port is a 115200-baud wire in HAT time: input arrives byte by byte while
the firmware prints, as on a real HAT (FIRMWARE-FACTS §1)."""

import pytest
from sil_support import cli, firmware_tree  # noqa: E402

pytestmark = pytest.mark.timeout(900)

PRELUDE = """@device 0 0x30
@device 1 0x40
@device 2 passive 8
@device 3 none
> echo 0
> debug 0
> port 3
> select
> port 2
> select
> port 1
> select
> port 0
> select
> version
@wait 12
"""

# debug 51 (bit 1: the raw serial trace, §7.4) runs until the guard's `debug 0` has crossed the
# wire; the trace lands in the next line's echo. The oracle judges such a step on liveness only.
RAW_TRACE = PRELUDE + """> l
> version
@wait 173
>raw ;list;;echo^\\xB8\\b\\b\\s1;\\r
> version
@wait 175
>  ;comb +0 ; d +51;;por 0;
@wait 147
> version
"""

# selonce reports as soon as the device's data arrives (R5+, §6.2), here before the next line of
# the same input has arrived; the report belongs to the selection after the first line.
SELONCE_RACE = PRELUDE + """> selonc  +1
> select 0; co
@wait 664
> version
"""


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


@pytest.mark.parametrize("oracle, script", [("hygiene", RAW_TRACE), ("state", SELONCE_RACE)],
                         ids=["raw-trace-on-a-wire", "selonce-race"])
def test_a_model_finding_on_the_firmware_is_not_reproduced(cache, tmp_path, oracle, script):
    path = tmp_path / f"{oracle}.script"
    path.write_text(f"@name fuzz finding ({oracle}): on the firmware in the loop\n{script}")
    done = cli("fuzz", "--reproduce", str(path), "--target", f"sil:{firmware_tree()}", "--confirm", "1",
               cache=cache)
    assert done.returncode == 0, done.stdout + done.stderr[-2000:]
    assert done.stdout.startswith("not reproduced (0/1 replays)"), done.stdout


# sil finding (`--against emulator --seed 5`): the firmware listed the motor on port 0, the emulator
# `no device detected`; the emulator process had opened at power-on, the firmware booted.
FIRST_LIST = PRELUDE + """> list
> version
"""


def _differential_not_reproduced(cache, tmp_path, against: str, what: str, script: str) -> None:
    """The finding's script, replayed on the firmware against ``against``, no longer differs."""
    path = tmp_path / "differential.script"
    path.write_text(f"@name fuzz finding (differential): {what}\n{script}")
    done = cli("fuzz", "--reproduce", str(path), "--target", f"sil:{firmware_tree()}", "--against",
               against, "--confirm", "1", cache=cache)
    assert done.returncode == 0, done.stdout + done.stderr[-2000:]
    assert done.stdout.startswith("not reproduced (0/1 replays)"), done.stdout


def test_the_first_list_against_the_emulator_process_agrees(cache, tmp_path):
    _differential_not_reproduced(cache, tmp_path, "emulator", "port 0 listed on one side only", FIRST_LIST)


# sil finding (`--against inprocess --seed 11`): a motor dropped after its selected combi was taken
# away (500 ms without data, fb-active) is set up again in about 2 s on the firmware, 0.8 s on the
# emulator (a model difference); a `list` in between differs by timing alone.
SET_UP_AGAIN = PRELUDE + """> combi 7 1 0 2 0 3 0
> select 7
> version
@wait 200
> combi 7
> select
> version
@wait 1500
> list
> version
"""


def test_a_port_set_up_again_is_not_compared_until_it_is_established(cache, tmp_path):
    _differential_not_reproduced(cache, tmp_path, "inprocess", "port 0 set up again", SET_UP_AGAIN)


def test_a_stream_an_odd_combi_left_running_holds_back_the_fence(cache, monkeypatch):
    """sil liveness finding (`--against emulator --seed 22`, 10 min): a `combi` with an odd count
    printed `Error` and left port 0's reports streaming, as the firmware does; the model took the
    port for silent, so a later step with `help` sent its fence at once, into a ring the reports
    and `help` had filled, and its answer was lost ("0 of 2 fence line(s) arrived" before the fix,
    fuzz/model/reference_model.py). Now the step waits for the ring to drain and is judged on what a full
    ring leaves."""
    from buildhat_conformance.fuzz.oracles.registry import Finding
    from buildhat_conformance.fuzz.running.checked_run import Runner
    from buildhat_conformance.harness.targets import make_target
    from buildhat_conformance.protocol.profiles import get_profile

    monkeypatch.setenv("BUILDHAT_SIL_CACHE", str(cache))
    target = make_target(f"sil:{firmware_tree()}")
    layout = {0: ("active", 0x30), 1: ("active", 0x40), 2: ("passive", 8), 3: None}
    runner = Runner([("target", lambda: target, get_profile("R7"))], 2.0, True, devices=layout, tx_ring=True)
    try:
        runner.start()
        runner.exchange([b"echo 1\r", b"select 5\r", b"selrate 1\r"], guard=True)   # 14 values a ms
        runner.exchange([b"combi 0 1\r"], guard=True)
        for _ in range(2):                      # steps later: nothing carried over from the select
            runner.exchange([b"port 0\r"], guard=True)
        try:
            runner.exchange([b"help\r"] + [b"x" * 60 + b"\r"] * 6 + [b"version\r"], guard=True)
        except Finding as finding:
            pytest.fail(f"{finding.oracle}: {finding}")
        assert runner.stats.ring_lossy == 1     # the ring did fill: judged on what it leaves
    finally:
        runner.close()
