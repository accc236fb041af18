"""A host library's own test module, as its authors would write it: the real, unmodified python-build-hat in
this process, one pytest session, one emulator shared by every test (the library keeps one serial
connection per process). Copied into a scratch directory and run by
tests/end_to_end/test_hostlib_fixture.py inside a library venv; the values to set and expect come from
there (BUILDHAT_CASE, JSON).
"""
import json
import os
import time

import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)
import pytest

CASE = json.loads(os.environ["BUILDHAT_CASE"])


@pytest.fixture(scope="session")
def buildhat_emulator_options():
    return CASE["options"]


def connect(emulator):
    # Every test asks; only the first opens the pty (the library keeps its connection for the process).
    return buildhat.Hat(device=emulator.path)


def test_vin_follows_the_adc(buildhat_emulator_shared):
    hat = connect(buildhat_emulator_shared)
    assert buildhat_emulator_shared.control(f"@adc {CASE['adc']}") == "ok"
    time.sleep(0.05)
    assert hat.get_vin() == CASE["vin"]


def test_distance_sensor_reads_what_the_world_says(buildhat_emulator_shared):
    connect(buildhat_emulator_shared)
    sensor = buildhat.DistanceSensor(CASE["distance_port"])
    assert buildhat_emulator_shared.control(CASE["distance_line"]) == "ok"
    time.sleep(0.3)
    assert sensor.get_distance() == CASE["distance"]


def test_motor_turns(buildhat_emulator_shared):
    connect(buildhat_emulator_shared)
    motor = buildhat.Motor(CASE["motor_port"])
    before = motor.get_position()
    motor.run_for_degrees(CASE["degrees"], speed=CASE["speed"])
    turned = motor.get_position() - before
    assert abs(turned - CASE["degrees"]) <= CASE["tolerance"]


def test_the_previous_tests_world_was_restored(buildhat_emulator_shared):
    hat = connect(buildhat_emulator_shared)
    assert hat.get_vin() == CASE["vin_default"]
    sensor = buildhat.DistanceSensor(CASE["distance_port"])
    time.sleep(0.3)
    assert sensor.get_distance() != CASE["distance"]
