"""The data shipped in ``navstack/data``: intact, packaged, documented, and found in order."""

from __future__ import annotations

import fnmatch
import hashlib
import tomllib
from pathlib import Path

import pytest

from navstack.benchmarks import common
from navstack.benchmarks.common import (
    SHIPPED_DATA,
    BenchDataMissing,
    data_file,
    data_roots,
)

ROOT = Path(__file__).resolve().parents[2]
META = {"README.md", "SHA256SUMS"}


def _shipped_files() -> list[str]:
    return sorted(p.relative_to(SHIPPED_DATA).as_posix() for p in SHIPPED_DATA.rglob("*")
                  if p.is_file() and p.name not in META)


def _sums() -> dict[str, str]:
    lines = (SHIPPED_DATA / "SHA256SUMS").read_text().splitlines()
    return {name.strip(): digest for digest, name in (line.split(maxsplit=1) for line in lines)}


def test_every_shipped_file_matches_its_published_digest() -> None:
    sums = _sums()
    assert sorted(sums) == _shipped_files()
    for name, digest in sums.items():
        assert hashlib.sha256((SHIPPED_DATA / name).read_bytes()).hexdigest() == digest, name


def test_the_data_the_readme_and_benchmarks_use_is_shipped() -> None:
    files = set(_shipped_files())
    assert {f"carmen/{n}-corrected.log.gz" for n in ("intel", "aces", "csail")} <= files
    assert {f"g2o/{n}.g2o" for n in ("intel", "MIT", "CSAIL")} <= files
    from navstack.benchmarks.planners import MAPS

    assert {f"movingai/{m}.map{s}" for m in MAPS for s in ("", ".scen")} <= files


def test_package_data_globs_install_every_shipped_file() -> None:
    """``pip install`` (a wheel, not the editable checkout) must carry the data."""
    config = tomllib.loads((ROOT / "pyproject.toml").read_text())
    globs = config["tool"]["setuptools"]["package-data"]["navstack"]
    for name in [*_shipped_files(), *META]:
        assert any(fnmatch.fnmatch(f"data/{name}", g) for g in globs), name


def test_the_data_readme_gives_each_file_a_source_and_licence() -> None:
    readme = (SHIPPED_DATA / "README.md").read_text()
    for name in _shipped_files():
        stem = Path(name).name.removesuffix(".scen").removesuffix(".map")
        assert f"`{stem}" in readme, name
    for folder in ("carmen", "g2o", "movingai"):
        section = readme.split(f"## {folder}/", 1)[1].split("\n## ", 1)[0]
        assert "Source:" in section and "Licence:" in section, folder
    assert "ODC-By 1.0" in readme


def test_lookup_order_option_then_environment_then_shipped(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    option, env = tmp_path / "option", tmp_path / "env"
    for root in (option, env):
        (root / "g2o").mkdir(parents=True)
    (option / "g2o" / "only_option.g2o").write_text("")
    (env / "g2o" / "only_env.g2o").write_text("")
    (env / "g2o" / "MIT.g2o").write_text("")
    monkeypatch.setenv("NAVSTACK_DATA", str(env))
    assert [label for label, _ in data_roots(option)][:3] == ["--data-dir", "NAVSTACK_DATA",
                                                               "shipped"]
    assert data_file("g2o/only_option.g2o", option) == option / "g2o" / "only_option.g2o"
    assert data_file("g2o/only_env.g2o", option) == env / "g2o" / "only_env.g2o"
    assert data_file("g2o/MIT.g2o", option) == env / "g2o" / "MIT.g2o"  # env before shipped
    assert data_file("g2o/intel.g2o", option) == SHIPPED_DATA / "g2o" / "intel.g2o"
    monkeypatch.delenv("NAVSTACK_DATA")
    assert data_file("g2o/MIT.g2o") == SHIPPED_DATA / "g2o" / "MIT.g2o"


def test_shared_data_comes_after_the_shipped_copy(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    (tmp_path / "movingai").mkdir()
    (tmp_path / "movingai" / "extra.map").write_text("")
    (tmp_path / "movingai" / "arena.map").write_text("")
    monkeypatch.delenv("NAVSTACK_DATA", raising=False)
    monkeypatch.setattr(common, "shared_data_dir", lambda: tmp_path)
    assert data_roots() == [("shipped", SHIPPED_DATA), ("../shared/data", tmp_path)]
    assert data_file("movingai/arena.map") == SHIPPED_DATA / "movingai" / "arena.map"
    assert data_file("movingai/extra.map") == tmp_path / "movingai" / "extra.map"


@pytest.mark.parametrize("via", ["option", "environment"])
def test_a_folder_that_does_not_exist_is_an_error(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, via: str) -> None:
    missing = tmp_path / "typo"
    if via == "option":
        monkeypatch.delenv("NAVSTACK_DATA", raising=False)
        with pytest.raises(BenchDataMissing, match=f"^--data-dir {missing}: no such folder"):
            data_file("g2o/MIT.g2o", missing)
    else:
        monkeypatch.setenv("NAVSTACK_DATA", str(missing))
        with pytest.raises(BenchDataMissing, match=f"^NAVSTACK_DATA {missing}: no such folder"):
            data_file("g2o/MIT.g2o")


def test_a_missing_file_names_itself_the_folders_and_the_source(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("NAVSTACK_DATA", raising=False)
    monkeypatch.setattr(common, "shared_data_dir", lambda: None)
    with pytest.raises(BenchDataMissing) as info:
        data_file("movingai/nowhere.map", tmp_path)
    assert str(info.value) == (
        f"benchmark data file movingai/nowhere.map not found; searched {tmp_path} "
        f"(--data-dir), {SHIPPED_DATA} (shipped). Download it from the MovingAI grid "
        "benchmarks (movingai.com/benchmarks), save it as DIR/movingai/nowhere.map and pass "
        "--data-dir DIR or set NAVSTACK_DATA=DIR")
    assert isinstance(info.value, FileNotFoundError)
