"""The built-in recipes: one folder per stage of TOML configs, shipped with the package and
found by name (`--config walk_to_fly`) or taken as a path."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from motionkit.core.errors import MotionkitError

ROOT = Path(__file__).resolve().parent
STAGES = ("retarget", "trajopt", "jet_ident", "train", "pipeline")


class RecipeError(MotionkitError):
    """A recipe that is neither a file nor a built-in name."""


@dataclass(frozen=True)
class Recipe:
    stage: str
    name: str
    path: Path

    @property
    def summary(self) -> str:
        """The first sentence of the recipe's opening comment, at most 72 characters."""
        lines = []
        for line in self.path.read_text().splitlines():
            if not line.startswith("#") or not line.strip("# "):
                break
            lines.append(line.strip("# "))
        sentence = " ".join(lines).split(". ")[0].rstrip(".")
        return sentence if len(sentence) <= 72 else sentence[:69].rstrip() + "..."


def builtin(stage: str) -> list[Recipe]:
    """The stage's built-in recipes, by name."""
    if stage not in STAGES:
        raise RecipeError(f"no stage '{stage}'; stages with recipes: {', '.join(STAGES)}")
    return [Recipe(stage, p.stem, p) for p in sorted((ROOT / stage).glob("*.toml"))]


def find(stage: str, text: str | Path) -> Path:
    """`text` when it names a file, else the stage's built-in recipe of that name (`.toml`
    optional); a RecipeError listing the built-ins otherwise."""
    path = Path(text).expanduser()
    if path.is_file():
        return path
    name = path.name.removesuffix(".toml")
    if path.parent == Path("."):
        for recipe in builtin(stage):
            if recipe.name == name:
                return recipe.path
    names = ", ".join(r.name for r in builtin(stage))
    raise RecipeError(f"{text}: no such file, nor a built-in {stage} recipe ({names})")


def sample_mocap() -> Path:
    """The offline sample: three CMU walking clips (02_01 BVH, 11_01 and 35_01 ASF/AMC)."""
    return ROOT.parent / "sample" / "cmu"
