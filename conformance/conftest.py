"""Loads the conformance plugin when pytest runs this folder (``pytest conformance --target URL``).

Plugins are named by their package path, so each loads once, under the name the rest of the
package imports it by.
"""
pytest_plugins = [
    "buildhat_conformance.conformance.collect",     # test modules import under the package name
    "buildhat_conformance.conformance.plugin",      # options, the `hat` fixture, verdicts, JUnit
    "buildhat_conformance.conformance.progress",    # terminal: legend, slow-case names, closing line
    "buildhat_conformance.conformance.fixtures",    # port fixtures
    "buildhat_conformance.conformance.multitarget", # several targets at once; inert with one
]
