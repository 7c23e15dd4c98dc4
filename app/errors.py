"""Errors the command line reports to the user without a traceback."""
from __future__ import annotations


class UserError(Exception):
    """A problem the user can fix (a bad path, a bad option value, a missing device).

    The message must say what was wrong and what to do; the CLI prints it and exits with status 2.
    """
