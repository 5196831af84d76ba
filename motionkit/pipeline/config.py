"""The pipeline recipe: which stage recipes to run, each a path relative to the recipe file or a
built-in recipe's name (every one is required: the built-in tiny_cpu is the example)."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from motionkit import recipes
from motionkit.core.checks import check
from motionkit.core.errors import PipelineError
from motionkit.core.tomlfile import load, read_toml


@dataclass(frozen=True)
class RetargetStage:
    recipe: str = ""  # settings and clips (unless --mocap-dir)
    fetch_recipe: str = ""  # with --fetch: a recipe whose CMU clip ids are downloaded
    jobs: int = 0  # processes, 0 = one per CPU

    def __post_init__(self) -> None:
        check(self, PipelineError, ">= 0", "jobs")


@dataclass(frozen=True)
class TrajoptStage:
    recipes: tuple[str, ...] = field(default_factory=tuple)  # one flight per recipe
    library: str = ""  # a flight library (the built-in: library): every clip it names
    jobs: int = 0  # processes for the flights and the library, 0 = one per CPU
    replay: bool = True  # check every flight by a MuJoCo replay
    # The stage succeeds when every recipe flight is solved and, of each kind of library clip
    # (take-off, flight, landing, jump), at least this share; the failed clips are listed in
    # its summary. 1.0: every clip.
    min_solved_share: float = 0.75

    def __post_init__(self) -> None:
        check(self, PipelineError, ">= 0", "jobs")
        check(self, PipelineError, "in (0, 1]", "min_solved_share")


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
        for key, texts in named.items():
            if not any(texts):
                raise PipelineError(f"{key} is missing (a recipe path or name)")
            stage = key[1 : key.index("]")]
            for text in filter(None, [*texts, self.retarget.fetch_recipe * (stage == "retarget")]):
                try:
                    self.resolve(stage, text)
                except recipes.RecipeError as exc:
                    raise PipelineError(f"{key}: {exc}") from None

    @classmethod
    def from_toml(cls, path: Path) -> PipelineConfig:
        data = read_toml(path, "pipeline config", PipelineError)
        return load(cls, data, str(path), PipelineError, source=Path(path))

    def resolve(self, stage: str, text: str) -> Path:
        """A stage recipe the pipeline recipe names: a file relative to it, or a built-in."""
        path = self.source.parent / text
        return path.resolve() if path.is_file() else recipes.find(stage, text).resolve()
