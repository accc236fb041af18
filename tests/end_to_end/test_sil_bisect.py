"""`sil bisect` through the user's command, on a git history the test makes from the R7 tree:
ten commits, a behaviour change planted in the sixth (the help text's `vin` line), the firmware
tree at the repository's root or in `firmware-pico/`."""
import re

import pytest
from sil_support import cli, git, git_history

pytestmark = pytest.mark.timeout(900)

def _git(repo, *args):
    return git(repo, *args)


def _history(repo, folder=".", broken=None):
    """Ten commits; the sixth changes the help text; ``broken``: that commit's tree does not compile
    (the next one mends it)."""
    return git_history(repo, folder, 10, 6, broken)


@pytest.mark.slow
def test_bisect_names_the_sixth_commit_in_at_most_five_builds(tmp_path):
    repo = tmp_path / "fw"
    shas = _history(repo)
    before = (_git(repo, "status", "--porcelain"), _git(repo, "rev-parse", "HEAD"),
              _git(repo, "worktree", "list"))
    done = cli("sil", "bisect", shas[0], shas[-1], "-C", str(repo), "-k", "test_help_prints",
               "--work", str(tmp_path / "work"), cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith(f"first changed: {shas[5]} commit 6: test_commands::test_help_prints"), done.stdout
    assert "pass -> fail" in last
    builds = int(re.search(r"\((\d+) build\(s\)\)", last).group(1))
    assert builds <= 5, done.stdout
    steps = [line for line in done.stdout.splitlines() if line.startswith("[")]
    assert len(steps) == builds - 1 and all(": same" in s or ": changed" in s for s in steps), done.stdout
    # the user's checkout is untouched: same HEAD, nothing changed, no worktree left behind
    assert (_git(repo, "status", "--porcelain"), _git(repo, "rev-parse", "HEAD"),
            _git(repo, "worktree", "list")) == before


@pytest.mark.slow
def test_bisect_skips_a_commit_that_does_not_build_and_compares_output(tmp_path):
    """The tree in firmware-pico/ (found without --folder); the seventh commit does not compile and
    is skipped; --output looks for a change of the HAT's lines."""
    repo = tmp_path / "fw"
    shas = _history(repo, folder="firmware-pico", broken=7)
    done = cli("sil", "bisect", shas[0], shas[-1], "--output", "-k", "test_help_prints", "-C", str(repo),
               "--work", str(tmp_path / "work"), cache=tmp_path / "cache")
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-2000:]
    assert f"{shas[6][:10]} commit 7: skipped" in done.stdout, done.stdout
    last = done.stdout.strip().splitlines()[-1]
    assert last.startswith(f"first changed: {shas[5]} commit 6: test_commands::test_help_prints"), done.stdout
    assert "its HAT output differs" in last


@pytest.mark.parametrize("good,bad,says", [
    ("nosuchref", "HEAD", "GOOD 'nosuchref': not a commit of"),
    ("HEAD", "HEAD~1", "is not an ancestor of BAD"),
])
def test_bisect_usage_mistakes_are_one_line_exit_2(tmp_path, good, bad, says):
    repo = tmp_path / "fw"
    repo.mkdir()
    _git(repo, "init", "-q")
    for n in (1, 2):
        _git(repo, "-c", "user.email=t@e", "-c", "user.name=t", "commit", "-q", "--allow-empty",
             "-m", f"c{n}")
    done = cli("sil", "bisect", good, bad, "-C", str(repo), cache=tmp_path / "cache")
    assert done.returncode == 2 and done.stdout == "", done.stdout + done.stderr
    assert len(done.stderr.strip().splitlines()) == 1 and says in done.stderr, done.stderr


def test_bisect_outside_a_repository_is_one_line_exit_2(tmp_path):
    done = cli("sil", "bisect", "a", "b", "-C", str(tmp_path), cache=tmp_path / "cache")
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1, done.stderr
    assert "not a git repository" in done.stderr, done.stderr
