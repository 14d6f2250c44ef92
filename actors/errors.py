"""Errors with a one-line, user-facing message.

They live in the lowest layer (actors/) so that learner/ and services/ can raise and
catch the same type without anything importing upward.
"""


class SfvError(Exception):
    """A user-facing failure: bad input file, unreachable service, bad request.

    The message is one line and names the file or endpoint and what is wrong.
    The command line prints it as `sfv: <message>` and exits 2.
    """


class MotionFormatError(SfvError, ValueError):
    """A motion file is malformed; the message names the file and the fault."""
