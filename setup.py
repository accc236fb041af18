"""Maps the top-level folders into the ``buildhat_conformance`` namespace.

The folders stay at the top of the repository (harness/, emulator/, ...) but install as
``buildhat_conformance.harness`` etc., so nothing generic lands in site-packages.
Sub-packages are found by walking each folder for ``__init__.py``.
"""
import os

from setuptools import setup

ROOT = "buildhat_conformance"
FOLDERS = ["plumbing", "protocol", "harness", "transcripts", "serving", "emulator", "sil", "rp2040",
           "conformance", "fuzz", "campaigns", "bench"]
# sil/standin/ is C source the user's machine compiles (`sil build`): shipped as data, the wheel stays pure.
STANDIN = ["standin/*.c", "standin/*.h", "standin/include/*.h", "standin/include/*/*.h",
           "standin/include/*/*/*.h"]
DATA = ["*.json", "*.txt", "*.md", "*.script", "*.jsonl", "*.html", "*.css", "*.pem", "*.bin", "*.mjs"]


def packages():
    found, dirs = [ROOT], {ROOT: ROOT}
    for top in FOLDERS:
        for here, _subdirs, files in os.walk(top):
            if "__init__.py" not in files or "__pycache__" in here:
                continue
            name = ".".join([ROOT] + here.split(os.sep))
            found.append(name)
            dirs[name] = here
    return found, dirs


pkgs, pkg_dirs = packages()
setup(packages=pkgs, package_dir=pkg_dirs,
      package_data={name: DATA + (STANDIN if name.endswith(".sil") else []) for name in pkgs})
