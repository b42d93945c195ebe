"""The one exception type a user can cause."""

import math


class Error(Exception):
    """A problem with user input (a number, a file, an option).

    The CLI prints its message on one line and exits non-zero, without a traceback.
    """


def parse_finite(text: str, what: str) -> float:
    """``text`` as a finite number, else an :class:`Error` naming ``what`` it was to be.

    Only ASCII digits are taken: ``float`` also reads other scripts' digits.
    """
    text = str(text).strip()
    try:
        if not text.isascii():
            raise ValueError
        value = float(text)
    except ValueError:
        raise Error(f"{what} {text!r} is not a number in ASCII digits") from None
    if not math.isfinite(value):
        raise Error(f"{what} {text!r} is not finite")
    return value


def plural(n: int, word: str) -> str:
    """``n`` and ``word``, with an "s" unless ``n`` is one: "1 motion", "64 motions"."""
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def require_extra(module: str, extra: str, what: str) -> None:
    """Raise an :class:`Error` naming the pip extra to install if ``module`` is missing:
    ``what`` (a command or a function) needs the ``[extra]`` extra."""
    import importlib.util

    if importlib.util.find_spec(module) is None:
        raise Error(f"{what} needs the [{extra}] extra: pip install 'cocomopl[{extra}]' (or pip install -e '.[{extra}]')")
