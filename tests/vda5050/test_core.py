"""The VDA 5050 core without I/O: what arrives checked (size, JSON, header, schema, limits), the
order book's orderId/orderUpdateId rules, and every message we build against the 2.0.0
schemas kept in protocol/vda5050."""

from __future__ import annotations

import orjson
import pytest
from jsonschema import Draft202012Validator

from hitrobot_server.vda5050 import errors as e
from hitrobot_server.vda5050 import messages as msgs
from hitrobot_server.vda5050.inbox import MAX_BYTES, MAX_NODES, Inbox
from hitrobot_server.vda5050.orders import (
    FAILED,
    FINISHED,
    INSTANT_KEPT,
    OrderBook,
    Refused,
    check_order,
)
from hitrobot_server.vda5050.schemas import FILES, load, problem

HEADER = {"timestamp": "2024-01-01T00:00:00.00Z", "version": "2.0.0",
          "manufacturer": "acme", "serialNumber": "r1"}


def node(i: int, x: float, released: bool = True, actions=(), map_id: str = "map") -> dict:
    return {"nodeId": f"n{i}", "sequenceId": 2 * i, "released": released,
            "actions": list(actions), "nodePosition": {"x": x, "y": 0.0, "mapId": map_id}}


def edge(i: int, released: bool = True) -> dict:
    return {"edgeId": f"e{i}", "sequenceId": 2 * i + 1, "startNodeId": f"n{i}",
            "endNodeId": f"n{i + 1}", "released": released, "actions": []}


def order(order_id: str, update: int, nodes: list[dict], header: int = 1) -> dict:
    edges = [edge(int(a["nodeId"][1:]), b["released"]) for a, b in zip(nodes, nodes[1:],
                                                                          strict=False)]
    return {"headerId": header, **HEADER, "orderId": order_id, "orderUpdateId": update,
            "nodes": nodes, "edges": edges}


def action(kind: str, action_id: str = "a1", **params) -> dict:
    return {"actionId": action_id, "actionType": kind, "blockingType": "HARD",
            "actionParameters": [{"key": k, "value": v} for k, v in params.items()]}


def at_origin(n: dict) -> float:
    return abs(n["nodePosition"]["x"])


def no_problem(x: float, y: float) -> None:
    return None


# ---------------------------------------------------------------------- the inbox
def take(payload, topic: str = "order", inbox: Inbox | None = None):
    inbox = inbox or Inbox("acme", "r1")
    raw = payload if isinstance(payload, bytes) else orjson.dumps(payload)
    return inbox.take(topic, raw)


def test_a_message_that_is_not_json_is_a_validation_error():
    verdict = take(b"{not json")
    assert verdict.message is None and verdict.error["errorType"] == e.VALIDATION
    assert "not JSON" in verdict.error["errorDescription"]


