"""Issue 47's matrix with the fourth client: roslibjs (the console's roslib, loaded by the
console's own page) in a real Chromium, its token in the WebSocket URL (``?token=``). Every
role against every op kind of the rosbridge matrix (tests/session/test_access_matrix.py),
each cell allowed or refused as the role table says, a refusal naming the role."""

from __future__ import annotations

from hitrobot_server.state.tokens import add_token
from tests.session.test_access_matrix import CELLS, REFUSALS, ROLES, assert_cell

# Per role: connect with its token, send each cell's op with an id of its own, and wait for a
# round trip (a whoami call, answered after the op: ops are handled in order) before the next.
MATRIX_JS = """
async ({ port, tokens, cells, refusals }) => {
  const bounded = (promise, what) => Promise.race([promise, new Promise((_, fail) =>
    setTimeout(() => fail(new Error(`no ${what} within 10 s`)), 10000))]);
  const out = {};
  for (const [role, token] of Object.entries(tokens)) {
    const url = `ws://127.0.0.1:${port}/?token=${encodeURIComponent(token)}`;
    const ros = new ROSLIB.Ros({ url });
    await bounded(new Promise((ok, fail) => { ros.on('connection', ok); ros.on('error', fail); }),
      `connection for ${role}`);
    const whoami = new ROSLIB.Service({
      ros, name: '/hitrobot/whoami', serviceType: 'std_srvs/Trigger' });
    const got = {};
    for (const [name, op] of Object.entries(cells)) {
      const id = `cell:${role}:${name}`;
      got[name] = [];
      ros.on(`status:${id}`, (s) => {
        const refusal = refusals.some((r) => String(s.msg).includes(r));
        if (s.level === 'error' && refusal) got[name].push(s.msg);
      });
      ros.callOnConnection({ ...op, id });
      await bounded(new Promise((ok, fail) => whoami.callService({}, ok, fail)),
        `round trip for ${name}`);
    }
    out[role] = got;
    ros.close();
  }
  return out;
}
"""


async def test_roslibjs_in_chromium(make_server, browser, tmp_path):
    tokens_file = tmp_path / "tokens.json"
    tokens = {role: add_token(tokens_file, f"{role}-js", role, None) for role in ROLES}
    server = await make_server(robot="sim", authenticate=True, tokens_file=str(tokens_file))
    page = browser.pages[0] if browser.pages else await browser.new_page()
    await page.goto(f"http://127.0.0.1:{server.port}/")  # the console's files: served to all
    await page.wait_for_function("typeof ROSLIB !== 'undefined'", timeout=30_000)
    cells = {name: op for name, (_allowed, op) in CELLS.items()}
    results = await page.evaluate(MATRIX_JS, {"port": server.port, "tokens": tokens,
                                              "cells": cells, "refusals": list(REFUSALS)})
    for role in ROLES:
        for cell, (allowed, _op) in CELLS.items():
            assert_cell(role, cell, allowed, results[role][cell])
