"""What stook's readers build in bulk, built without the constructors' general paths.

Shared by stook's distributions (the service reads API listings the same way the SDK reads
metrics data), so that there is one of each:

* `hex_uuid`: ``uuid.UUID(hex=text)`` without ``UUID.__init__``'s rewrites, for the
  hexadecimal IDs outputs and the API hold;
* `writable_twin`: frozen slotted dataclasses built without their ``__init__``. Such a
  dataclass's ``__init__`` sets each field through ``object.__setattr__`` (a 13-field
  `MetricsDataView` cost ~2.7 µs that way, a quarter of reading a job's series). An object
  is instead written as an instance of its *writable twin*, a plain class with the same
  slots, whose stores the interpreter specializes (~0.4 µs), and then given the dataclass
  as its ``__class__`` (allowed between classes of the same layout). Equality, hashing,
  ``repr``, pickling and frozenness are then the dataclass's own: the object is one like
  any other.
"""

import dataclasses
import uuid

__all__ = ["hex_uuid", "writable_twin"]

_UUID = uuid.UUID
_new = object.__new__
# What uuid.UUID.__init__ sets, through the slots' own descriptors (UUID's __setattr__
# refuses every write).
_set_int = _UUID.__dict__["int"].__set__
_set_is_safe = _UUID.__dict__["is_safe"].__set__
_UNKNOWN_SAFETY = uuid.SafeUUID.unknown


def hex_uuid(text: str) -> uuid.UUID:
    """``uuid.UUID(hex=text)``: an equal UUID, or the same error (for a value that is not
    a string as well).

    ``UUID.__init__`` first rewrites the text four times to accept URNs and braces (~1.5 µs
    an ID; a batch run reads ~23 IDs a job, and a data view one or two). Text that has 32
    hexadecimal digits once its hyphens are gone is read here the way ``__init__`` reads it
    (the same ``int(…, 16)`` of the same digits, the same state); anything else, valid or
    not, goes to ``uuid.UUID``, which also words the error.
    """
    if type(text) is str:
        digits = text.replace("-", "")
        # A digit string that int() reads holds no "urn:", "uuid:" or braces, which are
        # all __init__ strips besides the hyphens: both read the very same digits.
        if len(digits) == 32:
            try:
                value = int(digits, 16)
            except ValueError:
                pass
            else:
                ident: uuid.UUID = _new(_UUID)
                _set_int(ident, value)
                _set_is_safe(ident, _UNKNOWN_SAFETY)
                return ident
    return _UUID(hex=text)


def writable_twin(cls: type) -> type:
    """A plain class with the slots of `cls`, a frozen slotted dataclass whose slots are
    exactly its fields (TypeError otherwise, as an object written through it could
    then miss a field)."""
    slots = cls.__dict__.get("__slots__")
    if slots is None or tuple(slots) != tuple(f.name for f in dataclasses.fields(cls)):
        raise TypeError(f"{cls.__name__}: its slots are not its fields")
    return type(f"_Writable{cls.__name__}", (), {"__slots__": slots})