def test_a_megabyte_is_refused_unread():
    verdict = take(b"[" + b"0," * (MAX_BYTES // 2) + b"0]")
    assert verdict.error["errorType"] == e.VALIDATION and "bytes" in \
        verdict.error["errorDescription"]


def test_a_schema_failure_names_the_field():
    bad = order("o1", 0, [node(0, 0.0)])
    bad["nodes"][0]["released"] = "yes"
    verdict = take(bad)
    assert verdict.error["errorType"] == e.VALIDATION
    assert "nodes[0].released must be boolean" in verdict.error["errorDescription"]
    refs = {r["referenceKey"]: r["referenceValue"] for r in verdict.error["errorReferences"]}
    assert refs == {"topic": "order", "headerId": "1", "orderId": "o1", "orderUpdateId": "0"}


def test_ten_thousand_nodes_are_refused_before_the_schema():
    many = order("big", 0, [node(i, 0.0) for i in range(10_000)])
    verdict = take(many)  # over the size limit already
    assert verdict.error["errorType"] == e.VALIDATION
    assert "bytes" in verdict.error["errorDescription"]
    compact = orjson.dumps(order("big", 0, [node(i, 0.0) for i in range(MAX_NODES + 1)]))
    assert len(compact) < MAX_BYTES
    verdict = take(compact)
    assert f"over the {MAX_NODES}" in verdict.error["errorDescription"]


def test_another_version_is_refused_and_another_serial_ignored():
    other = {**order("o1", 0, [node(0, 0.0)]), "version": "1.1.0"}
    assert "version" in take(other).error["errorDescription"]
    stranger = {**order("o1", 0, [node(0, 0.0)]), "serialNumber": "r2"}
    verdict = take(stranger)
    assert verdict.message is None and verdict.error is None and "r2" in verdict.ignored


def test_a_header_id_not_above_the_last_is_ignored_but_zero_begins_again():
    inbox = Inbox("acme", "r1")
    assert take(order("o1", 0, [node(0, 0.0)], header=5), inbox=inbox).message is not None
    assert "not above" in take(order("o1", 1, [node(0, 0.0)], header=5), inbox=inbox).ignored
    assert take(order("o1", 1, [node(0, 0.0)], header=4), inbox=inbox).ignored
    assert take(order("o1", 1, [node(0, 0.0)], header=0), inbox=inbox).message is not None
    # per topic: instantActions count their own
    instant = {"headerId": 1, **HEADER, "actions": [action("stateRequest")]}
    assert take(instant, "instantActions", inbox).message is not None


def test_instant_actions_under_either_name():
    spec = {"headerId": 1, **HEADER, "actions": [action("startPause")]}
    older = {"headerId": 1, **HEADER, "instantActions": [action("startPause")]}
    assert take(spec, "instantActions").message["actions"][0]["actionType"] == "startPause"
    assert take(older, "instantActions").message["actions"][0]["actionType"] == "startPause"
    bad = {"headerId": 1, **HEADER, "actions": [{"actionId": "x"}]}
    assert take(bad, "instantActions").error["errorType"] == e.VALIDATION


# ---------------------------------------------------------------------- the order book
def accepted(book: OrderBook, o: dict) -> str:
    check_order(o, "map", no_problem)
    return book.receive(o, at_origin)


def test_a_new_order_an_update_a_repeat_and_a_stale_update():
    book = OrderBook()
    assert accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0), node(2, 2.0, False)])) \
        == "new"
    assert [n["nodeId"] for n in book.node_states()] == ["n0", "n1", "n2"]
    assert book.base_end() == ("n1", 2)
    assert accepted(book, order("o1", 1, [node(1, 1.0), node(2, 2.0)])) == "update"
    assert [(n["nodeId"], n["released"]) for n in book.node_states()] == [
        ("n0", True), ("n1", True), ("n2", True)]
    assert [x["edgeId"] for x in book.edge_states()] == ["e0", "e1"]
    assert accepted(book, order("o1", 1, [node(1, 1.0), node(2, 2.0)])) == "repeat"
    with pytest.raises(Refused) as stale:
        accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0)]))
    assert stale.value.error["errorType"] == e.ORDER_UPDATE
    assert book.update_id == 1  # the stale one left it as it was


def test_an_update_not_stitched_at_the_base_end_is_refused():
    book = OrderBook()
    accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0)]))
    with pytest.raises(Refused) as refused:
        accepted(book, order("o1", 1, [node(0, 0.0), node(1, 1.0)]))
    assert refused.value.error["errorType"] == e.ORDER_UPDATE
    assert [n["nodeId"] for n in book.node_states()] == ["n0", "n1"]


def test_a_new_order_while_one_runs_only_when_it_continues_it():
    book = OrderBook()
    accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0)]))
    book.reached(book.nodes[0])
    with pytest.raises(Refused) as refused:
        accepted(book, order("o2", 0, [node(0, 0.0), node(1, 5.0)]))
    assert refused.value.error["errorType"] == e.ORDER_UPDATE and "o1" in str(refused.value)
    onward = order("o2", 0, [node(1, 1.0), node(2, 2.0)])
    assert accepted(book, onward) == "update" and book.order_id == "o2"
    assert [n["nodeId"] for n in book.node_states()] == ["n1", "n2"]


def test_the_first_node_must_be_within_reach():
    book = OrderBook()
    with pytest.raises(Refused) as refused:
        accepted(book, order("o1", 0, [node(0, 3.0), node(1, 4.0)]))
    assert refused.value.error["errorType"] == e.NO_ROUTE and book.order_id == ""


