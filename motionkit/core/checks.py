"""Value checks of the config dataclasses (their `__post_init__`): a field that breaks its rule
is refused with the caller's error class, naming the field, what it should be and what it got."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from typing import Any

from motionkit.core.errors import MotionkitError

# Rules on each number of a field (a tuple's, item by item), which must also be finite.
NUMBERS: dict[str, Callable[[float], bool]] = {
    "finite": lambda v: True,
    "> 0": lambda v: v > 0,
    ">= 0": lambda v: v >= 0,
    ">= 1": lambda v: v >= 1,
    "in [0, 1]": lambda v: 0 <= v <= 1,
    "in (0, 1]": lambda v: 0 < v <= 1,
    "in (0, 1)": lambda v: 0 < v < 1,
    "in (0, 180]": lambda v: 0 < v <= 180,  # degrees
}
# Rules on a whole field (a tuple): the test and what the message says.
WHOLE: dict[str, tuple[Callable[[Any], bool], str]] = {
    "non-empty": (lambda v: len(v) > 0, "non-empty"),
    "distinct": (lambda v: len(set(v)) == len(v), "free of repeats"),
    "[low, high]": (lambda v: len(v) == 2 and v[0] <= v[1], "[low, high] with low <= high"),
}


def check(
    config: object, error: type[MotionkitError], rule: str | tuple[str, ...], *names: str
) -> None:
    """`error` unless each named field of `config` meets `rule`: a key of NUMBERS or WHOLE, or
    a tuple of the values allowed."""
    for name in names:
        value = getattr(config, name)
        if isinstance(rule, tuple):
            ok, expected = value in rule, "one of " + ", ".join(map(repr, rule))
        elif rule in WHOLE:
            test, expected = WHOLE[rule]
            ok = test(value)
        else:
            ok = all(math.isfinite(v) and NUMBERS[rule](v) for v in _numbers(value))
            expected = "finite" if rule == "finite" else f"finite and {rule}"
        if not ok:
            raise refusal(error, name, expected, value)


def refusal(error: type[MotionkitError], name: str, expected: str, value: object) -> MotionkitError:
    """The error of a rule of its own (those `check` does not know), worded as `check`'s."""
    return error(f"'{name}' should be {expected}, got {value!r}")


def _numbers(value: Any) -> Iterator[float]:
    if isinstance(value, tuple):
        for item in value:
            yield from _numbers(item)
    else:
        yield value
