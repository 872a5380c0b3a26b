"""Route graphs: ``save_graph_file``, ``load_graph_file`` and ``graph/navigate_to_node``.

A graph is a set of nodes (``hitrobot_msgs/GraphNode``: id and position in the map frame) and
**undirected** edges (``GraphEdge``: the two node ids and a cost; a cost of 0 stands for the
straight-line distance between the nodes). Graph files are ``<name>.yaml`` in the graph store
(the ``graphs`` folder next to the map store); saving while a map is loaded also makes the
graph that map's default (``graph.yaml`` in its folder, loaded with the map). The graph last
saved or loaded is the *current* graph, published latched on ``graph/current``
(``hitrobot_msgs/Graph``).

``graph/navigate_to_node`` (``hitrobot_msgs/NavigateToNode``) drives the robot from the node
nearest to it to the requested node along the shortest path over the edges (networkx's
Dijkstra on the edge costs), visiting every node of the path in turn; it answers once the robot
has arrived (``path`` lists the node ids) or failed.
"""

from __future__ import annotations

import asyncio
import logging
import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass
from typing import TYPE_CHECKING

from ..bus.core import Bus
from ..robot.backend import BackendError, Link, LocalizationBackend, MotionBackend
from ..robot.model import ActionResult, Point2D
from ..robot.motion import follow
from ..state import StateBinding
from .base import RobotNode
from .ground.loadedmap import GRAPH_FILE, MapDefaults
from .ground.memory import NodeMemory
from .ground.namedfiles import FileError, NamedFiles, dump_yaml, load_yaml, number
from .ground.requests import robot_error
from .options import NodeOptions

log = logging.getLogger(__name__)
PKG = "hitrobot_msgs"
CURRENT_TOPIC = "/graph/current"
MAX_NODES = 10_000
INT32 = (-(2**31), 2**31 - 1)

if TYPE_CHECKING:
    import networkx as nx


class GraphError(ValueError):
    """A refused graph; the text is user-facing."""


@dataclass(frozen=True, slots=True)
class GraphNode:
    id: int
    x: float
    y: float
    z: float = 0.0


@dataclass(frozen=True, slots=True)
class GraphEdge:
    from_node: int
    to_node: int
    cost: float = 0.0


@dataclass(frozen=True, slots=True)
class Graph:
    nodes: tuple[GraphNode, ...] = ()
    edges: tuple[GraphEdge, ...] = ()

    def as_msg(self) -> dict:
        return {"nodes": [asdict(n) for n in self.nodes],
                "edges": [asdict(e) for e in self.edges]}


def _int(value: object, path: str) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not INT32[0] <= value <= INT32[1]:
        raise GraphError(f"field '{path}' must be an int32")
    return value


def graph_of(nodes: Sequence[dict], edges: Sequence[dict]) -> Graph:
    """A validated graph: unique node ids, finite coordinates, edges between known nodes with
    finite non-negative costs."""
    if not isinstance(nodes, list | tuple) or not isinstance(edges, list | tuple):
        raise GraphError("'nodes' and 'edges' must be lists")
    if len(nodes) > MAX_NODES:
        raise GraphError(f"a graph has at most {MAX_NODES} nodes, got {len(nodes)}")
    out_nodes: list[GraphNode] = []
    seen: set[int] = set()
    try:
        for i, n in enumerate(nodes):
            if not isinstance(n, dict):
                raise GraphError(f"nodes[{i}] must be a mapping")
            node = GraphNode(_int(n.get("id"), f"nodes[{i}].id"),
                             *(number(n.get(k, 0.0 if k == "z" else None), f"nodes[{i}].{k}")
                               for k in "xyz"))
            if node.id in seen:
                raise GraphError(f"nodes[{i}]: node id {node.id} is used twice")
            seen.add(node.id)
            out_nodes.append(node)
        out_edges: list[GraphEdge] = []
        for i, e in enumerate(edges):
            if not isinstance(e, dict):
                raise GraphError(f"edges[{i}] must be a mapping")
            edge = GraphEdge(_int(e.get("from_node"), f"edges[{i}].from_node"),
                             _int(e.get("to_node"), f"edges[{i}].to_node"),
                             number(e.get("cost", 0.0), f"edges[{i}].cost"))
            for end in (edge.from_node, edge.to_node):
                if end not in seen:
                    raise GraphError(f"edges[{i}]: there is no node {end}")
            if edge.cost < 0:
                raise GraphError(f"edges[{i}]: the cost must not be negative")
            out_edges.append(edge)
    except FileError as exc:
        raise GraphError(str(exc)) from None
    return Graph(tuple(out_nodes), tuple(out_edges))


