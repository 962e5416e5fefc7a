"""The building blocks of every case-file model: numbers, names, the base models and tagged specs.

Every model is frozen, forbids unknown keys (with a "did you mean …?" hint, or the sibling model a
key belongs to) and accepts finite numbers only. :class:`TaggedSpec` is a spec written
``{tag: {fields…}}``; :func:`tagged_union` is the type "one of a registry of tagged specs".
"""

from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Annotated, Any, ClassVar, Union

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Tag,
    ValidationError,
    ValidationInfo,
    model_serializer,
    model_validator,
)
from pydantic_core import PydanticCustomError

from femref.case.errors import Problem, did_you_mean, problems_error, problems_from

__all__ = [
    "CaseModel",
    "Count",
    "NonNegativeReal",
    "PositiveReal",
    "ProbeName",
    "Real",
    "TaggedSpec",
    "resolve_case_path",
]


def reject_bool(value: Any) -> Any:
    """YAML ``true``/``yes`` would otherwise pass as the number 1."""
    if isinstance(value, bool):
        raise PydanticCustomError("number_not_bool", "must be a number, not true/false")
    return value


def is_number(value: Any) -> bool:
    """A number, or text that reads as one (YAML 1.1 reads ``1e9`` as text)."""
    if isinstance(value, str):
        try:
            float(value)
        except ValueError:
            return False
        return True
    return isinstance(value, (int, float)) and not isinstance(value, bool)


#: A finite real number (NaN and ±inf are refused by every model's configuration).
Real = Annotated[float, BeforeValidator(reject_bool)]
PositiveReal = Annotated[Real, Field(gt=0)]
NonNegativeReal = Annotated[Real, Field(ge=0)]
#: An integer >= 1 (element counts, strides, sample counts).
Count = Annotated[int, BeforeValidator(reject_bool), Field(ge=1)]


def validate_collecting(handler: Callable[[Any], Any], data: Any, problems: list[Problem]) -> Any:
    """Run ``handler(data)``; raise its problems together with ``problems`` if there are any."""
    try:
        result = handler(data)
    except ValidationError as error:
        problems = [*problems, *problems_from(error, data)]
    if problems:
        raise problems_error(problems)
    return result


class CaseModel(BaseModel):
    """Base of every case-file model: frozen, finite numbers, unknown keys refused with a hint."""

    model_config = ConfigDict(frozen=True, extra="forbid", allow_inf_nan=False, defer_build=True)

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        """Rewrite an accepted short form of the input (a number, a ``{tag: …}`` wrapper)."""
        return data

    @classmethod
    def _unknown_key_rule(cls, key: Any, known: list[str]) -> str:
        hint = did_you_mean(key, known)
        return f"unknown key{hint}" if hint else f"unknown key; expected one of: {', '.join(known)}"

    @model_validator(mode="wrap")
    @classmethod
    def _known_keys_only(cls, data: Any, handler: Callable[[Any], Any]) -> Any:
        data = cls._shorthand(data)
        if not isinstance(data, Mapping):
            return handler(data)
        fields = cls.model_fields
        unknown = [key for key in data if key not in fields]
        if not unknown:
            return handler(data)
        problems = [Problem((str(key),), cls._unknown_key_rule(key, list(fields))) for key in unknown]
        return validate_collecting(handler, {k: v for k, v in data.items() if k in fields}, problems)


def foreign_key_rule(
    cls: type[CaseModel], key: Any, known: list[str], family: Mapping[str, type[CaseModel]], tag_field: str, noun: str
) -> str | None:
    """``'axial_stiffness' is a rod key, not a beam key`` when ``key`` belongs to a sibling model."""
    own = cls.model_fields[tag_field].default
    for name, other in family.items():
        if other is not cls and key in other.model_fields:
            return f"{key!r} is a {name}{noun} key, not a {own}{noun} key{did_you_mean(key, known)}"
    return None


class TaggedSpec(CaseModel):
    """A spec written ``{tag: {fields…}}`` in the case file (the tag picks the class), or, with a ``number_field``,
    as a plain number: the value of that field."""

    tag: ClassVar[str]
    number_field: ClassVar[str | None] = None

    @classmethod
    def _shorthand(cls, data: Any) -> Any:
        if cls.number_field is not None:
            return {cls.number_field: data} if is_number(data) else data
        if isinstance(data, Mapping) and len(data) == 1 and cls.tag in data:
            return data[cls.tag]
        return data

    @model_serializer(mode="wrap")
    def _serialize(self, handler: Callable[[Any], Any]) -> Any:
        return {self.tag: handler(self)} if self.number_field is None else getattr(self, self.number_field)


