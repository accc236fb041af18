"""The smallest library session: Hat(device=pty), DistanceSensor on A, one get_distance()."""
from __future__ import annotations

from _harness import connect, run, step


def main() -> None:
    import buildhat  # pyright: ignore[reportMissingImports] - in the library's own venv (hostlib/venvs.py)

    connect(buildhat)
    sensor = buildhat.DistanceSensor("A")
    step("distance", sensor.get_distance)


run(main)
