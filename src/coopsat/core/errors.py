"""Errors as the one line a user reads."""


def one_line(err):
    """An exception as one line: its type, then its message's lines joined by "; "."""
    text = "; ".join(line.strip() for line in str(err).splitlines() if line.strip())
    return f"{type(err).__name__}: {text}" if text else type(err).__name__
