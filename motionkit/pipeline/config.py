"""The pipeline recipe: which stage recipes to run, paths relative to the recipe file (every
path is required: pipeline/tiny_cpu.toml is the example)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

from motionkit.errors import PipelineError
from motionkit.tomlfile import build_tables, read_toml


@dataclass(frozen=True)
class RetargetStage:
    recipe: str = ""  # settings and CMU clip ids (unless --mocap-dir)
    jobs: int = 0  # processes, 0 = one per CPU


@dataclass(frozen=True)
class TrajoptStage:
    recipes: tuple[str, ...] = field(default_factory=tuple)  # one flight per recipe
    library: str = ""  # a flight library (trajopt/library.toml): every clip it names
    jobs: int = 0  # processes for the library, 0 = one per CPU
    replay: bool = True  # check every flight by a MuJoCo replay


@dataclass(frozen=True)
class JetIdentStage:
    recipe: str = ""  # bench logs are simulated for its [bench] train_seeds


@dataclass(frozen=True)
class TrainStage:
    recipe: str = ""
    full_recipe: str = ""  # with --full
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
        config = cls(Path(path), **build_tables(data, cls.TABLES, str(path), PipelineError))
        config.check()
        return config

    def resolve(self, relative: str) -> Path:
        """A path of the recipe, relative to the recipe file."""
        return (self.source.parent / relative).resolve()

    def check(self) -> None:
        """Every recipe file named exists; the choices are valid."""
        named = {
            "[retarget] recipe": [self.retarget.recipe],
            "[trajopt] recipes or library": [*self.trajopt.recipes, self.trajopt.library],
            "[jet_ident] recipe": [self.jet_ident.recipe],
            "[train] recipe": [self.train.recipe],
            "[train] full_recipe": [self.train.full_recipe],
        }
        for key, paths in named.items():
            if not any(paths):
                raise PipelineError(f"{self.source}: {key} is missing (a path to a recipe)")
            for relative in filter(None, paths):
                if not self.resolve(relative).is_file():
                    raise PipelineError(
                        f"{self.source}: {key}: {relative} does not exist "
                        f"(looked for {self.resolve(relative)})"
                    )
        if self.train.jet not in ("lstm", "ideal"):
            raise PipelineError(f"{self.source}: [train] jet should be 'lstm' or 'ideal'")
        for table in ("retarget", "trajopt"):
            if getattr(self, table).jobs < 0:
                raise PipelineError(f"{self.source}: [{table}] jobs should be >= 0")
