"""The README is a short front door and the docs hang together.

- README.md stays within 12 KiB (12,288 bytes): detail belongs in docs/, history in CHANGELOG.md;
- every page in docs/ is linked from the README, so none is orphaned;
- every relative link in README.md, CHANGELOG.md and docs/*.md points at a file that exists
  (anchors and external links are not followed).
"""

from __future__ import annotations

import re
from pathlib import Path
from urllib.parse import unquote

REPO = Path(__file__).resolve().parents[1]
README = REPO / "README.md"
README_MAX_BYTES = 12 * 1024

#: [text](target) and ![alt](target); the target ends at the first space or closing parenthesis.
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^```.*?^```", re.MULTILINE | re.DOTALL)


def pages() -> list[Path]:
    return [README, REPO / "CHANGELOG.md", *sorted((REPO / "docs").glob("*.md"))]


def relative_links(page: Path) -> list[str]:
    """Link targets of ``page`` outside code blocks that name a file of the repository."""
    text = FENCE.sub("", page.read_text(encoding="utf-8"))
    targets = [m.group(1) for m in LINK.finditer(text)]
    return [t for t in targets if not re.match(r"^[a-z][a-z0-9+.-]*:", t) and not t.startswith("#")]


def test_link_pattern_finds_links_and_images():
    text = "see [a](docs/a.md#x), ![pic](b.png) and [web](https://example.org)\n```\n[no](c.md)\n```\n"
    assert [m.group(1) for m in LINK.finditer(FENCE.sub("", text))] == ["docs/a.md#x", "b.png", "https://example.org"]


def test_readme_is_at_most_12_kib():
    size = len(README.read_bytes())
    assert size <= README_MAX_BYTES, f"README.md is {size} bytes; move detail to docs/ (limit {README_MAX_BYTES})"


def test_every_docs_page_is_linked_from_the_readme():
    linked = {(README.parent / unquote(t.split("#", 1)[0])).resolve() for t in relative_links(README)}
    orphans = [p.relative_to(REPO).as_posix() for p in sorted((REPO / "docs").glob("*.md")) if p.resolve() not in linked]
    assert orphans == [], f"not linked from README.md: {orphans}"


def test_every_relative_link_resolves():
    broken = []
    for page in pages():
        for target in relative_links(page):
            path = (page.parent / unquote(target.split("#", 1)[0])).resolve()
            if not path.exists():
                broken.append(f"{page.relative_to(REPO)}: {target}")
    assert broken == [], broken
    assert relative_links(README), "README.md links to nothing"
