"""The op groups reach their client only through OpContext, and a Session provides all of it."""

import ast
import inspect
from pathlib import Path

from hitrobot_server.bus.core import Bus
from hitrobot_server.session.options import SessionOptions
from hitrobot_server.session.rosbridge import context
from hitrobot_server.session.rosbridge.context import OpContext
from hitrobot_server.session.rosbridge.session import Session
from hitrobot_server.types.registry import TypeRegistry

OP_GROUPS = ("publish.py", "subscribe.py", "services.py", "actions.py")
MEMBERS = set(OpContext.__annotations__) | {
    name for name, _ in inspect.getmembers(OpContext) if not name.startswith("_")
}


def client_attributes(source: str) -> set[str]:
    """Attributes read through what an op group calls its client: ``client``, ``c`` or
    ``self.client``."""
    found = set()
    for node in ast.walk(ast.parse(source)):
        if not isinstance(node, ast.Attribute):
            continue
        base = node.value
        named = isinstance(base, ast.Name) and base.id in ("client", "c")
        held = (isinstance(base, ast.Attribute) and base.attr == "client"
                and isinstance(base.value, ast.Name) and base.value.id == "self")
        if named or held:
            found.add(node.attr)
    return found


def test_op_groups_use_only_the_context():
    folder = Path(context.__file__).parent
    used = set()
    for name in OP_GROUPS:
        used |= client_attributes((folder / name).read_text(encoding="utf-8"))
    assert used, "the op groups reach their client somewhere"
    assert used <= MEMBERS, f"not in OpContext: {sorted(used - MEMBERS)}"


async def test_a_session_provides_the_whole_context():
    session = Session(Bus(TypeRegistry()), SessionOptions())
    try:
        missing = [name for name in MEMBERS if not hasattr(session, name)]
        assert not missing
    finally:
        session.close()
