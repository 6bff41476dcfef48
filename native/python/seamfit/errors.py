"""Errors a user can act on. Each names the file, panel, stitch or vertex at fault."""


class SeamfitError(Exception):
    """Base class for every error seamfit reports to a user."""


class PatternError(SeamfitError):
    """A pattern file or pattern object is invalid."""


class BodyError(SeamfitError):
    """A body mesh is invalid."""


class SolveError(SeamfitError):
    """A solve could not run or could not converge."""


class DeviceError(SeamfitError):
    """The requested compute device is not available."""
