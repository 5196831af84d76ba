"""Signal filters shared by the stages."""

from __future__ import annotations

import numpy as np


def low_pass(values: np.ndarray, rate: float, cutoff: float) -> np.ndarray:
    """Zero-phase 2nd-order Butterworth low-pass along the first axis (unchanged when the
    cut-off is 0, at or above the Nyquist frequency, or the clip is too short to pad)."""
    from scipy.signal import butter, sosfiltfilt

    if cutoff <= 0 or cutoff >= 0.5 * rate or len(values) < 10:
        return values
    sos = butter(2, cutoff, fs=rate, output="sos")
    return sosfiltfilt(sos, values, axis=0, padlen=min(len(values) - 1, int(rate / cutoff)))
