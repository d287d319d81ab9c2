class UsageError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


class ControllerError(Exception):
    """A user's controller (``--controller MODULE:CLASS``) raised in ``reset()`` or
    ``decide()``: its class, the instant and its error, reported as one line, exit status 2
    (it does not answer the Policy protocol). The project's own controllers raising is a bug
    of ours and keeps its traceback."""


def comma_items(text: str, option: str) -> list[str]:
    """The comma-separated items of ``text`` (an option's list), stripped; an empty item between
    commas (``nn,``, ``1,,2``: a name or number left out, a shell variable unset) is a
    :class:`UsageError` naming ``option``, not skipped. Empty ``text`` is no item."""
    items = [v.strip() for v in text.split(",")] if text.strip() else []
    if not all(items):
        raise UsageError(f"{option} {text!r}: an empty item between commas")
    return items
