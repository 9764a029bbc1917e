"""Errors the command line turns into one line on stderr and an exit status."""


class UsageError(Exception):
    """Unusable input (a broken fleet.yaml, a missing file, a bad option): exit status 2."""

    exit_status = 2