def tagged_union(registry: Mapping[str, type[TaggedSpec]], what: str, number_tag: str | None = None) -> Any:
    """The type "a number (if ``number_tag``) or a mapping with exactly one key of ``registry``"."""
    named = [name for name in registry if name != number_tag]
    expected = ("a number or " if number_tag else "") + f"a mapping with exactly one key out of {', '.join(named)}"

    def tag_of(value: Any) -> str | None:
        if isinstance(value, TaggedSpec):
            return value.tag
        if number_tag is not None and is_number(value):
            return number_tag
        if isinstance(value, Mapping) and len(value) == 1:
            return next(iter(value))
        return None

    def check_shape(value: Any) -> Any:
        if isinstance(value, TaggedSpec) or (number_tag is not None and is_number(value)):
            return value
        if not isinstance(value, Mapping):
            raise PydanticCustomError("spec_shape", "{rule}", {"rule": f"must be {expected}"})
        unknown = [key for key in value if key not in named]
        if unknown:
            raise problems_error([Problem((k,), f"unknown {what}{did_you_mean(k, named)}; expected {expected}") for k in unknown])
        if len(value) != 1:
            given = f"got {' and '.join(map(str, value))} together" if value else "got an empty mapping"
            raise problems_error([Problem((), f"give exactly one of {', '.join(named)}; {given}")])
        return value

    members = tuple(Annotated[cls, Tag(name)] for name, cls in registry.items())
    return Annotated[Union[members], Discriminator(tag_of), BeforeValidator(check_shape)]  # noqa: UP007


def name_or_model(name: Any, model: type[CaseModel], tags: tuple[str, str], shape_error: tuple[str, str, dict[str, str]],
                  names: tuple[type, ...] = (str,)) -> Any:
    """The type "a name (an instance of ``names``, validated as ``name``) or a mapping validated as ``model``",
    discriminated by ``tags`` (tags no input has as a key: error key paths drop them); anything else raises
    the ``PydanticCustomError(*shape_error)``."""

    def tag_of(value: Any) -> str | None:
        if isinstance(value, names):
            return tags[0]
        if isinstance(value, (Mapping, model)):
            return tags[1]
        return None

    def check_shape(value: Any) -> Any:
        if tag_of(value) is None:
            raise PydanticCustomError(*shape_error)
        return value

    return Annotated[Annotated[name, Tag(tags[0])] | Annotated[model, Tag(tags[1])], Discriminator(tag_of), BeforeValidator(check_shape)]


def name_rule(what: str) -> Callable[[str], str]:
    """A validator: ``what`` names use letters, digits, '_', '-', '.' (they become HDF5 path parts)."""

    def check(name: str) -> str:
        if not name or not all(c.isalnum() or c in "_-." for c in name):
            raise PydanticCustomError("name_chars", "{what} names use letters, digits, '_', '-' and '.' only", {"what": what})
        return name

    return check


ProbeName = Annotated[str, AfterValidator(name_rule("probe"))]


def entry_name(entry: Any) -> str:
    """The result-group name of a ``models`` or ``estimators`` entry: a plain name, or a mapping's ``name``."""
    return entry if isinstance(entry, str) else entry.name


def duplicates(names: list[str], what: str, path_of: Callable[[int], tuple[str | int, ...]]) -> list[Problem]:
    """A problem at each repeat of a name, pointing back at its first use."""
    first: dict[str, int] = {}
    problems = []
    for i, name in enumerate(names):
        if name in first:
            problems.append(Problem(path_of(i), f"duplicate {what} name; {name!r} is already used at index {first[name]}", name))
        first.setdefault(name, i)
    return problems


def resolve_case_path(path: Path, info: ValidationInfo) -> Path:
    """A file path of a case, absolute: a relative path is relative to the validation context's ``base_dir``
    (the case file's directory, set by the loader; without one, the working directory)."""
    base_dir = Path((info.context or {}).get("base_dir") or Path.cwd())
    path = path.expanduser()
    return path if path.is_absolute() else (base_dir / path).resolve()
