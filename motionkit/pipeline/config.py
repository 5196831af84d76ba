"""The pipeline recipe: which stage recipes to run, paths relative to the recipe file."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, ClassVar

from motionkit.errors import PipelineError
from motionkit.tomlfile import build_dataclass, read_toml


@dataclass(frozen=True)
class RetargetStage:
    recipe: str = "../retarget/cmu_walk.toml"  # settings and CMU clip ids (unless --mocap-dir)
    jobs: int = 0  # processes, 0 = one per CPU


@dataclass(frozen=True)
class TrajoptStage:
    recipes: tuple[str, ...] = field(default_factory=tuple)  # one flight per recipe
    replay: bool = True  # check every flight by a MuJoCo replay


@dataclass(frozen=True)
class JetIdentStage:
    recipe: str = "../jet_ident/p250.toml"  # bench logs simulated for its [bench] train_seeds


@dataclass(frozen=True)
class TrainStage:
    recipe: str = "../train/tiny_cpu.toml"
    full_recipe: str = "../train/paper_gpu.toml"  # with --full
    jet: str = "lstm"  # "lstm": the jet model of the jet_ident stage; "ideal": thrust rates


@dataclass(frozen=True)
class PipelineConfig:
    source: Path
    retarget: RetargetStage
    trajopt: TrajoptStage
    jet_ident: JetIdentStage
    train: TrainStage

    TABLES: ClassVar[dict[str, type]] = {
        "retarget": RetargetStage,
        "trajopt": TrajoptStage,
        "jet_ident": JetIdentStage,
        "train": TrainStage,
    }

    @classmethod
    def from_toml(cls, path: Path) -> PipelineConfig:
        data = read_toml(path, "pipeline config", PipelineError)
        unknown = sorted(set(data) - set(cls.TABLES))
        if unknown:
            raise PipelineError(f"{path}: unknown tables {unknown}; known: {sorted(cls.TABLES)}")
        tables: dict[str, Any] = {}
        for name, kind in cls.TABLES.items():
            table = data.get(name, {})
            if not isinstance(table, dict):
                raise PipelineError(f"{path}: '{name}' should be a table [{name}]")
            tables[name] = build_dataclass(kind, table, f"{path}: [{name}]", PipelineError)
        config = cls(Path(path), **tables)
        config.check()
        return config

    def resolve(self, relative: str) -> Path:
        """A path of the recipe, relative to the recipe file."""
        return (self.source.parent / relative).resolve()

    def check(self) -> None:
        """Every recipe file named exists; the choices are valid."""
        named = {
            "[retarget] recipe": [self.retarget.recipe],
            "[trajopt] recipes": list(self.trajopt.recipes),
            "[jet_ident] recipe": [self.jet_ident.recipe],
            "[train] recipe": [self.train.recipe],
            "[train] full_recipe": [self.train.full_recipe],
        }
        for key, paths in named.items():
            for relative in paths:
                if not self.resolve(relative).is_file():
                    raise PipelineError(
                        f"{self.source}: {key}: {relative} does not exist "
                        f"(looked for {self.resolve(relative)})"
                    )
        if not self.trajopt.recipes:
            raise PipelineError(f"{self.source}: [trajopt] recipes is empty")
        if self.train.jet not in ("lstm", "ideal"):
            raise PipelineError(f"{self.source}: [train] jet should be 'lstm' or 'ideal'")
        if self.retarget.jobs < 0:
            raise PipelineError(f"{self.source}: [retarget] jobs should be >= 0")