def encode_graph(graph: Graph) -> bytes:
    return dump_yaml("route graph", graph.as_msg())


def decode_graph(data: bytes, what: str = "graph file") -> Graph:
    doc = load_yaml(data, what)
    try:
        return graph_of(doc.get("nodes", []), doc.get("edges", []))
    except GraphError as exc:
        raise GraphError(f"{what}: {exc}") from None


def network(graph: Graph) -> nx.Graph:
    """The graph for networkx: edge weight = its cost (0 → the distance); parallel edges keep
    the cheapest. networkx is imported on first use: 12 MB that a server without graphs (every
    worker of ``--workers`` but one) need not hold."""
    import networkx as nx

    g = nx.Graph()
    where = {}
    for n in graph.nodes:
        g.add_node(n.id)
        where[n.id] = n
    for e in graph.edges:
        a, b = where[e.from_node], where[e.to_node]
        cost = e.cost or math.dist((a.x, a.y, a.z), (b.x, b.y, b.z))
        if not g.has_edge(a.id, b.id) or g[a.id][b.id]["weight"] > cost:
            g.add_edge(a.id, b.id, weight=cost)
    return g


def nearest_node(graph: Graph, x: float, y: float) -> GraphNode:
    return min(graph.nodes, key=lambda n: math.hypot(n.x - x, n.y - y))


def shortest_path(graph: Graph, start: int, goal: int) -> list[int]:
    """Node ids from ``start`` to ``goal`` along the edges; GraphError when there is none."""
    import networkx as nx

    try:
        return nx.dijkstra_path(network(graph), start, goal, weight="weight")
    except nx.NodeNotFound as exc:
        raise GraphError(str(exc)) from None
    except nx.NetworkXNoPath:
        raise GraphError(f"node {goal} cannot be reached from node {start} along the graph's "
                         "edges") from None


