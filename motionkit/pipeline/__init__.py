"""`motionkit pipeline`: every stage from raw data to a trained policy, for one robot, cached by
input hash.

    from motionkit.pipeline import PipelineConfig, run_pipeline
    from motionkit.robot import load_robot

    config = PipelineConfig.from_toml("pipeline/tiny_cpu.toml")
    outcomes = run_pipeline(config, out, load_robot("robot.urdf", "robot.toml"), until="trajopt")
    [(o.stage, o.status, o.made) for o in outcomes]       # each an Outcome: 'ran' or 'cached'

The stages (STAGE_NAMES: retarget, trajopt, jet_ident, datasets, train) need the [ik],
[trajopt] and [train] extras. A run prints nothing; `progress=print` shows the command's lines.
"""

from motionkit.pipeline.cache import Outcome
from motionkit.pipeline.config import PipelineConfig
from motionkit.pipeline.runner import STAGE_NAMES, run_pipeline

__all__ = ["STAGE_NAMES", "Outcome", "PipelineConfig", "run_pipeline"]
