"""scripts/docs_touched.py (run by scripts/lint.sh): a commit that changes the public surface without
changing the docs is named, with what it changed; one with a docs change, or with the marker line
saying why none is needed, passes; so does a commit that changes no surface."""
from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent
COPIED = ("dynamixel_handler", "dynamixel_handler_msgs", "scripts", "setup.py", "docs/README.md")


@pytest.fixture(scope="module")
def repo(tmp_path_factory):
    """A repository of its own holding the package, its messages and scripts, one commit."""
    root = tmp_path_factory.mktemp("docs-touched")
    for name in COPIED:
        src = ROOT / name
        if src.is_dir():
            shutil.copytree(src, root / name, ignore=shutil.ignore_patterns("__pycache__", "build", "*.pyc"))
        else:
            (root / name).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy(src, root / name)
    _git(root, "init", "-q")
    _git(root, "add", "-A")
    _git(root, "commit", "-qm", "start")
    (root / ".ci").mkdir()
    (root / ".ci" / "docs-baseline").write_text(_git(root, "rev-parse", "HEAD"))
    _git(root, "add", "-A")
    _git(root, "commit", "-qm", "baseline")
    return root


def _git(root: Path, *args: str) -> str:
    env = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@t", "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@t",
           "PATH": "/usr/bin:/bin", "HOME": str(root)}
    return subprocess.run(["git", *args], cwd=root, capture_output=True, text=True, check=True, env=env).stdout.strip()


def _check(root: Path, *args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(root / "scripts" / "docs_touched.py"), *args], capture_output=True,
                          text=True, timeout=120)


def _new_service(root: Path, name: str) -> None:
    path = root / "dynamixel_handler" / "ros" / "snapshot.py"
    path.write_text(path.read_text(encoding="utf-8") + f'\nEXTRA_SERVICE = "dynamixel/{name}"\n', encoding="utf-8")


def test_a_new_service_without_docs_fails_with_what_changed(repo):
    _new_service(repo, "calibrate")
    tree = _check(repo)
    assert tree.returncode == 1 and "+ ros dynamixel/calibrate" in tree.stderr  # uncommitted: the tree
    _git(repo, "commit", "-qam", "Add a calibrate service")
    done = _check(repo)
    assert done.returncode == 1
    assert "(Add a calibrate service) changes the public surface without a docs change" in done.stderr
    assert "+ ros dynamixel/calibrate" in done.stderr and "Docs: none (" in done.stderr
    _git(repo, "reset", "-q", "--hard", "HEAD~1")


def test_the_same_change_with_a_docs_change_or_the_marker_passes(repo):
    _new_service(repo, "calibrate2")
    (repo / "docs" / "README.md").write_text("the calibrate2 service\n")
    assert _check(repo).returncode == 0
    _git(repo, "commit", "-qam", "Add calibrate2 with its docs")
    assert _check(repo).returncode == 0
    _new_service(repo, "calibrate3")
    _git(repo, "commit", "-qam", "Add calibrate3\n\nDocs: none (an internal service of the tests)")
    assert _check(repo).returncode == 0


def test_a_change_that_keeps_the_surface_passes(repo):
    path = repo / "dynamixel_handler" / "units.py"
    path.write_text(path.read_text(encoding="utf-8") + "\n# a comment\n", encoding="utf-8")
    _git(repo, "commit", "-qam", "A comment")
    assert _check(repo).returncode == 0
    assert _check(repo, "HEAD").returncode == 0
