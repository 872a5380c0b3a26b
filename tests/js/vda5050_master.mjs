// A real VDA 5050 2.0.0 master control (vda-5050-lib's MasterController, its schema validation
// on both ways) against a hitrobot-server vehicle, through a real broker.
// Usage: node vda5050_master.mjs mqtt://127.0.0.1:PORT MANUFACTURER SERIAL
// Prints "ok NAME" or "fail NAME: why" per check, then the counts of messages read.
import { BlockingType, MasterController, Topic } from "vda-5050-lib";

const [brokerUrl, manufacturer, serialNumber] = process.argv.slice(2);
const agv = { manufacturer, serialNumber };
const STEP = 60000; // ms: the longest any one step may take

let drops = 0;
const errorLog = console.error;
console.error = (...args) => { // the library reports every message its validation drops here
  if (String(args[0]).includes("Drop inbound message")) drops += 1;
  errorLog(...args);
};

const results = [];
function report(name, ok, why = "") {
  results.push(ok);
  console.log(ok ? `ok ${name}` : `fail ${name}: ${why}`);
}

function within(promise, what, ms = STEP) {
  let timer;
  const timeout = new Promise((_, reject) => {
    timer = setTimeout(() => reject(new Error(`${what}: no answer in ${ms} ms`)), ms);
  });
  return Promise.race([promise, timeout]).finally(() => clearTimeout(timer));
}

const mc = new MasterController({
  interfaceName: "uagv", transport: { brokerUrl }, vdaVersion: "2.0.0",
  topicObjectValidation: { inbound: true, outbound: true },
}, { targetAgvs: agv });

const counts = { state: 0, connection: 0, factsheet: 0, visualization: 0 };
let lastState;
let firstState;
const stateSeen = new Promise((resolve) => { firstState = resolve; });
let connection;
let factsheet;
const watchers = [];
function waitState(pred, what) {
  if (lastState && pred(lastState)) return Promise.resolve(lastState);
  return within(new Promise((resolve) => watchers.push({ pred, resolve })), what);
}

await mc.start();
await mc.subscribe(Topic.State, agv, (state) => {
  counts.state += 1;
  lastState = state;
  firstState(state);
  for (const w of [...watchers]) {
    if (w.pred(state)) { watchers.splice(watchers.indexOf(w), 1); w.resolve(state); }
  }
});
await mc.subscribe(Topic.Connection, agv, (c) => { counts.connection += 1; connection = c; });
await mc.subscribe(Topic.Factsheet, agv, (f) => { counts.factsheet += 1; factsheet = f; });
await mc.subscribe(Topic.Visualization, agv, () => { counts.visualization += 1; });

function instant(actionType, actionParameters = []) {
  return within(new Promise((resolve, reject) => {
    mc.initiateInstantActions(agv, {
      instantActions: [{ actionId: mc.createUuid(), actionType, blockingType: BlockingType.Hard,
        actionParameters }],
    }, {
      onActionStateChanged: (actionState, withError) => {
        if (actionState.actionStatus === "FINISHED") resolve(actionState);
        if (actionState.actionStatus === "FAILED") {
          reject(new Error(`${actionType} failed: ${withError?.errorDescription ?? ""}`));
        }
      },
      onActionError: (error) => reject(new Error(`${actionType}: ${error.errorDescription}`)),
    }).catch(reject);
  }), actionType);
}

function node(id, sequenceId, x, y, mapId, released = true) {
  return { nodeId: id, sequenceId, released, actions: [], nodePosition: { x, y, mapId } };
}
function edge(id, sequenceId, start, end, released = true) {
  return { edgeId: id, sequenceId, startNodeId: start, endNodeId: end, released, actions: [] };
}

function assign(order, events = {}) {
  return within(new Promise((resolve, reject) => {
    mc.assignOrder(agv, order, {
      onOrderProcessed: (error, byCancelation, active, ctx) => {
        if (error) reject(new Error(`order ${order.orderId}: ${error.errorDescription}`));
        else resolve({ byCancelation, active, state: ctx.state });
      },
      onNodeTraversed: (n) => events.traversed?.(n),
    }).catch(reject);
  }), `order ${order.orderId}`, 3 * STEP);
}

