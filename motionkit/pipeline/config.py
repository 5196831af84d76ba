"""The pipeline recipe: which stage recipes to run, each a path relative to the recipe file or a
built-in recipe's name (every one is required: the built-in tiny_cpu is the example)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import ClassVar

from motionkit import recipes
from motionkit.errors import PipelineError
from motionkit.tomlfile import build_tables, read_toml


@dataclass(frozen=True)
class RetargetStage:
    recipe: str = ""  # settings and clips (unless --mocap-dir)
    fetch_recipe: str = ""  # with --fetch: a recipe whose CMU clip ids are downloaded
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

    def resolve(self, stage: str, text: str) -> Path:
        """A stage recipe the pipeline recipe names: a file relative to it, or a built-in."""
        path = self.source.parent / text
        return path.resolve() if path.is_file() else recipes.find(stage, text).resolve()

    def check(self) -> None:
        """Every recipe file named exists; the choices are valid."""
        named = {
            "[retarget] recipe": [self.retarget.recipe],
            "[trajopt] recipes or library": [*self.trajopt.recipes, self.trajopt.library],
            "[jet_ident] recipe": [self.jet_ident.recipe],
            "[train] recipe": [self.train.recipe],
            "[train] full_recipe": [self.train.full_recipe],
        }
        for key, texts in named.items():
            if not any(texts):
                raise PipelineError(f"{self.source}: {key} is missing (a recipe path or name)")
            stage = key[1 : key.index("]")]
            for text in filter(None, [*texts, self.retarget.fetch_recipe * (stage == "retarget")]):
                try:
                    self.resolve(stage, text)
                except recipes.RecipeError as exc:
                    raise PipelineError(f"{self.source}: {key}: {exc}") from None
        if self.train.jet not in ("lstm", "ideal"):
            raise PipelineError(f"{self.source}: [train] jet should be 'lstm' or 'ideal'")
        for table in ("retarget", "trajopt"):
            if getattr(self, table).jobs < 0:
                raise PipelineError(f"{self.source}: [{table}] jobs should be >= 0")
