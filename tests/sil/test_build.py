"""``buildhat-conformance sil build``: the user's command, its cache and its one-line errors."""
import hashlib
import os
import subprocess
import sys

import pytest
from sil_support import cli, copy_tree, firmware_tree  # noqa: E402

from buildhat_conformance.sil.build import standin_dir


def _digest(tree):
    h = hashlib.sha256()
    for p in sorted(tree.rglob("*")):
        if p.is_file():
            h.update(p.name.encode() + p.read_bytes())
    return h.hexdigest()


@pytest.fixture(scope="module")
def cache(tmp_path_factory):
    return tmp_path_factory.mktemp("silcache")


def test_build_prints_one_line_caches_and_leaves_the_tree_alone(cache):
    tree = firmware_tree()
    before = _digest(tree)
    first = cli("sil", "build", str(tree), cache=cache)
    assert first.returncode == 0, first.stderr
    lines = first.stdout.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(("built: ", "up to date: ")), first.stdout
    program = lines[0].split(" -> ")[1].split(" (")[0]
    assert os.access(program, os.X_OK)
    again = cli("sil", "build", str(tree), cache=cache)
    assert again.stdout.startswith("up to date: ") and program in again.stdout
    assert _digest(tree) == before, "the build wrote into the firmware tree"


def test_a_checkout_that_contains_firmware_pico_is_found(cache, tmp_path):
    copy_tree(tmp_path / "checkout" / "firmware-pico")
    done = cli("sil", "build", str(tmp_path / "checkout"), cache=cache)
    assert done.returncode == 0, done.stderr


@pytest.mark.parametrize("what", ["missing", "empty", "file"])
def test_not_a_firmware_tree_is_one_line_exit_2(cache, tmp_path, what):
    path = tmp_path / "x"
    if what == "empty":
        path.mkdir()
    elif what == "file":
        path.write_text("int main(void){return 0;}\n")
    done = cli("sil", "build", str(path), cache=cache)
    assert done.returncode == 2
    assert done.stdout == "" and len(done.stderr.strip().splitlines()) == 1
    assert done.stderr.startswith("buildhat-conformance sil: ")


def test_a_compile_error_names_the_file_and_the_compilers_first_error(cache, tmp_path):
    tree = copy_tree(tmp_path / "broken")
    (tree / "ioconv.c").write_text("#error planted by the test\n" + (tree / "ioconv.c").read_text())
    done = cli("sil", "build", str(tree), cache=cache)
    assert done.returncode == 2
    line = done.stderr.strip()
    assert "\n" not in line and "ioconv.c" in line and "planted by the test" in line


def test_no_compiler_is_one_line_exit_2(cache, tmp_path):
    empty = tmp_path / "bin"          # a PATH with no compiler on it
    empty.mkdir()
    done = subprocess.run([sys.executable, "-m", "buildhat_conformance.cli",
                           "sil", "build", str(firmware_tree())], capture_output=True, text=True,
                          env={"PATH": str(empty), "BUILDHAT_SIL_CACHE": str(cache)})
    assert done.returncode == 2
    assert done.stderr.strip() == ("buildhat-conformance sil: no C compiler found: "
                                   "install gcc or clang (or set CC)")


def test_unknown_sanitizer_is_a_usage_error(cache):
    done = cli("sil", "build", str(firmware_tree()), "--sanitize", "thread", cache=cache)
    assert done.returncode == 2 and "unknown sanitizer 'thread'" in done.stderr


def test_the_stand_in_is_warning_free(tmp_path):
    import shutil
    cc = shutil.which("cc") or shutil.which("gcc") or shutil.which("clang")
    if cc is None:
        pytest.skip("no C compiler on this machine")
    for src in sorted(standin_dir().glob("*.c")):
        done = subprocess.run([cc, "-std=gnu11", "-O1", "-Wall", "-Wextra", "-Werror",
                               "-I", str(standin_dir() / "include"), "-I", str(standin_dir()),
                               "-c", str(src), "-o", str(tmp_path / (src.stem + ".o"))],
                              capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
