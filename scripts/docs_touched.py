#!/usr/bin/env python3
"""A change to the public surface comes with a change to the docs, in the same commit.

The surface is what ``scripts/surface.py`` prints (parameters with their types and defaults, the
node's topic, service and action names, the executables, the set-up tool's verbs and options, the
message definitions). For each commit checked, the surface of the commit is compared with its
parent's; when it differs, the commit must also change a page of the docs (``docs/*.md``,
``README.md``, ``CONTRIBUTING.md``) or ``CHANGELOG.rst``, or say why not on a line of its message:

    Docs: none (<why the docs need no change>)

The uncommitted changes of the working tree are checked the same way against HEAD.

    scripts/docs_touched.py              # the commits after .ci/docs-baseline (at most 50), then the tree
    scripts/docs_touched.py REV          # that commit only

Exit 1 naming each commit and what it changed. ``scripts/lint.sh`` runs it.
"""
from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
BASELINE = ROOT / ".ci" / "docs-baseline"
#: what a surface is made from (copied out of a commit to read its surface)
SOURCES = ("dynamixel_handler", "dynamixel_handler_msgs", "setup.py")
#: at most this many commits after the baseline are checked
MOST = 50
MARKER = "Docs: none ("


def _git(*args: str) -> str:
    return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, check=True).stdout


def _is_docs(path: str) -> bool:
    return (path.startswith("docs/") and path.endswith(".md")) or path in ("README.md", "CONTRIBUTING.md",
                                                                          "CHANGELOG.rst")


def surface_of(rev: str | None) -> set[str]:
    """The surface of a commit (None: the working tree)."""
    script = str(ROOT / "scripts" / "surface.py")
    if rev is None:
        out = subprocess.run([sys.executable, script], capture_output=True, text=True, check=True).stdout
        return set(out.splitlines())
    with tempfile.TemporaryDirectory(prefix="dxl-surface-") as tmp:
        listed = [p for p in SOURCES if _git("ls-tree", "--name-only", rev, p).strip()]
        archive = subprocess.run(["git", "archive", rev, *listed], cwd=ROOT, capture_output=True, check=True).stdout
        subprocess.run(["tar", "-x", "-C", tmp], input=archive, check=True)
        out = subprocess.run([sys.executable, script, "--root", tmp], capture_output=True, text=True)
        if out.returncode != 0:  # a commit whose package does not import: nothing to compare
            return set()
        return set(out.stdout.splitlines())


def _changes(before: set[str], after: set[str]) -> list[str]:
    return [f"- {line}" for line in sorted(before - after)] + [f"+ {line}" for line in sorted(after - before)]


def check_commit(rev: str) -> list[str]:
    """Problems of one commit (empty: fine)."""
    parent = _git("rev-parse", "--verify", "--quiet", f"{rev}^").strip()
    if not parent:
        return []
    message = _git("log", "-1", "--format=%B", rev)
    files = _git("diff", "--name-only", parent, rev).split()
    if any(_is_docs(f) for f in files) or any(line.startswith(MARKER) for line in message.splitlines()):
        return []
    changes = _changes(surface_of(parent), surface_of(rev))
    if not changes:
        return []
    title = message.splitlines()[0][:80] if message else ""
    return [f"{rev[:10]} ({title}) changes the public surface without a docs change:", *changes[:20]]


def check_tree() -> list[str]:
    files = _git("diff", "--name-only", "HEAD").split() + _git("ls-files", "--others", "--exclude-standard").split()
    if not files or any(_is_docs(f) for f in files):
        return []
    changes = _changes(surface_of("HEAD"), surface_of(None))
    return ["the uncommitted changes change the public surface without a docs change:", *changes[:20]] if changes else []


def commits_to_check() -> list[str]:
    base = BASELINE.read_text(encoding="utf-8").split()[0] if BASELINE.exists() else ""
    if base and subprocess.run(["git", "cat-file", "-e", f"{base}^{{commit}}"], cwd=ROOT,
                               capture_output=True).returncode == 0:
        revs = _git("rev-list", f"--max-count={MOST}", f"{base}..HEAD").split()
    else:
        revs = _git("rev-list", "--max-count=1", "HEAD").split()
    return list(reversed(revs))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("rev", nargs="?", help="check this commit only")
    args = ap.parse_args(argv)
    problems: list[str] = []
    if args.rev:
        problems += check_commit(_git("rev-parse", args.rev).strip())
    else:
        for rev in commits_to_check():
            problems += check_commit(rev)
        problems += check_tree()
    if problems:
        print("\n".join(problems), file=sys.stderr)
        print(f"docs: change the docs the change touches in the same commit, or say why not on a line of the "
              f"commit message: '{MARKER}<why>)'", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
