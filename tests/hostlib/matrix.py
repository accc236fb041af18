"""The python-build-hat CI matrix: which library release runs which scenario on which emulator setup.

Everything a scenario's result is judged against is decided here (device readings, shaft positions),
handed to the emulator through its control channel, and checked by
tests/end_to_end/test_hostlib_python_build_hat.py.
Scenarios of a run are independent (one emulator each) and run in parallel: the library waits in real
time (11 s after a firmware upload alone), so the wall time is the longest scenario, not the sum.
"""
from __future__ import annotations

import concurrent.futures
import json
import time
from dataclasses import dataclass, field
from typing import Any, Dict, List, Optional, Tuple, TypedDict

from .emulator_proc import EmulatorFailed, EmulatorProcess
from .lpf2data import data_line
from .scenario import ScenarioResult, run_scenario
from .venvs import FIRMWARE_OF, HostLibUnavailable, buildhat_python

__all__ = ["Plan", "Outcome", "plans", "run_all", "ADC", "MOTOR", "COLOR", "DISTANCE", "FORCE", "CLASSIC"]

# -- what the world is made to be (the oracles) -----------------------------------------------------------
ADC = 1650                      # raw Vin ADC; FIRMWARE-FACTS §4.4 turns it into 7.58 V
MOTOR = dict(pos=90, degrees=180, rotations=1, target=-90, target2=0, ramp_speed=25, seconds=1, speed=40,
             rpm=60, pair_degrees=180)


class Colour(TypedDict):        # typed: which values are one number and which a list, for the checker too
    reflected: int
    ambient: int
    rgbi: List[int]
    hsv: List[int]


class Classic(TypedDict):
    reflected: int
    ambient: int
    rgb: List[int]
    proximity: int
    tilt: List[int]
    motion: int
    count: int


COLOR: Colour = {"reflected": 42, "ambient": 17, "rgbi": [1000, 40, 40, 900], "hsv": [200, 512, 768]}
DISTANCE = dict(far=250, near=60)
FORCE = dict(force=55, touch=1, peak=70, again=80)
CLASSIC: Classic = {"reflected": 33, "ambient": 21, "rgb": [200, 100, 400], "proximity": 4, "tilt": [10, -20],
                    "motion": 7, "count": 12345}

# While the emulator waits for devices to finish their LPF2 handshakes (no host attached yet) it may run
# fast; the library itself then always talks to it in real time.
SETTLE_SPEED = 10
SETTLE_HAT_MS = 5000
# The link runs at the HAT's wire rate, as on hardware: `buildhat-emulator --pty` as it comes (its default
# is a HAT's 115200-baud wire, issue 37). Unpaced output reaches the library within microseconds, which
# widens a race in python-build-hat 0.9.0's start-up (it arms its `list` counter only after sending `list`;
# a port line read before that is never counted and Hat() waits forever).
WIRE: List[str] = []


@dataclass
class Plan:
    script: str
    devices: Dict[int, str]
    params: Dict[str, Any]
    bootloader: bool = False
    timeout: float = 60.0
    # Run the release of the *other* protocol generation, reporting the version this library expects.
    wrong_generation: bool = False
    # Start the emulator on this release (booted) and hand the library this project's gpiozero pin factory,
    # so that its own GPIO reset reaches the emulator (``Hat()`` resets when the version differs).
    gpio_reset_from: Optional[str] = None
    # Start powered up (``--booted``) and in real time from the first moment, as a library's CI would.
    booted: bool = False


# Each library release against the other generation (R1-R5 dialect vs R6+), for the wrong_generation plan.
OTHER_GENERATION = {"0.9.0": "1636109636", "0.5.7": "1737564117"}


