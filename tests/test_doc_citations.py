"""Every section number and anchor that the sources cite in the docs exists.

Comments and docstrings send readers to the documents users have, by section number
("docs/world-and-laws.md §4.5", "world-and-laws §3-4", "§4.5, §4.6") or by link anchor
("docs/interface.md#observations"). When a document is renumbered or a heading renamed, such a
citation silently points at the wrong rule or nowhere. This test reads the citations in every
source file under envs/, rust/, tests/, training/ and benchmarks/, and the links between the
Markdown documents (docs/*.md, README.md), and checks that the cited document exists, that it has
a heading with that number, and that the anchor is the GitHub slug of one of its headings. It
also checks that no source still cites, by its bare name, a document that is not in the repository.
"""

import re
from functools import cache
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SOURCE_DIRS = ("envs", "rust", "tests", "training", "benchmarks")
SOURCE_SUFFIXES = {".py", ".rs", ".js", ".yaml"}
SKIPPED_DIRS = {".venv", "target", "__pycache__", "node_modules"}

NUM = r"\d+(?:\.\d+)*"
# A document name (with or without .md) followed by one section or a run of them:
# "§4.5", "§1–§5", "§3-4", "§4.5, §4.6", "§4.7 and §4.8".
SECTION_CITE = re.compile(rf"(?<![\w/.-])((?:docs/)?[\w-]+)(\.md)? §({NUM}(?:\s*[–-]\s*§?{NUM}|(?:,\s*|\s+and\s+)§{NUM})*)")
# A link to a heading of another document: "docs/interface.md#observations", "(../RESULTS.md#x)".
ANCHOR_LINK = re.compile(r"(?<![\w/.-])((?:\.\./)*(?:[\w.-]+/)*[\w.-]+\.md)#([\w-]+)")
# A link to a heading of the same Markdown document: "](#observations)".
LOCAL_ANCHOR = re.compile(r"\]\(#([\w-]+)\)")
# The name the retired citations used; identifiers such as FOO_SPEC_BAR do not match.
OLD_CITATION = re.compile(r"\bSPEC\b")


def slug(heading: str) -> str:
    """GitHub's anchor for a heading: lower case, punctuation dropped (letters such as ω, digits,
    '_' and '-' stay), each space a hyphen: "1.8 The laws' modes" -> "18-the-laws-modes"."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


@cache
def headings(doc: Path) -> tuple[frozenset, frozenset]:
    """(section numbers, anchors) of a Markdown document's headings, outside fenced code."""
    numbers, anchors, fenced = set(), set(), False
    for line in doc.read_text(encoding="utf-8").splitlines():
        if line.lstrip().startswith("```"):
            fenced = not fenced
        m = None if fenced else re.match(r"#{1,6}\s+(.*?)\s*#*$", line)
        if not m:
            continue
        if n := re.match(rf"({NUM})\.?\s", m.group(1)):
            numbers.add(n.group(1))
        base = anchor = slug(m.group(1))
        k = 0
        while anchor in anchors:  # GitHub numbers repeated headings: x, x-1, x-2, ...
            k += 1
            anchor = f"{base}-{k}"
        anchors.add(anchor)
    return frozenset(numbers), frozenset(anchors)


def resolve(name: str, source: Path, link: bool = False) -> Path | None:
    """The document a citation in `source` names. A link in a Markdown file is relative to its
    folder; any other citation may also be relative to the repository root or to docs/."""
    folders = [source.parent] if link and source.suffix == ".md" else [source.parent, ROOT, ROOT / "docs"]
    return next((f / name for f in folders if (f / name).is_file()), None)


