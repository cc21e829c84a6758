"""Every relative link of the README and the docs pages reaches a file of the repository, and a link to
a heading (`page.md#heading`) reaches a heading that page has, as GitHub names its anchors."""
import re
from pathlib import Path

import pytest

from rigs.harness import REPO

PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
FENCE = re.compile(r"^```.*?^```", re.S | re.M)
CODE_SPAN = re.compile(r"`[^`\n]*`")


def prose(text: str) -> str:
    """The page without its code blocks and code spans, where a `[x](y)` is not a link."""
    return CODE_SPAN.sub("", FENCE.sub("", text))


def anchors(page: Path) -> set[str]:
    """GitHub's anchor of each heading: lower case, punctuation dropped, spaces as hyphens, -1, -2... on
    repeats."""
    seen: dict[str, int] = {}
    names = set()
    for heading in re.findall(r"^#{1,6}\s+(.+?)\s*#*$", FENCE.sub("", page.read_text()), re.M):
        text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading).replace("`", "")
        slug = re.sub(r"[^\w\- ]", "", text.lower()).replace(" ", "-")
        names.add(f"{slug}-{seen[slug]}" if slug in seen else slug)
        seen[slug] = seen.get(slug, 0) + 1
    return names


def broken_links(page: Path) -> list[str]:
    broken = []
    for target in LINK.findall(prose(page.read_text())):
        if re.match(r"[a-z][a-z0-9+.-]*:", target):  # http:, https:, mailto: are not checked here
            continue
        path, _, anchor = target.partition("#")
        goal = (page.parent / path).resolve() if path else page
        if REPO not in goal.parents and goal != REPO:
            broken.append(f"{target}: outside the repository")
        elif not goal.exists():
            broken.append(f"{target}: no such file")
        elif anchor and goal.suffix == ".md" and anchor not in anchors(goal):
            broken.append(f"{target}: {goal.name} has no heading #{anchor}")
    return broken


@pytest.mark.parametrize("page", PAGES, ids=[str(p.relative_to(REPO)) for p in PAGES])
def test_every_relative_link_resolves(page):
    assert broken_links(page) == []


def test_the_check_finds_a_missing_file_a_missing_heading_and_a_way_out(tmp_path, monkeypatch):
    monkeypatch.setattr("tests.test_docs_links.REPO", tmp_path)
    (tmp_path / "docs").mkdir()
    (tmp_path / "docs" / "there.md").write_text("# A heading: `with code`\n\n## A heading: with code\n")
    page = tmp_path / "docs" / "page.md"
    page.write_text("[ok](there.md#a-heading-with-code) [ok](there.md#a-heading-with-code-1) [ok](#top)\n"
                    "# Top\n[gone](missing.md) [gone](there.md#nowhere) [out](../../etc/passwd)\n"
                    "`[not a link](missing.md)` [web](https://example.org/missing.md)\n")
    assert broken_links(page) == ["missing.md: no such file", "there.md#nowhere: there.md has no heading #nowhere",
                                  "../../etc/passwd: outside the repository"]
