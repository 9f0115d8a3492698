"""Every code block of README.md and docs/*.md runs as written.

What a fenced block is, by its language (the word after the opening fence):

* ``python``: run. A document's python blocks run in order in one namespace, so a later
  block uses what an earlier one made. A block whose first line is ``# NAME.py`` is a file
  the reader is told to write: it is written (and compiled), not run.
* ``bash``, ``sh``, ``shell``: commands, run by bash (``set -euo pipefail``); each must exit
  0. Install commands (``pip install …``, ``python -m pip install …``) are not run: the tests
  run in the installed project (CI installs every extra). ``$EDITOR`` is ``true``: the
  reader's edit is left out.
* any other (none, ``json``, ``toml``, ``yaml``, ``text``): output or data, never run.

``<!-- extra: needs_X -->`` in a document about an optional extra gives its test that
extra's marker (tests/conftest.py skips it, naming the install, where the extra is missing).

``<!-- not-run: REASON -->`` on the line before a fence skips a block that cannot run here
(an API key, a GPU, a cluster, a person at the keyboard, a server that runs until Ctrl-C);
the reason is required, and a marker before a block that is never run is refused.

Each document runs in a fresh folder standing for the repository root, as the docs assume:
``examples/`` is the checkout's and ``../shared`` the shared data beside it. Blocks of every
kind run in document order in that folder, offline: no API key in the environment.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from tests.paths import SHARED_DATA

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
PYTHON, SHELL = "python", "shell"
LANGUAGES = {"python": PYTHON, "bash": SHELL, "sh": SHELL, "shell": SHELL}
FENCE = re.compile(r"^(?P<indent>[ \t]*)```(?P<lang>[\w+-]*)[^\n]*\n(?P<body>.*?)^(?P=indent)```"
                   r"[ \t]*$", re.M | re.S)
MARKER = r"<!--\s*not-run:(?P<reason>(?:(?!-->).)*)-->"
#: A marker on the line right before a fence: the text before the fence ends with it.
MARKER_BEFORE = re.compile(MARKER + r"[ \t]*\n[ \t]*\Z", re.S)
EXTRA_NOTE = re.compile(r"<!--\s*extra:\s*(needs_\w+)\s*-->")
FILE_HEADER = re.compile(r"#\s*(?P<name>[\w.-]+\.py)\s*$")
# Install commands are the test environment's own; bash runs everything else.
SHELL_PRELUDE = """set -euo pipefail
pip() { [ "${1-}" = install ] || command pip "$@"; }
python() { if [ "${1-}" = -m ] && [ "${2-}" = pip ] && [ "${3-}" = install ]; then return 0; fi
           command python "$@"; }