class GraphNodeService(RobotNode):
    """The route graph node."""

    GLOBAL_NAMES = ("/graph", "/save_graph_file", "/load_graph_file")

    def __init__(self, bus: Bus, link: Link, motion: MotionBackend,
                 localization: LocalizationBackend, settings: NodeOptions,
                 mapfiles: MapDefaults, state: StateBinding | None = None):
        super().__init__(bus, "/graph", link)
        self.memory = NodeMemory(state, "graph")
        self.motion = motion
        self.localization = localization
        self.mapfiles = mapfiles
        self.files = NamedFiles(settings.map_store.parent / "graphs")
        if removed := self.files.clean_leftovers():  # created at start-up, before any save
            log.info("graphs: removed leftovers of interrupted saves: %s", ", ".join(removed))
        self.graph = Graph()
        self.graph_name = ""
        self.advertise(CURRENT_TOPIC, f"{PKG}/Graph", latch=True)
        self.service("/save_graph_file", f"{PKG}/SaveGraphFile", self._save)
        self.service("/load_graph_file", f"{PKG}/LoadGraphFile", self._load)
        self.service("/graph/navigate_to_node", f"{PKG}/NavigateToNode", self._navigate)
        mapfiles.defaults[GRAPH_FILE] = self._apply_default
        self._restore()
        self._publish()

    def _restore(self) -> None:
        saved = self.memory.get("current")
        self.graph, self.graph_name = Graph(), ""
        if saved is None:
            return
        try:
            self.graph = graph_of(saved["nodes"], saved["edges"])
            self.graph_name = str(saved["name"])
        except (GraphError, KeyError, TypeError) as exc:
            self.memory.reject("current", str(exc))

    def adopt(self, restore: bool) -> None:
        """A state folder was bound: take its graph (``restore``) or write ours into it."""
        if restore:
            self._restore()
            self._publish()
        else:
            self.memory.put("current", {"name": self.graph_name, **self.graph.as_msg()})

    def restored(self) -> list[str]:
        """What came back from the state folder, for the start-up log."""
        if self.memory.store is None or not self.graph.nodes:
            return []
        return [f"1 graph ({len(self.graph.nodes)} nodes)"]

    def _publish(self) -> None:
        self.publish(CURRENT_TOPIC, {"name": self.graph_name, **self.graph.as_msg()})

    def _set(self, graph: Graph, name: str) -> None:
        self.graph, self.graph_name = graph, name
        self.memory.put("current", {"name": name, **graph.as_msg()})
        self._publish()

    async def _save(self, request: dict) -> dict:
        name = request["name"]
        try:
            graph = graph_of(request["nodes"], request["edges"])
            data = encode_graph(graph)
            await asyncio.to_thread(self.files.write, name, data)
        except (GraphError, FileError) as exc:
            return {"success": False, "message": str(exc)}
        await asyncio.to_thread(self.mapfiles.save_default, GRAPH_FILE, data)
        self._set(graph, name)
        await self.memory.durable()
        return {"success": True, "message": f"Graph saved to: {name}"}

    async def _load(self, request: dict) -> dict:
        name = request["name"]
        empty = {"nodes": [], "edges": []}
        try:
            if not self.files.exists(name):
                return {"success": False, "message": f"File not found: {name}", **empty}
            data = await asyncio.to_thread(self.files.read, name)
            graph = decode_graph(data, f"graph {name!r}")
        except (GraphError, FileError) as exc:
            return {"success": False, "message": str(exc), **empty}
        self._set(graph, name)
        await self.memory.durable()
        return {"success": True, "message": f"Graph loaded from: {name}", **graph.as_msg()}

    def _apply_default(self, data: bytes) -> str:
        try:
            graph = decode_graph(data, GRAPH_FILE)
        except GraphError as exc:
            raise FileError(str(exc)) from None
        self._set(graph, GRAPH_FILE.removesuffix(".yaml"))
        return f"graph with {len(graph.nodes)} nodes loaded"

    async def _navigate(self, request: dict) -> dict:
        goal = request["node_id"]
        graph = self.graph
        if not graph.nodes:
            return {"success": False, "message": "No graph loaded", "path": []}
        if goal not in {n.id for n in graph.nodes}:
            return {"success": False, "message": f"the graph has no node {goal}", "path": []}
        try:
            pose = await self.localization.get_pose()
        except BackendError as exc:
            return {"success": False, "message": robot_error(exc, "robot pose unavailable"),
                    "path": []}
        start = nearest_node(graph, pose.x, pose.y)
        try:
            path = shortest_path(graph, start.id, goal)
        except GraphError as exc:
            return {"success": False, "message": str(exc), "path": []}
        where = {n.id: n for n in graph.nodes}
        for node_id in path:
            node = where[node_id]
            try:
                action = await self.motion.move_to([Point2D(node.x, node.y)])
                final = await follow(self.motion, action)
            except BackendError as exc:
                return {"success": False, "path": path, "message": robot_error(
                    exc, f"the robot refused the way to node {node_id}")}
            if final is None or final.result != ActionResult.SUCCESS:
                why = "replaced by another command" if final is None else (
                    final.reason or final.result.name.lower())
                return {"success": False, "path": path,
                        "message": f"stopped on the way to node {node_id}: {why}"}
        return {"success": True, "path": path,
                "message": f"arrived at node {goal} via {len(path)} nodes"}
