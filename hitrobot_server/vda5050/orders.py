"""One vehicle's order (sans-I/O): the spec's rules for ``orderId`` / ``orderUpdateId`` (a new
order, an update stitched at the end of the base, a repeat ignored, a stale or unstitched one
refused), the nodes and edges still ahead, the last node reached, and every action's state.

Nothing here moves a robot: the vehicle asks :meth:`OrderBook.next_node`, drives there, and
says :meth:`OrderBook.reached`; it runs the actions :meth:`OrderBook.reached` hands back and
reports their states with :meth:`OrderBook.set_action`."""

from __future__ import annotations

import math
from collections.abc import Callable

from . import errors as e

WAITING, INITIALIZING, RUNNING, FINISHED, FAILED = (
    "WAITING", "INITIALIZING", "RUNNING", "FINISHED", "FAILED")
ENDED = (FINISHED, FAILED)
NODE_ACTIONS = ("startCharging", "stopCharging")
"""Actions this vehicle runs on a node; none on an edge."""
DEFAULT_DEVIATION = 0.5
"""Metres a new order's first node may lie from the robot when it gives no allowedDeviationXY."""
INSTANT_KEPT = 64
"""Ended instant actions kept in ``actionStates`` (a flood of them stays bounded)."""

Problem = Callable[[float, float], str | None]


class Refused(Exception):
    """The order is not taken; ``error`` is what ``state.errors`` shows."""

    def __init__(self, error: dict):
        super().__init__(error["errorDescription"])
        self.error = error


def key(item: dict) -> tuple[str, int]:
    return item["nodeId"] if "nodeId" in item else item["edgeId"], item["sequenceId"]


def check_order(order: dict, map_id: str, problem: Problem) -> None:
    """What the schema cannot say: sequence ids, edges between their nodes, the base before the
    horizon, positions on this robot's map and where a robot can stand, actions we run."""
    def refuse(kind: str, why: str, **more: object) -> Refused:
        return Refused(e.order_error(kind, why, order, **more))

    nodes, edges = order["nodes"], order["edges"]
    if not nodes:
        raise refuse(e.VALIDATION, "nodes: an order has at least one node")
    if len(edges) != len(nodes) - 1:
        raise refuse(e.VALIDATION, f"edges: {len(edges)} edges between {len(nodes)} nodes")
    for i, node in enumerate(nodes):
        if i and node["sequenceId"] != nodes[i - 1]["sequenceId"] + 2:
            raise refuse(e.VALIDATION, f"nodes[{i}].sequenceId: {node['sequenceId']} does not "
                         "follow the previous node's by 2", nodeId=node["nodeId"])
        if i and node["released"] and not nodes[i - 1]["released"]:
            raise refuse(e.VALIDATION, f"nodes[{i}]: a released node after the horizon began",
                         nodeId=node["nodeId"])
    for i, edge in enumerate(edges):
        start, end = nodes[i], nodes[i + 1]
        if (edge["sequenceId"], edge["startNodeId"], edge["endNodeId"]) != (
                start["sequenceId"] + 1, start["nodeId"], end["nodeId"]):
            raise refuse(e.VALIDATION, f"edges[{i}] ({edge['edgeId']}) does not join "
                         f"{start['nodeId']} and {end['nodeId']} in sequence",
                         edgeId=edge["edgeId"])
        if edge["released"] and not end["released"]:
            raise refuse(e.VALIDATION, f"edges[{i}] is released but its end node is not",
                         edgeId=edge["edgeId"])
        for action in edge["actions"]:
            raise refuse(e.ORDER, f"edge action {action['actionType']!r} is not supported by "
                         "this vehicle (it runs no action on an edge)", edgeId=edge["edgeId"],
                         actionId=action["actionId"], actionType=action["actionType"])
    for i, node in enumerate(nodes):
        _check_node(i, node, map_id, problem, refuse)