def test_unsupported_actions_and_places_are_refused_naming_them():
    pick = order("o1", 0, [node(0, 0.0, actions=[action("pick", "p1")]), node(1, 1.0)])
    with pytest.raises(Refused) as refused:
        check_order(pick, "map", no_problem)
    assert refused.value.error["errorType"] == e.ORDER and "'pick'" in str(refused.value)
    refs = {r["referenceKey"]: r["referenceValue"]
            for r in refused.value.error["errorReferences"]}
    assert refs["actionId"] == "p1" and refs["actionType"] == "pick"
    elsewhere = order("o1", 0, [node(0, 0.0, map_id="hall2"), node(1, 1.0)])
    with pytest.raises(Refused) as refused:
        check_order(elsewhere, "map", no_problem)
    assert refused.value.error["errorType"] == e.NO_ROUTE
    with pytest.raises(Refused) as refused:
        check_order(order("o1", 0, [node(0, 0.0), node(1, 1.0)]), "map",
                    lambda x, y: "on an obstacle" if x > 0.5 else None)
    assert refused.value.error["errorType"] == e.NO_ROUTE and "obstacle" in str(refused.value)
    broken = order("o1", 0, [node(0, 0.0), node(1, 1.0)])
    broken["edges"][0]["endNodeId"] = "n7"
    with pytest.raises(Refused) as refused:
        check_order(broken, "map", no_problem)
    assert refused.value.error["errorType"] == e.VALIDATION


def test_reaching_cancelling_and_bounded_instant_actions():
    book = OrderBook()
    charge = action("startCharging", "c1")
    accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0, actions=[charge])]))
    assert book.reached(book.nodes[0]) == []
    assert book.next_node()["nodeId"] == "n1" and book.active
    book.paused = True
    assert book.next_node() is None
    assert book.cancel("cancelled") and not book.active
    assert book.actions["c1"]["actionStatus"] == FAILED
    assert not book.cancel("again")  # nothing left to cancel
    for i in range(INSTANT_KEPT * 3):
        book.add_instant(action("stateRequest", f"s{i}"))
        book.set_action(f"s{i}", FINISHED)
    assert len(book.action_states()) <= INSTANT_KEPT + 2


def test_errors_stay_bounded():
    errors = e.Errors()
    for i in range(500):
        errors.add(e.error(e.VALIDATION, f"bad {i}"))
    assert len(errors.list()) == e.KEPT and errors.list()[-1]["errorDescription"] == "bad 499"


# ---------------------------------------------------------------------- what we send
def test_every_message_we_build_passes_its_schema():
    headers = msgs.Headers("acme", "r1")
    book = OrderBook()
    accepted(book, order("o1", 0, [node(0, 0.0), node(1, 1.0, actions=[action("stopCharging")]),
                                   node(2, 2.0, False)]))
    book.refuse(e.order_error(e.ORDER, "refused", {"orderId": "x", "orderUpdateId": 0}))
    reading = msgs.Reading(x=1.0, y=2.0, theta=0.5, battery=80.4, charging=True,
                           localization=0.9, localized=True, online=True, voltage=24.1)
    built = {
        "state": msgs.state(headers, 0.0, book, reading, "map"),
        "factsheet": msgs.factsheet(headers, 0.0, "series"),
        "connection": msgs.connection(headers, 0.0, msgs.ONLINE),
        "visualization": msgs.visualization(headers, 0.0, reading, "map"),
    }
    for topic, message in built.items():
        assert problem(topic, message) is None, (topic, problem(topic, message))
        # and by a second implementation, of the schemas' own draft (2020-12)
        checker = Draft202012Validator(load(topic))
        assert not list(checker.iter_errors(message)), (topic, message)
    assert built["state"]["timestamp"] == "1970-01-01T00:00:00.00Z"
    assert msgs.state(headers, 1.0, book, reading, "map")["headerId"] == 1


def test_the_kept_schemas_are_valid_2020_12_schemas():
    for topic in FILES:
        Draft202012Validator.check_schema(load(topic))
