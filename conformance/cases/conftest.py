"""Registers the suite's pytest plugin (conformance/plugin/) for this folder: ``pytest
conformance/cases --target URL``, or ``buildhat-conformance run``. The plugin's package names its
parts; each loads once, under the name the rest of the package imports it by."""
pytest_plugins = ["buildhat_conformance.conformance.plugin"]
