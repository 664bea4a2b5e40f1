"""Options objects: pydantic models validated once, their errors as one line naming the option."""

from __future__ import annotations

from typing import TypeVar

from pydantic import BaseModel, ConfigDict, ValidationError

from twin.errors import TwinError

T = TypeVar("T", bound="Options")


class Options(BaseModel):
    """Base of every workflow's options: immutable, unknown fields refused, any Python type allowed."""

    model_config = ConfigDict(frozen=True, extra="forbid", arbitrary_types_allowed=True)

    @classmethod
    def build(cls: type[T], **values) -> T:
        """The options, or :class:`TwinError` naming the first offending option in one line.

        Parameters
        ----------
        **values
            Field values; an option's command-line name is its field name with ``-`` for ``_``.

        Returns
        -------
        Options
        """
        try:
            return cls(**values)
        except ValidationError as exc:
            err = exc.errors()[0]
            where = ".".join(str(x) for x in err["loc"])
            name = f"--{where.replace('_', '-')}" if where else cls.__name__
            raise TwinError(f"{name}: {err['msg'].removeprefix('Value error, ')}") from None
