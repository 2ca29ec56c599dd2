"""ROS message types for the readers.

Types come from the definitions a file embeds (ROS 1 connection headers, MCAP ``ros1msg``
/ ``ros2msg`` / ``ros2idl`` schemas, rosbag2 ``message_definitions``), parsed by rosbags
into a typestore per definition text (definitions of two files, or two topics, may
differ under the same type name). ROS 2 bags that embed no definitions fall back to the
user's message path (``--msg-path``, :data:`MSG_PATH_ENV`: the ``.msg`` files of their
own packages), then to the standard typestores shipped with rosbags, newest
distributions first.
"""

from __future__ import annotations

import os
from functools import cache
from pathlib import Path
from typing import Any

from rosbags.interfaces import Nodetype
from rosbags.typesys import Stores, get_types_from_idl, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from analyzer.types import MSG_PATH_ENV

FALLBACK_STORES: tuple[Stores, ...] = (
    Stores.ROS2_HUMBLE,
    Stores.ROS2_JAZZY,
    Stores.ROS2_IRON,
    Stores.ROS2_KILTED,
    Stores.ROS2_GALACTIC,
    Stores.ROS2_FOXY,
    Stores.ROS2_ELOQUENT,
    Stores.ROS2_DASHING,
)
"""Standard typestores tried, in order, for a type a ROS 2 bag does not define."""

IDL_SEPARATOR = "=" * 80 + "\n"


class TypeResolutionError(Exception):
    """A message type cannot be resolved (unparsable or missing definition)."""


class MessagePathError(ValueError):
    """The message path cannot be read (a missing directory, an unparsable ``.msg``)."""


class EmptyMessageType(TypeResolutionError):
    """A message type whose definition is empty (``std_msgs/Empty``, a marker topic): it
    has no field, so no channel; its topic is passed over without an error."""


EMPTY_MESSAGE_BYTES = {"cdr": 8, "ros1": 0}
"""Longest message of a type without fields, by wire format: CDR's 4-byte encapsulation
header and the one-byte member ROS 2 gives an empty structure, padded to 8 at most; ROS 1
serializes nothing. A type whose definition in a file is empty, and that no typestore
defines, is taken for such a type when its messages are no longer (a marker topic: no
channel, nothing wrong), and for a type the recorder did not find a definition for when
they are (an error naming ``--msg-path``). A type whose one field fits in 4 bytes
(``uint8 mode``, say) looks empty this way; its ``.msg`` on the message path reads it."""


class ServiceEventType(TypeResolutionError):
    """A ROS 2 service event type (``pkg/srv/Name_Event``, on a ``<service>/_service_event``
    topic: service introspection, recorded by rosbag2 since Iron): each message is one
    request or response of a call to the service (who called, when, the call's
    arguments or results), not a measurement. Its topic is skipped with a note that says
    so (:func:`refuse_service_event`), not decoded: recorders store the service's
    ``.srv`` text as its definition (request ``---`` response, not the ``_Event``
    message on the wire), which the parsers took for a syntax error, and a ROS 2 bag
    without embedded definitions named ``--msg-path``, as if the fix were a missing
    definition."""


MAX_NESTING = 64
"""The deepest a message definition may nest types (a field of a type with a field of a
type...): real ones nest a few levels (``sensor_msgs/msg/Imu``: 3); a definition
nested 20 000 deep exhausted Python's stack while its messages were decoded, and the
whole file was lost (security review ux63, M2). A type nested deeper, or within
itself, is refused (:class:`NestedTooDeep`): its topic is skipped with a note."""


class NestedTooDeep(TypeResolutionError):
    """A message definition that nests types more than :data:`MAX_NESTING` deep, or a
    type within itself (:func:`check_nesting`)."""


