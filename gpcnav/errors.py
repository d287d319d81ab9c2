class UsageError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


class ControllerError(Exception):
    """A user's controller (``--controller MODULE:CLASS``) raised in ``reset()`` or
    ``decide()``: its class, the instant and its error, reported as one line, exit status 2
    (it does not answer the Policy protocol). The project's own controllers raising is a bug
    of ours and keeps its traceback."""
