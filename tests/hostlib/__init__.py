"""Helpers for running real host libraries (PyPI ``buildhat``) against the emulator.

Use from a test file in any folder under tests/ (tests/conftest.py puts tests/ on ``sys.path``; pytest's
``--import-mode=importlib`` adds nothing)::

    from hostlib.venvs import buildhat_python

- ``venvs``: ``buildhat_python("0.9.0" | "0.5.7")`` -> the interpreter of a cached library venv.
- ``emulator_proc``: ``EmulatorProcess`` (``buildhat-emulator --pty --control``), ``control()``.
- ``scenario``: ``run_scenario()`` runs ``scenarios/<name>.py`` in a library venv with a hard time limit.
- ``matrix``: the python-build-hat CI matrix (plans, the values the emulator is told, parallel runner).
- ``lpf2data``: ``@data`` control lines encoded from devices.json.

``scenarios/`` holds the scripts that run inside the library venvs: they import only the library and the
standard library, never this project.
"""
