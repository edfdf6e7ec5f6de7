"""Errors a user can act on.  The CLI prints their message on one line and exits 2; the API
answers 4xx with it.  Anything else is a bug and is allowed to show a traceback."""


class BenchError(Exception):
    """Base of the errors that describe a problem with the user's input or set-up."""


class InputError(BenchError, ValueError):
    """A record, option or configuration the tool cannot use, and why."""


class NotIdentifiable(InputError):
    """The record does not contain what identification needs (e.g. no sliding)."""
