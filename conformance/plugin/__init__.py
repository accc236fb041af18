"""The suite's pytest plugin: loading this package loads its parts, each a plugin of its own.

Registered once, by conformance/cases/conftest.py (``buildhat-conformance run`` runs pytest on that
folder). conformance/plugin/interrupt.py is the runner's own (``-p``), not listed here.
"""
pytest_plugins = [
    "buildhat_conformance.conformance.plugin.collect",      # test modules import under the package name
    "buildhat_conformance.conformance.plugin.options",      # the `buildhat` options, output paths
    "buildhat_conformance.conformance.plugin.run",          # the run: one session, verdicts, JUnit
    "buildhat_conformance.conformance.plugin.case_fixtures",  # the `hat` fixture, per-case transcript
    "buildhat_conformance.conformance.plugin.progress",     # terminal: legend, slow-case names, closing line
    "buildhat_conformance.conformance.cases.fixtures",      # port fixtures
    "buildhat_conformance.conformance.plugin.multitarget",  # several targets at once; inert with one
]
