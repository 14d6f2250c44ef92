"""Errors with a one-line, user-facing message, and the learner's own kinds of them.

`SfvError` lives in the floor package (learner/) so that actors/ and services/ raise and
catch the same type without anything importing upward.
"""


class SfvError(Exception):
    """A user-facing failure: bad input file, unreachable service, bad request.

    The message is one line and names the file or endpoint and what is wrong.
    The command line prints it as `sfv: <message>` and exits 2.
    """


class NonFiniteError(SfvError, FloatingPointError):
    """A batch array, a loss or a gradient holds NaN or inf.

    The message names the quantity (for example ``batch['rewards']`` or
    ``gradients of the policy network``); the learner's weights, optimiser state,
    normaliser and RNG are left exactly as they were before the update.
    """


class BatchFormatError(SfvError, ValueError):
    """A rollout batch is missing an array or has the wrong shape or dtype."""


class ConfigError(SfvError, ValueError):
    """A PPOConfig field is out of range or unknown."""


class TrainingStopped(BaseException):
    """Training stopped on a signal (SIGTERM from a scheduler, SIGINT from a terminal) after its
    checkpoint was written: the message says where and how to resume. A BaseException, like
    KeyboardInterrupt, so that no `except Exception` on the way (a benchmark recording one run's
    fault and going on with the next) mistakes a stop for a failed run. The command line prints
    it as `sfv: <message>` and exits 128 + the signal's number, as a process killed by it would."""

    def __init__(self, message: str, signal_number: int):
        super().__init__(message)
        self.exit_code = 128 + int(signal_number)
