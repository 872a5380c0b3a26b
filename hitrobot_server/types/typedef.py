"""rosapi ``TypeDef`` lists, shaped like ROS 1 rosapi's ``objectutils`` output.

Clients (roslibjs ``Ros.getMessageDetails`` + ``decodeTypeDefs``) walk these to build forms and
examples, so names are ROS 1 short names and the quirks are kept: ``time``/``duration`` fields
show ``{}`` as example and get a synthetic typedef, constants are listed alphabetically.
"""

from __future__ import annotations

from typing import Any

from hitrobot_server.types.registry import MsgType, TypeRegistry

_EXAMPLES = {"bool": "False", "string": "", "float32": "0.0", "float64": "0.0"}
_TIME_BASES = ("time", "duration")


def _time_typedef(name: str) -> dict[str, Any]:
    return {
        "type": name,
        "fieldnames": ["secs", "nsecs"],
        "fieldtypes": ["int32", "int32"],
        "fieldarraylen": [-1, -1],
        "examples": ["0", "0"],
        "constnames": [],
        "constvalues": [],
    }


def _typedef(mtype: MsgType) -> dict[str, Any]:
    fieldtypes, arraylens, examples = [], [], []
    for field in mtype.fields:
        fieldtypes.append(TypeRegistry.short(field.type) if field.is_msg else field.type)
        arraylens.append(-1 if field.array is None else field.array)
        if field.array is not None:
            examples.append("[]")
        elif field.is_msg or field.type in _TIME_BASES:
            examples.append("{}")
        else:
            examples.append(_EXAMPLES.get(field.type, "0"))
    constants = sorted(mtype.constants, key=lambda const: const[0])
    return {
        "type": TypeRegistry.short(mtype.name),
        "fieldnames": [field.name for field in mtype.fields],
        "fieldtypes": fieldtypes,
        "fieldarraylen": arraylens,
        "examples": examples,
        "constnames": [name for name, _, _ in constants],
        "constvalues": [str(value) for _, _, value in constants],
    }


def _recursive(reg: TypeRegistry, root: MsgType) -> list[dict[str, Any]]:
    """The root, then each nested type once in depth-first pre-order (rosapi's order)."""
    out = [_typedef(root)]
    seen = {root.name}

    def walk(mtype: MsgType) -> None:
        for field in mtype.fields:
            if field.type in seen:
                continue
            if field.is_msg:
                seen.add(field.type)
                nested = reg.msg(field.type)
                out.append(_typedef(nested))
                walk(nested)
            elif field.type in _TIME_BASES:
                seen.add(field.type)
                out.append(_time_typedef(field.type))

    walk(root)
    return out


def typedefs(reg: TypeRegistry, name: str) -> list[dict[str, Any]]:
    """TypeDefs for message ``name`` and everything it contains (raises ``UnknownType``)."""
    return _recursive(reg, reg.msg(name))


def srv_request_typedefs(reg: TypeRegistry, name: str) -> list[dict[str, Any]]:
    """TypeDefs of a service's request (first entry typed ``pkg/NameRequest``)."""
    return _recursive(reg, reg.srv(name).request)


def srv_response_typedefs(reg: TypeRegistry, name: str) -> list[dict[str, Any]]:
    """TypeDefs of a service's response (first entry typed ``pkg/NameResponse``)."""
    return _recursive(reg, reg.srv(name).response)
