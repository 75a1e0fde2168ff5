"""An attribute kept in its object's state record.

The planner and the guidance keep their mutable state in one record each
(:class:`~attitude_core.fsw.guidance.fepf_state.FepfState`,
:class:`~attitude_core.fsw.guidance.guidance_state.GuidanceState`): the Python one, or
its compiled twin that the compiled step reads and writes in C. A :class:`StateField`
makes one of the record's fields an attribute of the object that holds it as
``state``: ``planner.sigma_t`` is ``planner.state.sigma_t``, read and written, so what
inspects a planner or a guidance sees the attributes it always did.
"""

from __future__ import annotations

from operator import attrgetter
from typing import Any, Generic, TypeVar, overload

__all__ = ["StateField"]

T = TypeVar("T")


class StateField(Generic[T]):
    """The record's field of the attribute's name, less any leading underscore
    (``_since_progress`` is ``state.since_progress``).

    Declared in the class body as ``name = StateField[type]()`` (so the checkers know the
    attribute's type); when the class is made, the declaration puts in its place a
    ``property`` that reads through :func:`operator.attrgetter` (a C call: about twice as
    fast as this descriptor's own ``__get__``, which only runs where that did not
    happen)."""

    __slots__ = ("field",)

    def __init__(self) -> None:
        self.field = ""

    def __set_name__(self, owner: type, name: str) -> None:
        field = self.field = name.lstrip("_")

        def write(obj: Any, value: Any) -> None:
            setattr(obj.state, field, value)

        setattr(
            owner, name, property(attrgetter(f"state.{field}"), write, doc=f"``state.{field}``")
        )

    @overload
    def __get__(self, obj: None, owner: type | None = None) -> StateField[T]: ...

    @overload
    def __get__(self, obj: object, owner: type | None = None) -> T: ...

    def __get__(self, obj: Any, owner: type | None = None) -> Any:
        if obj is None:
            return self
        return getattr(obj.state, self.field)

    def __set__(self, obj: Any, value: T) -> None:
        setattr(obj.state, self.field, value)
