"""Errors follicle raises for bad input or a too large request: each names the file or
field and the fix."""

from __future__ import annotations


class FollicleError(Exception):
    """Base of every error caused by what the user gave us (the CLI exits 2 on it)."""


class InputError(FollicleError, ValueError):
    """An argument, array or value is out of range, of the wrong shape, or not finite."""


class FormatError(FollicleError):
    """A file cannot be read: missing, unknown extension, truncated or malformed."""


class FileAccessError(FormatError):
    """A file that is not there, or that this process may not read or write (no such
    file, no permission, a full disk, a server that does not answer), unlike one whose
    contents are wrong: the fix is where the file is, not what it holds. On a cluster,
    the usual sign of a worker that does not see the client's paths."""


class ConfigError(FollicleError):
    """A scene file (TOML) has a syntax error, an unknown key or a bad value."""


class SimulationError(FollicleError):
    """A simulation left the range where it is meaningful (a non-finite or exploding
    state) although every input was valid: a bug to report, or settings to soften."""


class ResourceError(FollicleError):
    """A valid request that needs more memory or time than this machine or a limit gives
    (e.g. more hair than fits in free memory): the fix is a smaller request or a split,
    not a different value. A file that declares an impossible size is a FormatError."""