try {
  await instant("stateRequest"); // a state now: states are sent on change, else every 30 s
  const start = await within(stateSeen, "the first state");
  const p = start.agvPosition;
  const map = p.mapId;
  report("state_and_position", typeof p.x === "number" && p.positionInitialized === true,
    JSON.stringify(p));
  await within((async () => { while (!connection || !factsheet) await new Promise((r) => setTimeout(r, 50)); })(), "connection and factsheet");
  report("connection_online", connection.connectionState === "ONLINE", JSON.stringify(connection));
  const types = factsheet.protocolFeatures.agvActions.map((a) => a.actionType);
  report("factsheet_actions", ["cancelOrder", "startPause", "initPosition"].every((t) => types.includes(t)), types.join(","));

  // an order of three nodes: two released, the third a horizon until the update releases it
  const orderId = mc.createUuid();
  let traversed = [];
  const order = {
    orderId, orderUpdateId: 0,
    nodes: [node("n0", 0, p.x, p.y, map), node("n1", 2, p.x + 1.0, p.y, map),
      node("n2", 4, p.x + 1.5, p.y + 0.5, map, false)],
    edges: [edge("e01", 1, "n0", "n1"), edge("e12", 3, "n1", "n2", false)],
  };
  const first = assign(order, { traversed: (n) => traversed.push(n.nodeId) });
  first.catch(() => {});
  await waitState((s) => s.orderId === orderId && s.driving, "driving to n1");
  await instant("startPause");
  const paused = await waitState((s) => s.paused && !s.driving, "paused and stopped");
  report("pause", paused.paused === true && paused.lastNodeId === "n0", JSON.stringify(paused.nodeStates));
  await instant("stopPause");
  await waitState((s) => !s.paused && s.driving, "driving again");
  report("resume", true);
  // the update: stitched at n1 (the base's end), releases n2
  const update = {
    orderId, orderUpdateId: 1,
    nodes: [node("n1", 2, p.x + 1.0, p.y, map), node("n2", 4, p.x + 1.5, p.y + 0.5, map)],
    edges: [edge("e12", 3, "n1", "n2")],
  };
  const done = await assign(update, { traversed: (n) => traversed.push(n.nodeId) });
  const s = done.state;
  report("order_update", !done.byCancelation && s.lastNodeId === "n2" && s.orderUpdateId === 1,
    JSON.stringify({ done, traversed }));
  const reached = Math.hypot(s.agvPosition.x - (p.x + 1.5), s.agvPosition.y - (p.y + 0.5));
  report("three_nodes_driven", reached < 0.5, `${reached.toFixed(2)} m from n2`);

  // a second order, cancelled on its way
  const back = {
    orderId: mc.createUuid(), orderUpdateId: 0,
    nodes: [node("m0", 0, s.agvPosition.x, s.agvPosition.y, map),
      node("m1", 2, p.x, p.y, map)],
    edges: [edge("m01", 1, "m0", "m1")],
  };
  const cancelled = assign(back);
  cancelled.catch(() => {}); // awaited below; a rejection is reported there
  await waitState((st) => st.orderId === back.orderId && st.driving, "driving back");
  await instant("cancelOrder");
  const end = await cancelled;
  report("cancel", end.byCancelation === true && end.state.nodeStates.length === 0,
    JSON.stringify(end));

  // initPosition where the robot stands
  const here = (await waitState((st) => !st.driving, "stopped")).agvPosition;
  await instant("initPosition", [
    { key: "x", value: here.x }, { key: "y", value: here.y }, { key: "theta", value: here.theta },
    { key: "mapId", value: map }, { key: "lastNodeId", value: "m0" }]);
  const after = await waitState((st) => st.lastNodeId === "m0", "lastNodeId from initPosition");
  report("init_position", after.agvPosition.positionInitialized === true, JSON.stringify(after.agvPosition));
  await instant("factsheetRequest");
  await instant("stateRequest");
} catch (err) {
  report("run", false, err.stack || String(err));
}
report("no_validation_error", drops === 0, `${drops} messages dropped by the library's validation`);
report("read_every_topic", counts.state > 5 && counts.connection >= 1 && counts.factsheet >= 1 &&
  counts.visualization >= 1, JSON.stringify(counts));
console.log(`counts ${JSON.stringify(counts)}`);
await mc.stop();
process.exit(results.every(Boolean) ? 0 : 1);
