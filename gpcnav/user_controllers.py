"""A user's controller (``--controller MODULE:CLASS``) as the commands run it: made, held to the
Policy protocol (``decide``, ``reset``, ``sample_time_s``) in one line each, and wrapped so that an
error of theirs is one line too (:mod:`gpcnav.controllers` imports the class and registers it
beside the built-in controllers)."""
from __future__ import annotations

from .errors import MIN_SAMPLE_TIME_S, ControllerError, UsageError

__all__ = ["UserController", "make_user", "one_line"]


def one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split())
    return f"{type(exc).__name__}: {text}" if text else type(exc).__name__


def _check_protocol(text: str, controller) -> None:
    """Refuse, in one line, an object that does not answer the Policy protocol, or raises when read."""
    try:  # (a sample_time_s property that raised was a traceback, exit 1)
        missing = [m for m in ("decide", "reset") if not callable(getattr(controller, m, None))]
        T = getattr(controller, "sample_time_s", None)
    except Exception as exc:  # noqa: BLE001  (the user's code)
        raise UsageError(f"--controller {text}: reading its Policy protocol raised {one_line(exc)}") from None
    if missing:
        raise UsageError(f"--controller {text}: does not answer the Policy protocol (no {' and no '.join(missing)}"
                         f" method; see README, 'Your own controller')")
    from casadi_gpc.types import positive_seconds
    if not positive_seconds(T):  # numpy's numbers too
        raise UsageError(f"--controller {text}: does not answer the Policy protocol (sample_time_s must be a "
                         f"positive number of seconds, got {T!r})")
    if T < MIN_SAMPLE_TIME_S:  # --sample-time's rule (1e-9 s was taken: 4e10 decisions for 40 s)
        raise UsageError(f"--controller {text}: sample_time_s must be at least {MIN_SAMPLE_TIME_S} s, as "
                         f"--sample-time's, got {float(T):g} (one decision per sample)")


def make_user(text: str, cls: type):
    """The user's class ``cls`` (named ``text``, ``MODULE:CLASS``) made with no arguments and held to the
    Policy protocol, as the commands run it (:class:`UserController`)."""
    try:
        controller = cls()
    except Exception as exc:  # noqa: BLE001
        raise UsageError(f"--controller {text}: cannot be made with no arguments ({one_line(exc)})") from None
    _check_protocol(text, controller)
    return UserController(text, controller)


class UserController:
    """A user's class (``MODULE:CLASS``) as the commands run it: its ``reset()`` and
    ``decide()`` called as they are, an exception of theirs a :class:`ControllerError` of one
    line (the class, the instant, the error; the traceback kept as its cause), every other
    attribute the class's own. ``wrapped``: the user's object."""

    def __init__(self, text: str, wrapped):
        self.text, self.wrapped = text, wrapped

    def __getattr__(self, name):  # (not the proxy's own, nor a special name: a copy or pickle made before __init__)
        if name in ("text", "wrapped") or name.startswith("__"):
            raise AttributeError(name)
        return getattr(self.wrapped, name)

    def reset(self) -> None:
        try:
            self.wrapped.reset()
        except Exception as exc:  # noqa: BLE001  (the user's code: any error of theirs)
            raise ControllerError(f"--controller {self.text}: reset() raised {one_line(exc)}") from exc

    def decide(self, observation):
        from casadi_gpc.types import checked_decision
        try:
            decision = self.wrapped.decide(observation)
        except Exception as exc:  # noqa: BLE001
            raise ControllerError(f"--controller {self.text}: decide() raised at t = {float(observation.t_s):g} s: "
                                  f"{one_line(exc)}") from exc
        return checked_decision(decision, self.wrapped, numbers=True)  # named as the user's class
