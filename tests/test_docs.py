"""The manual (docs/, mkdocs.yml) and the README: the flags page is what the parsers say, the
site builds with ``mkdocs build --strict`` (every link and anchor checked), every page is in the
nav, and the README stays a short tour that links each page. The snippets on the pages run in
tests/test_doc_snippets.py."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import yaml

from hitrobot_server import docs_flags
from hitrobot_server.config import FLAG_ORDER, flag_spellings

REPO = Path(__file__).resolve().parents[1]
DOCS = REPO / "docs"
README_MAX_LINES = 250


def manual_pages() -> set[str]:
    return {p.name for p in DOCS.glob("*.md")}


def nav_pages() -> list[str]:
    """The pages mkdocs.yml's nav lists (its python tags left unparsed: only the nav is read)."""
    text = (REPO / "mkdocs.yml").read_text()
    nav = yaml.safe_load(text[text.index("\nnav:"):text.index("\n\n", text.index("\nnav:"))])
    return [next(iter(item.values())) for item in nav["nav"]]


def test_the_flags_page_is_what_the_parsers_say():
    """Regenerate it with `python -m hitrobot_server.docs_flags > docs/flags.md`."""
    assert (DOCS / "flags.md").read_text() == docs_flags.page(), (
        "docs/flags.md differs from the parsers: python -m hitrobot_server.docs_flags > "
        "docs/flags.md")


def test_the_flags_page_names_every_setting():
    page = docs_flags.page()
    for name in FLAG_ORDER:
        assert f"`{flag_spellings(name)[0]}`" in page and f"`{name}`" in page, name


def test_the_flags_page_would_show_a_new_flag():
    """The page is built from the parser: a flag added to it appears on the page."""
    parser = docs_flags.build_parser()
    parser.add_argument("--brand-new-flag", help="a flag nobody documented by hand")
    rows = docs_flags.table(docs_flags.documented(parser), toml=False)
    assert "| `--brand-new-flag` `BRAND_NEW_FLAG` | a flag nobody documented by hand |" in rows


def test_every_page_is_in_the_nav_and_every_nav_entry_exists():
    assert sorted(nav_pages()) == sorted(manual_pages())


def test_the_manual_builds_strictly(tmp_path):
    """`mkdocs build --strict`: a broken link, a missing anchor or a page outside the nav is a
    warning, and strict makes it an error. docs/_incoming/ is excluded."""
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "site")],
        cwd=REPO, capture_output=True, text=True, timeout=110,
        env={"NO_MKDOCS_2_WARNING": "1", "PATH": str(Path(sys.executable).parent)})
    assert out.returncode == 0, out.stdout + out.stderr
    assert (tmp_path / "site" / "flags" / "index.html").is_file()
    assert not (tmp_path / "site" / "_incoming").exists()


def test_the_strict_build_catches_a_broken_link(tmp_path):
    """The checker itself: the same config over a page with a dead link fails."""
    docs = tmp_path / "docs"
    docs.mkdir()
    (docs / "index.md").write_text("# x\n\n[gone](nowhere.md) and [no anchor](#not-here)\n")
    config = (REPO / "mkdocs.yml").read_text()
    config = re.sub(r"\nnav:\n(  - .*\n)+", "\nnav:\n  - Home: index.md\n", config)
    (tmp_path / "mkdocs.yml").write_text(config)
    out = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path / "s")],
        cwd=tmp_path, capture_output=True, text=True, timeout=110,
        env={"NO_MKDOCS_2_WARNING": "1", "PATH": str(Path(sys.executable).parent)})
    assert out.returncode != 0
    assert "nowhere.md" in out.stderr and "not-here" in out.stderr


def test_the_readme_is_a_short_tour_linking_every_page():
    readme = (REPO / "README.md").read_text()
    assert len(readme.splitlines()) <= README_MAX_LINES
    linked = {(REPO / target).resolve() for target in re.findall(r"\]\(([\w/.-]+\.md)", readme)}
    pages = {(DOCS / name).resolve(): name for name in manual_pages()}  # a link: the file
    missing = sorted(name for path, name in pages.items() if path not in linked)
    assert not missing, f"pages the README does not link: {missing}"
    assert "python -m tests.run" in readme and "bash .ci/run" in readme


def test_the_readme_has_no_measured_figures():
    """Figures of a run (rates, latencies, sizes measured) belong in docs/benchmarks.md."""
    readme = (REPO / "README.md").read_text()
    assert not re.search(r"\d\s*(k )?msgs?/s|\d\s*µs|\bp99\b|\bp50\b", readme)


def test_every_module_path_architecture_names_exists():
    """ARCHITECTURE.md is the map of the tree as it is: each `dir/file.py` or `dir/` it names is
    a file or folder of the repository (under hitrobot_server/ its path may start at any
    package, as the page writes `ground/acks.py` inside "Inside nodes/")."""
    text = (REPO / "ARCHITECTURE.md").read_text()
    named = {m for m in re.findall(r"`([\w./-]+/[\w./-]*)`", text)
             if not m.startswith(("/", ".")) and "//" not in m}
    tree = [p.relative_to(REPO).as_posix() for p in REPO.rglob("*")
            if not {".git", "node_modules", ".venv-ci", ".venv"} & set(p.parts)]
    named |= set(re.findall(r"`(\w+\.(?:py|js|md))`", text))  # a bare file name, in context
    missing = sorted(n for n in named
                     if not any(t == n.rstrip("/") or t.endswith("/" + n.rstrip("/"))
                                for t in tree))
    assert not missing, f"ARCHITECTURE.md names paths the tree does not have: {missing}"
