"""Code digests follow the import closure: a stage's key (and a batch's resume keys) change
when a module it imports only through others changes, and not for an unrelated module."""

import shutil
from pathlib import Path

import pytest

from motionkit import recipes
from motionkit.files import digests
from motionkit.files.digests import code_digest, import_closure
from motionkit.pipeline import stages
from motionkit.pipeline.config import PipelineConfig

TRAJOPT = ("motionkit.trajopt.runner",)
RETARGET = ("motionkit.retarget.batch",)


@pytest.fixture
def package(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A copy of motionkit's source that the digests read instead of the installed one."""
    root = tmp_path / "motionkit"
    shutil.copytree(digests.PACKAGE, root, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(digests, "PACKAGE", root)
    return root


def edit(path: Path) -> None:
    path.write_text(path.read_text() + "\nEDITED = 1\n")


def test_the_closure_follows_imports_through_other_modules() -> None:
    names = {str(p.relative_to(digests.PACKAGE)) for p in import_closure(TRAJOPT)}
    # trajopt.dynamics imports the P250 coefficients; robot.spec reads robot/ironcub.toml
    assert {"jet_ident/p250.py", "trajopt/dynamics.py", "robot/ironcub.toml"} <= names
    assert {"__init__.py", "trajopt/__init__.py", "trajopt/solve.py"} <= names  # _LAZY: solve
    assert not any(n.startswith(("viewer/", "train/", "retarget/")) for n in names)
    retarget = {str(p.relative_to(digests.PACKAGE)) for p in import_closure(RETARGET)}
    assert {"core/filters.py", "retarget/targets.py", "mocap/naming.py"} <= retarget
    assert "jet_ident/p250.py" not in retarget


def test_indirect_changes_change_the_digest_and_unrelated_ones_do_not(package: Path) -> None:
    before = code_digest(*TRAJOPT), code_digest(*RETARGET)
    edit(package / "viewer" / "__init__.py")
    assert (code_digest(*TRAJOPT), code_digest(*RETARGET)) == before
    edit(package / "jet_ident" / "p250.py")
    after_p250 = code_digest(*TRAJOPT), code_digest(*RETARGET)
    assert after_p250[0] != before[0] and after_p250[1] == before[1]
    edit(package / "mocap" / "naming.py")  # retarget reads mocap; trajopt does not
    after_naming = code_digest(*TRAJOPT), code_digest(*RETARGET)
    assert after_naming[0] == after_p250[0] and after_naming[1] != after_p250[1]
    edit(package / "core" / "filters.py")  # both: retarget's targets and the dataset's physics
    after_filter = code_digest(*TRAJOPT), code_digest(*RETARGET)
    assert after_filter[0] != after_naming[0] and after_filter[1] != after_naming[1]


def stage_keys(robot, out: Path) -> dict[str, str]:
    config = PipelineConfig.from_toml(recipes.find("pipeline", "tiny_cpu"))
    ctx = stages.DryRun(config, out, robot)  # keys, no work
    stages.retarget(ctx)
    stages.trajopt(ctx)
    return dict(ctx.keys)


def test_pipeline_stages_and_resume_keys_see_indirect_changes(
    package: Path, toy_robot, tmp_path: Path
) -> None:
    from motionkit.retarget.batch import clip_key, resolve_inputs
    from motionkit.retarget.config import RetargetConfig
    from motionkit.trajopt.config import TrajoptConfig
    from motionkit.trajopt.runner import Task, task_key

    clip = resolve_inputs([str(package / "sample" / "cmu" / "02_01.bvh")])[0]
    retarget_config = RetargetConfig()
    task = Task(TrajoptConfig().to_dict(), "flight", False, toy_robot)

    def keys() -> tuple[dict[str, str], str, str]:
        pipeline = stage_keys(toy_robot, tmp_path / "out")
        return pipeline, clip_key(clip, retarget_config, toy_robot), task_key(task)

    before = keys()
    edit(package / "jet_ident" / "p250.py")
    p250 = keys()
    assert p250[0]["trajopt"] != before[0]["trajopt"] and p250[2] != before[2]
    assert p250[0]["retarget"] == before[0]["retarget"] and p250[1] == before[1]
    edit(package / "core" / "filters.py")  # the retarget targets' low-pass filter
    filtered = keys()
    assert filtered[0]["retarget"] != p250[0]["retarget"] and filtered[1] != p250[1]
    edit(package / "viewer" / "__init__.py")
    assert keys() == filtered