def problems(text: str, source: Path) -> list[str]:
    """What is wrong with the citations in `text`, read as the contents of `source`."""
    out = []
    for m in SECTION_CITE.finditer(text):
        name, md, run = m.groups()
        doc = resolve(name + ".md", source)
        if doc is None:
            if md:  # "x.md §n" must name a document; a bare "source §1.5" may be anything
                out.append(f"{m.group(0)!r}: no document {name}.md")
            continue
        numbers, _ = headings(doc)
        out += [f"{m.group(0)!r}: {doc.name} has no section {n}" for n in re.findall(NUM, run) if n not in numbers]
    for m in ANCHOR_LINK.finditer(text):
        doc = resolve(m.group(1), source, link=True)
        if doc is None:
            out.append(f"{m.group(0)!r}: no document {m.group(1)}")
        elif m.group(2) not in headings(doc)[1]:
            out.append(f"{m.group(0)!r}: {doc.name} has no heading with anchor #{m.group(2)}")
    if source.suffix == ".md":
        anchors = headings(source)[1]
        out += [f"'#{a}': {source.name} has no heading with that anchor" for a in LOCAL_ANCHOR.findall(text) if a not in anchors]
    return out


def sources() -> list[Path]:
    """The source files to scan; not this one, whose examples of broken citations are deliberate."""
    files = [p for d in SOURCE_DIRS for p in (ROOT / d).rglob("*") if p.suffix in SOURCE_SUFFIXES and p.is_file()]
    return sorted(p for p in files if not SKIPPED_DIRS.intersection(p.relative_to(ROOT).parts) and p != Path(__file__).resolve())


DOCUMENTS = sorted((ROOT / "docs").glob("*.md")) + [ROOT / "README.md"]


def test_the_docs_are_found():
    """A sanity check for the scans below: they see the sources and the cited documents."""
    assert len(sources()) > 100 and (ROOT / "docs" / "world-and-laws.md") in DOCUMENTS
    numbers, anchors = headings(ROOT / "docs" / "world-and-laws.md")
    assert {"1.8", "4.4.1", "6"} <= numbers and "18-the-laws-modes" in anchors


@pytest.mark.parametrize("group", ["sources", "documents"])
def test_cited_sections_and_anchors_exist(group):
    files = sources() if group == "sources" else DOCUMENTS
    found = [f"{p.relative_to(ROOT)}: {e}" for p in files for e in problems(p.read_text(encoding="utf-8"), p)]
    assert not found, "citations of missing sections or anchors:\n" + "\n".join(found)


def test_sources_cite_only_the_docs():
    found = [f"{p.relative_to(ROOT)}:{i}: {line.strip()}" for p in sources() for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if OLD_CITATION.search(line)]
    assert not found, "cite docs/world-and-laws.md (or the doc that holds the fact) instead:\n" + "\n".join(found)


@pytest.mark.parametrize(
    "text, expected",
    [
        ("see docs/world-and-laws.md §4.5 and §4.4.1", []),
        ("see docs/world-and-laws.md §9.9", ["has no section 9.9"]),
        ("world-and-laws §3-4, interface.md §99", ["interface.md has no section 99"]),
        ("docs/world-and-laws.md §4.7, §4.9", ["has no section 4.9"]),
        ("docs/nowhere.md §1", ["no document docs/nowhere.md"]),
        ("source §9.9 and document §1.4", []),
        ("docs/world-and-laws.md#18-the-laws-modes, docs/interface.md#observations.", []),
        ("docs/world-and-laws.md#18-the-law-modes", ["no heading with anchor #18-the-law-modes"]),
    ],
)
def test_the_checker_catches_broken_citations(text, expected):
    found = problems(text, ROOT / "tests" / "example.py")
    assert len(found) == len(expected) and all(e in f for e, f in zip(expected, found)), found


def test_slugs_follow_github():
    assert slug("2. From a desired velocity to (v, ω): the saturator") == "2-from-a-desired-velocity-to-v-ω-the-saturator"
    assert slug("Entity observations (`env.observation: entities`)") == "entity-observations-envobservation-entities"
    assert slug("The shared observation (`shared_space=True`)") == "the-shared-observation-shared_spacetrue"
