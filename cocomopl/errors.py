"""The one exception type a user can cause."""


class Error(Exception):
    """A problem with user input (a number, a file, an option).

    The CLI prints its message on one line and exits non-zero, without a traceback.
    """