def _field_types(store: Typestore, msgtype: str) -> set[str]:
    """The types the fields of ``msgtype`` hold (of arrays and sequences too)."""
    found = set()
    for _, desc in store.fielddefs.get(msgtype, ((), ()))[1]:
        while desc[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE):
            desc = desc[1][0]
        if desc[0] == Nodetype.NAME:
            found.add(desc[1])
    return found


def check_nesting(store: Typestore, msgtype: str) -> None:
    """Raise :class:`NestedTooDeep` when ``msgtype`` nests types more than
    :data:`MAX_NESTING` deep in ``store``, or holds itself (then every level has a
    type): level by level, without recursion, at most that many levels."""
    level = {msgtype}
    for _ in range(MAX_NESTING):
        level = set().union(*(_field_types(store, t) for t in level))
        if not level:
            return
    raise NestedTooDeep(
        f"its message definition nests types more than {MAX_NESTING} deep, or within "
        "themselves (real ones nest a few)"
    )


SERVICE_EVENT_SUFFIX = "_Event"
"""The end of a service event type's name (``example_interfaces/srv/AddTwoInts_Event``)."""


SERVICE_EVENT_KINDS = ("srv", "action")
"""The interface kinds whose types end in :data:`SERVICE_EVENT_SUFFIX` only as service
events: a service's (``pkg/srv/Name_Event``) and an action's two services'
(``pkg/action/Name_SendGoal_Event``, ``pkg/action/Name_GetResult_Event``, on
``<action>/_action/send_goal/_service_event``); a message type of that name
(``pkg/msg/Door_Event``) is read as any other."""


def refuse_service_event(msgtype: str) -> None:
    """Raise :class:`ServiceEventType` for a ROS 2 service event type (of
    :data:`SERVICE_EVENT_KINDS`); return for any other."""
    parts = msgtype.strip().split("/")
    if (
        len(parts) == 3
        and parts[1] in SERVICE_EVENT_KINDS
        and parts[2].endswith(SERVICE_EVENT_SUFFIX)
    ):
        raise ServiceEventType(
            f"ROS 2 service events ({msgtype.strip()}: the requests and responses of calls "
            "to a service), not sensor data"
        )


def normalize_msgtype(name: str) -> str:
    """``pkg/Type`` -> ``pkg/msg/Type`` (ROS 1 and old rosbag2 spell types without ``msg``)."""
    parts = name.strip().split("/")
    if len(parts) == 2:
        return f"{parts[0]}/msg/{parts[1]}"
    return name.strip()


@cache
def _definition_store(msgtype: str, text: str, fmt: str) -> Typestore:
    try:
        if fmt == "idl":
            types = {}
            if text.startswith(f"{IDL_SEPARATOR}IDL: "):
                for section in text.split(IDL_SEPARATOR)[1:]:
                    _, idl = section.split("\n", 1)
                    types.update(get_types_from_idl(idl))
            else:
                types.update(get_types_from_idl(text))
        else:
            types = get_types_from_msg(text, msgtype)
        store = get_typestore(Stores.EMPTY)
        store.register(types)
    except Exception as err:  # rosbags raises several parser error types
        raise TypeResolutionError(
            f"cannot parse the {fmt} definition of {msgtype!r}: {_short(err)}"
        ) from err
    if msgtype not in store.fielddefs:
        raise TypeResolutionError(f"the embedded definition does not define {msgtype!r}")
    check_nesting(store, msgtype)
    return store


def store_from_definition(msgtype: str, text: str, fmt: str = "msg") -> Typestore:
    """A typestore holding ``msgtype`` and its dependencies, parsed from ``text``
    (``fmt`` ``"msg"``: ROS 1 or ROS 2 .msg text with ``MSG:`` sections; ``"idl"``)."""
    return _definition_store(normalize_msgtype(msgtype), text, fmt)


@cache
def standard_store(store: Stores) -> Typestore:
    """One of rosbags' standard typestores (cached: building one takes ~0.1 s)."""
    return get_typestore(store)


