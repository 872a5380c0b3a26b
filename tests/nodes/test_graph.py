"""Route graphs: validation and shortest paths, then saved/loaded identically and driven along
on a real server with the simulated robot."""

from __future__ import annotations

import math

import pytest

from hitrobot_server.nodes.graph import (
    GraphError,
    decode_graph,
    encode_graph,
    graph_of,
    nearest_node,
    shortest_path,
)
from tests.nodes.map_manager.util import NS, current, start


def node(i: int, x: float, y: float, z: float = 0.0) -> dict:
    return {"id": i, "x": x, "y": y, "z": z}


def edge(a: int, b: int, cost: float = 0.0) -> dict:
    return {"from_node": a, "to_node": b, "cost": cost}


# 1 (5, 8) is where the robot starts; 3 (8, 8) is only reachable through 4 (3, 8.5):
# the direct corridor east is not an edge.
NODES = [node(1, 5.0, 8.0), node(2, 11.0, 7.5, 0.25), node(3, 8.0, 8.0), node(4, 3.0, 8.5)]
EDGES = [edge(1, 4), edge(4, 3, 5.5), edge(2, 3, 0.0)]


def test_graph_validation_and_shortest_path():
    graph = graph_of(NODES, EDGES)
    assert decode_graph(encode_graph(graph)) == graph
    assert shortest_path(graph, 1, 3) == [1, 4, 3]
    assert shortest_path(graph, 1, 2) == [1, 4, 3, 2]
    cheap = graph_of(NODES, [*EDGES, edge(1, 3, 100.0), edge(3, 1, 0.5)])
    assert shortest_path(cheap, 1, 3) == [1, 3]  # undirected, the cheapest parallel edge
    assert nearest_node(graph, 3.4, 8.0).id == 4
    lonely = graph_of([*NODES, node(9, 0.0, 0.0)], EDGES)
    with pytest.raises(GraphError, match="cannot be reached"):
        shortest_path(lonely, 1, 9)
    for nodes, edges, needle in [
        ([node(1, 0, 0), node(1, 1, 1)], [], "used twice"),
        (NODES, [edge(1, 7)], "there is no node 7"),
        (NODES, [edge(1, 2, -1.0)], "must not be negative"),
        ([node(1, float("inf"), 0)], [], "finite"),
        ([{"id": 1.5, "x": 0.0, "y": 0.0, "z": 0.0}], [], "int32"),
    ]:
        with pytest.raises(GraphError, match=needle):
            graph_of(nodes, edges)


async def test_graph_saved_loaded_and_followed(make_server, tmp_path):
    _server, w = await start(make_server, tmp_path / "maps")
    reply = (await w.call("/save_graph_file", {"name": "floor", "nodes": NODES,
                                               "edges": EDGES}))["values"]
    assert reply == {"success": True, "message": "Graph saved to: floor"}
    assert (tmp_path / "graphs" / "floor.yaml").is_file()
    assert (await w.call("/load_graph_file", {"name": "gone"}))["values"] == {
        "success": False, "message": "File not found: gone", "nodes": [], "edges": []}
    reply = (await w.call("/load_graph_file", {"name": "floor"}))["values"]
    assert reply == {"success": True, "message": "Graph loaded from: floor", "nodes": NODES,
                     "edges": EDGES}
    reply = (await w.call("/save_graph_file", {"name": "bad", "nodes": NODES,
                                               "edges": [edge(1, 99)]}))["values"]
    assert not reply["success"] and "no node 99" in reply["message"]
    assert not (tmp_path / "graphs" / "bad.yaml").exists()
    reply = (await w.call("/graph/navigate_to_node", {"node_id": 42}))["values"]
    assert not reply["success"] and "no node 42" in reply["message"]

    # from node 1 to node 3 by way of node 4: the robot first goes west, then east
    start_count = len(w.messages[f"{NS}/odom"])
    reply = (await w.call("/graph/navigate_to_node", {"node_id": 3}, timeout=60))["values"]
    assert reply["success"], reply
    assert reply["path"] == [1, 4, 3]
    track = [(m["pose"]["pose"]["position"]["x"], m["pose"]["pose"]["position"]["y"])
             for _t, m in w.messages[f"{NS}/odom"][start_count:]]
    near_4 = next(k for k, (x, y) in enumerate(track) if math.hypot(x - 3.0, y - 8.5) < 0.4)
    assert all(x < 5.5 for x, _y in track[:near_4])  # it did not take the corridor east first
    x, y, _ = current(w)
    assert math.hypot(x - 8.0, y - 8.0) < 0.4
    await w.close()
