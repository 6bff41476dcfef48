"""Errors a user can act on. Each names the file, panel, stitch or vertex at fault."""

__all__ = ["BodyError", "DeviceError", "LimitError", "PatternError", "ProblemsError", "SeamfitError",
           "SolveError", "ValidationError"]


class SeamfitError(Exception):
    """Base class for every error seamfit reports to a user."""

    def lines(self) -> list[str]:
        """The message as the command line prints it: one line per problem."""
        return [" ".join(str(self).split("\n"))]


class ProblemsError(SeamfitError):
    """Several problems found together (a manifest's, a cluster's): one line each."""

    def __init__(self, problems: list[str]):
        super().__init__("; ".join(problems))
        self.problems = problems

    def lines(self) -> list[str]:
        return list(self.problems)


class PatternError(SeamfitError):
    """A pattern file or pattern object is invalid."""


class ValidationError(PatternError):
    """A pattern failed its checks; ``problems`` lists them, each naming what is at fault."""

    def __init__(self, message: str, problems: list[str]):
        super().__init__(message)
        self.problems = list(problems)

    def lines(self) -> list[str]:
        return list(self.problems) or super().lines()


class BodyError(SeamfitError):
    """A body mesh is invalid."""


class SolveError(SeamfitError):
    """A solve could not run or could not converge."""


class DeviceError(SeamfitError):
    """The requested compute device is not available."""


class LimitError(SeamfitError):
    """An input is larger than a resource limit (seamfit.limits) allows."""
