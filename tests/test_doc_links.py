"""Links between the docs: every relative link to a markdown file names a file that exists and,
with an anchor, a heading of that file (GitHub's anchor: lower case, punctuation dropped,
spaces as hyphens)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCUMENTS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]
LINK = re.compile(r"\]\(([^)\s]+\.md)(?:#([^)\s]+))?\)")
HEADING = re.compile(r"^#{1,6}\s+(.+?)\s*$", re.MULTILINE)
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)


def anchor(heading: str) -> str:
    """GitHub's anchor of a heading."""
    text = re.sub(r"[^\w\- ]", "", heading.strip().lower())
    return text.replace(" ", "-")


def anchors(path: Path) -> set[str]:
    text = FENCE.sub("", path.read_text(encoding="utf-8"))  # `# comments` in code blocks
    return {anchor(h) for h in HEADING.findall(text)}


def test_anchor_follows_githubs_rule():
    assert anchor("Write it in your own file") == "write-it-in-your-own-file"
    assert anchor("Decisions: what `decide` returns") == "decisions-what-decide-returns"
    assert anchor("Arms: paired differences") == "arms-paired-differences"


@pytest.mark.parametrize("document", DOCUMENTS, ids=lambda p: p.name)
def test_every_link_to_a_doc_names_an_existing_file_and_heading(document):
    broken = []
    for target, fragment in LINK.findall(document.read_text(encoding="utf-8")):
        if "://" in target:
            continue
        path = (document.parent / target).resolve()
        if not path.is_file():
            broken.append(f"{target}: no such file")
        elif fragment and fragment not in anchors(path):
            broken.append(f"{target}#{fragment}: no such heading")
    assert not broken, f"{document.name}: {broken}"
