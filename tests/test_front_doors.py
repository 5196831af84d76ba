"""Each stage's front door: the names the README uses are exported and documented in the
package docstring, and the stages with an optional extra import without it."""

import importlib
import inspect
import re
import subprocess
import sys

import pytest

from motionkit.core.errors import MotionkitError

# package -> the names the README's Python examples use
README_NAMES = {
    "motionkit.robot": ("Robot", "load_robot", "ironcub"),
    "motionkit.mocap": ("load_mocap",),
    "motionkit.retarget": ("RetargetConfig", "retarget", "resolve_inputs", "run_retarget"),
    "motionkit.trajopt": ("TrajoptConfig", "Prepared", "solve_clip", "solve_grid", "solve_library"),
    "motionkit.jet_ident": ("read_log", "identify", "fit_logs", "thrust_next"),
    "motionkit.dataset": ("read", "write", "Trajectory"),
    "motionkit.train": ("TrainConfig", "train_policy", "run_ablation"),
    "motionkit.viewer": ("ViewerApp", "resolve_clips"),
    "motionkit.pipeline": ("PipelineConfig", "run_pipeline"),
}
# the front doors whose docstring documents every name they export
DOCUMENTED = ("retarget", "trajopt", "train", "pipeline", "viewer")
# the front doors whose functions have a summary line, Args: (each parameter) and Returns:
DOCSTRING_STYLE = (
    "motionkit.robot",
    "motionkit.mocap",
    "motionkit.trajopt",
    "motionkit.jet_ident",
    "motionkit.dataset",
    "motionkit.train",
    "motionkit.viewer",
    "motionkit.retarget",
    "motionkit.pipeline",
)


@pytest.mark.parametrize(("module", "names"), README_NAMES.items())
def test_front_door_exports_what_the_readme_uses(module: str, names: tuple[str, ...]) -> None:
    package = importlib.import_module(module)
    assert set(names) <= set(package.__all__)
    for name in package.__all__:
        try:
            value = getattr(package, name)
        except MotionkitError as exc:  # a lazy name whose extra is not installed here
            assert "extra" in str(exc) and "pip install" in str(exc)
            continue
        assert not isinstance(value, type(sys)), f"{module}.{name} is a module, not the API"
    stage = module.removeprefix("motionkit.")
    if stage in DOCUMENTED:
        undocumented = [name for name in package.__all__ if name not in package.__doc__]
        assert not undocumented, f"{module}'s docstring does not name {undocumented}"


def _section(doc: str, title: str) -> str | None:
    """The lines of section `title:` of a docstring, up to the next section or the end."""
    match = re.search(rf"^{title}:\n(.*?)(?=^\S|\Z)", doc, re.M | re.S)
    return match.group(1) if match else None


@pytest.mark.parametrize("module", DOCSTRING_STYLE)
def test_front_door_functions_document_args_and_returns(module: str) -> None:
    package = importlib.import_module(module)
    problems = []
    for name in package.__all__:
        try:
            value = getattr(package, name)
        except MotionkitError:  # a lazy name whose extra is not installed here
            continue
        if isinstance(value, type) or not callable(value):
            continue
        doc = inspect.getdoc(value) or ""
        lines = doc.splitlines()
        if not lines or (len(lines) > 1 and lines[1].strip()):
            problems.append(f"{name}: no one-line summary")
        parameters = [
            p.name
            for p in inspect.signature(value).parameters.values()
            if p.name != "self" and p.kind not in (p.VAR_POSITIONAL, p.VAR_KEYWORD)
        ]
        args = _section(doc, "Args")
        if parameters and args is None:
            problems.append(f"{name}: no Args section")
        missing = [p for p in parameters if not re.search(rf"^ +{p}:", args or "", re.M)]
        if args is not None and missing:
            problems.append(f"{name}: Args does not name {missing}")
        if _section(doc, "Returns") is None:
            problems.append(f"{name}: no Returns section")
    assert not problems, f"{module}: " + "; ".join(problems)


def test_train_policy_is_the_run_and_not_the_module() -> None:
    """`motionkit.train.learner` is a module of the package; the front door's name is not."""
    pytest.importorskip("jax")
    import motionkit.train
    import motionkit.train.learner
    from motionkit.train.runner import train

    assert motionkit.train.train_policy is train


def test_stages_are_reachable_from_the_top_package() -> None:
    import motionkit

    assert motionkit.trajopt.TrajoptConfig.__module__ == "motionkit.trajopt.config"
    assert motionkit.pipeline.run_pipeline.__module__ == "motionkit.pipeline.runner"
    with pytest.raises(AttributeError, match="no attribute 'trajectory'"):
        motionkit.trajectory  # noqa: B018


CODE = """
import sys
for blocked in {blocked!r}:
    sys.modules[blocked] = None  # an import of it now fails
import motionkit.{stage} as stage
from motionkit.{stage} import {eager}
try:
    stage.{lazy}
except Exception as exc:
    print(type(exc).__name__, exc)
"""


@pytest.mark.parametrize(
    ("stage", "blocked", "eager", "lazy", "error", "message"),
    [
        ("trajopt", ["casadi"], "TrajoptConfig, solve_clip", "Prepared", "TrajoptError",
         "needs the [trajopt] extra (casadi is missing)"),
        ("train", ["jax"], "TrainConfig", "train_policy", "TrainError",
         "needs the [train] extra (jax is missing)"),
        ("viewer", ["viser"], "resolve_clips", "ViewerApp", "ViewerError",
         "needs the [viewer] extra (viser is missing)"),
        ("jet_ident", ["jax"], "read_log", "fit_logs", "JetIdentError",
         "needs the [train] extra (jax is missing)"),
    ],
)  # fmt: skip
def test_stage_imports_without_its_extra(
    stage: str, blocked: list[str], eager: str, lazy: str, error: str, message: str
) -> None:
    code = CODE.format(blocked=blocked, stage=stage, eager=eager, lazy=lazy)
    run = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr
    assert run.stdout.startswith(f"{error} motionkit.{stage}.{lazy} {message}"), run.stdout