def _check_node(i: int, node: dict, map_id: str, problem: Problem,
                refuse: Callable[..., Refused]) -> None:
    for action in node["actions"]:
        if action["actionType"] not in NODE_ACTIONS:
            raise refuse(e.ORDER, f"action {action['actionType']!r} on node {node['nodeId']} "
                         f"is not supported by this vehicle (it runs {', '.join(NODE_ACTIONS)} "
                         "on a node)", nodeId=node["nodeId"], actionId=action["actionId"],
                         actionType=action["actionType"])
    position = node.get("nodePosition")
    if position is None:
        raise refuse(e.ORDER, f"nodes[{i}] ({node['nodeId']}) has no nodePosition: this "
                     "vehicle drives to positions", nodeId=node["nodeId"])
    if position["mapId"] != map_id:
        raise refuse(e.NO_ROUTE, f"nodes[{i}] ({node['nodeId']}) is on map "
                     f"{position['mapId']!r}, not {map_id!r} (the robot's)",
                     nodeId=node["nodeId"], mapId=position["mapId"])
    if not all(math.isfinite(position.get(k, 0.0)) for k in ("x", "y", "theta")):
        raise refuse(e.VALIDATION, f"nodes[{i}].nodePosition is not finite", nodeId=node["nodeId"])
    why = problem(position["x"], position["y"]) if node["released"] else None
    if why:
        raise refuse(e.NO_ROUTE, f"node {node['nodeId']}: {why}", nodeId=node["nodeId"])


