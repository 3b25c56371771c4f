"""Former public names kept working: deprecated function aliases and keyword names.

The public vocabulary is American and says ``neighbors=`` for a neighbour table
(STYLE section 9, "one word, one meaning"); the British or older names that were
public keep working through these two helpers and emit one `DeprecationWarning`
per call, a single line naming the new name (Python's default filters show it once
per calling line).
"""

from __future__ import annotations

import functools
import warnings

__all__ = ["deprecated_alias", "renamed_keywords", "warn_renamed"]


def warn_renamed(old: str, new: str, *, stacklevel: int = 3) -> None:
    """Emit ``DeprecationWarning: <old> is deprecated; use <new>`` for the caller's line.

    Parameters
    ----------
    old, new : str
        The former and the current name, as the user writes them (``"f"``, ``"f(x=)"``).
    stacklevel : int
        Frame the warning points at: the default 3 is the caller of the function
        that calls `warn_renamed`.
    """
    warnings.warn(f"{old} is deprecated; use {new}", DeprecationWarning, stacklevel=stacklevel)


def deprecated_alias(func, old_name: str, *, new_name: str | None = None):
    """A thin alias of ``func`` under its former name that warns on each call.

    Parameters
    ----------
    func : callable
        The function (or class) under its current name.
    old_name : str
        The former public name.
    new_name : str, optional
        The name to point users at; ``func.__name__`` by default.

    Returns
    -------
    alias : callable
        Calls ``func`` with the same arguments after the warning; its signature is
        ``func``'s.

    Examples
    --------
    >>> import warnings
    >>> def colorize(x):
    ...     return x + 1
    >>> colourise = deprecated_alias(colorize, "colourise")
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     colourise(1)
    2
    >>> str(caught[0].message)
    'colourise is deprecated; use colorize'
    """
    new = new_name or func.__name__

    @functools.wraps(func)
    def alias(*args, **kwargs):
        warn_renamed(old_name, new)
        return func(*args, **kwargs)

    alias.__name__ = alias.__qualname__ = old_name
    alias.__doc__ = f"Deprecated alias of `{new}` (the former name, kept for old code)."
    return alias


def renamed_keywords(**old_to_new: str):
    """Decorator: accept each former keyword name with a `DeprecationWarning`.

    ``@renamed_keywords(indices="neighbors")`` passes ``indices=x`` on as
    ``neighbors=x`` after one warning naming the new keyword; giving both is a
    `TypeError`. The decorated function's signature (``inspect.signature``) shows
    the new names only.

    Parameters
    ----------
    **old_to_new : str
        Former keyword name -> current keyword name.

    Returns
    -------
    decorator : callable

    Examples
    --------
    >>> import warnings
    >>> @renamed_keywords(indices="neighbors")
    ... def count(*, neighbors=()):
    ...     return len(neighbors)
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     count(indices=[1, 2])
    2
    >>> str(caught[0].message)
    'count(indices=) is deprecated; use count(neighbors=)'
    """

    def decorate(func):
        name = func.__name__

        @functools.wraps(func)
        def wrapper(*args, **kwargs):
            for old, new in old_to_new.items():
                if old not in kwargs:
                    continue
                if new in kwargs:
                    raise TypeError(
                        f"{name}() got {new}= and its former name {old}=: give {new}= only "
                        "(not both)"
                    )
                warn_renamed(f"{name}({old}=)", f"{name}({new}=)")
                kwargs[new] = kwargs.pop(old)
            return func(*args, **kwargs)

        return wrapper

    return decorate
