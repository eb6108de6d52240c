"""The README and the documentation site's sources (quick checks; CI builds the site itself).

- the README stays short, with the two Quick start commands in its first screen;
- every relative link of the README reaches a file of the repository;
- the API reference (docs/api.rst) names every public name of ``rdmesh.__all__``;
- the gallery (examples/) has at least six example scripts that sphinx-gallery can run;
- runs are labelled by date and commit, not by internal work periods.
"""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest
import rdmesh

ROOT = Path(__file__).resolve().parent.parent
README = ROOT / "README.md"
API = ROOT / "docs" / "api.rst"
EXAMPLES = ROOT / "examples"

#: Largest README, in bytes.
README_MAX_BYTES = 15_000
#: The Quick start commands, exactly as the README gives them, and the lines they must be in.
QUICK_START = ("bash scripts/quickstart.sh demo", "bash scripts/quickstart.sh test")
FIRST_SCREEN = 40

#: Files where runs are quoted: the README, the results file and the site's pages.
LABELLED = [
    "README.md",
    "benchmarks/RESULTS.md",
    *sorted(
        p.relative_to(ROOT).as_posix()
        for p in (ROOT / "docs").rglob("*")
        if p.suffix in {".md", ".rst"} and not {"_build", "auto_examples"} & set(p.parts)
    ),
]

# [text](target) and ![alt](target); the target ends at the first space or ")".
_LINK = re.compile(r"!?\[[^\]]*\]\(\s*<?([^)\s>]+)>?(?:\s+\"[^\"]*\")?\s*\)")


def _readme_links() -> list[str]:
    text = README.read_text(encoding="utf-8")
    # Links inside code blocks are not links.
    text = re.sub(r"```.*?```", "", text, flags=re.S)
    return _LINK.findall(text)


def test_readme_is_short():
    size = len(README.read_bytes())
    assert size <= README_MAX_BYTES, f"README.md is {size} bytes, more than {README_MAX_BYTES}"


def test_quick_start_in_the_first_screen():
    lines = README.read_text(encoding="utf-8").splitlines()[:FIRST_SCREEN]
    for command in QUICK_START:
        assert any(line.strip().startswith(command) for line in lines), (
            f"{command!r} is not in the first {FIRST_SCREEN} lines of README.md"
        )


def test_readme_link_pattern_finds_links():
    # The pattern itself: a picture, a page with an anchor, a URL and a bare anchor.
    sample = "![a](docs/x.png) [b](docs/y.md#z) [c](https://example.org) [d](#e)"
    assert _LINK.findall(sample) == ["docs/x.png", "docs/y.md#z", "https://example.org", "#e"]
    assert len(_readme_links()) >= 10


def test_readme_relative_links_exist():
    missing = []
    for target in _readme_links():
        if re.match(r"^[a-z][a-z0-9+.-]*:", target) or target.startswith("#"):
            continue  # a URL (https:, mailto:) or an anchor of the README itself
        path = target.split("#", 1)[0]
        if not (ROOT / path).exists():
            missing.append(target)
    assert not missing, f"README.md links to files that do not exist: {missing}"


@pytest.mark.parametrize("name", sorted(rdmesh.__all__))
def test_public_name_in_api_reference(name):
    text = API.read_text(encoding="utf-8")
    assert re.search(rf"(?<![\w.]){re.escape(name)}\b|rdmesh\.{re.escape(name)}\b", text), (
        f"rdmesh.{name} is public (rdmesh.__all__) but docs/api.rst does not name it"
    )


def test_gallery_has_six_runnable_examples():
    assert (EXAMPLES / "GALLERY_HEADER.rst").is_file()
    scripts = sorted(EXAMPLES.glob("plot_*.py"))
    assert len(scripts) >= 6, [s.name for s in scripts]
    for script in scripts:
        module = ast.parse(script.read_text(encoding="utf-8"))
        doc = ast.get_docstring(module)
        assert doc, f"{script.name}: sphinx-gallery needs a docstring with a title"
        title, underline = doc.strip().splitlines()[:2]
        assert underline == "=" * len(title), f"{script.name}: the title is not underlined"


@pytest.mark.parametrize("path", LABELLED)
def test_runs_are_labelled_by_date_and_commit(path):
    text = (ROOT / path).read_text(encoding="utf-8")
    found = re.findall(r"(?i)\bsessions? \d+", text)
    assert not found, f"{path} labels runs by work period ({found}); use the date and commit"
