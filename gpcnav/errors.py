class UsageError(Exception):
    """Bad input from the user: reported as one line, exit status 2."""


class ControllerError(Exception):
    """A user's controller (``--controller MODULE:CLASS``) raised in ``reset()`` or
    ``decide()``: its class, the instant and its error, reported as one line, exit status 2
    (it does not answer the Policy protocol). The project's own controllers raising is a bug
    of ours and keeps its traceback."""


MIN_SAMPLE_TIME_S = 0.05
"""The shortest sample time the command line takes (``--sample-time``, ``--set sample_time_s``, a
``MODULE:CLASS`` controller's ``sample_time_s``): an episode is one decision per sample, so shorter
ones multiply its length (a 40 s scenario at 0.05 s is 800 decisions, at 1e-6 s forty million); the
presets use 0.5 and 1.5 s."""


def comma_items(text: str, option: str) -> list[str]:
    """The comma-separated items of ``text`` (an option's list), stripped; an empty item between
    commas (``nn,``, ``1,,2``: a name or number left out, a shell variable unset) is a
    :class:`UsageError` naming ``option``, not skipped. Empty ``text`` is no item."""
    items = [v.strip() for v in text.split(",")] if text.strip() else []
    if not all(items):
        raise UsageError(f"{option} {text!r}: an empty item between commas")
    return items
