"""The documentation cannot drift from the code: the reference pages generated from it are up to
date, the README stays a front door, and nothing cites a document the repository does not hold."""

from __future__ import annotations

import re
import subprocess

from locations import REPO

from vsegen.harness.starter import reference_docs

README_LINES = 250
TEXT_SUFFIXES = (".py", ".toml", ".md", ".j2", ".sh", ".c", ".h", ".txt")
OUTSIDE_DOCUMENTS = re.compile("shared" + r"/|design\.md")   # split, so this file does not match itself
"""Documents of the team that built vsegen, outside the repository: the product never cites them."""


def test_the_generated_reference_pages_are_up_to_date():
    for name, text in reference_docs.pages().items():
        assert (REPO / "docs" / name).read_text() == text, f"docs/{name} is stale: run `vsegen docs`"


def test_vsegen_docs_check_fails_on_a_stale_page(tmp_path, vsegen):
    (tmp_path / "vehicle-file.md").write_text("old\n")
    (tmp_path / "signals.md").write_text(reference_docs.signals_page())
    result = vsegen("docs", "--check", "--out", tmp_path)
    assert result.exit_code == 1
    assert "+# The vehicle file" in result.stdout and "run `vsegen docs`" in result.stderr


def test_every_vehicle_file_key_is_in_the_reference():
    page = reference_docs.vehicle_file_page()
    for _, fields, _ in reference_docs.COMMON_TABLES:
        for field in fields:
            assert f"| `{field.key}` |" in page
    for name, definition in reference_docs.DEFINITIONS.items():
        section = page.split(f"### [estimator.{name}]")[1].split("### ")[0]
        for field in definition.schema.fields:
            assert f"| `{field.key}` |" in section, f"{name}.{field.key}"


def test_the_readme_is_a_front_door():
    assert len((REPO / "README.md").read_text().splitlines()) <= README_LINES


def test_nothing_cites_a_document_outside_the_repository():
    tracked = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split()
    citing = [name for name in tracked if name.endswith(TEXT_SUFFIXES) and (REPO / name).is_file()
              and OUTSIDE_DOCUMENTS.search((REPO / name).read_text(errors="replace"))]
    assert citing == []


def test_markdown_links_inside_the_repository_resolve():
    broken = []
    for page in [REPO / "README.md", REPO / "CONTRIBUTING.md", *sorted((REPO / "docs").glob("*.md"))]:
        for target in re.findall(r"\]\(([^)#\s]+)(?:#[^)]*)?\)", page.read_text()):
            if "://" not in target and not (page.parent / target).exists():
                broken.append(f"{page.relative_to(REPO)} -> {target}")
    assert broken == []


def test_an_installed_vsegen_writes_every_page_a_user_needs(tmp_path, vsegen):
    """The conventions and log format, the vehicle-file reference and the signal catalogue come
    from the installed package (no docs/ folder needed)."""
    result = vsegen.process("docs", "--out", tmp_path / "docs", cwd=tmp_path)
    assert result.exit_code == 0, result.output
    written = {p.name for p in (tmp_path / "docs").iterdir()}
    assert written == {"conventions.md", "vehicle-file.md", "signals.md"}
    assert "## Log format" in (tmp_path / "docs" / "conventions.md").read_text()
