"""Citations name the works (the docs' References page), never the numbers of files
that are not in the repository ("000 §2.2", "002 eq. 5.6")."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
WORKS = ("Šik 2012", "Almeida 2014", "Le Muzic 2012")
# a seed file's number where a work belongs: before a section, equation, figure, …
SEED_NUMBER = re.compile(
    r"(?<![\d,.])(?<!\d )\b00\d\b(?=\s*(?:#\s*)?(?:§|eq\.|Eq\.|Alg\.|Fig\."
    r"|Listing|Table|p\.)|'s\b|:| multi-strand)"
)


def _texts() -> list[Path]:
    found = [ROOT / "README.md", ROOT / "CHANGELOG.md", ROOT / "mkdocs.yml"]
    for folder in ("src", "tests", "benchmarks", "examples", "docs", "tools"):
        found += [
            p
            for p in (ROOT / folder).rglob("*")
            if p.suffix in (".py", ".md", ".toml", ".glsl")
            and "__pycache__" not in p.parts
            and ".egg-info" not in str(p)
        ]
    return found


def test_no_citation_names_a_seed_file_number():
    bad = [
        f"{p.relative_to(ROOT)}:{i}: {line.strip()}"
        for p in _texts()
        for i, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1)
        if SEED_NUMBER.search(line) and p.name != "test_citations.py"
    ]
    assert not bad, "cite the work (Šik 2012, Almeida 2014, Le Muzic 2012):\n" + "\n".join(bad)


def test_the_references_page_lists_every_work_cited():
    page = (ROOT / "docs" / "explanation" / "references.md").read_text(encoding="utf-8")
    references = page[page.index("# References") :]
    for work in WORKS:
        assert f"**{work}**" in references, work
    cited = {w for p in _texts() for w in WORKS if w in p.read_text(encoding="utf-8")}
    assert cited == set(WORKS)
