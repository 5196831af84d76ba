"""Progress lines: rewritten in place on a terminal, plain and sparse in a log."""

import io

from motionkit.runtime.progress import LineProgress


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_a_log_gets_plain_lines_and_a_terminal_one_rewritten_line() -> None:
    log = io.StringIO()
    line = LineProgress("walk", log, every=3600.0)
    for frame in range(1, 501):
        line.show(f"IK frame {frame}/500")
    line.close()
    assert log.getvalue() == "walk: IK frame 500/500\n"  # no carriage return, one line
    screen = Terminal()
    line = LineProgress("walk", screen)
    line.every = 0.0  # every update drawn
    line.show("IK frame 1/2")
    line.show("IK frame 2/2")
    line.close(keep=False)
    assert screen.getvalue() == "\rwalk: IK frame 1/2\rwalk: IK frame 2/2\r\x1b[K"
