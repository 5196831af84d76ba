"""Fault injection for the executor tests, from outside the code under test: a Python process
started with this folder on PYTHONPATH and MOTIONKIT_TEST_KILL="DIR,NAME,TIMES" ends the
first TIMES attempts of task NAME at once, as a crash would (os._exit); DIR counts the
attempts. Local worker processes and Ray workers load it at start-up."""

import os

SETTING = os.environ.get("MOTIONKIT_TEST_KILL")

if SETTING:
    from pathlib import Path

    import motionkit.runtime.executors as executors

    folder, target, times = SETTING.split(",")
    run_task = executors._run_task

    def _dying_run_task(fn, name, item, shared):
        if name == target:
            attempt = len(list(Path(folder).glob(f"{name}.*"))) + 1
            if attempt <= int(times):
                (Path(folder) / f"{name}.{attempt}").touch()
                os._exit(70)
        return run_task(fn, name, item, shared)

    executors._run_task = _dying_run_task