class OrderBook:
    """The current order: what is ahead, what was reached, every action's state, the errors."""

    def __init__(self) -> None:
        self.order_id, self.update_id = "", 0
        self.nodes: list[dict] = []  # still to traverse: the base, then the horizon
        self.edges: list[dict] = []
        self.last_node_id, self.last_node_seq = "", 0
        self.actions: dict[str, dict] = {}  # actionId → actionState
        self.instant: list[str] = []  # the instant actions' ids, oldest first
        self.errors = e.Errors()
        self.paused = False
        self.halted = False  # a cancelOrder is stopping the robot: no node is driven to
        self.due: list[dict] = []  # actions of a node reached, to run now

    # ------------------------------------------------------------------ what it shows
    @property
    def driving_base(self) -> bool:
        """Released nodes are still ahead."""
        return any(n["released"] for n in self.nodes)

    @property
    def active(self) -> bool:
        """Released nodes ahead, or an order action not ended yet."""
        return self.driving_base or any(
            a["actionStatus"] not in ENDED for i, a in self.actions.items()
            if i not in self.instant)

    def next_node(self) -> dict | None:
        """The node to drive to now: the first one ahead, when released and not paused."""
        if self.paused or self.halted or not self.nodes or not self.nodes[0]["released"]:
            return None
        return self.nodes[0]

    def base_end(self) -> tuple[str, int]:
        """The last released node: still ahead, else the last one reached."""
        released = [n for n in self.nodes if n["released"]]
        return key(released[-1]) if released else (self.last_node_id, self.last_node_seq)

    def node_states(self) -> list[dict]:
        """The nodes ahead; a position only with its theta (2.0.0's state schema needs one)."""
        return [{k: n[k] for k in ("nodeId", "sequenceId", "released", "nodePosition",
                                   "nodeDescription")
                 if k in n and (k != "nodePosition" or "theta" in n[k])} for n in self.nodes]

    def edge_states(self) -> list[dict]:
        return [{k: x[k] for k in ("edgeId", "sequenceId", "released", "edgeDescription")
                 if k in x} for x in self.edges]

    def action_states(self) -> list[dict]:
        return list(self.actions.values())

    # ------------------------------------------------------------------ orders
    def receive(self, order: dict, distance_to: Callable[[dict], float]) -> str:
        """Take ``order`` by the spec's rules: ``"new"``, ``"update"`` (stitched), or
        ``"repeat"`` (same ids: ignored); :class:`Refused` with the error otherwise.
        ``distance_to(node)`` is how far the robot stands from a node's position."""
        first = order["nodes"][0]
        if order["orderId"] == self.order_id:
            if order["orderUpdateId"] < self.update_id:
                raise Refused(e.order_error(e.ORDER_UPDATE, f"orderUpdateId "
                              f"{order['orderUpdateId']} is below the current "
                              f"{self.update_id}", order))
            if order["orderUpdateId"] == self.update_id:
                return "repeat"
            self._stitch(order, first)
            return "update"
        if self.active:
            if key(first) != self.base_end():
                raise Refused(e.order_error(
                    e.ORDER_UPDATE, f"order {order['orderId']} does not continue the running "
                    f"order {self.order_id} at the end of its base {self.base_end()[0]}", order))
            self._stitch(order, first)
            return "update"
        reach = max(first.get("nodePosition", {}).get("allowedDeviationXY", 0.0),
                    DEFAULT_DEVIATION)
        if distance_to(first) > reach:
            raise Refused(e.order_error(e.NO_ROUTE, f"the first node {first['nodeId']} is "
                          f"{distance_to(first):.2f} m from the robot, beyond its deviation "
                          f"range of {reach:.2f} m", order, nodeId=first["nodeId"]))
        self._replace(order)
        return "new"

    def _stitch(self, order: dict, first: dict) -> None:
        if key(first) != self.base_end():
            raise Refused(e.order_error(e.ORDER_UPDATE, f"the update's first node "
                          f"{first['nodeId']} (sequence {first['sequenceId']}) is not the end "
                          f"of the base {self.base_end()[0]} (sequence {self.base_end()[1]})",
                          order))
        self.nodes = [n for n in self.nodes if n["released"]]
        self.edges = [x for x in self.edges if x["released"]]
        if self.nodes:  # the stitching node is still ahead: its new actions join it there
            self.nodes[-1] = {**self.nodes[-1],
                              "actions": self.nodes[-1]["actions"] + first["actions"]}
        else:  # reached already: they run now
            self.due += first["actions"]
        self._wait_for([first])
        self.nodes += order["nodes"][1:]
        self.edges += order["edges"]
        self.order_id, self.update_id = order["orderId"], order["orderUpdateId"]
        self._wait_for(order["nodes"][1:])
        self._accepted()

    def _replace(self, order: dict) -> None:
        self.actions = {i: a for i, a in self.actions.items()
                        if i in self.instant or a["actionStatus"] not in ENDED}
        self.order_id, self.update_id = order["orderId"], order["orderUpdateId"]
        self.nodes, self.edges = list(order["nodes"]), list(order["edges"])
        self._wait_for(self.nodes)
        self._accepted()

    def _wait_for(self, nodes: list[dict]) -> None:
        for node in nodes:
            if node["released"]:
                for action in node["actions"]:
                    self.actions[action["actionId"]] = state_of(action, WAITING)

    def _accepted(self) -> None:
        self.errors.clear(e.VALIDATION, e.ORDER, e.ORDER_UPDATE, e.NO_ROUTE, e.ORDER_CANCELLED)

    def refuse(self, error: dict) -> None:
        self.errors.add(error)

    # ------------------------------------------------------------------ progress
    def reached(self, node: dict) -> list[dict]:
        """The robot is at ``node`` (the first ahead): it and the edge to it are traversed;
        its actions, to run now."""
        self.nodes = [n for n in self.nodes if key(n) != key(node)]
        self.edges = [x for x in self.edges if x["sequenceId"] != node["sequenceId"] - 1]
        self.last_node_id, self.last_node_seq = key(node)
        return list(node["actions"])

    def set_action(self, action_id: str, status: str, result: str = "") -> None:
        state = self.actions.get(action_id)
        if state is not None:
            state["actionStatus"] = status
            if result:
                state["resultDescription"] = result[:200]

    def add_instant(self, action: dict) -> None:
        self.actions[action["actionId"]] = state_of(action, WAITING)
        self.instant.append(action["actionId"])
        ended = [i for i in self.instant if self.actions[i]["actionStatus"] in ENDED]
        for old in ended[:max(0, len(ended) - INSTANT_KEPT)]:
            self.instant.remove(old)
            del self.actions[old]

    def cancel(self, why: str) -> bool:
        """Nothing ahead any more; the order's waiting and running actions failed. False when
        there was no order to cancel."""
        if not self.active:
            return False
        self.nodes, self.edges = [], []
        for action_id, state in self.actions.items():
            if action_id not in self.instant and state["actionStatus"] not in ENDED:
                state.update(actionStatus=FAILED, resultDescription=why[:200])
        return True

    def set_last_node(self, node_id: str) -> None:
        self.last_node_id, self.last_node_seq = node_id, 0


def state_of(action: dict, status: str) -> dict:
    state = {"actionId": action["actionId"], "actionType": action["actionType"],
             "actionStatus": status}
    if "actionDescription" in action:
        state["actionDescription"] = action["actionDescription"]
    return state


def parameters(action: dict) -> dict:
    """An action's parameters by key."""
    return {p["key"]: p["value"] for p in action.get("actionParameters") or []}
