"""The built wheel carries every shipped resource, stays small, and nothing looks outside."""

from __future__ import annotations

import hashlib
import re
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

import hvacflex
from hvacflex.paths import buildings_dir, data_dir, resources_dir

REPO = Path(__file__).resolve().parents[1]
SOURCE_RESOURCES = REPO / "src" / "hvacflex" / "resources"
MAX_WHEEL_BYTES = 10 * 1024 * 1024


def _shipped_files() -> set[str]:
    return {
        "hvacflex/resources/" + path.relative_to(SOURCE_RESOURCES).as_posix()
        for path in SOURCE_RESOURCES.rglob("*")
        if path.is_file() and "__pycache__" not in path.parts
    }


@pytest.fixture(scope="module")
def wheel(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [sys.executable, "-m", "pip", "wheel", "--quiet", "--no-deps", "-w", str(out), str(REPO)],
        check=True,
        capture_output=True,
        timeout=600,
    )
    (built,) = out.glob("hvacflex-*.whl")
    return built


def test_wheel_holds_every_shipped_resource(wheel: Path) -> None:
    names = set(zipfile.ZipFile(wheel).namelist())
    missing = sorted(_shipped_files() - names)
    assert not missing, f"missing from the wheel: {missing}"
    for required in (
        "hvacflex/resources/PROVENANCE.md",
        "hvacflex/resources/buildings/office5.toml",
        "hvacflex/resources/nems_usep_2014/USEP_Dec-2014.csv",
        "hvacflex/resources/bestest/std140_2020_example_results_600_900.csv",
        "hvacflex/py.typed",
        "hvacflex/service/pages/dashboard.html",  # the service's own pages (GET /, /v1/docs)
        "hvacflex/service/pages/api_docs.html",
    ):
        assert required in names


def test_the_openadr_extra_and_the_ven_migration_ship_in_the_wheel(wheel: Path) -> None:
    """`pip install "hvacflex[openadr]"` brings openleadr; the VEN's tables are migrated
    from the wheel (issue 30)."""
    archive = zipfile.ZipFile(wheel)
    (metadata,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
    lines = archive.read(metadata).decode().splitlines()
    assert "Provides-Extra: openadr" in lines
    assert any(
        line.startswith("Requires-Dist: openleadr") and 'extra == "openadr"' in line
        for line in lines
    )
    names = set(archive.namelist())
    for module in ("openadr.py", "openadr_mapping.py", "openadr_store.py"):
        assert f"hvacflex/service/{module}" in names
    assert "hvacflex/service/migrations/versions/0002_openadr.py" in names


def test_wheel_is_small_and_has_no_iwec(wheel: Path) -> None:
    assert wheel.stat().st_size < MAX_WHEEL_BYTES
    assert not [n for n in zipfile.ZipFile(wheel).namelist() if "IWEC" in n]


def test_default_paths_are_package_data(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("HVACFLEX_DATA_DIR", raising=False)
    monkeypatch.delenv("HVACFLEX_BUILDINGS_DIR", raising=False)
    package = Path(hvacflex.__file__).parent
    assert resources_dir() == package / "resources"
    assert data_dir() == package / "resources"
    assert (buildings_dir() / "office5.toml").is_file()
    assert len(list((data_dir() / "nems_usep_2014").glob("USEP_*-2014.csv"))) == 12


def test_no_code_or_test_reaches_outside_the_repository() -> None:
    # spelt from parts so that this file does not itself name the paths it looks for
    shared = "".join(("sha", "red"))
    needles = (f"../{shared}", f"{shared}/data", f"/work/{shared}")
    offenders = [
        f"{path.relative_to(REPO)}: {needle}"
        for folder in ("src", "tests", "benchmarks", "scripts")
        for path in (REPO / folder).rglob("*.py")
        if path != Path(__file__).resolve()
        for needle in needles
        if needle in path.read_text(encoding="utf-8")
    ]
    assert not offenders


def test_provenance_checksums_match_the_shipped_files() -> None:
    text = (SOURCE_RESOURCES / "PROVENANCE.md").read_text(encoding="utf-8")
    rows = re.findall(r"^\| `([^`]+)` \| ([\d,]+) \| `([0-9a-f]{64})` \|$", text, flags=re.M)
    assert len(rows) >= 18  # 12 price files, weather, 3 BESTEST files, 3 room-model files
    for name, size, sha in rows:
        data = (SOURCE_RESOURCES / name).read_bytes()
        assert len(data) == int(size.replace(",", "")), name
        assert hashlib.sha256(data).hexdigest() == sha, name


EXTRA_ONLY_MODULES = (
    "fastapi",
    "uvicorn",
    "sqlalchemy",
    "alembic",
    "starlette",
    "dask",
    "distributed",
    "gymnasium",
    "openleadr",
)
"""What the core commands must not import: they belong to extras (pyproject.toml)."""


def test_simulate_kpi_and_reproduce_import_no_extra(tmp_path: Path) -> None:
    """The slim core (issue 59): `simulate` and `kpi` run, and `reproduce`'s modules load,
    without importing a module of the service, Dask, gym or OpenADR extras."""
    out = tmp_path / "run"
    code = f"""
import sys
from typer.testing import CliRunner
from hvacflex.cli import app
args = ["simulate", "--scenario", "thermostat", "--start", "2014-03-03", "--days", "0.25"]
done = CliRunner().invoke(app, [*args, "--out", {str(out)!r}, "-q"])
assert done.exit_code == 0, done.output
done = CliRunner().invoke(app, ["kpi", {str(out)!r}])
assert done.exit_code == 0, done.output
import hvacflex.reproduce, hvacflex.reproduce_plan, hvacflex.sensitivity, hvacflex.robustness
import hvacflex.simulation, hvacflex.api
print("imported:", ",".join(m for m in {EXTRA_ONLY_MODULES!r} if m in sys.modules))
"""
    src = str(Path(hvacflex.__file__).resolve().parents[1])
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={"PYTHONPATH": src, "PATH": "/usr/bin:/bin"},
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip().splitlines()[-1] == "imported:"
