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


def _report_row(report: str, first_cells: tuple[str, ...]) -> list[str]:
    """The cells of the row of ``report`` (a docs/ page a command writes) that starts with ``first_cells``."""
    for line in (REPO / "docs" / report).read_text().splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if tuple(cells[:len(first_cells)]) == first_cells:
            return cells
    raise AssertionError(f"docs/{report}: no row {first_cells}")


def test_the_figures_docs_estimators_copies_are_those_of_their_reports():
    """docs/estimators.md repeats a few figures of the generated reports: instructions per step
    (docs/benchmarks.md, double) and the β RMSE on the continuous DLC and the μ 1 DLCs
    (docs/accuracy.md); each must be the report's, rounded as written."""
    text = (REPO / "docs" / "estimators.md").read_text()
    rows = {line.split("|")[1].strip(): line for line in text.splitlines() if line.startswith("| `")}
    for name in ("kf2dof", "switching", "fusion"):
        instructions = float(_report_row("benchmarks.md", (name, "double"))[2])
        assert f"{instructions:.0f} instr/step" in rows[f"`{name}`"], name
    fusion = rows["`fusion`"]
    continuous = _report_row("accuracy.md", ("continuous_dlc", "yes", "no", "fusion"))
    assert f"continuous DLC max {float(continuous[4]):.3f}°, RMSE {float(continuous[6]):.3f}°" in fusion
    dlc = [float(_report_row("accuracy.md", (f"dlc(mu=1.0,speed_kmh={v})",) + cells + ("fusion",))[6])
           for v, cells in (("80.0", ("yes", "no")), ("120.0", ("no", "no")))]
    assert f"DLC 80 / 120 km/h μ 1 {dlc[0]:.3f}° / {dlc[1]:.3f}°" in fusion
    kf2dof = _report_row("accuracy.md", ("continuous_dlc", "yes", "no", "kf2dof"))
    assert f"continuous DLC {float(kf2dof[6]):.3f}°" in rows["`kf2dof`"]


def test_the_readme_estimator_table_gives_the_figures_of_its_reports():
    """The README's estimator table: the β RMSE on the continuous DLC is docs/accuracy.md's, the one on
    the real lap (identified without the reference) docs/real.md's, each rounded as written."""
    text = (REPO / "README.md").read_text()
    table = text[text.index("## Estimators"):].split("\n\n")[1]
    rows = {cells[0]: cells for cells in ([c.strip() for c in re.split(r"(?<!\\)\|", line.strip().strip("|"))]
                                          for line in table.splitlines() if line.startswith("| `"))}
    for name in ("kf2dof", "switching", "fusion", "ekf_rls"):
        continuous = float(_report_row("accuracy.md", ("continuous_dlc", "yes", "no", name))[6])
        lap = float(_report_row("real.md", (name, "identified without the reference columns"))[2])
        assert rows[f"`{name}`"][3] == f"{continuous:.3f}°", name
        assert rows[f"`{name}`"][4].startswith(f"{lap:.2f}°"), name
    ukf, aukf = (float(_report_row("accuracy.md", ("continuous_dlc", "yes", "no", n))[6]) for n in ("ukf", "aukf"))
    assert rows["`ukf` / `aukf`"][3] == f"{ukf:.3f}° / {aukf:.3f}°"


def test_the_readmes_never_silent_claims_are_those_of_their_reports():
    """The README says how many runs the disturbance matrix has and that none is silently wrong
    (docs/robustness.md, "K of N runs have a silent stretch beyond 0.5 s"), how many of its
    model-based runs are no better than beta = 0 ("K of N runs break it"), and that no estimator is
    silent over 0.5 s on the real lap (docs/real.md's summary line)."""
    readme = (REPO / "README.md").read_text()
    (claimed,) = re.findall(r"Across the (\d+) runs of the disturbance matrix \(both truth cars\) no estimator "
                            r"is silently wrong", " ".join(readme.split()))
    (silent, runs), = re.findall(r"^(\d+) of (\d+) runs have a silent stretch beyond 0\.5 s",
                                 (REPO / "docs" / "robustness.md").read_text(), flags=re.MULTILINE)
    assert (claimed, silent) == (runs, "0")
    (worse_claimed,) = re.findall(r"(\d+ of its \d+) model-based runs, unflagged, are no better than β = 0",
                                  " ".join(readme.split()))
    (worse,) = re.findall(r"\. (\d+) of (\d+) runs break it[:.]", (REPO / "docs" / "robustness.md").read_text())
    assert worse_claimed == f"{worse[0]} of its {worse[1]}"
    assert "No estimator is silently wrong for more than 0.5 s on it." in " ".join(readme.split())
    assert "* Silent stretches over 0.5 s on the whole lap (|beta error| > 2 deg, status 0): none." in (
        REPO / "docs" / "real.md").read_text()