@dataclass
class Outcome:
    version: str
    name: str
    plan: Plan
    result: Optional[ScenarioResult] = None
    skip: str = ""                     # why it could not run at all (PyPI unreachable): a failure
    setup_error: str = ""              # the emulator did not start
    emulator_exit: Optional[int] = None
    emulator_stderr: str = ""
    lint: Dict[str, Any] = field(default_factory=dict)
    wall: float = 0.0
    transcript: List[Dict[str, Any]] = field(default_factory=list)   # the emulator's --transcript

    def explain(self) -> str:
        head = f"buildhat {self.version} / {self.name}"
        if self.setup_error:
            return f"{head}: emulator setup failed: {self.setup_error}"
        body = self.result.explain() if self.result else "(no result)"
        shown = [json.dumps(e)[:200] for e in self.transcript[-40:]]
        return (f"{head}\n{body}\nemulator exit {self.emulator_exit}; stderr tail:\n"
                f"{self.emulator_stderr[-2000:]}\nemulator transcript (tail):\n" + "\n".join(shown))


def _spike_world() -> Dict[str, List[str]]:
    c, d, f = COLOR, DISTANCE, FORCE
    return {
        "color.reflected": [data_line(0, 0x3D, 1, [c["reflected"]])],
        "color.ambient": [data_line(0, 0x3D, 2, [c["ambient"]])],
        "color.rgbi": [data_line(0, 0x3D, 5, c["rgbi"])],
        "color.hsv": [data_line(0, 0x3D, 6, c["hsv"])],
        "distance.far": [data_line(1, 0x3E, 0, [d["far"]])],
        "distance.near": [data_line(1, 0x3E, 0, [d["near"]])],
        "force.pressed": [data_line(2, 0x3F, 0, [f["force"]]), data_line(2, 0x3F, 1, [f["touch"]]),
                          data_line(2, 0x3F, 3, [f["peak"]])],
        "force.released": [data_line(2, 0x3F, 0, [0]), data_line(2, 0x3F, 1, [0])],
        "force.pressed_again": [data_line(2, 0x3F, 0, [f["again"]]), data_line(2, 0x3F, 1, [1])],
    }


def _classic_world() -> Dict[str, List[str]]:
    k = CLASSIC
    return {
        "cd.reflected": [data_line(0, 0x25, 3, [k["reflected"]])],
        "cd.ambient": [data_line(0, 0x25, 4, [k["ambient"]])],
        "cd.rgb": [data_line(0, 0x25, 6, k["rgb"])],
        "cd.distance": [data_line(0, 0x25, 1, [k["proximity"]])],
        "tilt": [data_line(2, 0x22, 0, k["tilt"])],
        "motion.distance": [data_line(3, 0x23, 0, [k["motion"]])],
        "motion.count": [data_line(3, 0x23, 1, [k["count"]])],
    }


def plans() -> Dict[str, Plan]:
    """Scenario name -> plan; the same for every library release (each adapts to its own API)."""
    return {
        # Starts in the bootloader: the library uploads its bundled firmware, then carries on.
        "hat_upload": Plan("hat.py", {0: "0x30", 1: "0x3D", 2: "passive 8", 3: "none"},
                           {"adc": ADC, "leds": True}, bootloader=True, timeout=90),
        "motors": Plan("motors.py", {0: "0x30", 1: "0x30", 2: "0x30", 3: "passive 2"}, dict(MOTOR)),
        "sensors_spike": Plan("sensors_spike.py", {0: "0x3D", 1: "0x3E", 2: "0x3F", 3: "none"},
                              {"set": _spike_world(), "plug_matrix": "@plug 3 0x40"}),
        "sensors_classic": Plan("sensors_classic.py", {0: "0x25", 1: "passive 8", 2: "0x22", 3: "0x23"},
                                {"set": _classic_world(), "unplug": "@unplug 2"}),
        # The lint must catch the real library speaking the wrong dialect.
        "wrong_generation": Plan("wrong_generation.py", {0: "0x30", 1: "none", 2: "none", 3: "none"}, {},
                                 wrong_generation=True, timeout=40),
    }


