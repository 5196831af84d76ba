"""Bench-log CSV: round trip, metadata, and errors that name the line."""

from pathlib import Path

import numpy as np
import pytest

from motionkit.core.errors import JetIdentError
from motionkit.jet_ident.benchlog import BenchLog, parse_log, read_log, write_log

GOOD = """# engine: P250
# seed: 7
time_s,throttle_pct,thrust_n
0.00,0.0,15.2
0.01,10.0,15.9
0.02,60.0,18.5
0.03,60.0,30.0
"""


def test_parse_reads_columns_and_comment_metadata() -> None:
    log = parse_log(GOOD, "good.csv")
    assert log.metadata == {"engine": "P250", "seed": "7"}
    np.testing.assert_allclose(log.thrust, [15.2, 15.9, 18.5, 30.0])
    np.testing.assert_allclose(log.throttle, [0, 10, 60, 60])
    assert log.dt == pytest.approx(0.01)
    assert log.samples == 4 and log.duration == pytest.approx(0.03)


def test_columns_in_any_order_and_extra_columns_ignored() -> None:
    text = "thrust_n,note,time_s,throttle_pct\n15,a,0,0\n16,b,0.01,70\n"
    log = parse_log(text)
    np.testing.assert_allclose(log.time, [0, 0.01])
    np.testing.assert_allclose(log.throttle, [0, 70])


def test_write_then_read_round_trip(tmp_path: Path) -> None:
    time = np.arange(500) * 0.01
    log = BenchLog(time, 50 + 40 * np.sin(time), 100 + 60 * np.sin(time), "x", {"seed": "3"})
    write_log(tmp_path / "x.csv", log)
    back = read_log(tmp_path / "x.csv")
    assert back.metadata == {"seed": "3"}
    np.testing.assert_allclose(back.time, log.time, atol=1e-4)
    np.testing.assert_allclose(back.throttle, log.throttle, atol=5e-3)
    np.testing.assert_allclose(back.thrust, log.thrust, atol=5e-4)
    assert [p.name for p in tmp_path.iterdir()] == ["x.csv"]  # no temporary left


def _error(text: str) -> str:
    with pytest.raises(JetIdentError) as info:
        parse_log(text, "bench.csv")
    return str(info.value)


@pytest.mark.parametrize(
    "header",
    [
        "time_s,throttle_pct,thrust_N",
        "Time [s],Throttle [%],Thrust [N]",
        "TIME (s),throttle,thrust",
    ],
)
def test_header_spellings_of_the_same_units(header: str) -> None:
    log = parse_log(GOOD.replace("time_s,throttle_pct,thrust_n", header))
    np.testing.assert_allclose(log.thrust, [15.2, 15.9, 18.5, 30.0])
    np.testing.assert_allclose(log.time, [0.0, 0.01, 0.02, 0.03])


def test_missing_column_is_named() -> None:
    message = _error("time_s,throttle_pct,force_n\n0,0,15\n0.01,0,15\n")
    assert message.startswith("bench.csv: line 1: missing column(s) thrust_n; the header has")


@pytest.mark.parametrize(
    ("header", "message"),
    [
        ("time_s,throttle_pct,thrust_kN", "column 'thrust_kN' is in kN; expected N"),
        ("time [ms],throttle_pct,thrust_n", "column 'time [ms]' is in ms; expected s"),
        ("time_s,throttle_pct,thrust_n,Thrust [N]", "'thrust_n' and 'Thrust [N]' both give"),
    ],
)
def test_other_units_and_doubled_columns_are_refused(header: str, message: str) -> None:
    assert message in _error(GOOD.replace("time_s,throttle_pct,thrust_n", header))


def test_non_monotonic_time_names_the_line() -> None:
    text = GOOD.replace("0.03,60.0,30.0", "0.015,60.0,30.0")
    assert "line 7: time 0.015 s is not after the previous row's 0.02 s" in _error(text)


def test_repeated_time_names_the_line() -> None:
    assert "line 6" in _error(GOOD.replace("0.02,60.0,18.5", "0.01,60.0,18.5"))


def test_gap_in_sampling_names_the_line() -> None:
    assert "line 7: sample interval 0.05 s" in _error(GOOD.replace("0.03,60", "0.07,60"))


def test_nan_names_line_and_column() -> None:
    message = _error(GOOD.replace("0.02,60.0,18.5", "0.02,60.0,nan"))
    assert "line 6: thrust_n is nan" in message


def test_text_value_names_line_and_column() -> None:
    assert "line 5: throttle_pct 'ten' is not a number" in _error(GOOD.replace("10.0", "ten"))


def test_throttle_outside_0_100_names_the_line() -> None:
    assert "line 6: throttle_pct 160 is outside 0-100 %" in _error(
        GOOD.replace("0.02,60", "0.02,160")
    )
    assert "line 4: throttle_pct -1" in _error(GOOD.replace("0.00,0.0", "0.00,-1.0"))


def test_thrust_in_grams_is_caught_by_range() -> None:
    grams = GOOD.replace("15.2", "1550").replace("15.9", "1621").replace("18.5", "1886")
    grams = grams.replace("30.0", "3059")
    message = _error(grams)
    assert "line 4" in message and "grams" in message and "newtons" in message


def test_thrust_in_kilonewtons_is_caught_by_range() -> None:
    kn = GOOD.replace("15.2", "0.0152").replace("15.9", "0.0159").replace("18.5", "0.0185")
    message = _error(kn.replace("30.0", "0.030"))
    assert "line 7" in message and "kN" in message and "newtons" in message
    # a log that never passes 50 % throttle (idle 0.015 kN where the engine idles near 15 N)
    low = kn.replace("30.0", "0.021").replace("60.0", "30.0")
    assert "kN" in _error(low) and "reaches 30 %" in _error(low)


def test_short_row_and_missing_header() -> None:
    assert "line 6: 2 value(s)" in _error(GOOD.replace("0.02,60.0,18.5", "0.02,60.0"))
    assert "no header" in _error("# only a comment\n")


def test_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(JetIdentError, match="cannot read bench log"):
        read_log(tmp_path / "absent.csv")


def test_writing_a_bad_log_names_the_row_and_writes_nothing(tmp_path: Path) -> None:
    time = np.arange(5) * 0.01
    log = BenchLog(time, np.array([0, 10, 120, 50, 50.0]), np.full(5, 20.0))
    with pytest.raises(JetIdentError, match="row 3: throttle_pct 120"):
        write_log(tmp_path / "bad.csv", log)
    assert list(tmp_path.iterdir()) == []
