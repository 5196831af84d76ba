"""The pipeline recipe: which stage recipes to run, paths relative to the recipe file (every
path is required: pipeline/tiny_cpu.toml is the example)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from motionkit.checks import check
from motionkit.errors import PipelineError
from motionkit.tomlfile import load, read_toml


@dataclass(frozen=True)
class RetargetStage:
    recipe: str = ""  # settings and CMU clip ids (unless --mocap-dir)
    jobs: int = 0  # processes, 0 = one per CPU

    def __post_init__(self) -> None:
        check(self, PipelineError, ">= 0", "jobs")


@dataclass(frozen=True)
class TrajoptStage:
    recipes: tuple[str, ...] = field(default_factory=tuple)  # one flight per recipe
    library: str = ""  # a flight library (trajopt/library.toml): every clip it names
    jobs: int = 0  # processes for the library, 0 = one per CPU
    replay: bool = True  # check every flight by a MuJoCo replay

    def __post_init__(self) -> None:
        check(self, PipelineError, ">= 0", "jobs")


@dataclass(frozen=True)
class JetIdentStage:
    recipe: str = ""  # bench logs are simulated for its [bench] train_seeds


@dataclass(frozen=True)
class TrainStage:
    recipe: str = ""
    full_recipe: str = ""  # with --full
    jet: str = "lstm"  # "lstm": the jet model of the jet_ident stage; "ideal": thrust rates

    def __post_init__(self) -> None:
        check(self, PipelineError, ("lstm", "ideal"), "jet")


@dataclass(frozen=True)
class PipelineConfig:
    """The stage tables of a recipe file (`source`); every recipe file they name exists."""

    source: Path
    retarget: RetargetStage = RetargetStage()
    trajopt: TrajoptStage = TrajoptStage()
    jet_ident: JetIdentStage = JetIdentStage()
    train: TrainStage = TrainStage()

    def __post_init__(self) -> None:
        named = {
            "[retarget] recipe": [self.retarget.recipe],
            "[trajopt] recipes or library": [*self.trajopt.recipes, self.trajopt.library],
            "[jet_ident] recipe": [self.jet_ident.recipe],
            "[train] recipe": [self.train.recipe],
            "[train] full_recipe": [self.train.full_recipe],
        }
        for key, paths in named.items():
            if not any(paths):
                raise PipelineError(f"{key} is missing (a path to a recipe)")
            for relative in filter(None, paths):
                if not self.resolve(relative).is_file():
                    raise PipelineError(
                        f"{key}: {relative} does not exist (looked for {self.resolve(relative)})"
                    )

    @classmethod
    def from_toml(cls, path: Path) -> PipelineConfig:
        data = read_toml(path, "pipeline config", PipelineError)
        return load(cls, data, str(path), PipelineError, source=Path(path))

    def resolve(self, relative: str) -> Path:
        """A path of the recipe, relative to the recipe file."""
        return (self.source.parent / relative).resolve()
