"""The trajopt tests compile the problem's functions at -O0 (seconds instead of a minute or two;
the generated code is the same, only the compiler's optimisation differs)."""

import pytest


@pytest.fixture(autouse=True, scope="session")
def _quick_compile() -> None:
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("MOTIONKIT_TRAJOPT_COMPILE", "-O0")
        yield
