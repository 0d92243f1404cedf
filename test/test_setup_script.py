"""scripts/setup.sh on a machine that lacks system packages, run as a user who cannot install them:
one message names every missing package with one command to run, and nothing is half made."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
NOBODY = 65534
#: what the script runs besides Python; the compilers are left out (build-essential missing)
TOOLS = ("bash", "dirname", "id", "cat", "sha256sum", "cut", "env", "grep")


def _as_user(cmd: list[str]) -> list[str]:
    """As nobody when we are root (a user with no write access to the system and no sudo)."""
    if os.getuid() != 0:
        return cmd
    setpriv = shutil.which("setpriv")
    if setpriv is None:
        pytest.skip("setpriv (util-linux) is needed to drop root")  # Debian 12 has it
    return [setpriv, f"--reuid={NOBODY}", f"--regid={NOBODY}", "--clear-groups", *cmd]


@pytest.fixture()
def bare():
    """A copy of the script in a repository of its own, a PATH with a shell and Python but no compiler
    (in a folder the other user can reach: pytest's own are the owner's only)."""
    tmp_path = Path(tempfile.mkdtemp(prefix="dxl-setup-"))
    try:
        yield _bare(tmp_path)
    finally:
        shutil.rmtree(tmp_path, ignore_errors=True)


def _bare(tmp_path: Path) -> tuple[Path, dict[str, str]]:
    repo = tmp_path / "repo"
    (repo / "scripts").mkdir(parents=True)
    shutil.copy(ROOT / "scripts" / "setup.sh", repo / "scripts" / "setup.sh")
    shutil.copy(ROOT / "requirements.txt", repo / "requirements.txt")
    bin_dir = tmp_path / "bin"
    bin_dir.mkdir()
    for tool in TOOLS:
        found = shutil.which(tool)
        assert found, tool
        (bin_dir / tool).symlink_to(found)
    python = shutil.which("python3.11", path="/usr/bin:/usr/local/bin") or sys.executable
    (bin_dir / "python3").symlink_to(python)
    for path in (tmp_path, repo, repo / "scripts", bin_dir):
        path.chmod(0o755)
    env = {"PATH": str(bin_dir), "HOME": str(tmp_path), "LANG": "C.UTF-8"}
    return repo, env


def test_every_missing_package_is_named_in_one_message_and_nothing_is_made(bare):
    repo, env = bare
    done = subprocess.run(_as_user(["bash", str(repo / "scripts" / "setup.sh")]), env=env, capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 1, done.stdout + done.stderr
    errors = [line for line in done.stderr.splitlines() if "ERROR" in line]
    assert len(errors) == 1, done.stderr
    assert "missing system packages:" in errors[0] and "build-essential" in errors[0]
    assert "build-essential: a C and C++ compiler" in done.stderr
    fix = [line for line in done.stderr.splitlines() if "fix: sudo apt-get install" in line]
    assert len(fix) == 1 and "build-essential" in fix[0], done.stderr
    assert not (repo / ".venv").exists() and not (repo / "install").exists()


def test_check_system_says_none_missing_where_everything_is_there():
    done = subprocess.run(["bash", str(ROOT / "scripts" / "setup.sh"), "--check-system"], capture_output=True,
                          text=True, timeout=60)
    assert done.returncode == 0, done.stderr
    assert "system packages: none missing" in done.stdout
