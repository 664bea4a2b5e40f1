"""A progress bar per IMU while ``twin calibrate`` runs, on a terminal only.

One step per stage of :func:`twin.calibration.workflow.calibrate_imu`: the log-quality assessment,
the protocol, every method fitted on every fold, every method fitted on all rows. The bar is drawn
on standard error when it is a terminal (tqdm), never into a log file, a pipe or a test's capture.
"""

from __future__ import annotations

import sys


class FitProgress:
    """Steps of one IMU's calibration, drawn as a tqdm bar when enabled.

    Parameters
    ----------
    label : str
        What the bar names (``"IMU 0"``).
    enabled : bool, optional
        Default: standard error is a terminal.
    position : int, optional
        Row of the bar (IMUs calibrated side by side each draw on their own row).
    """

    def __init__(self, label: str, enabled: bool | None = None, position: int = 0):
        if enabled is None:
            enabled = bool(getattr(sys.stderr, "isatty", lambda: False)())
        self._bar = None
        if enabled:
            from tqdm import tqdm

            self._bar = tqdm(total=None, desc=label, unit="fit", file=sys.stderr, leave=True, position=position)

    def expect(self, steps: int) -> None:
        """Set the number of steps (known once the protocol is).

        Parameters
        ----------
        steps : int
            Steps in all, those done included.
        """
        if self._bar is not None:
            self._bar.total = int(steps)
            self._bar.refresh()

    def step(self, what: str = "") -> None:
        """One step done.

        Parameters
        ----------
        what : str
            Shown beside the bar (e.g. ``"twin on fold 2"``).
        """
        if self._bar is not None:
            self._bar.set_postfix_str(what[:40], refresh=False)
            self._bar.update(1)

    def close(self) -> None:
        """Leave the bar where it is and stop drawing."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None

    def __enter__(self) -> FitProgress:
        return self

    def __exit__(self, *exc) -> None:
        self.close()
