"""One exception family for nurbscomp; ``cli.py`` turns it into what the user sees.

Inside, it is caught only where a stage has an answer to it (``batch``
counts a file as failed and goes on, ``pipeline`` and the validity stage try
the next remedy).  Every error carries a one-line message. The CLI prints
``error: FILE: message``
and exits with the code of the class (see README, "Exit codes"); a batch
exits with the highest code among its files.
"""

from __future__ import annotations

#: Exit codes (README, "Exit codes and errors").  A batch exits with the
#: highest code among its files, so the codes rise with how much a failure
#: says about the tool rather than about its input.
EXIT_OK = 0
EXIT_INPUT = 1  # a bad input file (or a failure no other code names: out of memory)
EXIT_USAGE = 2  # bad options (click's own code)
EXIT_OUTPUT = 3  # the output exists (without --force) or cannot be written
EXIT_CONTAINER = 4  # a damaged container, or one past the decoding limits
EXIT_VERIFY = 5  # compress decoded what it wrote and it differs (a bug)
EXIT_DIFFERS = 6  # eval: the reconstruction fails its verdict
EXIT_INTERNAL = 70  # an internal error (sysexits' EX_SOFTWARE)


class NurbscompError(Exception):
    """Base class of every error nurbscomp raises on purpose."""

    exit_code = EXIT_INPUT


class InputError(NurbscompError):
    """The input CAD file is missing, unreadable, or holds no B-rep."""


class NoBRepError(InputError):
    """A valid STEP or IGES file that holds no B-rep (tessellated-only, curves or
    points only, nothing the reader transfers).  ``compress`` does not fail on it:
    it stores the file verbatim in a passthrough container (``passthrough``)."""


class FormatError(NurbscompError):
    """A ``.nzc`` container is damaged or not a container at all."""

    exit_code = EXIT_CONTAINER


class BadMagicError(FormatError):
    """The file does not start with the ``.nzc`` magic number."""


class VersionError(FormatError):
    """The container's major version is not one this build can read."""


class TruncatedError(FormatError):
    """The container ends before a declared length."""


class ChecksumError(FormatError):
    """A section's CRC32 does not match its bytes."""


class ReservedBitsError(FormatError):
    """A reserved field or flag bit of the container is not zero."""


class TrailingDataError(FormatError):
    """Bytes follow the end of the container's body."""


class LimitError(FormatError):
    """A declared size is beyond what a reader inflates or allocates (a bomb guard)."""


class CorruptError(FormatError):
    """The container's bytes pass their checksums but do not decode."""


class SectionError(CorruptError):
    """A section's bytes pass their checksum but do not decode.

    The message names the section's tag and where in it the fault is (a byte
    offset, or a table row).
    """


class BadReferenceError(CorruptError):
    """An index in the decoded tables points outside the table it refers to."""


class RebuildError(CorruptError):
    """The decoded tables are consistent but OCCT cannot build (or write) a shape from them."""


class UndiagnosedError(CorruptError):
    """The decoder failed in a way no specific check caught.

    Raised only by the last-resort wrapper in ``pipeline.decode``, which turns
    an unexpected ``ValueError``, ``IndexError`` … of the section decoders into
    a ``FormatError``; the fuzzer (``make fuzz``) counts it as a failure to fix.
    """


class OutputError(NurbscompError):
    """The output cannot be written: it exists already, or its folder is missing."""

    exit_code = EXIT_OUTPUT


class VerifyError(NurbscompError):
    """The written container does not decode to what was encoded."""

    exit_code = EXIT_VERIFY


class UnsupportedError(NurbscompError):
    """The B-rep holds an entity this version cannot store."""


class ArgumentError(NurbscompError, ValueError):
    """The Python API was given an argument it cannot take (an object that is no
    path, bytes or shape; a tolerance that is not a positive number).  Never
    raised by the CLI, whose options are checked by click."""
