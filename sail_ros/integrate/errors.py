"""What ends a run early (light: tools import it without numpy's solvers)."""


class IntegrationError(RuntimeError):
    """The state became non-finite; `SailStepper.reset` starts again."""


class StopError(RuntimeError):
    """An observer ends a run (`driver.run`): the message says why, `at` [s] from when the
    run's outputs no longer count (inf: from after the last step taken)."""

    def __init__(self, message: str, at: float = float("inf")):
        super().__init__(message)
        self.at = at


class AccuracyWarning(UserWarning):
    """A run's error estimate exceeds twice the accuracy its tolerance asks for."""
