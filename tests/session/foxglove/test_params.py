"""Parameters: get, set, updates, ``--params-glob`` and all-or-nothing sets (``params.py``)."""

from __future__ import annotations

from tests.session.foxglove.client import FoxClient


async def test_parameters_get_set_and_updates(hub):
    fox = FoxClient(hub)
    fox.send({"op": "subscribeParameterUpdates", "parameterNames": ["/fg/gain"]})
    fox.send({"op": "setParameters", "id": "s", "parameters": [
        {"name": "/fg/gain", "value": 2, "type": "float64"},
        {"name": "/fg/blob", "value": "AQI=", "type": "byte_array"}]})
    update = await fox.op("parameterValues")
    assert update.get("id") is None and update["parameters"] == [
        {"name": "/fg/gain", "value": 2.0, "type": "float64"}]
    reply = await fox.op("parameterValues")
    assert reply["id"] == "s"
    assert hub.bus.params.get("/fg/blob") == [1, 2]  # JSON on the bus, as rosapi serves it
    fox.send({"op": "getParameters", "id": "g", "parameterNames": ["/fg/gain", "/fg/none"]})
    got = await fox.op("parameterValues")
    assert got == {"op": "parameterValues", "id": "g",
                   "parameters": [{"name": "/fg/gain", "value": 2.0, "type": "float64"}]}
    fox.send({"op": "setParameters", "parameters": [{"name": "/fg/gain", "value": 1},
                                                    {"name": "not a name!", "value": 3}]})
    assert "'name'" in (await fox.error())["message"]
    assert hub.bus.params.get("/fg/gain") == 2.0  # validated first: nothing was set


async def test_params_glob_limits_foxglove_parameters(make_hub):
    hub = await make_hub()
    hub.bus.params.set("/open/gain", 1)
    hub.bus.params.set("/secret/key", "x")
    fox = FoxClient(hub, params_glob="/open/*")
    fox.send({"op": "getParameters", "id": "all", "parameterNames": []})
    got = await fox.op("parameterValues")
    assert got["parameters"] == [{"name": "/open/gain", "value": 1}]
    fox.send({"op": "getParameters", "id": "one", "parameterNames": ["/secret/key"]})
    assert (await fox.op("parameterValues"))["parameters"] == []
    fox.send({"op": "setParameters", "parameters": [{"name": "/open/gain", "value": 2},
                                                    {"name": "/secret/key", "value": "y"}]})
    assert "--params-glob" in (await fox.error())["message"]
    assert hub.bus.params.get("/open/gain") == 1 and hub.bus.params.get("/secret/key") == "x"
    fox.send({"op": "subscribeParameterUpdates", "parameterNames": ["/secret/key", "/open/gain"]})
    hub.bus.params.set("/secret/key", "z")
    hub.bus.params.set("/open/gain", 3)
    update = await fox.op("parameterValues")
    assert update["parameters"] == [{"name": "/open/gain", "value": 3}]


async def test_set_parameters_is_all_or_nothing_and_names_the_limit(hub):
    """Issue 37: an op refused at its 7th name (past the store's 16 MB) sets none of them,
    and says why without an 'internal error' (nor a traceback in the log)."""
    fox = FoxClient(hub)
    value = "v" * 990_000
    fill = [{"name": f"/fill/p{i}", "value": value} for i in range(10)]
    fox.send({"op": "setParameters", "id": "fill", "parameters": fill})
    await fox.until(lambda m: isinstance(m, dict) and m.get("id") == "fill", "the fill set")
    names = [f"/op/p{i}" for i in range(7)]
    fox.send({"op": "setParameters", "id": "op",
              "parameters": [{"name": n, "value": value} for n in names]})
    err = await fox.error()
    assert "16000000" in err["message"] and "no parameter was set" in err["message"]
    assert "internal error" not in err["message"]
    assert not any(hub.bus.params.has(n) for n in names)
    assert hub.bus.params.has("/fill/p9")