@cache
def user_store(spec: str) -> Typestore | None:
    """The typestore of the message path ``spec`` (see :data:`MSG_PATH_ENV`): every
    ``<package>/msg/<Type>.msg`` below its directories, and the newest standard types
    they do not redefine (which they may use); None for an empty path.
    :class:`MessagePathError` naming the directory or file that cannot be read."""
    dirs = [Path(part) for part in spec.split(os.pathsep) if part]
    if not dirs:
        return None
    types: dict[str, Any] = {}
    for directory in dirs:
        if not directory.is_dir():
            what = "not a directory" if directory.exists() else "no such directory"
            raise MessagePathError(f"{directory}: {what}")
        for path in sorted(directory.rglob("*.msg")):
            if path.parent.name != "msg":
                continue  # not a package's msg/ folder
            name = f"{path.parent.parent.name}/msg/{path.stem}"
            try:
                types.update(get_types_from_msg(path.read_text(encoding="utf-8"), name))
            except (OSError, UnicodeDecodeError) as err:
                raise MessagePathError(f"{path}: cannot read ({_short(err)})") from err
            except Exception as err:  # rosbags raises several parser error types
                raise MessagePathError(f"{path}: cannot parse ({_short(err)})") from err
    if not types:
        raise MessagePathError(f"{spec}: no <package>/msg/<Type>.msg file below it")
    # the newest standard types the user's may use; where the user defines one of them
    # too (a workspace of another distribution), the user's definition is the one kept
    base = standard_store(FALLBACK_STORES[0])
    standard = {name: base.fielddefs[name] for name in base.fielddefs if name not in types}
    store = get_typestore(Stores.EMPTY)
    try:
        store.register({**standard, **types})
    except Exception as err:  # rosbags raises several error types
        raise MessagePathError(f"{spec}: {_short(err)}") from err
    return store


def msg_path_hint(msgtype: str) -> str:
    """The fix for a message type a file does not define, worded alike for every format
    (MCAP files and ROS 2 bags said it two ways): the ``.msg`` file's path, which
    :func:`user_store` finds at any depth below a ``--msg-path`` folder."""
    return f"give the folder that holds {normalize_msgtype(msgtype)}.msg with --msg-path"


def candidate_stores(msgtype: str) -> list[Typestore]:
    """Typestores that define ``msgtype`` for a file that does not: the user's message
    path first (:data:`MSG_PATH_ENV`), then the standard ones in :data:`FALLBACK_STORES`
    order, without duplicates of an identical definition."""
    name = normalize_msgtype(msgtype)
    found: list[Typestore] = []
    seen: list[object] = []
    try:
        user = user_store(os.environ.get(MSG_PATH_ENV, ""))
    except MessagePathError as err:  # the CLI checks it up front; a library caller may not
        raise TypeResolutionError(f"{MSG_PATH_ENV}: {err}") from err
    stores = ([user] if user is not None else []) + [standard_store(w) for w in FALLBACK_STORES]
    for store in stores:
        if name in store.fielddefs:
            definition = _closure(store, name)
            if definition not in seen:
                seen.append(definition)
                found.append(store)
    return found


def _closure(store: Typestore, name: str) -> tuple[object, ...]:
    """The field definitions of ``name`` and every type it uses (for de-duplication)."""
    out: list[object] = []
    todo = [name]
    done: set[str] = set()
    while todo:
        current = todo.pop()
        if current in done:
            continue
        done.add(current)
        fields = store.fielddefs[current][1]
        out.append((current, tuple(fields)))
        for _, desc in fields:
            node = desc
            while node[0] in (Nodetype.ARRAY, Nodetype.SEQUENCE):
                node = node[1][0]
            if node[0] == Nodetype.NAME:
                todo.append(node[1])
    return tuple(out)


def _short(err: BaseException) -> str:
    text = " ".join(str(err).split())
    if text.startswith("Could not parse"):
        return "syntax error"  # rosbags echoes the whole remaining text: not useful
    return text[:160] if text else type(err).__name__