"""
SHELL_TIMEOUT_S = 900


class DocError(Exception):
    """A document that breaks the rules of this module, or a block of it that fails."""


@dataclass(frozen=True)
class Block:
    """One fenced block: where it is, its kind (PYTHON, SHELL or None: never run), its text,
    and the reason given for not running it."""

    document: Path
    line: int
    kind: str | None
    text: str
    not_run: str | None

    @property
    def where(self) -> str:
        return f"{_name(self.document)}:{self.line}"

    @property
    def file_name(self) -> str | None:
        """The file a python block stands for (its first line is ``# NAME.py``), if any."""
        first = self.text.split("\n", 1)[0]
        match = FILE_HEADER.fullmatch(first) if self.kind == PYTHON else None
        return match["name"] if match else None


def blocks_of(document: Path, text: str | None = None) -> list[Block]:
    """The fenced blocks of `document`, in order; `DocError` for a not-run marker without a
    reason, or one that is not right before a block that would run."""
    text = document.read_text(encoding="utf-8") if text is None else text
    blocks, used = [], set()
    for fence in FENCE.finditer(text):
        line = text.count("\n", 0, fence.start()) + 1
        kind = LANGUAGES.get(fence["lang"])
        marker = MARKER_BEFORE.search(text, 0, fence.start())
        where = f"{_name(document)}:{line}"
        if marker is not None:
            used.add(marker.start())
            if not marker["reason"].strip():
                raise DocError(f"{where}: <!-- not-run: … --> needs a reason")
            if kind is None:
                raise DocError(f"{where}: a not-run marker before a block that is never run "
                               f"(```{fence['lang']}: output or data)")
        body = "\n".join(row[len(fence["indent"]):] for row in fence["body"].split("\n"))
        blocks.append(Block(document, line, kind, body,
                            marker["reason"].strip() if marker else None))
    for marker in re.finditer(MARKER, text, re.S):
        if marker.start() not in used:
            line = text.count("\n", 0, marker.start()) + 1
            raise DocError(f"{_name(document)}:{line}: a not-run marker that is not on the "
                           "line before a fenced block")
    return blocks


def _name(document: Path) -> str:
    return str(document.relative_to(ROOT)) if document.is_relative_to(ROOT) else document.name


def runnable(document: Path) -> list[Block]:
    return [b for b in blocks_of(document) if b.kind is not None and b.not_run is None]


def run_document(document: Path, workspace: Path, blocks: list[Block] | None = None) -> None:
    """Run `document`'s runnable blocks in order in `workspace` (its current folder for
    python blocks too); `DocError` naming the block that fails."""
    namespace: dict = {"__name__": "__doc_example__"}
    env = _offline_environment()
    for block in runnable(document) if blocks is None else blocks:
        if block.file_name:
            compile(block.text, block.where, "exec")  # a file with a syntax error fails here
            (workspace / block.file_name).write_text(block.text, encoding="utf-8")
        elif block.kind == PYTHON:
            try:
                exec(compile(block.text, block.where, "exec"), namespace)  # our own docs
            except Exception as exc:  # any failure of a documented example
                raise DocError(f"{block.where}: {type(exc).__name__}: {exc}") from exc
        else:
            _run_shell(block, workspace, env)


def _run_shell(block: Block, workspace: Path, env: dict[str, str]) -> None:
    done = subprocess.run(["bash", "-c", SHELL_PRELUDE + block.text], cwd=workspace, env=env,
                          stdin=subprocess.DEVNULL, capture_output=True, text=True,
                          timeout=SHELL_TIMEOUT_S)
    if done.returncode != 0:
        tail = (done.stdout[-1500:] + done.stderr[-3000:]).strip()
        raise DocError(f"{block.where}: exit {done.returncode}\n{tail}")


def _offline_environment() -> dict[str, str]:
    """This process's environment without API keys or COCOBENCH_RUN_* settings, with this
    interpreter's scripts (`cocobench`) first on PATH."""
    env = {k: v for k, v in os.environ.items() if not _machine_setting(k)}
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    env["EDITOR"] = "true"
    return env


def _machine_setting(name: str) -> bool:
    """An API key or a run setting of the machine running the tests: never seen by a block."""
    return name.endswith("_API_KEY") or name.startswith("COCOBENCH_RUN_")


@pytest.fixture
def workspace(tmp_path, monkeypatch) -> Path:
    """A folder standing for the repository root: its examples, the shared data beside it."""
    root = tmp_path / "repo"
    root.mkdir()
    (root / "examples").symlink_to(ROOT / "examples")
    if SHARED_DATA.is_dir():
        (tmp_path / "shared").symlink_to(SHARED_DATA.parent)
    for name in [n for n in os.environ if _machine_setting(n)]:
        monkeypatch.delenv(name)  # python blocks run in this process
    monkeypatch.chdir(root)
    return root


# -- the rules ----------------------------------------------------------------------------

def test_every_block_runs_or_says_why_not():
    everything = [b for document in DOCUMENTS for b in blocks_of(document)]  # rules checked
    assert all(b.kind is not None for b in everything if b.not_run)
    quickstart = runnable(ROOT / "README.md")[0]  # the main job itself, as written
    assert "cocobench run --model greedy --baselines" in quickstart.text


def test_a_marker_needs_a_reason_and_a_block_to_skip(tmp_path):
    doc = tmp_path / "doc.md"
    with pytest.raises(DocError, match=r"doc.md:3: .*needs a reason"):
        blocks_of(doc, "text\n<!-- not-run: -->\n```bash\nfalse\n```\n")
    with pytest.raises(DocError, match=r"doc.md:3: .*never run"):
        blocks_of(doc, "text\n<!-- not-run: output -->\n```\nprinted\n```\n")
    with pytest.raises(DocError, match=r"doc.md:1: .*not on the line before"):
        blocks_of(doc, "<!-- not-run: far away -->\n\n```bash\nfalse\n```\n")
    [block] = blocks_of(doc, "- a list\n  <!-- not-run: a GPU -->\n  ```bash\n  nvidia-smi\n"
                             "  ```\n")
    assert (block.line, block.kind, block.text, block.not_run) == (3, SHELL, "nvidia-smi\n",
                                                                  "a GPU")


def test_a_failing_block_is_named_with_its_line(tmp_path, workspace):
    doc = tmp_path / "doc.md"
    doc.write_text("```python\nanswer = 42\n```\n\n```python\nassert answer == 41\n```\n"
                   "```bash\ncocobench run --model greedy --conditions C9_image --out r\n```\n")
    with pytest.raises(DocError, match=r"doc.md:5: AssertionError"):
        run_document(doc, workspace)
    shell = [b for b in blocks_of(doc) if b.kind == SHELL]
    with pytest.raises(DocError, match=r"doc.md:8: exit 2\n.*unknown condition 'C9_image'"):
        run_document(doc, workspace, shell)


def test_a_file_block_is_written_and_install_commands_are_the_environments_own(
        tmp_path, workspace):
    doc = tmp_path / "doc.md"
    doc.write_text("```python\n# hello.py\nopen('ran', 'w')\n```\n"
                   "```bash\npython -m pip install -e . && pip install nothing-such && "
                   "python hello.py\n```\n")
    run_document(doc, workspace)
    assert (workspace / "hello.py").is_file() and (workspace / "ran").is_file()


# -- the documents ------------------------------------------------------------------------

def _to_run(document: Path) -> bool:
    """Whether `document` has a block to run (a document breaking the rules is collected,
    and its test names the rule, rather than failing the whole module's collection)."""
    try:
        return bool(runnable(document))
    except DocError:
        return True


def _needs_shared(document: Path) -> list:
    text = document.read_text(encoding="utf-8")
    uses = "../shared" in text
    # A document about an extra says so (``<!-- extra: needs_inspect -->``): its test
    # carries that extra's marker, and skips with the install command where it is missing.
    extras = [getattr(pytest.mark, m) for m in EXTRA_NOTE.findall(text)]
    return [pytest.mark.skipif(uses and not SHARED_DATA.is_dir(),
                               reason=f"no shared data at {SHARED_DATA}"), *extras]


@pytest.mark.slow
@pytest.mark.parametrize("document", [
    pytest.param(d, id=_name(d), marks=_needs_shared(d)) for d in DOCUMENTS if _to_run(d)])
def test_the_document_runs_as_written(document, workspace):
    run_document(document, workspace)