#: Scenarios run for one library release only: python-build-hat 0.5.12 resets the HAT through gpiozero.
PIXELS = [[[3, 10], [3, 10], [3, 10]], [[6, 5], [6, 5], [6, 5]], [[9, 1], [9, 1], [9, 1]]]
EXTRA_PLANS: Dict[Tuple[str, str], Plan] = {
    ("0.5.12", "gpio_reset"): Plan(
        "gpio_reset.py", {0: "0x30", 1: "0x3D", 2: "0x3E", 3: "0x40"},
        {"pos": MOTOR["pos"], "degrees": MOTOR["degrees"], "speed": MOTOR["ramp_speed"], "pixels": PIXELS,
         "set": {"color.reflected": [data_line(1, 0x3D, 1, [COLOR["reflected"]])],
                 "color.rgbi": [data_line(1, 0x3D, 5, COLOR["rgbi"])],
                 "distance": [data_line(2, 0x3E, 0, [DISTANCE["far"]])]}},
        timeout=90, gpio_reset_from="1636109636"),
    # The library's upstream stress loops (shortened): the calibrated lint must find nothing.
    ("0.9.0", "stress"): Plan("stress.py", {0: "0x30", 1: "none", 2: "none", 3: "none"}, {"seconds": 3},
                              timeout=60),
    # Issue 27: Motor.run_for_seconds(N) timed by the host, on a HAT started as `--booted`.
    ("0.9.0", "timed_runs"): Plan("timed_runs.py", {0: "0x30", 1: "none", 2: "none", 3: "none"},
                                  {"seconds": [1, 2]}, timeout=60, booted=True),
}


def run_one(version: str, name: str, plan: Plan) -> Outcome:
    """One scenario on a fresh emulator running the release the library bundles."""
    outcome = Outcome(version, name, plan)
    started = time.monotonic()
    try:
        python = buildhat_python(version)
    except HostLibUnavailable as exc:
        outcome.skip = str(exc)
        return outcome
    firmware = None if plan.bootloader else str(FIRMWARE_OF[version])
    extra = list(WIRE)
    env: Dict[str, str] = {}
    if plan.gpio_reset_from:
        firmware = plan.gpio_reset_from
        extra += ["--booted"]
    settle = not plan.bootloader and not plan.booted     # else it starts (or is) settled, at speed 1
    if plan.booted:
        extra += ["--booted"]
    if plan.wrong_generation:
        firmware = OTHER_GENERATION[version]
        extra += ["--version-string", f"{FIRMWARE_OF[version]} (release {firmware} underneath)"]
    emu = EmulatorProcess(firmware=firmware, devices=plan.devices, bootloader=plan.bootloader,
                          speed=SETTLE_SPEED if settle else None, extra=extra)
    transcript = emu.tmp / "transcript.jsonl"
    emu.args += ["--transcript", str(transcript)]
    if plan.gpio_reset_from:
        env = {"GPIOZERO_PIN_FACTORY": "buildhat_emulator", "BUILDHAT_EMULATOR_CONTROL": emu.control_path}
    try:
        emu.start()
        if settle:
            emu.wait_settled(SETTLE_HAT_MS)
            emu.control("@speed 1")
        outcome.result = run_scenario(python, plan.script, emu.pty, emu.control_path, plan.params,
                                      plan.timeout, env_extra=env)
        time.sleep(0.3)   # the library's last lines (its shutdown at exit) reach the HAT at 115200 baud
        try:
            outcome.lint = json.loads(emu.control("@lint"))
        except (EmulatorFailed, OSError, ValueError) as exc:
            outcome.lint = {"unavailable": str(exc)}
    except (EmulatorFailed, OSError) as exc:
        outcome.setup_error = f"{type(exc).__name__}: {exc}"
    finally:
        outcome.emulator_exit = emu.stop()
        outcome.emulator_stderr = emu.stderr()
        outcome.transcript = _events(transcript)
        emu.__exit__(None, None, None)
    outcome.wall = time.monotonic() - started
    return outcome


Futures = Dict[Tuple[str, str], "concurrent.futures.Future[Outcome]"]


def _events(path: Any) -> List[Dict[str, Any]]:
    try:
        return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]
    except (OSError, ValueError):
        return []


def run_all(versions: List[str], workers: int = 12) -> Futures:
    """Start every (version, scenario) at once, and the EXTRA_PLANS; the caller waits on the futures."""
    pool = concurrent.futures.ThreadPoolExecutor(max_workers=workers, thread_name_prefix="hostlib")
    futures = {(v, name): pool.submit(run_one, v, name, plan)
               for v in versions for name, plan in plans().items()}
    futures.update({key: pool.submit(run_one, key[0], key[1], plan) for key, plan in EXTRA_PLANS.items()})
    pool.shutdown(wait=False)
    return futures
