"""An install that works anywhere: one `vsegen` namespace in the wheel, projects found from the
current directory (never the install location), `vsegen init` starter projects."""

from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest
from locations import REPO

from vsegen.harness.logs.channels import read_channel_map
from vsegen.harness.project.paths import Project, ProjectError, project
from vsegen.harness.project.vehicles import load_vehicle
from vsegen.harness.starter.files import MAPPED_BY_DEFAULT, StarterError, init_project


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel built from this checkout."""
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "--no-build-isolation", "-w", str(out),
                    str(REPO)], check=True, capture_output=True)
    return next(out.glob("vsegen-*.whl"))


def test_the_wheel_installs_everything_under_one_vsegen_namespace(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    top = {name.split("/")[0] for name in names}
    assert {t for t in top if not t.endswith(".dist-info")} == {"vsegen"}
    for needed in ("vsegen/harness/cli/__init__.py", "vsegen/model/estimators/kf2dof.py",
                   "vsegen/codegen/templates/step.c.j2", "vsegen/harness/target/misra_baseline.json",
                   "vsegen/harness/host/runner.c.j2", "vsegen/harness/verify/fuzz.c.j2",
                   "vsegen/harness/campaign/report.html.j2",
                   "vsegen/harness/target/pil_main.c.j2", "vsegen/harness/target/boards/mps2.ld",
                   "vsegen/harness/starter/conventions.md",
                   "vsegen/vehicles/c_class.toml"):
        assert needed in names


def test_the_project_is_the_nearest_folder_with_vehicles(tmp_path):
    (tmp_path / "vehicles").mkdir()
    (tmp_path / "logs" / "day1").mkdir(parents=True)
    assert project(tmp_path / "logs" / "day1").root == tmp_path.resolve()
    assert project(tmp_path / "logs" / "day1").generated == tmp_path.resolve() / "generated"


def test_the_default_vehicle_is_the_only_one_or_c_class(tmp_path):
    folder = Project(tmp_path)
    with pytest.raises(ProjectError, match="no vehicle file in"):
        folder.default_vehicle()
    (tmp_path / "vehicles").mkdir()
    (tmp_path / "vehicles" / "mine.toml").write_text("")
    assert folder.default_vehicle().name == "mine.toml"
    (tmp_path / "vehicles" / "other.toml").write_text("")
    with pytest.raises(ProjectError, match="2 vehicle files .* expected --vehicle FILE"):
        folder.default_vehicle()
    (tmp_path / "vehicles" / "c_class.toml").write_text("")
    assert folder.default_vehicle().name == "c_class.toml"


@pytest.mark.parametrize("like", ["c_class", "rwd_saloon"])
def test_init_writes_a_vehicle_file_that_loads_as_the_shipped_car(tmp_path, like):
    written = init_project(tmp_path / "proj", like)
    assert sorted(p.name for p in written) == ["README.md", "car.toml", "channels.toml"]
    car = load_vehicle(tmp_path / "proj" / "vehicles" / "car.toml")
    shipped = load_vehicle(REPO / "vehicles" / f"{like}.toml")
    assert car.vehicle == shipped.vehicle and car.estimators == shipped.estimators
    assert (tmp_path / "proj" / "vehicles" / "car.toml").read_text().startswith("# Your car's vehicle file")


def test_init_writes_a_channel_map_that_reads(tmp_path):
    init_project(tmp_path)
    mapping = read_channel_map(tmp_path / "channels.toml")
    assert set(mapping.columns) == set(MAPPED_BY_DEFAULT)
    assert all(c.channel == c.name and c.scale == 1.0 for c in mapping.columns.values())


def test_init_never_overwrites(tmp_path):
    (tmp_path / "channels.toml").write_text("mine\n")
    with pytest.raises(StarterError, match="channels.toml: already exists"):
        init_project(tmp_path)
    assert (tmp_path / "channels.toml").read_text() == "mine\n"
    assert not (tmp_path / "vehicles").exists()


def test_init_refuses_an_unknown_car(tmp_path):
    with pytest.raises(StarterError, match="--like bus: no such shipped vehicle: expected one of c_class"):
        init_project(tmp_path, "bus")


def _tree(folder: Path) -> dict[str, float]:
    return {str(p.relative_to(folder)): p.stat().st_mtime for p in folder.rglob("*") if "__pycache__" not in p.parts}


@pytest.mark.slow
def test_the_wheel_in_a_fresh_venv_runs_init_generate_verify(wheel, tmp_path):
    venv = tmp_path / "venv"
    # System site-packages lend the dependencies (casadi, numpy, ...); vsegen itself comes from the wheel.
    subprocess.run([sys.executable, "-m", "venv", "--system-site-packages", str(venv)], check=True)
    subprocess.run([str(venv / "bin" / "python"), "-m", "pip", "install", "-q", "--no-deps", str(wheel)], check=True,
                   capture_output=True)
    env = {**os.environ, "PIP_ROOT_USER_ACTION": "ignore"}
    where = subprocess.run([str(venv / "bin" / "python"), "-c", "import vsegen.harness.cli as c; print(c.__file__)"],
                           cwd=tmp_path, capture_output=True, text=True, env=env, check=True).stdout
    installed = Path(where.strip()).parents[1]
    assert installed.is_relative_to(venv), where
    before = _tree(installed)

    def vsegen(*args: str, cwd: Path) -> subprocess.CompletedProcess:
        return subprocess.run([str(venv / "bin" / "vsegen"), *args], cwd=cwd, capture_output=True, text=True, env=env)

    outside = vsegen("generate", cwd=tmp_path)
    assert outside.returncode == 2 and outside.stderr.count("\n") == 1 and "no vehicle file in" in outside.stderr
    listed = vsegen("list", cwd=tmp_path)
    assert listed.returncode == 0 and "c_class.toml" in listed.stdout
    assert vsegen("init", "proj", cwd=tmp_path).returncode == 0
    project_folder = tmp_path / "proj"
    generated = vsegen("generate", "--estimator", "kf2dof", cwd=project_folder)
    assert generated.returncode == 0, generated.stderr
    assert (project_folder / "generated" / "car" / "kf2dof" / "vse_kf2dof.c").is_file()
    verified = vsegen("verify", "--estimator", "kf2dof", cwd=project_folder / "generated")   # from a subfolder
    assert verified.returncode == 0, verified.stderr
    assert "verify passed" in verified.stdout
    assert _tree(installed) == before, "vsegen wrote into its install location"


def test_every_package_folder_is_in_the_wheel_list():
    """pyproject lists the sub-packages explicitly (package-dir maps them under vsegen): a new
    folder with an __init__.py must be listed, or the wheel leaves it out."""
    import tomllib

    listed = set(tomllib.loads((REPO / "pyproject.toml").read_text())["tool"]["setuptools"]["packages"])
    found = {"vsegen." + ".".join(init.parent.relative_to(REPO).parts)
             for folder in ("model", "codegen", "harness", "vehicles") for init in (REPO / folder).rglob("__init__.py")}
    assert found == listed
