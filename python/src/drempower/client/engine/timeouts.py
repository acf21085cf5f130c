"""Checks of the time arguments of the client API (``timeout``, ``poll_interval``), before anything is sent.

A time is a number of seconds, > 0 and at most :data:`MAX_TIMEOUT`; anything else
(a string, NaN, infinity, 1e12 s, which the operating system's waits cannot hold)
raises :class:`~drempower.errors.ValidationError` naming the argument. The class
decorator :func:`checks_times` applies the check to every public method of a
front end, so a bad time is refused before the method sends its first frame.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from types import FunctionType
from typing import Any, TypeVar

from ...errors import ValidationError

__all__ = ["MAX_TIMEOUT", "TIME_ARGUMENTS", "check_timeout", "checks_times", "seconds"]

MAX_TIMEOUT = 86_400.0
"""The longest time any call waits (s): one day."""

TIME_ARGUMENTS = ("timeout", "poll_interval")
"""The arguments, by name, that :func:`checks_times` checks."""

C = TypeVar("C", bound=type)

_CO_COROUTINE = 0x80
"""``co_flags`` bit of an ``async def`` function (``inspect.CO_COROUTINE``; inspect itself is slow to import)."""
_NO_DEFAULT = object()


def check_timeout(value: object, name: str = "timeout", *, none_ok: bool = True) -> float | None:
    """``value`` as seconds (float), or None when ``none_ok``; :class:`ValidationError` otherwise."""
    if value is None and none_ok:
        return None
    return seconds(value, name)


def seconds(value: object, name: str = "timeout") -> float:
    """``value`` as seconds (float): a number > 0 and at most :data:`MAX_TIMEOUT`."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise ValidationError(f"{name}={value!r}: expected a number of seconds")
    if not 0 < value <= MAX_TIMEOUT:  # also refuses NaN
        limit = f"must be > 0 s and at most {MAX_TIMEOUT:g} s (one day)"
        detail = "not a number of seconds" if math.isnan(value) else limit
        raise ValidationError(f"{name}={value!r}: {detail}")
    return float(value)


def _checked(fn: Callable[..., Any]) -> Callable[..., Any] | None:
    """``fn`` wrapped to check its time arguments, or None when it has none."""
    code = fn.__code__
    npos = code.co_argcount
    positional = code.co_varnames[:npos]
    keyword_only = code.co_varnames[npos : npos + code.co_kwonlyargcount]
    defaults = fn.__defaults__ or ()
    kwdefaults = fn.__kwdefaults__ or {}
    checks: list[tuple[int, str, bool]] = []
    for n in TIME_ARGUMENTS:
        if n in positional:
            index = positional.index(n)
            k = index - (npos - len(defaults))
            default = defaults[k] if k >= 0 else _NO_DEFAULT
        elif n in keyword_only:
            index = 1 << 30  # never passed by position
            default = kwdefaults.get(n, _NO_DEFAULT)
        else:
            continue
        checks.append((index, n, default is None))
    if not checks:
        return None

    first = min(index for index, _, _ in checks)
    """The first position a time argument may take: a call with fewer arguments and no keywords has none."""

    def check(args: tuple[Any, ...], kwargs: dict[str, Any]) -> None:
        for index, name, none_ok in checks:
            if name in kwargs:
                check_timeout(kwargs[name], name, none_ok=none_ok)
            elif index < len(args):
                check_timeout(args[index], name, none_ok=none_ok)

    if code.co_flags & _CO_COROUTINE:

        @functools.wraps(fn)
        async def run_async(*args: Any, **kwargs: Any) -> Any:
            if kwargs or len(args) > first:  # else no time argument was given
                check(args, kwargs)
            return await fn(*args, **kwargs)

        return run_async

    @functools.wraps(fn)
    def run(*args: Any, **kwargs: Any) -> Any:
        if kwargs or len(args) > first:  # else no time argument was given (get_state() and the like)
            check(args, kwargs)
        return fn(*args, **kwargs)

    return run


def checks_times(cls: C) -> C:
    """Class decorator: every public method of ``cls`` with a time argument checks it first."""
    for name, fn in list(vars(cls).items()):
        if name.startswith("_") or not isinstance(fn, FunctionType):
            continue
        wrapped = _checked(fn)
        if wrapped is not None:
            setattr(cls, name, wrapped)
    return cls
