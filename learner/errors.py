"""Errors raised by the learner; all are one-line, user-facing `SfvError`s."""

from actors.errors import SfvError


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
