"""The project's exceptions. The CLI turns each into one line on stderr and exit status 2."""


class TwinError(Exception):
    """Base class: a message naming what was wrong, where, and what would be right."""


class ScenarioError(TwinError):
    """A scenario file that cannot be loaded or run."""


class DatasetError(TwinError):
    """A dataset file that cannot be read or written."""


class ModelError(TwinError):
    """A model (effect composition) that cannot be built."""
